//! Analytic spheres.

use crate::math::{fast_atan2, sin_cos_turns, Aabb, Frame, Ray, Transform, Vec2, Vec3, PI};
use crate::sampling::warp;

use super::{Intersection, SurfaceSample};

/// A cone of directions around a unit axis.
#[derive(Clone, Copy, Debug)]
pub struct Cone {
    pub axis: Vec3,
    /// 1 - cos of the half-angle.
    pub one_minus_cos: f32,
    /// sin^2 of the half-angle (radius^2 / distance^2 for a sphere's cone).
    pub sin2_max: f32,
}

impl Cone {
    /// Solid-angle density of uniform sampling.
    pub fn pdf(&self) -> f32 {
        1.0 / (2.0 * PI * self.one_minus_cos)
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    pub center: Vec3,
    pub radius: f32,
    /// Unit polar axis of the (u, v) parameterization: object-space +z
    /// carried by the transform, as in Mitsuba. Shading frames follow
    /// dp/du, the azimuthal direction around it.
    pub axis: Vec3,
    /// Object-space +x and +y carried by the transform (unit): where the
    /// azimuth u starts and turns to.
    pub x_axis: Vec3,
    pub y_axis: Vec3,
    /// Which (u, v) a hit gets.
    pub uv: SphereUv,
}

/// A sphere's surface parameterisation, about its polar axis (object z)
/// with the azimuth measured from object x.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SphereUv {
    /// Mitsuba's: u = atan2(y, x) / 2pi in [0, 1), v = acos(z) / pi (0 at
    /// the top).
    #[default]
    Mitsuba,
    /// ETH Zurich's Nori course (its textured-sphere assignment):
    /// u = 1/2 + atan2(y, x) / 2pi, v = 1/2 + asin(z) / pi (1 at the top).
    Eth,
}

/// A sphere that cannot be. Each message completes a sentence that starts
/// with the parameter's name ([`SphereError::describe_param`]).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SphereError {
    #[error("must be positive and finite (with the centre's coordinates), found {0}")]
    Radius(f32),
    #[error("must be finite, found {0}")]
    Center(Vec3),
    #[error(
        "puts the sphere (centre ({:e}, {:e}, {:e}), radius {radius:e}) beyond +-{:e}, the coordinate range lente supports",
        center.x, center.y, center.z, crate::limits::MAX_COORDINATE
    )]
    OutOfRange { center: Vec3, radius: f32 },
    #[error("must be a similarity (rotations, translations and uniform scales only)")]
    NotSimilarity,
}

impl SphereError {
    /// The parameter in words: "radius", "centre" or "transform".
    pub fn describe_param(&self) -> &'static str {
        match self {
            SphereError::Radius(_) => "radius",
            SphereError::Center(_) | SphereError::OutOfRange { .. } => "centre",
            SphereError::NotSimilarity => "transform",
        }
    }
}

impl Sphere {
    /// A sphere with its polar axis along +z.
    pub fn new(center: Vec3, radius: f32) -> Result<Sphere, SphereError> {
        let s = Sphere {
            center,
            radius,
            axis: Vec3::Z,
            x_axis: Vec3::X,
            y_axis: Vec3::Y,
            uv: SphereUv::Mitsuba,
        };
        s.check()?;
        Ok(s)
    }

    fn check(&self) -> Result<(), SphereError> {
        if !(self.radius > 0.0 && self.radius.is_finite()) {
            return Err(SphereError::Radius(self.radius));
        }
        if !self.center.is_finite() {
            return Err(SphereError::Center(self.center));
        }
        // Bounds (centre +- radius) must stay in the range whose BVH
        // arithmetic is finite.
        let reach = (self.center.abs() + Vec3::splat(self.radius)).max_element();
        if reach > crate::limits::MAX_COORDINATE {
            return Err(SphereError::OutOfRange {
                center: self.center,
                radius: self.radius,
            });
        }
        Ok(())
    }

