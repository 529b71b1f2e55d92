//! Surface scattering models. Directions are in the local shading frame
//! (z = shading normal) and both point away from the surface: `wi` towards
//! where light is gathered from the camera side (Nori's convention: `wi` is
//! the direction the path arrived from, `wo` the sampled continuation).

mod conductor;
mod dielectric;
pub mod distribution;
mod fresnel;
mod microfacet;
mod plastic;
pub mod presets;
mod rough_dielectric;
mod rough_plastic;

use crate::color::Rgb;
use crate::math::{Vec2, Vec3};

pub use conductor::RoughConductor;
pub use distribution::{MicrofacetDistribution, MicrofacetType};
pub use fresnel::{
    fresnel_conductor, fresnel_conductor_1, fresnel_dielectric, fresnel_diffuse_reflectance,
};
pub use plastic::Plastic;
pub use presets::{conductor_preset, ior_preset};
pub use rough_dielectric::RoughDielectric;
pub use rough_plastic::RoughPlastic;

/// The closed set of BSDFs lente renders.
#[derive(Clone, Debug, PartialEq)]
pub enum Bsdf {
    /// Lambertian reflector.
    Diffuse { albedo: Rgb },
    /// Perfect specular reflector.
    Mirror,
    /// Smooth dielectric interface; `eta` = interior IOR / exterior IOR.
    Dielectric { eta: f32 },
    /// Nori's rough plastic-like model: Beckmann specular lobe (roughness
    /// `alpha`, Fresnel with relative IOR `eta`) weighted by `ks` = 1 - max(kd)
    /// over a Lambertian base `kd`.
    Microfacet {
        alpha: f32,
        eta: f32,
        kd: Rgb,
        ks: f32,
    },
    /// Mitsuba's `conductor`: smooth metal, complex IOR `eta + i k` per
    /// channel, Fresnel times `specular_reflectance`. One-sided.
    Conductor {
        eta: Rgb,
        k: Rgb,
        specular_reflectance: Rgb,
    },
    /// Mitsuba's `roughconductor`. One-sided.
    RoughConductor(RoughConductor),
    /// Mitsuba's `thindielectric`: a thin sheet (both faces, all internal
    /// bounces summed); reflects or passes straight through. `eta` =
    /// interior / exterior IOR.
    ThinDielectric {
        eta: f32,
        specular_reflectance: Rgb,
        specular_transmittance: Rgb,
    },
    /// Mitsuba's `roughdielectric`: rough interface, reflection and refraction.
    RoughDielectric(RoughDielectric),
    /// Mitsuba's smooth `plastic`: delta coating reflection over a diffuse
    /// base. Not "specular" as a whole: NEE applies to its smooth lobe.
    Plastic(Plastic),
    /// Mitsuba's `roughplastic`: rough coating over a diffuse base (the
    /// coating's transmittance table is boxed, built at scene load).
    RoughPlastic(RoughPlastic),
    /// Mitsuba's `twosided`: `front` seen from above, `back` (with
    /// directions mirrored through the surface) seen from below. Boxed
    /// once at scene load; never allocated per ray.
    TwoSided { front: Box<Bsdf>, back: Box<Bsdf> },
}

/// Result of sampling a BSDF.
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    /// Sampled outgoing direction (local frame).
    pub wo: Vec3,
    /// eval * |cos theta_o| / pdf (for specular lobes: the lobe's weight).
    pub weight: Rgb,
    /// Solid-angle pdf; for a specular (delta) lobe, the discrete probability.
    pub pdf: f32,
    /// True if the lobe is a Dirac delta (eval and pdf are zero for it).
    pub specular: bool,
    /// Relative IOR crossed (1 for reflection), for radiance scaling and RR.
    pub eta: f32,
}

impl Default for Bsdf {
    fn default() -> Self {
        Bsdf::Diffuse {
            albedo: Rgb::splat(0.5),
        }
    }
}

impl Bsdf {
    /// Nori's dielectric from interior/exterior IORs.
    pub fn dielectric(int_ior: f32, ext_ior: f32) -> Bsdf {
        Bsdf::Dielectric {
            eta: int_ior / ext_ior,
        }
    }

