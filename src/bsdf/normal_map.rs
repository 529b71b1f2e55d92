//! Mitsuba's `normalmap`: a nested BSDF seen in a shading frame tilted by
//! a normal read from a texture (colour c gives the normal 2c − 1 in the
//! hit's shading frame, whose x axis is dp/du). As in Mitsuba 3.9.1: a
//! normal facing away from `wi` is mirrored through the shading normal
//! (`flip_invalid_normals`); directions on opposite sides of the two
//! frames carry nothing; Estevez et al.'s shadowing term softens the
//! terminator (`use_shadowing_function`). Works in the local frame, so
//! the renderer knows nothing of it.

use super::params::BsdfError;
use super::{Bsdf, BsdfSample};
use crate::color::Rgb;
use crate::math::{Frame, Vec2, Vec3};
use crate::texture::{SurfacePoint, Texture};

#[derive(Clone, Debug, PartialEq)]
pub struct NormalMap {
    /// Normals encoded as (n + 1) / 2, read with `Texture::eval`.
    pub normals: Texture,
    pub nested: Bsdf,
    pub flip_invalid_normals: bool,
    pub use_shadowing_function: bool,
}

/// tan²θ of a local direction (infinite at the horizon).
#[inline]
fn tan2_theta(v: Vec3) -> f32 {
    let c2 = v.z * v.z;
    (1.0 - c2).max(0.0) / c2
}

/// Estevez et al. 2019's shadowing term for a normal `n` tilted in the
/// shading frame, seen from `wo` (local to the unperturbed frame).
#[inline]
pub(super) fn shadow_terminator(n: Vec3, wo: Vec3) -> f32 {
    let alpha2 = (0.125 * tan2_theta(n)).min(1.0);
    let s = 2.0 / (1.0 + (1.0 + alpha2 * tan2_theta(wo)).sqrt());
    if s.is_finite() {
        s
    } else {
        0.0
    }
}

impl NormalMap {
    pub fn new(
        normals: Texture,
        nested: Bsdf,
        flip_invalid_normals: bool,
        use_shadowing_function: bool,
    ) -> Result<NormalMap, BsdfError> {
        if !normals.max_value().is_finite() {
            return Err(BsdfError::NegativeColor {
                param: super::BsdfParam::NormalMap,
                value: Rgb::splat(normals.max_value()),
            });
        }
        Ok(NormalMap {
            normals,
            nested,
            flip_invalid_normals,
            use_shadowing_function,
        })
    }

    /// The tilted frame in the local shading frame at `uv`, seen from `wi`.
    #[inline]
    fn frame(&self, at: SurfacePoint, wi: Vec3) -> Frame {
        let mut n = self.normals.eval(at) * 2.0 - 1.0;
        if self.flip_invalid_normals && wi.z * wi.dot(n) <= 0.0 {
            n = Vec3::new(-n.x, -n.y, n.z);
        }
        tilted_frame(n)
    }

    pub fn eval(&self, at: SurfacePoint, wi: Vec3, wo: Vec3) -> Rgb {
        let f = self.frame(at, wi);
        eval_tilted(&self.nested, &f, self.use_shadowing_function, at, wi, wo)
    }

    pub fn pdf(&self, at: SurfacePoint, wi: Vec3, wo: Vec3) -> f32 {
        pdf_tilted(&self.nested, &self.frame(at, wi), at, wi, wo)
    }

    pub fn sample(&self, at: SurfacePoint, wi: Vec3, u: Vec2, u_lobe: f32) -> Option<BsdfSample> {
        let f = self.frame(at, wi);
        sample_tilted(
            &self.nested,
            &f,
            self.use_shadowing_function,
            at,
            wi,
            u,
            u_lobe,
        )
    }
}

/// `nested`'s value seen in the tilted frame `f` (local to the shading
/// frame), as this frame's BSDF: its cosine over ours, times the shadowing
/// term; zero where `wo` and its tilted image lie on opposite sides.
/// Shared by `normalmap` and `bumpmap`, which differ only in the frame.
#[inline]
pub(super) fn eval_tilted(
    nested: &Bsdf,
    f: &Frame,
    shadowing: bool,
    at: SurfacePoint,
    wi: Vec3,
    wo: Vec3,
) -> Rgb {
    let pwo = f.to_local(wo);
    if wo.z * pwo.z <= 0.0 {
        return Rgb::ZERO;
    }
    let shadow = if shadowing {
        shadow_terminator(f.n, wo)
    } else {
        1.0
    };
    nested.eval(at, f.to_local(wi), pwo) * (shadow * pwo.z.abs() / wo.z.abs())
}

/// `nested`'s density in the tilted frame `f` (see [`eval_tilted`]).
#[inline]
pub(super) fn pdf_tilted(nested: &Bsdf, f: &Frame, at: SurfacePoint, wi: Vec3, wo: Vec3) -> f32 {
    let pwo = f.to_local(wo);
    if wo.z * pwo.z <= 0.0 {
        return 0.0;
    }
    nested.pdf(at, f.to_local(wi), pwo)
}

/// A sample of `nested` in the tilted frame `f` (see [`eval_tilted`]).
#[inline]
#[allow(clippy::too_many_arguments)]
pub(super) fn sample_tilted(
    nested: &Bsdf,
    f: &Frame,
    shadowing: bool,
    at: SurfacePoint,
    wi: Vec3,
    u: Vec2,
    u_lobe: f32,
) -> Option<BsdfSample> {
    let mut s = nested.sample(at, f.to_local(wi), u, u_lobe)?;
    let pwo = s.wo;
    s.wo = f.to_world(pwo);
    if s.wo.z * pwo.z <= 0.0 {
        return None;
    }
    if shadowing {
        s.weight *= shadow_terminator(f.n, s.wo);
    }
    Some(s)
}

/// The frame around a tilted normal `n` (not necessarily unit) whose s
/// axis is the shading frame's x made orthogonal to it, as Mitsuba builds
/// it; the untilted frame where `n` is degenerate.
#[inline]
pub(super) fn tilted_frame(n: Vec3) -> Frame {
    let n = n.normalize_or_zero();
    if n == Vec3::ZERO {
        return Frame {
            s: Vec3::X,
            t: Vec3::Y,
            n: Vec3::Z,
        };
    }
    let s = (Vec3::X - n * n.x).normalize_or_zero();
    if s == Vec3::ZERO {
        return Frame::from_normal(n);
    }
    Frame {
        s,
        t: n.cross(s),
        n,
    }
}
