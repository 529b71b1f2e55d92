//! Nori's `microfacet` BSDF: a Beckmann specular lobe with exact dielectric
//! Fresnel over a Lambertian base. The specular weight is 1 - max(kd), and
//! sampling picks a lobe in proportion to the weights.

use super::params::{self, BsdfError, BsdfParam};
use super::{fresnel_dielectric, BsdfSample};
use crate::color::Rgb;
use crate::math::{reflect, Vec2, Vec3, INV_PI};
use crate::sampling::warp;

/// Smith's shadowing for the Beckmann distribution (Walter et al. 2007's
/// rational approximation), with the sidedness check.
pub(super) fn smith_g1(v: Vec3, m: Vec3, alpha: f32) -> f32 {
    if v.dot(m) * v.z <= 0.0 {
        return 0.0;
    }
    let cos = v.z;
    let sin = (1.0 - cos * cos).max(0.0).sqrt();
    if sin == 0.0 {
        return 1.0;
    }
    let b = cos / (alpha * sin);
    if b >= 1.6 {
        1.0
    } else {
        let b2 = b * b;
        (3.535 * b + 2.181 * b2) / (1.0 + 2.276 * b + 2.577 * b2)
    }
}

/// Nori's rough plastic-like model: Beckmann specular lobe (roughness
/// `alpha`, Fresnel with relative IOR `eta`) weighted by `ks` = 1 - max(kd)
/// over a Lambertian base `kd`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Microfacet {
    pub alpha: f32,
    /// Interior IOR / exterior IOR.
    pub eta: f32,
    pub kd: Rgb,
    pub ks: f32,
}

impl Microfacet {
    /// Nori's parameters: `alpha` (positive), `intIOR`, `extIOR`, `kd`
    /// (at most 1 per channel: `ks` = 1 - max(kd) must not be negative).
    pub fn new(alpha: f32, int_ior: f32, ext_ior: f32, kd: Rgb) -> Result<Microfacet, BsdfError> {
        let kd = params::albedo(BsdfParam::Diffuse, kd)?;
        Ok(Microfacet {
            alpha: params::positive(BsdfParam::Alpha, alpha)?,
            eta: params::relative_ior(int_ior, ext_ior)?,
            kd,
            ks: 1.0 - crate::color::max_component(kd),
        })
    }

    pub fn eval(&self, wi: Vec3, wo: Vec3) -> Rgb {
        let Microfacet { alpha, eta, kd, ks } = *self;
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return Rgb::ZERO;
        }
        let wh = (wi + wo).normalize();
        let d = warp::beckmann_d(wh, alpha);
        let (f, _, _) = fresnel_dielectric(wh.dot(wi), eta);
        let g = smith_g1(wi, wh, alpha) * smith_g1(wo, wh, alpha);
        kd * INV_PI + Rgb::splat(ks * d * f * g / (4.0 * wi.z * wo.z))
    }

    pub fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        let Microfacet { alpha, ks, .. } = *self;
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return 0.0;
        }
        let wh = (wi + wo).normalize();
        let spec = warp::square_to_beckmann_pdf(wh, alpha) / (4.0 * wh.dot(wo).abs());
        ks * spec + (1.0 - ks) * wo.z * INV_PI
    }

    pub fn sample(&self, wi: Vec3, u: Vec2, u_lobe: f32) -> Option<BsdfSample> {
        if wi.z <= 0.0 {
            return None;
        }
        let wo = if u_lobe < self.ks {
            let wh = warp::square_to_beckmann(u, self.alpha);
            reflect(wi, wh)
        } else {
            warp::square_to_cosine_hemisphere(u)
        };
        BsdfSample::smooth_reflection(wo, self.pdf(wi, wo), || self.eval(wi, wo))
    }
}
