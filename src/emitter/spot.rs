//! Mitsuba's `spot`: a point light that shines along its local +z inside
//! a cone. Full intensity out to `beam_width`, then falling linearly in
//! angle to zero at `cutoff_angle` (Mitsuba 3.9.1's `falloff_curve`); an
//! optional texture projected through the cone tints it, read at
//! uv = 0.5 + 0.5 (x, y) / (z tan(cutoff)) of the local direction.

use super::{EmitterError, LightSample};
use crate::color::{luminance, Rgb};
use crate::math::{Mat3, Transform, Vec2, Vec3, PI};
use crate::texture::Texture;

#[derive(Clone, Debug)]
pub struct SpotLight {
    pub position: Vec3,
    /// The beam's axis in the world (unit).
    pub axis: Vec3,
    /// Radiant intensity on the axis, W/sr.
    pub intensity: Rgb,
    /// Directions from the world into the light's frame (the inverse of
    /// `to_world`'s linear part, as Mitsuba applies it).
    to_local: Mat3,
    cos_cutoff: f32,
    cos_beam: f32,
    cutoff: f32,
    inv_transition: f32,
    uv_factor: f32,
    texture: Option<Texture>,
}

/// A spot light parameter that describes no light; each message completes
/// a sentence that starts with the parameter's name.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SpotError {
    #[error(transparent)]
    Emitter(#[from] EmitterError),
    #[error("must be more than 0 and less than 90 degrees, found {0}")]
    Cutoff(f32),
    #[error("must be between 0 degrees and the cutoff angle ({cutoff}), found {beam}")]
    Beam { beam: f32, cutoff: f32 },
    #[error("must be an invertible transform whose +z is not degenerate")]
    ToWorld,
    #[error("must have finite values, found a largest of {0}")]
    Texture(f32),
}

impl SpotLight {
    /// Angles in degrees; `to_world` places the light at its origin,
    /// shining along its +z.
    pub fn new(
        to_world: &Transform,
        intensity: Rgb,
        cutoff_deg: f32,
        beam_deg: f32,
        texture: Option<Texture>,
    ) -> Result<SpotLight, SpotError> {
        if !(cutoff_deg > 0.0 && cutoff_deg < 90.0) {
            return Err(SpotError::Cutoff(cutoff_deg));
        }
        if !(beam_deg >= 0.0 && beam_deg <= cutoff_deg) {
            return Err(SpotError::Beam {
                beam: beam_deg,
                cutoff: cutoff_deg,
            });
        }
        let (position, axis, to_local) = super::placement(to_world).map_err(|e| match e {
            Some(p) => EmitterError::Position(p).into(),
            None => SpotError::ToWorld,
        })?;
        if let Some(t) = &texture {
            if !t.max_value().is_finite() {
                return Err(SpotError::Texture(t.max_value()));
            }
        }
        let (cutoff, beam) = (cutoff_deg.to_radians(), beam_deg.to_radians());
        Ok(SpotLight {
            position,
            axis,
            intensity: super::radiance(intensity)?,
            to_local,
            cos_cutoff: cutoff.cos(),
            cos_beam: beam.cos(),
            cutoff,
            inv_transition: 1.0 / (cutoff - beam),
            uv_factor: cutoff.tan(),
            texture,
        })
    }

    /// Cosine of the cone's half-angle: no light beyond it.
    pub fn cos_cutoff(&self) -> f32 {
        self.cos_cutoff
    }

    /// Cosine of the beam angle (full intensity inside it).
    pub fn cos_beam(&self) -> f32 {
        self.cos_beam
    }

    /// The world-to-light linear map (the cone's axis is the local +z).
    pub fn to_local(&self) -> Mat3 {
        self.to_local
    }

    /// The texture projected through the cone, if any.
    pub fn texture(&self) -> Option<&Texture> {
        self.texture.as_ref()
    }

    /// Luminance of the power it emits: the intensity (times the
    /// texture's mean) over the cone, the falloff counted at half.
    pub fn power(&self) -> f32 {
        let tint = self.texture.as_ref().map_or(1.0, |t| luminance(t.mean()));
        let full = 1.0 - self.cos_beam;
        let ramp = self.cos_beam - self.cos_cutoff;
        2.0 * PI * (full + 0.5 * ramp) * luminance(self.intensity) * tint
    }

