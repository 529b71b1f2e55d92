//! Mitsuba 3's round curves, `linearcurve` and `bsplinecurve`: tubes of
//! varying radius along polylines or uniform cubic B-splines, read from
//! Mitsuba's text format (a control point `x y z radius` per line, a blank
//! line between curves) and intersected as Embree, which Mitsuba traces
//! them with, defines them:
//!
//! - a linear segment is the cone tangent to the spheres at its two
//!   control points plus its end sphere (and its start sphere where no
//!   segment precedes it); the end sphere is cut where the next segment's
//!   cone takes over;
//! - a B-spline segment is swept by a circle of the interpolated radius
//!   held perpendicular to the curve: the points `c(v) + r(v) w` with `w`
//!   a unit vector orthogonal to `c'(v)`; the ends of a curve are open.
//!
//! Only front faces are hit (Mitsuba builds Embree with back-face culling
//! for curves): a ray that starts inside a tube does not see it.
//! Parameterisation and normals follow Mitsuba's shapes: `v` runs along all
//! segments of the file, `u` around the tube.

use std::f32::consts::PI;

use glam::{DVec3, DVec4, Vec4Swizzles};

use super::{BvhHit, Intersection};
use crate::math::{Aabb, Frame, Ray, Transform, Vec2, Vec3, Vec4};

/// The curve's basis: what its control points mean.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CurveBasis {
    /// A polyline: each segment joins two control points.
    Linear,
    /// A uniform cubic B-spline: each segment spans four control points.
    BSpline,
}

impl CurveBasis {
    /// Control points one segment reads.
    fn span(self) -> usize {
        match self {
            CurveBasis::Linear => 2,
            CurveBasis::BSpline => 4,
        }
    }

    fn name(self) -> &'static str {
        match self {
            CurveBasis::Linear => "linear",
            CurveBasis::BSpline => "B-spline",
        }
    }
}

/// A file of curves: control points in world space (radius in `w`; radii
/// do not change with `to_world`, as in Mitsuba) and the first control
/// point of every segment.
#[derive(Clone, Debug)]
pub struct Curve {
    basis: CurveBasis,
    points: Vec<Vec4>,
    segments: Vec<u32>,
    bounds: Aabb,
}

/// A curve file that cannot be read: the line and what is wrong with it.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum CurveError {
    #[error("line {line}: {message}")]
    Line { line: usize, message: String },
    #[error("no control points")]
    Empty,
    #[error("{0} segments; lente takes at most 2^28 per file")]
    TooMany(usize),
}

/// Segments one file may hold (the BVH tags them in 30 bits).
const MAX_SEGMENTS: usize = 1 << 28;

/// Reads a curve file (within the mesh files' size bound) and parses it.
pub fn load_curve(
    path: &std::path::Path,
    basis: CurveBasis,
    to_world: &Transform,
) -> Result<Curve, super::MeshFileError> {
    let bytes = super::read_mesh_file(path)?;
    Curve::parse(&String::from_utf8_lossy(&bytes), basis, to_world).map_err(|error| {
        super::MeshFileError::Curve {
            path: path.to_path_buf(),
            error,
        }
    })
}

impl Curve {
    /// Parses Mitsuba's curve text format, placing the points with `to_world`.
    pub fn parse(text: &str, basis: CurveBasis, to_world: &Transform) -> Result<Curve, CurveError> {
        let mut points = Vec::new();
        let mut segments = Vec::new();
        // First control point of the curve being read, and its line.
        let mut open: Option<(usize, usize)> = None;
        let close = |open: Option<(usize, usize)>,
                     points: &Vec<Vec4>,
                     segments: &mut Vec<u32>|
         -> Result<(), CurveError> {
            let Some((first, line)) = open else {
                return Ok(());
            };
            let n = points.len() - first;
            let span = basis.span();
            if n < span {
                return Err(CurveError::Line {
                    line,
                    message: format!(
                        "this {} curve has {n} control point{}; it needs at least {span}",
                        basis.name(),
                        if n == 1 { "" } else { "s" }
                    ),
                });
            }
            segments.extend((first..=points.len() - span).map(|i| i as u32));
            Ok(())
        };
        for (i, raw) in text.lines().enumerate() {
            let line = i + 1;
            let fields: Vec<&str> = raw.split_whitespace().collect();
            if fields.is_empty() {
                close(open.take(), &points, &mut segments)?;
                continue;
            }
            let bad = |message: String| CurveError::Line { line, message };
            if fields.len() != 4 {
                return Err(bad(format!(
                    "expected a control point 'x y z radius', found {} value{}",
                    fields.len(),
                    if fields.len() == 1 { "" } else { "s" }
                )));
            }
            let mut v = [0.0f32; 4];
            for (slot, f) in v.iter_mut().zip(&fields) {
                *slot = f
                    .parse::<f32>()
                    .ok()
                    .filter(|x| x.is_finite())
                    .ok_or_else(|| bad(format!("'{f}' is not a finite number")))?;
            }
            if v[3] < 0.0 {
                return Err(bad(format!("the radius {} is negative", v[3])));
            }
            let p = to_world.point(Vec3::new(v[0], v[1], v[2]));
            if !p.is_finite() || p.abs().max_element() > crate::limits::MAX_COORDINATE {
                return Err(bad(
                    "the control point is out of range after to_world".into()
                ));
            }
            if open.is_none() {
                open = Some((points.len(), line));
            }
            points.push(Vec4::new(p.x, p.y, p.z, v[3]));
        }
        close(open, &points, &mut segments)?;
        if points.is_empty() {
            return Err(CurveError::Empty);
        }
        if segments.len() > MAX_SEGMENTS {
            return Err(CurveError::TooMany(segments.len()));
        }
        let mut curve = Curve {
            basis,
            points,
            segments,
            bounds: Aabb::EMPTY,
        };
        curve.bounds = curve.segments_bounds();
        Ok(curve)
    }

