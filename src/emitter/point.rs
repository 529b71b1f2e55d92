//! Isotropic point lights (a delta in position).

use super::{EmitterError, LightSample};
use crate::color::{luminance, Rgb};
use crate::math::{Vec3, PI};

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointLight {
    pub position: Vec3,
    /// Radiant intensity in W/sr.
    pub intensity: Rgb,
}

impl PointLight {
    /// A finite `position`; `intensity` finite and not negative.
    pub fn new(position: Vec3, intensity: Rgb) -> Result<PointLight, EmitterError> {
        if !position.is_finite() {
            return Err(EmitterError::Position(position));
        }
        Ok(PointLight {
            position,
            intensity: super::radiance(intensity)?,
        })
    }

    pub fn power(&self) -> f32 {
        4.0 * PI * luminance(self.intensity)
    }

    pub fn sample(&self, p_ref: Vec3) -> Option<LightSample> {
        LightSample::from_point(self.position, p_ref, |_| Some(self.intensity))
    }
}
