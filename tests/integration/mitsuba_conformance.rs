//! Conformance with Mitsuba 3: small Mitsuba scenes (`tests/conformance/`)
//! rendered by both renderers and compared statistically.
//!
//! Together the scenes cover every sensor (perspective, thinlens), shape
//! (obj, ply, sphere, rectangle, cube, disk, cylinder, shapegroup and
//! instance), BSDF (diffuse,
//! conductor with material none and a named metal, roughconductor GGX and
//! Beckmann, dielectric, thindielectric, roughdielectric, plastic,
//! roughplastic, twosided with one and two BSDFs, mask, blendbsdf,
//! normalmap, bumpmap, principled, pplastic, polarizer, null), medium
//! (homogeneous, with isotropic and hg phase functions and constvolume
//! values, rendered by volpath), texture (checkerboard, mesh_attribute,
//! bitmap) and emitter (envmap, constant, area (also textured), point, spot, projector,
//! directional) that
//! lente reads from Mitsuba files.
//!
//! # The statistic
//!
//! Mitsuba (variant `scalar_rgb`, driven by `conformance/mitsuba_render.py`)
//! renders each scene K times with independent seeds; lente renders it K
//! times too. Per pixel and channel that gives a mean and the variance of
//! that mean (sample variance / K) for each renderer. The film uses a box
//! filter, so pixels are independent within a render. For every 8 x 8 block
//! and channel,
//!
//! ```text
//! z = (mean_lente - mean_mitsuba) / sqrt(var_lente + var_mitsuba)
//! ```
//!
//! of the block means (the variance of a block mean is the sum of its
//! pixels' variances / 64^2: 64 (K - 1) degrees of freedom, so z is close to
//! normal; a relative rounding floor of 1e-4 is added, see [`ROUNDING`]).
//! If both renderers estimate the same image, every z is a standard
//! normal draw; the check fails if any |z| over all blocks, channels and
//! scenes exceeds the two-sided normal quantile at the Sidak-corrected
//! level 1 - (1 - 0.01)^(1/m) (m tests in all): a false alarm rate of 1%
//! for the whole check.
//!
//! Environment maps: Mitsuba 3.9.1's `envmap` (`emitters/envmap.cpp`,
//! `eval_spectrum`) puts image row j at v = j / (H - 1), rows 0 and H - 1 on
//! the poles, where lente's own convention centres it at (j + 0.5) / H; the
//! Mitsuba reader builds maps with Mitsuba's rows
//! ([`TexelRows::PoleToPole`](lente::emitter::TexelRows)).
//! `env_elevation.xml` shows it with a sky that varies with the elevation
//! (built with lente's rows instead, its blocks differ from Mitsuba's by |z| up to 967); the other
//! maps (`stripes.pfm`) vary with the azimuth only.
//!
//! Every comparison must be able to fail: each scene's lente estimate,
//! scaled by 1.05, must be rejected by the same threshold in the blocks
//! whose sampling noise is at least the rounding floor (where a sky is seen
//! directly, the floor alone rejects any scaling, which says nothing about
//! the shaded parts), and so must a
//! render of `area_box.xml` whose gold sphere has roughness 0.35 instead of
//! 0.25.
//!
//! # Configurations left out, and why
//!
//! - **`sample_visible = false` on rough dielectrics.** Mitsuba's
//!   roughdielectric then samples normals from a widened distribution
//!   (alpha times 1.2 - 0.2 sqrt|cos theta_i|, Walter et al.'s trick) but
//!   weights the sample as if drawn from the unwidened one (G (wi.m) /
//!   (cos theta_i cos theta_m)): its BSDF-sampling estimator is biased,
//!   lente's is not. In `glass_constant.xml` the difference stays below
//!   what 256 spp x 16 renders resolve (max |z| 2.6 with alpha 0.6), but it
//!   is not Mitsuba's reference behaviour, so only visible-normal sampling
//!   (the default) is compared.
//! - **Spectral data, media**: lente reads neither; RGB values and
//!   `scalar_rgb` only.
//! - **Caustics of small lights**: a unidirectional path tracer finds them
//!   by BSDF sampling alone, so their estimates are heavy-tailed and the
//!   normal approximation of z fails; the glass here is lit by a constant
//!   emitter, the metals by large emitters.
//!
//! # Running it
//!
//! The test needs a Python with the `mitsuba` wheel (3.x): it takes the
//! interpreter from `LENTE_MITSUBA_PYTHON`, else `target/mitsuba-venv`
//! (what `.ci/run` creates), else `python3`. Without one it prints why and
//! passes, unless `CI` is set: then it fails. `LENTE_CONFORMANCE_OUT=dir`
//! also writes both renderers' mean images there (EXR and PNG); for a
//! closer look by hand, `LENTE_CONFORMANCE_ONLY=area_box` runs the scenes
//! whose names contain that text and `LENTE_CONFORMANCE_SPP=1024` changes
//! the samples per pixel of every render (the power checks then still
//! apply, the threshold to the scenes run).

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use lente::color::Rgb;
use lente::image::io::{load_image, save_image};
use lente::image::Bitmap;
use lente::load::load_scene_with;
use lente::render::{render, RenderOptions};
use lente::scene::Scene;
use statrs::distribution::{ContinuousCDF, Normal};

