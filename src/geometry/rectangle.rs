//! Analytic rectangles: Mitsuba's `rectangle`, the square [-1, 1]^2 at
//! z = 0 facing +z, carried into the world by any affine `to_world` (a
//! parallelogram under shear). One primitive and one plane test per ray,
//! and a hit record without vertex fetches or normal interpolation, where
//! the two triangles it replaces cost two of each; like Mitsuba's, its
//! edges are not watertight against a neighbour's (a ray exactly on a
//! shared edge may pass between them).

use crate::math::{Aabb, Frame, Transform, Vec2, Vec3};

use super::plane::{PlaneError, PlaneFrame};
use super::{BvhHit, Intersection, SurfaceSample};

/// The points `center + x ex + y ey` of its frame with |x|, |y| <= 1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rectangle {
    pub frame: PlaneFrame,
    bounds: Aabb,
    /// The shading frame every hit gets (normal, and the x axis made
    /// orthogonal to it), worked out once rather than per hit.
    shading: Frame,
}

impl Rectangle {
    /// The square [-1, 1]^2 carried by `t`.
    pub fn new(t: &Transform) -> Result<Rectangle, PlaneError> {
        Rectangle::on(PlaneFrame::new(t)?)
    }

    fn on(frame: PlaneFrame) -> Result<Rectangle, PlaneError> {
        // The corners' box: centre +- (|ex_i| + |ey_i|).
        let bounds = frame.checked_bounds(frame.ex.abs() + frame.ey.abs())?;
        Ok(Rectangle {
            frame,
            bounds,
            shading: Rectangle::shading_of(&frame),
        })
    }

    fn shading_of(frame: &PlaneFrame) -> Frame {
        Frame::from_normal_tangent(frame.n, frame.ex)
    }

    /// This rectangle carried by `t`.
    pub fn transform(&mut self, t: &Transform) -> Result<(), PlaneError> {
        *self = Rectangle::on(self.frame.transformed(t)?)?;
        Ok(())
    }

    /// Turns the front side to the other face.
    pub fn flip_normals(&mut self) {
        self.frame.flip_normals();
        self.shading = Rectangle::shading_of(&self.frame);
    }

    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    pub fn area(&self) -> f32 {
        4.0 * self.frame.area_scale()
    }

    /// The hit in (tmin, tmax): its parameter and object coordinates.
    #[inline]
    pub fn intersect(&self, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> Option<(f32, Vec2)> {
        self.frame
            .hit(o, d, tmin, tmax)
            .filter(|(_, l)| l.x.abs() <= 1.0 && l.y.abs() <= 1.0)
    }

    /// [`Rectangle::intersect`] of a packet's rays: the lanes that hit as
    /// bits, their t and object coordinates (bit for bit the scalar's).
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
        let one = l.splat(1.0);
        let inside = l.m_and(l.le(l.abs(x), one), l.le(l.abs(y), one));
        (l.bits(l.m_and(within, inside)), [t, x, y])
    }

    /// Mitsuba's (u, v) at object coordinates `l`: ((x + 1) / 2, (y + 1) / 2).
    fn uv(l: Vec2) -> Vec2 {
        (l + Vec2::ONE) * 0.5
    }

    /// (u, v) at a point of the rectangle.
    pub fn uv_at(&self, p: Vec3) -> Vec2 {
        Rectangle::uv(self.frame.local(p))
    }

    /// dp/du and dp/dv: twice the frame's axes (u and v run over half the
    /// object range).
    pub fn dpdu_dpdv(&self) -> (Vec3, Vec3) {
        (2.0 * self.frame.ex, 2.0 * self.frame.ey)
    }

    /// The surface point of a BVH hit, whose `b1`, `b2` hold the object
    /// coordinates [`Rectangle::intersect`] found, stored into `out`.
    pub fn intersection_into(&self, hit: &BvhHit, out: &mut Intersection) {
        let l = Vec2::new(hit.b1, hit.b2);
        let (p, err) = self.frame.point(l);
        let n = self.frame.n;
        *out = Intersection {
            t: hit.t,
            p,
            err,
            ng: n,
            shading: self.shading,
            uv: Rectangle::uv(l),
            bary: Vec2::ZERO,
            shape: 0,
            instance: BvhHit::NO_INSTANCE,
            prim: 0,
        };
    }

    /// A point uniform over the rectangle.
    pub fn sample_area(&self, u: Vec2) -> SurfaceSample {
        let (p, err) = self.frame.point(2.0 * u - Vec2::ONE);
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

    fn sheared() -> Rectangle {
        let shear = Mat4::from_cols_array(&[
            2.0, 0.0, 0.0, 0.0, //
            0.7, 0.5, 0.0, 0.0, //
            0.0, 0.0, 1.0, 0.0, //
            1.0, -2.0, 0.5, 1.0,
        ]);
        Rectangle::new(&Transform::new(Mat4::from_rotation_x(0.7) * shear).unwrap()).unwrap()
    }

    #[test]
    fn hits_inside_and_misses_outside_the_parallelogram() {
        let r = sheared();
        for (l, inside) in [
            (Vec2::new(0.99, 0.99), true),
            (Vec2::new(-0.99, 0.5), true),
            (Vec2::new(1.01, 0.0), false),
            (Vec2::new(0.0, -1.01), false),
        ] {
            let target = r.frame.point(l).0;
            let o = target + Vec3::new(0.3, 2.0, 1.0);
            let hit = r.intersect(o, target - o, 0.0, f32::INFINITY);
            assert_eq!(hit.is_some(), inside, "{l}");
        }
    }

    #[test]
    fn area_bounds_uv_and_frame_match_the_transform() {
        let r = sheared();
        assert!((r.area() - 4.0 * 2.0 * 0.5).abs() < 1e-5);
        let b = r.bounds();
        let corners = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)];
        let mut reach = Vec3::splat(f32::NEG_INFINITY);
        for (x, y) in corners {
            let p = r.frame.point(Vec2::new(x, y)).0;
            assert!(p.cmpge(b.min - 1e-5).all() && p.cmple(b.max + 1e-5).all());
            reach = reach.max(p);
        }
        assert!((reach - b.max).abs().max_element() < 1e-5);
        let p = r.frame.point(Vec2::new(0.5, -0.5)).0;
        assert!((r.uv_at(p) - Vec2::new(0.75, 0.25)).abs().max_element() < 1e-6);
        let (dpdu, dpdv) = r.dpdu_dpdv();
        assert!((dpdu - 2.0 * r.frame.ex).length() < 1e-6);
        assert!((dpdv - 2.0 * r.frame.ey).length() < 1e-6);
    }

    /// Area sampling is uniform: 4 x 4 cells of equal area get 1/16 of the
    /// samples each (chi-square).
    #[test]
    fn area_samples_are_uniform() {
        let r = sheared();
        let mut s = Sampler::new(11, 2);
        let n = 64_000;
        let mut counts = [0.0f64; 16];
        for _ in 0..n {
            let p = r.sample_area(s.next_2d());
            assert_eq!(p.pdf_area, 1.0 / r.area());
            let uv = r.uv_at(p.p);
            assert!(uv.cmpge(Vec2::splat(-1e-5)).all() && uv.cmple(Vec2::splat(1.0 + 1e-5)).all());
            let cell = |x: f32| ((x * 4.0) as usize).min(3);
            counts[cell(uv.y) * 4 + cell(uv.x)] += 1.0;
        }
        let expected = vec![n as f64 / 16.0; 16];
        let res = crate::stats::chi2_test(&counts, &expected, 5.0);
        assert!(res.passes(1e-3), "{res:?}");
    }
}