    /// dp/du at the point with outward normal `n`: around the polar axis
    /// (zero at the poles), the way u grows from `x_axis` to `y_axis`
    /// (against `axis x n` when a mirror made the frame left-handed).
    pub fn dpdu(&self, n: Vec3) -> Vec3 {
        self.x_axis.cross(self.y_axis).cross(n)
    }

    /// dp/du and dp/dv at the point with outward normal `n`, as Mitsuba's
    /// sphere has them: u = azimuth / 2pi about `axis`, v = polar angle /
    /// pi, so dp/du = 2pi r (axis x n) and dp/dv = pi r (cos(theta) times
    /// the horizontal direction of n, minus sin(theta) axis).
    pub fn dpdu_dpdv(&self, n: Vec3) -> (Vec3, Vec3) {
        let r = self.radius;
        let cos = n.dot(self.axis);
        let horizontal = n - self.axis * cos;
        let sin = horizontal.length();
        let dpdu = self.dpdu(n) * (2.0 * PI * r);
        let dpdv = if sin > 0.0 {
            (horizontal * (cos / sin) - self.axis * sin) * (PI * r)
        } else {
            Vec3::ZERO
        };
        (dpdu, dpdv)
    }

    pub fn bounds(&self) -> Aabb {
        Aabb {
            min: self.center - Vec3::splat(self.radius),
            max: self.center + Vec3::splat(self.radius),
        }
    }

    pub fn area(&self) -> f32 {
        4.0 * PI * self.radius * self.radius
    }

    /// Applies a similarity transform; anything that shears or scales
    /// unevenly would no longer be a sphere.
    pub fn transform(&mut self, t: &Transform) -> Result<(), SphereError> {
        if !t.is_similarity() {
            return Err(SphereError::NotSimilarity);
        }
        let moved = Sphere {
            center: t.point(self.center),
            radius: self.radius * t.vector(Vec3::X).length(),
            axis: t.vector(self.axis).normalize(),
            x_axis: t.vector(self.x_axis).normalize(),
            y_axis: t.vector(self.y_axis).normalize(),
            uv: self.uv,
        };
        moved.check()?;
        *self = moved;
        Ok(())
    }

    /// Nearest hit parameter in (tmin, tmax), computed in a numerically
    /// stable way (the quadratic relative to the closest point on the ray).
    pub fn intersect(&self, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> Option<f32> {
        let f = o - self.center;
        let a = d.length_squared();
        let b = -f.dot(d);
        // Distance from centre to the ray's closest point, computed stably.
        let l = f + (b / a) * d;
        let disc = self.radius * self.radius - l.length_squared();
        if disc < 0.0 {
            return None;
        }
        let c = f.length_squared() - self.radius * self.radius;
        let q = b + b.signum() * (a * disc).sqrt();
        let (t0, t1) = if q == 0.0 {
            (0.0, 0.0)
        } else {
            let (x, y) = (c / q, q / a);
            (x.min(y), x.max(y))
        };
        if t0 > tmin && t0 < tmax {
            Some(t0)
        } else if t1 > tmin && t1 < tmax {
            Some(t1)
        } else {
            None
        }
    }

    /// [`Sphere::intersect`] of a packet's rays: the lanes that hit within
    /// (tmin, tmax) as bits, and their t, by the scalar test's operations
    /// in its order (each lane's t is its, bit for bit).
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
    ) -> (u32, L::F) {
        use super::lanes::{dot3, splat3, sub3};
        let l = p.l;
        let dot = dot3;
        let (o, d, tmin) = (p.o, p.d, p.tmin);
        let f = sub3(o, splat3(l, self.center));
        let a = dot(d, d);
        let b = l.xor(dot(f, d), l.splat(-0.0));
        let s = b / a;
        let lp = [f[0] + s * d[0], f[1] + s * d[1], f[2] + s * d[2]];
        let r2 = l.splat(self.radius * self.radius);
        let disc = r2 - dot(lp, lp);
        let zero = l.zero();
        let outside = l.lt(disc, zero);
        let cc = dot(f, f) - r2;
        // `b.signum()`: +-1 by b's sign bit (a NaN b makes q NaN anyway).
        let sign = l.or(l.and(b, l.splat(-0.0)), l.splat(1.0));
        let q = b + sign * l.sqrt(a * disc);
        let (x, y) = (cc / q, q / a);
        // f32::min and max: a NaN operand gives the other one.
        // (`minps(x, y)` gives y where either is NaN.)
        let y_nan = l.unord(y, y);
        let t0 = l.blend(l.min(x, y), x, y_nan);
        let t1 = l.blend(l.max(x, y), x, y_nan);
        let q_zero = l.eq(q, zero);
        let (t0, t1) = (l.blend(t0, zero, q_zero), l.blend(t1, zero, q_zero));
        let in0 = l.m_and(l.gt(t0, tmin), l.lt(t0, tmax));
        let in1 = l.m_and(l.gt(t1, tmin), l.lt(t1, tmax));
        let t = l.blend(t1, t0, in0);
        (l.bits(l.m_andnot(outside, l.m_or(in0, in1))), t)
    }

