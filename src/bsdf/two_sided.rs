//! Mitsuba's `twosided`: `front` seen from above, `back` (with directions
//! mirrored through the surface) seen from below. Boxed once at scene
//! load; never allocated per ray.

use super::params::BsdfError;
use super::{Bsdf, BsdfSample};
use crate::color::Rgb;
use crate::math::{Vec2, Vec3};
use crate::texture::SurfacePoint;

#[derive(Clone, Debug, PartialEq)]
pub struct TwoSided {
    pub front: Box<Bsdf>,
    pub back: Box<Bsdf>,
}

/// Mirror a direction through the surface (the back's view).
#[inline]
fn flip_z(v: Vec3) -> Vec3 {
    Vec3::new(v.x, v.y, -v.z)
}

impl TwoSided {
    /// One nested BSDF for both sides, or a second one for the back;
    /// neither may transmit (Mitsuba: "Only materials without a
    /// transmission component can be nested").
    pub fn new(front: Bsdf, back: Option<Bsdf>) -> Result<TwoSided, BsdfError> {
        let back = back.unwrap_or_else(|| front.clone());
        if front.has_transmission() || back.has_transmission() {
            return Err(BsdfError::NestedTransmission);
        }
        Ok(TwoSided {
            front: Box::new(front),
            back: Box::new(back),
        })
    }

    pub fn eval(&self, at: SurfacePoint, wi: Vec3, wo: Vec3) -> Rgb {
        if wi.z > 0.0 {
            self.front.eval(at, wi, wo)
        } else if wi.z < 0.0 {
            self.back.eval(at, flip_z(wi), flip_z(wo))
        } else {
            Rgb::ZERO
        }
    }

    pub fn pdf(&self, at: SurfacePoint, wi: Vec3, wo: Vec3) -> f32 {
        if wi.z > 0.0 {
            self.front.pdf(at, wi, wo)
        } else if wi.z < 0.0 {
            self.back.pdf(at, flip_z(wi), flip_z(wo))
        } else {
            0.0
        }
    }

    pub fn sample(&self, at: SurfacePoint, wi: Vec3, u: Vec2, u_lobe: f32) -> Option<BsdfSample> {
        if wi.z > 0.0 {
            self.front.sample(at, wi, u, u_lobe)
        } else if wi.z < 0.0 {
            self.back.sample(at, flip_z(wi), u, u_lobe).map(|mut s| {
                s.wo = flip_z(s.wo);
                s
            })
        } else {
            None
        }
    }
}
