//! Uniform radiance from every direction at infinity (Mitsuba's
//! `constant`), sampled uniformly over the sphere.

use super::{EmitterContext, EmitterError, LightSample};
use crate::color::{luminance, Rgb};
use crate::math::{Vec2, Vec3, PI};
use crate::sampling::warp;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConstantLight {
    pub radiance: Rgb,
}

impl ConstantLight {
    /// `radiance`: finite and not negative.
    pub fn new(radiance: Rgb) -> Result<ConstantLight, EmitterError> {
        Ok(ConstantLight {
            radiance: super::radiance(radiance)?,
        })
    }

    /// The power falling on the scene's bounding sphere.
    pub fn power(&self, ctx: &EmitterContext) -> f32 {
        PI * ctx.scene_radius * ctx.scene_radius * PI * luminance(self.radiance)
    }

    pub fn sample(&self, ctx: &EmitterContext, p_ref: Vec3, u: Vec2) -> Option<LightSample> {
        Some(self.sample_toward(ctx, p_ref, warp::square_to_uniform_sphere(u)))
    }

    /// [`ConstantLight::sample`] whose uniform direction `wi` is drawn
    /// (a batch draws four at a time:
    /// [`warp::square_to_uniform_sphere_lanes`]).
    #[inline]
    pub fn sample_toward(&self, ctx: &EmitterContext, p_ref: Vec3, wi: Vec3) -> LightSample {
        let pdf = warp::square_to_uniform_sphere_pdf(wi);
        LightSample::at_infinity(ctx, p_ref, wi, self.radiance / pdf, pdf)
    }

    pub fn pdf(&self, wi: Vec3) -> f32 {
        warp::square_to_uniform_sphere_pdf(wi)
    }

    /// [`ConstantLight::pdf`], the same for every direction.
    pub fn uniform_pdf(&self) -> f32 {
        self.pdf(Vec3::Z)
    }
}
