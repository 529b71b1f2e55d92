//! Geometric primitives shared by every module: rays, frames, transforms.

mod approx;
mod frame;
mod ray;
mod transform;

pub use approx::{fast_atan2, FAST_ATAN2_MAX_ERROR};
pub use frame::Frame;
pub use glam::{Mat3, Mat4, Vec2, Vec3, Vec4};
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
}

pub const PI: f32 = std::f32::consts::PI;
pub const INV_PI: f32 = std::f32::consts::FRAC_1_PI;
pub const INV_TWO_PI: f32 = 0.5 * std::f32::consts::FRAC_1_PI;
pub const INV_FOUR_PI: f32 = 0.25 * std::f32::consts::FRAC_1_PI;

/// Reflect `wi` about normal `n` (both pointing away from the surface).
pub fn reflect(wi: Vec3, n: Vec3) -> Vec3 {
    2.0 * wi.dot(n) * n - wi
}
