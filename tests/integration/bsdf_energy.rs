//! Weights and energy of the Mitsuba-3 BSDFs: each non-delta sample's
//! weight is eval |cos| / pdf and its pdf is pdf(); directional albedos
//! (mean sample weights) never exceed one; the cases with exact answers
//! hit them (the `none` conductor reflects everything, a thin sheet
//! reflects R' = 2R / (1 + R) and transmits the rest, a white plastic and a
//! smooth-ish rough dielectric keep nearly all energy); the conductor
//! Fresnel term has its closed forms; and the sampling estimator of
//! integral f |cos| agrees with a uniform-direction estimator (Welch).

use crate::common::UV0;
use lente::bsdf::{
    conductor_preset, fresnel_conductor, fresnel_conductor_1, fresnel_dielectric,
    fresnel_diffuse_reflectance, Bsdf, MicrofacetType,
};
use lente::color::Rgb;
use lente::math::Vec3;
use lente::sampling::{warp, Sampler};
use lente::stats::{sidak, t_test, welch_t_test, MeanVar};
use lente::texture::Texture;

use MicrofacetType::{Beckmann, Ggx};

fn dir(theta_deg: f32, phi_deg: f32, below: bool) -> Vec3 {
    let (t, p) = (theta_deg.to_radians(), phi_deg.to_radians());
    let z = if below { -t.cos() } else { t.cos() };
    Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), z)
}

const AIR: f32 = 1.000277;
const BK7: f32 = 1.5046;

fn metal(name: &str) -> (Rgb, Rgb) {
    conductor_preset(name).unwrap()
}

