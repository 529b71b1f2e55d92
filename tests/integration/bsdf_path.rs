//! The path tracer with the Mitsuba-3 BSDFs: BSDF sampling (mats), emitter
//! sampling (ems) and MIS must estimate the same image. This exercises
//! path.rs's handling of each BSDF: plastic mixes a delta lobe (after which
//! emission counts fully and MIS is skipped) with a smooth one (NEE + MIS
//! on its pdf, which excludes the delta); roughplastic, rough conductors
//! and rough glass
//! go through NEE and MIS with their eval/pdf, glass from both sides.

use crate::common::*;
use lente::bsdf::{conductor_preset, Bsdf, MicrofacetType};
use lente::color::Rgb;
use lente::emitter::Emitter;
use lente::integrator::Strategy;
use lente::math::Vec3;
use lente::stats::{sidak, welch_t_test};

/// A ball with `bsdf` filling the view, a grey floor-ball below it for
/// indirect light, under a constant sky (whose emitter sampling keeps the
/// NEE-only estimator's variance bounded, so every comparison has power).
fn scene(bsdf: Bsdf, strategy: Strategy) -> TestScene {
    let mut d = desc(
        look_at(Vec3::ZERO, Vec3::new(0.0, 0.0, 4.0), 30.0, 16, 16),
        path(strategy),
    );
    d.shapes
        .push(shape(sphere(Vec3::new(0.0, 0.0, 4.0), 1.0), bsdf, None));
    d.shapes.push(shape(
        sphere(Vec3::new(0.0, -101.5, 4.0), 100.0),
        diffuse(0.5),
        None,
    ));
    d.emitters
        .push(Emitter::Constant(lente::emitter::ConstantLight {
            radiance: Rgb::ONE,
        }));
    d.build()
}

#[test]
fn strategies_agree_for_each_bsdf() {
    let (au_e, au_k) = conductor_preset("Au").unwrap();
    let bsdfs = [
        (
            "plastic",
            Bsdf::plastic(1.49, 1.000277, Rgb::new(0.05, 0.1, 0.15), Rgb::ONE, false).unwrap(),
        ),
        (
            "roughconductor ggx 0.3",
            Bsdf::rough_conductor(MicrofacetType::Ggx, 0.3, 0.3, au_e, au_k, Rgb::ONE, true)
                .unwrap(),
        ),
        (
            "roughdielectric beckmann 0.2",
            Bsdf::rough_dielectric(
                MicrofacetType::Beckmann,
                0.2,
                0.2,
                1.5046,
                1.000277,
                Rgb::ONE,
                Rgb::ONE,
                true,
            )
            .unwrap(),
        ),
        (
            "roughplastic ggx 0.2",
            Bsdf::rough_plastic(
                MicrofacetType::Ggx,
                0.2,
                1.49,
                1.000277,
                Rgb::new(0.05, 0.1, 0.15),
                Rgb::ONE,
                false,
                true,
            )
            .unwrap(),
        ),
        (
            "twosided plastic",
            Bsdf::two_sided(
                Bsdf::plastic(1.6, 1.0, Rgb::splat(0.1), Rgb::ONE, true).unwrap(),
                None,
            )
            .unwrap(),
        ),
    ];
    let alpha = sidak(0.01, 2 * bsdfs.len());
    let mut failures = Vec::new();
    for (i, (name, b)) in bsdfs.iter().enumerate() {
        let n = 100_000;
        let seed = 100 * i as u64;
        let mats = estimate(&scene(b.clone(), Strategy::Mats), n, seed);
        let ems = estimate(&scene(b.clone(), Strategy::Ems), n, seed + 1);
        let mis = estimate(&scene(b.clone(), Strategy::Mis), n, seed + 2);
        for (other, mv) in [("mats", &mats), ("ems", &ems)] {
            let r = welch_t_test(mv, &mis);
            if !r.passes(alpha) {
                failures.push(format!(
                    "{name}: {other} {} vs mis {} (p {:.2e})",
                    mv.mean(),
                    mis.mean(),
                    r.p_value
                ));
            }
        }
        // MIS should not be worse than the worse of the two.
        assert!(mis.variance() <= mats.variance().max(ems.variance()) * 1.05);
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
