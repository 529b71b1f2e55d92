//! Mitsuba 3's `pplastic` as its RGB variants render it (unpolarised): a
//! rough specular reflection (Beckmann or GGX, isotropic or not, dielectric
//! Fresnel at the microfacet) plus a Lambertian base whose light is
//! weighted by the smooth interface's transmittance on the way in and out,
//! (1 - F(cos theta_i)) (1 - F(cos theta_o)). Unlike `roughplastic` there
//! are no internal reflections and no rough-transmittance tables: the
//! model is cheaper and not energy-conserving in the same way (it is
//! Mitsuba's polarised plastic with the polarisation dropped).
//! Sampling picks the specular lobe with probability s / (s + d) (the
//! reflectances' means) and reports the combined density.

use super::distribution::{MicrofacetDistribution, Roughness};
use super::params::BsdfError;
use super::rough_plastic::sample_glossy_or_diffuse;
use super::{fresnel_dielectric, BsdfSample, Plastic};
use crate::color::Rgb;
use crate::math::{Vec2, Vec3, INV_PI};
use crate::sampling::warp;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PolarizedPlastic {
    pub distr: MicrofacetDistribution,
    /// Interior IOR / exterior IOR.
    pub eta: f32,
    pub diffuse_reflectance: Rgb,
    pub specular_reflectance: Rgb,
    /// Probability of sampling the specular lobe.
    pub specular_sampling_weight: f32,
}

impl PolarizedPlastic {
    /// Mitsuba's parameters and defaults: `distribution` (beckmann),
    /// `alpha` (0.1) or `alpha_u` and `alpha_v`, `sample_visible` (true),
    /// `eta` or `int_ior` (polypropylene = 1.49) and `ext_ior` (air),
    /// `diffuse_reflectance` (0.5), `specular_reflectance` (1).
    pub fn new(
        roughness: Roughness,
        int_ior: f32,
        ext_ior: f32,
        diffuse_reflectance: Rgb,
        specular_reflectance: Rgb,
    ) -> Result<PolarizedPlastic, BsdfError> {
        // The smooth plastic checks the same parameters and weighs its
        // lobes the same way.
        let smooth = Plastic::new(
            int_ior,
            ext_ior,
            diffuse_reflectance,
            specular_reflectance,
            false,
        )?;
        Ok(PolarizedPlastic {
            distr: roughness.distribution()?,
            eta: smooth.eta,
            diffuse_reflectance: smooth.diffuse_reflectance,
            specular_reflectance: smooth.specular_reflectance,
            specular_sampling_weight: smooth.specular_sampling_weight,
        })
    }

    pub fn eval(&self, wi: Vec3, wo: Vec3) -> Rgb {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return Rgb::ZERO;
        }
        let h = (wi + wo).normalize();
        let (f, _, _) = fresnel_dielectric(wi.dot(h), self.eta);
        let spec = self.distr.d(h) * self.distr.g(wi, wo, h) * f / (4.0 * wi.z * wo.z);
        let (f_i, _, _) = fresnel_dielectric(wi.z, self.eta);
        let (f_o, _, _) = fresnel_dielectric(wo.z, self.eta);
        self.specular_reflectance * spec
            + self.diffuse_reflectance * ((1.0 - f_i) * (1.0 - f_o) * INV_PI)
    }

    pub fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return 0.0;
        }
        let h = (wi + wo).normalize();
        let spec = if wi.dot(h) <= 0.0 || wo.dot(h) <= 0.0 {
            0.0
        } else if self.distr.sample_visible {
            self.distr.d(h) * self.distr.smith_g1(wi, h) / (4.0 * wi.z)
        } else {
            self.distr.pdf(wi, h) / (4.0 * wo.dot(h))
        };
        let p_spec = self.specular_sampling_weight;
        p_spec * spec + (1.0 - p_spec) * warp::square_to_cosine_hemisphere_pdf(wo)
    }

    /// The lobe choice uses the reflectances' means (a textured model
    /// keeps its base's weight), as Mitsuba's does.
    pub fn sample(&self, wi: Vec3, u: Vec2, u_lobe: f32) -> Option<BsdfSample> {
        if wi.z <= 0.0 {
            return None;
        }
        sample_glossy_or_diffuse(
            &self.distr,
            wi,
            u,
            u_lobe < self.specular_sampling_weight,
            |wo| (self.eval(wi, wo), self.pdf(wi, wo)),
        )
    }
}
