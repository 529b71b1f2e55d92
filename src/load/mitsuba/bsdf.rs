//! BSDFs: Mitsuba's diffuse, dielectrics, conductors, plastics and
//! twosided, read with all their parameters into a [`BsdfSpec`];
//! [`BsdfSpec::build`] makes the lente BSDF (Mitsuba's own models), and
//! [`BsdfSpec::approximation`] names what it cannot reproduce, for a
//! warning.

use super::Ctx;
use crate::bsdf::presets::{conductor_preset_names, ior_preset_names};
use crate::bsdf::{conductor_preset, ior_preset, Bsdf, MicrofacetType};
use crate::color::Rgb;
use crate::load::props::{Kind, Props};
use crate::load::xml::{describe, Pos, SceneNode};
use crate::load::SceneError;

type Result<T> = std::result::Result<T, SceneError>;

impl<'d> Ctx<'d> {
    /// The lente BSDF for a spec. Rough plastics build tables (up to half a
    /// second): shapes that share one (by reference or by equal
    /// parameters) share the build.
    pub(super) fn build_bsdf(&mut self, spec: &BsdfSpec, at: Pos) -> Result<Bsdf> {
        if let Some((_, b)) = self.built.iter().find(|(s, _)| s == spec) {
            return Ok(b.clone());
        }
        let b = spec.build().map_err(|e| self.err(at, e))?;
        if spec.has_tables() {
            self.built.push((spec.clone(), b.clone()));
        }
        Ok(b)
    }

    /// Mitsuba's BSDFs with their parameters and defaults (`bsdfs/*.cpp`).
    pub(super) fn bsdf(&mut self, node: &'d SceneNode) -> Result<BsdfSpec> {
        let ty = self.object_type(
            node,
            &[
                "diffuse",
                "dielectric",
                "thindielectric",
                "roughdielectric",
                "conductor",
                "roughconductor",
                "plastic",
                "roughplastic",
                "twosided",
            ],
            &[
                "principled",
                "principledthin",
                "blendbsdf",
                "mask",
                "bumpmap",
                "normalmap",
                "hair",
                "measured",
                "pplastic",
                "polarizer",
                "retarder",
                "circular",
                "null",
            ],
        )?;
        let owner = format!("<bsdf type=\"{ty}\">");
        let (mut p, children) = self.read_object(node, &owner)?;
        let spec = match ty {
            "diffuse" => BsdfSpec::Diffuse {
                reflectance: p.get_rgb_or_float("reflectance", Rgb::splat(0.5))?,
            },
            "dielectric" | "thindielectric" | "roughdielectric" => {
                let int_ior = ior(&mut p, "int_ior", 1.5046)?;
                let ext_ior = ior(&mut p, "ext_ior", 1.000277)?;
                let specular_reflectance = p.get_rgb_or_float("specular_reflectance", Rgb::ONE)?;
                let specular_transmittance =
                    p.get_rgb_or_float("specular_transmittance", Rgb::ONE)?;
                let d = DielectricParams {
                    int_ior,
                    ext_ior,
                    specular_reflectance,
                    specular_transmittance,
                };
                match ty {
                    "dielectric" => BsdfSpec::Dielectric(d),
                    "thindielectric" => BsdfSpec::ThinDielectric(d),
                    _ => BsdfSpec::RoughDielectric(d, roughness(&mut p)?),
                }
            }
            "conductor" | "roughconductor" => {
                let material = p.get_string("material", "none".into())?;
                let ior = if p.has("eta") || p.has("k") || material == "none" {
                    if material != "none" {
                        return Err(p.error(
                            "material",
                            "give either 'material' or 'eta' and 'k', not both",
                        ));
                    }
                    ConductorIor::Custom {
                        eta: p.get_rgb_or_float("eta", Rgb::ZERO)?,
                        k: p.get_rgb_or_float("k", Rgb::ONE)?,
                    }
                } else if conductor_preset(&material).is_some() {
                    ConductorIor::Named(material)
                } else {
                    let names: Vec<&str> = conductor_preset_names().collect();
                    return Err(p.error(
                        "material",
                        format!(
                            "unknown conductor material '{material}'; Mitsuba's are: {}",
                            names.join(", ")
                        ),
                    ));
                };
                let specular_reflectance = p.get_rgb_or_float("specular_reflectance", Rgb::ONE)?;
                if ty == "conductor" {
                    BsdfSpec::Conductor {
                        ior,
                        specular_reflectance,
                    }
                } else {
                    BsdfSpec::RoughConductor {
                        ior,
                        specular_reflectance,
                        roughness: roughness(&mut p)?,
                    }
                }
            }
            "plastic" | "roughplastic" => {
                let params = PlasticParams {
                    diffuse_reflectance: p
                        .get_rgb_or_float("diffuse_reflectance", Rgb::splat(0.5))?,
                    specular_reflectance: p.get_rgb_or_float("specular_reflectance", Rgb::ONE)?,
                    int_ior: ior(&mut p, "int_ior", 1.49)?,
                    ext_ior: ior(&mut p, "ext_ior", 1.000277)?,
                    nonlinear: p.get_bool("nonlinear", false)?,
                };
                if ty == "plastic" {
                    BsdfSpec::Plastic(params)
                } else {
                    let r = roughness(&mut p)?;
                    if r.alpha_u != r.alpha_v {
                        return Err(p.error(
                            "alpha_u",
                            "roughplastic takes one 'alpha' (Mitsuba's roughplastic is \
                             isotropic only)",
                        ));
                    }
                    BsdfSpec::RoughPlastic(params, r)
                }
            }
            _ => {
                let mut inner = Vec::new();
                for c in &children {
                    if c.node.tag != "bsdf" {
                        return Err(self.misplaced(c, &owner));
                    }
                    if inner.len() == 2 {
                        return Err(self.err(c.at, "a twosided BSDF takes one or two <bsdf>s"));
                    }
                    let nested = self.enter(c, |x| x.bsdf(c.node))?;
                    if nested.transmits() {
                        return Err(self.err(
                            c.at,
                            format!(
                                "{} transmits light, and a twosided BSDF can only hold \
                                 BSDFs without transmission (as in Mitsuba); a dielectric \
                                 is two-sided already, use it without twosided",
                                describe(c.node)
                            ),
                        ));
                    }
                    inner.push(nested);
                }
                let mut it = inner.into_iter();
                let Some(front) = it.next() else {
                    return Err(self.err(node.pos, "a twosided BSDF needs a nested <bsdf>"));
                };
                BsdfSpec::TwoSided {
                    front: Box::new(front),
                    back: it.next().map(Box::new),
                }
            }
        };
        if ty != "twosided" {
            self.no_children(&children, &owner)?;
        }
        p.finish(&mut self.warnings);
        if let Some(msg) = spec.approximation() {
            self.warn(node.pos, format!("{owner} {msg}"));
        }
        Ok(spec)
    }
}