    /// Outward normal and spherical (u, v) at a surface point, in
    /// object space ([`SphereUv`]). The angles come from [`fast_atan2`]
    /// (within 6e-7 radians: below the rounding of u and v; libm's
    /// `atan2f` and `acosf` were a few percent of a sphere scene's time),
    /// theta as atan2(rho, z), accurate at the poles where acos(z) is not.
    pub fn normal_uv(&self, p: Vec3) -> (Vec3, Vec2) {
        let n = ((p - self.center) / self.radius).normalize();
        let (x, y, z) = (n.dot(self.x_axis), n.dot(self.y_axis), n.dot(self.axis));
        let phi = fast_atan2(y, x);
        let theta = fast_atan2((x * x + y * y).sqrt(), z);
        let uv = match self.uv {
            SphereUv::Mitsuba => {
                let phi = if phi < 0.0 { phi + 2.0 * PI } else { phi };
                Vec2::new(phi / (2.0 * PI), theta / PI)
            }
            // asin(z) / pi = 1/2 - acos(z) / pi.
            SphereUv::Eth => Vec2::new(0.5 + phi / (2.0 * PI), 1.0 - theta / PI),
        };
        (n, uv)
    }

    /// The surface point at parameter `t` of `ray`, stored into `out`
    /// (shape index left 0 for the caller; see
    /// [`super::Geometry::intersection_into`]).
    pub fn intersection_into(&self, ray: &Ray, t: f32, out: &mut Intersection) {
        let (n, uv) = self.normal_uv(ray.at(t));
        *out = Intersection {
            t,
            // Reprojected onto the surface to remove the error of o + t d.
            p: self.center + n * self.radius,
            err: self.point_error(n),
            ng: n,
            shading: Frame::from_normal_tangent(n, self.dpdu(n)),
            uv,
            bary: Vec2::ZERO,
            shape: 0,
            instance: super::BvhHit::NO_INSTANCE,
            prim: 0,
        };
    }

    /// Error bound of the point `center + radius * n`.
    pub fn point_error(&self, n: Vec3) -> Vec3 {
        (self.center.abs() + (self.radius * n).abs()) * crate::math::gamma(6)
    }

    /// The cone of directions the sphere subtends from a point outside it
    /// (None inside or on it, where area sampling is used instead).
    pub fn visible_cone(&self, p: Vec3) -> Option<Cone> {
        let to = self.center - p;
        let d2 = to.length_squared();
        let r2 = self.radius * self.radius;
        if d2 <= r2 * 1.0001 {
            return None;
        }
        let sin2 = r2 / d2;
        let cos_max = (1.0 - sin2).max(0.0).sqrt();
        Some(Cone {
            axis: to / d2.sqrt(),
            // 1 - cos, computed without cancellation for small cones.
            one_minus_cos: sin2 / (1.0 + cos_max),
            sin2_max: sin2,
        })
    }

