//! Mitsuba's `bumpmap`: the tilt of a [`super::Tilted`] BSDF from a surface
//! displaced along its normal by `scale` times a texture's value (read as
//! a number). As in Mitsuba 3.9.1: dp/du and dp/dv gain the texture's
//! slopes along the normal, and the bumped normal is their cross product,
//! turned to the geometric normal's side; the tilted frame's s axis
//! follows dp/du. dp/du, dp/dv and the geometric normal come in the
//! [`SurfacePoint`] (local to the shading frame): the renderer computes
//! them for shapes whose BSDF needs them.

use super::params::BsdfError;
use crate::math::Vec3;
use crate::texture::{SurfacePoint, Texture};

#[derive(Clone, Debug, PartialEq)]
pub struct BumpMap {
    /// Displacement, read as a number (`Texture::eval_1` and its gradient).
    pub height: Texture,
    pub scale: f32,
}

impl BumpMap {
    /// The texture's values and `scale` must be finite.
    pub fn new(height: Texture, scale: f32) -> Result<BumpMap, BsdfError> {
        if !height.max_value().is_finite() || !scale.is_finite() {
            return Err(BsdfError::NotPositive {
                param: super::BsdfParam::BumpScale,
                value: scale,
            });
        }
        Ok(BumpMap { height, scale })
    }

    /// The bumped normal at `at` (not normalised), on the geometric
    /// normal's side; zero where the differentials are missing or
    /// degenerate (the frame is then left untilted).
    #[inline]
    pub fn normal(&self, at: SurfacePoint) -> Vec3 {
        let grad = self.height.eval_1_grad(at) * self.scale;
        // The shading normal is +z here.
        let dp_du = Vec3::new(at.dp_du.x, at.dp_du.y, grad.x);
        let dp_dv = Vec3::new(at.dp_dv.x, at.dp_dv.y, grad.y);
        let n = dp_du.cross(dp_dv);
        if !n.is_finite() {
            Vec3::ZERO
        } else if at.ng.dot(n) < 0.0 {
            -n
        } else {
            n
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::{Bsdf, Tilt, Tilted};
    use crate::color::Rgb;
    use crate::image::Bitmap;
    use crate::math::Vec2;
    use crate::texture::{BitmapTexture, FilterType, TextureImage, UvTransform, WrapMode};
    use std::sync::Arc;

    /// Heights 0 and 1 side by side: between the texel centres (u from
    /// 0.25 to 0.75) the height rises by 2 per unit of u.
    fn ramp() -> Texture {
        let image = Bitmap {
            width: 2,
            height: 1,
            pixels: vec![Rgb::ZERO, Rgb::ONE],
        };
        Texture::Bitmap(BitmapTexture::new(
            Arc::new(TextureImage::new(image)),
            FilterType::Bilinear,
            WrapMode::Clamp,
            UvTransform::IDENTITY,
        ))
    }

    fn flat(uv: Vec2) -> SurfacePoint {
        SurfacePoint {
            uv,
            dp_du: Vec3::X,
            dp_dv: Vec3::Y,
            ng: Vec3::Z,
            ..SurfacePoint::default()
        }
    }

    #[test]
    fn the_bumped_normal_leans_against_the_slope() {
        assert_eq!(ramp().eval_1_grad(Vec2::new(0.5, 0.5)), Vec2::new(2.0, 0.0));
        let b = Tilted {
            tilt: Tilt::BumpMap(BumpMap::new(ramp(), 0.25).unwrap()),
            nested: Bsdf::default(),
            flip_invalid_normals: true,
            use_shadowing_function: true,
        };
        let wi = Vec3::new(0.0, 0.3, 1.0).normalize();
        let f = b.frame(flat(Vec2::new(0.5, 0.5)), wi);
        // dp/du + 0.5 z crossed with dp/dv: (-0.5, 0, 1).
        let expect = Vec3::new(-0.5, 0.0, 1.0).normalize();
        assert!((f.n - expect).length() < 1e-5, "{}", f.n);
        assert!(f.s.dot(f.n).abs() < 1e-6 && (f.t - f.n.cross(f.s)).length() < 1e-6);
        // Seen from the side it leans away from, it is mirrored.
        let behind = Vec3::new(0.99, 0.0, 0.1).normalize();
        let g = b.frame(flat(Vec2::new(0.5, 0.5)), behind);
        assert!((g.n - Vec3::new(0.5, 0.0, 1.0).normalize()).length() < 1e-5);
        // Without differentials (or on the flat part) nothing tilts.
        let none = b.frame(SurfacePoint::from(Vec2::new(0.5, 0.5)), wi);
        assert_eq!(none.n, Vec3::Z);
        let edge = b.frame(flat(Vec2::new(0.1, 0.5)), wi);
        assert!((edge.n - Vec3::Z).length() < 1e-6);
    }

    #[test]
    fn weights_are_eval_cos_over_pdf_on_a_slope() {
        let nested = Bsdf::rough_plastic(
            crate::bsdf::MicrofacetType::Ggx,
            0.3,
            1.5,
            1.0,
            Rgb::splat(0.5),
            Rgb::ONE,
            false,
            true,
        )
        .unwrap();
        let b = Bsdf::bump_map(ramp(), 0.25, nested, true, true).unwrap();
        let at = flat(Vec2::new(0.4, 0.5));
        let wi = Vec3::new(0.3, -0.2, 0.9).normalize();
        let mut s = crate::sampling::Sampler::new(3, 3);
        let mut n = 0;
        for _ in 0..2000 {
            let Some(x) = b.sample(at, wi, s.next_2d(), s.next_1d()) else {
                continue;
            };
            n += 1;
            let pdf = b.pdf(at, wi, x.wo);
            let expect = b.eval(at, wi, x.wo) * x.wo.z.abs() / pdf;
            assert!((x.pdf - pdf).abs() <= 1e-3 * pdf, "{} vs {pdf}", x.pdf);
            assert!(
                (x.weight - expect).abs().max_element() <= 2e-3 * expect.max_element().max(1e-3)
            );
        }
        assert!(n > 1500, "{n}");
    }
}
