//! Geometric primitives shared by every module: rays, frames, transforms.

mod approx;
mod frame;
mod lanes3;
mod prefetch;
mod ray;
mod transform;

#[cfg(target_arch = "x86_64")]
pub use approx::exp8;
pub use approx::{
    clamp_unit_lanes, exp4, exp_or_zero, fast_atan2, fast_atan2_lanes, select_bits, sin_cos_turns,
    sin_cos_turns_lanes, EXP4_MAX_RELATIVE_ERROR, FAST_ATAN2_MAX_ERROR, SIN_COS_TURNS_MAX_ERROR,
};
pub use frame::Frame;
pub use glam::{Mat3, Mat4, Vec2, Vec3, Vec4};
pub use lanes3::{sqrt4, Lanes3};
pub use prefetch::{prefetch, prefetch_at};
pub use ray::{barycentric_error, gamma, offset_ray_origin, Ray};
pub use transform::Transform;

/// Axis-aligned bounding box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub min: Vec3,
    pub max: Vec3,
}

impl Aabb {
    /// An empty box that any union will overwrite.
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    pub fn union(self, o: Aabb) -> Aabb {
        Aabb {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    pub fn extend(self, p: Vec3) -> Aabb {
        Aabb {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.min.cmpgt(self.max).any()
    }

    pub fn center(&self) -> Vec3 {
        0.5 * (self.min + self.max)
    }

    pub fn diagonal(&self) -> Vec3 {
        self.max - self.min
    }

    /// The part of the ray `o + t d`, `t` in `[0, t_max]`, inside the box
    /// (slab test): `None` if it misses. Axes along which the ray does not
    /// move are inside or not by its origin alone (no 0 * inf).
    pub fn ray_range(&self, o: Vec3, d: Vec3, t_max: f32) -> Option<(f32, f32)> {
        let (mut t0, mut t1) = (0.0f32, t_max);
        for a in 0..3 {
            if d[a] == 0.0 {
                if o[a] < self.min[a] || o[a] > self.max[a] {
                    return None;
                }
                continue;
            }
            let inv = 1.0 / d[a];
            let (mut near, mut far) = ((self.min[a] - o[a]) * inv, (self.max[a] - o[a]) * inv);
            if near > far {
                std::mem::swap(&mut near, &mut far);
            }
            t0 = t0.max(near);
            t1 = t1.min(far);
        }
        (t0 <= t1).then_some((t0, t1))
    }
}

pub const PI: f32 = std::f32::consts::PI;
pub const INV_PI: f32 = std::f32::consts::FRAC_1_PI;
pub const INV_TWO_PI: f32 = 0.5 * std::f32::consts::FRAC_1_PI;
pub const INV_FOUR_PI: f32 = 0.25 * std::f32::consts::FRAC_1_PI;

/// floor(x) as an integer, saturating at the ends of i32 (NaN gives 0).
/// `f32::floor` is a libm call on the x86_64 baseline (no SSE4.1); this is
/// a conversion and a compare, for the per-sample paths (film splats,
/// texel lookups).
#[inline]
pub fn floor_i32(x: f32) -> i32 {
    // Every float of magnitude 2^23 or more is an integer, so `i as f32`
    // is exact wherever `x as i32` did not saturate.
    let i = x as i32;
    i.saturating_sub(((i as f32) > x) as i32)
}

/// ceil(x) as an integer, as [`floor_i32`] does floor.
#[inline]
pub fn ceil_i32(x: f32) -> i32 {
    let i = x as i32;
    i.saturating_add(((i as f32) < x) as i32)
}

/// Reflect `wi` about normal `n` (both pointing away from the surface).
pub fn reflect(wi: Vec3, n: Vec3) -> Vec3 {
    2.0 * wi.dot(n) * n - wi
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn floor_and_ceil_match_std() {
        let mut xs = vec![0.0f32, -0.0, 0.5, -0.5, 1.0, -1.0, 2.5, -2.5, 1e-30, -1e-30];
        xs.extend([
            8388607.5,
            -8388607.5,
            16777217.0,
            2147483520.0,
            -2147483648.0,
        ]);
        for k in -2000..=2000 {
            xs.push(k as f32 * 0.37);
        }
        for x in xs {
            assert_eq!(floor_i32(x), x.floor() as i32, "floor {x}");
            assert_eq!(ceil_i32(x), x.ceil() as i32, "ceil {x}");
        }
        for x in [3e9f32, -3e9, f32::INFINITY, f32::NEG_INFINITY, f32::NAN] {
            assert_eq!(floor_i32(x), x.floor() as i32, "floor {x}");
            assert_eq!(ceil_i32(x), x.ceil() as i32, "ceil {x}");
        }
    }
}
