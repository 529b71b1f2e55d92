//! Chi-square tests of the Mitsuba-3 BSDFs' sample() against their pdf()
//! over the whole sphere (Sidak-corrected, alpha 0.01 for the family):
//! rough conductors and dielectrics with Beckmann and GGX, isotropic and
//! anisotropic, with and without visible-normal sampling, near-mirror
//! roughness (on finer grids), grazing incidence, dielectrics from outside
//! and inside; the smooth lobe of plastic; roughplastic; pplastic; twosided from
//! below; principled (every lobe, transmission from both sides);
//! principledthin (every lobe, from both sides). Plus the
//! tests that this test rejects wrong pdfs.

use crate::common::UV0;
use lente::bsdf::{conductor_preset, Bsdf, MicrofacetDistribution, MicrofacetType, Roughness};
use lente::color::Rgb;
use lente::math::Vec3;
use lente::stats::{sidak, sphere_histogram, Histogram};

use MicrofacetType::{Beckmann, Ggx};

const N: usize = 1_000_000;

/// Direction at polar angle `theta_deg` (measured from +z, or from -z when
/// `below`) and azimuth `phi_deg`.
fn dir(theta_deg: f32, phi_deg: f32, below: bool) -> Vec3 {
    let (t, p) = (theta_deg.to_radians(), phi_deg.to_radians());
    let z = if below { -t.cos() } else { t.cos() };
    Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), z)
}

struct Case {
    name: String,
    bsdf: Bsdf,
    wi: Vec3,
    /// Theta rows of the histogram (more for near-mirror lobes).
    rows: usize,
    cols: usize,
}

fn rc(kind: MicrofacetType, au: f32, av: f32, visible: bool) -> Bsdf {
    let (eta, k) = conductor_preset("Cu").unwrap();
    Bsdf::rough_conductor(kind, au, av, eta, k, Rgb::ONE, visible).unwrap()
}

fn rd(kind: MicrofacetType, au: f32, av: f32, visible: bool) -> Bsdf {
    Bsdf::rough_dielectric(kind, au, av, 1.5046, 1.000277, Rgb::ONE, Rgb::ONE, visible).unwrap()
}

fn case(name: &str, bsdf: Bsdf, wi: Vec3, rows: usize, cols: usize) -> Case {
    Case {
        name: name.to_string(),
        bsdf,
        wi,
        rows,
        cols,
    }
}

/// Histogram of the non-delta samples against pdf(); delta samples (the
/// plastic's coating) count nowhere, like rejected ones, and pdf() does not
/// include them either.
fn histogram(c: &Case, seed: u64) -> Histogram {
    sphere_histogram(
        c.rows,
        c.cols,
        N,
        seed,
        |s| {
            c.bsdf
                .sample(UV0, c.wi, s.next_2d(), s.next_1d())
                .filter(|b| !b.specular)
                .map(|b| b.wo)
        },
        |wo| c.bsdf.pdf(UV0, c.wi, wo) as f64,
    )
}

