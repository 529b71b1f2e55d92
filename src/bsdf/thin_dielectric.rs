//! Mitsuba's `thindielectric`: a sheet whose two parallel faces reflect
//! R' = R + T^2 R / (1 - R^2) = 2R / (1 + R) in total (all internal
//! bounces), with R the Fresnel reflectance at |cos|; the rest passes
//! straight through (wo = -wi, no refraction: the faces are parallel). Both
//! lobes are deltas, sampled in proportion to R' and 1 - R'; works from
//! either side.

use super::params::{self, BsdfError, BsdfParam};
use super::{fresnel_dielectric, BsdfSample};
use crate::color::Rgb;
use crate::math::Vec3;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThinDielectric {
    /// Interior IOR / exterior IOR.
    pub eta: f32,
    pub specular_reflectance: Rgb,
    pub specular_transmittance: Rgb,
}

impl ThinDielectric {
    /// Parameters (Mitsuba's defaults): `int_ior` (bk7 = 1.5046), `ext_ior`
    /// (air = 1.000277), `specular_reflectance` (1),
    /// `specular_transmittance` (1).
    pub fn new(
        int_ior: f32,
        ext_ior: f32,
        specular_reflectance: Rgb,
        specular_transmittance: Rgb,
    ) -> Result<ThinDielectric, BsdfError> {
        Ok(ThinDielectric {
            eta: params::relative_ior(int_ior, ext_ior)?,
            specular_reflectance: params::color(
                BsdfParam::SpecularReflectance,
                specular_reflectance,
            )?,
            specular_transmittance: params::color(
                BsdfParam::SpecularTransmittance,
                specular_transmittance,
            )?,
        })
    }

    /// Reflectance at incidence cosine `cos_i`, the internal reflections
    /// summed (r' = r + t r t + ... = 2r / (1 + r)).
    fn reflectance(&self, cos_i: f32) -> f32 {
        let (r, _, _) = fresnel_dielectric(cos_i.abs(), self.eta);
        2.0 * r / (1.0 + r)
    }

    pub fn sample(&self, wi: Vec3, u: f32) -> Option<BsdfSample> {
        let r = self.reflectance(wi.z);
        Some(if u <= r {
            BsdfSample {
                wo: Vec3::new(-wi.x, -wi.y, wi.z),
                weight: self.specular_reflectance,
                pdf: r,
                specular: true,
                eta: 1.0,
                null: false,
            }
        } else {
            // Mitsuba flags this lobe Null: the direction is unchanged, so
            // volpath does not count it as a bounce.
            BsdfSample {
                wo: -wi,
                weight: self.specular_transmittance,
                pdf: 1.0 - r,
                specular: true,
                eta: 1.0,
                null: true,
            }
        })
    }

    /// What passes straight through at incidence cosine `cos_i`: the
    /// transmission lobe's weight times its probability.
    pub fn null_transmission(&self, cos_i: f32) -> Rgb {
        self.specular_transmittance * (1.0 - self.reflectance(cos_i))
    }
}
