//! Directions to lat-long (u, v) and back (the convention is in the
//! module docs of `envmap`).

use crate::math::{
    clamp_unit_lanes, fast_atan2, fast_atan2_lanes, sin_cos_turns, sin_cos_turns_lanes, Vec2, Vec3,
    Vec4, INV_PI, INV_TWO_PI,
};

/// (u, v) to the local unit direction.
#[inline]
pub fn uv_to_dir(uv: Vec2) -> Vec3 {
    uv_to_dir_sin(uv).0
}

/// (u, v) to the local unit direction and its sin(theta).
#[inline]
pub fn uv_to_dir_sin(uv: Vec2) -> (Vec3, f32) {
    let (sin_phi, cos_phi) = sin_cos_turns(uv.x);
    let (sin_theta, cos_theta) = sin_cos_turns(0.5 * uv.y);
    let d = Vec3::new(sin_theta * sin_phi, cos_theta, -sin_theta * cos_phi);
    (d, sin_theta)
}

/// [`uv_to_dir_sin`] of four points in lanes: the direction's x, y and z,
/// and sin(theta), each lane bit for bit the scalar routine's.
#[inline]
pub fn uv_to_dir_sin_lanes(u: Vec4, v: Vec4) -> ([Vec4; 3], Vec4) {
    let (sin_phi, cos_phi) = sin_cos_turns_lanes(u);
    let (sin_theta, cos_theta) = sin_cos_turns_lanes(v * 0.5);
    (
        [sin_theta * sin_phi, cos_theta, -sin_theta * cos_phi],
        sin_theta,
    )
}

/// (u, v) and sin(theta) of a local direction (normalised or not; zero and
/// non-finite input give the top-left corner and sin(theta) = 0). The
/// angles are within [`FAST_ATAN2_MAX_ERROR`](crate::math::FAST_ATAN2_MAX_ERROR)
/// radians of libm's.
#[inline]
pub fn dir_to_uv_sin(d: Vec3) -> (Vec2, f32) {
    let len = d.length();
    if len > 0.0 && len.is_finite() {
        unit_dir_to_uv_sin(d / len)
    } else {
        (Vec2::ZERO, 0.0)
    }
}

/// [`dir_to_uv_sin`] of a unit direction (or one within rounding of unit
/// length).
#[inline]
pub fn unit_dir_to_uv_sin(d: Vec3) -> (Vec2, f32) {
    let sin_theta = (d.x * d.x + d.z * d.z).sqrt();
    // atan2 is accurate near the poles, where acos(y) is not.
    let theta = fast_atan2(sin_theta, d.y);
    let phi = fast_atan2(d.x, -d.z);
    let mut u = phi * INV_TWO_PI;
    if u < 0.0 {
        u += 1.0;
    }
    if u >= 1.0 {
        // Rounding can land on the modulus for tiny negative angles.
        u = 0.0;
    }
    let v = (theta * INV_PI).clamp(0.0, 1.0);
    (Vec2::new(u, v), sin_theta)
}

/// [`unit_dir_to_uv_sin`] of four unit directions (components in lanes),
/// each lane bit for bit the scalar routine's (tested): (u, v, sin theta).
#[inline]
pub fn unit_dir_to_uv_sin_lanes(x: Vec4, y: Vec4, z: Vec4) -> (Vec4, Vec4, Vec4) {
    let sin_theta = (x * x + z * z).sqrt();
    let theta = fast_atan2_lanes(sin_theta, y);
    let phi = fast_atan2_lanes(x, -z);
    let mut u = phi * INV_TWO_PI;
    u = Vec4::select(u.cmplt(Vec4::ZERO), u + Vec4::ONE, u);
    u = Vec4::select(u.cmpge(Vec4::ONE), Vec4::ZERO, u);
    (u, clamp_unit_lanes(theta * INV_PI), sin_theta)
}

/// Unit vector in the direction of `v`, robust to tiny and huge lengths.
#[inline]
pub fn normalize_robust(v: Vec3) -> Option<Vec3> {
    let m = v.abs().max_element();
    if !(m > 0.0 && m.is_finite()) {
        return None;
    }
    let v = v / m;
    let n = v / v.length();
    n.is_finite().then_some(n)
}