/// Every non-delta BSDF configuration the weight and albedo tests visit,
/// with incidence directions from the side(s) it scatters.
fn rough_bsdfs() -> Vec<(String, Bsdf, Vec<Vec3>)> {
    let (au_e, au_k) = metal("Au");
    let (none_e, none_k) = metal("none");
    let up = vec![
        dir(0.0, 0.0, false),
        dir(35.0, 40.0, false),
        dir(80.0, 200.0, false),
    ];
    let both = vec![
        dir(5.0, 0.0, false),
        dir(50.0, 120.0, false),
        dir(85.0, 10.0, false),
        dir(20.0, 300.0, true),
        dir(60.0, 30.0, true),
        dir(86.0, 180.0, true),
    ];
    let mut v = Vec::new();
    for kind in [Beckmann, Ggx] {
        for vis in [true, false] {
            v.push((
                format!("roughconductor {kind:?} vis={vis} Au 0.3"),
                Bsdf::rough_conductor(kind, 0.3, 0.3, au_e, au_k, Rgb::ONE, vis).unwrap(),
                up.clone(),
            ));
            v.push((
                format!("roughconductor {kind:?} vis={vis} none aniso"),
                Bsdf::rough_conductor(kind, 0.05, 0.5, none_e, none_k, Rgb::ONE, vis).unwrap(),
                up.clone(),
            ));
            v.push((
                format!("roughdielectric {kind:?} vis={vis} 0.3"),
                Bsdf::rough_dielectric(kind, 0.3, 0.3, BK7, AIR, Rgb::ONE, Rgb::ONE, vis).unwrap(),
                both.clone(),
            ));
            v.push((
                format!("roughdielectric {kind:?} vis={vis} aniso"),
                Bsdf::rough_dielectric(kind, 0.4, 0.08, 1.33, 1.0, Rgb::ONE, Rgb::ONE, vis)
                    .unwrap(),
                both.clone(),
            ));
        }
    }
    v.push((
        "plastic".into(),
        Bsdf::plastic(1.49, AIR, Rgb::new(0.9, 0.5, 0.1), Rgb::ONE, false).unwrap(),
        up.clone(),
    ));
    v.push((
        "plastic nonlinear".into(),
        Bsdf::plastic(1.7, AIR, Rgb::new(0.9, 0.5, 0.1), Rgb::splat(0.8), true).unwrap(),
        up.clone(),
    ));
    v.push((
        "roughplastic beckmann".into(),
        Bsdf::rough_plastic(
            Beckmann,
            0.2,
            1.49,
            AIR,
            Rgb::new(0.9, 0.5, 0.1),
            Rgb::ONE,
            false,
            true,
        )
        .unwrap(),
        up.clone(),
    ));
    v.push((
        "roughplastic ggx nonlinear all normals".into(),
        Bsdf::rough_plastic(
            Ggx,
            0.4,
            1.7,
            AIR,
            Rgb::new(0.9, 0.5, 0.1),
            Rgb::splat(0.8),
            true,
            false,
        )
        .unwrap(),
        up.clone(),
    ));
    v.push((
        "twosided roughconductor".into(),
        Bsdf::two_sided(
            Bsdf::rough_conductor(Ggx, 0.2, 0.2, au_e, au_k, Rgb::ONE, true).unwrap(),
            Some(Bsdf::plastic(1.49, AIR, Rgb::splat(0.5), Rgb::ONE, false).unwrap()),
        )
        .unwrap(),
        both.clone(),
    ));
    // A mask's pass-through is a delta lobe; its nested lobe keeps the
    // nested weight, with pdf and eval scaled by the opacity.
    v.push((
        "mask 0.6 over twosided roughconductor".into(),
        Bsdf::mask(
            Texture::Constant(Rgb::splat(0.6)),
            Bsdf::two_sided(
                Bsdf::rough_conductor(Ggx, 0.3, 0.3, au_e, au_k, Rgb::ONE, true).unwrap(),
                None,
            )
            .unwrap(),
        )
        .unwrap(),
        both.clone(),
    ));
    v.push((
        "mask (0.2, 0.9, 0.4) over roughdielectric".into(),
        Bsdf::mask(
            Texture::Constant(Rgb::new(0.2, 0.9, 0.4)),
            Bsdf::rough_dielectric(Beckmann, 0.4, 0.4, BK7, AIR, Rgb::ONE, Rgb::ONE, true).unwrap(),
        )
        .unwrap(),
        both.clone(),
    ));
    // blendbsdf: the mixture's value and density in every sampled
    // direction, a delta component's samples keeping their own weight.
    v.push((
        "blend 0.35 roughconductor / twosided roughplastic".into(),
        Bsdf::blend(
            Texture::Constant(Rgb::splat(0.35)),
            Bsdf::rough_conductor(Ggx, 0.2, 0.2, au_e, au_k, Rgb::ONE, true).unwrap(),
            Bsdf::two_sided(
                Bsdf::rough_plastic(
                    Ggx,
                    0.3,
                    1.49,
                    AIR,
                    Rgb::new(0.9, 0.5, 0.1),
                    Rgb::ONE,
                    false,
                    true,
                )
                .unwrap(),
                None,
            )
            .unwrap(),
        )
        .unwrap(),
        up.clone(),
    ));
    v.push((
        "blend 0.5 plastic / roughdielectric".into(),
        Bsdf::blend(
            Texture::Constant(Rgb::splat(0.5)),
            Bsdf::plastic(1.49, AIR, Rgb::splat(0.5), Rgb::ONE, false).unwrap(),
            Bsdf::rough_dielectric(Beckmann, 0.3, 0.3, BK7, AIR, Rgb::ONE, Rgb::ONE, true).unwrap(),
        )
        .unwrap(),
        both.clone(),
    ));
    // The Zaragoza Nori fork's models.
    v.push((
        "zaragoza roughconductor".into(),
        Bsdf::SchlickConductor(
            lente::bsdf::SchlickConductor::new(0.25, Rgb::new(0.95, 0.64, 0.54)).unwrap(),
        ),
        up.clone(),
    ));
    v.push((
        "zaragoza roughsubstrate".into(),
        Bsdf::RoughSubstrate(
            lente::bsdf::RoughSubstrate::new(0.2, 1.5046, AIR, Rgb::new(0.8, 0.5, 0.1)).unwrap(),
        ),
        up.clone(),
    ));
    // normalmap: the nested weight times the shadowing term, which keeps
    // it at most the nested albedo.
    let tilt = |n: Vec3| Texture::Constant((n.normalize() + Vec3::ONE) * 0.5);
    v.push((
        "normalmap over roughconductor".into(),
        Bsdf::normal_map(
            tilt(Vec3::new(0.3, 0.4, 0.8)),
            Bsdf::rough_conductor(Ggx, 0.3, 0.3, none_e, none_k, Rgb::ONE, true).unwrap(),
            true,
            true,
        )
        .unwrap(),
        up.clone(),
    ));
    v.push((
        "twosided normalmap over diffuse".into(),
        Bsdf::two_sided(
            Bsdf::normal_map(
                tilt(Vec3::new(-0.5, 0.1, 0.8)),
                Bsdf::diffuse(Rgb::splat(0.8)).unwrap(),
                true,
                true,
            )
            .unwrap(),
            None,
        )
        .unwrap(),
        both.clone(),
    ));
    v
}