    /// Nori's microfacet from its parameters.
    pub fn microfacet(alpha: f32, int_ior: f32, ext_ior: f32, kd: Rgb) -> Bsdf {
        Bsdf::Microfacet {
            alpha,
            eta: int_ior / ext_ior,
            kd,
            ks: 1.0 - crate::color::max_component(kd),
        }
    }

    /// Mitsuba's `conductor` with explicit complex IOR.
    ///
    /// Parameters (Mitsuba names): `eta`, `k` (default: material `none`,
    /// i.e. eta 0, k 1, an ideal mirror; see [`conductor_preset`] for
    /// `material`), `specular_reflectance` (default 1).
    pub fn conductor(eta: Rgb, k: Rgb, specular_reflectance: Rgb) -> Bsdf {
        Bsdf::Conductor {
            eta,
            k,
            specular_reflectance,
        }
    }

    /// Mitsuba's `roughconductor`.
    ///
    /// Parameters (Mitsuba names and defaults): `distribution` (beckmann),
    /// `alpha_u`, `alpha_v` (both from `alpha`, default 0.1; clamped to at
    /// least 1e-4), `eta`, `k` (material `none`: 0 and 1),
    /// `specular_reflectance` (1), `sample_visible` (true).
    pub fn rough_conductor(
        distribution: MicrofacetType,
        alpha_u: f32,
        alpha_v: f32,
        eta: Rgb,
        k: Rgb,
        specular_reflectance: Rgb,
        sample_visible: bool,
    ) -> Bsdf {
        Bsdf::RoughConductor(RoughConductor {
            distr: MicrofacetDistribution::new(distribution, alpha_u, alpha_v, sample_visible),
            eta,
            k,
            specular_reflectance,
        })
    }

    /// Mitsuba's `thindielectric`.
    ///
    /// Parameters: `int_ior` (bk7 = 1.5046), `ext_ior` (air = 1.000277),
    /// `specular_reflectance` (1), `specular_transmittance` (1).
    pub fn thin_dielectric(
        int_ior: f32,
        ext_ior: f32,
        specular_reflectance: Rgb,
        specular_transmittance: Rgb,
    ) -> Bsdf {
        Bsdf::ThinDielectric {
            eta: int_ior / ext_ior,
            specular_reflectance,
            specular_transmittance,
        }
    }

    /// Mitsuba's `roughdielectric`.
    ///
    /// Parameters: `distribution` (beckmann), `alpha_u`, `alpha_v` (from
    /// `alpha`, 0.1), `int_ior` (bk7 = 1.5046), `ext_ior` (air = 1.000277),
    /// `specular_reflectance` (1), `specular_transmittance` (1),
    /// `sample_visible` (true).
    #[allow(clippy::too_many_arguments)]
    pub fn rough_dielectric(
        distribution: MicrofacetType,
        alpha_u: f32,
        alpha_v: f32,
        int_ior: f32,
        ext_ior: f32,
        specular_reflectance: Rgb,
        specular_transmittance: Rgb,
        sample_visible: bool,
    ) -> Bsdf {
        Bsdf::RoughDielectric(RoughDielectric {
            distr: MicrofacetDistribution::new(distribution, alpha_u, alpha_v, sample_visible),
            eta: int_ior / ext_ior,
            specular_reflectance,
            specular_transmittance,
        })
    }

    /// Mitsuba's smooth `plastic`.
    ///
    /// Parameters: `int_ior` (polypropylene = 1.49), `ext_ior` (air =
    /// 1.000277), `diffuse_reflectance` (0.5), `specular_reflectance` (1),
    /// `nonlinear` (false).
    pub fn plastic(
        int_ior: f32,
        ext_ior: f32,
        diffuse_reflectance: Rgb,
        specular_reflectance: Rgb,
        nonlinear: bool,
    ) -> Bsdf {
        Bsdf::Plastic(Plastic::new(
            int_ior,
            ext_ior,
            diffuse_reflectance,
            specular_reflectance,
            nonlinear,
        ))
    }

