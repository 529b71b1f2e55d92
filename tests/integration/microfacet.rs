//! Nori's microfacet BSDF: sampling matches its pdf (chi-square), and the
//! sampling estimator of its albedo agrees with an independent
//! uniform-hemisphere estimator (Welch t-test), including near-mirror cases.

use crate::common::UV0;
use lente::bsdf::Bsdf;
use lente::color::Rgb;
use lente::math::Vec3;
use lente::sampling::{warp, Sampler};
use lente::stats::{sidak, sphere_histogram, welch_t_test, MeanVar};

fn incident(theta_deg: f32) -> Vec3 {
    let t = theta_deg.to_radians();
    Vec3::new(t.sin(), 0.0, t.cos())
}

const CASES: [(f32, f32, f32); 5] = [
    // (alpha, kd, incident angle in degrees)
    (0.5, 0.3, 30.0),
    (0.2, 0.0, 60.0),
    (0.05, 0.1, 20.0), // near-mirror
    (0.8, 0.6, 75.0),
    (0.3, 0.9, 0.0),
];

#[test]
fn microfacet_sampling_matches_pdf() {
    let alpha_sig = sidak(0.01, CASES.len());
    for (i, &(alpha, kd, angle)) in CASES.iter().enumerate() {
        let bsdf = Bsdf::microfacet(alpha, 1.5046, 1.000277, Rgb::splat(kd)).unwrap();
        let wi = incident(angle);
        let h = sphere_histogram(
            if alpha < 0.1 { 40 } else { 20 },
            40,
            1_000_000,
            i as u64,
            |s| bsdf.sample(UV0, wi, s.next_2d(), s.next_1d()).map(|b| b.wo),
            |wo| bsdf.pdf(UV0, wi, wo) as f64,
        );
        let r = h.test(5.0);
        assert!(
            r.passes(alpha_sig),
            "alpha {alpha} kd {kd} angle {angle}: chi2 {} dof {} p {:.2e}",
            r.statistic,
            r.dof,
            r.p_value
        );
    }
}

#[test]
fn microfacet_weights_agree_with_uniform_estimator() {
    let alpha_sig = sidak(0.01, CASES.len());
    for (i, &(alpha, kd, angle)) in CASES.iter().enumerate() {
        if alpha < 0.1 {
            // Uniform hemisphere sampling cannot resolve a near-mirror lobe.
            continue;
        }
        let bsdf = Bsdf::microfacet(alpha, 1.5046, 1.000277, Rgb::splat(kd)).unwrap();
        let wi = incident(angle);
        let mut s = Sampler::new(100 + i as u64, 0);
        let (mut a, mut b) = (MeanVar::default(), MeanVar::default());
        for _ in 0..400_000 {
            let w = bsdf
                .sample(UV0, wi, s.next_2d(), s.next_1d())
                .map_or(0.0, |x| x.weight.x);
            a.push(w as f64);
            let wo = warp::square_to_uniform_hemisphere(s.next_2d());
            let f = bsdf.eval(UV0, wi, wo).x * wo.z / warp::square_to_uniform_hemisphere_pdf(wo);
            b.push(f as f64);
        }
        let r = welch_t_test(&a, &b);
        assert!(
            r.passes(alpha_sig),
            "alpha {alpha} kd {kd}: sampled {} vs uniform {}, p {:.2e}",
            a.mean(),
            b.mean(),
            r.p_value
        );
        // Energy: reflectance never exceeds one.
        assert!(a.mean() < 1.0 + 4.0 * (a.variance() / a.n as f64).sqrt());
    }
}

#[test]
fn microfacet_sample_weight_is_eval_cos_over_pdf() {
    let bsdf = Bsdf::microfacet(0.3, 1.5, 1.0, Rgb::new(0.2, 0.4, 0.1)).unwrap();
    let wi = incident(40.0);
    let mut s = Sampler::new(5, 5);
    for _ in 0..10_000 {
        if let Some(b) = bsdf.sample(UV0, wi, s.next_2d(), s.next_1d()) {
            let expect = bsdf.eval(UV0, wi, b.wo) * b.wo.z / bsdf.pdf(UV0, wi, b.wo);
            assert!((b.weight - expect).abs().max_element() < 1e-3 * expect.max_element().max(1.0));
            assert!((b.pdf - bsdf.pdf(UV0, wi, b.wo)).abs() < 1e-3 * b.pdf);
        }
    }
}
