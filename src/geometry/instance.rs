//! Instances: a shape group placed in the world by a transform. Rays are
//! taken into the group's space, and its hits brought back, so one copy of
//! the group's geometry and BVH serves every instance (Mitsuba's
//! `shapegroup` + `instance`).

use super::Intersection;
use crate::math::{gamma, Aabb, Frame, Ray, Transform, Vec3};

/// One placement of a shape group.
#[derive(Clone, Copy, Debug)]
pub struct Instance {
    /// Index of the group (in the scene's list of groups).
    pub group: u32,
    pub to_world: Transform,
}

impl Instance {
    /// The ray in the group's space. The direction is transformed without
    /// normalising, so the hit distance `t` means the same in both spaces.
    #[inline]
    pub fn to_local(&self, ray: &Ray) -> Ray {
        let inv = self.to_world.inverse();
        Ray::with_range(inv.point(ray.o), inv.vector(ray.d), ray.tmin, ray.tmax)
    }

    /// The world bounds of a group's local bounds under this placement.
    pub fn world_bounds(&self, local: Aabb) -> Aabb {
        self.to_world.bounds(local)
    }

    /// A hit found in the group's space, in the world: the point with an
    /// error bound that also covers the rounding of the transforms both
    /// ways (so spawned rays, taken back into the group's space, still
    /// start off the surface), normals by the inverse transpose, the
    /// shading frame's tangent by the transform (anisotropy follows the
    /// placement).
    pub fn to_world(&self, local: &Intersection, instance: u32) -> Intersection {
        let m = &self.to_world;
        let abs_linear = |t: &Transform, v: Vec3| {
            let l = t.linear();
            l.x_axis.abs() * v.x + l.y_axis.abs() * v.y + l.z_axis.abs() * v.z
        };
        let p = m.point(local.p);
        let inv = m.inverse();
        let there = abs_linear(m, local.err) * (1.0 + gamma(3))
            + (abs_linear(m, local.p.abs()) + m.m.w_axis.truncate().abs()) * gamma(3);
        let back = abs_linear(
            m,
            (abs_linear(&inv, p.abs()) + inv.m.w_axis.truncate().abs()) * gamma(3),
        );
        let ng = m.normal(local.ng).normalize_or_zero();
        let n = m.normal(local.shading.n).normalize_or_zero();
        let mut its = Intersection {
            p,
            err: there + back * (1.0 + gamma(3)),
            ng,
            shading: Frame::from_normal_tangent(n, m.vector(local.shading.s)),
            instance,
            ..*local
        };
        if its.ng.dot(its.shading.n) < 0.0 {
            its.ng = -its.ng;
        }
        its
    }
}
