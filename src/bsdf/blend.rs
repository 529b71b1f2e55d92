//! Mitsuba's `blendbsdf`: (1 − w) · `first` + w · `second`, with the
//! weight w a number or a texture (read as a number at the hit's uv and
//! clipped to [0, 1]). Sampling picks one BSDF with probability 1 − w or
//! w and returns the mixture's value and density in the sampled
//! direction, as Mitsuba 3 does, so MIS sees one consistent density. A
//! delta sample keeps its own weight (the other BSDF adds nothing to a
//! delta), with its probability scaled by the choice.

use super::params::BsdfError;
use super::{Bsdf, BsdfSample};
use crate::color::Rgb;
use crate::math::{Vec2, Vec3};
use crate::texture::{SurfacePoint, Texture};

#[derive(Clone, Debug, PartialEq)]
pub struct Blend {
    /// The second BSDF's share, read as a number (`Texture::eval_1`).
    pub weight: Texture,
    pub first: Bsdf,
    pub second: Bsdf,
}

impl Blend {
    /// `weight` must be finite and not negative (it is clipped to at most
    /// 1 where read, as Mitsuba does).
    pub fn new(weight: Texture, first: Bsdf, second: Bsdf) -> Result<Blend, BsdfError> {
        super::params::texture_color(super::BsdfParam::Weight, &weight)?;
        Ok(Blend {
            weight,
            first,
            second,
        })
    }

    #[inline]
    pub(crate) fn w(&self, at: SurfacePoint) -> f32 {
        self.weight.eval_1(at).clamp(0.0, 1.0)
    }

    pub fn eval(&self, at: SurfacePoint, wi: Vec3, wo: Vec3) -> Rgb {
        self.eval_with(self.w(at), at, wi, wo)
    }

    pub fn pdf(&self, at: SurfacePoint, wi: Vec3, wo: Vec3) -> f32 {
        self.pdf_with(self.w(at), at, wi, wo)
    }

    /// [`Blend::eval`] with the weight already read.
    #[inline]
    fn eval_with(&self, w: f32, at: SurfacePoint, wi: Vec3, wo: Vec3) -> Rgb {
        self.first.eval(at, wi, wo) * (1.0 - w) + self.second.eval(at, wi, wo) * w
    }

    /// [`Blend::pdf`] with the weight already read.
    #[inline]
    fn pdf_with(&self, w: f32, at: SurfacePoint, wi: Vec3, wo: Vec3) -> f32 {
        self.first.pdf(at, wi, wo) * (1.0 - w) + self.second.pdf(at, wi, wo) * w
    }

    /// `first` when `u_lobe` ≥ w, else `second` (`u_lobe` rescaled for the
    /// chosen one).
    pub fn sample(&self, at: SurfacePoint, wi: Vec3, u: Vec2, u_lobe: f32) -> Option<BsdfSample> {
        let w = self.w(at);
        let (chosen, p, u_lobe) = if u_lobe >= w {
            (&self.first, 1.0 - w, (u_lobe - w) / (1.0 - w))
        } else {
            (&self.second, w, u_lobe / w)
        };
        let mut s = chosen.sample(at, wi, u, u_lobe.min(1.0 - f32::EPSILON))?;
        if s.specular {
            s.pdf *= p;
            return Some(s);
        }
        // The mixture's value and density, the weight read once.
        let pdf = self.pdf_with(w, at, wi, s.wo);
        if pdf <= 0.0 {
            return None;
        }
        s.weight = self.eval_with(w, at, wi, s.wo) * s.wo.z.abs() / pdf;
        s.pdf = pdf;
        Some(s)
    }
}
