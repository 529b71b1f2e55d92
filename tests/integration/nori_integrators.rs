//! Nori's remaining integrators agree in expectation with the path tracers
//! (or with closed forms) where they compute the same quantity.

use crate::common::*;
use lente::bsdf::Bsdf;
use lente::color::Rgb;
use lente::geometry::Geometry;
use lente::integrator::{Integrator, PathParams, Strategy};
use lente::math::Vec3;
use lente::stats::{sidak, t_test, welch_t_test};

/// A diffuse sphere lit by a quad light from above; a scene where direct
/// lighting is all there is (a convex object cannot light itself).
fn lit_sphere(integrator: Integrator, albedo: f32) -> TestScene {
    let mut d = desc(
        look_at(Vec3::new(0.0, 0.5, 4.0), Vec3::ZERO, 30.0, 32, 32),
        integrator,
    );
    d.shapes
        .push(shape(sphere(Vec3::ZERO, 1.0), diffuse(albedo), None));
    d.shapes.push(shape(
        Geometry::Mesh(quad(Vec3::new(0.5, 3.0, 0.5), 0.5, false)),
        diffuse(0.0),
        Some(Rgb::splat(10.0)),
    ));
    d.build()
}

#[test]
fn direct_integrators_agree_with_each_other_and_with_path() {
    let alpha = sidak(0.01, 3);
    let path_mis = estimate(
        &lit_sphere(
            Integrator::Path {
                strategy: Strategy::Mis,
                params: PathParams::default(),
            },
            0.6,
        ),
        100_000,
        1,
    );
    for (i, s) in [Strategy::Ems, Strategy::Mats, Strategy::Mis]
        .into_iter()
        .enumerate()
    {
        let n = if s == Strategy::Mats {
            400_000
        } else {
            100_000
        };
        let mv = estimate(
            &lit_sphere(Integrator::Direct { strategy: s }, 0.6),
            n,
            10 + i as u64,
        );
        let r = welch_t_test(&mv, &path_mis);
        assert!(
            r.passes(alpha),
            "direct {s:?}: {} vs path_mis {} (p {:.2e})",
            mv.mean(),
            path_mis.mean(),
            r.p_value
        );
    }
}

#[test]
fn simple_matches_direct_lighting_of_a_white_point_lit_sphere() {
    let (pos, power) = (Vec3::new(1.0, 3.0, 2.0), Rgb::splat(200.0));
    let build = |integ: Integrator| {
        let mut d = desc(
            look_at(Vec3::new(0.0, 0.5, 4.0), Vec3::ZERO, 30.0, 32, 32),
            integ,
        );
        d.shapes
            .push(shape(sphere(Vec3::ZERO, 1.0), diffuse(1.0), None));
        d.emitters.push(point_light(pos, power));
        d.build()
    };
    let simple = estimate(
        &build(Integrator::Simple {
            position: pos,
            energy: power,
        }),
        50_000,
        3,
    );
    let direct = estimate(
        &build(Integrator::Direct {
            strategy: Strategy::Ems,
        }),
        50_000,
        4,
    );
    let r = welch_t_test(&simple, &direct);
    assert!(
        r.passes(0.01),
        "simple {} vs direct_ems {}",
        simple.mean(),
        direct.mean()
    );
    assert!(simple.mean() > 0.1);
}

/// Between two parallel planes a distance h apart, a uniform hemisphere
/// direction from the floor is unoccluded within `length` L with
/// probability h / L (it must leave at cos theta < h / L).
#[test]
fn average_visibility_between_parallel_planes() {
    let (h, length) = (1.0f32, 2.5f32);
    let mut d = desc(
        look_at(
            Vec3::new(0.0, 0.5, 0.0),
            Vec3::new(0.0, 0.0, 0.01),
            20.0,
            16,
            16,
        ),
        Integrator::AverageVisibility { length },
    );
    d.shapes.push(shape(
        Geometry::Mesh(quad(Vec3::ZERO, 50.0, true)),
        diffuse(0.5),
        None,
    ));
    d.shapes.push(shape(
        Geometry::Mesh(quad(Vec3::new(0.0, h, 0.0), 50.0, false)),
        diffuse(0.5),
        None,
    ));
    let scene = d.build();
    let mv = estimate(&scene, 200_000, 6);
    let expect = (h / length) as f64;
    let r = t_test(&mv, expect);
    assert!(r.passes(0.01), "av {} vs {expect}", mv.mean());
    assert!(
        !t_test(&mv, expect * 1.03).passes(0.01),
        "test without power"
    );
}

/// Whitted equals path tracing where light reaches each diffuse surface
/// only directly: in a constant environment of radiance 1, a lone diffuse
/// convex body shows rho (emitter sampling), and lone mirror and glass
/// spheres show exactly 1 (recursion with Russian roulette is unbiased).
#[test]
fn whitted_agrees_with_path_tracing_in_a_furnace() {
    let cases: [(Bsdf, f64); 3] = [
        (diffuse(0.6), 0.6),
        (Bsdf::mirror(), 1.0),
        (Bsdf::dielectric(1.5, 1.0).unwrap(), 1.0),
    ];
    let alpha = sidak(0.01, 2 * cases.len());
    for (i, (bsdf, expect)) in cases.into_iter().enumerate() {
        let build = |integ: Integrator| {
            let mut d = desc(look_at(Vec3::ZERO, Vec3::Z, 20.0, 16, 16), integ);
            d.shapes.push(shape(
                sphere(Vec3::new(0.0, 0.0, 4.0), 1.0),
                bsdf.clone(),
                None,
            ));
            d.emitters.push(lente::emitter::Emitter::Constant(
                lente::emitter::ConstantLight { radiance: Rgb::ONE },
            ));
            d.build()
        };
        let whitted = estimate(&build(Integrator::Whitted), 50_000, 20 + i as u64);
        let path = estimate(
            &build(Integrator::Path {
                strategy: Strategy::Mis,
                params: PathParams::default(),
            }),
            50_000,
            40 + i as u64,
        );
        let r = t_test(&whitted, expect);
        assert!(
            r.passes(alpha),
            "whitted case {i}: {} vs {expect}",
            whitted.mean()
        );
        let r = welch_t_test(&whitted, &path);
        assert!(
            r.passes(alpha),
            "whitted case {i}: {} vs path {}",
            whitted.mean(),
            path.mean()
        );
    }
}

/// A directional light of irradiance E on a white diffuse plane facing it
/// at angle theta gives radiance E cos(theta) / pi.
#[test]
fn directional_light_on_a_diffuse_plane() {
    let e = 3.0f32;
    let dir = Vec3::new(0.3, -1.0, 0.2).normalize();
    let mut d = desc(
        look_at(
            Vec3::new(0.0, 2.0, 0.0),
            Vec3::new(0.0, 0.0, 0.01),
            20.0,
            8,
            8,
        ),
        Integrator::Direct {
            strategy: Strategy::Mis,
        },
    );
    d.shapes.push(shape(
        Geometry::Mesh(quad(Vec3::ZERO, 50.0, true)),
        diffuse(1.0),
        None,
    ));
    d.emitters.push(lente::emitter::Emitter::Directional(
        lente::emitter::DirectionalLight {
            direction: dir,
            irradiance: Rgb::splat(e),
        },
    ));
    let scene = d.build();
    let mv = estimate(&scene, 1000, 9);
    let expect = (e * -dir.y / std::f32::consts::PI) as f64;
    assert!(
        (mv.mean() - expect).abs() < 1e-4 * expect,
        "{} vs {expect}",
        mv.mean()
    );
}
