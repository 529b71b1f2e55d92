//! The GPU backend (`--device gpu`) against the CPU renderer: the same
//! scenes, K renders each with independent seeds, compared with the Mitsuba
//! conformance check's block z-test (box filter, 8 x 8 blocks, Sidak
//! threshold at 1% for all blocks together). The scenes cover what the GPU
//! renders: rectangles, disks, spheres, cubes and OBJ meshes; diffuse,
//! two-sided diffuse, mirror, smooth and rough dielectric, conductor,
//! rough conductor (GGX and Beckmann), plastic, rough plastic and
//! pplastic, Nori's microfacet and the Zaragoza fork's roughconductor and
//! roughsubstrate, masks, blends, null and polarizer; volpath through
//! homogeneous media (the conformance check's fog scene, and media behind
//! null, dielectric and thin-dielectric boundaries with every phase
//! function) and heterogeneous ones (the conformance check's grid volumes);
//! mesh_attribute textures (per vertex and per face, in a mirrored instance);
//! rectangle, disk, sphere and mesh area lights (constant, and a bitmap or
//! checkerboard radiance), point, spot (plain and projecting a bitmap) and
//! directional lights, the light choice past 64 emitters, a light triangle
//! sampled by solid angle, a constant sky and
//! environment maps (Mitsuba's and Nori's texel rows, a real probe with a
//! sun); perspective, thin-lens (disk and polygon) and orthographic
//! cameras; hide_emitters; and the showcase.
//!
//! Runs where wgpu finds an adapter (CI: Mesa's lavapipe, installed by
//! `.ci/run`, which sets LENTE_REQUIRE_GPU so that a missing adapter fails
//! rather than skips).

use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::time::Instant;

use lente::image::{Bitmap, Filter};
use lente::integrator::Integrator;
use lente::load::load_scene_with;
use lente::render::{render, RenderJob, RenderOptions};
use lente::scene::Scene;

use super::mitsuba_conformance::{compare, sidak_threshold, Estimate};
use super::samplers::{luminances, stratified_scene, summed_variance};

/// Independent renders per renderer and scene.
const RENDERS: usize = 16;

/// Whether the tests can run; panics where they must (LENTE_REQUIRE_GPU).
fn gpu_here() -> bool {
    if lente::gpu::adapter().is_some() {
        return true;
    }
    assert!(
        std::env::var_os("LENTE_REQUIRE_GPU").is_none(),
        "LENTE_REQUIRE_GPU is set but wgpu finds no adapter (install mesa-vulkan-drivers)"
    );
    eprintln!("skipped: no GPU adapter (install mesa-vulkan-drivers for lavapipe)");
    false
}

/// A scene of the repository, at most 48 pixels wide, with a box filter
/// (independent pixels, as the z-test assumes) and 64 spp (32 under
/// volpath).
fn load(file: &str) -> (Scene, RenderJob) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(file);
    let (mut desc, _) = load_scene_with(&path, &[]).unwrap_or_else(|e| panic!("{e}"));
    let cam = &mut desc.scene.camera;
    if cam.width > 48 {
        cam.height = (cam.height * 48).div_ceil(cam.width);
        cam.width = 48;
    }
    desc.job.filter = Filter::Box { radius: 0.5 };
    // Volumetric paths take lavapipe 3-5 times longer per sample: 32 spp
    // keeps the CI's z-test set in time (a wrong phase function or volume
    // lookup still reads |z| > 30 at 64).
    desc.job.spp = match desc.job.integrator {
        Integrator::VolPath { .. } => 32,
        _ => 64,
    };
    let scene = Scene::new(desc.scene).unwrap_or_else(|e| panic!("{file}: {e}"));
    (scene, desc.job)
}

fn gpu_image(scene: &Scene, job: &RenderJob, seed: u64) -> Bitmap {
    lente::gpu::render(
        scene,
        job,
        &RenderOptions::new(seed),
        &AtomicBool::new(false),
    )
    .unwrap_or_else(|e| panic!("{e}"))
    .image
}

