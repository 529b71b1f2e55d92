//! Smooth dielectric: Fresnel-weighted choice of reflection or refraction.

use super::{fresnel_dielectric, BsdfSample};
use crate::color::Rgb;
use crate::math::Vec3;

/// Samples reflection with probability F, refraction otherwise. The weight is
/// 1 for reflection and 1/eta^2 for refraction (radiance scaling), so the
/// estimator is exact for each lobe.
pub fn sample(eta: f32, wi: Vec3, u: f32) -> BsdfSample {
    let cos_i = wi.z;
    let (f, cos_t, eta_ti) = fresnel_dielectric(cos_i, eta);
    if u < f {
        BsdfSample {
            wo: Vec3::new(-wi.x, -wi.y, wi.z),
            weight: Rgb::ONE,
            pdf: f,
            specular: true,
            eta: 1.0,
        }
    } else {
        let wo = Vec3::new(
            -wi.x / eta_ti,
            -wi.y / eta_ti,
            if cos_i >= 0.0 { -cos_t } else { cos_t },
        );
        let scale = 1.0 / (eta_ti * eta_ti);
        BsdfSample {
            wo: wo.normalize(),
            weight: Rgb::splat(scale),
            pdf: 1.0 - f,
            specular: true,
            eta: eta_ti,
        }
    }
}
