//! lente's Mitsuba-3 BSDFs against Mitsuba 3 itself: eval (as f |cos|),
//! pdf and sample (wo, weight, pdf, delta or not, eta) at fixed directions
//! and random numbers, for every new BSDF in several configurations, from
//! both sides. The reference rows, in tests/data/bsdf_mitsuba.txt, were
//! produced by Mitsuba 3.9.1 (PyPI wheel, variant `scalar_rgb`) with
//! tests/data/make_bsdf_mitsuba.py; "N" rows are samples Mitsuba rejects
//! (zero weight), which lente must reject too (None or zero weight). One
//! documented deviation: see [`mitsuba_bias`].

use crate::common::UV0;
use lente::bsdf::{conductor_preset, Bsdf, MicrofacetType, PrincipledThin, Roughness};
use lente::color::Rgb;
use lente::math::{Vec2, Vec3};
use lente::texture::Texture;

/// One row of the reference table (see tests/data/bsdf_mitsuba.txt).
#[derive(Debug)]
enum Row {
    E {
        name: String,
        wi: [f32; 3],
        wo: [f32; 3],
        f_cos: [f32; 3],
        pdf: f32,
    },
    S {
        name: String,
        wi: [f32; 3],
        u_lobe: f32,
        u: [f32; 2],
        wo: [f32; 3],
        weight: [f32; 3],
        pdf: f32,
        delta: bool,
        eta: f32,
    },
    N {
        name: String,
        wi: [f32; 3],
        u_lobe: f32,
        u: [f32; 2],
    },
}

/// The rows of tests/data/bsdf_mitsuba.txt.
fn rows() -> Vec<Row> {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/bsdf_mitsuba.txt");
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut rows = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let at = || format!("{}:{}", path.display(), i + 1);
        let fields: Vec<&str> = line.split_whitespace().collect();
        let num = |k: usize| -> f32 {
            fields
                .get(k)
                .and_then(|f| f.parse().ok())
                .unwrap_or_else(|| panic!("{}: field {k} is not a number", at()))
        };
        let v3 = |k: usize| [num(k), num(k + 1), num(k + 2)];
        let name = fields[1].to_string();
        let want = match fields[0] {
            "E" => 12,
            "S" => 17,
            "N" => 8,
            other => panic!("{}: unknown row kind '{other}'", at()),
        };
        assert_eq!(fields.len(), want, "{}: field count", at());
        rows.push(match fields[0] {
            "E" => Row::E {
                name,
                wi: v3(2),
                wo: v3(5),
                f_cos: v3(8),
                pdf: num(11),
            },
            "S" => Row::S {
                name,
                wi: v3(2),
                u_lobe: num(5),
                u: [num(6), num(7)],
                wo: v3(8),
                weight: v3(11),
                pdf: num(14),
                delta: fields[15] == "true",
                eta: num(16),
            },
            _ => Row::N {
                name,
                wi: v3(2),
                u_lobe: num(5),
                u: [num(6), num(7)],
            },
        });
    }
    rows
}