/// Both devices' estimates of `file` at `spp` samples per pixel.
fn estimates(file: &str, spp: u32) -> (Estimate, Estimate) {
    let (scene, mut job) = load(file);
    job.spp = spp;
    let (w, h) = (
        scene.camera.width() as usize,
        scene.camera.height() as usize,
    );
    let t = Instant::now();
    let cpu = Estimate::from_renders(w, h, RENDERS, |k| {
        let opts = RenderOptions::new(k as u64 + 1);
        render(&scene, &job, &opts, &AtomicBool::new(false)).image
    });
    let t_cpu = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let gpu = Estimate::from_renders(w, h, RENDERS, |k| gpu_image(&scene, &job, k as u64 + 101));
    // What this test's time goes to (lavapipe in CI).
    eprintln!(
        "{file}: {w}x{h}, {} spp x {RENDERS}: CPU {t_cpu:.1} s, GPU {:.1} s",
        job.spp,
        t.elapsed().as_secs_f64()
    );
    (cpu, gpu)
}

fn cpu_width(e: &Estimate) -> usize {
    e.mean_image().width
}

#[test]
fn gpu_images_match_the_cpu_renderer() {
    if !gpu_here() {
        return;
    }
    // Samples per pixel of each render, set by the power check below: in
    // a run at 64 (32 under volpath) the blocks with sampling noise gave
    // lente x1.05 a |z| of 8.0-16 (kept), 16-45 (halved) or more than 45
    // (quartered, to no less than 16), which keeps it above 10 where it
    // is least: this test is the longest of the suite on lavapipe.
    let files: [(&str, u32); 36] = [
        ("tests/gpu/diffuse_box.xml", 32),
        ("tests/gpu/glass_env.xml", 16),
        ("scenes/cbox/cbox.xml", 64),
        ("tests/gpu/env_rows.xml", 16),
        ("tests/gpu/env_sunset_nori.xml", 32),
        ("tests/gpu/env_facing.xml", 16),
        ("tests/gpu/glossy_delta_lights.xml", 32),
        ("scenes/showcase/showcase-mirror.xml", 16),
        ("tests/gpu/hidden_emitters.xml", 32),
        ("tests/gpu/textured.xml", 32),
        ("tests/gpu/instances.xml", 16),
        ("tests/gpu/masks_and_sides.xml", 16),
        ("tests/conformance/textured_area.xml", 32),
        ("tests/conformance/spot.xml", 32),
        ("tests/gpu/anisotropic.xml", 32),
        ("tests/gpu/normal_map.xml", 16),
        ("tests/gpu/bump_map.xml", 16),
        ("tests/conformance/projector.xml", 32),
        ("tests/gpu/conductor_textures.xml", 16),
        ("tests/gpu/blends.xml", 16),
        ("tests/conformance/blend_normalmap.xml", 16),
        ("tests/conformance/principled.xml", 32),
        ("tests/gpu/principled.xml", 16),
        ("tests/conformance/principled_thin.xml", 16),
        ("tests/gpu/principled_thin.xml", 32),
        ("tests/gpu/many_lights.xml", 64),
        ("bench/lights/near_light.xml", 64),
        ("tests/gpu/stratified.xml", 16),
        ("tests/gpu/path_ems_env.xml", 64),
        ("tests/gpu/path_mats_light.xml", 16),
        ("tests/gpu/nori_rough.xml", 32),
        ("tests/conformance/media.xml", 32),
        ("tests/gpu/volumes.xml", 16),
        ("tests/conformance/hetero.xml", 16),
        ("tests/conformance/pplastic.xml", 16),
        ("tests/gpu/mesh_attribute.xml", 16),
    ];
    // LENTE_GPU_ONLY=text: only the scenes whose path contains it (while
    // working on one; the Sidak threshold then covers those alone).
    let only = std::env::var("LENTE_GPU_ONLY").unwrap_or_default();
    let pairs: Vec<_> = files
        .iter()
        .filter(|(f, _)| f.contains(only.as_str()))
        .map(|&(f, spp)| (f, estimates(f, spp)))
        .collect();
    let tests: usize = pairs.iter().map(|(_, (c, g))| compare(g, c).z.len()).sum();
    let threshold = sidak_threshold(tests);
    let mut failures = Vec::new();
    for (file, (cpu, gpu)) in &pairs {
        let c = compare(gpu, cpu);
        // The test can fail: 5% more light must be noticed, and in the
        // blocks with sampling noise, not only where a sky seen directly
        // meets the rounding floor.
        let off = compare(&gpu.scaled(1.05), cpu);
        eprintln!(
            "{file}: max |z| {:.2} (threshold {threshold:.2}); x1.05: {:.1}, {:.1} in sampled blocks",
            c.max_abs_z, off.max_abs_z, off.max_abs_z_sampled
        );
        if std::env::var_os("LENTE_GPU_DEBUG").is_some() {
            let bw = cpu_width(cpu).div_ceil(8);
            for (i, z) in c.z.iter().enumerate() {
                if z.abs() > 2.5 {
                    eprintln!(
                        "  block ({}, {}) channel {}: z {z:.2}",
                        (i / 3) % bw,
                        (i / 3) / bw,
                        i % 3
                    );
                }
            }
        }
        if c.max_abs_z > threshold {
            failures.push(format!("{file}: max |z| {:.2}", c.max_abs_z));
        }
        assert!(
            off.max_abs_z_sampled > threshold,
            "{file}: a 5% brighter GPU image passes in the blocks with sampling noise (max |z| {:.2})",
            off.max_abs_z_sampled
        );
    }
    assert!(failures.is_empty(), "GPU differs from CPU: {failures:?}");
}

