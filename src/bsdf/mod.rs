//! Surface scattering models. Directions are in the local shading frame
//! (z = shading normal) and both point away from the surface: `wi` towards
//! where light is gathered from the camera side (Nori's convention: `wi` is
//! the direction the path arrived from, `wo` the sampled continuation).

mod dielectric;
mod fresnel;
mod microfacet;

use crate::color::Rgb;
use crate::math::{Vec2, Vec3};

pub use fresnel::fresnel_dielectric;

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

    /// True if every lobe is a delta: NEE is pointless on it.
    pub fn is_specular(&self) -> bool {
        matches!(self, Bsdf::Mirror | Bsdf::Dielectric { .. })
    }

    /// Diffuse albedo for the `ao`/visualisation paths, if any.
    pub fn albedo(&self) -> Option<Rgb> {
        match self {
            Bsdf::Diffuse { albedo } => Some(*albedo),
            Bsdf::Microfacet { kd, .. } => Some(*kd),
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
            Bsdf::Mirror | Bsdf::Dielectric { .. } => Rgb::ZERO,
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
            Bsdf::Mirror | Bsdf::Dielectric { .. } => 0.0,
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
        }
    }
}
