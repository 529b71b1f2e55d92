//! Mitsuba 3's `roughconductor`: microfacet reflection with the exact
//! conductor Fresnel term per RGB channel. One-sided: black seen from
//! below.

use super::distribution::MicrofacetDistribution;
use super::distribution::Roughness;
use super::params::BsdfError;
use super::{fresnel_conductor, BsdfSample, Conductor};
use crate::color::Rgb;
use crate::math::{reflect, Vec2, Vec3};

/// Mitsuba's `roughconductor`. One-sided.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RoughConductor {
    pub distr: MicrofacetDistribution,
    pub eta: Rgb,
    pub k: Rgb,
    pub specular_reflectance: Rgb,
}

impl RoughConductor {
    /// Parameters (Mitsuba names and defaults): `distribution` (beckmann),
    /// `alpha_u`, `alpha_v` (both from `alpha`, default 0.1; clamped to at
    /// least 1e-4), `eta`, `k` (material `none`: 0 and 1),
    /// `specular_reflectance` (1), `sample_visible` (true).
    pub fn new(
        roughness: Roughness,
        eta: Rgb,
        k: Rgb,
        specular_reflectance: Rgb,
    ) -> Result<RoughConductor, BsdfError> {
        let smooth = Conductor::new(eta, k, specular_reflectance)?;
        Ok(RoughConductor {
            distr: roughness.distribution()?,
            eta: smooth.eta,
            k: smooth.k,
            specular_reflectance: smooth.specular_reflectance,
        })
    }

    /// f(wi, wo) = F(wi.h) D(h) G(wi, wo, h) / (4 cos_i cos_o).
    pub fn eval(&self, wi: Vec3, wo: Vec3) -> Rgb {
        self.eval_pdf(wi, wo).0
    }

    pub fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        self.eval_pdf(wi, wo).1
    }

    /// `(eval, pdf)` at once: they share the half vector, `D` and one
    /// `G1`.
    #[inline]
    pub fn eval_pdf(&self, wi: Vec3, wo: Vec3) -> (Rgb, f32) {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return (Rgb::ZERO, 0.0);
        }
        let h = (wi + wo).normalize();
        // Mirror the sidedness checks that G1 applies in eval and sample.
        if wi.dot(h) <= 0.0 || wo.dot(h) <= 0.0 {
            return (Rgb::ZERO, 0.0);
        }
        let d = self.distr.d(h);
        if d == 0.0 {
            return (Rgb::ZERO, 0.0);
        }
        let g1_i = self.distr.smith_g1(wi, h);
        let g = g1_i * self.distr.smith_g1(wo, h);
        let f = fresnel_conductor(wi.dot(h), self.eta, self.k);
        let value = self.specular_reflectance * f * (d * g / (4.0 * wi.z * wo.z));
        let pdf = if self.distr.sample_visible {
            d * g1_i / (4.0 * wi.z)
        } else {
            self.distr.pdf(wi, h) / (4.0 * wo.dot(h))
        };
        (value, pdf)
    }

    pub fn sample(&self, wi: Vec3, u: Vec2) -> Option<BsdfSample> {
        if wi.z <= 0.0 {
            return None;
        }
        let (m, pdf_m) = self.distr.sample(wi, u);
        let wo = reflect(wi, m);
        if pdf_m <= 0.0 || wo.z <= 0.0 {
            return None;
        }
        let g = if self.distr.sample_visible {
            self.distr.smith_g1(wo, m)
        } else {
            self.distr.g(wi, wo, m) * wi.dot(m) / (wi.z * m.z)
        };
        if g <= 0.0 {
            return None;
        }
        let f = fresnel_conductor(wi.dot(m), self.eta, self.k);
        Some(BsdfSample {
            wo,
            weight: self.specular_reflectance * f * g,
            pdf: pdf_m / (4.0 * wo.dot(m)),
            specular: false,
            eta: 1.0,
            null: false,
        })
    }
}