/// Edge of the square blocks whose means are compared.
const BLOCK: usize = 8;

/// False-alarm rate of the whole check.
const ALPHA: f64 = 0.01;

/// Relative difference that counts as rounding: its square (times the
/// block mean squared) is added to the variance of every difference. Blocks
/// that see a smooth environment directly have almost no sampling noise
/// (at 512 spp the standard error of a sky block is ~1e-7 of its value),
/// and there two float32 renderers legitimately differ by ~1e-6 (a
/// different order of operations in the ray direction and the bilinear
/// lookup): without this floor such blocks would fail on rounding alone.
/// 1e-4 keeps the check blind only to biases below 0.01% in those blocks.
const ROUNDING: f64 = 1e-4;

/// The scaling every comparison must detect.
const PERTURBATION: f64 = 1.05;

#[derive(Clone, Copy)]
struct Case {
    file: &'static str,
    covers: &'static str,
    /// Samples per pixel of each render: enough that lente x1.05 is
    /// rejected in the blocks with sampling noise with a wide margin (at
    /// 32 spp the least of those z was 8.2, in media.xml, and the next
    /// 12.8; z grows as the square root of the spp), and no more, since
    /// this check is the longest part of the test suite.
    spp: u32,
    /// Independent renders per renderer (K).
    renders: u32,
}

