//! Indexed triangle meshes.

use crate::math::{Aabb, Frame, Transform, Vec2, Vec3};
use crate::sampling::Distribution1D;

use super::{BvhHit, Intersection, SurfaceSample};

/// A triangle mesh in world space. Built only by [`TriangleMesh::new`]
/// and changed only by its methods, which keep its invariants: at least
/// one face, every index in range, `normals` and `uvs` per vertex (or
/// empty), finite positions whose bounds fit the float range, a positive
/// finite area.
#[derive(Clone, Debug)]
pub struct TriangleMesh {
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    uvs: Vec<Vec2>,
    indices: Vec<[u32; 3]>,
    /// Area-weighted triangle choice.
    area_distribution: Distribution1D,
    area: f32,
}

/// A mesh that breaks an invariant of [`TriangleMesh`]. Each message
/// completes a sentence that starts with "the mesh".
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum MeshError {
    #[error("has no faces")]
    NoFaces,
    #[error("has {found} normals for {vertices} vertices")]
    NormalCount { found: usize, vertices: usize },
    #[error("has {found} texture coordinates for {vertices} vertices")]
    UvCount { found: usize, vertices: usize },
    #[error("has face {face} with vertex index {index}, but only {vertices} vertices")]
    IndexOutOfRange {
        face: usize,
        index: u32,
        vertices: usize,
    },
    #[error("has vertex {0} at a position that is not finite")]
    NotFinite(usize),
    #[error(
        "has vertex {index} at ({:e}, {:e}, {:e}), beyond +-{:e}, the coordinate range lente supports",
        position.x, position.y, position.z, crate::limits::MAX_COORDINATE
    )]
    OutOfRange { index: usize, position: Vec3 },
    #[error("has no area")]
    NoArea,
}

impl TriangleMesh {
    /// A mesh of `positions` and triangles `indices`, with per-vertex
    /// `normals` and `uvs` (each empty or one per position).
    pub fn new(
        positions: Vec<Vec3>,
        normals: Vec<Vec3>,
        uvs: Vec<Vec2>,
        indices: Vec<[u32; 3]>,
    ) -> Result<TriangleMesh, MeshError> {
        let vertices = positions.len();
        if !normals.is_empty() && normals.len() != vertices {
            return Err(MeshError::NormalCount {
                found: normals.len(),
                vertices,
            });
        }
        if !uvs.is_empty() && uvs.len() != vertices {
            return Err(MeshError::UvCount {
                found: uvs.len(),
                vertices,
            });
        }
        for (face, tri) in indices.iter().enumerate() {
            if let Some(&index) = tri.iter().find(|&&i| i as usize >= vertices) {
                return Err(MeshError::IndexOutOfRange {
                    face,
                    index,
                    vertices,
                });
            }
        }
        let mut m = TriangleMesh {
            positions,
            normals,
            uvs,
            indices,
            area_distribution: Distribution1D::new(&[1.0]),
            area: 0.0,
        };
        m.finish()?;
        Ok(m)
    }

    /// Checks the geometry and rebuilds the area table (after
    /// construction or a change of the positions).
    fn finish(&mut self) -> Result<(), MeshError> {
        if self.indices.is_empty() {
            return Err(MeshError::NoFaces);
        }
        if let Some(i) = self.positions.iter().position(|p| !p.is_finite()) {
            return Err(MeshError::NotFinite(i));
        }
        // Coordinates near f32::MAX are finite, but their differences (edge
        // vectors, box extents) and the BVH's surface-area costs are not.
        let max = crate::limits::MAX_COORDINATE;
        if let Some(index) = self
            .positions
            .iter()
            .position(|p| p.abs().max_element() > max)
        {
            return Err(MeshError::OutOfRange {
                index,
                position: self.positions[index],
            });
        }
        let areas: Vec<f32> = (0..self.indices.len())
            .map(|i| self.triangle_area(i))
            .collect();
        self.area = areas.iter().map(|&a| a as f64).sum::<f64>() as f32;
        if !(self.area > 0.0 && self.area.is_finite()) {
            return Err(MeshError::NoArea);
        }
        self.area_distribution = Distribution1D::new(&areas);
        Ok(())
    }

    pub fn positions(&self) -> &[Vec3] {
        &self.positions
    }

