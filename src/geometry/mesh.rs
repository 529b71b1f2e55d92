//! Indexed triangle meshes.

use crate::math::{Aabb, Frame, Transform, Vec2, Vec3};
use crate::sampling::{warp, Distribution1D};

use super::{BvhHit, Intersection, SurfaceSample};

/// A triangle mesh in world space. `normals` and `uvs` are per vertex and
/// either empty or as long as `positions`.
#[derive(Clone, Debug, Default)]
pub struct TriangleMesh {
    pub positions: Vec<Vec3>,
    pub normals: Vec<Vec3>,
    pub uvs: Vec<Vec2>,
    pub indices: Vec<[u32; 3]>,
    /// Area-weighted triangle choice, built by [`TriangleMesh::prepare`].
    area_distribution: Option<Distribution1D>,
    area: f32,
}

impl TriangleMesh {
    pub fn new(
        positions: Vec<Vec3>,
        normals: Vec<Vec3>,
        uvs: Vec<Vec2>,
        indices: Vec<[u32; 3]>,
    ) -> TriangleMesh {
        let mut m = TriangleMesh {
            positions,
            normals,
            uvs,
            indices,
            area_distribution: None,
            area: 0.0,
        };
        m.prepare();
        m
    }

    /// Recomputes the area table (after construction or a transform).
    pub fn prepare(&mut self) {
        let areas: Vec<f32> = (0..self.indices.len())
            .map(|i| self.triangle_area(i))
            .collect();
        self.area = areas.iter().map(|&a| a as f64).sum::<f64>() as f32;
        self.area_distribution = if areas.is_empty() {
            None
        } else {
            Some(Distribution1D::new(&areas))
        };
    }

    pub fn vertices(&self, tri: usize) -> [Vec3; 3] {
        let [a, b, c] = self.indices[tri];
        [
            self.positions[a as usize],
            self.positions[b as usize],
            self.positions[c as usize],
        ]
    }

    pub fn triangle_area(&self, tri: usize) -> f32 {
        let [a, b, c] = self.vertices(tri);
        0.5 * (b - a).cross(c - a).length()
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

    /// Bakes a transform into the vertices (normals by the inverse transpose).
    pub fn transform(&mut self, t: &Transform) {
        for p in &mut self.positions {
            *p = t.point(*p);
        }
        for n in &mut self.normals {
            *n = t.normal(*n).normalize_or_zero();
        }
        if t.flips_handedness() {
            // Keep the geometric normal (from winding) pointing the same way
            // as the transformed shading normals.
            for tri in &mut self.indices {
                tri.swap(1, 2);
            }
        }
        self.prepare();
    }

    /// Unit geometric normal of a triangle from its winding.
    pub fn geometric_normal(&self, tri: usize) -> Vec3 {
        let [a, b, c] = self.vertices(tri);
        (b - a).cross(c - a).normalize_or_zero()
    }

    /// Shading normal and uv at barycentrics (b1, b2) of a triangle.
    pub fn shading(&self, tri: usize, b1: f32, b2: f32) -> (Vec3, Vec2) {
        let [i0, i1, i2] = self.indices[tri].map(|i| i as usize);
        let b0 = 1.0 - b1 - b2;
        let ng = self.geometric_normal(tri);
        let n = if self.normals.is_empty() {
            ng
        } else {
            let n = (b0 * self.normals[i0] + b1 * self.normals[i1] + b2 * self.normals[i2])
                .normalize_or_zero();
            if n == Vec3::ZERO {
                ng
            } else {
                n
            }
        };
        let uv = if self.uvs.is_empty() {
            Vec2::new(b1, b2)
        } else {
            b0 * self.uvs[i0] + b1 * self.uvs[i1] + b2 * self.uvs[i2]
        };
        (n, uv)
    }

    /// dp/du of a triangle: the direction the surface moves as u grows,
    /// from its uvs, or from the barycentric (b1, b2) when the mesh has none
    /// (Mitsuba's rule; it orients anisotropic roughness). Zero when the
    /// uvs are degenerate.
    pub fn dpdu(&self, tri: usize) -> Vec3 {
        let [a, b, c] = self.vertices(tri);
        let (dp0, dp1) = (b - a, c - a);
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

    /// The surface point at barycentrics (b1, b2) of triangle `hit.index`
    /// (shape index left 0 for the caller).
    pub fn intersection(&self, hit: &BvhHit) -> Intersection {
        let tri = hit.index as usize;
        let (ns, uv) = self.shading(tri, hit.b1, hit.b2);
        // Recompute the point from barycentrics: more precise than o + t d.
        let [a, b, c] = self.vertices(tri);
        let b0 = 1.0 - hit.b1 - hit.b2;
        Intersection {
            t: hit.t,
            p: a * b0 + b * hit.b1 + c * hit.b2,
            err: crate::math::barycentric_error(b0, hit.b1, hit.b2, a, b, c),
            ng: self.geometric_normal(tri),
            shading: Frame::from_normal_tangent(ns, self.dpdu(tri)),
            uv,
            shape: 0,
        }
    }

    /// Samples a point uniformly by area.
    pub fn sample_area(&self, u_tri: f32, u: Vec2) -> SurfaceSample {
        let dist = self
            .area_distribution
            .as_ref()
            .expect("sampling an empty mesh");
        let (tri, _, _) = dist.sample_discrete(u_tri);
        let b = warp::square_to_uniform_triangle(u);
        let [a, bb, c] = self.vertices(tri);
        let p = a * (1.0 - b.x - b.y) + bb * b.x + c * b.y;
        let err = crate::math::barycentric_error(1.0 - b.x - b.y, b.x, b.y, a, bb, c);
        let (n, _) = self.shading(tri, b.x, b.y);
        let ng = self.geometric_normal(tri);
        // Emission is defined on the geometric side the shading normal agrees with.
        let n = if n.dot(ng) < 0.0 { -ng } else { ng };
        SurfaceSample {
            p,
            err,
            n,
            pdf_area: 1.0 / self.area,
        }
    }
}
