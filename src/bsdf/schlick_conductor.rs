//! The Universidad de Zaragoza Nori fork's `roughconductor`: a Beckmann
//! lobe (roughness `alpha`) with Schlick's Fresnel term from the
//! reflectance at normal incidence `R0`, and Walter et al.'s shadowing:
//! f = D F G1(wi) G1(wo) / (4 cos θi cos θo), as the fork's source
//! defines it. Sampled by the Beckmann normals with the half-vector
//! Jacobian (the fork's own pdf omits it; its value is what a render
//! converges to, so lente samples it correctly).

use super::fresnel::schlick;
use super::microfacet::smith_g1;
use super::params::{self, BsdfError, BsdfParam};
use super::BsdfSample;
use crate::color::Rgb;
use crate::math::{reflect, Vec2, Vec3};
use crate::sampling::warp;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SchlickConductor {
    pub alpha: f32,
    pub r0: Rgb,
}

impl SchlickConductor {
    /// `alpha` positive; `r0` in [0, 1] per channel.
    pub fn new(alpha: f32, r0: Rgb) -> Result<SchlickConductor, BsdfError> {
        Ok(SchlickConductor {
            alpha: params::positive(BsdfParam::Alpha, alpha)?,
            r0: params::albedo(BsdfParam::SpecularReflectance, r0)?,
        })
    }

    pub fn eval(&self, wi: Vec3, wo: Vec3) -> Rgb {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return Rgb::ZERO;
        }
        let wh = (wi + wo).normalize();
        let d = warp::beckmann_d(wh, self.alpha);
        let g = smith_g1(wi, wh, self.alpha) * smith_g1(wo, wh, self.alpha);
        let f = schlick(self.r0, wh.dot(wi));
        f * (d * g / (4.0 * wi.z * wo.z))
    }

    pub fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return 0.0;
        }
        let wh = (wi + wo).normalize();
        warp::square_to_beckmann_pdf(wh, self.alpha) / (4.0 * wh.dot(wo).abs())
    }

    pub fn sample(&self, wi: Vec3, u: Vec2) -> Option<BsdfSample> {
        if wi.z <= 0.0 {
            return None;
        }
        let wo = reflect(wi, warp::square_to_beckmann(u, self.alpha));
        BsdfSample::smooth_reflection(wo, self.pdf(wi, wo), || self.eval(wi, wo))
    }
}