fn run(cases: &[Case], family: usize, seed: u64) {
    let alpha = sidak(0.01, family);
    let mut failures = Vec::new();
    for (i, c) in cases.iter().enumerate() {
        let r = histogram(c, seed + i as u64).test(5.0);
        if !r.passes(alpha) {
            failures.push(format!(
                "{}: chi2 {:.1}, dof {}, p {:.2e}",
                c.name, r.statistic, r.dof, r.p_value
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Grazing incidence from inside glass (about 87 degrees). Light leaves
/// only if the generalised half vector wi + wo / eta can point up, i.e. for
/// cos theta_o < |cos theta_i| eta: the transmitted density ends there with
/// a jump. Midpoint integration cannot resolve a jump inside a cell, so the
/// angle is chosen to put the edge on a row boundary (85.5 degrees with 40
/// rows) instead of 0.015 degrees beside it, as 87.0 exactly would.
fn grazing_inside() -> Vec3 {
    let eta = 1.000277f32 / 1.5046;
    let cos_i = eta * 85.5f32.to_radians().cos();
    dir(cos_i.acos().to_degrees(), 300.0, true)
}

/// Total number of chi-square tests that must pass, across this file.
const FAMILY: usize = 51;

#[test]
fn rough_conductor_sampling_matches_pdf() {
    let cases = [
        case(
            "beckmann 0.3 vis",
            rc(Beckmann, 0.3, 0.3, true),
            dir(30.0, 20.0, false),
            30,
            60,
        ),
        case(
            "ggx 0.3 vis",
            rc(Ggx, 0.3, 0.3, true),
            dir(60.0, 110.0, false),
            30,
            60,
        ),
        case(
            "ggx 0.6 all",
            rc(Ggx, 0.6, 0.6, false),
            dir(10.0, 0.0, false),
            30,
            60,
        ),
        case(
            "ggx aniso vis",
            rc(Ggx, 0.1, 0.4, true),
            dir(45.0, 30.0, false),
            40,
            80,
        ),
        case(
            "beckmann aniso vis",
            rc(Beckmann, 0.4, 0.15, true),
            dir(50.0, 250.0, false),
            40,
            80,
        ),
        case(
            "beckmann aniso all",
            rc(Beckmann, 0.4, 0.1, false),
            dir(45.0, 60.0, false),
            40,
            80,
        ),
        case(
            "ggx aniso all",
            rc(Ggx, 0.25, 0.05, false),
            dir(35.0, 160.0, false),
            60,
            120,
        ),
        case(
            "ggx 0.03 vis (near mirror)",
            rc(Ggx, 0.03, 0.03, true),
            dir(20.0, 45.0, false),
            180,
            120,
        ),
        case(
            "beckmann 0.02 vis (near mirror)",
            rc(Beckmann, 0.02, 0.02, true),
            dir(40.0, 200.0, false),
            180,
            120,
        ),
        case(
            "beckmann 0.05 all (near mirror)",
            rc(Beckmann, 0.05, 0.05, false),
            dir(25.0, 300.0, false),
            120,
            120,
        ),
        case(
            "ggx 0.2 vis grazing 85",
            rc(Ggx, 0.2, 0.2, true),
            dir(85.0, 10.0, false),
            40,
            80,
        ),
        case(
            "beckmann 0.5 vis grazing 88",
            rc(Beckmann, 0.5, 0.5, true),
            dir(88.0, 90.0, false),
            30,
            60,
        ),
        case(
            "beckmann 0.3 all grazing 80",
            rc(Beckmann, 0.3, 0.3, false),
            dir(80.0, 0.0, false),
            30,
            60,
        ),
    ];
    run(&cases, FAMILY, 1000);
}

#[test]
fn rough_dielectric_sampling_matches_pdf() {
    let cases = [
        case(
            "beckmann 0.3 vis outside",
            rd(Beckmann, 0.3, 0.3, true),
            dir(30.0, 20.0, false),
            40,
            60,
        ),
        case(
            "ggx 0.3 vis inside",
            rd(Ggx, 0.3, 0.3, true),
            dir(30.0, 70.0, true),
            40,
            60,
        ),
        case(
            "ggx 0.3 vis inside beyond TIR",
            rd(Ggx, 0.3, 0.3, true),
            dir(60.0, 200.0, true),
            40,
            60,
        ),
        case(
            "beckmann 0.2 vis inside",
            rd(Beckmann, 0.2, 0.2, true),
            dir(10.0, 0.0, true),
            40,
            60,
        ),
        case(
            "ggx aniso vis outside",
            rd(Ggx, 0.1, 0.4, true),
            dir(50.0, 30.0, false),
            60,
            80,
        ),
        case(
            "beckmann aniso vis inside",
            rd(Beckmann, 0.35, 0.1, true),
            dir(25.0, 130.0, true),
            60,
            80,
        ),
        case(
            "beckmann 0.2 all outside",
            rd(Beckmann, 0.2, 0.2, false),
            dir(45.0, 0.0, false),
            40,
            60,
        ),
        case(
            "ggx 0.2 all inside",
            rd(Ggx, 0.2, 0.2, false),
            dir(20.0, 300.0, true),
            40,
            60,
        ),
        case(
            "ggx aniso all outside",
            rd(Ggx, 0.3, 0.1, false),
            dir(40.0, 80.0, false),
            60,
            80,
        ),
        case(
            "ggx 0.04 vis outside (near mirror)",
            rd(Ggx, 0.04, 0.04, true),
            dir(35.0, 100.0, false),
            180,
            120,
        ),
        case(
            "beckmann 0.03 vis inside (near mirror)",
            rd(Beckmann, 0.03, 0.03, true),
            dir(20.0, 10.0, true),
            180,
            120,
        ),
        case(
            "beckmann 0.3 vis grazing 85",
            rd(Beckmann, 0.3, 0.3, true),
            dir(85.0, 45.0, false),
            40,
            60,
        ),
        case(
            "ggx 0.5 vis grazing 87 inside",
            rd(Ggx, 0.5, 0.5, true),
            grazing_inside(),
            40,
            60,
        ),
        case(
            "ggx 0.3 vis, eta < 1 (bubble)",
            Bsdf::rough_dielectric(Ggx, 0.3, 0.3, 1.0, 1.33, Rgb::ONE, Rgb::ONE, true).unwrap(),
            dir(40.0, 0.0, false),
            40,
            60,
        ),
    ];
    run(&cases, FAMILY, 2000);
}

#[test]
fn plastics_and_twosided_sampling_match_pdf() {
    let (eta, k) = conductor_preset("Au").unwrap();
    let cases = [
        case(
            "plastic smooth lobe, normal",
            Bsdf::plastic(1.49, 1.000277, Rgb::new(0.2, 0.5, 0.8), Rgb::ONE, false).unwrap(),
            dir(10.0, 0.0, false),
            20,
            40,
        ),
        case(
            "plastic smooth lobe, grazing, nonlinear",
            Bsdf::plastic(1.6, 1.0, Rgb::new(0.9, 0.1, 0.1), Rgb::splat(0.5), true).unwrap(),
            dir(75.0, 40.0, false),
            20,
            40,
        ),
        case(
            "twosided roughconductor from below",
            Bsdf::two_sided(
                Bsdf::rough_conductor(Ggx, 0.2, 0.4, eta, k, Rgb::ONE, true).unwrap(),
                None,
            )
            .unwrap(),
            dir(30.0, 60.0, true),
            40,
            80,
        ),
        case(
            "twosided plastic from below",
            Bsdf::two_sided(
                Bsdf::plastic(1.49, 1.0, Rgb::splat(0.5), Rgb::ONE, false).unwrap(),
                None,
            )
            .unwrap(),
            dir(50.0, 60.0, true),
            20,
            40,
        ),
        case(
            "roughplastic beckmann 0.1",
            Bsdf::rough_plastic(
                Beckmann,
                0.1,
                1.49,
                1.000277,
                Rgb::splat(0.5),
                Rgb::ONE,
                false,
                true,
            )
            .unwrap(),
            dir(30.0, 0.0, false),
            60,
            80,
        ),
        case(
            "pplastic ggx anisotropic 0.08 / 0.4",
            Bsdf::polarized_plastic(
                Roughness {
                    distribution: Ggx,
                    alpha_u: 0.08,
                    alpha_v: 0.4,
                    sample_visible: true,
                },
                1.6,
                1.0,
                Rgb::new(0.1, 0.5, 0.2),
                Rgb::new(0.9, 0.8, 0.6),
            )
            .unwrap(),
            dir(40.0, 30.0, false),
            60,
            80,
        ),
        case(
            "pplastic beckmann 0.3 all normals, grazing",
            Bsdf::polarized_plastic(
                Roughness::isotropic(Beckmann, 0.3, false),
                1.33,
                1.0,
                Rgb::splat(0.4),
                Rgb::ONE,
            )
            .unwrap(),
            dir(75.0, 200.0, false),
            30,
            60,
        ),
        case(
            "roughplastic ggx 0.3 all normals, grazing",
            Bsdf::rough_plastic(
                Ggx,
                0.3,
                1.6,
                1.0,
                Rgb::new(0.1, 0.5, 0.9),
                Rgb::ONE,
                true,
                false,
            )
            .unwrap(),
            dir(70.0, 120.0, false),
            30,
            60,
        ),
    ];
    run(&cases, FAMILY, 3000);
    // Sanity: the plastic's delta lobe is sampled, and flagged.
    let p = Bsdf::plastic(1.49, 1.0, Rgb::splat(0.5), Rgb::ONE, false).unwrap();
    let mut s = lente::sampling::Sampler::new(9, 9);
    let wi = dir(70.0, 0.0, false);
    let spec = (0..10_000)
        .filter_map(|_| p.sample(UV0, wi, s.next_2d(), s.next_1d()))
        .filter(|b| b.specular)
        .count();
    assert!(spec > 500, "delta lobe sampled {spec} times");
}

/// A mask: its nested lobe against pdf() (which is the nested pdf times
/// the opacity), and the pass-through: straight on, weight 1, as often as
/// 1 - opacity says (a binomial z-test at 4.4 sigma).
#[test]
fn mask_sampling_matches_pdf() {
    let (eta, k) = conductor_preset("Cu").unwrap();
    let rough = Bsdf::rough_conductor(Ggx, 0.3, 0.3, eta, k, Rgb::ONE, true).unwrap();
    let opacity = |a: f32| lente::texture::Texture::Constant(Rgb::splat(a));
    let cases = [
        case(
            "mask 0.3 over roughconductor",
            Bsdf::mask(opacity(0.3), rough.clone()).unwrap(),
            dir(40.0, 10.0, false),
            30,
            60,
        ),
        case(
            "mask 0.8 over twosided roughplastic, from below",
            Bsdf::mask(
                opacity(0.8),
                Bsdf::two_sided(
                    Bsdf::rough_plastic(
                        Beckmann,
                        0.2,
                        1.5,
                        1.0,
                        Rgb::splat(0.5),
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
            dir(60.0, 200.0, true),
            30,
            60,
        ),
    ];
    run(&cases, FAMILY, 4000);
    let m = Bsdf::mask(opacity(0.3), rough).unwrap();
    let wi = dir(40.0, 10.0, false);
    let mut s = lente::sampling::Sampler::new(5, 5);
    let n = 200_000;
    let mut through = 0usize;
    for _ in 0..n {
        // (None: a nested sample below the horizon.)
        let Some(b) = m.sample(UV0, wi, s.next_2d(), s.next_1d()) else {
            continue;
        };
        if b.specular {
            through += 1;
            assert_eq!((b.wo, b.weight, b.eta), (-wi, Rgb::ONE, 1.0));
            assert!((b.pdf - 0.7).abs() < 1e-6);
        }
    }
    let p = 0.7;
    let z = (through as f64 - n as f64 * p) / (n as f64 * p * (1.0 - p)).sqrt();
    assert!(z.abs() < 4.4, "pass-through {through} of {n}: z = {z:.2}");
}

/// blendbsdf's mixture density (one BSDF chosen by the weight, the
/// mixture's pdf returned) and normalmap's tilted frames (a constant tilt,
/// one that the flip mirrors for this wi, and a normal map over a
/// twosided BSDF seen from below) against their pdf().
#[test]
fn blend_and_normal_map_sampling_match_pdf() {
    use lente::texture::Texture;
    let constant = |c: Rgb| Texture::Constant(c);
    let plastic = Bsdf::rough_plastic(
        Beckmann,
        0.2,
        1.5,
        1.0,
        Rgb::splat(0.5),
        Rgb::ONE,
        false,
        true,
    )
    .unwrap();
    // Normals are stored as (n + 1) / 2.
    let tilt = |n: Vec3| constant((n.normalize() + Vec3::ONE) * 0.5);
    let cases = [
        case(
            "blend 0.3 diffuse / roughconductor",
            Bsdf::blend(
                constant(Rgb::splat(0.3)),
                Bsdf::diffuse(Rgb::splat(0.7)).unwrap(),
                rc(Ggx, 0.15, 0.15, true),
            )
            .unwrap(),
            dir(40.0, 10.0, false),
            40,
            80,
        ),
        case(
            "blend 0.6 roughdielectric / roughplastic, from below",
            Bsdf::blend(
                constant(Rgb::splat(0.6)),
                rd(Ggx, 0.3, 0.3, true),
                plastic.clone(),
            )
            .unwrap(),
            dir(30.0, 100.0, true),
            40,
            80,
        ),
        case(
            "normalmap tilted 25 degrees over roughplastic",
            Bsdf::normal_map(tilt(Vec3::new(0.4, 0.2, 0.9)), plastic.clone(), true, true).unwrap(),
            dir(50.0, 30.0, false),
            40,
            80,
        ),
        case(
            "normalmap flipped for wi, over roughconductor, no shadowing",
            Bsdf::normal_map(
                tilt(Vec3::new(-0.7, 0.1, 0.7)),
                rc(Beckmann, 0.3, 0.3, true),
                true,
                false,
            )
            .unwrap(),
            dir(60.0, 0.0, false),
            40,
            80,
        ),
        case(
            "twosided normalmap diffuse from below",
            Bsdf::two_sided(
                Bsdf::normal_map(
                    tilt(Vec3::new(0.3, -0.3, 0.9)),
                    Bsdf::diffuse(Rgb::splat(0.5)).unwrap(),
                    true,
                    true,
                )
                .unwrap(),
                None,
            )
            .unwrap(),
            dir(45.0, 250.0, true),
            30,
            60,
        ),
    ];
    run(&cases, FAMILY, 5000);
}

/// The Zaragoza Nori fork's roughconductor (Beckmann normals) and
/// roughsubstrate (coating chosen with probability F(cos θi), else a
/// cosine-weighted direction).
#[test]
fn nori_fork_bsdf_sampling_matches_pdf() {
    use lente::bsdf::{RoughSubstrate, SchlickConductor};
    let cases = [
        case(
            "zaragoza roughconductor 0.2",
            Bsdf::SchlickConductor(SchlickConductor::new(0.2, Rgb::new(0.9, 0.6, 0.3)).unwrap()),
            dir(45.0, 20.0, false),
            40,
            80,
        ),
        case(
            "zaragoza roughsubstrate 0.15, grazing",
            Bsdf::RoughSubstrate(
                RoughSubstrate::new(0.15, 1.5046, 1.000277, Rgb::new(0.2, 0.5, 0.8)).unwrap(),
            ),
            dir(75.0, 200.0, false),
            40,
            80,
        ),
    ];
    run(&cases, FAMILY, 6000);
}

/// Every sample of each case carries the density `pdf` gives its
/// direction and the weight eval cos / pdf (of the whole mixture), and
/// most draws give one.
fn weights_are_eval_over_pdf(cases: &[Case], seed: u64) {
    let mut s = lente::sampling::Sampler::new(3, seed);
    for c in cases {
        let mut n = 0;
        for _ in 0..20_000 {
            let Some(x) = c.bsdf.sample(UV0, c.wi, s.next_2d(), s.next_1d()) else {
                continue;
            };
            n += 1;
            let pdf = c.bsdf.pdf(UV0, c.wi, x.wo);
            let expect = c.bsdf.eval(UV0, c.wi, x.wo) * x.wo.z.abs() / pdf;
            assert!(
                (x.pdf - pdf).abs() <= 1e-4 * pdf,
                "{}: pdf {} vs {pdf}",
                c.name,
                x.pdf
            );
            assert!(
                (x.weight - expect).abs().max_element() <= 1e-4 * expect.max_element(),
                "{}: weight {} vs {expect}",
                c.name,
                x.weight
            );
        }
        assert!(n > 10_000, "{}: only {n} samples", c.name);
    }
}

/// Mitsuba's principled with numbers for its parameters (None: absent).
fn principled(roughness: f32, extra: &[(&str, f32)], eta: f32) -> lente::bsdf::Principled {
    use lente::texture::Texture;
    let get = |name: &str| {
        extra
            .iter()
            .find(|(n, _)| *n == name)
            .map(|&(_, v)| Texture::Constant(Rgb::splat(v)))
    };
    lente::bsdf::Principled {
        base_color: Texture::Constant(Rgb::new(0.7, 0.4, 0.2)),
        roughness: Texture::Constant(Rgb::splat(roughness)),
        anisotropic: get("anisotropic"),
        spec_trans: get("spec_trans"),
        sheen: get("sheen"),
        sheen_tint: get("sheen_tint"),
        flatness: get("flatness"),
        spec_tint: get("spec_tint"),
        metallic: get("metallic"),
        clearcoat: get("clearcoat"),
        clearcoat_gloss: get("clearcoat_gloss").unwrap_or(Texture::Constant(Rgb::ZERO)),
        eta,
        spec_rate: 1.0,
        clearcoat_rate: 1.0,
        diffuse_rate: 1.0,
    }
}

/// Principled: diffuse, clearcoat and specular lobes from outside, with
/// anisotropy; transmission from outside and inside; a near-mirror
/// clearcoat on a finer grid. And every sample's weight is eval cos / pdf
/// of the whole mixture, with pdf() its density.
#[test]
fn principled_sampling_matches_pdf() {
    let every = [
        ("metallic", 0.4),
        ("clearcoat", 0.8),
        ("clearcoat_gloss", 0.5),
        ("sheen", 0.5),
        ("anisotropic", 0.7),
        ("spec_tint", 0.3),
    ];
    let glass = [("spec_trans", 0.8), ("metallic", 0.1)];
    let boxed = |p| Bsdf::Principled(Box::new(p));
    let cases = [
        case(
            "principled, every reflection lobe",
            boxed(principled(0.4, &every, 1.5)),
            dir(40.0, 30.0, false),
            40,
            80,
        ),
        case(
            "principled transmission from outside, grazing",
            boxed(principled(0.3, &glass, 1.45)),
            dir(75.0, 100.0, false),
            40,
            80,
        ),
        case(
            "principled transmission from inside",
            boxed(principled(0.35, &glass, 1.45)),
            dir(30.0, 250.0, true),
            40,
            80,
        ),
        case(
            "principled glossy clearcoat",
            boxed(principled(
                0.2,
                &[("clearcoat", 1.0), ("clearcoat_gloss", 0.9)],
                1.5,
            )),
            dir(20.0, 0.0, false),
            80,
            120,
        ),
    ];
    run(&cases, FAMILY, 7000);

    weights_are_eval_over_pdf(&cases, 3);
}

/// Mitsuba's principledthin with numbers for its parameters (None:
/// absent).
fn principled_thin(roughness: f32, extra: &[(&str, f32)], eta: f32) -> Bsdf {
    use lente::texture::Texture;
    let get = |name: &str| {
        extra
            .iter()
            .find(|(n, _)| *n == name)
            .map(|&(_, v)| Texture::Constant(Rgb::splat(v)))
    };
    Bsdf::PrincipledThin(Box::new(lente::bsdf::PrincipledThin {
        base_color: Texture::Constant(Rgb::new(0.7, 0.4, 0.2)),
        roughness: Texture::Constant(Rgb::splat(roughness)),
        anisotropic: get("anisotropic"),
        spec_trans: get("spec_trans"),
        sheen: get("sheen"),
        sheen_tint: get("sheen_tint"),
        flatness: get("flatness"),
        spec_tint: get("spec_tint"),
        diff_trans: get("diff_trans"),
        eta: Texture::Constant(Rgb::splat(eta)),
        spec_refl_rate: 1.0,
        spec_trans_rate: 1.0,
        diff_refl_rate: 1.0,
        diff_trans_rate: 1.0,
    }))
}

/// Principledthin: every lobe (specular reflection and transmission
/// through the sheet, diffuse reflection and transmission) from the front
/// and, mirrored, from the back; anisotropic and nearly specular; and
/// every sample's weight is eval cos / pdf of the whole mixture.
#[test]
fn principled_thin_sampling_matches_pdf() {
    let every = [
        ("spec_trans", 0.5),
        ("diff_trans", 0.9),
        ("sheen", 0.5),
        ("spec_tint", 0.3),
        ("flatness", 0.4),
    ];
    let cases = [
        case(
            "principledthin, every lobe",
            principled_thin(0.4, &every, 1.5),
            dir(40.0, 30.0, false),
            40,
            80,
        ),
        case(
            "principledthin from the back, grazing",
            principled_thin(0.3, &every, 1.3),
            dir(70.0, 200.0, true),
            40,
            80,
        ),
        case(
            "principledthin anisotropic, specular only",
            principled_thin(0.25, &[("spec_trans", 1.0), ("anisotropic", 0.7)], 1.6),
            dir(25.0, 60.0, false),
            60,
            100,
        ),
    ];
    run(&cases, FAMILY, 7100);
    weights_are_eval_over_pdf(&cases, 4);
}

#[test]
fn two_test_seeds_for_anisotropic_beckmann_vndf() {
    // Jakob's numerical inversion is the most intricate sampler here: test
    // it at a second incidence and seed, strongly anisotropic.
    let cases = [
        case(
            "beckmann 0.05/0.5 vis",
            rc(Beckmann, 0.05, 0.5, true),
            dir(70.0, 45.0, false),
            60,
            120,
        ),
        case(
            "beckmann 0.5/0.05 vis",
            rd(Beckmann, 0.5, 0.05, true),
            dir(55.0, 135.0, true),
            60,
            120,
        ),
    ];
    run(&cases, FAMILY, 4000);
}

type Pdf<'a> = Box<dyn Fn(Vec3) -> f64 + 'a>;

/// The chi-square test must reject pdfs that are wrong: GGX's D without
/// its 1/(pi alpha_u alpha_v) normalisation; a roughness 5% off; the
/// visible-normal density missing its G1(wi) factor; Beckmann's pdf for
/// GGX samples.
#[test]
fn chi2_rejects_wrong_pdfs() {
    let wi = dir(60.0, 30.0, false);
    let d = MicrofacetDistribution::new(Ggx, 0.3, 0.3, true);
    let b = rc(Ggx, 0.3, 0.3, true);
    let sample = |s: &mut lente::sampling::Sampler| {
        b.sample(UV0, wi, s.next_2d(), s.next_1d()).map(|x| x.wo)
    };
    let half = |wo: Vec3| (wi + wo).normalize();
    let wrong: [(&str, Pdf); 4] = [
        (
            "GGX D without normalisation",
            Box::new(|wo: Vec3| {
                let m = half(wo);
                let dn = d.d(m) * std::f32::consts::PI * 0.3 * 0.3;
                if wo.z <= 0.0 {
                    0.0
                } else {
                    (dn * d.smith_g1(wi, m) / (4.0 * wi.z)) as f64
                }
            }),
        ),
        (
            "alpha 5% too large",
            Box::new(|wo: Vec3| rc(Ggx, 0.315, 0.315, true).pdf(UV0, wi, wo) as f64),
        ),
        (
            "visible pdf without G1(wi)",
            Box::new(|wo: Vec3| {
                let m = half(wo);
                if wo.z <= 0.0 || wo.dot(m) <= 0.0 {
                    0.0
                } else {
                    (d.d(m) / (4.0 * wi.z)) as f64
                }
            }),
        ),
        (
            "Beckmann pdf for GGX samples",
            Box::new(|wo: Vec3| rc(Beckmann, 0.3, 0.3, true).pdf(UV0, wi, wo) as f64),
        ),
    ];
    for (i, (name, pdf)) in wrong.iter().enumerate() {
        let h = sphere_histogram(30, 60, N, 5000 + i as u64, sample, pdf);
        let r = h.test(5.0);
        assert!(
            !r.passes(0.01),
            "{name} accepted: chi2 {}, p {}",
            r.statistic,
            r.p_value
        );
    }
    // ... while the right one passes with the same samples.
    let h = sphere_histogram(30, 60, N, 5000, sample, |wo| b.pdf(UV0, wi, wo) as f64);
    assert!(h.test(5.0).passes(0.01));
}
