//! What a light sample on one triangle of an emitting mesh needs, kept per
//! triangle by its [`AreaLight`](super::AreaLight): the vertices, the edge
//! cross product and the centroid (the solid-angle test's inputs), and the
//! emitting side wherever the vertex normals all agree on it. Computed once
//! when the scene is built rather than gathered from the mesh and derived
//! again at every light sample (on the Cornell box a light sample's
//! triangle gathers, normals and side test were half its instructions).
//! Every value is the one the mesh's own routines compute, bit for bit.

use crate::geometry::{SurfaceSample, TriangleMesh};
use crate::math::Vec3;

#[derive(Clone, Debug, PartialEq)]
pub struct LightTriangle {
    pub v: [Vec3; 3],
    /// (v1 - v0) x (v2 - v0): twice the area, along the winding's normal.
    pub cross: Vec3,
    /// (v0 + v1 + v2) / 3.
    pub centroid: Vec3,
    /// The normal of the emitting side at every point of the triangle,
    /// where it does not depend on the point: `None` where the vertex
    /// normals do not all lie clearly on one side of the geometric normal,
    /// and outside a table (the side is then found per point, by the mesh).
    front: Option<Vec3>,
}

impl LightTriangle {
    /// Triangle `tri` of `m`, its emitting side left to the mesh to find
    /// per point (what a light sample of an untabulated mesh computes: no
    /// more than it gathered before the table).
    pub fn of(m: &TriangleMesh, tri: usize) -> LightTriangle {
        let v = m.vertices(tri);
        LightTriangle {
            v,
            cross: (v[1] - v[0]).cross(v[2] - v[0]),
            centroid: (v[0] + v[1] + v[2]) / 3.0,
            front: None,
        }
    }

    /// The normal of triangle `tri`'s emitting side, where every point of
    /// it has the same one.
    fn known_side(m: &TriangleMesh, tri: usize) -> Option<Vec3> {
        let ng = m.geometric_normal(tri);
        if m.normals().is_empty() || ng == Vec3::ZERO {
            // `surface_point` keeps ng then (its side test reads 0 or |ng|^2).
            return Some(ng);
        }
        let normals = m.indices()[tri].map(|i| m.normals()[i as usize]);
        // Normals of about unit length, each at least 0.01 onto one side
        // of ng: their interpolation at any barycentrics in the triangle
        // has a dot product with ng of at least 0.009 (rounding moves it
        // by ~1e-6), so its sign, which the mesh tests, is known.
        let on_side = |s: f32| {
            normals
                .iter()
                .all(|n| (0.81..=1.21).contains(&n.length_squared()) && s * n.dot(ng) >= 0.01)
        };
        if on_side(1.0) {
            Some(ng)
        } else if on_side(-1.0) {
            Some(-ng)
        } else {
            None
        }
    }

    /// Every triangle of `m`, in order, with its emitting side where it is
    /// known.
    pub fn table(m: &TriangleMesh) -> Box<[LightTriangle]> {
        (0..m.triangle_count())
            .map(|tri| LightTriangle {
                front: LightTriangle::known_side(m, tri),
                ..LightTriangle::of(m, tri)
            })
            .collect()
    }

    /// The normal of the emitting side where every point of the triangle
    /// has the same one (see [`LightTriangle::table`]).
    #[inline]
    pub fn front_ref(&self) -> Option<&Vec3> {
        self.front.as_ref()
    }

    /// [`TriangleMesh::surface_point`] of this triangle (`tri` of `m`), the
    /// same bits.
    #[inline]
    pub fn surface_point(&self, m: &TriangleMesh, tri: usize, b1: f32, b2: f32) -> SurfaceSample {
        let Some(n) = self.front else {
            return m.surface_point(tri, b1, b2);
        };
        let (p, err) = TriangleMesh::barycentric_point(self.v, b1, b2);
        SurfaceSample {
            p,
            err,
            n,
            pdf_area: 1.0 / m.area(),
            prim: tri as u32,
            bary: crate::math::Vec2::new(b1, b2),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Sampler;

    /// Triangles whose vertex normals agree with the winding, oppose it,
    /// disagree among themselves, are not of unit length, and a degenerate
    /// one; then the same positions without normals.
    fn meshes() -> [TriangleMesh; 2] {
        let p = vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
            Vec3::new(1.0, 1.0, 0.5),
            Vec3::new(2.0, 2.0, 1.0),
            Vec3::new(3.0, 3.0, 1.5),
        ];
        let n = vec![
            Vec3::new(0.1, 0.0, 1.0).normalize(),
            Vec3::Z,
            Vec3::new(0.0, 0.3, 1.0).normalize(),
            -Vec3::Z,
            Vec3::new(1.0, 0.0, -0.004).normalize() * 3.0,
            Vec3::new(0.0, 1.0, 0.001).normalize(),
        ];
        let idx = vec![[0, 1, 2], [0, 2, 1], [1, 3, 2], [0, 1, 4], [3, 4, 5]];
        [
            TriangleMesh::new(p.clone(), n, vec![], idx.clone()).unwrap(),
            TriangleMesh::new(p, vec![], vec![], idx).unwrap(),
        ]
    }

    fn bits(v: Vec3) -> [u32; 3] {
        v.to_array().map(f32::to_bits)
    }

    /// The table's points are the mesh's, bit for bit, at random and at
    /// corner barycentrics, and the side is known for the triangles whose
    /// normals agree (so the test covers both ways).
    #[test]
    fn light_triangles_give_the_mesh_s_points() {
        let mut s = Sampler::for_pixel_sample(3, 0, 0, 0);
        for m in meshes() {
            let table = LightTriangle::table(&m);
            for (tri, t) in table.iter().enumerate() {
                let v = m.vertices(tri);
                assert_eq!(t.v, v);
                assert_eq!(
                    bits(t.cross.normalize_or_zero()),
                    bits(m.geometric_normal(tri))
                );
                let mut bary = vec![(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (0.5, 0.5)];
                bary.extend((0..500).map(|_| {
                    let (a, b) = (s.next_1d(), s.next_1d());
                    if a + b > 1.0 {
                        (1.0 - a, 1.0 - b)
                    } else {
                        (a, b)
                    }
                }));
                for (b1, b2) in bary {
                    let (x, y) = (
                        t.surface_point(&m, tri, b1, b2),
                        m.surface_point(tri, b1, b2),
                    );
                    assert_eq!(bits(x.p), bits(y.p));
                    assert_eq!(bits(x.err), bits(y.err));
                    assert_eq!(bits(x.n), bits(y.n), "triangle {tri} at ({b1}, {b2})");
                    assert_eq!(x.pdf_area.to_bits(), y.pdf_area.to_bits());
                    assert_eq!((x.prim, x.bary), (y.prim, y.bary));
                }
            }
        }
        let [with_normals, without] = meshes();
        let sides: Vec<_> = LightTriangle::table(&with_normals)
            .iter()
            .map(|t| t.front.map(|n| n.z.signum()))
            .collect();
        // Agreeing, opposed (the winding reversed), mixed, a normal of length
        // 3, degenerate (ng = 0: known).
        assert_eq!(sides, [Some(1.0), Some(1.0), None, None, Some(1.0)]);
        assert!(LightTriangle::table(&without)
            .iter()
            .all(|t| t.front.is_some()));
    }
}
