//! Mitsuba 3's smooth `conductor`: a delta reflection weighted by the exact
//! conductor Fresnel term per RGB channel. One-sided: black seen from below.

use super::params::{self, BsdfError, BsdfParam};
use super::{fresnel_conductor, BsdfSample};
use crate::color::Rgb;
use crate::math::Vec3;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Conductor {
    /// Complex index of refraction `eta + i k`, per channel.
    pub eta: Rgb,
    pub k: Rgb,
    pub specular_reflectance: Rgb,
}

impl Conductor {
    /// Parameters (Mitsuba names): `eta`, `k` (material `none`: 0 and 1,
    /// an ideal mirror; see [`super::conductor_preset`] for `material`),
    /// `specular_reflectance` (1). All finite and not negative.
    pub fn new(eta: Rgb, k: Rgb, specular_reflectance: Rgb) -> Result<Conductor, BsdfError> {
        Ok(Conductor {
            eta: params::color(BsdfParam::Eta, eta)?,
            k: params::color(BsdfParam::K, k)?,
            specular_reflectance: params::color(
                BsdfParam::SpecularReflectance,
                specular_reflectance,
            )?,
        })
    }

    pub fn sample(&self, wi: Vec3) -> Option<BsdfSample> {
        if wi.z <= 0.0 {
            return None;
        }
        Some(BsdfSample {
            wo: Vec3::new(-wi.x, -wi.y, wi.z),
            weight: self.specular_reflectance * fresnel_conductor(wi.z, self.eta, self.k),
            pdf: 1.0,
            specular: true,
            eta: 1.0,
            null: false,
        })
    }
}
