//! Mesh versions of simple shapes.
//!
//! The shapes follow Mitsuba 3's object-space definitions: the rectangle
//! is the square [-1, 1]^2 at z = 0 facing +z, the cube is [-1, 1]^3 with
//! outward normals, the disk is the unit disk at z = 0 facing +z, the
//! cylinder runs from `p0` to `p1` without caps. Rectangle and cube are
//! exact; the disk and the cylinder are fine polygons whose radius is
//! chosen so that their area (and so the power of an area light on them)
//! is exact. Flat shapes carry explicit vertex normals, so their front side
//! is the one the normals give, whatever a transform does to the winding.

use super::{MeshError, TriangleMesh};
use crate::math::{Vec2, Vec3, PI};

/// Segments around the disk and the cylinder.
pub const ROUND_SEGMENTS: usize = 512;

/// The square [-1, 1]^2 at z = 0, facing +z; uv = ((x + 1) / 2, (y + 1) / 2).
pub fn rectangle_mesh() -> TriangleMesh {
    let positions = vec![
        Vec3::new(-1.0, -1.0, 0.0),
        Vec3::new(1.0, -1.0, 0.0),
        Vec3::new(1.0, 1.0, 0.0),
        Vec3::new(-1.0, 1.0, 0.0),
    ];
    let uvs = positions
        .iter()
        .map(|p| Vec2::new(p.x + 1.0, p.y + 1.0) * 0.5)
        .collect();
    TriangleMesh::new(positions, vec![Vec3::Z; 4], uvs, vec![[0, 1, 2], [0, 2, 3]])
        .expect("the rectangle is a valid mesh")
}

/// The cube [-1, 1]^3: 6 faces of 2 triangles, 4 vertices each with the
/// face's outward normal. Each face's u runs along the axis Mitsuba's cube
/// gives it (so anisotropic roughness is oriented the same way).
pub fn cube_mesh() -> TriangleMesh {
    let mut positions = Vec::with_capacity(24);
    let mut normals = Vec::with_capacity(24);
    let mut uvs = Vec::with_capacity(24);
    let mut indices = Vec::with_capacity(12);
    for axis in 0..3 {
        for sign in [-1.0f32, 1.0] {
            let mut n = Vec3::ZERO;
            n[axis] = sign;
            // Tangents with t1 x t2 = n, so the winding faces outward.
            let mut t1 = Vec3::ZERO;
            t1[(axis + 1) % 3] = 1.0;
            let t2 = n.cross(t1);
            let tu = mitsuba_cube_u(axis, sign);
            let tv = n.cross(tu);
            let base = positions.len() as u32;
            for (a, b) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                let q = n + t1 * a + t2 * b;
                positions.push(q);
                normals.push(n);
                uvs.push(Vec2::new((q.dot(tu) + 1.0) * 0.5, (q.dot(tv) + 1.0) * 0.5));
            }
            indices.push([base, base + 1, base + 2]);
            indices.push([base, base + 2, base + 3]);
        }
    }
    TriangleMesh::new(positions, normals, uvs, indices).expect("the cube is a valid mesh")
}

/// The direction of u on the cube face with outward normal `sign` along
/// `axis`, as Mitsuba's `cube` parameterizes it (read off Mitsuba 3.9.1's
/// shading frames).
fn mitsuba_cube_u(axis: usize, sign: f32) -> Vec3 {
    match (axis, sign > 0.0) {
        (1, true) => -Vec3::X,
        (1, false) => Vec3::Z,
        (2, false) => -Vec3::Y,
        _ => Vec3::Y,
    }
}

/// The unit disk at z = 0 facing +z, as a fan of `segments` triangles
/// (at least 3) with the disk's exact area. uv = (radius, angle / 2π) as
/// in Mitsuba, so dp/du points outward along each triangle's middle
/// radius (each triangle has its own centre vertex for that).
pub fn disk_mesh(segments: usize) -> TriangleMesh {
    let n = segments.max(3);
    let step = 2.0 * PI as f64 / n as f64;
    // A regular n-gon of circumradius r has area n/2 r^2 sin(step).
    let r = (PI as f64 / (0.5 * n as f64 * step.sin())).sqrt();
    // Rim vertices 0..=n (the seam repeated so the angle can reach 1),
    // then one centre vertex per triangle.
    let mut positions = Vec::with_capacity(2 * n + 1);
    let mut uvs = Vec::with_capacity(2 * n + 1);
    for i in 0..=n {
        let (s, c) = (i as f64 * step).sin_cos();
        positions.push(Vec3::new((r * c) as f32, (r * s) as f32, 0.0));
        uvs.push(Vec2::new(1.0, i as f32 / n as f32));
    }
    for i in 0..n {
        positions.push(Vec3::ZERO);
        uvs.push(Vec2::new(0.0, (i as f32 + 0.5) / n as f32));
    }
    let rim = n as u32 + 1;
    let indices = (0..n as u32).map(|i| [rim + i, i, i + 1]).collect();
    let normals = vec![Vec3::Z; positions.len()];
    TriangleMesh::new(positions, normals, uvs, indices).expect("the disk is a valid mesh")
}