const CASES: &[Case] = &[
    Case {
        file: "area_box.xml",
        covers: "perspective; area; rectangle, cube, sphere; diffuse, plastic, roughconductor GGX (Au)",
        spp: 64,
        renders: 16,
    },
    Case {
        file: "env_metals.xml",
        covers: "perspective; envmap (rotated); disk, sphere; conductor none, conductor Cu, anisotropic roughconductor Beckmann (Al, sphere) and GGX (Ag, disk)",
        spp: 64,
        renders: 16,
    },
    Case {
        file: "glass_constant.xml",
        covers: "perspective; constant; cube, rectangle, sphere; dielectric, thindielectric, roughdielectric GGX",
        spp: 64,
        renders: 16,
    },
    Case {
        file: "delta_lights.xml",
        covers: "perspective; point, directional; obj, ply, serialized, cylinder, rectangle; roughplastic, plastic, twosided (1 and 2 BSDFs)",
        spp: 64,
        renders: 16,
    },
    Case {
        file: "env_elevation.xml",
        covers: "envmap varying with the elevation (Mitsuba's pole-to-pole rows), seen directly; sphere, rectangle; diffuse, roughconductor GGX (Al)",
        spp: 64,
        renders: 16,
    },
    Case {
        file: "bumpmap.xml",
        covers: "bumpmap: a raw greyscale bitmap's bilinear slopes over roughplastic on a rectangle and over diffuse on a sphere (to_uv scaled), named arbitrarily; area, point and constant lights",
        spp: 64,
        renders: 16,
    },
    Case {
        file: "blend_normalmap.xml",
        covers: "blendbsdf (a bitmap weight over diffuse and roughconductor; a constant weight over roughplastic and roughconductor), normalmap (a raw bitmap, bilinear and nearest, over roughplastic on a rectangle and inside twosided over diffuse on a sphere); point and area lights",
        spp: 64,
        renders: 16,
    },
    Case {
        file: "mask.xml",
        covers: "mask: a bitmap opacity over twosided diffuse before an area light, constant opacity over a checkerboard diffuse and over a roughconductor (an RGB opacity: its channel mean, as Mitsuba's eval_1)",
        spp: 64,
        renders: 16,
    },
    Case {
        file: "mesh_attribute.xml",
        covers: "mesh_attribute: a PLY's per-vertex float r g b (vertex_color, interpolated) as a diffuse reflectance, plain and scaled, and its per-face weight_0 (face_weight) as a blendbsdf weight; directional and constant lights",
        spp: 64,
        renders: 16,
    },
    Case {
        file: "orthographic.xml",
        covers: "orthographic: a scaled sensor plane (scale then lookat), near_clip; directional, constant; rectangle, sphere, cube; diffuse, roughplastic",
        spp: 64,
        renders: 16,
    },
    Case {
        file: "spot.xml",
        covers: "spot: beam width and cutoff (the linear falloff), Mitsuba's default beam width with a projected sRGB bitmap, tilted; diffuse, roughconductor",
        spp: 64,
        renders: 16,
    },
    Case {
        file: "projector.xml",
        covers: "projector: a 2:1 sRGB bitmap with fov and scale, tilted; a constant irradiance with the default focal length; diffuse, roughconductor",
        spp: 64,
        renders: 16,
    },
    Case {
        file: "instancing.xml",
        covers: "shapegroup and instance: a group of an OBJ (roughconductor), a sphere (checkerboard uvs) and a rectangle (bumpmap over roughplastic) placed as it is, rotated and scaled unevenly, and mirrored; area, point and constant lights",
        spp: 64,
        renders: 16,
    },
    Case {
        file: "curves.xml",
        covers: "linearcurve (two polylines with changing radii, to_world rotated and scaled, checkerboard on the curves' uv) and bsplinecurve (a wave in an anisotropic roughconductor, which reads dp/du; an arc in a shapegroup placed twice, once scaled unevenly); area, point and constant lights",
        spp: 64,
        renders: 16,
    },
    Case {
        file: "media.xml",
        covers: "volpath with homogeneous media: the camera in a fog (a sensor medium, every boundary's exterior); a null sphere of chromatic hg medium with scale; absorbing-only medium in a smooth dielectric; thindielectric cube with sample_emitters off; roughdielectric sphere with a constvolume albedo and backward hg; shadow rays through a checkerboard mask; area and point lights in the fog",
        spp: 128,
        renders: 16,
    },
    Case {
        file: "hetero.xml",
        covers: "volpath with heterogeneous media and grid volumes: a null box of smoke from a one-channel .vol placed by its own box (use_grid_bbox) under scale, trilinear, with a three-channel albedo grid (nearest, repeat) and forward hg; a dielectric sphere holding a chromatic extinction grid whose box is smaller than the sphere; a homogeneous medium with a mirrored albedo grid; area, point and constant lights",
        spp: 64,
        renders: 16,
    },
    Case {
        file: "principled_thin.xml",
        covers: "principledthin: sheets in front of an area light, so light passes through them: defaults (diffuse only); spec_trans with eta, spec_tint and a checkerboard base_color; diff_trans with sheen, sheen_tint and flatness; anisotropic spec_trans with a textured roughness and a doubled specular_reflectance_sampling_rate; a sphere of it (both sides); area, point and constant lights",
        spp: 64,
        renders: 16,
    },
    Case {
        file: "rayleigh_lanczos.xml",
        covers: "the rayleigh phase function (a null sphere, a chromatic homogeneous box) under volpath, and a lanczos reconstruction filter of 2 lobes over a sharp checkerboard floor; point and constant lights",
        spp: 64,
        renders: 16,
    },
    Case {
        file: "pplastic.xml",
        covers: "pplastic: defaults (Beckmann) with a checkerboard diffuse reflectance, anisotropic GGX with int_ior by name and a tinted specular reflectance, eta with sample_visible off; area, point and constant lights",
        spp: 64,
        renders: 16,
    },
    Case {
        file: "polarizer.xml",
        covers: "polarizer (RGB: half the light passes whatever theta): crossed pair, tinted transmittance; shadow rays blocked; area, point and constant lights",
        spp: 64,
        renders: 16,
    },
    Case {
        file: "principled.xml",
        covers: "principled: a checkerboard base colour with metallic and spec_tint; sheen, sheen_tint and flatness; clearcoat with gloss and specular; anisotropic with a textured metallic; spec_trans with eta; area, point and constant lights",
        spp: 64,
        renders: 16,
    },
    Case {
        file: "spectra.xml",
        covers: "spectra in RGB mode: wavelength:value lists as a reflectance, an area light's radiance and a roughconductor's eta/k; a .spd file; uniform spectra as a constant emitter's radiance and a plastic's reflectance",
        spp: 64,
        renders: 16,
    },
    Case {
        file: "textured_area.xml",
        covers: "area lights with texture radiance: an sRGB bitmap with to_uv on a rectangle, a checkerboard on a sphere, seen directly and through diffuse and roughconductor",
        spp: 64,
        renders: 16,
    },
    Case {
        file: "textures.xml",
        covers: "textures: checkerboard (to_uv; reflectance, specular_reflectance, inside twosided), bitmap (sRGB PNG, bilinear/nearest, repeat/mirror, to_uv, raw roughness); sphere and PLY uvs",
        spp: 64,
        renders: 16,
    },
    Case {
        file: "thinlens_env.xml",
        covers: "thinlens; envmap; rectangle, sphere; diffuse, conductor, plastic",
        spp: 64,
        renders: 16,
    },
];

