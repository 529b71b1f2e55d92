//! Area lights: uniform emission from the front side of a shape (the side
//! its shading normal faces). Spheres seen from outside are sampled by the
//! cone they subtend. Meshes pick a triangle by area, then sample the solid
//! angle it subtends (spherical-triangle sampling) where that is neither
//! tiny nor near a hemisphere, its area elsewhere; points inside a sphere
//! sample its area. The radiance may be a texture read at the point's uv
//! (it is not importance-sampled: the density is the geometry's).

use std::borrow::Cow;

use super::light_triangle::LightTriangle;
use super::{EmitterContext, EmitterError, LightHit, LightSample};
use crate::color::{luminance, Rgb};
use crate::geometry::{Geometry, SurfaceSample, TriangleMesh};
use crate::math::{Vec2, Vec3, PI};
use crate::sampling::spherical_triangle::{self, MAX_SOLID_ANGLE, MIN_SOLID_ANGLE};
use crate::texture::{SurfacePoint, Texture};

/// The solid angle triangle `t` subtends from `p_ref` and the unit
/// directions to its vertices, if it is sampled by solid angle from there
/// (see [`spherical_triangle::MIN_SOLID_ANGLE`]).
fn spherical(t: &LightTriangle, p_ref: Vec3) -> Option<([Vec3; 3], f32)> {
    // Cheap first: where the projected area over the cubed centroid
    // distance is far below the threshold, area sampling without any
    // trigonometry. (It underestimates for points close to the plane near
    // a vertex; those are then sampled by area: more variance, no bias,
    // since sample and pdf decide alike.)
    let to_c = t.centroid - p_ref;
    let d2 = to_c.length_squared();
    let projected = 0.5 * t.cross.dot(to_c).abs();
    if projected < 0.25 * MIN_SOLID_ANGLE * d2 * d2.sqrt() {
        return None;
    }
    let dirs = t.v.map(|v| (v - p_ref).normalize_or_zero());
    let omega = spherical_triangle::solid_angle(dirs[0], dirs[1], dirs[2]);
    ((MIN_SOLID_ANGLE..=MAX_SOLID_ANGLE).contains(&omega)).then_some((dirs, omega))
}

/// The largest emitting mesh whose triangles an area light tabulates
/// (76 bytes each: at most 80 MB); larger ones are sampled from the mesh,
/// with the same results, rather than doubling their memory.
pub const MAX_TABULATED_TRIANGLES: usize = 1 << 20;

#[derive(Clone, Debug, PartialEq)]
pub struct AreaLight {
    /// Index of the shape in the scene.
    pub shape: u32,
    /// The radiance, or a textured radiance's mean (for the light's power).
    pub radiance: Rgb,
    /// Radiance varying over the surface, read at the point's uv (Mitsuba's
    /// `radiance` texture).
    pub texture: Option<Texture>,
    /// Its mesh's triangles as light samples read them
    /// ([`AreaLight::with_triangles`]; empty: computed at each sample).
    triangles: Box<[LightTriangle]>,
}

impl AreaLight {
    /// `radiance`: finite and not negative.
    pub fn new(shape: u32, radiance: Rgb) -> Result<AreaLight, EmitterError> {
        Ok(AreaLight {
            shape,
            radiance: super::radiance(radiance)?,
            texture: None,
            triangles: Box::default(),
        })
    }

    /// Radiance from a texture (its mean finite and not negative).
    pub fn textured(shape: u32, texture: Texture) -> Result<AreaLight, EmitterError> {
        Ok(AreaLight {
            shape,
            radiance: super::radiance(texture.mean())?,
            texture: Some(texture),
            triangles: Box::default(),
        })
    }