/// An open cylinder of radius `radius` around the segment p0 -> p1, with
/// `segments` flat sides (at least 3), smooth outward normals and the exact
/// lateral area. [`MeshError::NoArea`] if the segment or the radius is
/// degenerate.
pub fn cylinder_mesh(
    p0: Vec3,
    p1: Vec3,
    radius: f32,
    segments: usize,
) -> Result<TriangleMesh, MeshError> {
    let axis = p1 - p0;
    let length = axis.length();
    if !(length > 0.0 && length.is_finite() && radius > 0.0 && radius.is_finite()) {
        return Err(MeshError::NoArea);
    }
    let n = segments.max(3);
    let dir = axis / length;
    let frame = crate::math::Frame::from_normal(dir);
    let (s, t) = (frame.s, frame.t);
    let step = 2.0 * PI as f64 / n as f64;
    // Perimeter of the n-gon of circumradius r: 2 n r sin(step / 2).
    let r = radius as f64 * (0.5 * step) / (0.5 * step).sin();
    let mut positions = Vec::with_capacity(2 * (n + 1));
    let mut normals = Vec::with_capacity(2 * (n + 1));
    let mut uvs = Vec::with_capacity(2 * (n + 1));
    // n + 1 columns: the seam is duplicated so uv can wrap.
    for i in 0..=n {
        let (sn, cs) = (i as f64 * step).sin_cos();
        let radial = s * cs as f32 + t * sn as f32;
        for (end, v) in [(p0, 0.0f32), (p1, 1.0)] {
            positions.push(end + radial * r as f32);
            normals.push(radial);
            uvs.push(Vec2::new(i as f32 / n as f32, v));
        }
    }
    let mut indices = Vec::with_capacity(2 * n);
    for i in 0..n as u32 {
        let (a, b, c, d) = (2 * i, 2 * i + 1, 2 * i + 2, 2 * i + 3);
        // Counter-clockwise seen from outside: radial, then along the axis.
        indices.push([a, c, d]);
        indices.push([a, d, b]);
    }
    TriangleMesh::new(positions, normals, uvs, indices)
}

/// A latitude-longitude sphere mesh with smooth normals (`rings` >= 2
/// bands of latitude, `sectors` >= 3 of longitude).
pub fn sphere_mesh(
    center: Vec3,
    radius: f32,
    sectors: usize,
    rings: usize,
) -> Result<TriangleMesh, MeshError> {
    let (ns, nr) = (sectors.max(3), rings.max(2));
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    let mut uvs = Vec::new();
    for j in 0..=nr {
        let theta = PI * j as f32 / nr as f32;
        for i in 0..=ns {
            let phi = 2.0 * PI * i as f32 / ns as f32;
            let n = Vec3::new(
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            );
            positions.push(center + n * radius);
            normals.push(n);
            uvs.push(Vec2::new(i as f32 / ns as f32, j as f32 / nr as f32));
        }
    }
    let row = ns as u32 + 1;
    let mut indices = Vec::new();
    for j in 0..nr as u32 {
        for i in 0..ns as u32 {
            let a = j * row + i;
            let (b, c, d) = (a + 1, a + row, a + row + 1);
            // Outward winding; skip the degenerate triangles at the poles.
            if j != 0 {
                indices.push([a, c, b]);
            }
            if j + 1 != nr as u32 {
                indices.push([b, c, d]);
            }
        }
    }
    TriangleMesh::new(positions, normals, uvs, indices)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flat_shapes_have_their_areas() {
        assert!((rectangle_mesh().area() - 4.0).abs() < 1e-6);
        assert!((cube_mesh().area() - 24.0).abs() < 1e-5);
        assert!((disk_mesh(ROUND_SEGMENTS).area() - PI).abs() < 1e-4);
        let c = cylinder_mesh(Vec3::ZERO, Vec3::new(0.0, 0.0, 2.0), 0.5, ROUND_SEGMENTS).unwrap();
        assert!(
            (c.area() - 2.0 * PI * 0.5 * 2.0).abs() < 1e-3,
            "{}",
            c.area()
        );
    }

    #[test]
    fn windings_agree_with_normals() {
        let c = cylinder_mesh(Vec3::ZERO, Vec3::Y, 1.0, 16).unwrap();
        for m in [
            rectangle_mesh(),
            cube_mesh(),
            disk_mesh(16),
            c,
            sphere_mesh(Vec3::ZERO, 1.0, 16, 8).unwrap(),
        ] {
            for (tri, &[a, _, _]) in m.indices().iter().enumerate() {
                let ng = m.geometric_normal(tri);
                assert!(ng.dot(m.normals()[a as usize]) > 0.5, "triangle {tri}");
            }
        }
    }
}