/// Per-pixel means and variances of the means, RGB, row-major.
pub(crate) struct Estimate {
    width: usize,
    height: usize,
    mean: Vec<[f64; 3]>,
    var: Vec<[f64; 3]>,
}

impl Estimate {
    /// The estimate from `n` independent renders (`render(k)`, k in 0..n)
    /// of a `w` x `h` image.
    pub(crate) fn from_renders(
        w: usize,
        h: usize,
        n: usize,
        mut render: impl FnMut(usize) -> Bitmap,
    ) -> Estimate {
        let mut mean = vec![[0.0f64; 3]; w * h];
        let mut m2 = vec![[0.0f64; 3]; w * h];
        for k in 0..n {
            let img = render(k);
            for (i, px) in pixels(&img).iter().enumerate() {
                for c in 0..3 {
                    // Welford.
                    let d = px[c] - mean[i][c];
                    mean[i][c] += d / (k + 1) as f64;
                    m2[i][c] += d * (px[c] - mean[i][c]);
                }
            }
        }
        let var = m2
            .iter()
            .map(|m| m.map(|x| x / ((n - 1) * n) as f64))
            .collect();
        Estimate {
            width: w,
            height: h,
            mean,
            var,
        }
    }

    pub(crate) fn scaled(&self, s: f64) -> Estimate {
        Estimate {
            width: self.width,
            height: self.height,
            mean: self.mean.iter().map(|m| m.map(|x| x * s)).collect(),
            var: self.var.iter().map(|v| v.map(|x| x * s * s)).collect(),
        }
    }

    pub(crate) fn mean_image(&self) -> Bitmap {
        let mut b = Bitmap::new(self.width, self.height);
        for y in 0..self.height {
            for x in 0..self.width {
                let m = self.mean[y * self.width + x];
                b.set(x, y, Rgb::new(m[0] as f32, m[1] as f32, m[2] as f32));
            }
        }
        b
    }
}

fn conformance_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/conformance")
}

/// The Python to run Mitsuba with, and its version; Err says why none.
pub fn mitsuba_python() -> Result<(String, String), String> {
    let venv = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/mitsuba-venv/bin/python");
    let python = match std::env::var("LENTE_MITSUBA_PYTHON") {
        Ok(p) if !p.trim().is_empty() => p,
        _ if venv.exists() => venv.to_string_lossy().into_owned(),
        _ => "python3".to_string(),
    };
    let out = Command::new(&python)
        .args(["-c", "import mitsuba; print(mitsuba.__version__)"])
        .output()
        .map_err(|e| format!("cannot run {python}: {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "{python} cannot import mitsuba: {}",
            String::from_utf8_lossy(&out.stderr).trim()
        ));
    }
    let version = String::from_utf8_lossy(&out.stdout).trim().to_string();
    if !version.starts_with("3.") {
        return Err(format!("{python} has mitsuba {version}, not 3.x"));
    }
    Ok((python, version))
}