    /// Per-vertex shading normals (empty: the geometric normal is used).
    pub fn normals(&self) -> &[Vec3] {
        &self.normals
    }

    /// Per-vertex texture coordinates (empty: barycentrics are used).
    pub fn uvs(&self) -> &[Vec2] {
        &self.uvs
    }

    pub fn indices(&self) -> &[[u32; 3]] {
        &self.indices
    }

    pub fn triangle_count(&self) -> usize {
        self.indices.len()
    }

    pub fn vertices(&self, tri: usize) -> [Vec3; 3] {
        let [a, b, c] = self.indices[tri];
        [
            self.positions[a as usize],
            self.positions[b as usize],
            self.positions[c as usize],
        ]
    }

    /// In f64: the squared length of the cross product overflows f32 for
    /// edges beyond ~4e9, well inside the accepted coordinate range.
    pub fn triangle_area(&self, tri: usize) -> f32 {
        let [a, b, c] = self.vertices(tri);
        (0.5 * (b - a).as_dvec3().cross((c - a).as_dvec3()).length()) as f32
    }

    pub fn area(&self) -> f32 {
        self.area
    }

    pub fn bounds(&self) -> Aabb {
        self.positions.iter().fold(Aabb::EMPTY, |b, &p| b.extend(p))
    }

    pub fn triangle_bounds(&self, tri: usize) -> Aabb {
        let [a, b, c] = self.vertices(tri);
        Aabb::EMPTY.extend(a).extend(b).extend(c)
    }

    /// Bakes a transform into the vertices (normals by the inverse
    /// transpose). A mirroring transform also reverses the winding, so the
    /// geometric normal keeps agreeing with the shading normals (Nori).
    pub fn transform(&mut self, t: &Transform) -> Result<(), MeshError> {
        self.transform_keep_winding(t)?;
        if t.flips_handedness() {
            for tri in &mut self.indices {
                tri.swap(1, 2);
            }
        }
        Ok(())
    }

    /// Bakes a transform into the vertices keeping the winding, Mitsuba's
    /// way: the geometric normal is the cross product of the transformed
    /// edges (so a mirror turns it around), vertex normals go through the
    /// inverse transpose.
    pub fn transform_keep_winding(&mut self, t: &Transform) -> Result<(), MeshError> {
        for p in &mut self.positions {
            *p = t.point(*p);
        }
        for n in &mut self.normals {
            *n = t.normal(*n).normalize_or_zero();
        }
        self.finish()
    }

    /// Replaces the vertex normals by smooth ones: each vertex gets the sum
    /// of the unit normals of its triangles weighted by the triangle's
    /// angle at the vertex (Thürmer and Wüthrich 1998, as Mitsuba does for
    /// meshes without normals). Vertices of degenerate triangles only get
    /// (1, 0, 0).
    pub fn compute_vertex_normals(&mut self) {
        let mut normals = vec![Vec3::ZERO; self.positions.len()];
        for tri in &self.indices {
            let v = tri.map(|i| self.positions[i as usize]);
            let n = (v[1] - v[0]).cross(v[2] - v[0]);
            let len = n.length();
            if !(len > 0.0 && len.is_finite()) {
                continue;
            }
            let n = n / len;
            for k in 0..3 {
                let e1 = (v[(k + 1) % 3] - v[k]).normalize_or_zero();
                let e2 = (v[(k + 2) % 3] - v[k]).normalize_or_zero();
                let angle = e1.dot(e2).clamp(-1.0, 1.0).acos();
                normals[tri[k] as usize] += n * angle;
            }
        }
        for n in &mut normals {
            *n = n.try_normalize().unwrap_or(Vec3::X);
        }
        self.normals = normals;
    }

    /// Drops the vertex normals: faces are shaded flat.
    pub fn clear_normals(&mut self) {
        self.normals.clear();
    }

    /// Turns the mesh inside out: reverses the winding and negates the
    /// normals.
    pub fn flip_normals(&mut self) {
        for tri in &mut self.indices {
            tri.swap(1, 2);
        }
        for n in &mut self.normals {
            *n = -*n;
        }
    }

