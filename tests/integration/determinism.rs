//! Renders are the same bit for bit whatever the thread count, and renders
//! with different seeds are independent.

use std::sync::atomic::AtomicBool;

use crate::common::*;
use lente::bsdf::Bsdf;
use lente::color::Rgb;
use lente::geometry::Geometry;
use lente::integrator::Strategy;
use lente::math::Vec3;
use lente::render::{render, RenderJob, RenderOptions};
use lente::sampling::SamplerKind;

fn small_scene() -> TestScene {
    scene_sized(40, 30)
}

fn scene_sized(width: u32, height: u32) -> TestScene {
    let mut d = desc(
        look_at(Vec3::new(0.0, 0.0, -0.95), Vec3::ZERO, 70.0, width, height),
        path(Strategy::Mis),
    );
    d.shapes.push(shape(
        Geometry::Mesh(flipped(cube(1.0, 1))),
        diffuse(0.6),
        None,
    ));
    d.shapes.push(shape(
        sphere(Vec3::new(-0.4, -0.6, 0.2), 0.35),
        Bsdf::mirror(),
        None,
    ));
    d.shapes.push(shape(
        sphere(Vec3::new(0.45, -0.6, -0.2), 0.35),
        Bsdf::dielectric(1.5, 1.0).unwrap(),
        None,
    ));
    d.shapes.push(shape(
        sphere(Vec3::new(0.0, 0.9, 0.0), 0.15),
        diffuse(0.0),
        Some(Rgb::splat(15.0)),
    ));
    d.build()
}

fn render_kind(
    threads: usize,
    scene: &TestScene,
    spp: u32,
    seed: u64,
    sampler: SamplerKind,
) -> lente::image::Bitmap {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    let opts = RenderOptions::new(seed);
    let job = RenderJob {
        integrator: scene.integrator,
        spp,
        sampler,
        filter: lente::image::Filter::default(),
        aovs: Default::default(),
    };
    pool.install(|| render(scene, &job, &opts, &AtomicBool::new(false)).image)
}

#[test]
fn one_and_two_threads_render_identical_bits() {
    let scene = small_scene();
    for kind in [SamplerKind::Independent, SamplerKind::Stratified] {
        let a = render_kind(1, &scene, 4, 5, kind);
        let b = render_kind(2, &scene, 4, 5, kind);
        assert!(a.mean().x > 0.0, "image is black");
        for (i, (p, q)) in a.pixels.iter().zip(&b.pixels).enumerate() {
            assert_eq!(
                p.to_array().map(f32::to_bits),
                q.to_array().map(f32::to_bits),
                "{kind:?}: pixel {i}"
            );
        }
    }
}

/// Renders with different seeds are independent: the differences of two
/// pairs of renders with four distinct seeds are uncorrelated (Spearman's
/// rank correlation, robust to fireflies), while pairs sharing a seed are
/// not; for a stratified sampler too (the seed changes its scrambles).
#[test]
fn different_seeds_are_independent() {
    for kind in [SamplerKind::Independent, SamplerKind::Stratified] {
        seeds_are_independent(kind);
    }
}

fn seeds_are_independent(kind: SamplerKind) {
    let scene = small_scene();
    let img = |seed| render_kind(2, &scene, 2, seed, kind);
    let (a, b, c, d, e) = (img(1), img(2), img(3), img(4), img(5));
    let diff = |x: &lente::image::Bitmap, y: &lente::image::Bitmap| -> Vec<f64> {
        x.pixels
            .iter()
            .zip(&y.pixels)
            .map(|(p, q)| (p.x - q.x) as f64)
            .collect()
    };
    let ranks = |v: &[f64]| -> Vec<f64> {
        let mut idx: Vec<usize> = (0..v.len()).collect();
        idx.sort_by(|&i, &j| v[i].total_cmp(&v[j]));
        let mut r = vec![0.0; v.len()];
        let mut k = 0;
        while k < idx.len() {
            // Ties share their mean rank.
            let mut m = k;
            while m + 1 < idx.len() && v[idx[m + 1]] == v[idx[k]] {
                m += 1;
            }
            for &i in &idx[k..=m] {
                r[i] = (k + m) as f64 / 2.0;
            }
            k = m + 1;
        }
        r
    };
    let spearman = |x: &[f64], y: &[f64]| -> f64 {
        let (x, y) = (ranks(x), ranks(y));
        let n = x.len() as f64;
        let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
        let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
        for (a, b) in x.iter().zip(&y) {
            sxy += (a - mx) * (b - my);
            sxx += (a - mx) * (a - mx);
            syy += (b - my) * (b - my);
        }
        sxy / (sxx * syy).sqrt()
    };
    let n = a.pixels.len() as f64;
    let r = spearman(&diff(&a, &c), &diff(&b, &d));
    // Under independence r is ~ N(0, 1/n): 4 sigma bound.
    assert!(
        r.abs() < 4.0 / n.sqrt(),
        "{kind:?}: correlation {r} between seeds"
    );
    // Sanity: sharing a render makes them correlated (the test can fail).
    let shared = spearman(&diff(&a, &c), &diff(&a, &e));
    assert!(shared > 0.3, "shared-seed correlation only {shared}");
    let _ = Rgb::ZERO;
}

#[test]
fn an_abandoned_unit_stops_at_once() {
    // A second Ctrl-C sets `abandon`: a unit in flight stops at its next
    // row and is dropped, however many samples it had left.
    let scene = small_scene();
    let job = RenderJob {
        integrator: scene.integrator,
        spp: 1_000_000,
        sampler: Default::default(),
        filter: lente::image::Filter::default(),
        aovs: Default::default(),
    };
    let tile = lente::render::tiles(40, 30)[0];
    let start = std::time::Instant::now();
    let stop = AtomicBool::new(true);
    assert!(lente::render::render_tile(
        &scene,
        &job,
        tile,
        (0, 1_000_000),
        1,
        &Default::default(),
        &stop
    )
    .is_none());
    assert!(start.elapsed() < std::time::Duration::from_secs(5));
    let go = AtomicBool::new(false);
    let block = lente::render::render_tile(&scene, &job, tile, (0, 1), 1, &Default::default(), &go);
    assert!(block.is_some());
}

#[test]
fn strips_are_the_rows_of_the_whole_render_bit_for_bit() {
    // 100 rows: four rows of 32-pixel tiles; strips that cut tiles and
    // stop short of and on tile edges, with the Gaussian filter's reach.
    let scene = scene_sized(24, 100);
    let job = RenderJob {
        integrator: scene.integrator,
        spp: 6,
        sampler: Default::default(),
        filter: lente::image::Filter::default(),
        aovs: Default::default(),
    };
    let mut opts = RenderOptions::new(5);
    opts.aovs = "albedo,depth".parse().unwrap();
    let whole = render(&scene, &job, &opts, &AtomicBool::new(false)).film;
    let w = 24;
    for (y0, y1) in [(0, 17), (17, 64), (64, 65), (65, 100), (0, 100)] {
        opts.rows = Some((y0, y1));
        let strip = render(&scene, &job, &opts, &AtomicBool::new(false)).film;
        assert_eq!((strip.width, strip.height), (24, (y1 - y0) as usize));
        let rows = y0 as usize * w..y1 as usize * w;
        assert!(
            strip.data() == &whole.data()[rows.clone()],
            "rows {y0}..{y1} differ"
        );
        let n = strip.aov_channels();
        assert!(strip.aov_sums() == &whole.aov_sums()[rows.start * n..rows.end * n]);
    }
}
