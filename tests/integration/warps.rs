//! Chi-square tests of every warp, the aperture samplers, the diffuse
//! BSDF and the phase functions against their pdfs; plus the tests that
//! the tests can fail.

use crate::common::UV0;
use lente::bsdf::Bsdf;
use lente::camera::{regular_polygon_area, sample_regular_polygon};
use lente::color::Rgb;
use lente::math::{Vec2, Vec3};
use lente::sampling::warp;
use lente::stats::{plane_histogram, sidak, sphere_histogram};

/// Number of chi-square tests in this file that are expected to pass.
const TESTS: usize = 15;
const N: usize = 1_000_000;

fn alpha() -> f64 {
    sidak(0.01, TESTS)
}

fn assert_passes(name: &str, h: lente::stats::Histogram) {
    let r = h.test(5.0);
    assert!(
        r.passes(alpha()),
        "{name}: chi2 = {:.1}, dof = {}, p = {:.3e}",
        r.statistic,
        r.dof,
        r.p_value
    );
}

#[test]
fn square() {
    let h = plane_histogram(
        20,
        20,
        (0.0, 1.0),
        N,
        1,
        |s| Some(warp::square_to_uniform_square(s.next_2d())),
        |p| warp::square_to_uniform_square_pdf(p) as f64,
    );
    assert_passes("square", h);
}

#[test]
fn tent() {
    let h = plane_histogram(
        30,
        30,
        (-1.0, 1.0),
        N,
        2,
        |s| Some(warp::square_to_tent(s.next_2d())),
        |p| warp::square_to_tent_pdf(p) as f64,
    );
    assert_passes("tent", h);
}

#[test]
fn disk() {
    let h = plane_histogram(
        30,
        30,
        (-1.0, 1.0),
        N,
        3,
        |s| Some(warp::square_to_uniform_disk(s.next_2d())),
        |p| warp::square_to_uniform_disk_pdf(p) as f64,
    );
    assert_passes("disk", h);
}

fn polygon_pdf(p: Vec2, blades: u32, rotation: f32) -> f64 {
    // Inside the regular polygon iff on the inner side of every edge.
    let n = blades as f32;
    for k in 0..blades {
        let a0 = rotation + 2.0 * std::f32::consts::PI * k as f32 / n;
        let a1 = rotation + 2.0 * std::f32::consts::PI * (k + 1) as f32 / n;
        let p0 = Vec2::new(a0.cos(), a0.sin());
        let p1 = Vec2::new(a1.cos(), a1.sin());
        let e = p1 - p0;
        if e.perp_dot(p - p0) < 0.0 {
            return 0.0;
        }
    }
    1.0 / regular_polygon_area(blades) as f64
}

#[test]
fn polygon_apertures() {
    for (i, &(blades, rot)) in [(3u32, 0.0f32), (6, 0.3)].iter().enumerate() {
        let h = plane_histogram(
            30,
            30,
            (-1.0, 1.0),
            N,
            4 + i as u64,
            |s| Some(sample_regular_polygon(s.next_2d(), blades, rot)),
            |p| polygon_pdf(p, blades, rot),
        );
        assert_passes(&format!("polygon {blades}"), h);
    }
}

#[test]
fn uniform_sphere() {
    let h = sphere_histogram(
        20,
        40,
        N,
        6,
        |s| Some(warp::square_to_uniform_sphere(s.next_2d())),
        |d| warp::square_to_uniform_sphere_pdf(d) as f64,
    );
    assert_passes("uniform sphere", h);
}

#[test]
fn uniform_hemisphere() {
    let h = sphere_histogram(
        20,
        40,
        N,
        7,
        |s| Some(warp::square_to_uniform_hemisphere(s.next_2d())),
        |d| warp::square_to_uniform_hemisphere_pdf(d) as f64,
    );
    assert_passes("uniform hemisphere", h);
}

#[test]
fn cosine_hemisphere() {
    let h = sphere_histogram(
        20,
        40,
        N,
        8,
        |s| Some(warp::square_to_cosine_hemisphere(s.next_2d())),
        |d| warp::square_to_cosine_hemisphere_pdf(d) as f64,
    );
    assert_passes("cosine hemisphere", h);
}

#[test]
fn uniform_cone() {
    let h = sphere_histogram(
        20,
        40,
        N,
        9,
        |s| Some(warp::square_to_uniform_cone(s.next_2d(), 0.7)),
        |d| warp::square_to_uniform_cone_pdf(d, 0.7) as f64,
    );
    assert_passes("uniform cone", h);
}