#[test]
fn weight_is_eval_cos_over_pdf() {
    let mut s = Sampler::new(1, 1);
    for (name, b, wis) in rough_bsdfs() {
        for wi in wis {
            let mut n = 0;
            for _ in 0..4000 {
                let Some(x) = b.sample(UV0, wi, s.next_2d(), s.next_1d()) else {
                    continue;
                };
                if x.specular {
                    continue;
                }
                n += 1;
                let pdf = b.pdf(UV0, wi, x.wo);
                let expect = b.eval(UV0, wi, x.wo) * x.wo.z.abs() / pdf;
                assert!(
                    (x.pdf - pdf).abs() <= 1e-3 * pdf,
                    "{name} wi {wi}: sample pdf {} vs pdf() {pdf}",
                    x.pdf
                );
                assert!(
                    (x.weight - expect).abs().max_element()
                        <= 2e-3 * expect.max_element().max(1e-3),
                    "{name} wi {wi} wo {}: weight {} vs eval cos / pdf {expect}",
                    x.wo,
                    x.weight
                );
                assert!(x.wo.is_finite() && (x.wo.length() - 1.0).abs() < 1e-4);
            }
            assert!(n > 300, "{name} wi {wi}: only {n} smooth samples");
        }
    }
}

/// Directional albedo: the mean sample weight (times eta^2 for refraction,
/// which undoes the radiance scaling and leaves the energy) is at most one.
#[test]
fn albedo_never_exceeds_one() {
    let mut s = Sampler::new(2, 2);
    let mut bsdfs = rough_bsdfs();
    let (au_e, au_k) = metal("Au");
    bsdfs.push((
        "conductor Au".into(),
        Bsdf::conductor(au_e, au_k, Rgb::ONE).unwrap(),
        vec![
            dir(0.0, 0.0, false),
            dir(60.0, 0.0, false),
            dir(89.0, 0.0, false),
        ],
    ));
    bsdfs.push((
        "thindielectric".into(),
        Bsdf::thin_dielectric(BK7, AIR, Rgb::ONE, Rgb::ONE).unwrap(),
        vec![dir(0.0, 0.0, false), dir(70.0, 0.0, true)],
    ));
    for (name, b, wis) in bsdfs {
        for wi in wis {
            let mut mv = MeanVar::default();
            for _ in 0..50_000 {
                let e = b
                    .sample(UV0, wi, s.next_2d(), s.next_1d())
                    .map_or(0.0, |x| x.weight.max_element() * x.eta * x.eta);
                mv.push(e as f64);
            }
            let se = (mv.variance() / mv.n as f64).sqrt();
            assert!(
                mv.mean() <= 1.0 + 4.0 * se + 1e-6,
                "{name} wi {wi}: albedo {} +- {se}",
                mv.mean()
            );
        }
    }
}

#[test]
fn conductor_none_reflects_exactly_one() {
    let (e, k) = metal("none");
    assert_eq!((e, k), (Rgb::ZERO, Rgb::ONE));
    let b = Bsdf::conductor(e, k, Rgb::ONE).unwrap();
    for t in [0.0f32, 10.0, 45.0, 80.0, 89.9] {
        let wi = dir(t, 33.0, false);
        let x = b.sample(UV0, wi, Default::default(), 0.5).unwrap();
        assert_eq!(x.weight, Rgb::ONE, "theta {t}");
        assert!(x.specular);
        assert!((x.wo - Vec3::new(-wi.x, -wi.y, wi.z)).length() < 1e-6);
        assert_eq!(b.eval(UV0, wi, x.wo), Rgb::ZERO);
        assert_eq!(b.pdf(UV0, wi, x.wo), 0.0);
    }
    // One-sided: nothing from below.
    assert!(b
        .sample(UV0, dir(30.0, 0.0, true), Default::default(), 0.5)
        .is_none());
    // specular_reflectance scales it.
    let tinted = Bsdf::conductor(e, k, Rgb::new(0.5, 0.25, 1.0)).unwrap();
    let x = tinted
        .sample(UV0, dir(20.0, 0.0, false), Default::default(), 0.5)
        .unwrap();
    assert_eq!(x.weight, Rgb::new(0.5, 0.25, 1.0));
}

