//! One BVH over every triangle and sphere of the scene: built by obvhs
//! (compressed wide BVH), traversed with our own watertight triangle test.

use std::time::{Duration, Instant};

use glam::{Vec3A, Vec4};
use obvhs::cwbvh::{builder::build_cwbvh, CwBvh};
use obvhs::{aabb::Aabb as OAabb, Boundable, BvhBuildParams};

use super::triangle::{intersect_triangle, PackedTriangle, RayShear};
use super::{Geometry, Sphere};
use crate::math::{Aabb, Ray, Vec3};

/// A primitive with its data copied in BVH order, so traversal touches one
/// contiguous array of 48-byte records: a triangle's vertices by
/// coordinate in lanes 0-2 ([`PackedTriangle`]); lane 3 of `xs` holds, as
/// bits, 0 for a triangle or 1 + the index of a sphere in `Bvh::spheres`.
#[derive(Clone, Copy, Debug)]
struct Prim {
    xs: Vec4,
    ys: Vec4,
    zs: Vec4,
}

impl Prim {
    fn triangle(v: [Vec3; 3]) -> Prim {
        Prim {
            xs: Vec4::new(v[0].x, v[1].x, v[2].x, f32::from_bits(0)),
            ys: Vec4::new(v[0].y, v[1].y, v[2].y, 0.0),
            zs: Vec4::new(v[0].z, v[1].z, v[2].z, 0.0),
        }
    }

    fn sphere(index: u32) -> Prim {
        Prim {
            xs: Vec4::new(0.0, 0.0, 0.0, f32::from_bits(index + 1)),
            ys: Vec4::ZERO,
            zs: Vec4::ZERO,
        }
    }

    /// The sphere's index, or None for a triangle.
    #[inline]
    fn sphere_index(&self) -> Option<usize> {
        match self.xs.w.to_bits() {
            0 => None,
            i => Some(i as usize - 1),
        }
    }

    #[inline]
    fn packed_triangle(&self) -> PackedTriangle {
        PackedTriangle::from_lanes(
            Vec3A::from_vec4(self.xs),
            Vec3A::from_vec4(self.ys),
            Vec3A::from_vec4(self.zs),
        )
    }
}

#[derive(Clone, Copy, Debug)]
struct PrimRef {
    shape: u32,
    index: u32,
}

struct BoundsOnly(OAabb);

impl Boundable for BoundsOnly {
    fn aabb(&self) -> OAabb {
        self.0
    }
}

/// Closest-hit record from the BVH: enough to rebuild the full intersection.
#[derive(Clone, Copy, Debug)]
pub struct BvhHit {
    pub t: f32,
    pub shape: u32,
    /// Triangle index within its mesh (0 for spheres).
    pub index: u32,
    /// Barycentrics of vertices 1 and 2 (triangles only).
    pub b1: f32,
    pub b2: f32,
}

/// The scene's acceleration structure.
pub struct Bvh {
    bvh: Option<CwBvh>,
    prims: Vec<Prim>,
    /// The spheres, in the order of their primitives' indices.
    spheres: Vec<Sphere>,
    refs: Vec<PrimRef>,
    bounds: Aabb,
    /// Wall time spent building.
    pub build_time: Duration,
}