#[test]
fn beckmann() {
    for (i, alpha) in [0.1f32, 0.6].iter().enumerate() {
        let h = sphere_histogram(
            20,
            40,
            N,
            10 + i as u64,
            |s| Some(warp::square_to_beckmann(s.next_2d(), *alpha)),
            |d| warp::square_to_beckmann_pdf(d, *alpha) as f64,
        );
        assert_passes(&format!("beckmann {alpha}"), h);
    }
}

#[test]
fn diffuse_bsdf_sampling_matches_pdf() {
    let bsdf = Bsdf::Diffuse(lente::bsdf::Diffuse {
        albedo: Rgb::splat(0.7),
    });
    let wi = Vec3::new(0.3, -0.2, 0.9).normalize();
    let h = sphere_histogram(
        20,
        40,
        N,
        12,
        |s| {
            let u = s.next_2d();
            let ul = s.next_1d();
            bsdf.sample(UV0, wi, u, ul).map(|b| b.wo)
        },
        |wo| bsdf.pdf(UV0, wi, wo) as f64,
    );
    assert_passes("diffuse", h);
    // Weight must equal eval * cos / pdf.
    let mut s = lente::sampling::Sampler::new(5, 5);
    for _ in 0..1000 {
        let b = bsdf.sample(UV0, wi, s.next_2d(), s.next_1d()).unwrap();
        let expect = bsdf.eval(UV0, wi, b.wo) * b.wo.z / bsdf.pdf(UV0, wi, b.wo);
        assert!((b.weight - expect).abs().max_element() < 1e-4);
    }
}

/// The phase functions: isotropic, Henyey-Greenstein forward and
/// backward, and Rayleigh, around a tilted arrival direction.
#[test]
fn phase_functions() {
    use lente::medium::Phase;
    let d = Vec3::new(0.36, -0.48, 0.8);
    for (i, phase) in [
        Phase::Isotropic,
        Phase::HenyeyGreenstein { g: 0.7 },
        Phase::HenyeyGreenstein { g: -0.4 },
        Phase::Rayleigh,
    ]
    .into_iter()
    .enumerate()
    {
        let h = sphere_histogram(
            20,
            40,
            N,
            40 + i as u64,
            |s| Some(phase.sample(d, s.next_2d()).wo),
            |wo| phase.eval(d, wo) as f64,
        );
        assert_passes(&format!("{phase:?}"), h);
    }
}

/// A Henyey-Greenstein sampler tested against the density of a slightly
/// different g must fail.
#[test]
fn chi2_rejects_hg_with_another_g() {
    use lente::medium::Phase;
    let d = Vec3::Z;
    let h = sphere_histogram(
        20,
        40,
        N,
        43,
        |s| Some(Phase::HenyeyGreenstein { g: 0.7 }.sample(d, s.next_2d()).wo),
        |wo| Phase::HenyeyGreenstein { g: 0.67 }.eval(d, wo) as f64,
    );
    let r = h.test(5.0);
    assert!(!r.passes(0.01), "wrong g accepted: p = {}", r.p_value);
}

/// The Rayleigh sampler tested against a density with 10% less of its
/// cos^2 term (renormalised) must fail.
#[test]
fn chi2_rejects_rayleigh_against_a_flatter_density() {
    use lente::medium::Phase;
    let d = Vec3::Z;
    let h = sphere_histogram(
        20,
        40,
        N,
        44,
        |s| Some(Phase::Rayleigh.sample(d, s.next_2d()).wo),
        |wo| {
            let c = d.dot(wo) as f64;
            (1.0 + 0.9 * c * c) / (4.0 * std::f64::consts::PI * (1.0 + 0.9 / 3.0))
        },
    );
    let r = h.test(5.0);
    assert!(
        !r.passes(0.01),
        "flatter density accepted: p = {}",
        r.p_value
    );
}

/// The chi-square machinery must reject a sampler whose pdf is wrong.
#[test]
fn chi2_rejects_cosine_samples_against_uniform_pdf() {
    let h = sphere_histogram(
        20,
        40,
        100_000,
        13,
        |s| Some(warp::square_to_cosine_hemisphere(s.next_2d())),
        |d| warp::square_to_uniform_hemisphere_pdf(d) as f64,
    );
    let r = h.test(5.0);
    assert!(!r.passes(0.01), "wrong pdf accepted: p = {}", r.p_value);
}

/// ... and a subtly wrong one: a disk sampler whose radius is 2% too small.
#[test]
fn chi2_rejects_slightly_shrunken_disk() {
    let h = plane_histogram(
        30,
        30,
        (-1.0, 1.0),
        N,
        14,
        |s| Some(0.98 * warp::square_to_uniform_disk(s.next_2d())),
        |p| warp::square_to_uniform_disk_pdf(p) as f64,
    );
    let r = h.test(5.0);
    assert!(!r.passes(0.01), "shrunken disk accepted: p = {}", r.p_value);
}