fn bsdf(name: &str) -> Bsdf {
    use MicrofacetType::{Beckmann, Ggx};
    let air = 1.000277;
    let bk7 = 1.5046;
    let one = Rgb::ONE;
    let metal = |m: &str| conductor_preset(m).unwrap();
    match name {
        "conductor_au" => {
            let (e, k) = metal("Au");
            Bsdf::conductor(e, k, one).unwrap()
        }
        "conductor_none" => {
            let (e, k) = metal("none");
            Bsdf::conductor(e, k, one).unwrap()
        }
        "rc_beck_cu" => {
            let (e, k) = metal("Cu");
            Bsdf::rough_conductor(Beckmann, 0.3, 0.3, e, k, one, true).unwrap()
        }
        "rc_ggx_aniso_au" => {
            let (e, k) = metal("Au");
            Bsdf::rough_conductor(Ggx, 0.1, 0.4, e, k, one, true).unwrap()
        }
        "rc_ggx_none_novis" => {
            let (e, k) = metal("none");
            Bsdf::rough_conductor(Ggx, 0.2, 0.2, e, k, one, false).unwrap()
        }
        "rc_beck_aniso_al_novis" => {
            let (e, k) = metal("Al");
            Bsdf::rough_conductor(Beckmann, 0.05, 0.2, e, k, Rgb::new(0.9, 0.8, 0.7), false)
                .unwrap()
        }
        "rd_beck" => Bsdf::rough_dielectric(Beckmann, 0.3, 0.3, bk7, air, one, one, true).unwrap(),
        "rd_ggx_aniso" => Bsdf::rough_dielectric(Ggx, 0.2, 0.5, 1.33, 1.0, one, one, true).unwrap(),
        "rd_ggx_novis" => Bsdf::rough_dielectric(
            Ggx,
            0.25,
            0.25,
            bk7,
            air,
            Rgb::new(0.9, 0.8, 0.7),
            Rgb::new(0.5, 0.6, 0.7),
            false,
        )
        .unwrap(),
        "rd_beck_novis" => {
            Bsdf::rough_dielectric(Beckmann, 0.15, 0.15, bk7, air, one, one, false).unwrap()
        }
        "thin" => Bsdf::thin_dielectric(bk7, air, one, one).unwrap(),
        "plastic" => Bsdf::plastic(1.49, air, Rgb::new(0.2, 0.5, 0.8), one, false).unwrap(),
        "plastic_nl" => {
            Bsdf::plastic(1.6, air, Rgb::new(0.6, 0.3, 0.1), Rgb::splat(0.7), true).unwrap()
        }
        "twosided_rc" => {
            let (e, k) = metal("Cu");
            Bsdf::two_sided(
                Bsdf::rough_conductor(Ggx, 0.3, 0.3, e, k, one, true).unwrap(),
                None,
            )
            .unwrap()
        }
        "twosided_pair" => {
            let (e, k) = metal("none");
            Bsdf::two_sided(
                Bsdf::Diffuse(lente::bsdf::Diffuse {
                    albedo: Rgb::new(0.3, 0.4, 0.5),
                }),
                Some(Bsdf::rough_conductor(Ggx, 0.2, 0.2, e, k, one, true).unwrap()),
            )
            .unwrap()
        }
        "dielectric" => Bsdf::dielectric(bk7, air).unwrap(),
        "roughplastic" => Bsdf::rough_plastic(
            Beckmann,
            0.1,
            1.49,
            air,
            Rgb::new(0.2, 0.5, 0.8),
            one,
            false,
            true,
        )
        .unwrap(),
        "roughplastic_ggx_nl" => Bsdf::rough_plastic(
            Ggx,
            0.3,
            1.6,
            air,
            Rgb::new(0.6, 0.3, 0.1),
            Rgb::splat(0.7),
            true,
            true,
        )
        .unwrap(),
        "roughplastic_novis" => {
            Bsdf::rough_plastic(Ggx, 0.2, 1.49, air, Rgb::splat(0.5), one, false, false).unwrap()
        }
        "pplastic" => Bsdf::polarized_plastic(
            Roughness::isotropic(Beckmann, 0.1, true),
            1.49,
            air,
            Rgb::new(0.2, 0.5, 0.8),
            one,
        )
        .unwrap(),
        "pplastic_ggx_aniso" => Bsdf::polarized_plastic(
            Roughness {
                distribution: Ggx,
                alpha_u: 0.1,
                alpha_v: 0.35,
                sample_visible: true,
            },
            1.6,
            air,
            Rgb::new(0.6, 0.3, 0.1),
            Rgb::splat(0.7),
        )
        .unwrap(),
        "pplastic_novis" => Bsdf::polarized_plastic(
            Roughness::isotropic(Beckmann, 0.2, false),
            1.33,
            1.0,
            Rgb::splat(0.5),
            one,
        )
        .unwrap(),
        "pthin_default" => thin(PrincipledThin { ..thin_defaults() }),
        "pthin_full" => thin(PrincipledThin {
            base_color: c(Rgb::new(0.7, 0.4, 0.2)),
            roughness: c(Rgb::splat(0.35)),
            spec_trans: Some(c(Rgb::splat(0.6))),
            diff_trans: Some(c(Rgb::splat(0.8))),
            sheen: Some(c(Rgb::splat(0.5))),
            sheen_tint: Some(c(Rgb::splat(0.3))),
            spec_tint: Some(c(Rgb::splat(0.4))),
            flatness: Some(c(Rgb::splat(0.3))),
            eta: c(Rgb::splat(1.4)),
            ..thin_defaults()
        }),
        "pthin_aniso" => thin(PrincipledThin {
            base_color: c(Rgb::new(0.3, 0.6, 0.9)),
            anisotropic: Some(c(Rgb::splat(0.6))),
            spec_trans: Some(c(Rgb::splat(1.0))),
            roughness: c(Rgb::splat(0.3)),
            eta: c(Rgb::splat(1.6)),
            spec_refl_rate: 2.0,
            ..thin_defaults()
        }),
        _ => panic!("unknown config {name}"),
    }
}

fn c(v: Rgb) -> Texture {
    Texture::Constant(v)
}

fn thin(b: PrincipledThin) -> Bsdf {
    Bsdf::PrincipledThin(Box::new(b))
}

