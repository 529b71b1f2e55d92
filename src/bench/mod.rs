//! `lente bench`: samples per second on a fixed suite of Mitsuba 3 scenes
//! kept in the repository (bench/speed/), per core and in total, beside
//! Mitsuba 3's `scalar_rgb` and `llvm_ad_rgb` on the same files in the same
//! run when a Python with the mitsuba wheel is at hand; and rays per second
//! of closest-hit and any-hit queries on a mesh of 102,400 triangles,
//! beside Embree 3's on the same mesh and rays where its library is
//! installed ([`embree`]).
//!
//! Renders are timed without loading (both renderers), best of a few runs
//! with different seeds; Mitsuba warm (its kernel compilation is timed
//! apart by scripts/mitsuba_bench.py).

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use rayon::prelude::*;

use crate::geometry::{Bvh, Geometry};
use crate::load::{load_scene_with, SceneError};
use crate::math::Ray;
use crate::render::{render, RenderJob, RenderOptions};
use crate::sampling::{warp, Sampler};
use crate::scene::{BuildError, Scene};

pub mod embree;
pub mod machine;

/// One scene of the suite: a file relative to the repository root and the
/// Mitsuba `$parameters` it is rendered with.
#[derive(Clone, Copy, Debug)]
pub struct SuiteScene {
    pub name: &'static str,
    pub file: &'static str,
    pub params: &'static [(&'static str, &'static str)],
}

/// The speed suite: env-lit spheres, a thin lens, mirror and glass on a
/// stand, a Cornell box of rectangles, a 100k-triangle mesh, rough metals,
/// a constant-lit cube, and Veach's MIS scene (area lights, glossy plates).
pub const SUITE: &[SuiteScene] = &[
    SuiteScene {
        name: "env_spheres",
        file: "bench/speed/env_spheres.xml",
        params: &[],
    },
    SuiteScene {
        name: "thinlens",
        file: "bench/speed/thinlens.xml",
        params: &[],
    },
    SuiteScene {
        name: "mirror_stand",
        file: "bench/speed/mirror_stand.xml",
        params: &[],
    },
    SuiteScene {
        name: "glass_stand",
        file: "bench/speed/glass_stand.xml",
        params: &[],
    },
    SuiteScene {
        name: "cbox",
        file: "scenes/mitsuba/cbox.xml",
        params: &[("res", "128")],
    },
    SuiteScene {
        name: "blob_mesh",
        file: "bench/speed/blob_mesh.xml",
        params: &[],
    },
    SuiteScene {
        name: "rough_conductor",
        file: "bench/speed/rough_conductor.xml",
        params: &[],
    },
    SuiteScene {
        name: "constant_cube",
        file: "bench/speed/constant_cube.xml",
        params: &[],
    },
    SuiteScene {
        name: "veach_mis",
        file: "bench/lights/veach_mis.xml",
        params: &[("width", "192"), ("height", "128")],
    },
];

/// The suite scene whose mesh the ray-query figures use.
pub const RAY_SCENE: &str = "bench/speed/blob_mesh.xml";

/// What to measure.
#[derive(Clone, Debug)]
pub struct BenchOptions {
    /// The repository root (the suite's paths are relative to it).
    pub root: PathBuf,
    pub spp: u32,
    /// Thread counts to measure at.
    pub threads: Vec<usize>,
    /// Timed renders per scene and thread count (the fastest counts).
    pub repeat: u32,
    /// Scene names (empty: all).
    pub only: Vec<String>,
    /// A Python with the mitsuba wheel, or None to skip Mitsuba.
    pub mitsuba_python: Option<PathBuf>,
    /// Embree 3's library (a path, or a name for the system's loader).
    pub embree_library: PathBuf,
    /// Only the ray queries, no renders.
    pub rays_only: bool,
}