fn pixels(b: &Bitmap) -> Vec<[f64; 3]> {
    (0..b.height)
        .flat_map(|y| (0..b.width).map(move |x| (x, y)))
        .map(|(x, y)| {
            let c = b.get(x, y);
            [c.x as f64, c.y as f64, c.z as f64]
        })
        .collect()
}

/// Mitsuba's estimate: `renders` renders of `spp` samples, seeds 1, 3, ...
fn mitsuba_estimate(python: &str, case: &Case, out: &Path) -> Estimate {
    let prefix = out.join(case.file.trim_end_matches(".xml"));
    let run = Command::new(python)
        .arg(conformance_dir().join("mitsuba_render.py"))
        .arg(conformance_dir().join(case.file))
        .args(["--spp", &case.spp.to_string()])
        .args(["--renders", &case.renders.to_string()])
        .arg("--out")
        .arg(&prefix)
        .output()
        .expect("run the Mitsuba driver");
    assert!(
        run.status.success(),
        "Mitsuba failed on {}:\n{}\n{}",
        case.file,
        String::from_utf8_lossy(&run.stdout),
        String::from_utf8_lossy(&run.stderr)
    );
    let load = |suffix: &str| {
        let p = PathBuf::from(format!("{}-{suffix}.pfm", prefix.display()));
        load_image(&p)
            .unwrap_or_else(|e| panic!("{}: {e}", p.display()))
            .0
    };
    let (mean, var) = (load("mean"), load("var"));
    assert_eq!((mean.width, mean.height), (var.width, var.height));
    Estimate {
        width: mean.width,
        height: mean.height,
        mean: pixels(&mean),
        var: pixels(&var),
    }
}

/// lente's estimate of the same file: `renders` renders with seeds 1..=K.
fn lente_estimate(case: &Case, defines: &[(&str, &str)]) -> Estimate {
    let mut defs: Vec<(String, String)> = vec![("spp".into(), case.spp.to_string())];
    defs.extend(defines.iter().map(|(a, b)| (a.to_string(), b.to_string())));
    let path = conformance_dir().join(case.file);
    let (desc, warnings) = load_scene_with(&path, &defs).unwrap_or_else(|e| panic!("{e}"));
    // Nothing may be approximated.
    assert!(warnings.is_empty(), "{}: {warnings:?}", case.file);
    let scene = Scene::new(desc.scene).unwrap_or_else(|e| panic!("{}: {e}", case.file));
    assert_eq!(desc.job.spp, case.spp, "{}", case.file);
    let (w, h) = (
        scene.camera.width() as usize,
        scene.camera.height() as usize,
    );
    Estimate::from_renders(w, h, case.renders as usize, |k| {
        let opts = RenderOptions::new(k as u64 + 1);
        render(&scene, &desc.job, &opts, &AtomicBool::new(false)).image
    })
}

/// Block z-scores (per block and channel) and summary figures.
pub(crate) struct Comparison {
    pub(crate) z: Vec<f64>,
    blocks: usize,
    pub(crate) max_abs_z: f64,
    /// max |z| over the blocks whose sampling noise is at least the
    /// rounding floor: a sky seen directly has almost none, so there any
    /// change of 0.01% or more stands out, and only these blocks say what
    /// the comparison can see in the shaded parts of the image.
    pub(crate) max_abs_z_sampled: f64,
    /// sum |block mean difference| / sum of Mitsuba's block means.
    mean_rel_diff: f64,
    /// (sum of lente's means - sum of Mitsuba's) / sum of Mitsuba's.
    overall_rel_diff: f64,
}

