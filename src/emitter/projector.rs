//! Mitsuba's `projector`: a point light that projects an image like a
//! slide projector (a perspective camera run backwards). A point at
//! (x, y, z) in the light's frame (+z forward) reads the image at
//! uv = (0.5 − x / (2 z t), 0.5 − a y / (2 z t)), t = tan(fov_x / 2) and a
//! the image's aspect ratio, and receives π · scale · E(uv) / (z² cos θ)
//! from it (Mitsuba 3.9.1's `sample_direction`: the irradiance on a plane
//! facing the light at z = 1 is π · scale · E). Nothing outside the image.

use super::{EmitterError, LightSample};
use crate::color::{luminance, Rgb};
use crate::math::{Mat3, Transform, Vec2, Vec3, PI};
use crate::texture::Texture;

#[derive(Clone, Debug)]
pub struct Projector {
    pub position: Vec3,
    /// The optical axis in the world (unit).
    pub axis: Vec3,
    /// Directions from the world into the light's frame.
    to_local: Mat3,
    /// tan(fov_x / 2).
    tan_half: f32,
    /// The image's width / height.
    aspect: f32,
    pub scale: f32,
    pub irradiance: Texture,
}

/// A projector parameter that describes no light.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ProjectorError {
    #[error(transparent)]
    Emitter(#[from] EmitterError),
    #[error("must be an invertible transform, found a degenerate one")]
    ToWorld,
    #[error("must be finite and not negative, found {0}")]
    Scale(f32),
}

impl Projector {
    /// `fov_x_deg` the horizontal field of view, `aspect` the image's
    /// width / height (1 for a constant irradiance, as in Mitsuba).
    pub fn new(
        to_world: &Transform,
        irradiance: Texture,
        scale: f32,
        fov_x_deg: f32,
        aspect: f32,
    ) -> Result<Projector, ProjectorError> {
        let (position, axis, to_local) = super::placement(to_world).map_err(|e| match e {
            Some(p) => EmitterError::Position(p).into(),
            None => ProjectorError::ToWorld,
        })?;
        if !(scale >= 0.0 && scale.is_finite()) {
            return Err(ProjectorError::Scale(scale));
        }
        let max = irradiance.max_value();
        if !max.is_finite() || irradiance.constant().is_some_and(|c| c.min_element() < 0.0) {
            return Err(EmitterError::Radiance(Rgb::splat(max)).into());
        }
        Ok(Projector {
            position,
            axis,
            to_local,
            tan_half: (0.5 * fov_x_deg).to_radians().tan(),
            aspect,
            scale,
            irradiance,
        })
    }

    /// The world-to-light linear map (the axis is the local +z).
    pub fn to_local(&self) -> Mat3 {
        self.to_local
    }

    /// tan(fov_x / 2): the image spans +-tan_half along local x at z = 1.
    pub fn tan_half(&self) -> f32 {
        self.tan_half
    }

    /// The image's width over its height.
    pub fn aspect(&self) -> f32 {
        self.aspect
    }

    /// Cosine of the half-angle of the cone around the axis that holds
    /// the image (through its corners).
    pub fn cos_cone(&self) -> f32 {
        let corner = self.tan_half * (1.0 + 1.0 / (self.aspect * self.aspect)).sqrt();
        1.0 / (1.0 + corner * corner).sqrt()
    }

    /// Luminance of the power it emits: π · scale · mean(E) over the
    /// image's area on the plane at z = 1.
    pub fn power(&self) -> f32 {
        let area = 4.0 * self.tan_half * self.tan_half / self.aspect;
        PI * self.scale * luminance(self.irradiance.mean()) * area
    }

    pub fn sample(&self, p_ref: Vec3) -> Option<LightSample> {
        let to = self.position - p_ref;
        let d2 = to.length_squared();
        let local = self.to_local * -to;
        // (NaN coordinates are behind it too.)
        if d2 <= 0.0 || local.z.is_nan() || local.z <= 0.0 {
            return None;
        }
        let k = 0.5 / (local.z * self.tan_half);
        let uv = Vec2::new(0.5 - local.x * k, 0.5 - self.aspect * local.y * k);
        if !(uv.cmpge(Vec2::ZERO).all() && uv.cmple(Vec2::ONE).all()) {
            return None;
        }
        let dist = d2.sqrt();
        let wi = to / dist;
        let cos = self.axis.dot(-wi);
        let e = self.irradiance.eval(uv);
        if e == Rgb::ZERO || cos.is_nan() || cos <= 0.0 {
            return None;
        }
        Some(LightSample::at_point(
            self.position,
            wi,
            dist,
            e * (PI * self.scale / (local.z * local.z * cos)),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The irradiance on a plane facing the projector at distance d is
    /// π · scale · E / d² on the axis; off the axis the intensity grows as
    /// 1 / cos³ (a plane at z = 1 gets π · scale · E everywhere on it).
    #[test]
    fn a_plane_facing_it_is_lit_evenly() {
        let p = Projector::new(
            &Transform::IDENTITY,
            Texture::Constant(Rgb::new(1.0, 2.0, 3.0)),
            0.5,
            60.0,
            1.0,
        )
        .unwrap();
        let t = 30f32.to_radians().tan();
        for (x, y) in [(0.0, 0.0), (0.3 * t, -0.8 * t), (-0.99 * t, 0.99 * t)] {
            let s = p.sample(Vec3::new(x, y, 1.0)).unwrap();
            // Irradiance on the plane: weight · cos.
            let e = s.weight * s.wi.dot(Vec3::NEG_Z);
            let expect = Rgb::new(1.0, 2.0, 3.0) * (PI * 0.5);
            assert!((e - expect).abs().max_element() < 1e-4, "{x} {y}: {e}");
        }
        assert!(p.sample(Vec3::new(1.01 * t, 0.0, 1.0)).is_none());
        assert!(p.sample(Vec3::new(0.0, 0.0, -1.0)).is_none());
        let expect = PI * 0.5 * luminance(Rgb::new(1.0, 2.0, 3.0)) * 4.0 * t * t;
        assert!((p.power() - expect).abs() < 1e-4 * expect);
    }
}
