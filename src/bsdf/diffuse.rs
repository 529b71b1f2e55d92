//! Lambertian reflection: Nori's and Mitsuba's `diffuse`. One-sided (black
//! seen from below, as in Nori).

use super::params::{self, BsdfError, BsdfParam};
use super::BsdfSample;
use crate::color::Rgb;
use crate::math::{Vec2, Vec3, INV_PI};
use crate::sampling::warp;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Diffuse {
    pub albedo: Rgb,
}

impl Diffuse {
    /// `albedo`: finite and not negative (above 1 is allowed, as in Nori
    /// and Mitsuba; the readers warn).
    pub fn new(albedo: Rgb) -> Result<Diffuse, BsdfError> {
        Ok(Diffuse {
            albedo: params::color(BsdfParam::Diffuse, albedo)?,
        })
    }

    pub fn eval(&self, wi: Vec3, wo: Vec3) -> Rgb {
        self.eval_pdf(wi, wo).0
    }

    pub fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        self.eval_pdf(wi, wo).1
    }

    /// `(eval, pdf)` in one inlined call, where both formulas live: the
    /// one BSDF of most scenes' next-event estimates, where two
    /// out-of-line calls and their dispatch cost four times the work.
    #[inline]
    pub fn eval_pdf(&self, wi: Vec3, wo: Vec3) -> (Rgb, f32) {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            (Rgb::ZERO, 0.0)
        } else {
            (
                self.albedo * INV_PI,
                warp::square_to_cosine_hemisphere_pdf(wo),
            )
        }
    }

    /// Cosine-weighted: the weight is the albedo.
    pub fn sample(&self, wi: Vec3, u: Vec2) -> Option<BsdfSample> {
        if wi.z <= 0.0 {
            return None;
        }
        self.sample_toward(warp::square_to_cosine_hemisphere(u))
    }

    /// [`Diffuse::sample`] for a `wi` above the surface, given the
    /// cosine-weighted direction `wo` its numbers map to (a batch maps
    /// several in lanes: `warp::square_to_cosine_hemisphere_lanes`).
    #[inline]
    pub fn sample_toward(&self, wo: Vec3) -> Option<BsdfSample> {
        if wo.z <= 0.0 {
            return None;
        }
        Some(BsdfSample {
            wo,
            weight: self.albedo,
            pdf: warp::square_to_cosine_hemisphere_pdf(wo),
            specular: false,
            eta: 1.0,
            null: false,
        })
    }
}