impl Bvh {
    pub fn build(shapes: &[Geometry]) -> Bvh {
        let start = Instant::now();
        let mut prims = Vec::new();
        let mut spheres = Vec::new();
        let mut refs = Vec::new();
        let mut boxes = Vec::new();
        let mut bounds = Aabb::EMPTY;
        for (si, g) in shapes.iter().enumerate() {
            match g {
                Geometry::Mesh(m) => {
                    for ti in 0..m.triangle_count() {
                        prims.push(Prim::triangle(m.vertices(ti)));
                        refs.push(PrimRef {
                            shape: si as u32,
                            index: ti as u32,
                        });
                        boxes.push(m.triangle_bounds(ti));
                    }
                }
                Geometry::Sphere(s) => {
                    prims.push(Prim::sphere(spheres.len() as u32));
                    spheres.push(*s);
                    refs.push(PrimRef {
                        shape: si as u32,
                        index: 0,
                    });
                    boxes.push(s.bounds());
                }
            }
        }
        for b in &boxes {
            bounds = bounds.union(*b);
        }
        if prims.is_empty() {
            return Bvh {
                bvh: None,
                prims,
                spheres,
                refs,
                bounds,
                build_time: start.elapsed(),
            };
        }
        // obvhs's slab test is not conservatively rounded: a ray that meets a
        // triangle exactly at its bounding box's face can be culled. Padding
        // each box by a few ulps of its coordinates keeps the hit inside.
        let oboxes: Vec<BoundsOnly> = boxes
            .iter()
            .map(|b| {
                let pad = b.min.abs().max(b.max.abs()) * 1e-5 + Vec3::splat(1e-30);
                BoundsOnly(OAabb::new(
                    Vec3A::from(b.min - pad),
                    Vec3A::from(b.max + pad),
                ))
            })
            .collect();
        let mut core = Duration::default();
        let bvh = build_cwbvh(&oboxes, BvhBuildParams::medium_build(), &mut core);
        // Reorder primitives into leaf order so the traversal id indexes directly.
        let prims: Vec<Prim> = bvh
            .primitive_indices
            .iter()
            .map(|&i| prims[i as usize])
            .collect();
        let refs: Vec<PrimRef> = bvh
            .primitive_indices
            .iter()
            .map(|&i| refs[i as usize])
            .collect();
        Bvh {
            bvh: Some(bvh),
            prims,
            spheres,
            refs,
            bounds,
            build_time: start.elapsed(),
        }
    }

    pub fn bounds(&self) -> Aabb {
        self.bounds
    }

    pub fn primitive_count(&self) -> usize {
        self.prims.len()
    }

    fn oray(ray: &Ray) -> obvhs::ray::Ray {
        obvhs::ray::Ray::new(Vec3A::from(ray.o), Vec3A::from(ray.d), ray.tmin, ray.tmax)
    }

    /// Closest hit along the ray within its range.
    pub fn intersect(&self, ray: &Ray) -> Option<BvhHit> {
        let bvh = self.bvh.as_ref()?;
        let shear = RayShear::new(ray.o, ray.d);
        let mut best = BvhHit {
            t: ray.tmax,
            shape: 0,
            index: 0,
            b1: 0.0,
            b2: 0.0,
        };
        let mut hit = obvhs::ray::RayHit::none();
        let o = ray.o;
        let d = ray.d;
        let found = bvh.ray_traverse(Self::oray(ray), &mut hit, |r, id| {
            let prim = &self.prims[id];
            match prim.sphere_index() {
                None => match intersect_triangle(&shear, &prim.packed_triangle(), r.tmin, r.tmax) {
                    Some((t, b1, b2)) => {
                        best = BvhHit {
                            t,
                            shape: self.refs[id].shape,
                            index: self.refs[id].index,
                            b1,
                            b2,
                        };
                        t
                    }
                    None => f32::INFINITY,
                },
                Some(si) => match self.spheres[si].intersect(o, d, r.tmin, r.tmax) {
                    Some(t) => {
                        best = BvhHit {
                            t,
                            shape: self.refs[id].shape,
                            index: 0,
                            b1: 0.0,
                            b2: 0.0,
                        };
                        t
                    }
                    None => f32::INFINITY,
                },
            }
        });
        if found {
            Some(best)
        } else {
            None
        }
    }

    /// True if anything blocks the ray within its range.
    pub fn occluded(&self, ray: &Ray) -> bool {
        let Some(bvh) = self.bvh.as_ref() else {
            return false;
        };
        let shear = RayShear::new(ray.o, ray.d);
        let o = ray.o;
        let d = ray.d;
        !bvh.ray_traverse_miss(Self::oray(ray), |r, id| {
            let prim = &self.prims[id];
            match prim.sphere_index() {
                None => intersect_triangle(&shear, &prim.packed_triangle(), r.tmin, r.tmax)
                    .map_or(f32::INFINITY, |(t, _, _)| t),
                Some(si) => self.spheres[si]
                    .intersect(o, d, r.tmin, r.tmax)
                    .unwrap_or(f32::INFINITY),
            }
        })
    }
}