    /// Mirrors the texture coordinates vertically (v becomes 1 - v).
    pub fn flip_v(&mut self) {
        for uv in &mut self.uvs {
            uv.y = 1.0 - uv.y;
        }
    }

    /// The point at barycentrics (b1, b2) of the triangle with vertices `v`
    /// and its rounding-error bound: how every point on a mesh (hits, light
    /// samples) is computed.
    #[inline]
    pub fn barycentric_point(v: [Vec3; 3], b1: f32, b2: f32) -> (Vec3, Vec3) {
        let [a, b, c] = v;
        let b0 = 1.0 - b1 - b2;
        (
            a * b0 + b * b1 + c * b2,
            crate::math::barycentric_error(b0, b1, b2, a, b, c),
        )
    }

    /// Unit geometric normal of a triangle from its winding.
    pub fn geometric_normal(&self, tri: usize) -> Vec3 {
        let [a, b, c] = self.vertices(tri);
        (b - a).cross(c - a).normalize_or_zero()
    }

    /// Shading normal and uv at barycentrics (b1, b2) of a triangle.
    pub fn shading(&self, tri: usize, b1: f32, b2: f32) -> (Vec3, Vec2) {
        self.shading_with(tri, self.geometric_normal(tri), b1, b2)
    }

    /// [`TriangleMesh::shading`] given the triangle's geometric normal `ng`
    /// (callers that have it already).
    fn shading_with(&self, tri: usize, ng: Vec3, b1: f32, b2: f32) -> (Vec3, Vec2) {
        let n = self.shading_normal(tri, ng, b1, b2);
        let uv = if self.uvs.is_empty() {
            Vec2::new(b1, b2)
        } else {
            let [i0, i1, i2] = self.indices[tri].map(|i| i as usize);
            (1.0 - b1 - b2) * self.uvs[i0] + b1 * self.uvs[i1] + b2 * self.uvs[i2]
        };
        (n, uv)
    }

    /// The shading normal alone (what a light sample needs: no uv).
    #[inline]
    fn shading_normal(&self, tri: usize, ng: Vec3, b1: f32, b2: f32) -> Vec3 {
        if self.normals.is_empty() {
            return ng;
        }
        let [i0, i1, i2] = self.indices[tri].map(|i| i as usize);
        let b0 = 1.0 - b1 - b2;
        let n = (b0 * self.normals[i0] + b1 * self.normals[i1] + b2 * self.normals[i2])
            .normalize_or_zero();
        if n == Vec3::ZERO {
            ng
        } else {
            n
        }
    }

    /// dp/du of a triangle: the direction the surface moves as u grows,
    /// from its uvs, or from the barycentric (b1, b2) when the mesh has none
    /// (Mitsuba's rule; it orients anisotropic roughness). Zero when the
    /// uvs are degenerate.
    pub fn dpdu(&self, tri: usize) -> Vec3 {
        let [a, b, c] = self.vertices(tri);
        self.dpdu_with(tri, b - a, c - a)
    }

    /// dp/du and dp/dv of a triangle (from its uvs; the edges p1 - p0 and
    /// p2 - p0 when the mesh has none, as Mitsuba parameterises it by
    /// barycentrics): how far the surface moves per unit of u and v, which
    /// bump maps need. Zero when the uvs are degenerate.
    pub fn dpdu_dpdv(&self, tri: usize) -> (Vec3, Vec3) {
        let [a, b, c] = self.vertices(tri);
        let (dp0, dp1) = (b - a, c - a);
        if self.uvs.is_empty() {
            return (dp0, dp1);
        }
        let [i0, i1, i2] = self.indices[tri].map(|i| i as usize);
        let duv0 = self.uvs[i1] - self.uvs[i0];
        let duv1 = self.uvs[i2] - self.uvs[i0];
        let det = duv0.x * duv1.y - duv0.y * duv1.x;
        if det == 0.0 || !det.is_finite() {
            return (Vec3::ZERO, Vec3::ZERO);
        }
        (
            (dp0 * duv1.y - dp1 * duv0.y) / det,
            (dp1 * duv0.x - dp0 * duv1.x) / det,
        )
    }

