//! Furnace tests: closed emitting diffuse boxes and white furnaces whose
//! answers are known in closed form, checked with Student t-tests.

use crate::common::*;
use lente::color::Rgb;
use lente::emitter::Emitter;
use lente::geometry::Geometry;
use lente::integrator::Strategy;
use lente::math::Vec3;
use lente::stats::{sidak, t_test};

/// Inside a closed box whose walls all emit radiance 1 and reflect with
/// albedo a, every ray sees 1 + a + a^2 + ... = 1 / (1 - a).
fn emitting_box(a: f32, strategy: Strategy) -> TestScene {
    let mut d = desc(
        look_at(Vec3::ZERO, Vec3::new(0.3, 0.2, 1.0), 90.0, 32, 32),
        path(strategy),
    );
    d.shapes.push(shape(
        Geometry::Mesh(flipped(cube(1.0, 2))),
        diffuse(a),
        Some(Rgb::ONE),
    ));
    d.build()
}

#[test]
fn emitting_box_path_mats() {
    let alpha = sidak(0.01, 2);
    for (i, a) in [0.5f32, 0.8].into_iter().enumerate() {
        let scene = emitting_box(a, Strategy::Mats);
        let mv = estimate(&scene, 40_000, 100 + i as u64);
        let expect = 1.0 / (1.0 - a as f64);
        let r = t_test(&mv, expect);
        assert!(
            r.passes(alpha),
            "albedo {a}: mean {} vs {expect}, p = {}",
            mv.mean(),
            r.p_value
        );
    }
}

#[test]
fn emitting_box_rejects_wrong_reference() {
    // The same estimate must fail against a reference 2% off: the test has power.
    let scene = emitting_box(0.5, Strategy::Mats);
    let mv = estimate(&scene, 40_000, 7);
    assert!(!t_test(&mv, 2.0 * 1.02).passes(0.01));
}

#[test]
fn emitting_box_nee_strategies() {
    let alpha = sidak(0.01, 4);
    for (i, s) in [Strategy::Ems, Strategy::Mis].into_iter().enumerate() {
        for a in [0.5f32, 0.8] {
            let scene = emitting_box(a, s);
            let mv = estimate(&scene, 40_000, 200 + i as u64);
            let expect = 1.0 / (1.0 - a as f64);
            let r = t_test(&mv, expect);
            assert!(
                r.passes(alpha),
                "{s:?} albedo {a}: mean {} vs {expect}, p = {}",
                mv.mean(),
                r.p_value
            );
        }
    }
}

/// Drops shading normals: interpolated normals on a faceted convex body
/// make it slightly non-convex to light, and the furnace identity then
/// holds only approximately.
fn faceted(mut m: lente::geometry::TriangleMesh) -> lente::geometry::TriangleMesh {
    m.clear_normals();
    m
}

/// White furnace: a convex diffuse object of albedo rho under a constant
/// environment of radiance 1 has radiance rho wherever it is seen (the
/// background is 1 too, so we look only at rays that hit it).
#[test]
fn white_furnace_all_strategies() {
    let alpha = sidak(0.01, 6);
    for (i, s) in [Strategy::Mats, Strategy::Ems, Strategy::Mis]
        .into_iter()
        .enumerate()
    {
        for (j, (rho, geom)) in [
            (0.7f32, sphere(Vec3::new(0.0, 0.0, 4.0), 1.0)),
            (0.4f32, Geometry::Mesh(faceted(icosphere(1.0, 2)))),
        ]
        .into_iter()
        .enumerate()
        {
            let mut geom = geom;
            if let Geometry::Mesh(_) = geom {
                geom.transform(
                    &lente::math::Transform::new(lente::math::Mat4::from_translation(Vec3::new(
                        0.0, 0.0, 4.0,
                    )))
                    .unwrap(),
                )
                .unwrap();
            }
            let mut d = desc(look_at(Vec3::ZERO, Vec3::Z, 20.0, 16, 16), path(s));
            d.shapes.push(shape(geom, diffuse(rho), None));
            d.emitters
                .push(Emitter::Constant(lente::emitter::ConstantLight {
                    radiance: Rgb::ONE,
                }));
            let scene = d.build();
            // fov 20 at distance 4: the sphere of radius 1 fills the view.
            let mv = estimate(&scene, 20_000, (10 * i + j) as u64);
            let r = t_test(&mv, rho as f64);
            assert!(
                r.passes(alpha),
                "{s:?} rho {rho}: mean {} (var {}), p = {}",
                mv.mean(),
                mv.variance(),
                r.p_value
            );
        }
    }
}