    /// Moves the control points (radii stay, as in Mitsuba's `to_world`).
    pub fn transform(&mut self, t: &Transform) {
        for p in &mut self.points {
            let q = t.point(p.xyz());
            *p = Vec4::new(q.x, q.y, q.z, p.w);
        }
        self.bounds = self.segments_bounds();
    }

    /// The union of all segments' boxes.
    fn segments_bounds(&self) -> Aabb {
        (0..self.segment_count()).fold(Aabb::EMPTY, |b, s| b.union(self.segment_bounds(s)))
    }

    pub fn basis(&self) -> CurveBasis {
        self.basis
    }

    pub fn segment_count(&self) -> usize {
        self.segments.len()
    }

    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    /// The control points segment `s` reads.
    fn control(&self, s: usize) -> &[Vec4] {
        let first = self.segments[s] as usize;
        &self.points[first..first + self.basis.span()]
    }

    /// A box around segment `s`: its control points' box widened by their
    /// largest radius (the segment lies in their convex hull).
    pub fn segment_bounds(&self, s: usize) -> Aabb {
        let r = self.max_radius(s);
        self.control(s).iter().fold(Aabb::EMPTY, |b, c| {
            b.union(Aabb {
                min: c.xyz() - Vec3::splat(r),
                max: c.xyz() + Vec3::splat(r),
            })
        })
    }

    /// The largest radius of segment `s`'s control points, which bounds
    /// its interpolated radius.
    fn max_radius(&self, s: usize) -> f32 {
        self.control(s).iter().fold(0.0f32, |m, c| m.max(c.w))
    }

    /// What the BVH stores for segment `s`.
    pub fn segment(&self, s: usize) -> CurveSegment {
        let cp = self.control(s);
        match self.basis {
            CurveBasis::Linear => {
                let first = self.segments[s];
                // Neighbours as Embree derives them from the index buffer.
                let left = s > 0 && self.segments[s - 1] + 1 == first;
                let right = (s + 1 < self.segments.len() && self.segments[s + 1] == first + 1)
                    .then(|| self.points[first as usize + 2]);
                CurveSegment::Linear {
                    p0: cp[0],
                    p1: cp[1],
                    left,
                    right,
                }
            }
            CurveBasis::BSpline => {
                let [a, b, c, d] = [cp[0], cp[1], cp[2], cp[3]].map(|p| p.as_dvec4());
                // The same cubic in the Bezier basis, whose control points
                // bound it and subdivide exactly.
                CurveSegment::BSpline {
                    bezier: [
                        (a + 4.0 * b + c) / 6.0,
                        (2.0 * b + c) / 3.0,
                        (b + 2.0 * c) / 3.0,
                        (b + 4.0 * c + d) / 6.0,
                    ],
                }
            }
        }
    }

