//! The three path tracers under an environment map with a small, very
//! bright sun: they agree in expectation, and MIS is far less noisy.

use crate::common::*;
use lente::bsdf::Bsdf;
use lente::color::Rgb;
use lente::emitter::{Emitter, EnvFilter, EnvMap, TexelRows};
use lente::geometry::{Geometry, TriangleMesh};
use lente::image::Bitmap;
use lente::integrator::Strategy;
use lente::math::{Transform, Vec2, Vec3};
use lente::stats::{sidak, welch_t_test};

/// A 64x32 sky: blue gradient, plus a one-texel sun `sun` times brighter
/// than the zenith, about 40 degrees above the horizon, in front of the
/// camera (so the scene is backlit and the sun's image is not in view).
fn sun_map(sun: f32) -> Bitmap {
    let (w, h) = (64, 32);
    let mut b = Bitmap::new(w, h);
    for y in 0..h {
        for x in 0..w {
            let v = (y as f32 + 0.5) / h as f32;
            let sky = if v < 0.5 {
                Rgb::new(0.3, 0.5, 1.0) * (0.6 + 0.8 * v)
            } else {
                Rgb::splat(0.2)
            };
            b.set(x, y, sky);
        }
    }
    b.set(4, 8, Rgb::new(1.0, 0.95, 0.85) * sun);
    b
}

fn ground(size: f32, y: f32) -> TriangleMesh {
    let p = [
        Vec3::new(-size, y, -size),
        Vec3::new(size, y, -size),
        Vec3::new(size, y, size),
        Vec3::new(-size, y, size),
    ];
    // Counter-clockwise seen from above: normal +y.
    TriangleMesh::new(
        p.to_vec(),
        Vec::new(),
        Vec::new(),
        vec![[0, 2, 1], [0, 3, 2]],
    )
    .unwrap()
}

fn scene(strategy: Strategy, sun: f32, w: u32, h: u32) -> TestScene {
    let mut d = desc(
        look_at(
            Vec3::new(0.0, 1.2, 4.0),
            Vec3::new(0.0, 0.4, 0.0),
            45.0,
            w,
            h,
        ),
        path(strategy),
    );
    d.shapes
        .push(shape(Geometry::Mesh(ground(6.0, 0.0)), diffuse(0.5), None));
    d.shapes.push(shape(
        sphere(Vec3::new(-1.1, 0.5, 0.0), 0.5),
        diffuse(0.7),
        None,
    ));
    // A planar mirror facing the camera (the sun is behind it), and a glass
    // sphere in the mirror's shadow. Sun caustics (sun -> specular ->
    // diffuse) can only be found by BSDF sampling in any unidirectional path
    // tracer, for every strategy alike; this scene has none, so the test
    // measures what MIS is for: direct light from a small bright source.
    let mirror = TriangleMesh::new(
        vec![
            Vec3::new(-0.6, 0.0, -1.2),
            Vec3::new(0.6, 0.0, -1.2),
            Vec3::new(0.6, 1.0, -1.2),
            Vec3::new(-0.6, 1.0, -1.2),
        ],
        Vec::new(),
        Vec::new(),
        vec![[0, 1, 2], [0, 2, 3]],
    )
    .unwrap();
    d.shapes
        .push(shape(Geometry::Mesh(mirror), Bsdf::mirror(), None));
    d.shapes.push(shape(
        sphere(Vec3::new(-0.2, 0.2, -0.8), 0.2),
        Bsdf::dielectric(1.5, 1.0).unwrap(),
        None,
    ));
    d.emitters.push(Emitter::Environment(Box::new(
        EnvMap::new(
            sun_map(sun),
            1.0,
            Transform::IDENTITY,
            EnvFilter::Bilinear,
            TexelRows::CellCentres,
        )
        .unwrap(),
    )));
    d.build()
}

#[test]
fn mats_ems_and_mis_agree_under_a_sun() {
    let regions = [
        (Vec2::new(0.0, 0.0), Vec2::new(1.0, 1.0)), // whole image
        (Vec2::new(0.1, 0.4), Vec2::new(0.4, 0.8)), // diffuse sphere
        (Vec2::new(0.4, 0.2), Vec2::new(0.6, 0.6)), // mirror
        (Vec2::new(0.4, 0.55), Vec2::new(0.55, 0.75)), // glass sphere
        (Vec2::new(0.0, 0.8), Vec2::new(1.0, 1.0)), // ground
    ];
    let alpha = sidak(0.01, 2 * regions.len());
    let sun = 1000.0;
    let mis = scene(Strategy::Mis, sun, 64, 48);
    for other in [Strategy::Mats, Strategy::Ems] {
        let s = scene(other, sun, 64, 48);
        for (k, &(lo, hi)) in regions.iter().enumerate() {
            let n = if other == Strategy::Mats {
                400_000
            } else {
                100_000
            };
            let a = estimate_region(&s, n, 10 + k as u64, lo, hi);
            let b = estimate_region(&mis, 100_000, 50 + k as u64, lo, hi);
            let r = welch_t_test(&a, &b);
            assert!(
                r.passes(alpha),
                "{other:?} vs Mis, region {k}: {} vs {} (p = {:.2e})",
                a.mean(),
                b.mean(),
                r.p_value
            );
        }
    }
}

fn mse(a: &Bitmap, b: &Bitmap) -> f64 {
    a.pixels
        .iter()
        .zip(&b.pixels)
        .map(|(p, q)| ((*p - *q) * (*p - *q)).element_sum() as f64 / 3.0)
        .sum::<f64>()
        / a.pixels.len() as f64
}

#[test]
fn mis_has_ten_times_lower_error_than_bsdf_sampling() {
    let sun = 10_000.0;
    let reference = scene(Strategy::Mis, sun, 48, 36).render(1024, 1);
    let mis = scene(Strategy::Mis, sun, 48, 36).render(16, 2);
    let mats = scene(Strategy::Mats, sun, 48, 36).render(16, 2);
    let (e_mis, e_mats) = (mse(&mis, &reference), mse(&mats, &reference));
    eprintln!(
        "MSE at 16 spp: path_mis {e_mis:.4e}, path_mats {e_mats:.4e}, ratio {:.1}",
        e_mats / e_mis
    );
    assert!(
        e_mats > 10.0 * e_mis,
        "path_mats {e_mats} vs path_mis {e_mis}"
    );
}

#[test]
#[ignore = "writes a picture of the test scene for a human to look at"]
fn picture_of_the_test_scene() {
    let img = scene(Strategy::Mis, 1000.0, 320, 240).render(64, 1);
    let out = std::env::temp_dir().join("lente-envmap-test-scene.png");
    lente::image::io::save_image(&out, &img).unwrap();
    eprintln!("wrote {}", out.display());
}
