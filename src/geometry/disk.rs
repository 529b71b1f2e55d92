//! Analytic disks: Mitsuba's `disk`, the unit disk at z = 0 facing +z,
//! carried into the world by any affine `to_world` (an ellipse under
//! uneven scales or shear). One primitive and one plane test per ray,
//! where the 512-triangle fan it replaces cost a BVH of its own and most
//! of the triangle tests of a scene with a disk in view.

use crate::math::{Aabb, Frame, Transform, Vec2, Vec3, PI};
use crate::sampling::warp;

use super::plane::{PlaneError, PlaneFrame};
use super::{BvhHit, Intersection, SurfaceSample};

/// The points `center + x ex + y ey` of its frame with x^2 + y^2 <= 1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Disk {
    pub frame: PlaneFrame,
    bounds: Aabb,
}

impl Disk {
    /// The unit disk carried by `t`.
    pub fn new(t: &Transform) -> Result<Disk, PlaneError> {
        Disk::on(PlaneFrame::new(t)?)
    }

    /// This disk carried by `t`.
    pub fn transformed(&self, t: &Transform) -> Result<Disk, PlaneError> {
        Disk::on(self.frame.transformed(t)?)
    }

    fn on(frame: PlaneFrame) -> Result<Disk, PlaneError> {
        // The exact box of the ellipse: centre +- sqrt(ex_i^2 + ey_i^2).
        let half = (frame.ex * frame.ex + frame.ey * frame.ey).powf(0.5);
        let bounds = frame.checked_bounds(half)?;
        Ok(Disk { frame, bounds })
    }

    /// This disk carried by `t`.
    pub fn transform(&mut self, t: &Transform) -> Result<(), PlaneError> {
        *self = Disk::on(self.frame.transformed(t)?)?;
        Ok(())
    }

    /// Turns the front side to the other face.
    pub fn flip_normals(&mut self) {
        self.frame.flip_normals();
    }

    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    pub fn area(&self) -> f32 {
        PI * self.frame.area_scale()
    }

    /// The hit in (tmin, tmax): its parameter and object coordinates.
    #[inline]
    pub fn intersect(&self, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> Option<(f32, Vec2)> {
        self.frame
            .hit(o, d, tmin, tmax)
            .filter(|(_, l)| l.length_squared() <= 1.0)
    }

    /// [`Disk::intersect`] of a packet's rays: the lanes that hit as bits,
    /// their t and object coordinates (bit for bit the scalar's).
    ///
    /// `ANY_HIT` (the any-hit walk's copy or the closest-hit walk's) only
    /// gives each walk a copy of its own, which LLVM inlines (one called
    /// from both stayed out of line: +13% instructions for the walk).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub fn intersect_lanes<L: super::lanes::Lanes, const ANY_HIT: bool>(
        &self,
        p: &super::packet::RayPacket<L>,
        tmax: L::F,
    ) -> (u32, [L::F; 3]) {
        let l = p.l;
        let (within, [t, x, y]) = self.frame.hit_lanes(p, tmax);
        let inside = l.le(x * x + y * y, l.splat(1.0));
        (l.bits(l.m_and(within, inside)), [t, x, y])
    }

    /// Mitsuba's (u, v) at object coordinates `l`: (radius, angle / 2pi),
    /// the angle from object x towards y, in [0, 1).
    fn uv(l: Vec2) -> Vec2 {
        let turns = l.y.atan2(l.x) / (2.0 * PI);
        Vec2::new(l.length(), if turns < 0.0 { turns + 1.0 } else { turns })
    }

    /// (u, v) at a point of the disk.
    pub fn uv_at(&self, p: Vec3) -> Vec2 {
        Disk::uv(self.frame.local(p))
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
        let (ex, ey) = (self.frame.ex, self.frame.ey);
        (cos * ex + sin * ey, (2.0 * PI * r) * (cos * ey - sin * ex))
    }

    /// dp/du and dp/dv at a point of the disk.
    pub fn dpdu_dpdv(&self, p: Vec3) -> (Vec3, Vec3) {
        self.derivatives(self.frame.local(p))
    }

    /// The surface point of a BVH hit, whose `b1`, `b2` hold the object
    /// coordinates [`Disk::intersect`] found, stored into `out`.
    pub fn intersection_into(&self, hit: &BvhHit, out: &mut Intersection) {
        let l = Vec2::new(hit.b1, hit.b2);
        let (p, err) = self.frame.point(l);
        let n = self.frame.n;
        *out = Intersection {
            t: hit.t,
            p,
            err,
            ng: n,
            shading: Frame::from_normal_tangent(n, self.derivatives(l).0),
            uv: Disk::uv(l),
            bary: Vec2::ZERO,
            shape: 0,
            instance: BvhHit::NO_INSTANCE,
            prim: 0,
        };
    }

    /// A point uniform over the disk (the concentric map, carried by the
    /// affine map, stays uniform: its Jacobian is constant).
    pub fn sample_area(&self, u: Vec2) -> SurfaceSample {
        let (p, err) = self.frame.point(warp::square_to_uniform_disk(u));
        SurfaceSample {
            p,
            err,
            n: self.frame.n,
            pdf_area: 1.0 / self.area(),
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
        for (l, inside) in [
            (Vec2::new(0.99, 0.0), true),
            (Vec2::new(0.0, -0.99), true),
            (Vec2::new(0.7, 0.7), true),
            (Vec2::new(1.01, 0.0), false),
            (Vec2::new(0.72, 0.72), false),
        ] {
            let target = d.frame.point(l).0;
            let o = target + Vec3::new(0.3, 2.0, 1.0);
            let hit = d.intersect(o, target - o, 0.0, f32::INFINITY);
            assert_eq!(hit.is_some(), inside, "{l}");
        }
    }

    #[test]
    fn area_and_bounds_match_the_transform() {
        let d = tilted();
        assert!((d.area() - PI * 2.0 * 0.5).abs() < 1e-5);
        // Every rim point lies in the box, and the box is tight.
        let b = d.bounds();
        let mut reach = Vec3::splat(f32::NEG_INFINITY);
        for i in 0..4096 {
            let a = i as f32 / 4096.0 * 2.0 * PI;
            let p = d.frame.point(Vec2::new(a.cos(), a.sin())).0;
            assert!(p.cmpge(b.min - 1e-5).all() && p.cmple(b.max + 1e-5).all());
            reach = reach.max(p);
        }
        assert!((reach - b.max).abs().max_element() < 1e-4);
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
            let uv = d.uv_at(p.p);
            assert!(uv.x <= 1.0 + 1e-5);
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
