//! Smooth dielectric: Fresnel-weighted choice of reflection or refraction;
//! and Mitsuba's thin dielectric sheet.

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

/// Mitsuba's `thindielectric`: a sheet whose two parallel faces reflect
/// R' = R + T^2 R / (1 - R^2) = 2R / (1 + R) in total (all internal bounces),
/// with R the Fresnel reflectance at |cos|; the rest passes straight
/// through (wo = -wi, no refraction: the faces are parallel). Both lobes
/// are deltas, sampled in proportion to R' and 1 - R'; works from either
/// side.
pub fn sample_thin(
    eta: f32,
    specular_reflectance: Rgb,
    specular_transmittance: Rgb,
    wi: Vec3,
    u: f32,
) -> BsdfSample {
    let (r, _, _) = fresnel_dielectric(wi.z.abs(), eta);
    let r = 2.0 * r / (1.0 + r);
    if u <= r {
        BsdfSample {
            wo: Vec3::new(-wi.x, -wi.y, wi.z),
            weight: specular_reflectance,
            pdf: r,
            specular: true,
            eta: 1.0,
        }
    } else {
        BsdfSample {
            wo: -wi,
            weight: specular_transmittance,
            pdf: 1.0 - r,
            specular: true,
            eta: 1.0,
        }
    }
}
