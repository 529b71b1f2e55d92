//! Analytic disks: Mitsuba's `disk`, the unit disk at z = 0 facing +z,
//! carried into the world by any affine `to_world` (an ellipse under
//! uneven scales or shear). One primitive and one plane test per ray,
//! where the 512-triangle fan it replaces cost a BVH of its own and most
//! of the triangle tests of a scene with a disk in view.

use crate::math::{gamma, Aabb, Frame, Transform, Vec2, Vec3, PI};
use crate::sampling::warp;

use super::{BvhHit, Intersection, SurfaceSample};

/// The points `center + x ex + y ey` with x^2 + y^2 <= 1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Disk {
    pub center: Vec3,
    /// The world images of object-space x and y (any lengths, any angle).
    pub ex: Vec3,
    pub ey: Vec3,
    /// Unit normal of the front side: object +z carried as a normal (so a
    /// mirroring transform keeps the side Mitsuba's disk has), negated by
    /// `flip_normals`.
    pub n: Vec3,
    /// Dual basis of (ex, ey) in the disk's plane: a point q of the plane
    /// has object coordinates ((q - center) . dx, (q - center) . dy).
    dx: Vec3,
    dy: Vec3,
    area: f32,
}

/// A disk that cannot be.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum DiskError {
    #[error("has no area")]
    NoArea,
    #[error(
        "reaches beyond +-{:e}, the coordinate range lente supports",
        crate::limits::MAX_COORDINATE
    )]
    OutOfRange,
}

impl Disk {
    /// The unit disk carried by `t`.
    pub fn new(t: &Transform) -> Result<Disk, DiskError> {
        Disk::from_parts(
            t.point(Vec3::ZERO),
            t.vector(Vec3::X),
            t.vector(Vec3::Y),
            t.normal(Vec3::Z),
        )
    }

    /// This disk carried by `t` (its front side carried as a normal).
    pub fn transform(&mut self, t: &Transform) -> Result<(), DiskError> {
        *self = Disk::from_parts(
            t.point(self.center),
            t.vector(self.ex),
            t.vector(self.ey),
            t.normal(self.n),
        )?;
        Ok(())
    }

    /// The disk with centre, axes and (not necessarily unit) front normal.
    fn from_parts(center: Vec3, ex: Vec3, ey: Vec3, normal: Vec3) -> Result<Disk, DiskError> {
        let m = ex.cross(ey);
        let m2 = m.length_squared();
        let n = normal.normalize_or_zero();
        let area = PI * m2.sqrt();
        if !(m2 > 0.0 && m2.is_finite() && area.is_finite() && n != Vec3::ZERO) {
            return Err(DiskError::NoArea);
        }
        let disk = Disk {
            center,
            ex,
            ey,
            n,
            dx: ey.cross(m) / m2,
            dy: m.cross(ex) / m2,
            area,
        };
        let b = disk.bounds();
        let reach = b.min.abs().max(b.max.abs()).max_element();
        if !(reach <= crate::limits::MAX_COORDINATE && disk.dx.is_finite() && disk.dy.is_finite()) {
            return Err(DiskError::OutOfRange);
        }
        Ok(disk)
    }

    /// Turns the front side to the other face.
    pub fn flip_normals(&mut self) {
        self.n = -self.n;
    }

    /// The exact box of the ellipse: centre +- sqrt(ex_i^2 + ey_i^2) per axis.
    pub fn bounds(&self) -> Aabb {
        let half = (self.ex * self.ex + self.ey * self.ey).powf(0.5);
        Aabb {
            min: self.center - half,
            max: self.center + half,
        }
    }

    pub fn area(&self) -> f32 {
        self.area
    }