#[test]
fn conductor_fresnel_closed_forms() {
    for name in ["Au", "Cu", "Ag", "Al", "Cr", "W"] {
        let (eta, k) = metal(name);
        // Normal incidence: ((eta-1)^2 + k^2) / ((eta+1)^2 + k^2).
        let r = fresnel_conductor(1.0, eta, k);
        let e = ((eta - Rgb::ONE) * (eta - Rgb::ONE) + k * k)
            / ((eta + Rgb::ONE) * (eta + Rgb::ONE) + k * k);
        assert!((r - e).abs().max_element() < 1e-5, "{name}: {r} vs {e}");
        // The smooth conductor's sample weight is that Fresnel term.
        let b = Bsdf::conductor(eta, k, Rgb::ONE).unwrap();
        let w = b
            .sample(UV0, Vec3::Z, Default::default(), 0.5)
            .unwrap()
            .weight;
        assert!((w - e).abs().max_element() < 1e-5);
        // Grazing incidence reflects everything (metals dip a little before,
        // near their pseudo-Brewster angle, so no monotonicity).
        let g = fresnel_conductor(1e-6, eta, k);
        assert!(
            (g - Rgb::ONE).abs().max_element() < 1e-4,
            "{name}: grazing {g}"
        );
        let near = fresnel_conductor(89.9f32.to_radians().cos(), eta, k);
        assert!(
            near.cmpgt(e).all(),
            "{name}: {near} at 89.9 deg vs {e} at 0"
        );
        // Values in [0, 1].
        for i in 0..=100 {
            let c = fresnel_conductor(i as f32 / 100.0, eta, k);
            assert!(c.cmpge(Rgb::ZERO).all() && c.cmple(Rgb::splat(1.0 + 1e-6)).all());
        }
    }
    // A conductor with k = 0 is a dielectric.
    let (d, _, _) = fresnel_dielectric(0.3, 1.5);
    assert!((fresnel_conductor_1(0.3, 1.5, 0.0) - d).abs() < 1e-6);
}

/// A thin sheet reflects R' = R + T^2 R / (1 - R^2) (T = 1 - R, R at |cos|)
/// and transmits 1 - R' straight through, from both sides: the reflected
/// fraction passes a t-test against R', every weight is 1 (R' + T' = 1).
#[test]
fn thin_dielectric_reflects_r_prime_and_transmits_the_rest() {
    let b = Bsdf::thin_dielectric(BK7, AIR, Rgb::ONE, Rgb::ONE).unwrap();
    let angles = [0.0f32, 30.0, 60.0, 80.0, 89.0];
    let alpha = sidak(0.01, 2 * angles.len());
    let mut s = Sampler::new(3, 3);
    for below in [false, true] {
        for &t in &angles {
            let wi = dir(t, 70.0, below);
            let (r, _, _) = fresnel_dielectric(wi.z.abs(), BK7 / AIR);
            let tr = 1.0 - r;
            let r_prime = r + tr * tr * r / (1.0 - r * r);
            let mut refl = MeanVar::default();
            for _ in 0..40_000 {
                let x = b.sample(UV0, wi, s.next_2d(), s.next_1d()).unwrap();
                assert!(x.specular);
                assert_eq!(x.weight, Rgb::ONE);
                assert_eq!(x.eta, 1.0);
                let reflected = x.wo.z * wi.z > 0.0;
                if reflected {
                    assert!((x.wo - Vec3::new(-wi.x, -wi.y, wi.z)).length() < 1e-6);
                    assert!((x.pdf - r_prime).abs() < 1e-5);
                } else {
                    assert_eq!(x.wo, -wi);
                    assert!((x.pdf - (1.0 - r_prime)).abs() < 1e-5);
                }
                refl.push(if reflected { 1.0 } else { 0.0 });
            }
            let res = t_test(&refl, r_prime as f64);
            assert!(
                res.passes(alpha),
                "theta {t} below {below}: reflected {} vs R' {r_prime}",
                refl.mean()
            );
        }
    }
}