/// The GPU honours a stratified sampler: over 8 seeds of 16 spp, its
/// per-pixel variance is well below that of its independent sampling of
/// the same scene (the CPU's ratio is 0.22; tests/integration/samplers.rs).
#[test]
fn gpu_stratified_sampling_lowers_variance() {
    if !gpu_here() {
        return;
    }
    let variance = |sampler: &str| {
        let (scene, job) = stratified_scene(sampler);
        let imgs: Vec<_> = (0..8)
            .map(|seed| luminances(&gpu_image(&scene, &job, seed)))
            .collect();
        summed_variance(&imgs)
    };
    let ratio = variance("ldsampler") / variance("independent");
    assert!(
        ratio < 0.7,
        "GPU variance ratio stratified / independent {ratio}"
    );
}

#[test]
fn gpu_renders_are_deterministic() {
    if !gpu_here() {
        return;
    }
    let (scene, job) = load("tests/gpu/glass_env.xml");
    let render = |seed| {
        lente::gpu::render(
            &scene,
            &job,
            &RenderOptions::new(seed),
            &AtomicBool::new(false),
        )
        .unwrap()
        .film
    };
    let (a, b, c) = (render(3), render(3), render(4));
    assert!(a.data() == b.data(), "same seed, different films");
    assert!(a.data() != c.data(), "different seeds, same film");
}

/// AOVs on the GPU are the CPU's (computed on the CPU while the GPU traces
/// each pass, from the same random streams): equal up to the rounding of
/// the merge order; asking for them leaves the GPU's image the same bit
/// for bit.
#[test]
fn gpu_renders_carry_the_cpus_aovs() {
    if !gpu_here() {
        return;
    }
    let (scene, job) = load("tests/gpu/glossy_delta_lights.xml");
    let mut opts = RenderOptions::new(5);
    opts.aovs = "albedo,normal,depth,dd:depth,nn:sh_normal".parse().unwrap();
    let cancel = AtomicBool::new(false);
    let cpu = render(&scene, &job, &opts, &cancel).film;
    let gpu = lente::gpu::render(&scene, &job, &opts, &cancel)
        .unwrap()
        .film;
    let n = opts.aovs.channel_count();
    assert_eq!(gpu.aov_channels(), n);
    for c in 0..n {
        let (a, b) = (cpu.aov_channel(c), gpu.aov_channel(c));
        for (x, y) in a.iter().zip(&b) {
            assert!(
                (x - y).abs() <= 1e-5 * x.abs().max(1.0),
                "channel {c}: {x} vs {y}"
            );
        }
        assert!(a.iter().any(|&x| x != 0.0), "channel {c} is all zero");
    }
    let plain = lente::gpu::render(&scene, &job, &RenderOptions::new(5), &cancel).unwrap();
    assert!(
        plain.film.data() == gpu.data(),
        "AOVs changed the GPU's image"
    );
}

