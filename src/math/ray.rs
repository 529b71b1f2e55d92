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

/// Moves a surface point off its surface along the geometric normal, towards
/// the side `w` points to, by an amount that scales with the point's
/// floating-point magnitude (Wächter and Binder, Ray Tracing Gems ch. 6).
/// This avoids self-intersection without a scene-dependent epsilon.
pub fn offset_ray_origin(p: Vec3, n: Vec3, w: Vec3) -> Vec3 {
    const ORIGIN: f32 = 1.0 / 32.0;
    const FLOAT_SCALE: f32 = 1.0 / 65536.0;
    const INT_SCALE: f32 = 256.0;
    let n = if n.dot(w) < 0.0 { -n } else { n };
    let of_i = [
        (INT_SCALE * n.x) as i32,
        (INT_SCALE * n.y) as i32,
        (INT_SCALE * n.z) as i32,
    ];
    let pi = |v: f32, o: i32| -> f32 {
        let bits = v.to_bits() as i32;
        f32::from_bits((bits + if v < 0.0 { -o } else { o }) as u32)
    };
    let p_i = Vec3::new(pi(p.x, of_i[0]), pi(p.y, of_i[1]), pi(p.z, of_i[2]));
    let pick = |v: f32, vi: f32, nv: f32| {
        if v.abs() < ORIGIN {
            v + FLOAT_SCALE * nv
        } else {
            vi
        }
    };
    Vec3::new(
        pick(p.x, p_i.x, n.x),
        pick(p.y, p_i.y, n.y),
        pick(p.z, p_i.z, n.z),
    )
}