/// With white base and coating, Mitsuba's plastic keeps (almost) all
/// energy: its albedo is F_i + (1 - F_i)(1 - Fdr_ext) / (eta^2 (1 - Fdr_int)),
/// which the fits make one to within a percent.
#[test]
fn white_plastic_albedo() {
    let eta = 1.49 / AIR;
    let angles = [0.0f32, 45.0, 75.0];
    let alpha = sidak(0.01, 2 * angles.len());
    let mut s = Sampler::new(4, 4);
    for nonlinear in [false, true] {
        let b = Bsdf::plastic(1.49, AIR, Rgb::ONE, Rgb::ONE, nonlinear).unwrap();
        for &t in &angles {
            let wi = dir(t, 0.0, false);
            let (f_i, _, _) = fresnel_dielectric(wi.z, eta);
            let fdr_int = fresnel_diffuse_reflectance(1.0 / eta);
            let fdr_ext = fresnel_diffuse_reflectance(eta);
            let expect = f_i + (1.0 - f_i) * (1.0 - fdr_ext) / (eta * eta * (1.0 - fdr_int));
            assert!((expect - 1.0).abs() < 0.01, "expected albedo {expect}");
            let mut mv = MeanVar::default();
            for _ in 0..100_000 {
                let w = b
                    .sample(UV0, wi, s.next_2d(), s.next_1d())
                    .map_or(0.0, |x| x.weight.x);
                mv.push(w as f64);
            }
            let r = t_test(&mv, expect as f64);
            assert!(
                r.passes(alpha),
                "theta {t} nonlinear {nonlinear}: albedo {} vs {expect}, p {}",
                mv.mean(),
                r.p_value
            );
        }
    }
}

/// A nearly smooth rough dielectric loses almost no energy: reflection
/// plus transmission (with the eta^2 compensation) is within 2% of one,
/// from either side, and never above it.
#[test]
fn smooth_rough_dielectric_conserves_energy() {
    let mut s = Sampler::new(5, 5);
    for kind in [Beckmann, Ggx] {
        let b =
            Bsdf::rough_dielectric(kind, 0.02, 0.02, BK7, AIR, Rgb::ONE, Rgb::ONE, true).unwrap();
        for wi in [
            dir(0.0, 0.0, false),
            dir(40.0, 10.0, false),
            dir(70.0, 10.0, false),
            dir(20.0, 10.0, true),
            dir(60.0, 10.0, true),
        ] {
            let mut mv = MeanVar::default();
            for _ in 0..40_000 {
                let e = b
                    .sample(UV0, wi, s.next_2d(), s.next_1d())
                    .map_or(0.0, |x| x.weight.x * x.eta * x.eta);
                mv.push(e as f64);
            }
            let se = (mv.variance() / mv.n as f64).sqrt();
            assert!(
                mv.mean() > 0.98 && mv.mean() <= 1.0 + 4.0 * se + 1e-5,
                "{kind:?} wi {wi}: energy {} +- {se}",
                mv.mean()
            );
        }
    }
}