    /// [`TriangleMesh::dpdu`] given the triangle's edges p1 - p0, p2 - p0.
    fn dpdu_with(&self, tri: usize, dp0: Vec3, dp1: Vec3) -> Vec3 {
        if self.uvs.is_empty() {
            return dp0;
        }
        let [i0, i1, i2] = self.indices[tri].map(|i| i as usize);
        let duv0 = self.uvs[i1] - self.uvs[i0];
        let duv1 = self.uvs[i2] - self.uvs[i0];
        let det = duv0.x * duv1.y - duv0.y * duv1.x;
        if det == 0.0 || !det.is_finite() {
            return Vec3::ZERO;
        }
        (dp0 * duv1.y - dp1 * duv0.y) / det
    }

    /// The surface point at barycentrics (b1, b2) of triangle `hit.index`,
    /// stored into `out` (shape index left 0 for the caller).
    pub fn intersection_into(&self, hit: &BvhHit, out: &mut Intersection) {
        let tri = hit.index as usize;
        // The vertices, edges and normal once, for every quantity below.
        let [a, b, c] = self.vertices(tri);
        let (e1, e2) = (b - a, c - a);
        let ng = e1.cross(e2).normalize_or_zero();
        let (ns, uv) = self.shading_with(tri, ng, hit.b1, hit.b2);
        // Recompute the point from barycentrics: more precise than o + t d.
        let (p, err) = TriangleMesh::barycentric_point([a, b, c], hit.b1, hit.b2);
        *out = Intersection {
            t: hit.t,
            p,
            err,
            ng,
            shading: Frame::from_normal_tangent(ns, self.dpdu_with(tri, e1, e2)),
            uv,
            bary: Vec2::new(hit.b1, hit.b2),
            shape: 0,
            instance: super::BvhHit::NO_INSTANCE,
            prim: hit.index,
        };
    }

    /// A triangle chosen in proportion to its area, and the probability.
    pub fn choose_triangle(&self, u: f32) -> (usize, f32) {
        self.area_distribution.sample_index(u)
    }

    /// Probability that [`TriangleMesh::choose_triangle`] picks `tri`.
    pub fn triangle_probability(&self, tri: usize) -> f32 {
        self.area_distribution.discrete_pdf(tri)
    }

    /// The point at barycentrics (b1, b2) of triangle `tri` as an emitter
    /// sees it (area density of uniform sampling over the whole mesh).
    pub fn surface_point(&self, tri: usize, b1: f32, b2: f32) -> SurfaceSample {
        let (p, err) = TriangleMesh::barycentric_point(self.vertices(tri), b1, b2);
        let ng = self.geometric_normal(tri);
        // Emission is defined on the geometric side the shading normal
        // agrees with (ng computed once, no uv: this runs for every light
        // sample on a mesh).
        let n = if self.shading_normal(tri, ng, b1, b2).dot(ng) < 0.0 {
            -ng
        } else {
            ng
        };
        SurfaceSample {
            p,
            err,
            n,
            pdf_area: 1.0 / self.area,
            prim: tri as u32,
            bary: Vec2::new(b1, b2),
        }
    }

    /// Where the ray from `o` along `d` meets the plane of triangle `tri`,
    /// as barycentrics (b1, b2) clamped to the triangle; `None` if the ray
    /// runs parallel to it or points away. (f64: the directions come from
    /// a solid-angle warp and must land on the triangle they sampled.)
    pub fn barycentrics_along(&self, tri: usize, o: Vec3, d: Vec3) -> Option<(f32, f32)> {
        let [a, b, c] = self.vertices(tri).map(|v| v.as_dvec3());
        let (o, d) = (o.as_dvec3(), d.as_dvec3());
        let (e1, e2) = (b - a, c - a);
        let pvec = d.cross(e2);
        let det = e1.dot(pvec);
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let tvec = o - a;
        let qvec = tvec.cross(e1);
        let t = e2.dot(qvec) / det;
        if t <= 0.0 {
            return None;
        }
        let b1 = (tvec.dot(pvec) / det).clamp(0.0, 1.0);
        let b2 = (d.dot(qvec) / det).clamp(0.0, 1.0);
        let sum = b1 + b2;
        let (b1, b2) = if sum > 1.0 {
            (b1 / sum, b2 / sum)
        } else {
            (b1, b2)
        };
        Some((b1 as f32, b2 as f32))
    }
}
