//! Smooth dielectric interface (Nori's and Mitsuba's `dielectric`):
//! Fresnel-weighted choice of reflection or refraction, both delta lobes.

use super::params::{self, BsdfError};
use super::{fresnel_dielectric, BsdfSample};
use crate::color::Rgb;
use crate::math::Vec3;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dielectric {
    /// Interior IOR / exterior IOR.
    pub eta: f32,
}

impl Dielectric {
    /// From interior and exterior IORs (positive, finite).
    pub fn new(int_ior: f32, ext_ior: f32) -> Result<Dielectric, BsdfError> {
        Ok(Dielectric {
            eta: params::relative_ior(int_ior, ext_ior)?,
        })
    }

    /// Samples reflection with probability F, refraction otherwise. The
    /// weight is 1 for reflection and 1/eta^2 for refraction (radiance
    /// scaling), so the estimator is exact for each lobe.
    pub fn sample(&self, wi: Vec3, u: f32) -> Option<BsdfSample> {
        let cos_i = wi.z;
        let (f, cos_t, eta_ti) = fresnel_dielectric(cos_i, self.eta);
        if u < f {
            return Some(BsdfSample {
                wo: Vec3::new(-wi.x, -wi.y, wi.z),
                weight: Rgb::ONE,
                pdf: f,
                specular: true,
                eta: 1.0,
                null: false,
            });
        }
        let wo = Vec3::new(
            -wi.x / eta_ti,
            -wi.y / eta_ti,
            if cos_i >= 0.0 { -cos_t } else { cos_t },
        );
        let scale = 1.0 / (eta_ti * eta_ti);
        Some(BsdfSample {
            wo: wo.normalize(),
            weight: Rgb::splat(scale),
            pdf: 1.0 - f,
            specular: true,
            eta: eta_ti,
            null: false,
        })
    }
}