/// The sampling estimator of integral f |cos| dw (mean sample weight,
/// delta lobes excluded) agrees with a uniform-sphere estimator of the
/// same integral (Welch t-test), for every rough configuration with
/// roughness the uniform estimator can resolve.
#[test]
fn sampling_and_uniform_estimators_agree() {
    let cases: Vec<_> = rough_bsdfs()
        .into_iter()
        .flat_map(|(name, b, wis)| wis.into_iter().map(move |wi| (name.clone(), b.clone(), wi)))
        .filter(|(name, _, _)| !name.contains("aniso"))
        .collect();
    let alpha = sidak(0.01, cases.len() * 3);
    let mut s = Sampler::new(6, 6);
    let mut failures = Vec::new();
    for (name, b, wi) in &cases {
        let (mut a, mut u) = ([MeanVar::default(); 3], [MeanVar::default(); 3]);
        for _ in 0..200_000 {
            let w = b
                .sample(UV0, *wi, s.next_2d(), s.next_1d())
                .filter(|x| !x.specular)
                .map_or(Rgb::ZERO, |x| x.weight);
            let wo = warp::square_to_uniform_sphere(s.next_2d());
            let f = b.eval(UV0, *wi, wo) * wo.z.abs() / warp::square_to_uniform_sphere_pdf(wo);
            for c in 0..3 {
                a[c].push(w[c] as f64);
                u[c].push(f[c] as f64);
            }
        }
        for c in 0..3 {
            let r = welch_t_test(&a[c], &u[c]);
            if !r.passes(alpha) {
                failures.push(format!(
                    "{name} wi {wi} channel {c}: sampled {} vs uniform {} (p {:.2e})",
                    a[c].mean(),
                    u[c].mean(),
                    r.p_value
                ));
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// ... and the same comparison notices a 3% error (a weight that forgot
/// a factor): the test has power.
#[test]
fn estimator_comparison_detects_a_three_percent_error() {
    let (e, k) = metal("Cu");
    let b = Bsdf::rough_conductor(Ggx, 0.3, 0.3, e, k, Rgb::ONE, true).unwrap();
    let wi = dir(35.0, 40.0, false);
    let mut s = Sampler::new(7, 7);
    let (mut a, mut u) = (MeanVar::default(), MeanVar::default());
    for _ in 0..200_000 {
        let w = b
            .sample(UV0, wi, s.next_2d(), s.next_1d())
            .map_or(0.0, |x| x.weight.x);
        a.push(1.03 * w as f64);
        let wo = warp::square_to_uniform_hemisphere(s.next_2d());
        u.push((b.eval(UV0, wi, wo).x * wo.z / warp::square_to_uniform_hemisphere_pdf(wo)) as f64);
    }
    assert!(!welch_t_test(&a, &u).passes(0.01));
}

#[test]
fn twosided_mirrors_the_back_and_refuses_transmitters() {
    let (e, k) = metal("Cu");
    let front = Bsdf::rough_conductor(Ggx, 0.3, 0.3, e, k, Rgb::ONE, true).unwrap();
    let two = Bsdf::two_sided(front.clone(), None).unwrap();
    let flip = |v: Vec3| Vec3::new(v.x, v.y, -v.z);
    let wi = dir(40.0, 10.0, false);
    let wo = dir(30.0, 200.0, false);
    assert_eq!(two.eval(UV0, wi, wo), front.eval(UV0, wi, wo));
    assert_eq!(two.eval(UV0, flip(wi), flip(wo)), front.eval(UV0, wi, wo));
    assert_eq!(two.pdf(UV0, flip(wi), flip(wo)), front.pdf(UV0, wi, wo));
    assert_eq!(two.eval(UV0, flip(wi), wo), Rgb::ZERO);
    let mut s = Sampler::new(8, 8);
    for _ in 0..100 {
        let (u, ul) = (s.next_2d(), s.next_1d());
        let a = front.sample(UV0, wi, u, ul);
        let b = two.sample(UV0, flip(wi), u, ul);
        assert_eq!(a.map(|x| flip(x.wo)), b.map(|x| x.wo));
    }
    assert!(!two.is_specular());
    assert!(
        Bsdf::two_sided(Bsdf::conductor(e, k, Rgb::ONE).unwrap(), None)
            .unwrap()
            .is_specular()
    );
    // Mitsuba refuses to nest transmitting BSDFs.
    assert!(Bsdf::two_sided(Bsdf::dielectric(BK7, AIR).unwrap(), None).is_err());
    assert!(Bsdf::two_sided(
        Bsdf::thin_dielectric(BK7, AIR, Rgb::ONE, Rgb::ONE).unwrap(),
        None
    )
    .is_err());
    assert!(Bsdf::two_sided(
        front.clone(),
        Some(Bsdf::rough_dielectric(Ggx, 0.1, 0.1, BK7, AIR, Rgb::ONE, Rgb::ONE, true).unwrap())
    )
    .is_err());
}

#[test]
fn specular_flags() {
    let (e, k) = metal("Au");
    assert!(Bsdf::conductor(e, k, Rgb::ONE).unwrap().is_specular());
    assert!(Bsdf::thin_dielectric(BK7, AIR, Rgb::ONE, Rgb::ONE)
        .unwrap()
        .is_specular());
    // Plastic has a delta lobe and a smooth one: NEE must still run.
    assert!(!Bsdf::plastic(1.49, AIR, Rgb::splat(0.5), Rgb::ONE, false)
        .unwrap()
        .is_specular());
    assert!(!Bsdf::rough_conductor(Ggx, 0.1, 0.1, e, k, Rgb::ONE, true)
        .unwrap()
        .is_specular());
    assert!(
        !Bsdf::rough_dielectric(Ggx, 0.1, 0.1, BK7, AIR, Rgb::ONE, Rgb::ONE, true)
            .unwrap()
            .is_specular()
    );
}
