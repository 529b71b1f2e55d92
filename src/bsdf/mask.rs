//! Mitsuba's `mask`: a nested BSDF with an opacity α (a number or a
//! texture, read as a number at the hit's uv and clipped to [0, 1]). A
//! fraction 1 − α of the light passes straight through: a delta lobe
//! (wo = −wi, weight 1, discrete probability 1 − α), the way Mitsuba
//! samples its null component. Shadow rays stop at masked surfaces, as
//! in Mitsuba's `path`; light through the holes is found by sampling.
//! Like Mitsuba, `twosided` refuses a mask (the holes transmit); a mask
//! over a `twosided` is the way to write a two-sided masked surface.

use super::params::BsdfError;
use super::{Bsdf, BsdfSample};
use crate::color::Rgb;
use crate::math::{Vec2, Vec3};
use crate::texture::{SurfacePoint, Texture};

#[derive(Clone, Debug, PartialEq)]
pub struct Mask {
    /// Opacity, read as a number (`Texture::eval_1`).
    pub opacity: Texture,
    pub nested: Bsdf,
}

impl Mask {
    /// `opacity` must be finite and not negative (it is clipped to at
    /// most 1 where read, as Mitsuba does).
    pub fn new(opacity: Texture, nested: Bsdf) -> Result<Mask, BsdfError> {
        super::params::texture_color(super::BsdfParam::Opacity, &opacity)?;
        Ok(Mask { opacity, nested })
    }

    #[inline]
    pub(crate) fn alpha(&self, at: SurfacePoint) -> f32 {
        self.opacity.eval_1(at).clamp(0.0, 1.0)
    }

    pub fn eval(&self, at: SurfacePoint, wi: Vec3, wo: Vec3) -> Rgb {
        self.nested.eval(at, wi, wo) * self.alpha(at)
    }

    pub fn pdf(&self, at: SurfacePoint, wi: Vec3, wo: Vec3) -> f32 {
        self.nested.pdf(at, wi, wo) * self.alpha(at)
    }

    /// The nested BSDF with probability α (`u_lobe` rescaled for it), else
    /// straight through.
    pub fn sample(&self, at: SurfacePoint, wi: Vec3, u: Vec2, u_lobe: f32) -> Option<BsdfSample> {
        let alpha = self.alpha(at);
        if u_lobe < alpha {
            let mut s = self
                .nested
                .sample(at, wi, u, (u_lobe / alpha).min(1.0 - f32::EPSILON))?;
            s.pdf *= alpha;
            return Some(s);
        }
        Some(BsdfSample {
            wo: -wi,
            weight: Rgb::ONE,
            pdf: 1.0 - alpha,
            specular: true,
            eta: 1.0,
            null: true,
        })
    }
}