    /// Mitsuba's `roughplastic` (isotropic only, as in Mitsuba).
    ///
    /// Parameters: `distribution` (beckmann), `alpha` (0.1), `int_ior`
    /// (polypropylene = 1.49), `ext_ior` (air = 1.000277),
    /// `diffuse_reflectance` (0.5), `specular_reflectance` (1), `nonlinear`
    /// (false), `sample_visible` (true). Builds its tables (~0.1 s): call
    /// once per material.
    #[allow(clippy::too_many_arguments)]
    pub fn rough_plastic(
        distribution: MicrofacetType,
        alpha: f32,
        int_ior: f32,
        ext_ior: f32,
        diffuse_reflectance: Rgb,
        specular_reflectance: Rgb,
        nonlinear: bool,
        sample_visible: bool,
    ) -> Bsdf {
        Bsdf::RoughPlastic(RoughPlastic::new(
            MicrofacetDistribution::new(distribution, alpha, alpha, sample_visible),
            int_ior,
            ext_ior,
            diffuse_reflectance,
            specular_reflectance,
            nonlinear,
        ))
    }

    /// Mitsuba's `twosided`: one nested BSDF for both sides, or a second one
    /// for the back. None if a nested BSDF transmits (Mitsuba refuses
    /// those: "Only materials without a transmission component can be
    /// nested").
    pub fn two_sided(front: Bsdf, back: Option<Bsdf>) -> Option<Bsdf> {
        let back = back.unwrap_or_else(|| front.clone());
        if front.has_transmission() || back.has_transmission() {
            return None;
        }
        Some(Bsdf::TwoSided {
            front: Box::new(front),
            back: Box::new(back),
        })
    }

    /// True if some lobe scatters light through the surface.
    pub fn has_transmission(&self) -> bool {
        match self {
            Bsdf::Dielectric { .. } | Bsdf::ThinDielectric { .. } | Bsdf::RoughDielectric(_) => {
                true
            }
            Bsdf::TwoSided { front, back } => front.has_transmission() || back.has_transmission(),
            _ => false,
        }
    }

    /// True if every lobe is a delta: NEE is pointless on it. A BSDF with
    /// both delta and smooth lobes (plastic) is not specular; its samples
    /// say which lobe they came from.
    pub fn is_specular(&self) -> bool {
        match self {
            Bsdf::Mirror
            | Bsdf::Dielectric { .. }
            | Bsdf::Conductor { .. }
            | Bsdf::ThinDielectric { .. } => true,
            Bsdf::TwoSided { front, back } => front.is_specular() && back.is_specular(),
            _ => false,
        }
    }

    /// Diffuse albedo for the `ao`/visualisation paths, if any.
    pub fn albedo(&self) -> Option<Rgb> {
        match self {
            Bsdf::Diffuse { albedo } => Some(*albedo),
            Bsdf::Microfacet { kd, .. } => Some(*kd),
            Bsdf::Plastic(p) => Some(p.diffuse_reflectance),
            Bsdf::RoughPlastic(p) => Some(p.diffuse_reflectance),
            Bsdf::TwoSided { front, .. } => front.albedo(),
            _ => None,
        }
    }

    /// BSDF value f(wi, wo) (without the cosine). Zero for delta lobes.
    pub fn eval(&self, wi: Vec3, wo: Vec3) -> Rgb {
        match self {
            Bsdf::Diffuse { albedo } => {
                if wi.z <= 0.0 || wo.z <= 0.0 {
                    Rgb::ZERO
                } else {
                    *albedo * crate::math::INV_PI
                }
            }
            Bsdf::Microfacet { alpha, eta, kd, ks } => {
                microfacet::eval(*alpha, *eta, *kd, *ks, wi, wo)
            }
            Bsdf::RoughConductor(b) => b.eval(wi, wo),
            Bsdf::RoughDielectric(b) => b.eval(wi, wo),
            Bsdf::Plastic(b) => b.eval(wi, wo),
            Bsdf::RoughPlastic(b) => b.eval(wi, wo),
            Bsdf::TwoSided { front, back } => {
                if wi.z > 0.0 {
                    front.eval(wi, wo)
                } else if wi.z < 0.0 {
                    back.eval(flip_z(wi), flip_z(wo))
                } else {
                    Rgb::ZERO
                }
            }
            Bsdf::Mirror
            | Bsdf::Dielectric { .. }
            | Bsdf::Conductor { .. }
            | Bsdf::ThinDielectric { .. } => Rgb::ZERO,
        }
    }