    /// Intensity leaving the light in world direction `d` (unit).
    fn intensity_towards(&self, d: Vec3) -> Rgb {
        let local = self.to_local * d;
        let cos = local.z / local.length();
        // (NaN, from a zero direction, is dark too.)
        if cos.is_nan() || cos <= self.cos_cutoff {
            return Rgb::ZERO;
        }
        let falloff = if cos >= self.cos_beam {
            1.0
        } else {
            (self.cutoff - cos.clamp(-1.0, 1.0).acos()) * self.inv_transition
        };
        let mut i = self.intensity * falloff;
        if let Some(t) = &self.texture {
            let k = 0.5 / (local.z * self.uv_factor);
            i *= t.eval(Vec2::new(0.5 + local.x * k, 0.5 + local.y * k));
        }
        i
    }

    pub fn sample(&self, p_ref: Vec3) -> Option<LightSample> {
        LightSample::from_point(self.position, p_ref, |wi| {
            Some(self.intensity_towards(-wi)).filter(|i| *i != Rgb::ZERO)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Mat4;

    /// A spot 2 above the origin shining down (-y), beam 10, cutoff 30.
    fn down(texture: Option<Texture>) -> SpotLight {
        // Mitsuba's look_at from (0, 2, 0) to the origin, up +z: columns
        // (left, up, dir, origin).
        let to_world = Transform::new(Mat4::from_cols(
            Vec3::X.extend(0.0),
            Vec3::Z.extend(0.0),
            Vec3::NEG_Y.extend(0.0),
            Vec3::new(0.0, 2.0, 0.0).extend(1.0),
        ))
        .unwrap();
        SpotLight::new(&to_world, Rgb::new(4.0, 2.0, 1.0), 30.0, 10.0, texture).unwrap()
    }

    /// Irradiance-to-intensity factor at a floor point seen at `deg` off
    /// the axis: intensity × d² (1 on the axis).
    fn falloff_at(s: &SpotLight, deg: f32) -> Rgb {
        let x = 2.0 * deg.to_radians().tan();
        let p = Vec3::new(x, 0.0, 0.0);
        let d2 = (s.position - p).length_squared();
        s.sample(p).map_or(Rgb::ZERO, |l| l.weight * d2)
    }

    #[test]
    fn full_inside_the_beam_linear_to_the_cutoff_then_dark() {
        let s = down(None);
        assert!((s.axis - Vec3::NEG_Y).length() < 1e-6);
        let i = Rgb::new(4.0, 2.0, 1.0);
        for (deg, k) in [
            (0.0, 1.0),
            (9.0, 1.0),
            (15.0, 0.75),
            (20.0, 0.5),
            (25.0, 0.25),
        ] {
            let got = falloff_at(&s, deg);
            assert!((got - i * k).abs().max_element() < 2e-4, "{deg}: {got}");
        }
        assert!(s
            .sample(Vec3::new(2.0 * 31f32.to_radians().tan(), 0.0, 0.0))
            .is_none());
        assert!(
            s.sample(Vec3::new(0.0, 3.0, 0.0)).is_none(),
            "behind the light"
        );
        // Power: 2 pi (1 - cos 10 + (cos 10 - cos 30) / 2) times the luminance.
        let (c10, c30) = (10f32.to_radians().cos(), 30f32.to_radians().cos());
        let expect = 2.0 * PI * (1.0 - c10 + 0.5 * (c10 - c30)) * luminance(i);
        assert!((s.power() - expect).abs() < 1e-4 * expect);
    }

    #[test]
    fn the_texture_is_projected_through_the_cone() {
        // A checkerboard read at v = 0.25: u below 0.5 is colour0. The
        // light's local x is the world's +x, so a point at world +x
        // reads u > 0.5.
        let t = Texture::Checkerboard(crate::texture::Checkerboard {
            color0: Rgb::new(1.0, 0.0, 0.0),
            color1: Rgb::new(0.0, 1.0, 0.0),
            to_uv: crate::texture::UvTransform {
                row0: [1.0, 0.0, 0.0],
                row1: [0.0, 0.0, 0.25],
            },
        });
        let s = down(Some(t));
        let plus_x = falloff_at(&s, 5.0);
        let minus_x = falloff_at(&s, -5.0);
        assert!(plus_x.y > 0.0 && plus_x.x == 0.0, "{plus_x}");
        assert!(minus_x.x > 0.0 && minus_x.y == 0.0, "{minus_x}");
        assert!(matches!(
            SpotLight::new(&Transform::IDENTITY, Rgb::ONE, 20.0, 25.0, None),
            Err(SpotError::Beam { .. })
        ));
        assert!(matches!(
            SpotLight::new(&Transform::IDENTITY, Rgb::ONE, 90.0, 25.0, None),
            Err(SpotError::Cutoff(_))
        ));
    }
}
