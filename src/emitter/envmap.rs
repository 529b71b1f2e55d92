//! Image-based lighting from a lat-long HDR probe. (Filled in by the
//! environment-map work; this is the interface the renderer uses.)

use crate::color::Rgb;
use crate::image::Bitmap;
use crate::math::{Transform, Vec2, Vec3};

/// How texels are looked up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EnvFilter {
    Bilinear,
    Nearest,
}

/// A lat-long environment map, importance-sampled by luminance x sin(theta).
#[derive(Clone, Debug)]
pub struct EnvMap {
    pub image: Bitmap,
    pub scale: f32,
    pub to_world: Transform,
    pub filter: EnvFilter,
    /// Seen by camera rays (it lights the scene either way).
    pub visible: bool,
}

impl EnvMap {
    pub fn new(image: Bitmap, scale: f32, to_world: Transform, filter: EnvFilter) -> EnvMap {
        EnvMap {
            image,
            scale,
            to_world,
            filter,
            visible: true,
        }
    }

    /// Radiance seen in world direction `d`.
    pub fn eval(&self, _d: Vec3) -> Rgb {
        Rgb::ZERO
    }

    /// (direction, radiance / pdf, solid-angle pdf).
    pub fn sample(&self, _u: Vec2) -> Option<(Vec3, Rgb, f32)> {
        None
    }

    /// Solid-angle pdf of sampling world direction `d`.
    pub fn pdf(&self, _d: Vec3) -> f32 {
        0.0
    }

    /// Mean luminance over the sphere (for choosing between lights).
    pub fn mean_luminance(&self) -> f32 {
        0.0
    }
}