    /// The hit in (tmin, tmax): its parameter and object coordinates.
    #[inline]
    pub fn intersect(&self, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> Option<(f32, f32, f32)> {
        let to_center = self.center - o;
        let t = to_center.dot(self.n) / d.dot(self.n);
        // Also false for NaN (a ray in the plane).
        if !(t > tmin && t < tmax) {
            return None;
        }
        let q = t * d - to_center;
        let (x, y) = (q.dot(self.dx), q.dot(self.dy));
        (x * x + y * y <= 1.0).then_some((t, x, y))
    }

    /// The point at object coordinates (x, y) and its error bound.
    fn point(&self, x: f32, y: f32) -> (Vec3, Vec3) {
        let (a, b) = (x * self.ex, y * self.ey);
        let err = (self.center.abs() + a.abs() + b.abs()) * gamma(6);
        (self.center + a + b, err)
    }

    /// Object coordinates of a point in the disk's plane.
    fn local(&self, p: Vec3) -> Vec2 {
        let q = p - self.center;
        Vec2::new(q.dot(self.dx), q.dot(self.dy))
    }

    /// Mitsuba's (u, v) at object coordinates `l`: (radius, angle / 2pi),
    /// the angle from object x towards y, in [0, 1).
    fn uv(l: Vec2) -> Vec2 {
        let turns = l.y.atan2(l.x) / (2.0 * PI);
        Vec2::new(l.length(), if turns < 0.0 { turns + 1.0 } else { turns })
    }

    /// (u, v) at a point of the disk.
    pub fn uv_at(&self, p: Vec3) -> Vec2 {
        Disk::uv(self.local(p))
    }

    /// dp/du (radial, object length 1) and dp/dv (around, 2pi r) at
    /// object coordinates `l`; at the centre u points along object x.
    fn derivatives(&self, l: Vec2) -> (Vec3, Vec3) {
        let r = l.length();
        let (cos, sin) = if r > 0.0 {
            (l.x / r, l.y / r)
        } else {
            (1.0, 0.0)
        };
        let dpdu = cos * self.ex + sin * self.ey;
        let dpdv = (2.0 * PI * r) * (cos * self.ey - sin * self.ex);
        (dpdu, dpdv)
    }

    /// dp/du and dp/dv at a point of the disk.
    pub fn dpdu_dpdv(&self, p: Vec3) -> (Vec3, Vec3) {
        self.derivatives(self.local(p))
    }

    /// The surface point of a BVH hit, whose `b1`, `b2` hold the object
    /// coordinates [`Disk::intersect`] found. The point is rebuilt from
    /// them, on the plane up to its error bound (not o + t d).
    pub fn intersection(&self, hit: &BvhHit) -> Intersection {
        let l = Vec2::new(hit.b1, hit.b2);
        let (p, err) = self.point(l.x, l.y);
        let (dpdu, _) = self.derivatives(l);
        Intersection {
            t: hit.t,
            p,
            err,
            ng: self.n,
            shading: Frame::from_normal_tangent(self.n, dpdu),
            uv: Disk::uv(l),
            bary: Vec2::ZERO,
            shape: 0,
            instance: BvhHit::NO_INSTANCE,
            prim: 0,
        }
    }

    /// A point uniform over the disk (the concentric map, carried by the
    /// affine map, stays uniform: its Jacobian is constant).
    pub fn sample_area(&self, u: Vec2) -> SurfaceSample {
        let l = warp::square_to_uniform_disk(u);
        let (p, err) = self.point(l.x, l.y);
        SurfaceSample {
            p,
            err,
            n: self.n,
            pdf_area: 1.0 / self.area,
            prim: 0,
            bary: Vec2::ZERO,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Mat4;
    use crate::sampling::Sampler;

    fn tilted() -> Disk {
        let m = Mat4::from_translation(glam::Vec3::new(1.0, -2.0, 0.5))
            * Mat4::from_rotation_x(0.7)
            * Mat4::from_scale(glam::Vec3::new(2.0, 0.5, 1.0));
        Disk::new(&Transform::new(m).unwrap()).unwrap()
    }

    #[test]
    fn hits_inside_and_misses_outside_the_ellipse() {
        let d = tilted();
        // Aim at object points just inside and just outside the rim.
        for (x, y, inside) in [(0.99, 0.0, true), (0.0, -0.99, true), (1.01, 0.0, false)] {
            let target = d.center + x * d.ex + y * d.ey;
            let o = target + Vec3::new(0.3, 2.0, 1.0);
            let dir = (target - o).normalize();
            let hit = d.intersect(o, dir, 0.0, f32::INFINITY);
            assert_eq!(hit.is_some(), inside, "({x}, {y})");
            if let Some((t, hx, hy)) = hit {
                assert!((o + t * dir - target).length() < 1e-5);
                assert!((hx - x).abs() < 1e-5 && (hy - y).abs() < 1e-5);
            }
        }
        // Parallel to the plane, and behind the origin.
        assert!(d.intersect(d.center + d.n, d.ex, 0.0, 10.0).is_none());
        assert!(d.intersect(d.center + d.n, d.n, 0.0, 10.0).is_none());
    }

    #[test]
    fn area_bounds_and_normal_match_the_transform() {
        let d = tilted();
        assert!((d.area() - PI * 2.0 * 0.5).abs() < 1e-5);
        assert!(d.n.dot(d.ex).abs() < 1e-6 && d.n.dot(d.ey).abs() < 1e-6);
        assert!((d.n.length() - 1.0).abs() < 1e-6);
        // Every rim point lies in the box, and the box is tight.
        let b = d.bounds();
        let mut reach = Vec3::splat(f32::NEG_INFINITY);
        for i in 0..4096 {
            let a = i as f32 / 4096.0 * 2.0 * PI;
            let p = d.center + a.cos() * d.ex + a.sin() * d.ey;
            assert!(p.cmpge(b.min - 1e-5).all() && p.cmple(b.max + 1e-5).all());
            reach = reach.max(p);
        }
        assert!((reach - b.max).abs().max_element() < 1e-4);
        // A mirror keeps the side the transformed normal gives.
        let mirror = Transform::new(Mat4::from_scale(glam::Vec3::new(-1.0, 1.0, 1.0))).unwrap();
        assert_eq!(Disk::new(&mirror).unwrap().n, Vec3::Z);
        let flat = Transform::new(Mat4::from_scale(glam::Vec3::new(1.0, 1e-30, 1.0)));
        assert!(flat.is_none_or(|t| Disk::new(&t).is_err()));
    }

    #[test]
    fn uv_and_derivatives_follow_mitsuba() {
        let d = Disk::new(&Transform::IDENTITY).unwrap();
        let uv = d.uv_at(Vec3::new(0.0, -0.5, 0.0));
        assert!((uv - Vec2::new(0.5, 0.75)).abs().max_element() < 1e-6);
        let (dpdu, dpdv) = d.dpdu_dpdv(Vec3::new(0.0, 0.5, 0.0));
        assert!((dpdu - Vec3::Y).length() < 1e-6);
        assert!((dpdv - Vec3::new(-PI, 0.0, 0.0)).length() < 1e-5);
        // The centre: u along object x.
        assert_eq!(d.dpdu_dpdv(Vec3::ZERO).0, Vec3::X);
    }

    /// A ray leaving a hit (either side, any direction) from its offset
    /// origin never meets the disk again, even far from the origin.
    #[test]
    fn spawned_rays_do_not_hit_their_own_disk() {
        let m = Mat4::from_translation(glam::Vec3::new(1000.0, 200.0, -50.0))
            * Mat4::from_rotation_y(0.3)
            * Mat4::from_rotation_x(1.1)
            * Mat4::from_scale(glam::Vec3::new(30.0, 7.0, 1.0));
        let d = Disk::new(&Transform::new(m).unwrap()).unwrap();
        let mut s = Sampler::new(3, 9);
        for _ in 0..20_000 {
            let target = d.sample_area(s.next_2d()).p;
            let o = target + warp::square_to_uniform_sphere(s.next_2d()) * 100.0;
            let Some((t, x, y)) = d.intersect(o, target - o, 0.0, f32::INFINITY) else {
                continue;
            };
            let hit = BvhHit {
                t,
                shape: 0,
                index: 0,
                b1: x,
                b2: y,
                instance: BvhHit::NO_INSTANCE,
            };
            let its = d.intersection(&hit);
            let w = warp::square_to_uniform_sphere(s.next_2d());
            let again = d.intersect(its.spawn(w), w, 0.0, f32::INFINITY);
            assert!(again.is_none(), "{its:?} {w:?} {again:?}");
        }
    }

    /// Area sampling is uniform: the share of samples in each of 16
    /// rings-by-sectors cells of equal area is 1/16 (chi-square), and
    /// every point lies on the disk.
    #[test]
    fn area_samples_are_uniform() {
        let d = tilted();
        let mut s = Sampler::new(7, 3);
        let n = 64_000;
        let mut counts = [0.0f64; 16];
        for _ in 0..n {
            let p = d.sample_area(s.next_2d());
            assert_eq!(p.pdf_area, 1.0 / d.area());
            let l = d.local(p.p);
            assert!(l.length() <= 1.0 + 1e-5);
            let uv = Disk::uv(l);
            // Rings of equal area: r^2 in quarters; sectors: quarters.
            let ring = ((uv.x * uv.x * 4.0) as usize).min(3);
            let sector = ((uv.y * 4.0) as usize).min(3);
            counts[ring * 4 + sector] += 1.0;
        }
        let expected = vec![n as f64 / 16.0; 16];
        let r = crate::stats::chi2_test(&counts, &expected, 5.0);
        assert!(r.passes(1e-3), "{r:?}");
    }
}
