//! The Universidad de Zaragoza Nori fork's `roughsubstrate`: a Beckmann
//! coating with dielectric Fresnel over a diffuse base, Ashikhmin and
//! Shirley's coupled model as the fork's source defines it:
//!
//! f = D F(wh·wi) G1(wi) G1(wo) / (4 cos θi cos θo)
//!   + 28 kd / (23π) (1 − R0) (1 − (1 − cos θi / 2)^5) (1 − (1 − cos θo / 2)^5)
//!
//! with R0 = ((ext − int) / (ext + int))². Sampling picks the coating with
//! probability F(cos θi), else a cosine-weighted direction, and returns
//! the mixture's density (the fork's choice of lobes; with the half-vector
//! Jacobian its pdf omits).

use super::fresnel::schlick_weight;
use super::microfacet::smith_g1;
use super::params::{self, BsdfError, BsdfParam};
use super::{fresnel_dielectric, BsdfSample};
use crate::color::Rgb;
use crate::math::{reflect, Vec2, Vec3, PI};
use crate::sampling::warp;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RoughSubstrate {
    pub alpha: f32,
    /// Interior IOR / exterior IOR.
    pub eta: f32,
    pub kd: Rgb,
    /// 28 (1 − R0) / (23π): the diffuse term's constant without kd.
    diffuse_scale: f32,
}

impl RoughSubstrate {
    /// `alpha` positive, IORs positive, `kd` in [0, 1] per channel.
    pub fn new(
        alpha: f32,
        int_ior: f32,
        ext_ior: f32,
        kd: Rgb,
    ) -> Result<RoughSubstrate, BsdfError> {
        let eta = params::relative_ior(int_ior, ext_ior)?;
        let r = (ext_ior - int_ior) / (ext_ior + int_ior);
        Ok(RoughSubstrate {
            alpha: params::positive(BsdfParam::Alpha, alpha)?,
            eta,
            kd: params::albedo(BsdfParam::Diffuse, kd)?,
            diffuse_scale: 28.0 * (1.0 - r * r) / (23.0 * PI),
        })
    }

    /// The diffuse lobe's constant factor, 28 (1 - r^2) / (23 pi) (the
    /// GPU keeps it beside kd, which may be textured).
    pub fn diffuse_scale(&self) -> f32 {
        self.diffuse_scale
    }

    /// The coating's share of the samples: F(cos θi).
    #[inline]
    fn coating_probability(&self, wi: Vec3) -> f32 {
        fresnel_dielectric(wi.z, self.eta).0
    }

    pub fn eval(&self, wi: Vec3, wo: Vec3) -> Rgb {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return Rgb::ZERO;
        }
        let wh = (wi + wo).normalize();
        let d = warp::beckmann_d(wh, self.alpha);
        let (f, _, _) = fresnel_dielectric(wh.dot(wi), self.eta);
        let g = smith_g1(wi, wh, self.alpha) * smith_g1(wo, wh, self.alpha);
        let coating = d * f * g / (4.0 * wi.z * wo.z);
        let base = self.diffuse_scale
            * (1.0 - schlick_weight(0.5 * wi.z))
            * (1.0 - schlick_weight(0.5 * wo.z));
        Rgb::splat(coating) + self.kd * base
    }

    pub fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return 0.0;
        }
        let wh = (wi + wo).normalize();
        let p = self.coating_probability(wi);
        let coating = warp::square_to_beckmann_pdf(wh, self.alpha) / (4.0 * wh.dot(wo).abs());
        p * coating + (1.0 - p) * warp::square_to_cosine_hemisphere_pdf(wo)
    }

    pub fn sample(&self, wi: Vec3, u: Vec2, u_lobe: f32) -> Option<BsdfSample> {
        if wi.z <= 0.0 {
            return None;
        }
        let wo = if u_lobe < self.coating_probability(wi) {
            reflect(wi, warp::square_to_beckmann(u, self.alpha))
        } else {
            warp::square_to_cosine_hemisphere(u)
        };
        BsdfSample::smooth_reflection(wo, self.pdf(wi, wo), || self.eval(wi, wo))
    }
}