pub(crate) fn compare(a: &Estimate, b: &Estimate) -> Comparison {
    assert_eq!((a.width, a.height), (b.width, b.height), "image sizes");
    let (bw, bh) = (a.width.div_ceil(BLOCK), a.height.div_ceil(BLOCK));
    let mut z = Vec::new();
    let mut max_abs_z_sampled = 0.0f64;
    let (mut abs_diff, mut sum_a, mut sum_b) = (0.0, 0.0, 0.0);
    for by in 0..bh {
        for bx in 0..bw {
            let mut s = [[0.0f64; 4]; 3]; // per channel: mean a, mean b, var a, var b
            let mut count = 0.0;
            for y in by * BLOCK..((by + 1) * BLOCK).min(a.height) {
                for x in bx * BLOCK..((bx + 1) * BLOCK).min(a.width) {
                    let i = y * a.width + x;
                    for (c, sc) in s.iter_mut().enumerate() {
                        sc[0] += a.mean[i][c];
                        sc[1] += b.mean[i][c];
                        sc[2] += a.var[i][c];
                        sc[3] += b.var[i][c];
                    }
                    count += 1.0;
                }
            }
            for sc in &s {
                let (ma, mb) = (sc[0] / count, sc[1] / count);
                // Rounding: see ROUNDING.
                let floor = ROUNDING * ma.abs().max(mb.abs());
                let sampling_var = (sc[2] + sc[3]) / (count * count);
                let var = sampling_var + floor * floor;
                let d = ma - mb;
                let zi = if var > 0.0 {
                    d / var.sqrt()
                } else if d == 0.0 {
                    0.0
                } else {
                    f64::INFINITY
                };
                if sampling_var > 0.0 && sampling_var >= floor * floor {
                    max_abs_z_sampled = max_abs_z_sampled.max(zi.abs());
                }
                z.push(zi);
                abs_diff += d.abs();
                sum_a += ma;
                sum_b += mb;
            }
        }
    }
    let max_abs_z = z.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    Comparison {
        blocks: bw * bh,
        max_abs_z,
        max_abs_z_sampled,
        mean_rel_diff: abs_diff / sum_b,
        overall_rel_diff: (sum_a - sum_b) / sum_b,
        z,
    }
}

/// The two-sided normal threshold for `m` tests at overall level ALPHA.
pub(crate) fn sidak_threshold(m: usize) -> f64 {
    let per_test = 1.0 - (1.0 - ALPHA).powf(1.0 / m as f64);
    Normal::standard().inverse_cdf(1.0 - per_test / 2.0)
}

fn save_pair(dir: &Path, name: &str, lente: &Estimate, mitsuba: &Estimate) {
    std::fs::create_dir_all(dir).expect("create LENTE_CONFORMANCE_OUT");
    for (who, e) in [("lente", lente), ("mitsuba", mitsuba)] {
        for ext in ["exr", "png"] {
            let p = dir.join(format!("{name}-{who}.{ext}"));
            save_image(&p, &e.mean_image()).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
        }
    }
}

