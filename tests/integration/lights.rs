//! Light selection and emitter visibility: several lights of very
//! different size, power and distance give the closed-form direct light
//! with every strategy; `hide_emitters` lets camera rays through area
//! emitters (Mitsuba 3's behaviour).

use crate::common::*;
use lente::color::Rgb;
use lente::geometry::{Geometry, TriangleMesh};
use lente::integrator::{Integrator, PathParams, Strategy};
use lente::math::Vec3;
use lente::stats::{sidak, t_test, welch_t_test};

/// Spherical lights (centre, radius, radiance) over a diffuse floor of
/// albedo `rho` at y = 0, seen at one spot below a camera 1 above it,
/// estimated with `Direct { strategy }`.
fn lights_over_a_floor(strategy: Strategy, rho: f32, lights: &[(Vec3, f32, f32)]) -> TestScene {
    let mut d = desc(
        look_at(
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(0.0, 0.0, 0.001),
            0.5,
            8,
            8,
        ),
        Integrator::Direct { strategy },
    );
    d.shapes.push(shape(
        Geometry::Mesh(quad(Vec3::ZERO, 100.0, true)),
        diffuse(rho),
        None,
    ));
    for &(c, r, l) in lights {
        d.shapes
            .push(shape(sphere(c, r), diffuse(0.0), Some(Rgb::splat(l))));
    }
    d.build()
}

/// The floor's radiance at the origin: a sphere of radiance L, radius r,
/// centre at distance d and angle theta from the normal, wholly above the
/// horizon and hidden by no other, gives rho L r^2 cos(theta) / d^2.
fn floor_radiance(rho: f32, lights: &[(Vec3, f32, f32)]) -> f64 {
    lights
        .iter()
        .map(|&(c, r, l)| {
            let d2 = c.length_squared();
            let cos = c.y / d2.sqrt();
            (rho * l * r * r * cos / d2) as f64
        })
        .sum()
}

/// One spherical light straight above the floor: all three direct
/// strategies agree with the closed form (emitter sampling uses the cone
/// the sphere subtends).
#[test]
fn spherical_light_over_a_floor() {
    let rho = 0.8;
    let lights = [(Vec3::new(0.0, 3.0, 0.0), 0.5, 5.0)];
    let expect = floor_radiance(rho, &lights);
    let alpha = sidak(0.01, 3);
    for (i, s) in [Strategy::Ems, Strategy::Mats, Strategy::Mis]
        .into_iter()
        .enumerate()
    {
        let scene = lights_over_a_floor(s, rho, &lights);
        let n = if s == Strategy::Mats { 400_000 } else { 50_000 };
        let mv = estimate(&scene, n, 70 + i as u64);
        let t = t_test(&mv, expect);
        assert!(t.passes(alpha), "{s:?}: {} vs {expect}", mv.mean());
        if s == Strategy::Ems {
            // Cone sampling sees the whole sphere: nearly noise-free here.
            assert!(
                mv.variance().sqrt() < 0.05 * expect,
                "std {}",
                mv.variance().sqrt()
            );
        }
    }
}

/// Veach's light set over the floor (radii 0.03 to 0.9 at the same power,
/// and a big bright light far away; none hides another): every strategy
/// gives the closed form, whatever chooses the lights.
#[test]
fn many_sphere_lights_over_a_floor() {
    let rho = 0.8f32;
    let lights = [
        (Vec3::new(-2.0, 2.0, 0.0), 0.0333, 900.0),
        (Vec3::new(0.0, 2.0, -2.0), 0.1, 100.0),
        (Vec3::new(2.0, 2.5, 0.0), 0.3, 11.1),
        (Vec3::new(0.0, 3.0, 3.0), 0.9, 1.23),
        (Vec3::new(20.0, 30.0, 10.0), 1.0, 800.0),
    ];
    let expect = floor_radiance(rho, &lights);
    let alpha = sidak(0.01, 3);
    for (i, s) in [Strategy::Ems, Strategy::Mats, Strategy::Mis]
        .into_iter()
        .enumerate()
    {
        let scene = lights_over_a_floor(s, rho, &lights);
        let n = if s == Strategy::Mats {
            1_000_000
        } else {
            100_000
        };
        let mv = estimate(&scene, n, 90 + i as u64);
        let t = t_test(&mv, expect);
        assert!(t.passes(alpha), "{s:?}: {} vs {expect} ({t:?})", mv.mean());
        if s == Strategy::Ems {
            // Each light is chosen by what it delivers here: close to
            // noise-free (choosing by power sends almost every sample to
            // the far light: a relative deviation of 5.7).
            let rel = mv.variance().sqrt() / expect;
            assert!(rel < 0.5, "relative standard deviation {rel}");
        }
    }
}

/// With `hide_emitters`, a camera ray that meets an area emitter goes on
/// to the surface behind it; without, the emitter's surface is what it
/// sees.
#[test]
fn hidden_emitters_let_camera_rays_through() {
    let build = |with_sphere: bool, hide: bool| {
        let mut d = desc(
            look_at(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, 20.0, 16, 16),
            Integrator::Path {
                strategy: Strategy::Mis,
                params: PathParams {
                    max_depth: Some(3),
                    rr_depth: 5,
                    hide_emitters: hide,
                },
            },
        );
        // A wall at z = 0 facing the camera, lit from the side by a point
        // light that casts no shadow of the sphere on it.
        let wall = TriangleMesh::new(
            vec![
                Vec3::new(-5.0, -5.0, 0.0),
                Vec3::new(5.0, -5.0, 0.0),
                Vec3::new(5.0, 5.0, 0.0),
                Vec3::new(-5.0, 5.0, 0.0),
            ],
            Vec::new(),
            Vec::new(),
            vec![[0, 1, 2], [0, 2, 3]],
        )
        .unwrap();
        d.shapes
            .push(shape(Geometry::Mesh(wall), diffuse(0.5), None));
        d.emitters
            .push(point_light(Vec3::new(3.0, 0.0, 1.0), Rgb::splat(200.0)));
        if with_sphere {
            d.shapes.push(shape(
                sphere(Vec3::new(0.0, 0.0, 2.5), 0.4),
                diffuse(0.0),
                // Black: it changes nothing the camera can see behind it.
                Some(Rgb::ZERO),
            ));
        }
        d.build()
    };
    let lo = lente::math::Vec2::splat(0.4);
    let hi = lente::math::Vec2::splat(0.6);
    let n = 20_000;
    let without = estimate_region(&build(false, true), n, 3, lo, hi);
    let hidden = estimate_region(&build(true, true), n, 4, lo, hi);
    let shown = estimate_region(&build(true, false), n, 5, lo, hi);
    assert!(without.mean() > 0.05, "{}", without.mean());
    let t = welch_t_test(&hidden, &without);
    assert!(
        t.passes(0.01),
        "{} vs {} ({t:?})",
        hidden.mean(),
        without.mean()
    );
    // Shown: the black sphere.
    assert_eq!(shown.mean(), 0.0);
}