/// Parameters shared by Mitsuba's dielectrics.
#[derive(Clone, Debug, PartialEq)]
pub struct DielectricParams {
    pub int_ior: f32,
    pub ext_ior: f32,
    pub specular_reflectance: Rgb,
    pub specular_transmittance: Rgb,
}

/// A conductor's complex index of refraction.
#[derive(Clone, Debug, PartialEq)]
pub enum ConductorIor {
    /// One of Mitsuba's measured materials (`material="Au"`).
    Named(String),
    /// Explicit `eta` and `k` (`material="none"` gives 0 and 1: a mirror).
    Custom { eta: Rgb, k: Rgb },
}

/// Microfacet roughness (`distribution`, `alpha` or `alpha_u`/`alpha_v`,
/// `sample_visible`).
#[derive(Clone, Debug, PartialEq)]
pub struct Roughness {
    pub distribution: MicrofacetType,
    pub alpha_u: f32,
    pub alpha_v: f32,
    pub sample_visible: bool,
}

#[derive(Clone, Debug, PartialEq)]
pub struct PlasticParams {
    pub diffuse_reflectance: Rgb,
    pub specular_reflectance: Rgb,
    pub int_ior: f32,
    pub ext_ior: f32,
    pub nonlinear: bool,
}

/// A Mitsuba BSDF with all its parameters.
#[derive(Clone, Debug, PartialEq)]
pub enum BsdfSpec {
    Diffuse {
        reflectance: Rgb,
    },
    Dielectric(DielectricParams),
    ThinDielectric(DielectricParams),
    RoughDielectric(DielectricParams, Roughness),
    Conductor {
        ior: ConductorIor,
        specular_reflectance: Rgb,
    },
    RoughConductor {
        ior: ConductorIor,
        specular_reflectance: Rgb,
        roughness: Roughness,
    },
    Plastic(PlasticParams),
    RoughPlastic(PlasticParams, Roughness),
    TwoSided {
        front: Box<BsdfSpec>,
        back: Option<Box<BsdfSpec>>,
    },
}