    /// The surface point of a BVH hit (`hit.index` the segment, `hit.b1`
    /// the parameter along it), with Mitsuba's uv, normal and tangent.
    /// Stored into `out`.
    pub fn intersection_into(&self, ray: &Ray, hit: &BvhHit, out: &mut Intersection) {
        let s = hit.index as usize;
        let v = hit.b1.clamp(0.0, 1.0);
        let p = ray.at(hit.t);
        let centre = self.centre_line(s, v);
        let radial = p - centre.c;
        let n = match self.basis {
            // The cone's normal: Embree's parameter already accounts for
            // the changing radius, so the centre point is the foot.
            CurveBasis::Linear => radial,
            // Normal of the swept circle, with the curvature correction.
            CurveBasis::BSpline => {
                (centre.dc.length_squared() - radial.dot(centre.ddc)) * radial
                    - (centre.dr * centre.r) * centre.dc
            }
        }
        .normalize_or(radial.normalize_or(Vec3::Z));
        let (rot, rad) = local_frame(centre.tangent());
        let w = radial.normalize_or(n);
        let mut u = w.dot(rot).atan2(w.dot(rad)) / (2.0 * PI);
        if u < 0.0 {
            u += 1.0;
        }
        let count = self.segments.len() as f32;
        let dpdu = centre.dpdu(radial);
        let r_max = self.max_radius(s);
        *out = Intersection {
            t: hit.t,
            p,
            // The hit is solved for, not interpolated: a generous bound
            // (front-face-only hits keep a leaving ray off its own tube).
            err: Vec3::splat(p.abs().max_element() * 1e-5 + r_max * 1e-4),
            ng: n,
            shading: Frame::from_normal_tangent(n, dpdu),
            uv: Vec2::new(u, (v + s as f32) / count),
            bary: Vec2::ZERO,
            shape: 0,
            instance: BvhHit::NO_INSTANCE,
            prim: s as u32,
        };
    }

    /// dp/du and dp/dv at a hit (Mitsuba's, so normal and bump maps agree):
    /// u once around the tube, v along all segments.
    pub fn dpdu_dpdv(&self, its: &Intersection) -> (Vec3, Vec3) {
        let s = its.prim as usize;
        let count = self.segments.len() as f32;
        let v = (its.uv.y * count - s as f32).clamp(0.0, 1.0);
        let centre = self.centre_line(s, v);
        let radial = its.p - centre.c;
        let tangent = centre.tangent();
        let dpdu = centre.dpdu(radial);
        let w = radial.normalize_or(its.ng);
        let dpdv = match self.basis {
            CurveBasis::Linear => centre.dc + centre.dr * w,
            CurveBasis::BSpline => {
                // The radial direction turns with the curve's Frenet frame
                // (curvature kappa, torsion tau), as in Mitsuba's partials.
                let speed = centre.dc.length();
                let cross = centre.dc.cross(centre.ddc);
                let cross_len = cross.length();
                let kappa = cross_len / (speed * speed * speed);
                let mut tau = centre.dddc.dot(cross) / (cross_len * cross_len);
                if cross_len < 1e-6 || centre.dddc.length() < 1e-6 || !tau.is_finite() {
                    tau = 0.0;
                }
                let (normal, binormal, kappa, tau) = if kappa < f32::EPSILON || !kappa.is_finite() {
                    let f = Frame::from_normal(tangent);
                    (f.s, f.t, 0.0, 0.0)
                } else {
                    let normal = cross.cross(centre.dc).normalize();
                    (normal, tangent.cross(normal).normalize(), kappa, tau)
                };
                let (cos, sin) = (normal.dot(w), binormal.dot(w));
                let radv = speed * cos * (-kappa * tangent + tau * binormal)
                    + speed * sin * (-tau * normal);
                centre.dc + centre.dr * w + centre.r * radv
            }
        };
        (dpdu, dpdv * count)
    }

    /// The centre line of segment `s` at `v`, with its derivatives.
    fn centre_line(&self, s: usize, v: f32) -> CentreLine {
        let cp = self.control(s);
        match self.basis {
            CurveBasis::Linear => {
                let (a, b) = (cp[0], cp[1]);
                CentreLine {
                    c: a.xyz().lerp(b.xyz(), v),
                    dc: b.xyz() - a.xyz(),
                    ddc: Vec3::ZERO,
                    dddc: Vec3::ZERO,
                    r: a.w + (b.w - a.w) * v,
                    dr: b.w - a.w,
                }
            }
            CurveBasis::BSpline => {
                let (v2, v3) = (v * v, v * v * v);
                let w = [
                    (1.0 - v) * (1.0 - v) * (1.0 - v) / 6.0,
                    (3.0 * v3 - 6.0 * v2 + 4.0) / 6.0,
                    (-3.0 * v3 + 3.0 * v2 + 3.0 * v + 1.0) / 6.0,
                    v3 / 6.0,
                ];
                let dw = [
                    -(1.0 - v) * (1.0 - v) / 2.0,
                    (3.0 * v2 - 4.0 * v) / 2.0,
                    (-3.0 * v2 + 2.0 * v + 1.0) / 2.0,
                    v2 / 2.0,
                ];
                let ddw = [1.0 - v, 3.0 * v - 2.0, 1.0 - 3.0 * v, v];
                let dddw = [-1.0, 3.0, -3.0, 1.0];
                let sum = |k: &[f32; 4]| (0..4).fold(Vec4::ZERO, |acc, i| acc + cp[i] * k[i]);
                let (c, dc, ddc, dddc) = (sum(&w), sum(&dw), sum(&ddw), sum(&dddw));
                CentreLine {
                    c: c.xyz(),
                    dc: dc.xyz(),
                    ddc: ddc.xyz(),
                    dddc: dddc.xyz(),
                    r: c.w,
                    dr: dc.w,
                }
            }
        }
    }
}

