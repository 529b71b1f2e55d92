//! What Mitsuba's `normalmap` and `bumpmap` share: a nested BSDF seen in a
//! shading frame tilted by a normal that a [`Tilt`] gives (a normal map's
//! texel, or a bump map's bumped normal). As in Mitsuba 3.9.1: a normal
//! facing away from `wi` is mirrored through the shading normal
//! (`flip_invalid_normals`); the tilted frame's s axis is the tilt's
//! tangent made orthogonal to the normal; directions on opposite sides of
//! the two frames carry nothing; Estevez et al.'s shadowing term softens
//! the terminator (`use_shadowing_function`). Works in the local frame.

use super::bump_map::BumpMap;
use super::normal_map::NormalMap;
use super::{Bsdf, BsdfSample};
use crate::color::Rgb;
use crate::math::{Frame, Vec2, Vec3};
use crate::texture::{SurfacePoint, Texture};

/// Where the tilted normal comes from.
#[derive(Clone, Debug, PartialEq)]
pub enum Tilt {
    NormalMap(NormalMap),
    BumpMap(BumpMap),
}

#[derive(Clone, Debug, PartialEq)]
pub struct Tilted {
    pub tilt: Tilt,
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
fn shadow_terminator(n: Vec3, wo: Vec3) -> f32 {
    let alpha2 = (0.125 * tan2_theta(n)).min(1.0);
    let s = 2.0 / (1.0 + (1.0 + alpha2 * tan2_theta(wo)).sqrt());
    if s.is_finite() {
        s
    } else {
        0.0
    }
}

/// The frame around a tilted normal `n` (not necessarily unit) whose s
/// axis is `tangent` made orthogonal to it, as Mitsuba builds it; the
/// shading frame's x in its place where that is degenerate, and the
/// untilted frame where `n` is.
#[inline]
fn frame_around(n: Vec3, tangent: Vec3) -> Frame {
    let n = n.normalize_or_zero();
    if n == Vec3::ZERO {
        return Frame {
            s: Vec3::X,
            t: Vec3::Y,
            n: Vec3::Z,
        };
    }
    let mut s = (tangent - n * n.dot(tangent)).normalize_or_zero();
    if s == Vec3::ZERO {
        s = (Vec3::X - n * n.x).normalize_or_zero();
    }
    if s == Vec3::ZERO {
        return Frame::from_normal(n);
    }
    Frame {
        s,
        t: n.cross(s),
        n,
    }
}

impl Tilted {
    /// The textures the tilt reads (for the loader's binding).
    pub fn texture_mut(&mut self) -> &mut Texture {
        match &mut self.tilt {
            Tilt::NormalMap(m) => &mut m.normals,
            Tilt::BumpMap(b) => &mut b.height,
        }
    }

    /// The tilted frame in the local shading frame at `at`, seen from
    /// `wi`.
    #[inline]
    pub(super) fn frame(&self, at: SurfacePoint, wi: Vec3) -> Frame {
        let (mut n, tangent) = match &self.tilt {
            Tilt::NormalMap(m) => (m.normal(at), Vec3::X),
            Tilt::BumpMap(b) => (b.normal(at), at.dp_du),
        };
        if self.flip_invalid_normals && wi.z * wi.dot(n) <= 0.0 {
            n = Vec3::new(-n.x, -n.y, n.z);
        }
        frame_around(n, tangent)
    }

    /// The nested BSDF's value in the tilted frame as this frame's BSDF:
    /// its cosine over ours, times the shadowing term.
    pub fn eval(&self, at: SurfacePoint, wi: Vec3, wo: Vec3) -> Rgb {
        let f = self.frame(at, wi);
        let pwo = f.to_local(wo);
        if wo.z * pwo.z <= 0.0 {
            return Rgb::ZERO;
        }
        let shadow = if self.use_shadowing_function {
            shadow_terminator(f.n, wo)
        } else {
            1.0
        };
        self.nested.eval(at, f.to_local(wi), pwo) * (shadow * pwo.z.abs() / wo.z.abs())
    }

    pub fn pdf(&self, at: SurfacePoint, wi: Vec3, wo: Vec3) -> f32 {
        let f = self.frame(at, wi);
        let pwo = f.to_local(wo);
        if wo.z * pwo.z <= 0.0 {
            return 0.0;
        }
        self.nested.pdf(at, f.to_local(wi), pwo)
    }

    pub fn sample(&self, at: SurfacePoint, wi: Vec3, u: Vec2, u_lobe: f32) -> Option<BsdfSample> {
        let f = self.frame(at, wi);
        let mut s = self.nested.sample(at, f.to_local(wi), u, u_lobe)?;
        let pwo = s.wo;
        s.wo = f.to_world(pwo);
        if s.wo.z * pwo.z <= 0.0 {
            return None;
        }
        if self.use_shadowing_function {
            s.weight *= shadow_terminator(f.n, s.wo);
        }
        Some(s)
    }
}