    /// Samples a point on the visible cap by sampling the cone uniformly;
    /// returns it with the solid-angle pdf. The point is found in closed
    /// form (pbrt-v4's sphere sampling, section 6.2.4): the direction's
    /// angle theta to the axis gives the angle alpha at the centre between
    /// the axis back to `p` and the point's normal, so no ray is traced
    /// and no trigonometric library call is made (the azimuth's sine and
    /// cosine are [`sin_cos_turns`]'s).
    pub fn sample_cone(&self, cone: &Cone, u: Vec2) -> (SurfaceSample, f32) {
        // 1 - cos(theta), uniform in [0, 1 - cos_max], and sin^2(theta)
        // from it without cancellation: (1 - cos)(1 + cos).
        let t = u.y * cone.one_minus_cos;
        let cos_theta = 1.0 - t;
        let sin2_theta = t * (2.0 - t);
        // Law of sines and cosines in the triangle (p, centre, point):
        // cos(alpha) = sin^2(theta) / sin_max + cos(theta) cos(theta'),
        // sin(theta') = sin(theta) / sin_max the angle at the point.
        let ratio = (sin2_theta / cone.sin2_max).min(1.0);
        let cos_alpha = (sin2_theta / cone.sin2_max.sqrt()
            + cos_theta * (1.0 - ratio).max(0.0).sqrt())
        .min(1.0);
        let sin_alpha = (1.0 - cos_alpha * cos_alpha).max(0.0).sqrt();
        let (sin_phi, cos_phi) = sin_cos_turns(u.x);
        // The normal leans back towards `p`: against the axis (which points
        // from `p` to the centre) by alpha.
        let local = Vec3::new(sin_alpha * cos_phi, sin_alpha * sin_phi, cos_alpha);
        let n = -Frame::from_normal(cone.axis).to_world(local);
        let s = SurfaceSample {
            p: self.center + self.radius * n,
            err: self.point_error(n),
            n,
            pdf_area: 0.0,
            prim: 0,
            bary: Vec2::ZERO,
        };
        (s, cone.pdf())
    }