/// A point of a segment's centre line and its derivatives in `v`.
struct CentreLine {
    c: Vec3,
    dc: Vec3,
    ddc: Vec3,
    dddc: Vec3,
    r: f32,
    dr: f32,
}

impl CentreLine {
    /// The unit direction of the curve.
    fn tangent(&self) -> Vec3 {
        self.dc.normalize_or(Vec3::X)
    }

    /// dp/du of the surface point `c + radial`: u turns once around the
    /// tube (Mitsuba's `2 pi (t x radial)`).
    fn dpdu(&self, radial: Vec3) -> Vec3 {
        2.0 * PI * self.tangent().cross(radial)
    }
}

/// Mitsuba's frame around a curve's tangent, from which `u` is measured:
/// `rot` is the world's z made orthogonal to the tangent (y where they are
/// parallel), `rad` completes it.
fn local_frame(tangent: Vec3) -> (Vec3, Vec3) {
    let guide = Vec3::Z;
    let rot = if tangent.dot(guide).abs() == 1.0 {
        Vec3::Y
    } else {
        (guide - tangent * tangent.dot(guide)).normalize_or(Vec3::Y)
    };
    (rot, rot.cross(tangent))
}

/// One segment as the BVH stores it, ready to intersect.
#[derive(Clone, Copy, Debug)]
pub enum CurveSegment {
    Linear {
        p0: Vec4,
        p1: Vec4,
        /// A segment ends where this one starts (no start sphere then).
        left: bool,
        /// The far control point of the next segment, if one follows.
        right: Option<Vec4>,
    },
    BSpline {
        /// The segment's cubic (position and radius) in the Bezier basis.
        bezier: [DVec4; 4],
    },
}

