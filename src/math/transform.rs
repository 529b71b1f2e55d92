//! Affine transforms carried with their inverse.

use super::{Aabb, Mat3, Mat4, Vec3, Vec4};

/// A 4x4 transform and its inverse, so normals and inverse mappings are cheap.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    pub m: Mat4,
    pub inv: Mat4,
}

impl Default for Transform {
    fn default() -> Self {
        Transform::IDENTITY
    }
}

impl Transform {
    pub const IDENTITY: Transform = Transform {
        m: Mat4::IDENTITY,
        inv: Mat4::IDENTITY,
    };

    /// Wraps a matrix; `None` if it is singular or not finite.
    pub fn new(m: Mat4) -> Option<Transform> {
        let det = m.determinant();
        if !det.is_finite() || det.abs() < 1e-12 {
            return None;
        }
        let inv = m.inverse();
        if !inv.is_finite() {
            return None;
        }
        Some(Transform { m, inv })
    }

    /// `self` applied after `first`.
    pub fn then_after(&self, first: &Transform) -> Transform {
        Transform {
            m: self.m * first.m,
            inv: first.inv * self.inv,
        }
    }

    pub fn inverse(&self) -> Transform {
        Transform {
            m: self.inv,
            inv: self.m,
        }
    }

    pub fn point(&self, p: Vec3) -> Vec3 {
        self.m.project_point3(p)
    }

    pub fn vector(&self, v: Vec3) -> Vec3 {
        self.m.transform_vector3(v)
    }

    /// A box around the image of `local`: its eight corners transformed
    /// (an empty box stays empty).
    pub fn bounds(&self, local: Aabb) -> Aabb {
        if local.is_empty() {
            return local;
        }
        (0..8).fold(Aabb::EMPTY, |b, i| {
            let corner = Vec3::new(
                if i & 1 == 0 { local.min.x } else { local.max.x },
                if i & 2 == 0 { local.min.y } else { local.max.y },
                if i & 4 == 0 { local.min.z } else { local.max.z },
            );
            b.extend(self.point(corner))
        })
    }

    /// Transforms a normal by the inverse transpose (not normalised).
    pub fn normal(&self, n: Vec3) -> Vec3 {
        self.inv.transpose().transform_vector3(n)
    }

    /// Linear (upper-left 3x3) part of the matrix.
    pub fn linear(&self) -> Mat3 {
        Mat3::from_mat4(self.m)
    }

    /// True if the linear part has orthogonal columns of equal length and
    /// the last row is affine: rotations, mirrors, uniform scales and
    /// translations, the transforms that keep a sphere a sphere.
    pub fn is_similarity(&self) -> bool {
        let m = self.linear();
        let s2 = m.x_axis.length_squared();
        if !(s2 > 0.0 && s2.is_finite()) || (self.m.row(3) - Vec4::W).abs().max_element() > 1e-6 {
            return false;
        }
        let g = m.transpose() * m;
        let tol = 1e-4 * s2;
        (g - Mat3::from_diagonal(Vec3::splat(s2)))
            .to_cols_array()
            .iter()
            .all(|x| x.abs() <= tol)
    }

    /// True if the linear part is orthonormal to within `tol` on each entry
    /// of M M^T: rotations, possibly with a mirror.
    pub fn is_rotation(&self, tol: f32) -> bool {
        let m = self.linear();
        let g = m * m.transpose();
        (g - Mat3::IDENTITY)
            .to_cols_array()
            .iter()
            .all(|x| x.abs() <= tol)
    }

    /// True if the transform flips handedness.
    pub fn flips_handedness(&self) -> bool {
        self.m.determinant() < 0.0
    }
}