#[test]
fn lente_matches_mitsuba_3() {
    let (python, version) = match mitsuba_python() {
        Ok(p) => p,
        Err(why) => {
            if std::env::var_os("CI").is_some() {
                panic!(
                    "CI is set but Mitsuba 3 is not available ({why}); .ci/run installs it \
                     into target/mitsuba-venv"
                );
            }
            println!("skipping the Mitsuba conformance check: {why}");
            println!("(set LENTE_MITSUBA_PYTHON to a Python with `pip install mitsuba==3.9.1`)");
            return;
        }
    };
    let start = Instant::now();
    let out_dir = tempfile::Builder::new()
        .prefix("lente-conformance-")
        .tempdir()
        .unwrap();
    let out = out_dir.path().to_path_buf();
    let keep = std::env::var_os("LENTE_CONFORMANCE_OUT").map(PathBuf::from);

    let only = std::env::var("LENTE_CONFORMANCE_ONLY").unwrap_or_default();
    let spp: Option<u32> = std::env::var("LENTE_CONFORMANCE_SPP")
        .ok()
        .and_then(|s| s.parse().ok());
    let cases: Vec<Case> = CASES
        .iter()
        .filter(|c| c.file.contains(only.as_str()))
        .map(|c| Case {
            spp: spp.unwrap_or(c.spp),
            ..*c
        })
        .collect();
    let mut results = Vec::new();
    let (mut t_mitsuba, mut t_lente) = (0.0, 0.0);
    for case in &cases {
        let t = Instant::now();
        let reference = mitsuba_estimate(&python, case, &out);
        t_mitsuba += t.elapsed().as_secs_f64();
        let t = Instant::now();
        let ours = lente_estimate(case, &[]);
        t_lente += t.elapsed().as_secs_f64();
        if let Some(dir) = &keep {
            save_pair(dir, case.file.trim_end_matches(".xml"), &ours, &reference);
        }
        results.push((case, reference, ours));
    }
    // The roughness change the comparison of area_box must notice.
    let t = Instant::now();
    let rougher = results
        .iter()
        .find(|r| r.0.file == "area_box.xml")
        .map(|(case, reference, _)| (lente_estimate(case, &[("gold_alpha", "0.35")]), reference));
    t_lente += t.elapsed().as_secs_f64();

    assert!(
        !results.is_empty(),
        "no scene matches LENTE_CONFORMANCE_ONLY={only}"
    );
    let comparisons: Vec<Comparison> = results.iter().map(|(_, r, o)| compare(o, r)).collect();
    let m: usize = comparisons.iter().map(|c| c.z.len()).sum();
    let threshold = sidak_threshold(m);

    println!(
        "lente vs Mitsuba {version}: {BLOCK}x{BLOCK} blocks x 3 channels, {m} tests, \
         Sidak threshold |z| <= {threshold:.3} (alpha {ALPHA})"
    );
    println!(
        "| scene | covers | spp x renders | blocks | max abs z | mean rel. diff | overall | max abs z x{PERTURBATION} | in sampled blocks |"
    );
    println!("| --- | --- | --- | --- | --- | --- | --- | --- | --- |");
    let mut failures = Vec::new();
    for ((case, reference, ours), c) in results.iter().zip(&comparisons) {
        let perturbed = compare(&ours.scaled(PERTURBATION), reference);
        println!(
            "| {} | {} | {} x {} | {} | {:.2} | {:.2}% | {:+.2}% | {:.1} | {:.1} |",
            case.file,
            case.covers,
            case.spp,
            case.renders,
            c.blocks,
            c.max_abs_z,
            100.0 * c.mean_rel_diff,
            100.0 * c.overall_rel_diff,
            perturbed.max_abs_z,
            perturbed.max_abs_z_sampled
        );
        if c.max_abs_z > threshold {
            let worst =
                c.z.iter()
                    .enumerate()
                    .max_by(|a, b| a.1.abs().total_cmp(&b.1.abs()))
                    .map(|(i, z)| {
                        let (block, ch) = (i / 3, i % 3);
                        let bw = reference.width.div_ceil(BLOCK);
                        format!(
                            "block ({}, {}) channel {} z = {z:.2}",
                            BLOCK * (block % bw),
                            BLOCK * (block / bw),
                            ["R", "G", "B"][ch]
                        )
                    })
                    .unwrap_or_default();
            failures.push(format!(
                "{}: max |z| {:.2} > {threshold:.2} (worst: pixel {worst})",
                case.file, c.max_abs_z
            ));
        }
        // Rejected where the image has sampling noise, not only where a
        // noiseless sky meets the rounding floor.
        if perturbed.max_abs_z_sampled <= threshold {
            failures.push(format!(
                "{}: lente x{PERTURBATION} is not rejected in the blocks with sampling noise \
                 (max |z| {:.2} there): the comparison has no power",
                case.file, perturbed.max_abs_z_sampled
            ));
        }
    }
    if let Some((rougher, reference)) = rougher {
        let rough = compare(&rougher, reference);
        println!(
            "area_box.xml with the gold sphere's alpha 0.35 instead of 0.25: max |z| {:.1} \
             (must exceed {threshold:.2})",
            rough.max_abs_z
        );
        if rough.max_abs_z <= threshold {
            failures.push(format!(
                "area_box.xml with alpha 0.35 is not rejected (max |z| {:.2})",
                rough.max_abs_z
            ));
        }
    }
    println!(
        "time: Mitsuba {t_mitsuba:.1} s, lente {t_lente:.1} s, total {:.1} s",
        start.elapsed().as_secs_f64()
    );
    let _ = std::fs::remove_dir_all(&out);
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
