//! Four 3-vectors in SIMD lanes (glam's four-lane `Vec4`, one per axis):
//! what the batch's four-at-a-time stages compute with, each lane doing
//! glam's scalar `Vec3` operations in their order, so the same bits.

use super::{Vec3, Vec4};

/// Three coordinates of four points, one vector per axis.
#[derive(Clone, Copy)]
pub struct Lanes3 {
    pub x: Vec4,
    pub y: Vec4,
    pub z: Vec4,
}

impl Lanes3 {
    /// Four points' coordinates in lanes, read where the points lie:
    /// copied into an array first, they were loaded back in 16-byte
    /// pieces across the 8- and 4-byte stores just made, which could not
    /// be forwarded.
    #[inline]
    pub fn gather(v: [&Vec3; 4]) -> Lanes3 {
        Lanes3 {
            x: Vec4::from_array(v.map(|v| v.x)),
            y: Vec4::from_array(v.map(|v| v.y)),
            z: Vec4::from_array(v.map(|v| v.z)),
        }
    }

    #[inline]
    pub fn lane(&self, k: usize) -> Vec3 {
        Vec3::new(self.x[k], self.y[k], self.z[k])
    }

    /// glam's `Vec3::dot`: (x x' + y y') + z z'.
    #[inline]
    pub fn dot(&self, o: &Lanes3) -> Vec4 {
        self.x * o.x + self.y * o.y + self.z * o.z
    }

    /// glam's `Vec3::dot(self, self)`.
    #[inline]
    pub fn length_squared(&self) -> Vec4 {
        self.dot(self)
    }

    /// `self - o`, axis by axis.
    #[inline]
    pub fn sub(&self, o: &Lanes3) -> Lanes3 {
        Lanes3 {
            x: self.x - o.x,
            y: self.y - o.y,
            z: self.z - o.z,
        }
    }

    #[inline]
    pub fn map(&self, f: impl Fn(Vec4) -> Vec4) -> Lanes3 {
        Lanes3 {
            x: f(self.x),
            y: f(self.y),
            z: f(self.z),
        }
    }
}

/// Each lane's square root (`f32::sqrt`, correctly rounded).
#[inline]
pub fn sqrt4(v: Vec4) -> Vec4 {
    Vec4::from_array(v.to_array().map(f32::sqrt))
}