    /// The light with its shape's triangles tabulated for light sampling,
    /// when the shape is a mesh of at most `MAX_TABULATED_TRIANGLES`
    /// (the scene's lights are built so; samples and densities are the
    /// same bits either way, only faster).
    pub fn with_triangles(mut self, shape: &Geometry) -> AreaLight {
        match shape {
            Geometry::Mesh(m) if m.triangle_count() <= MAX_TABULATED_TRIANGLES => {
                self.triangles = LightTriangle::table(m);
            }
            _ => {}
        }
        self
    }

    /// Triangle `tri` of the light's mesh from its table, if the light
    /// has one and radiates a constant radiance: what
    /// [`sample_triangles_lanes`](super::area_lanes::sample_triangles_lanes)
    /// samples in lanes.
    #[inline]
    pub(crate) fn constant_table_triangle(&self, tri: usize) -> Option<&LightTriangle> {
        self.samples_in_lanes()
            .then(|| self.triangles.get(tri))
            .flatten()
    }

    /// Whether the light is a tabulated mesh of constant radiance: what
    /// the batch samples four at a time
    /// ([`sample_triangles_lanes`](super::sample_triangles_lanes)).
    #[inline]
    pub fn samples_in_lanes(&self) -> bool {
        self.texture.is_none() && !self.triangles.is_empty()
    }

