//! The affine frame shared by the flat analytic shapes (disk, rectangle):
//! the points `center + x ex + y ey` of a plane, its front normal, and the
//! ray test that finds a hit's object coordinates (x, y).

use crate::math::{gamma, Aabb, Transform, Vec2, Vec3};

/// Object-space z = 0 carried into the world by an affine map.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlaneFrame {
    pub center: Vec3,
    /// The world images of object-space x and y (any lengths, any angle).
    pub ex: Vec3,
    pub ey: Vec3,
    /// Unit normal of the front side: object +z carried as a normal (so a
    /// mirroring transform keeps the side Mitsuba gives), negated by
    /// `flip_normals`.
    pub n: Vec3,
    /// Dual basis of (ex, ey) in the plane: a point q of the plane has
    /// object coordinates ((q - center) . dx, (q - center) . dy).
    dx: Vec3,
    dy: Vec3,
    /// |ex x ey|: world area per unit of object area.
    area_scale: f32,
}

/// A flat shape that cannot be.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum PlaneError {
    #[error("has no area")]
    NoArea,
    #[error(
        "reaches beyond +-{:e}, the coordinate range lente supports",
        crate::limits::MAX_COORDINATE
    )]
    OutOfRange,
}

impl PlaneFrame {
    /// Object z = 0 carried by `t`.
    pub fn new(t: &Transform) -> Result<PlaneFrame, PlaneError> {
        PlaneFrame::from_parts(
            t.point(Vec3::ZERO),
            t.vector(Vec3::X),
            t.vector(Vec3::Y),
            t.normal(Vec3::Z),
        )
    }

    /// This frame carried by `t` (its front side carried as a normal).
    pub fn transformed(&self, t: &Transform) -> Result<PlaneFrame, PlaneError> {
        PlaneFrame::from_parts(
            t.point(self.center),
            t.vector(self.ex),
            t.vector(self.ey),
            t.normal(self.n),
        )
    }

    /// The frame with centre, axes and (not necessarily unit) front normal.
    fn from_parts(
        center: Vec3,
        ex: Vec3,
        ey: Vec3,
        normal: Vec3,
    ) -> Result<PlaneFrame, PlaneError> {
        let m = ex.cross(ey);
        let m2 = m.length_squared();
        let n = normal.normalize_or_zero();
        if !(m2 > 0.0 && m2.is_finite() && n != Vec3::ZERO && center.is_finite()) {
            return Err(PlaneError::NoArea);
        }
        let frame = PlaneFrame {
            center,
            ex,
            ey,
            n,
            dx: ey.cross(m) / m2,
            dy: m.cross(ex) / m2,
            area_scale: m2.sqrt(),
        };
        if !(frame.dx.is_finite() && frame.dy.is_finite()) {
            return Err(PlaneError::NoArea);
        }
        Ok(frame)
    }

    /// Turns the front side to the other face.
    pub fn flip_normals(&mut self) {
        self.n = -self.n;
    }

    /// The dual basis of (ex, ey) ([`Self::local`]'s projections).
    pub fn dual_basis(&self) -> (Vec3, Vec3) {
        (self.dx, self.dy)
    }

    /// World area per unit of object area.
    pub fn area_scale(&self) -> f32 {
        self.area_scale
    }

    /// The box centre +- `half`, if it stays in lente's coordinate range.
    pub fn checked_bounds(&self, half: Vec3) -> Result<Aabb, PlaneError> {
        let b = Aabb {
            min: self.center - half,
            max: self.center + half,
        };
        let reach = b.min.abs().max(b.max.abs()).max_element();
        if reach <= crate::limits::MAX_COORDINATE {
            Ok(b)
        } else {
            Err(PlaneError::OutOfRange)
        }
    }

    /// Where the ray meets the plane within (tmin, tmax): its parameter
    /// and object coordinates.
    #[inline(always)]
    pub fn hit(&self, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> Option<(f32, Vec2)> {
        let to_center = self.center - o;
        let t = to_center.dot(self.n) / d.dot(self.n);
        // Also false for NaN (a ray in the plane).
        if !(t > tmin && t < tmax) {
            return None;
        }
        let q = t * d - to_center;
        Some((t, Vec2::new(q.dot(self.dx), q.dot(self.dy))))
    }

    /// [`PlaneFrame::hit`] of a packet's rays: the lanes that meet the
    /// plane within (tmin, tmax) as a mask, their t and object coordinates,
    /// by the scalar routine's operations in its order.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub fn hit_lanes<L: super::lanes::Lanes>(
        &self,
        p: &super::packet::RayPacket<L>,
        tmax: L::F,
    ) -> (L::M, [L::F; 3]) {
        use super::lanes::{dot3, scaled_sub3, splat3, sub3};
        let l = p.l;
        let (o, d, tmin) = (p.o, p.d, p.tmin);
        let to_center = sub3(splat3(l, self.center), o);
        let n = splat3(l, self.n);
        let t = dot3(to_center, n) / dot3(d, n);
        let within = l.m_and(l.gt(t, tmin), l.lt(t, tmax));
        let q = scaled_sub3(t, d, to_center);
        (
            within,
            [t, dot3(q, splat3(l, self.dx)), dot3(q, splat3(l, self.dy))],
        )
    }