impl CurveSegment {
    /// The nearest front-facing hit in (tmin, tmax): its distance and the
    /// parameter along the segment.
    pub fn intersect(&self, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> Option<(f32, f32)> {
        match self {
            CurveSegment::Linear {
                p0,
                p1,
                left,
                right,
            } => intersect_round_line(*p0, *p1, *left, *right, o, d, tmin, tmax),
            CurveSegment::BSpline { bezier } => intersect_swept_bezier(bezier, o, d, tmin, tmax),
        }
    }
}

/// Embree's round linear segment, front faces only: the cone tangent to
/// the spheres (p0, r0) and (p1, r1) between its touching circles, the end
/// sphere beyond them except where the next segment's cone starts, and the
/// start sphere when no segment comes before.
#[allow(clippy::too_many_arguments)]
fn intersect_round_line(
    p0: Vec4,
    p1: Vec4,
    left: bool,
    right: Option<Vec4>,
    o: Vec3,
    d: Vec3,
    tmin: f32,
    tmax: f32,
) -> Option<(f32, f32)> {
    let dd = d.length_squared();
    // Solve from a point of the ray near the segment, for precision.
    let (a, b) = (p0.xyz(), p1.xyz());
    let shift = (0.5 * (a + b) - o).dot(d) / dd;
    let org = o + shift * d;
    let (r0, r1) = (p0.w, p1.w);
    let dp = b - a;
    let dpdp = dp.length_squared();
    let dr = r1 - r0;
    // Squared length between the cone's clipping planes (scaled by |dp|^2).
    let g = dpdp - dr * dr;
    let rel = org - a;
    let odp = rel.dot(dp);
    let ddp = d.dot(dp);
    // y(t): where along the cone the ray is (0 and g at the touching circles).
    let y0 = odp + r0 * dr;
    let y_at = |t: f32| y0 + t * ddp;
    let (lo, hi) = (tmin - shift, tmax - shift);
    let mut best: Option<(f32, f32)> = None;
    let mut offer = |t: f32, v: f32| {
        if t > lo && t < hi && best.is_none_or(|(bt, _)| t < bt) {
            best = Some((t, v));
        }
    };
    if g > 0.0 {
        let qa = g * dd - ddp * ddp;
        let qb = 2.0 * (g * rel.dot(d) - ddp * y0);
        let qc = g * rel.length_squared() - odp * odp - r0 * r0 * dpdp - 2.0 * r0 * dr * odp;
        let disc = qb * qb - 4.0 * qa * qc;
        if disc >= 0.0 && qa.abs() > f32::MIN_POSITIVE {
            let t = (-qb - disc.sqrt()) / (2.0 * qa);
            let y = y_at(t);
            if y > -f32::EPSILON && y <= g {
                offer(t, (y / g).clamp(0.0, 1.0));
            }
        }
    }
    if let Some(t) = sphere_front(org, d, dd, b, r1) {
        let clipped_by_next = right.is_some_and(|next| {
            let h = org + t * d;
            (h - b).dot(next.xyz() - b) > -r1 * (next.w - r1)
        });
        if y_at(t) > g && !clipped_by_next {
            offer(t, 1.0);
        }
    }
    if !left {
        if let Some(t) = sphere_front(org, d, dd, a, r0) {
            if y_at(t) < 0.0 {
                offer(t, 0.0);
            }
        }
    }
    best.map(|(t, v)| (t + shift, v))
}

/// Where a ray enters a sphere (None if it misses).
fn sphere_front(o: Vec3, d: Vec3, dd: f32, centre: Vec3, r: f32) -> Option<f32> {
    let rel = o - centre;
    let b = rel.dot(d);
    let h = b * b - dd * (rel.length_squared() - r * r);
    (h >= 0.0).then(|| (-b - h.sqrt()) / dd)
}

/// Subdivision depth of a B-spline segment before Newton's method takes
/// over (32 pieces, each a good enough start).
const SWEEP_DEPTH: u32 = 5;

/// A swept-circle cubic segment, front faces only: subdivide the Bezier
/// curve while a piece's hull, widened by its largest radius, can reach the
/// ray; from each remaining piece, solve the two conditions of a surface
/// point (on the circle's plane, at the radius) for the curve parameter and
/// the distance by Newton's method.
fn intersect_swept_bezier(
    bezier: &[DVec4; 4],
    o: Vec3,
    d: Vec3,
    tmin: f32,
    tmax: f32,
) -> Option<(f32, f32)> {
    let len = d.as_dvec3().length();
    let dir = d.as_dvec3() / len;
    // Ray space: the ray along +z from the origin, distances in units of
    // |d| converted back at the end; centred near the segment.
    let mid = (bezier[0] + bezier[3]).xyz() * 0.5;
    let shift = (mid - o.as_dvec3()).dot(dir);
    let org = o.as_dvec3() + shift * dir;
    let (e1, e2) = {
        let f = Frame::from_normal(dir.as_vec3());
        (f.s.as_dvec3(), f.t.as_dvec3())
    };
    let to_ray = |p: DVec4| {
        let q = p.xyz() - org;
        DVec4::new(q.dot(e1), q.dot(e2), q.dot(dir), p.w)
    };
    let root = bezier.map(to_ray);
    let z_lo = tmin as f64 * len - shift;
    let z_hi = tmax as f64 * len - shift;
    let scale = root
        .iter()
        .fold(0.0f64, |m, p| m.max(p.xyz().abs().max_element() + p.w));
    let mut best: Option<(f64, f64)> = None;
    // Depth first: at most one waiting piece per level, plus the current.
    let mut stack = [([DVec4::ZERO; 4], 0.0f64, 0.0f64, 0u32); SWEEP_DEPTH as usize + 2];
    stack[0] = (root, 0.0, 1.0, 0);
    let mut waiting = 1;
    while waiting > 0 {
        waiting -= 1;
        let (b, v0, v1, depth) = stack[waiting];
        let r = b.iter().fold(0.0f64, |m, p| m.max(p.w));
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for p in &b {
            lo = lo.min(p.xyz());
            hi = hi.max(p.xyz());
        }
        let z_far = best.map_or(z_hi, |(z, _)| z);
        if lo.x - r > 0.0
            || hi.x + r < 0.0
            || lo.y - r > 0.0
            || hi.y + r < 0.0
            || lo.z - r > z_far
            || hi.z + r < z_lo
        {
            continue;
        }
        if depth < SWEEP_DEPTH {
            let (near, far) = split_bezier(&b);
            let vm = 0.5 * (v0 + v1);
            let (first, second) = ((near, v0, vm), (far, vm, v1));
            // The piece nearer along the ray is tried first.
            let near_first = first.0[0].z + first.0[3].z <= second.0[0].z + second.0[3].z;
            let (a, c) = if near_first {
                (first, second)
            } else {
                (second, first)
            };
            stack[waiting] = (c.0, c.1, c.2, depth + 1);
            stack[waiting + 1] = (a.0, a.1, a.2, depth + 1);
            waiting += 2;
            continue;
        }
        if let Some((z, v)) = newton_sweep(&root, v0, v1, z_lo, z_far, scale) {
            if best.is_none_or(|(bz, _)| z < bz) {
                best = Some((z, v));
            }
        }
    }
    best.map(|(z, v)| (((z + shift) / len) as f32, v as f32))
        .filter(|&(t, _)| t > tmin && t < tmax)
}

/// Splits a cubic Bezier curve at its middle (de Casteljau).
fn split_bezier(b: &[DVec4; 4]) -> ([DVec4; 4], [DVec4; 4]) {
    let ab = (b[0] + b[1]) * 0.5;
    let bc = (b[1] + b[2]) * 0.5;
    let cd = (b[2] + b[3]) * 0.5;
    let abc = (ab + bc) * 0.5;
    let bcd = (bc + cd) * 0.5;
    let m = (abc + bcd) * 0.5;
    ([b[0], ab, abc, m], [m, bcd, cd, b[3]])
}

/// A cubic Bezier curve (with its radius) and its first two derivatives.
fn bezier_eval(b: &[DVec4; 4], v: f64) -> (DVec4, DVec4, DVec4) {
    let s = 1.0 - v;
    let p = b[0] * (s * s * s)
        + b[1] * (3.0 * s * s * v)
        + b[2] * (3.0 * s * v * v)
        + b[3] * (v * v * v);
    let d = (b[1] - b[0]) * (3.0 * s * s)
        + (b[2] - b[1]) * (6.0 * s * v)
        + (b[3] - b[2]) * (3.0 * v * v);
    let dd = (b[2] - b[1] * 2.0 + b[0]) * (6.0 * s) + (b[3] - b[2] * 2.0 + b[1]) * (6.0 * v);
    (p, d, dd)
}

/// Newton's method on (v, z) for the point `(0, 0, z)` of the ray (in ray
/// space) that lies on the circle of the curve at `v`: in the plane
/// through `c(v)` orthogonal to `c'(v)` (f = 0), at distance `r(v)` from
/// `c(v)` (g = 0). Starts in the middle of [v0, v1], at the front of that
/// circle; accepts a front-facing root with v in [0, 1] and z in range.
fn newton_sweep(
    b: &[DVec4; 4],
    v0: f64,
    v1: f64,
    z_lo: f64,
    z_hi: f64,
    scale: f64,
) -> Option<(f64, f64)> {
    let mut v = 0.5 * (v0 + v1);
    let (c, _, _) = bezier_eval(b, v);
    let rho2 = c.x * c.x + c.y * c.y;
    let mut z = c.z - (c.w * c.w - rho2).max(0.0).sqrt();
    let tol = 1e-9 * scale.max(1e-30);
    for _ in 0..12 {
        let (c, dc, ddc) = bezier_eval(b, v);
        let q = DVec3::new(0.0, 0.0, z);
        let rr = q - c.xyz();
        let speed2 = dc.xyz().length_squared();
        if speed2 <= 0.0 {
            return None;
        }
        let speed = speed2.sqrt();
        let t_hat = dc.xyz() / speed;
        let dt_hat = (ddc.xyz() - t_hat * t_hat.dot(ddc.xyz())) / speed;
        let f = rr.dot(t_hat);
        let dfdv = -speed + rr.dot(dt_hat);
        let dfdz = t_hat.z;
        let k = (rr.length_squared() - f * f).max(0.0);
        let sk = k.sqrt();
        if sk <= 0.0 {
            return None;
        }
        let g = sk - c.w;
        let dgdv = (rr.dot(-dc.xyz()) - f * dfdv) / sk - dc.w;
        let dgdz = (rr.z - f * dfdz) / sk;
        let det = dfdv * dgdz - dfdz * dgdv;
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let dv = (f * dgdz - dfdz * g) / det;
        let dz = (dfdv * g - f * dgdv) / det;
        v -= dv;
        z -= dz;
        if !(v.is_finite() && z.is_finite()) {
            return None;
        }
        if f.abs() < tol && g.abs() < tol && dv.abs() < 1e-9 {
            break;
        }
    }
    if !(0.0..=1.0).contains(&v) || z <= z_lo || z >= z_hi {
        return None;
    }
    let (c, dc, ddc) = bezier_eval(b, v);
    let rr = DVec3::new(0.0, 0.0, z) - c.xyz();
    let f = rr.dot(dc.xyz().normalize());
    let g = (rr.length_squared() - f * f).max(0.0).sqrt() - c.w;
    if f.abs() > 1e-6 * scale || g.abs() > 1e-6 * scale {
        return None;
    }
    // Front faces only: the swept surface's normal against the ray (+z).
    let n = (dc.xyz().length_squared() - rr.dot(ddc.xyz())) * rr - (dc.w * c.w) * dc.xyz();
    (n.z < 0.0).then_some((z, v))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn curve(text: &str, basis: CurveBasis) -> Curve {
        Curve::parse(text, basis, &Transform::IDENTITY).unwrap()
    }

    fn first_hit(c: &Curve, o: Vec3, d: Vec3) -> Option<(f32, usize, f32)> {
        (0..c.segment_count())
            .filter_map(|s| {
                c.segment(s)
                    .intersect(o, d, 0.0, f32::INFINITY)
                    .map(|(t, v)| (t, s, v))
            })
            .min_by(|a, b| a.0.total_cmp(&b.0))
    }

    #[test]
    fn parses_curves_and_counts_segments() {
        let text = "0 0 0 0.1\n1 0 0 0.1\n2 0 0 0.1\n\n\n0 1 0 0.2\n1 1 0 0.2\n";
        assert_eq!(curve(text, CurveBasis::Linear).segment_count(), 3);
        let err = Curve::parse(text, CurveBasis::BSpline, &Transform::IDENTITY).unwrap_err();
        assert_eq!(
            err.to_string(),
            "line 1: this B-spline curve has 3 control points; it needs at least 4"
        );
        for (bad, want) in [
            ("0 0 0\n", "line 1: expected a control point"),
            (
                "0 0 0 0.1\n0 0 x 0.1\n",
                "line 2: 'x' is not a finite number",
            ),
            ("0 0 0 -1\n1 0 0 1\n", "line 1: the radius -1 is negative"),
            ("0 0 0 inf\n", "line 1: 'inf' is not a finite number"),
            ("\n \n", "no control points"),
        ] {
            let e = Curve::parse(bad, CurveBasis::Linear, &Transform::IDENTITY)
                .unwrap_err()
                .to_string();
            assert!(e.starts_with(want), "{bad:?}: {e}");
        }
    }

    /// Signed distance to a union of balls along the polyline (what a
    /// round linear curve is): min over the centre line of |p - c| - r.
    fn capsule_chain_distance(c: &Curve, p: Vec3) -> f32 {
        let mut best = f32::INFINITY;
        for s in 0..c.segment_count() {
            let cp = c.control(s);
            for i in 0..=2000 {
                let v = i as f32 / 2000.0;
                let q = cp[0].lerp(cp[1], v);
                best = best.min((p - q.xyz()).length() - q.w);
            }
        }
        best
    }

    #[test]
    fn linear_hits_lie_on_the_union_of_balls_and_nothing_is_missed() {
        // A bent polyline with growing radii: cones, joints and end caps.
        let c = curve(
            "0 0 0 0.2\n1 0 0 0.3\n1.5 0.8 0 0.15\n1.5 1.5 0.4 0.25\n",
            CurveBasis::Linear,
        );
        let mut rng = crate::sampling::Sampler::new(7, 1);
        let (mut hits, mut misses) = (0, 0);
        for _ in 0..400 {
            let target = Vec3::new(
                -0.5 + 2.5 * rng.next_1d(),
                -0.5 + 2.5 * rng.next_1d(),
                -0.5 + 1.5 * rng.next_1d(),
            );
            let dir = crate::sampling::warp::square_to_uniform_sphere(rng.next_2d());
            let o = target - 5.0 * dir;
            let found = first_hit(&c, o, dir);
            // March the distance field: a sphere-traced reference.
            let mut t = 0.0f32;
            let mut reference = None;
            while t < 10.0 {
                let dist = capsule_chain_distance(&c, o + t * dir);
                if dist < 1e-4 {
                    reference = Some(t);
                    break;
                }
                t += dist.max(1e-4);
            }
            match (found, reference) {
                (Some((t, _, _)), Some(rt)) => {
                    hits += 1;
                    assert!((t - rt).abs() < 2e-3, "hit at {t}, reference {rt}");
                }
                (None, None) => misses += 1,
                (f, r) => {
                    // Only grazing rays may disagree: the closest approach
                    // is within the reference's own tolerance.
                    let closest = (0..4000)
                        .map(|i| capsule_chain_distance(&c, o + (i as f32 / 400.0) * dir))
                        .fold(f32::INFINITY, f32::min);
                    assert!(closest.abs() < 2e-3, "{f:?} vs {r:?}, closest {closest}");
                }
            }
        }
        assert!(hits > 50 && misses > 50, "{hits} hits, {misses} misses");
    }

    #[test]
    fn rays_from_inside_a_tube_see_nothing_of_it() {
        for basis in [CurveBasis::Linear, CurveBasis::BSpline] {
            let c = curve(
                "-2 0 0 0.5\n-1 0 0 0.5\n0 0 0 0.5\n1 0 0 0.5\n2 0 0 0.5\n",
                basis,
            );
            assert!(first_hit(&c, Vec3::ZERO, Vec3::Y).is_none(), "{basis:?}");
            let (t, _, _) = first_hit(&c, Vec3::new(0.0, 3.0, 0.0), -Vec3::Y).unwrap();
            assert!((t - 2.5).abs() < 1e-4, "{basis:?}: {t}");
        }
    }

    /// Whether `q` is inside the swept tube (brute force over v): the
    /// segment and parameter of a circle whose plane holds it and whose
    /// centre is nearer than the radius.
    fn inside_sweep(c: &Curve, q: Vec3) -> Option<(usize, f32)> {
        (0..c.segment_count()).find_map(|s| {
            let n = 200;
            let plane = |v: f32| {
                let cl = c.centre_line(s, v);
                ((q - cl.c).dot(cl.dc), (q - cl.c).length() < cl.r)
            };
            let mut prev = plane(0.0);
            (1..=n).find_map(|i| {
                let cur = plane(i as f32 / n as f32);
                let crossed = prev.0.signum() != cur.0.signum();
                let inside = crossed && (prev.1 || cur.1);
                prev = cur;
                inside.then_some((s, i as f32 / n as f32))
            })
        })
    }

    #[test]
    fn bspline_hits_are_on_the_swept_circles_and_match_a_brute_force_march() {
        let c = curve(
            "-1 0 -0.5 0.1\n-0.5 0.3 0.5 0.12\n0 0 -0.5 0.15\n0.5 -0.3 0.5 0.12\n1 0 -0.5 0.1\n1.5 0.2 0.3 0.1\n",
            CurveBasis::BSpline,
        );
        let mut rng = crate::sampling::Sampler::new(11, 1);
        let (mut hits, mut misses, mut grazing, mut ends) = (0, 0, 0, 0);
        for _ in 0..200 {
            let target = Vec3::new(
                -0.6 + 1.8 * rng.next_1d(),
                -0.4 + 0.8 * rng.next_1d(),
                -0.6 + 1.2 * rng.next_1d(),
            );
            let dir = crate::sampling::warp::square_to_uniform_sphere(rng.next_2d());
            let o = target - 3.0 * dir;
            let found = first_hit(&c, o, dir);
            if let Some((t, s, v)) = found {
                // On the circle at v: in its plane, at its radius.
                let cl = c.centre_line(s, v);
                let r = o + t * dir - cl.c;
                assert!(r.dot(cl.dc.normalize()).abs() < 1e-3, "off the plane");
                assert!((r.length() - cl.r).abs() < 1e-3, "off the radius");
            }
            let step = 2e-3;
            let reference = (0..3000)
                .map(|i| i as f32 * step)
                .find_map(|t| inside_sweep(&c, o + t * dir).map(|(s, v)| (t, s, v)));
            // A ray that enters through an open end meets no surface there.
            let last = c.segment_count() - 1;
            let through_end = |(t, _, _): (f32, usize, f32)| {
                let q = o + t * dir;
                [(0, 0.0), (last, 1.0)].iter().any(|&(s, v)| {
                    let cl = c.centre_line(s, v);
                    let off = q - cl.c;
                    off.dot(cl.dc.normalize()).abs() < 0.01 && off.length() < cl.r + 0.01
                })
            };
            let reference = match reference {
                Some(r) if through_end(r) => {
                    ends += 1;
                    continue;
                }
                r => r.map(|r| r.0),
            };
            match (found, reference) {
                (Some((t, _, _)), Some(rt)) => {
                    hits += 1;
                    assert!((t - rt).abs() < 3.0 * step, "hit at {t}, reference {rt}");
                }
                (None, None) => misses += 1,
                (f, r) => {
                    // Grazing: the two agree a step beside the ray.
                    grazing += 1;
                    assert!(grazing <= 3, "{f:?} vs {r:?} ({grazing} disagreements)");
                }
            }
        }
        eprintln!("{hits} hits, {misses} misses, {grazing} grazing, {ends} through the ends");
        assert!(
            hits > 40 && misses > 40 && ends < 30,
            "{hits} hits, {misses} misses, {ends} through the ends"
        );
    }

    #[test]
    fn normals_face_out_and_uv_follow_mitsuba() {
        let c = curve("0 0 -1 0.5\n0 0 1 0.5\n", CurveBasis::Linear);
        let ray = Ray::new(Vec3::new(3.0, 0.0, 0.25), -Vec3::X);
        let (t, s, v) = first_hit(&c, ray.o, ray.d).unwrap();
        let hit = BvhHit {
            t,
            shape: 0,
            index: s as u32,
            b1: v,
            b2: 0.0,
            instance: BvhHit::NO_INSTANCE,
        };
        let mut its = Intersection::UNSET;
        c.intersection_into(&ray, &hit, &mut its);
        assert!((its.ng - Vec3::X).length() < 1e-5, "{:?}", its.ng);
        // Tangent +z is parallel to the guide: rot = y, rad = y x z = x.
        assert!(its.uv.x.abs() < 1e-5 || (its.uv.x - 1.0).abs() < 1e-5);
        assert!((its.uv.y - 0.625).abs() < 1e-5, "{}", its.uv.y);
        let (dpdu, dpdv) = c.dpdu_dpdv(&its);
        assert!((dpdu - Vec3::new(0.0, PI, 0.0)).length() < 1e-4, "{dpdu:?}");
        assert!(
            (dpdv - Vec3::new(0.0, 0.0, 2.0)).length() < 1e-4,
            "{dpdv:?}"
        );
    }
}
