//! Renders are the same bit for bit whatever the thread count, and renders
//! with different seeds are independent.

mod common;

use std::sync::atomic::AtomicBool;

use common::*;
use lente::bsdf::Bsdf;
use lente::color::Rgb;
use lente::geometry::Geometry;
use lente::integrator::Strategy;
use lente::math::Vec3;
use lente::render::{render, RenderOptions};
use lente::scene::Scene;

fn small_scene() -> Scene {
    let mut d = desc(
        look_at(Vec3::new(0.0, 0.0, -0.95), Vec3::ZERO, 70.0, 40, 30),
        path(Strategy::Mis),
    );
    d.filter = lente::image::Filter::default();
    d.shapes.push(shape(
        Geometry::Mesh(flipped(cube(1.0, 1))),
        diffuse(0.6),
        None,
    ));
    d.shapes.push(shape(
        sphere(Vec3::new(-0.4, -0.6, 0.2), 0.35),
        Bsdf::Mirror,
        None,
    ));
    d.shapes.push(shape(
        sphere(Vec3::new(0.45, -0.6, -0.2), 0.35),
        Bsdf::dielectric(1.5, 1.0),
        None,
    ));
    d.shapes.push(shape(
        sphere(Vec3::new(0.0, 0.9, 0.0), 0.15),
        diffuse(0.0),
        Some(Rgb::splat(15.0)),
    ));
    Scene::new(d).unwrap()
}

fn render_with(threads: usize, scene: &Scene, spp: u32, seed: u64) -> lente::image::Bitmap {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    let opts = RenderOptions {
        spp,
        seed,
        progress: false,
    };
    pool.install(|| render(scene, &opts, &AtomicBool::new(false)).image)
}

#[test]
fn one_and_two_threads_render_identical_bits() {
    let scene = small_scene();
    let a = render_with(1, &scene, 4, 5);
    let b = render_with(2, &scene, 4, 5);
    assert!(a.mean().x > 0.0, "image is black");
    for (i, (p, q)) in a.pixels.iter().zip(&b.pixels).enumerate() {
        assert_eq!(
            p.to_array().map(f32::to_bits),
            q.to_array().map(f32::to_bits),
            "pixel {i}"
        );
    }
}

/// The pixel errors of two renders with different seeds are uncorrelated.
#[test]
fn different_seeds_are_independent() {
    let scene = small_scene();
    let reference = render_with(2, &scene, 64, 1000);
    let a = render_with(2, &scene, 2, 1);
    let b = render_with(2, &scene, 2, 2);
    let same = render_with(2, &scene, 2, 1);
    let err = |img: &lente::image::Bitmap| -> Vec<f64> {
        img.pixels
            .iter()
            .zip(&reference.pixels)
            .map(|(p, r)| (p.x - r.x) as f64)
            .collect()
    };
    let corr = |x: &[f64], y: &[f64]| -> f64 {
        let n = x.len() as f64;
        let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
        let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
        for (a, b) in x.iter().zip(y) {
            sxy += (a - mx) * (b - my);
            sxx += (a - mx) * (a - mx);
            syy += (b - my) * (b - my);
        }
        sxy / (sxx * syy).sqrt()
    };
    let (ea, eb, es) = (err(&a), err(&b), err(&same));
    let n = ea.len() as f64;
    let r = corr(&ea, &eb);
    // Under independence r is ~ N(0, 1/n): 4 sigma bound.
    assert!(r.abs() < 4.0 / n.sqrt(), "correlation {r} between seeds");
    // Sanity: the same seed is perfectly correlated (the test can fail).
    assert!(corr(&ea, &es) > 0.999);
    let _ = Rgb::ZERO;
}