/// The GPU renders in the CPU's passes, reporting each with its film (for
/// the preview, tev and checkpoints); Ctrl-C drops the pass in flight, and
/// a render continued from its film takes the samples after it.
#[test]
fn gpu_passes_are_reported_dropped_when_cut_and_continued() {
    if !gpu_here() {
        return;
    }
    let (scene, mut job) = load("tests/gpu/glass_env.xml");
    job.spp = 16;
    // Box filter: every sample adds exactly 1 to its pixel's weight.
    let weights_are =
        |film: &lente::image::Film, spp: u32| film.data().iter().all(|&(_, w)| w == spp as f32);
    let mut seen = Vec::new();
    let full = lente::gpu::render_with_passes(
        &scene,
        &job,
        &RenderOptions::new(5),
        &AtomicBool::new(false),
        |info| {
            assert!(
                weights_are(info.film, info.spp_done),
                "pass to {} spp: pixel weights are not the sample counts",
                info.spp_done
            );
            seen.push(info.spp_done);
        },
    )
    .unwrap();
    let expected: Vec<u32> = lente::render::pass_schedule_from(0, 16)
        .iter()
        .map(|p| p.1)
        .collect();
    assert_eq!(seen, expected);
    assert!(weights_are(&full.film, 16) && !full.cancelled);

    // Cancelled once the second pass is in: the third is never kept.
    let cancel = AtomicBool::new(false);
    let mut passes = 0;
    let cut = lente::gpu::render_with_passes(&scene, &job, &RenderOptions::new(5), &cancel, |_| {
        passes += 1;
        if passes == 2 {
            cancel.store(true, std::sync::atomic::Ordering::Relaxed);
        }
    })
    .unwrap();
    assert!(cut.cancelled);
    assert_eq!(cut.spp, expected[1]);
    assert!(weights_are(&cut.film, cut.spp));

    // Continued from there to 16 spp: the samples of the whole render.
    let mut opts = RenderOptions::new(5);
    opts.first_sample = cut.spp;
    opts.film = Some(cut.film);
    let rest = lente::gpu::render(&scene, &job, &opts, &AtomicBool::new(false)).unwrap();
    assert_eq!(rest.spp, 16);
    assert!(weights_are(&rest.film, 16));
    let close =
        rest.film.data().iter().zip(full.film.data()).all(|(a, b)| {
            (a.0 - b.0).abs().max_element() <= 1e-4 * b.0.abs().max_element().max(1.0)
        });
    assert!(close, "the continued render is not the whole render");
}

#[test]
fn unsupported_features_are_named() {
    // Needs no adapter: the scene is checked before the device is opened.
    let (scene, job) = load("tests/conformance/curves.xml");
    let err = lente::gpu::render(
        &scene,
        &job,
        &RenderOptions::new(1),
        &AtomicBool::new(false),
    )
    .err()
    .expect("curves.xml has curves");
    let msg = err.to_string();
    assert!(msg.contains("does not support curves"), "{msg}");
    assert!(msg.contains("--device cpu"), "{msg}");
}

#[test]
fn device_flag_names_what_the_gpu_lacks_and_auto_falls_back() {
    use super::cli_util::{run_fails_with, run_ok, text};
    let dir = tempfile::tempdir().unwrap();
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/conformance/curves.xml");
    let scene = scene.to_str().unwrap();
    let out = dir.path().join("out");
    let out = out.to_str().unwrap();
    run_fails_with(
        &["render", scene, "--device", "gpu", "--spp", "1", "-o", out],
        "does not support curves",
    );
    assert!(!dir.path().join("out.exr").exists(), "no output on failure");
    let done = run_ok(&["render", scene, "--device", "auto", "--spp", "1", "-o", out]);
    assert!(
        text(&done.stderr).contains("note: rendering on the CPU: the GPU backend does not support"),
        "{}",
        text(&done.stderr)
    );
    assert!(dir.path().join("out.exr").exists());
}