/// `principledthin` with Mitsuba's defaults.
fn thin_defaults() -> PrincipledThin {
    PrincipledThin {
        base_color: c(Rgb::splat(0.5)),
        roughness: c(Rgb::splat(0.5)),
        anisotropic: None,
        spec_trans: None,
        sheen: None,
        sheen_tint: None,
        flatness: None,
        spec_tint: None,
        diff_trans: None,
        eta: c(Rgb::splat(1.5)),
        spec_refl_rate: 1.0,
        spec_trans_rate: 1.0,
        diff_refl_rate: 1.0,
        diff_trans_rate: 1.0,
    }
}

/// The one place lente deliberately differs from Mitsuba 3: `roughdielectric`
/// with `sample_visible = false` samples normals from a widened
/// distribution D' (Walter's trick) but Mitsuba's sample weight leaves out
/// D(m) / D'(m), so it disagrees with Mitsuba's own eval / pdf (a biased
/// estimator). lente's weight is eval |cos| / pdf; this returns the factor
/// D'(m) / D(m) that turns it into Mitsuba's (1 everywhere else).
fn mitsuba_bias(b: &Bsdf, wi: Vec3, wo: Vec3) -> f32 {
    let Bsdf::RoughDielectric(rd) = b else {
        return 1.0;
    };
    if rd.distr.sample_visible {
        return 1.0;
    }
    let reflect = wi.z * wo.z > 0.0;
    let eta = if wi.z > 0.0 { rd.eta } else { 1.0 / rd.eta };
    let mut m = (wi + wo * if reflect { 1.0 } else { eta }).normalize();
    if m.z < 0.0 {
        m = -m;
    }
    let widened = rd.distr.scaled(1.2 - 0.2 * wi.z.abs().sqrt());
    widened.d(m) / rd.distr.d(m)
}

fn close(a: f32, b: f32, rel: f32) -> bool {
    (a - b).abs() <= rel * a.abs().max(b.abs()) + 1e-6
}

fn close3(a: Vec3, b: [f32; 3], rel: f32) -> bool {
    (0..3).all(|i| close(a[i], b[i], rel))
}

#[test]
fn matches_mitsuba_3() {
    let rows = rows();
    assert!(rows.len() > 1100);
    let mut failures = Vec::new();
    let mut checked = 0;
    // Build each configuration once (roughplastic tabulates at construction).
    let mut cache = std::collections::HashMap::new();
    let mut bsdf = |name: &str| {
        cache
            .entry(name.to_string())
            .or_insert_with(|| bsdf(name))
            .clone()
    };
    for row in &rows {
        match row {
            Row::E {
                name,
                wi,
                wo,
                f_cos,
                pdf,
            } => {
                let (f_cos, pdf) = (*f_cos, *pdf);
                let b = bsdf(name);
                let (wi, wo) = (Vec3::from_array(*wi), Vec3::from_array(*wo));
                let f = b.eval(UV0, wi, wo) * wo.z.abs();
                let p = b.pdf(UV0, wi, wo);
                if !close3(f, f_cos, 2e-4) || !close(p, pdf, 2e-4) {
                    failures.push(format!(
                        "{name} eval wi {wi} wo {wo}: f|cos| {f} vs {f_cos:?}, pdf {p} vs {pdf}"
                    ));
                }
            }
            Row::S {
                name,
                wi,
                u_lobe,
                u,
                wo,
                weight,
                pdf,
                delta,
                eta,
            } => {
                let (wo, weight, pdf, delta, eta) = (*wo, *weight, *pdf, *delta, *eta);
                let (u, u_lobe) = (*u, *u_lobe);
                let b = bsdf(name);
                let wi = Vec3::from_array(*wi);
                let s = b.sample(UV0, wi, Vec2::from_array(u), u_lobe);
                let ok = s.is_some_and(|s| {
                    close3(s.wo, wo, 1e-3)
                        && close3(s.weight * mitsuba_bias(&b, wi, s.wo), weight, 2e-3)
                        && close(s.pdf, pdf, 2e-3)
                        && s.specular == delta
                        && close(s.eta, eta, 1e-6)
                });
                if !ok {
                    failures.push(format!(
                        "{name} sample wi {wi} u {u:?} {u_lobe}: got {s:?}, Mitsuba wo {wo:?} \
                         weight {weight:?} pdf {pdf} delta {delta} eta {eta}"
                    ));
                }
            }
            Row::N {
                name,
                wi,
                u_lobe,
                u,
            } => {
                let b = bsdf(name);
                let s = b.sample(UV0, Vec3::from_array(*wi), Vec2::from_array(*u), *u_lobe);
                if let Some(s) = s {
                    if s.weight.max_element() > 0.0 {
                        failures.push(format!(
                            "{name} sample wi {wi:?} u {u:?} {u_lobe}: Mitsuba rejects, got {s:?}"
                        ));
                    }
                }
            }
        }
        checked += 1;
    }
    assert!(
        failures.is_empty(),
        "{} of {checked} rows differ from Mitsuba 3:\n{}",
        failures.len(),
        failures.join("\n")
    );
}