    /// Solid-angle density of `sample` producing `wo`. Zero for delta lobes.
    pub fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        match self {
            Bsdf::Diffuse { .. } => {
                if wi.z <= 0.0 || wo.z <= 0.0 {
                    0.0
                } else {
                    crate::sampling::warp::square_to_cosine_hemisphere_pdf(wo)
                }
            }
            Bsdf::Microfacet { alpha, ks, .. } => microfacet::pdf(*alpha, *ks, wi, wo),
            Bsdf::RoughConductor(b) => b.pdf(wi, wo),
            Bsdf::RoughDielectric(b) => b.pdf(wi, wo),
            Bsdf::Plastic(b) => b.pdf(wi, wo),
            Bsdf::RoughPlastic(b) => b.pdf(wi, wo),
            Bsdf::TwoSided { front, back } => {
                if wi.z > 0.0 {
                    front.pdf(wi, wo)
                } else if wi.z < 0.0 {
                    back.pdf(flip_z(wi), flip_z(wo))
                } else {
                    0.0
                }
            }
            Bsdf::Mirror
            | Bsdf::Dielectric { .. }
            | Bsdf::Conductor { .. }
            | Bsdf::ThinDielectric { .. } => 0.0,
        }
    }

    /// Samples `wo` given `wi`; `u` drives the direction, `u_lobe` the lobe choice.
    pub fn sample(&self, wi: Vec3, u: Vec2, u_lobe: f32) -> Option<BsdfSample> {
        match self {
            Bsdf::Diffuse { albedo } => {
                if wi.z <= 0.0 {
                    return None;
                }
                let wo = crate::sampling::warp::square_to_cosine_hemisphere(u);
                if wo.z <= 0.0 {
                    return None;
                }
                Some(BsdfSample {
                    wo,
                    weight: *albedo,
                    pdf: crate::sampling::warp::square_to_cosine_hemisphere_pdf(wo),
                    specular: false,
                    eta: 1.0,
                })
            }
            Bsdf::Mirror => {
                if wi.z <= 0.0 {
                    return None;
                }
                Some(BsdfSample {
                    wo: Vec3::new(-wi.x, -wi.y, wi.z),
                    weight: Rgb::ONE,
                    pdf: 1.0,
                    specular: true,
                    eta: 1.0,
                })
            }
            Bsdf::Dielectric { eta } => Some(dielectric::sample(*eta, wi, u_lobe)),
            Bsdf::Microfacet { alpha, eta, kd, ks } => {
                microfacet::sample(*alpha, *eta, *kd, *ks, wi, u, u_lobe)
            }
            Bsdf::Conductor {
                eta,
                k,
                specular_reflectance,
            } => conductor::sample_smooth(*eta, *k, *specular_reflectance, wi),
            Bsdf::RoughConductor(b) => b.sample(wi, u),
            Bsdf::ThinDielectric {
                eta,
                specular_reflectance,
                specular_transmittance,
            } => Some(dielectric::sample_thin(
                *eta,
                *specular_reflectance,
                *specular_transmittance,
                wi,
                u_lobe,
            )),
            Bsdf::RoughDielectric(b) => b.sample(wi, u, u_lobe),
            Bsdf::Plastic(b) => b.sample(wi, u, u_lobe),
            Bsdf::RoughPlastic(b) => b.sample(wi, u, u_lobe),
            Bsdf::TwoSided { front, back } => {
                if wi.z > 0.0 {
                    front.sample(wi, u, u_lobe)
                } else if wi.z < 0.0 {
                    back.sample(flip_z(wi), u, u_lobe).map(|mut s| {
                        s.wo = flip_z(s.wo);
                        s
                    })
                } else {
                    None
                }
            }
        }
    }
}

/// Mirror a direction through the surface (twosided's view of the back).
#[inline]
fn flip_z(v: Vec3) -> Vec3 {
    Vec3::new(v.x, v.y, -v.z)
}