impl BsdfSpec {
    /// The lente BSDF that renders it: Mitsuba's own model, with every
    /// parameter (see [`BsdfSpec::approximation`] for what is not). An
    /// error only for a twosided BSDF holding a transmissive one (the
    /// parser refuses those at the element already).
    pub fn build(&self) -> std::result::Result<Bsdf, String> {
        Ok(match self {
            BsdfSpec::Diffuse { reflectance } => Bsdf::Diffuse {
                albedo: *reflectance,
            },
            // Lente's smooth dielectric has no tints (see `approximation`).
            BsdfSpec::Dielectric(d) => Bsdf::dielectric(d.int_ior, d.ext_ior),
            BsdfSpec::ThinDielectric(d) => Bsdf::thin_dielectric(
                d.int_ior,
                d.ext_ior,
                d.specular_reflectance,
                d.specular_transmittance,
            ),
            BsdfSpec::RoughDielectric(d, r) => Bsdf::rough_dielectric(
                r.distribution,
                r.alpha_u,
                r.alpha_v,
                d.int_ior,
                d.ext_ior,
                d.specular_reflectance,
                d.specular_transmittance,
                r.sample_visible,
            ),
            BsdfSpec::Conductor {
                ior,
                specular_reflectance,
            } => {
                let (eta, k) = ior.eta_k()?;
                Bsdf::conductor(eta, k, *specular_reflectance)
            }
            BsdfSpec::RoughConductor {
                ior,
                specular_reflectance,
                roughness: r,
            } => {
                let (eta, k) = ior.eta_k()?;
                Bsdf::rough_conductor(
                    r.distribution,
                    r.alpha_u,
                    r.alpha_v,
                    eta,
                    k,
                    *specular_reflectance,
                    r.sample_visible,
                )
            }
            BsdfSpec::Plastic(pl) => Bsdf::plastic(
                pl.int_ior,
                pl.ext_ior,
                pl.diffuse_reflectance,
                pl.specular_reflectance,
                pl.nonlinear,
            ),
            BsdfSpec::RoughPlastic(pl, r) => Bsdf::rough_plastic(
                r.distribution,
                r.alpha_u,
                pl.int_ior,
                pl.ext_ior,
                pl.diffuse_reflectance,
                pl.specular_reflectance,
                pl.nonlinear,
                r.sample_visible,
            ),
            BsdfSpec::TwoSided { front, back } => {
                let back = match back {
                    Some(b) => Some(b.build()?),
                    None => None,
                };
                Bsdf::two_sided(front.build()?, back).ok_or_else(|| {
                    "a twosided BSDF can only hold BSDFs without transmission".to_string()
                })?
            }
        })
    }

    /// True if it scatters light through the surface (Mitsuba's twosided
    /// refuses those).
    pub fn transmits(&self) -> bool {
        match self {
            BsdfSpec::Dielectric(_)
            | BsdfSpec::ThinDielectric(_)
            | BsdfSpec::RoughDielectric(..) => true,
            BsdfSpec::TwoSided { front, back } => {
                front.transmits() || back.as_ref().is_some_and(|b| b.transmits())
            }
            _ => false,
        }
    }

    /// True if building it computes tables (worth sharing).
    fn has_tables(&self) -> bool {
        match self {
            BsdfSpec::RoughPlastic(..) => true,
            BsdfSpec::TwoSided { front, back } => {
                front.has_tables() || back.as_ref().is_some_and(|b| b.has_tables())
            }
            _ => false,
        }
    }

    /// What `build` does not reproduce, if anything (for a warning).
    pub fn approximation(&self) -> Option<String> {
        match self {
            BsdfSpec::Dielectric(d)
                if d.specular_reflectance != Rgb::ONE || d.specular_transmittance != Rgb::ONE =>
            {
                Some(
                    "is rendered without its specular_reflectance/specular_transmittance \
                     tints (lente's smooth dielectric has none)"
                        .into(),
                )
            }
            // Nested BSDFs warn for themselves.
            _ => None,
        }
    }
}

