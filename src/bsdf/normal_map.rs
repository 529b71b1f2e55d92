//! Mitsuba's `normalmap`: the tilt of a [`super::Tilted`] BSDF read from a
//! texture (colour c gives the normal 2c − 1 in the hit's shading frame,
//! whose x axis is dp/du).

use super::params::BsdfError;
use crate::color::Rgb;
use crate::math::Vec3;
use crate::texture::{SurfacePoint, Texture};

#[derive(Clone, Debug, PartialEq)]
pub struct NormalMap {
    /// Normals encoded as (n + 1) / 2, read with `Texture::eval`.
    pub normals: Texture,
}

impl NormalMap {
    /// The texture's values must be finite.
    pub fn new(normals: Texture) -> Result<NormalMap, BsdfError> {
        if !normals.max_value().is_finite() {
            return Err(BsdfError::NegativeColor {
                param: super::BsdfParam::NormalMap,
                value: Rgb::splat(normals.max_value()),
            });
        }
        Ok(NormalMap { normals })
    }

    /// The normal at `at` (not normalised).
    #[inline]
    pub fn normal(&self, at: SurfacePoint) -> Vec3 {
        self.normals.eval(at) * 2.0 - 1.0
    }
}
