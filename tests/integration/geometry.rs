//! Geometry: the BVH with the watertight triangle test lets no ray escape a
//! closed mesh; robust offsets avoid self-intersection.

use crate::common::*;
use lente::geometry::{Bvh, Geometry};
use lente::math::{offset_ray_origin, Ray, Vec3};
use lente::sampling::{warp, Sampler};

fn escapes(bvh: &Bvh, rays: impl Iterator<Item = Ray>) -> (usize, usize) {
    let mut n = 0;
    let mut lost = 0;
    for r in rays {
        n += 1;
        if bvh.intersect(&r).is_none() {
            lost += 1;
        }
    }
    (lost, n)
}

#[test]
fn a_million_rays_from_inside_closed_meshes_never_escape() {
    let meshes = [
        Geometry::Mesh(icosphere(1.0, 4)),
        Geometry::Mesh(cube(1.0, 7)),
    ];
    for (k, g) in meshes.into_iter().enumerate() {
        let vertices = match &g {
            Geometry::Mesh(m) => m.positions().to_vec(),
            _ => unreachable!(),
        };
        let bvh = Bvh::build(std::slice::from_ref(&g));
        let mut s = Sampler::new(42 + k as u64, 0);
        // Random origins and directions, half of them aimed exactly at
        // vertices (where several triangles meet) from random interior points.
        let rays = (0..500_000).map(|i| {
            let o = warp::square_to_uniform_sphere(s.next_2d()) * 0.5 * s.next_1d().sqrt();
            let d = if i % 2 == 0 {
                warp::square_to_uniform_sphere(s.next_2d())
            } else {
                let v = vertices[(s.next_u32() as usize) % vertices.len()];
                (v - o).normalize()
            };
            Ray::new(o, d)
        });
        let (lost, n) = escapes(&bvh, rays);
        assert_eq!(lost, 0, "mesh {k}: {lost} of {n} rays escaped");
    }
}

#[test]
fn rays_along_shared_edges_from_the_centre_hit() {
    // Rays from the centre through midpoints of every edge of the icosphere.
    let g = Geometry::Mesh(icosphere(1.0, 3));
    let edges: Vec<Vec3> = match &g {
        Geometry::Mesh(m) => m
            .indices()
            .iter()
            .flat_map(|t| {
                let p = t.map(|i| m.positions()[i as usize]);
                [
                    (p[0] + p[1]) * 0.5,
                    (p[1] + p[2]) * 0.5,
                    (p[2] + p[0]) * 0.5,
                ]
            })
            .collect(),
        _ => unreachable!(),
    };
    let bvh = Bvh::build(std::slice::from_ref(&g));
    let (lost, n) = escapes(
        &bvh,
        edges.iter().map(|&e| Ray::new(Vec3::ZERO, e.normalize())),
    );
    assert_eq!(lost, 0, "{lost} of {n} edge rays escaped");
}

#[test]
fn offset_origins_do_not_self_intersect() {
    // Far from the origin, where a fixed epsilon would fail, spawned rays
    // leaving a surface must not hit it again.
    for scale in [1.0f32, 1e3, 1e5] {
        let mut g = Geometry::Mesh(icosphere(scale, 2));
        g.transform(
            &lente::math::Transform::new(lente::math::Mat4::from_translation(Vec3::splat(
                3.0 * scale,
            )))
            .unwrap(),
        )
        .unwrap();
        let bvh = Bvh::build(std::slice::from_ref(&g));
        let centre = Vec3::splat(3.0 * scale);
        let mut s = Sampler::new(9, 9);
        let mut self_hits = 0;
        for _ in 0..20_000 {
            let d = warp::square_to_uniform_sphere(s.next_2d());
            let r = Ray::new(centre, d);
            let Some(h) = bvh.intersect(&r) else { continue };
            let (ng, tri) = match &g {
                Geometry::Mesh(m) => (
                    m.geometric_normal(h.index as usize),
                    m.vertices(h.index as usize),
                ),
                _ => unreachable!(),
            };
            // Leave outwards: nothing else is there, so any hit is a self-hit.
            let mut out = warp::square_to_cosine_hemisphere(s.next_2d());
            let f = lente::math::Frame::from_normal(ng);
            out = f.to_world(out);
            let err = lente::math::barycentric_error(
                1.0 - h.b1 - h.b2,
                h.b1,
                h.b2,
                tri[0],
                tri[1],
                tri[2],
            );
            let p = tri[0] * (1.0 - h.b1 - h.b2) + tri[1] * h.b1 + tri[2] * h.b2;
            let o = offset_ray_origin(p, err, ng, out);
            if bvh.intersect(&Ray::new(o, out)).is_some() {
                self_hits += 1;
            }
        }
        assert_eq!(
            self_hits, 0,
            "scale {scale}: {self_hits} self-intersections"
        );
    }
}