    /// The point at object coordinates `l` and its error bound: on the
    /// plane up to that bound, whatever the error of the ray's o + t d.
    pub fn point(&self, l: Vec2) -> (Vec3, Vec3) {
        let (a, b) = (l.x * self.ex, l.y * self.ey);
        let err = (self.center.abs() + a.abs() + b.abs()) * gamma(6);
        (self.center + a + b, err)
    }

    /// Object coordinates of a point in the plane.
    pub fn local(&self, p: Vec3) -> Vec2 {
        let q = p - self.center;
        Vec2::new(q.dot(self.dx), q.dot(self.dy))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Mat4;

    #[test]
    fn normal_follows_the_inverse_transpose_and_degenerate_maps_fail() {
        let m = Mat4::from_rotation_x(0.7) * Mat4::from_scale(glam::Vec3::new(2.0, 0.5, 1.0));
        let f = PlaneFrame::new(&Transform::new(m).unwrap()).unwrap();
        assert!(f.n.dot(f.ex).abs() < 1e-6 && f.n.dot(f.ey).abs() < 1e-6);
        assert!((f.area_scale() - 1.0).abs() < 1e-6);
        // A mirror keeps the side the transformed normal gives.
        let mirror = Transform::new(Mat4::from_scale(glam::Vec3::new(-1.0, 1.0, 1.0))).unwrap();
        assert_eq!(PlaneFrame::new(&mirror).unwrap().n, Vec3::Z);
        let flat = Transform::new(Mat4::from_scale(glam::Vec3::new(1.0, 1e-30, 1.0)));
        assert!(flat.is_none_or(|t| PlaneFrame::new(&t).is_err()));
        let far = PlaneFrame::new(&Transform::IDENTITY).unwrap();
        assert_eq!(
            far.checked_bounds(Vec3::splat(2e12)),
            Err(PlaneError::OutOfRange)
        );
    }

    /// A ray leaving a point found by a hit (either side, any direction)
    /// from its offset origin never meets the plane again, even far from
    /// the world's origin.
    #[test]
    fn spawned_rays_do_not_hit_their_own_plane() {
        use crate::sampling::{warp, Sampler};
        let m = Mat4::from_translation(glam::Vec3::new(1000.0, 200.0, -50.0))
            * Mat4::from_rotation_y(0.3)
            * Mat4::from_rotation_x(1.1)
            * Mat4::from_scale(glam::Vec3::new(30.0, 7.0, 1.0));
        let f = PlaneFrame::new(&Transform::new(m).unwrap()).unwrap();
        let mut s = Sampler::new(3, 9);
        for _ in 0..20_000 {
            let (target, _) = f.point(2.0 * s.next_2d() - Vec2::ONE);
            let o = target + warp::square_to_uniform_sphere(s.next_2d()) * 100.0;
            let Some((_, l)) = f.hit(o, target - o, 0.0, f32::INFINITY) else {
                continue;
            };
            let (p, err) = f.point(l);
            let w = warp::square_to_uniform_sphere(s.next_2d());
            let from = crate::math::offset_ray_origin(p, err, f.n, w);
            let again = f.hit(from, w, 0.0, f32::INFINITY);
            assert!(again.is_none(), "{p} {w} {again:?}");
        }
    }

    #[test]
    fn hits_report_object_coordinates() {
        let m = Mat4::from_translation(glam::Vec3::new(1.0, -2.0, 0.5))
            * Mat4::from_rotation_y(0.4)
            * Mat4::from_scale(glam::Vec3::new(3.0, 0.5, 1.0));
        let f = PlaneFrame::new(&Transform::new(m).unwrap()).unwrap();
        let l = Vec2::new(0.3, -0.8);
        let (target, _) = f.point(l);
        let o = target + Vec3::new(0.3, 2.0, 1.0);
        let (t, hit) = f.hit(o, target - o, 0.0, 2.0).unwrap();
        assert!((t - 1.0).abs() < 1e-5 && (hit - l).abs().max_element() < 1e-5);
        assert!((f.local(target) - l).abs().max_element() < 1e-5);
        // Parallel to the plane, behind the origin, beyond tmax.
        assert!(f.hit(f.center + f.n, f.ex, 0.0, 10.0).is_none());
        assert!(f.hit(f.center + f.n, f.n, 0.0, 10.0).is_none());
        assert!(f.hit(o, target - o, 0.0, 0.5).is_none());
    }
}
