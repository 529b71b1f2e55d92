//! Nori's `mirror`: perfect specular reflection of everything (a delta
//! lobe), one-sided.

use super::BsdfSample;
use crate::color::Rgb;
use crate::math::Vec3;

#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Mirror;

impl Mirror {
    pub fn sample(&self, wi: Vec3) -> Option<BsdfSample> {
        if wi.z <= 0.0 {
            return None;
        }
        Some(BsdfSample {
            wo: Vec3::new(-wi.x, -wi.y, wi.z),
            weight: Rgb::ONE,
            pdf: 1.0,
            specular: true,
            eta: 1.0,
            null: false,
        })
    }
}
