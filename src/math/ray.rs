//! Rays and robust ray origins.

use super::Vec3;

/// A ray `o + t d` valid for `t` in `[tmin, tmax]`.
#[derive(Clone, Copy, Debug)]
pub struct Ray {
    pub o: Vec3,
    pub d: Vec3,
    pub tmin: f32,
    pub tmax: f32,
}

impl Ray {
    pub fn new(o: Vec3, d: Vec3) -> Ray {
        Ray {
            o,
            d,
            tmin: 0.0,
            tmax: f32::INFINITY,
        }
    }

    pub fn with_range(o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> Ray {
        Ray { o, d, tmin, tmax }
    }

    pub fn at(&self, t: f32) -> Vec3 {
        self.o + t * self.d
    }
}

/// gamma(n) of Higham's floating-point error analysis: a bound on the
/// relative error of n chained f32 operations.
pub const fn gamma(n: i32) -> f32 {
    let e = f32::EPSILON * 0.5 * n as f32;
    e / (1.0 - e)
}

/// Moves a surface point off its surface, towards the side `w` points to,
/// by just more than its floating-point error bound `err` projected on the
/// normal `n`, then one ulp further away (pbrt's spawned-ray origins). No
/// scene-dependent epsilon: points far from the origin or on huge
/// triangles get proportionally larger offsets, tiny ones tiny offsets.
pub fn offset_ray_origin(p: Vec3, err: Vec3, n: Vec3, w: Vec3) -> Vec3 {
    let d = n.abs().dot(err);
    let mut offset = d * n;
    if w.dot(n) < 0.0 {
        offset = -offset;
    }
    let po = p + offset;
    let away = |v: f32, o: f32| {
        if o > 0.0 {
            v.next_up()
        } else if o < 0.0 {
            v.next_down()
        } else {
            v
        }
    };
    Vec3::new(
        away(po.x, offset.x),
        away(po.y, offset.y),
        away(po.z, offset.z),
    )
}

/// Error bound of a point computed as b0 p0 + b1 p1 + b2 p2.
pub fn barycentric_error(b0: f32, b1: f32, b2: f32, p0: Vec3, p1: Vec3, p2: Vec3) -> Vec3 {
    ((b0 * p0).abs() + (b1 * p1).abs() + (b2 * p2).abs()) * gamma(7)
}