    /// Uniform point on the whole sphere.
    pub fn sample_area(&self, u: Vec2) -> SurfaceSample {
        let n = warp::square_to_uniform_sphere(u);
        SurfaceSample {
            p: self.center + self.radius * n,
            err: self.point_error(n),
            n,
            pdf_area: 1.0 / self.area(),
            prim: 0,
            bary: Vec2::ZERO,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn uv_agrees_with_f64_angles_in_both_conventions() {
        let mut rng = crate::sampling::Sampler::new(11, 3);
        for uv in [SphereUv::Mitsuba, SphereUv::Eth] {
            let s = Sphere {
                uv,
                ..Sphere::new(Vec3::new(0.5, -1.0, 2.0), 1.5).unwrap()
            };
            let mut worst = 0.0f32;
            for _ in 0..200_000 {
                let n = warp::square_to_uniform_sphere(rng.next_2d());
                let (got_n, got) = s.normal_uv(s.center + n * s.radius);
                // The reference: libm's atan2 in f64 (theta as atan2 too:
                // acos of a not quite unit z is off by ~1e-6 near the poles).
                let g = got_n.as_dvec3();
                let phi = g.y.atan2(g.x);
                let theta = (g.x * g.x + g.y * g.y).sqrt().atan2(g.z);
                let tau = std::f64::consts::TAU;
                let want = match uv {
                    SphereUv::Mitsuba => [phi.rem_euclid(tau) / tau, theta / std::f64::consts::PI],
                    SphereUv::Eth => [0.5 + phi / tau, 1.0 - theta / std::f64::consts::PI],
                };
                // u wraps at the seam (phi = +-pi or 0): compare on the circle.
                let du = (got.x as f64 - want[0]).abs();
                let du = du.min((1.0 - du).abs());
                worst = worst
                    .max(du as f32)
                    .max((got.y as f64 - want[1]).abs() as f32);
            }
            // 6e-7 radians over 2 pi, plus the rounding of u and v.
            assert!(worst < 3e-7, "{uv:?}: worst uv error {worst:e}");
        }
    }

    /// Cone samples lie on the sphere's cap visible from the point, with
    /// directions uniform over the cone it subtends: a chi-square test over
    /// equal-solid-angle cells (1 - cos(theta) and the azimuth, in f64) from
    /// points near the sphere (a wide cone), at middle distances and far
    /// (a cone of 0.04 degrees, where sin^2 is tiny).
    #[test]
    fn cone_samples_are_uniform_over_the_cone_on_the_visible_cap() {
        let s = Sphere::new(Vec3::new(0.5, -1.0, 2.0), 1.5).unwrap();
        let c = s.center.as_dvec3();
        let r = s.radius as f64;
        let points = [
            Vec3::new(0.5, -1.0, 3.6),
            Vec3::new(2.5, 1.0, 0.0),
            Vec3::new(-10.0, 4.0, 12.0),
            Vec3::new(1500.0, -900.0, 1200.0),
        ];
        let (bins_a, bins_phi) = (8, 8);
        let alpha = crate::stats::sidak(0.01, points.len());
        let mut rng = crate::sampling::Sampler::new(17, 4);
        for &p in &points {
            let cone = s.visible_cone(p).expect("outside");
            let pd = p.as_dvec3();
            let to = c - pd;
            let axis = to.normalize();
            let sin2 = r * r / to.length_squared();
            let omc = sin2 / (1.0 + (1.0 - sin2).sqrt());
            // A frame about the axis for the azimuth.
            let (e1, e2) = axis.any_orthonormal_pair();
            let n = 100_000;
            let mut observed = vec![0.0f64; bins_a * bins_phi];
            for _ in 0..n {
                let (ss, pdf) = s.sample_cone(&cone, rng.next_2d());
                assert_eq!(pdf.to_bits(), cone.pdf().to_bits());
                let q = ss.p.as_dvec3();
                assert!(
                    ((q - c).length() - r).abs() < 1e-5 * r,
                    "{p}: off the sphere"
                );
                let n_d = ss.n.as_dvec3();
                assert!((n_d - (q - c) / r).length() < 1e-5, "{p}: normal");
                // Seen from p: the normal faces it (up to rounding at the rim).
                let d = (q - pd).normalize();
                assert!(n_d.dot(-d) > -1e-4, "{p}: sample behind the rim");
                let cross = d.cross(axis).length_squared();
                let one_minus_cos = cross / (1.0 + d.dot(axis));
                let a = ((one_minus_cos / omc) * bins_a as f64) as usize;
                let phi = d.dot(e2).atan2(d.dot(e1)).rem_euclid(std::f64::consts::TAU);
                let b = (phi / std::f64::consts::TAU * bins_phi as f64) as usize;
                observed[a.min(bins_a - 1) * bins_phi + b.min(bins_phi - 1)] += 1.0;
            }
            let expected = vec![n as f64 / (bins_a * bins_phi) as f64; observed.len()];
            let t = crate::stats::chi2_test(&observed, &expected, 5.0);
            assert!(t.passes(alpha), "{p}: {t:?}");
        }
    }

    #[test]
    fn hits_from_outside_and_inside() {
        let s = Sphere::new(Vec3::new(0.0, 0.0, 5.0), 1.0).unwrap();
        let t = s
            .intersect(Vec3::ZERO, Vec3::Z, 0.0, f32::INFINITY)
            .unwrap();
        assert!((t - 4.0).abs() < 1e-5);
        let t = s
            .intersect(Vec3::new(0.0, 0.0, 5.0), Vec3::Z, 0.0, f32::INFINITY)
            .unwrap();
        assert!((t - 1.0).abs() < 1e-5);
        assert!(s
            .intersect(Vec3::ZERO, Vec3::X, 0.0, f32::INFINITY)
            .is_none());
    }

    #[test]
    fn far_small_sphere_is_precise() {
        let s = Sphere::new(Vec3::new(0.0, 0.0, 1e4), 0.01).unwrap();
        let t = s
            .intersect(Vec3::ZERO, Vec3::Z, 0.0, f32::INFINITY)
            .unwrap();
        assert!((t - (1e4 - 0.01)).abs() < 2e-3);
    }
}