/// Why the benchmark could not run.
#[derive(Debug, thiserror::Error)]
pub enum BenchError {
    #[error("{0}")]
    Load(#[from] SceneError),
    #[error("{file}: {source}")]
    Build { file: String, source: BuildError },
    #[error("cannot start the worker threads: {0}")]
    Pool(#[from] rayon::ThreadPoolBuildError),
    #[error("unknown suite scene '{0}' (known: {1})")]
    UnknownScene(String, String),
}

/// Samples per second of one renderer on one scene at one thread count.
#[derive(Clone, Copy, Debug)]
pub struct Timing {
    pub samples: u64,
    pub seconds: f64,
    pub threads: usize,
}

impl Timing {
    pub fn per_second(&self) -> f64 {
        self.samples as f64 / self.seconds.max(1e-12)
    }
    pub fn per_core(&self) -> f64 {
        self.per_second() / self.threads as f64
    }
}

/// The suite scenes selected by `only` (all if empty).
pub fn selected(only: &[String]) -> Result<Vec<SuiteScene>, BenchError> {
    if only.is_empty() {
        return Ok(SUITE.to_vec());
    }
    only.iter()
        .map(|n| {
            SUITE.iter().find(|s| s.name == n).copied().ok_or_else(|| {
                let known: Vec<_> = SUITE.iter().map(|s| s.name).collect();
                BenchError::UnknownScene(n.clone(), known.join(", "))
            })
        })
        .collect()
}

/// A suite file, built, with its render job.
fn load(
    root: &Path,
    file: &str,
    params: &[(&str, &str)],
) -> Result<(Scene, RenderJob), BenchError> {
    let defines: Vec<(String, String)> = params
        .iter()
        .map(|(k, v)| (k.to_string(), v.to_string()))
        .collect();
    let (loaded, _) = load_scene_with(&root.join(file), &defines)?;
    let scene = Scene::new(loaded.scene).map_err(|source| BenchError::Build {
        file: file.to_string(),
        source,
    })?;
    Ok((scene, loaded.job))
}

/// Times lente on one suite scene: the fastest of `repeat` renders at
/// `spp` on a pool of `threads` workers.
pub fn time_lente(
    root: &Path,
    scene: &SuiteScene,
    spp: u32,
    threads: usize,
    repeat: u32,
) -> Result<Timing, BenchError> {
    let (built, mut job) = load(root, scene.file, scene.params)?;
    job.spp = spp;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()?;
    let cancel = AtomicBool::new(false);
    let mut best = f64::INFINITY;
    let mut samples = 0;
    pool.install(|| {
        for seed in 0..=repeat as u64 {
            let out = render(&built, &job, &RenderOptions::new(seed), &cancel);
            samples = out.samples;
            // Seed 0 warms caches and the pool; it is not counted.
            if seed > 0 {
                best = best.min(out.elapsed.as_secs_f64());
            }
        }
    });
    Ok(Timing {
        samples,
        seconds: best,
        threads,
    })
}

/// Closest-hit and any-hit rays per second on one mesh, one set of rays
/// and one thread count.
#[derive(Clone, Debug)]
pub struct RayFigures {
    /// Which rays: "coherent" or "incoherent".
    pub rays: &'static str,
    pub threads: usize,
    pub triangles: usize,
    pub closest: f64,
    pub any: f64,
    /// Embree 3's (closest, any) on the same mesh and rays, or why not.
    pub embree: Result<(f64, f64), String>,
    /// Rays whose closest hit Embree and lente place at different
    /// triangles and distances (a check that both answer the same queries).
    pub disagreements: usize,
}

/// The number of rays of each set.
const RAY_COUNT: usize = 1 << 20;

/// The suite's big mesh, alone (the scene's ground left out), in world
/// space.
fn ray_mesh(root: &Path) -> Result<crate::geometry::TriangleMesh, BenchError> {
    let (scene, _) = load(root, RAY_SCENE, &[])?;
    let mesh = scene
        .geometry
        .into_iter()
        .filter_map(|g| match g {
            Geometry::Mesh(m) => Some(m),
            _ => None,
        })
        .max_by_key(|m| m.triangle_count())
        .expect("the ray scene has a mesh");
    Ok(mesh)
}

/// Incoherent rays, each from its own random point on a sphere around
/// `bounds` towards a random point near its centre (almost all meet the
/// mesh): consecutive rays share no nodes, so every query waits on memory.
fn incoherent_rays(bounds: &crate::math::Aabb) -> Vec<Ray> {
    let centre = bounds.center();
    let radius = 0.5 * bounds.diagonal().length();
    let mut s = Sampler::new(7, 0);
    (0..RAY_COUNT)
        .map(|_| {
            let o = centre + warp::square_to_uniform_sphere(s.next_2d()) * radius * 1.5;
            let target = centre + warp::square_to_uniform_sphere(s.next_2d()) * radius * 0.4;
            Ray::new(o, (target - o).normalize())
        })
        .collect()
}

/// Coherent rays: a pinhole camera's 1024 x 1024 pixels in 16 x 16 tiles
/// (a render's order), framing `bounds` from a diagonal.
fn coherent_rays(bounds: &crate::math::Aabb) -> Vec<Ray> {
    let centre = bounds.center();
    let radius = 0.5 * bounds.diagonal().length();
    let eye = centre + crate::math::Vec3::new(1.0, 0.6, 1.4).normalize() * radius * 2.5;
    let forward = (centre - eye).normalize();
    let right = forward.cross(crate::math::Vec3::Y).normalize();
    let up = right.cross(forward);
    let (side, tile) = (1024usize, 16usize);
    let half = 0.5;
    let mut rays = Vec::with_capacity(RAY_COUNT);
    for ty in (0..side).step_by(tile) {
        for tx in (0..side).step_by(tile) {
            for y in ty..ty + tile {
                for x in tx..tx + tile {
                    let sx = ((x as f32 + 0.5) / side as f32 * 2.0 - 1.0) * half;
                    let sy = (1.0 - (y as f32 + 0.5) / side as f32 * 2.0) * half;
                    rays.push(Ray::new(eye, (forward + right * sx + up * sy).normalize()));
                }
            }
        }
    }
    rays
}

/// Closest-hit and any-hit rays per second on the suite's big mesh
/// (102,400 triangles) at each of `threads` worker counts, lente's and
/// Embree's, for coherent and for incoherent rays. The mesh, the rays and
/// both BVHs are built once; the hits are compared once per ray set.
pub fn ray_queries(
    root: &Path,
    threads: &[usize],
    embree_library: &Path,
) -> Result<Vec<RayFigures>, BenchError> {
    let mesh = ray_mesh(root)?;
    let sets = [
        ("coherent", coherent_rays(&mesh.bounds())),
        ("incoherent", incoherent_rays(&mesh.bounds())),
    ];
    let embree = embree::EmbreeMesh::build(embree_library, mesh.positions(), mesh.indices());
    let triangles = mesh.triangle_count();
    let bvh = Bvh::build(&[Geometry::Mesh(mesh)]);
    let disagreements: Vec<usize> = match &embree {
        Ok(e) => {
            let differ = |r: &Ray| match (bvh.intersect(r), e.intersect(r)) {
                (None, None) => false,
                (Some(a), Some((t, tri))) => a.index != tri && (a.t - t).abs() > 1e-4 * t.max(1.0),
                _ => true,
            };
            let count = |rays: &[Ray]| rays.par_iter().filter(|r| differ(r)).count();
            sets.iter().map(|(_, rays)| count(rays)).collect()
        }
        Err(_) => vec![0; sets.len()],
    };
    let mut figures = Vec::new();
    for &t in threads {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(t).build()?;
        let time = |rays: &[Ray], f: &(dyn Fn(&Ray) -> bool + Sync)| {
            pool.install(|| {
                let mut best = f64::INFINITY;
                for _ in 0..3 {
                    let t0 = Instant::now();
                    let hits = rays
                        .par_chunks(4096)
                        .map(|c| c.iter().filter(|r| f(r)).count());
                    std::hint::black_box(hits.sum::<usize>());
                    best = best.min(t0.elapsed().as_secs_f64());
                }
                rays.len() as f64 / best
            })
        };
        for ((name, rays), &disagreements) in sets.iter().zip(&disagreements) {
            let embree = match &embree {
                Ok(e) => Ok((
                    time(rays, &|r| e.intersect(r).is_some()),
                    time(rays, &|r| e.occluded(r)),
                )),
                Err(why) => Err(why.clone()),
            };
            figures.push(RayFigures {
                rays: name,
                threads: t,
                triangles,
                closest: time(rays, &|r| bvh.intersect(r).is_some()),
                any: time(rays, &|r| bvh.occluded(r)),
                embree,
                disagreements,
            });
        }
    }
    Ok(figures)
}

/// Mitsuba's timings keyed by (scene name, variant, threads).
pub type MitsubaTimings = HashMap<(String, String, usize), Timing>;

/// Mitsuba's timings from scripts/mitsuba_bench.py, keyed by (scene name,
/// variant, threads); errors (a variant that cannot start) come back as
/// notes.
pub fn time_mitsuba(
    opts: &BenchOptions,
    python: &Path,
    scenes: &[SuiteScene],
) -> (MitsubaTimings, Vec<String>) {
    let mut out = HashMap::new();
    let mut notes = Vec::new();
    let script = opts.root.join("scripts/mitsuba_bench.py");
    let threads: Vec<String> = opts.threads.iter().map(|t| t.to_string()).collect();
    let mut cmd = Command::new(python);
    cmd.arg(&script)
        .args(["--spp", &opts.spp.to_string()])
        .args(["--threads", &threads.join(",")])
        .args(["--repeat", &opts.repeat.max(1).to_string()]);
    let mut by_arg = HashMap::new();
    for s in scenes {
        let params: Vec<String> = s.params.iter().map(|(k, v)| format!("{k}={v}")).collect();
        let arg = format!("{}::{}", opts.root.join(s.file).display(), params.join(","));
        by_arg.insert(arg.clone(), s.name);
        cmd.arg(arg);
    }
    let output = match cmd.output() {
        Ok(o) => o,
        Err(e) => {
            notes.push(format!("cannot run {}: {e}", python.display()));
            return (out, notes);
        }
    };
    if !output.status.success() {
        let err = String::from_utf8_lossy(&output.stderr);
        let last = err.lines().last().unwrap_or("no message");
        notes.push(format!("Mitsuba benchmark failed: {last}"));
    }
    for line in String::from_utf8_lossy(&output.stdout).lines() {
        let Ok(v) = serde_json::from_str::<serde_json::Value>(line) else {
            continue;
        };
        let variant = v["variant"].as_str().unwrap_or("?").to_string();
        if let Some(e) = v["error"].as_str() {
            notes.push(format!("Mitsuba {variant} unavailable: {e}"));
            continue;
        }
        let (Some(arg), Some(t), Some(secs), Some(n)) = (
            v["scene"].as_str(),
            v["threads"].as_u64(),
            v["render_s"].as_f64(),
            v["samples"].as_u64(),
        ) else {
            continue;
        };
        if let Some(name) = by_arg.get(arg) {
            out.insert(
                (name.to_string(), variant, t as usize),
                Timing {
                    samples: n,
                    seconds: secs,
                    threads: t as usize,
                },
            );
        }
    }
    (out, notes)
}

/// The geometric mean of positive values (None if there are none).
pub fn geometric_mean(values: &[f64]) -> Option<f64> {
    let v: Vec<f64> = values.iter().copied().filter(|x| *x > 0.0).collect();
    if v.is_empty() {
        return None;
    }
    Some((v.iter().map(|x| x.ln()).sum::<f64>() / v.len() as f64).exp())
}

/// Runs the benchmark and prints its report on stdout (progress on
/// stderr): per scene and thread count lente's samples/s in total and per
/// core, Mitsuba's per core where measured, and lente's ratio to each;
/// then the geometric means and the ray-query figures.
pub fn run(opts: &BenchOptions) -> Result<(), BenchError> {
    println!("{}", machine::Machine::detect().describe());
    if !opts.rays_only {
        run_suite(opts)?;
    }
    print_ray_queries(opts)
}

/// The suite's renders, lente's and Mitsuba's, and their table.
fn run_suite(opts: &BenchOptions) -> Result<(), BenchError> {
    let scenes = selected(&opts.only)?;
    let mut lente = HashMap::new();
    for s in &scenes {
        for &t in &opts.threads {
            eprintln!("lente: {} on {t} thread(s)", s.name);
            lente.insert(
                (s.name, t),
                time_lente(&opts.root, s, opts.spp, t, opts.repeat)?,
            );
        }
    }
    let (mitsuba, notes) = match &opts.mitsuba_python {
        Some(py) => {
            eprintln!("Mitsuba 3: {} scene(s) via {}", scenes.len(), py.display());
            time_mitsuba(opts, py, &scenes)
        }
        None => (
            HashMap::new(),
            vec!["Mitsuba 3 not measured (no --mitsuba Python)".into()],
        ),
    };
    const VARIANTS: [(&str, &str); 2] = [("scalar_rgb", "scalar"), ("llvm_ad_rgb", "llvm")];
    println!(
        "speed suite, {} spp, best of {} renders; M samples/s (per core = total / threads)",
        opts.spp, opts.repeat
    );
    println!(
        "{:<16} {:>3} {:>9} {:>9} {:>9} {:>9} {:>9} {:>9}",
        "scene", "thr", "lente", "/core", "scalar/c", "llvm/c", "x scalar", "x llvm"
    );
    let mut ratios: HashMap<(usize, &str), Vec<f64>> = HashMap::new();
    let mut per_core: HashMap<usize, Vec<f64>> = HashMap::new();
    let m = |x: f64| x / 1e6;
    for s in &scenes {
        for &t in &opts.threads {
            let l = lente[&(s.name, t)];
            per_core.entry(t).or_default().push(l.per_core());
            let mut cols = Vec::new();
            let mut xs = Vec::new();
            for (variant, short) in VARIANTS {
                match mitsuba.get(&(s.name.to_string(), variant.to_string(), t)) {
                    Some(mt) => {
                        cols.push(format!("{:>9.3}", m(mt.per_core())));
                        let r = l.per_core() / mt.per_core();
                        ratios.entry((t, short)).or_default().push(r);
                        xs.push(format!("{r:>9.2}"));
                    }
                    None => {
                        cols.push(format!("{:>9}", "-"));
                        xs.push(format!("{:>9}", "-"));
                    }
                }
            }
            println!(
                "{:<16} {:>3} {:>9.3} {:>9.3} {} {}",
                s.name,
                t,
                m(l.per_second()),
                m(l.per_core()),
                cols.join(" "),
                xs.join(" ")
            );
        }
    }
    for &t in &opts.threads {
        let g = geometric_mean(&per_core[&t]).unwrap_or(0.0);
        let mut line = format!(
            "geometric mean, {t} thread(s): lente {:.3} M samples/s per core",
            m(g)
        );
        for (_, short) in VARIANTS {
            if let Some(r) = ratios.get(&(t, short)).and_then(|v| geometric_mean(v)) {
                line += &format!(", {r:.2}x Mitsuba {short}");
            }
        }
        println!("{line}");
    }
    for n in notes {
        println!("note: {n}");
    }
    Ok(())
}

/// The ray-query lines, one per ray set and thread count.
fn print_ray_queries(opts: &BenchOptions) -> Result<(), BenchError> {
    let m = |x: f64| x / 1e6;
    for f in ray_queries(&opts.root, &opts.threads, &opts.embree_library)? {
        let mut line = format!(
            "{} rays on {} triangles, {} thread(s): closest hit {:.2} M rays/s, any hit {:.2} M rays/s",
            f.rays,
            f.triangles,
            f.threads,
            m(f.closest),
            m(f.any)
        );
        match &f.embree {
            Ok((closest, any)) => {
                line += &format!(
                    "; Embree 3: {:.2} and {:.2} ({:.2}x, {:.2}x lente's; {} of {RAY_COUNT} closest hits differ)",
                    m(*closest),
                    m(*any),
                    closest / f.closest,
                    any / f.any,
                    f.disagreements,
                )
            }
            Err(e) => line += &format!("; Embree not measured ({e})"),
        }
        println!("{line}");
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn geometric_mean_of_ratios() {
        let g = geometric_mean(&[2.0, 8.0]).unwrap();
        assert!((g - 4.0).abs() < 1e-12);
        assert!(geometric_mean(&[]).is_none());
    }

    #[test]
    fn every_suite_scene_loads() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        for s in SUITE {
            load(root, s.file, s.params).unwrap_or_else(|e| panic!("{}: {e}", s.name));
        }
    }

    #[test]
    fn unknown_scene_is_named() {
        let e = selected(&["nope".to_string()]).unwrap_err().to_string();
        assert!(e.contains("nope") && e.contains("cbox"), "{e}");
    }
}