    /// Triangle `tri` of the light's mesh `m`, from the table or computed.
    #[inline]
    fn triangle(&self, m: &TriangleMesh, tri: usize) -> Cow<'_, LightTriangle> {
        match self.triangles.get(tri) {
            Some(t) => Cow::Borrowed(t),
            None => Cow::Owned(LightTriangle::of(m, tri)),
        }
    }

    /// The radiance leaving the front side at a surface point.
    #[inline]
    pub fn radiance_at(&self, at: impl Into<SurfacePoint>) -> Rgb {
        match &self.texture {
            None => self.radiance,
            Some(t) => t.eval(at),
        }
    }

    /// [`AreaLight::radiance_at`] a sampled point (its uv found only for a
    /// texture). Inlined for a constant radiance: a call returned it
    /// through the stack, where the caller's 8-byte load across the
    /// callee's two stores waited for them (half of a sphere light's
    /// sample in `perf`).
    #[inline]
    fn radiance_of(&self, ctx: &EmitterContext, s: &SurfaceSample) -> Rgb {
        match &self.texture {
            None => self.radiance,
            Some(t) => self.textured_radiance_of(ctx, s, t),
        }
    }

    /// [`AreaLight::radiance_of`] with the texture `t`.
    #[inline(never)]
    fn textured_radiance_of(&self, ctx: &EmitterContext, s: &SurfaceSample, t: &Texture) -> Rgb {
        let uv = match &ctx.shapes[self.shape as usize] {
            Geometry::Mesh(m) => m.shading(s.prim as usize, s.bary.x, s.bary.y).1,
            Geometry::Sphere(sp) => sp.normal_uv(s.p).1,
            Geometry::Disk(d) => d.uv_at(s.p),
            Geometry::Rectangle(r) => r.uv_at(s.p),
            // Curves emit nothing (the scene refuses an area light on one).
            Geometry::Curve(_) => Vec2::ZERO,
        };
        t.eval(SurfacePoint {
            uv,
            prim: s.prim,
            bary: s.bary,
            ..Default::default()
        })
    }

    pub fn power(&self, ctx: &EmitterContext) -> f32 {
        PI * ctx.shapes[self.shape as usize].area() * luminance(self.radiance)
    }

    pub fn sample(
        &self,
        ctx: &EmitterContext,
        p_ref: Vec3,
        u: Vec2,
        u1: f32,
    ) -> Option<LightSample> {
        let mut out = None;
        self.sample_into(ctx, p_ref, u, u1, &mut out);
        out
    }

    /// [`AreaLight::sample`] stored into `out` field by field, where the
    /// caller keeps it (a batch's light samples: returned by value, each
    /// was copied in wide loads that waited on the stores just made).
    pub fn sample_into(
        &self,
        ctx: &EmitterContext,
        p_ref: Vec3,
        u: Vec2,
        u1: f32,
        out: &mut Option<LightSample>,
    ) {
        let s = match &ctx.shapes[self.shape as usize] {
            Geometry::Mesh(m) => {
                let (tri, p_tri) = m.choose_triangle(u1);
                let t = self.triangle(m, tri);
                if let Some((dirs, omega)) = spherical(&t, p_ref) {
                    let pdf = p_tri / omega;
                    return self.sample_spherical(ctx, m, (tri, &t), p_ref, (dirs, pdf), u, out);
                }
                let b = crate::sampling::warp::square_to_uniform_triangle(u);
                t.surface_point(m, tri, b.x, b.y)
            }
            Geometry::Sphere(sp) => match sp.visible_cone(p_ref) {
                // Outside the sphere: sample the cone it subtends.
                Some(cone) => {
                    let (s, pdf) = sp.sample_cone(&cone, u);
                    let to = s.p - p_ref;
                    let dist = to.length();
                    return self.set_light_sample(ctx, &s, to / dist, dist, pdf, out);
                }
                None => sp.sample_area(u),
            },
            Geometry::Disk(d) => d.sample_area(u),
            Geometry::Rectangle(r) => r.sample_area(u),
            Geometry::Curve(_) => return *out = None,
        };
        let to = s.p - p_ref;
        let d2 = to.length_squared();
        if d2 <= 0.0 {
            return *out = None;
        }
        let dist = d2.sqrt();
        let wi = to / dist;
        let cos_l = -wi.dot(s.n);
        if cos_l <= 0.0 {
            return *out = None;
        }
        self.set_light_sample(ctx, &s, wi, dist, s.pdf_area * d2 / cos_l, out);
    }

    /// The light sample reaching the point `s` along the unit `wi` at
    /// distance `dist`, with solid-angle density `pdf`, stored into `out`.
    #[inline]
    pub(crate) fn set_light_sample(
        &self,
        ctx: &EmitterContext,
        s: &SurfaceSample,
        wi: Vec3,
        dist: f32,
        pdf: f32,
        out: &mut Option<LightSample>,
    ) {
        *out = Some(LightSample {
            wi,
            p: s.p,
            err: s.err,
            n: s.n,
            dist,
            weight: self.radiance_of(ctx, s) / pdf,
            pdf,
            delta: false,
        });
    }

    /// A direction uniform over the solid angle of triangle `tri` (unit
    /// vertex directions `dirs` from `p_ref`), the point it reaches, and
    /// the solid-angle density `pdf` (triangle choice included), into
    /// `out`.
    #[allow(clippy::too_many_arguments)]
    fn sample_spherical(
        &self,
        ctx: &EmitterContext,
        m: &TriangleMesh,
        (tri, t): (usize, &LightTriangle),
        p_ref: Vec3,
        (dirs, pdf): ([Vec3; 3], f32),
        u: Vec2,
        out: &mut Option<LightSample>,
    ) {
        *out = None;
        let Some(d) = spherical_triangle::sample(dirs[0], dirs[1], dirs[2], u) else {
            return;
        };
        let Some((b1, b2)) = m.barycentrics_along(tri, p_ref, d) else {
            return;
        };
        let s = t.surface_point(m, tri, b1, b2);
        let to = s.p - p_ref;
        let dist = to.length();
        // The emitting side faces p_ref, or nothing arrives.
        if dist <= 0.0 || to.dot(s.n) >= 0.0 || !(pdf > 0.0 && pdf.is_finite()) {
            return;
        }
        self.set_light_sample(ctx, &s, to / dist, dist, pdf, out);
    }

    /// Solid-angle density of [`AreaLight::sample`] from `p_ref` reaching
    /// the light point `at` in direction `wi`.
    pub fn pdf(&self, ctx: &EmitterContext, p_ref: Vec3, wi: Vec3, at: &LightHit) -> f32 {
        let g = &ctx.shapes[self.shape as usize];
        let cos_l = (-wi).dot(at.n);
        match g {
            Geometry::Sphere(sp) => {
                if let Some(cone) = sp.visible_cone(p_ref) {
                    return cone.pdf();
                }
            }
            Geometry::Mesh(m) => {
                let tri = at.prim as usize;
                if tri < m.triangle_count() {
                    if let Some((_, omega)) = spherical(&self.triangle(m, tri), p_ref) {
                        return if cos_l > 0.0 {
                            m.triangle_probability(tri) / omega
                        } else {
                            0.0
                        };
                    }
                }
            }
            Geometry::Disk(_) | Geometry::Rectangle(_) => {}
            Geometry::Curve(_) => return 0.0,
        }
        let area = g.area();
        let d2 = (at.p - p_ref).length_squared();
        if cos_l <= 0.0 || area <= 0.0 {
            return 0.0;
        }
        d2 / (cos_l * area)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::spherical_triangle::subdivide;
    use crate::stats::sidak;

    /// A downward-facing unit quad at z = 1 (two triangles), a tilted
    /// triangle beside it and a tiny one (solid angle below
    /// MIN_SOLID_ANGLE from everywhere here: sampled by area).
    fn light_mesh() -> TriangleMesh {
        let p = vec![
            Vec3::new(-0.5, -0.5, 1.0),
            Vec3::new(0.5, -0.5, 1.0),
            Vec3::new(0.5, 0.5, 1.0),
            Vec3::new(-0.5, 0.5, 1.0),
            Vec3::new(0.8, -0.5, 0.6),
            Vec3::new(1.6, 0.0, 1.2),
            Vec3::new(0.8, 0.6, 0.9),
            Vec3::new(-0.9, 0.0, 0.8),
            Vec3::new(-0.9, 0.004, 0.8),
            Vec3::new(-0.904, 0.0, 0.8),
        ];
        let idx = vec![[0, 2, 1], [0, 3, 2], [4, 6, 5], [7, 9, 8]];
        TriangleMesh::new(p, vec![], vec![], idx).unwrap()
    }

    fn hit(s: crate::geometry::SurfaceSample, tri: usize) -> LightHit {
        LightHit {
            p: s.p,
            n: s.n,
            prim: tri as u32,
        }
    }

    /// Every triangle of `m` the ray from `o` along `d` meets, with its
    /// barycentrics (Moller-Trumbore, f64).
    fn hits(m: &TriangleMesh, o: Vec3, d: Vec3) -> Vec<(usize, f32, f32)> {
        let mut out = Vec::new();
        for tri in 0..m.triangle_count() {
            let [a, b, c] = m.vertices(tri).map(|v| v.as_dvec3());
            let (o, d) = (o.as_dvec3(), d.as_dvec3());
            let (e1, e2) = (b - a, c - a);
            let pv = d.cross(e2);
            let det = e1.dot(pv);
            if det.abs() < 1e-12 {
                continue;
            }
            let tv = o - a;
            let b1 = tv.dot(pv) / det;
            let qv = tv.cross(e1);
            let b2 = d.dot(qv) / det;
            let t = e2.dot(qv) / det;
            if b1 >= 0.0 && b2 >= 0.0 && b1 + b2 <= 1.0 && t > 0.0 {
                out.push((tri, b1 as f32, b2 as f32));
            }
        }
        out
    }

    /// Index of the sub-triangle of `subdivide(n)` holding (b1, b2).
    fn sub_index(n: usize, b1: f32, b2: f32) -> usize {
        let (x, y) = (b1 * n as f32, b2 * n as f32);
        let (i, j) = ((x as usize).min(n - 1), (y as usize).min(n - 1));
        let (i, j) = if i + j > n - 1 {
            (n - 1 - j, j)
        } else {
            (i, j)
        };
        let upper = (x - i as f32) + (y - j as f32) > 1.0 && i + j + 1 < n;
        // Position of (i, j) in subdivide's order.
        let mut k = 0;
        for ii in 0..i {
            k += 2 * (n - ii) - 1;
        }
        k + 2 * j + usize::from(upper)
    }

    /// Meshes beyond the table's limit are left to the per-sample path
    /// (whose results the test below checks are the same), and a table
    /// entry is the 76 bytes the limit's memory bound assumes.
    #[test]
    fn only_meshes_up_to_the_limit_are_tabulated() {
        assert_eq!(std::mem::size_of::<LightTriangle>(), 76);
        let p = vec![Vec3::ZERO, Vec3::X, Vec3::Y];
        for (n, tabulated) in [(3, true), (MAX_TABULATED_TRIANGLES + 1, false)] {
            let mesh = TriangleMesh::new(p.clone(), vec![], vec![], vec![[0, 1, 2]; n]).unwrap();
            let light = AreaLight::new(0, Rgb::ONE)
                .unwrap()
                .with_triangles(&Geometry::Mesh(mesh));
            assert_eq!(light.triangles.len(), if tabulated { n } else { 0 });
        }
    }

    /// A light with its triangles tabulated (as the scene builds it) takes
    /// the same samples, bit for bit, with the same densities as one that
    /// computes them from the mesh, for flat and smoothly shaded meshes,
    /// by solid angle (near) and by area (far).
    #[test]
    fn tabulated_triangles_sample_the_same() {
        let mut smooth = light_mesh();
        smooth.compute_vertex_normals();
        let mut s = crate::sampling::Sampler::for_pixel_sample(11, 0, 0, 0);
        let mut spherical_seen = 0;
        for mesh in [light_mesh(), smooth] {
            let shapes = [Geometry::Mesh(mesh)];
            let ctx = EmitterContext {
                shapes: &shapes,
                scene_radius: 10.0,
            };
            let plain = AreaLight::new(0, Rgb::ONE).unwrap();
            let tabulated = plain.clone().with_triangles(&shapes[0]);
            assert!(!tabulated.triangles.is_empty() && plain.triangles.is_empty());
            for i in 0..4000 {
                let scale = if i % 2 == 0 { 1.0 } else { 30.0 };
                let p_ref = (Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) - 0.5) * scale;
                let (u, u1) = (Vec2::new(s.next_1d(), s.next_1d()), s.next_1d());
                let a = plain.sample(&ctx, p_ref, u, u1);
                let b = tabulated.sample(&ctx, p_ref, u, u1);
                assert_eq!(format!("{a:?}"), format!("{b:?}"), "from {p_ref}");
                if let Some(ls) = a {
                    let Geometry::Mesh(m) = &shapes[0] else {
                        unreachable!()
                    };
                    let tri = m.choose_triangle(u1).0;
                    spherical_seen +=
                        usize::from(spherical(&LightTriangle::of(m, tri), p_ref).is_some());
                    let at = LightHit {
                        p: ls.p,
                        n: ls.n,
                        prim: tri as u32,
                    };
                    let (pa, pb) = (
                        plain.pdf(&ctx, p_ref, ls.wi, &at),
                        tabulated.pdf(&ctx, p_ref, ls.wi, &at),
                    );
                    assert_eq!(pa.to_bits(), pb.to_bits());
                }
            }
        }
        assert!(spherical_seen > 500, "{spherical_seen} solid-angle samples");
    }

    /// Samples land on the light with the density `pdf` reports for their
    /// point, and pass a chi-square test against `pdf` integrated over the
    /// solid angle of sub-triangles of each triangle (bins that follow
    /// the light's edges: no cut cells), from points close to the light
    /// (spherical sampling), far (area sampling of the tiny triangle) and
    /// beside it.
    #[test]
    fn mesh_light_sample_matches_pdf() {
        let shapes = [Geometry::Mesh(light_mesh())];
        let ctx = EmitterContext {
            shapes: &shapes,
            scene_radius: 10.0,
        };
        let Geometry::Mesh(m) = &shapes[0] else {
            unreachable!()
        };
        let light = AreaLight::new(0, Rgb::ONE).unwrap();
        let points = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(0.2, 0.1, 0.85),
            Vec3::new(-0.5, 0.3, -2.0),
            Vec3::new(3.0, 1.0, 1.0),
        ];
        let (bins, fine) = (4, 8);
        let subs = subdivide(bins);
        let alpha = sidak(0.01, points.len());
        let mut sampler = crate::sampling::Sampler::new(5, 9);
        for &p in &points {
            // Expected: pdf at the centre of each fine sub-triangle times
            // its solid angle, summed per bin.
            let mut expected = vec![0.0f64; m.triangle_count() * subs.len()];
            for tri in 0..m.triangle_count() {
                for (k, sub) in subs.iter().enumerate() {
                    for f in subdivide(fine) {
                        let bary = f.map(|(x, y)| {
                            let (a, b, c) = (sub[0], sub[1], sub[2]);
                            (
                                a.0 + x * (b.0 - a.0) + y * (c.0 - a.0),
                                a.1 + x * (b.1 - a.1) + y * (c.1 - a.1),
                            )
                        });
                        let pts = bary.map(|(b1, b2)| m.surface_point(tri, b1, b2).p);
                        let dirs = pts.map(|q| (q - p).normalize());
                        let omega = spherical_triangle::solid_angle(dirs[0], dirs[1], dirs[2]);
                        let (c1, c2) = (
                            (bary[0].0 + bary[1].0 + bary[2].0) / 3.0,
                            (bary[0].1 + bary[1].1 + bary[2].1) / 3.0,
                        );
                        let s = m.surface_point(tri, c1, c2);
                        let d = (s.p - p).normalize();
                        let q = light.pdf(&ctx, p, d, &hit(s, tri)) as f64;
                        expected[tri * subs.len() + k] += q * omega as f64;
                    }
                }
            }
            let n = 100_000;
            let mut observed = vec![0.0f64; expected.len()];
            let mut mismatches = 0;
            for _ in 0..n {
                let u1 = sampler.next_1d();
                let Some(ls) = light.sample(&ctx, p, sampler.next_2d(), u1) else {
                    continue;
                };
                // The triangle the point lies on, and where.
                let (tri, b1, b2) = hits(m, p, ls.wi)
                    .into_iter()
                    .min_by(|a, b| {
                        let da = (m.surface_point(a.0, a.1, a.2).p - ls.p).length();
                        let db = (m.surface_point(b.0, b.1, b.2).p - ls.p).length();
                        da.total_cmp(&db)
                    })
                    .expect("the sample lies on the light");
                let s = m.surface_point(tri, b1, b2);
                let q = light.pdf(&ctx, p, ls.wi, &hit(s, tri));
                if (q - ls.pdf).abs() > 1e-3 * q.max(1e-3) {
                    mismatches += 1;
                }
                observed[tri * subs.len() + sub_index(bins, b1, b2)] += 1.0;
            }
            assert!(
                mismatches <= n / 1000,
                "point {p}: {mismatches} pdf mismatches"
            );
            let expected: Vec<f64> = expected.iter().map(|e| e * n as f64).collect();
            let r = crate::stats::chi2_test(&observed, &expected, 5.0);
            assert!(r.passes(alpha), "point {p}: {r:?}");
        }
    }

    #[test]
    fn sub_index_inverts_subdivide() {
        let n = 5;
        for (k, s) in subdivide(n).iter().enumerate() {
            let c = (
                (s[0].0 + s[1].0 + s[2].0) / 3.0,
                (s[0].1 + s[1].1 + s[2].1) / 3.0,
            );
            assert_eq!(sub_index(n, c.0, c.1), k);
        }
    }
}