impl ConductorIor {
    /// The complex index of refraction, per RGB channel, as Mitsuba's RGB
    /// variants use it.
    pub fn eta_k(&self) -> std::result::Result<(Rgb, Rgb), String> {
        match self {
            ConductorIor::Custom { eta, k } => Ok((*eta, *k)),
            ConductorIor::Named(name) => {
                conductor_preset(name).ok_or_else(|| format!("unknown conductor material '{name}'"))
            }
        }
    }
}

/// An index of refraction: a number, or one of Mitsuba's names.
fn ior(p: &mut Props, name: &str, default: f32) -> Result<f32> {
    let v = if p.kind_of(name) == Some(Kind::String) {
        let s = p.require_string(name)?;
        match ior_preset(s.trim()) {
            Some(v) => v,
            None => {
                let names: Vec<&str> = ior_preset_names().collect();
                return Err(p.error(
                    name,
                    format!(
                        "unknown index of refraction '{s}'; give a number or one of: {}",
                        names.join(", ")
                    ),
                ));
            }
        }
    } else {
        p.get_float(name, default)?
    };
    if v <= 0.0 {
        return Err(p.error(name, format!("'{name}' must be positive, found {v}")));
    }
    Ok(v)
}

/// `distribution` (beckmann or ggx, default beckmann), `alpha` (0.1) or
/// both `alpha_u` and `alpha_v`, `sample_visible` (true).
fn roughness(p: &mut Props) -> Result<Roughness> {
    let dist = p.get_string("distribution", "beckmann".into())?;
    let Some(distribution) = MicrofacetType::from_name(dist.trim()) else {
        return Err(p.error(
            "distribution",
            format!("unknown distribution '{dist}'; use beckmann or ggx"),
        ));
    };
    let (alpha_u, alpha_v) = if p.has("alpha_u") || p.has("alpha_v") {
        if p.has("alpha") {
            return Err(p.error("alpha", "give either 'alpha' or 'alpha_u' and 'alpha_v'"));
        }
        (
            non_negative_req(p, "alpha_u")?,
            non_negative_req(p, "alpha_v")?,
        )
    } else {
        let a = p.get_float("alpha", 0.1)?;
        if a < 0.0 {
            return Err(p.error("alpha", format!("'alpha' must not be negative, found {a}")));
        }
        (a, a)
    };
    Ok(Roughness {
        distribution,
        alpha_u,
        alpha_v,
        sample_visible: p.get_bool("sample_visible", true)?,
    })
}

fn non_negative_req(p: &mut Props, name: &str) -> Result<f32> {
    let v = p.require_float(name)?;
    if v < 0.0 {
        return Err(p.error(name, format!("'{name}' must not be negative, found {v}")));
    }
    Ok(v)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn specs_build_mitsubas_bsdfs() {
        let mirror = BsdfSpec::Conductor {
            ior: ConductorIor::Custom {
                eta: Rgb::ZERO,
                k: Rgb::ONE,
            },
            specular_reflectance: Rgb::ONE,
        };
        assert_eq!(
            mirror.build().unwrap(),
            Bsdf::conductor(Rgb::ZERO, Rgb::ONE, Rgb::ONE)
        );
        assert!(mirror.approximation().is_none());
        let gold = BsdfSpec::Conductor {
            ior: ConductorIor::Named("Au".into()),
            specular_reflectance: Rgb::ONE,
        };
        let (eta, k) = conductor_preset("Au").unwrap();
        assert_eq!(gold.build().unwrap(), Bsdf::conductor(eta, k, Rgb::ONE));
        assert!(gold.approximation().is_none());
        let glass = DielectricParams {
            int_ior: 1.5,
            ext_ior: 1.0,
            specular_reflectance: Rgb::ONE,
            specular_transmittance: Rgb::ONE,
        };
        let two = BsdfSpec::TwoSided {
            front: Box::new(BsdfSpec::Diffuse {
                reflectance: Rgb::ONE,
            }),
            back: Some(Box::new(BsdfSpec::Dielectric(glass.clone()))),
        };
        assert!(two.transmits());
        assert!(two.build().is_err());
        let tinted = BsdfSpec::Dielectric(DielectricParams {
            specular_reflectance: Rgb::splat(0.5),
            ..glass
        });
        assert!(tinted.approximation().unwrap().contains("tints"));
    }
}