/// Points on a huge ground quad near the origin: the error of the
/// barycentric hit point scales with the vertices (1000 units), not with the
/// point, and the offset must follow it.
#[test]
fn huge_triangles_do_not_shadow_themselves() {
    let m = lente::geometry::TriangleMesh::new(
        vec![
            Vec3::new(-1000.0, 0.0, -1000.0),
            Vec3::new(1000.0, 0.0, -1000.0),
            Vec3::new(1000.0, 0.0, 1000.0),
            Vec3::new(-1000.0, 0.0, 1000.0),
        ],
        Vec::new(),
        Vec::new(),
        vec![[0, 2, 1], [0, 3, 2]],
    )
    .unwrap();
    let mut d = crate::common::desc(
        crate::common::look_at(Vec3::new(0.0, 2.0, 5.0), Vec3::ZERO, 40.0, 8, 8),
        crate::common::path(lente::integrator::Strategy::Mis),
    );
    d.shapes.push(crate::common::shape(
        Geometry::Mesh(m),
        crate::common::diffuse(0.5),
        None,
    ));
    let scene = d.build();
    let mut s = Sampler::new(3, 3);
    let mut self_hits = 0;
    for _ in 0..100_000 {
        let target = Vec3::new(s.next_1d() * 6.0 - 3.0, 0.0, s.next_1d() * 6.0 - 3.0);
        let o = Vec3::new(0.0, 2.0, 5.0);
        let Some(its) = scene.intersect(&Ray::new(o, (target - o).normalize())) else {
            continue;
        };
        let f = lente::math::Frame::from_normal(its.ng);
        let d = f.to_world(warp::square_to_cosine_hemisphere(s.next_2d()));
        if scene.intersect(&Ray::new(its.spawn(d), d)).is_some() {
            self_hits += 1;
        }
    }
    assert_eq!(self_hits, 0, "{self_hits} rays re-hit the ground they left");
}

/// Geometry filling the whole coordinate range the loaders accept
/// (±1e12): the BVH builds (its surface-area costs stay finite) and
/// answers rays; a vertex or sphere beyond the range is refused with an
/// error, not handed to the builder.
#[test]
fn the_bvh_builds_over_the_whole_accepted_coordinate_range() {
    use lente::geometry::{MeshError, Sphere, SphereError, TriangleMesh};
    let max = lente::limits::MAX_COORDINATE;
    let mut s = Sampler::new(11, 0);
    let mut point = |scale: f32| {
        Vec3::new(
            (s.next_1d() * 2.0 - 1.0) * scale,
            (s.next_1d() * 2.0 - 1.0) * scale,
            (s.next_1d() * 2.0 - 1.0) * scale,
        )
    };
    let mut positions = Vec::new();
    for i in 0..30_000 {
        // Tiny triangles anywhere, and some spanning the whole range.
        let c = point(max * 0.999);
        let size = if i % 100 == 0 { max } else { 1.0 };
        positions.push(c);
        positions.push((c + Vec3::new(size, 0.0, 0.0)).clamp(Vec3::splat(-max), Vec3::splat(max)));
        positions.push((c + Vec3::new(0.0, size, 0.0)).clamp(Vec3::splat(-max), Vec3::splat(max)));
    }
    let indices = (0..30_000u32)
        .map(|i| [3 * i, 3 * i + 1, 3 * i + 2])
        .collect();
    let mesh = TriangleMesh::new(positions, Vec::new(), Vec::new(), indices).unwrap();
    let mut shapes = vec![Geometry::Mesh(mesh)];
    for corner in [Vec3::splat(max * 0.5), Vec3::splat(-max * 0.5)] {
        shapes.push(Geometry::Sphere(Sphere::new(corner, max * 0.5).unwrap()));
    }
    let bvh = Bvh::build(&shapes);
    let mut hits = 0;
    for _ in 0..10_000 {
        let o = point(max * 0.9);
        let d = (point(1.0)).normalize();
        hits += usize::from(bvh.intersect(&Ray::new(o, d)).is_some());
    }
    assert!(hits > 0);

    let far = vec![Vec3::new(max * 2.0, 0.0, 0.0), Vec3::X, Vec3::Y];
    assert!(matches!(
        TriangleMesh::new(far, Vec::new(), Vec::new(), vec![[0, 1, 2]]),
        Err(MeshError::OutOfRange { index: 0, .. })
    ));
    assert!(matches!(
        Sphere::new(Vec3::new(max, 0.0, 0.0), 1e6),
        Err(SphereError::OutOfRange { .. })
    ));
}
