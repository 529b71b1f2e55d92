//! Directional lights: parallel light from infinitely far away (a delta in
//! direction).

use super::{EmitterContext, EmitterError, LightSample};
use crate::color::{luminance, Rgb};
use crate::math::{Vec3, PI};

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DirectionalLight {
    /// Unit direction the light travels in.
    pub direction: Vec3,
    /// Irradiance on a surface facing the light.
    pub irradiance: Rgb,
}

impl DirectionalLight {
    /// `direction`: finite and not zero (it is normalised); `irradiance`
    /// finite and not negative.
    pub fn new(direction: Vec3, irradiance: Rgb) -> Result<DirectionalLight, EmitterError> {
        let Some(direction) = direction.try_normalize() else {
            return Err(EmitterError::Direction(direction));
        };
        Ok(DirectionalLight {
            direction,
            irradiance: super::radiance(irradiance)?,
        })
    }

    /// The power falling on the scene's bounding disk.
    pub fn power(&self, ctx: &EmitterContext) -> f32 {
        PI * ctx.scene_radius * ctx.scene_radius * luminance(self.irradiance)
    }

    pub fn sample(&self, ctx: &EmitterContext, p_ref: Vec3) -> Option<LightSample> {
        Some(LightSample::at_infinity(
            ctx,
            p_ref,
            -self.direction,
            self.irradiance,
            0.0,
        ))
    }
}
