//! Specular BSDFs: energy conservation and the laws of reflection/refraction.

use crate::common::UV0;
use lente::bsdf::{fresnel_dielectric, Bsdf};
use lente::math::Vec3;
use lente::sampling::Sampler;
use lente::stats::{sidak, t_test, MeanVar};

fn dir(theta_deg: f32, phi: f32, below: bool) -> Vec3 {
    let t = theta_deg.to_radians();
    let z = if below { -t.cos() } else { t.cos() };
    Vec3::new(t.sin() * phi.cos(), t.sin() * phi.sin(), z)
}

/// Reflection plus transmission of the smooth dielectric sum to one, the
/// reflected fraction is the Fresnel reflectance, and the directions obey
/// the laws of reflection and Snell's law, from both sides (including total
/// internal reflection inside).
#[test]
fn dielectric_conserves_energy_and_obeys_snell() {
    let eta = 1.5046f32 / 1.000277;
    let bsdf = Bsdf::dielectric(1.5046, 1.000277).unwrap();
    let angles = [0.0f32, 20.0, 40.0, 60.0, 80.0, 89.0];
    let alpha = sidak(0.01, 2 * angles.len());
    let mut s = Sampler::new(11, 0);
    for below in [false, true] {
        for &a in &angles {
            let wi = dir(a, 0.7, below);
            let (f, _, _) = fresnel_dielectric(wi.z, eta);
            let mut refl = MeanVar::default();
            let mut energy = MeanVar::default();
            for _ in 0..20_000 {
                let b = bsdf.sample(UV0, wi, s.next_2d(), s.next_1d()).unwrap();
                assert!(b.specular);
                let reflected = b.wo.z * wi.z > 0.0;
                refl.push(if reflected { 1.0 } else { 0.0 });
                // Radiance weight times eta^2 undoes the radiance scaling:
                // each sample then carries its lobe's share of energy.
                energy.push((b.weight.x * b.eta * b.eta) as f64);
                assert!((b.wo.length() - 1.0).abs() < 1e-4);
                if reflected {
                    assert!((b.wo - Vec3::new(-wi.x, -wi.y, wi.z)).length() < 1e-4);
                } else {
                    // Snell: n_i sin_i = n_t sin_t, relative index b.eta.
                    let sin_i = (1.0 - wi.z * wi.z).max(0.0).sqrt();
                    let sin_t = (1.0 - b.wo.z * b.wo.z).max(0.0).sqrt();
                    assert!((sin_i - b.eta * sin_t).abs() < 1e-3, "angle {a}");
                    // Transmitted direction lies in the plane of incidence, opposite side.
                    assert!(b.wo.x * wi.x <= 1e-6 && b.wo.y * wi.y <= 1e-6);
                }
            }
            assert!(
                (energy.mean() - 1.0).abs() < 1e-5,
                "energy {}",
                energy.mean()
            );
            let r = t_test(&refl, f as f64);
            if f < 1.0 && f > 0.0 {
                assert!(
                    r.passes(alpha),
                    "angle {a} below {below}: reflected {} vs F {f}",
                    refl.mean()
                );
            } else {
                assert_eq!(refl.mean(), f as f64);
            }
        }
    }
}

#[test]
fn total_internal_reflection_from_inside() {
    let bsdf = Bsdf::dielectric(1.5, 1.0).unwrap();
    let mut s = Sampler::new(12, 0);
    let wi = dir(60.0, 0.0, true); // beyond the critical angle of 41.8 deg
    for _ in 0..1000 {
        let b = bsdf.sample(UV0, wi, s.next_2d(), s.next_1d()).unwrap();
        assert!(b.wo.z < 0.0, "escaped despite TIR");
    }
}

#[test]
fn mirror_reflects_with_unit_weight() {
    let wi = dir(35.0, 1.2, false);
    let b = Bsdf::mirror()
        .sample(UV0, wi, Default::default(), 0.5)
        .unwrap();
    assert!((b.wo - Vec3::new(-wi.x, -wi.y, wi.z)).length() < 1e-6);
    assert_eq!(b.weight, lente::color::Rgb::ONE);
    assert_eq!(Bsdf::mirror().eval(UV0, wi, b.wo), lente::color::Rgb::ZERO);
    assert_eq!(Bsdf::mirror().pdf(UV0, wi, b.wo), 0.0);
}

/// `eval_pdf` gives the bits `eval` and `pdf` give, for the models with a
/// combined routine of their own (diffuse, plastic, rough conductor, rough
/// plastic) and for one that takes the two calls (Nori's microfacet), over
/// directions on both sides.
#[test]
fn eval_pdf_is_eval_and_pdf_bit_for_bit() {
    use lente::bsdf::MicrofacetType;
    use lente::color::Rgb;
    let bsdfs = [
        Bsdf::diffuse(Rgb::new(0.2, 0.5, 0.7)).unwrap(),
        Bsdf::plastic(1.49, 1.000277, Rgb::new(0.2, 0.4, 0.8), Rgb::ONE, false).unwrap(),
        Bsdf::plastic(1.6, 1.0, Rgb::new(0.9, 0.1, 0.1), Rgb::splat(0.5), true).unwrap(),
        Bsdf::rough_conductor(
            MicrofacetType::Ggx,
            0.2,
            0.3,
            Rgb::new(0.2, 0.9, 1.1),
            Rgb::new(3.9, 2.4, 2.2),
            Rgb::ONE,
            true,
        )
        .unwrap(),
        Bsdf::rough_plastic(
            MicrofacetType::Ggx,
            0.3,
            1.5,
            1.0,
            Rgb::splat(0.5),
            Rgb::ONE,
            false,
            true,
        )
        .unwrap(),
        Bsdf::microfacet(0.3, 1.7, 1.0, Rgb::splat(0.4)).unwrap(),
    ];
    let mut s = Sampler::new(5, 9);
    let mut compared = 0;
    for bsdf in &bsdfs {
        for _ in 0..2000 {
            let wi = lente::sampling::warp::square_to_uniform_sphere(s.next_2d());
            let wo = lente::sampling::warp::square_to_uniform_sphere(s.next_2d());
            let (f, pdf) = bsdf.eval_pdf(UV0, wi, wo);
            let (want_f, want_pdf) = (bsdf.eval(UV0, wi, wo), bsdf.pdf(UV0, wi, wo));
            let bits = |c: Rgb| c.to_array().map(f32::to_bits);
            assert_eq!(bits(f), bits(want_f), "{bsdf:?} at {wi}, {wo}");
            assert_eq!(pdf.to_bits(), want_pdf.to_bits(), "{bsdf:?} at {wi}, {wo}");
            compared += usize::from(pdf > 0.0);
        }
    }
    assert!(compared > 2000, "{compared} nonzero densities");
}
