//! Shapes, ray intersection, and the acceleration structure.

mod bvh;
mod mesh;
mod obj;
mod ply;
mod shapes;
mod sphere;
mod triangle;

pub use bvh::{Bvh, BvhHit};
pub use mesh::TriangleMesh;
pub use obj::load_obj;
pub use ply::{load_ply, parse_ply};
pub use shapes::{
    compute_vertex_normals, cube_mesh, cylinder_mesh, disk_mesh, flip_mesh_normals, rectangle_mesh,
    sphere_mesh, transform_mesh_keep_winding, ROUND_SEGMENTS,
};
pub use sphere::Sphere;
pub use triangle::{intersect_triangle, RayShear};

use crate::math::{Aabb, Frame, Ray, Transform, Vec2, Vec3};

/// The geometry of one shape.
#[derive(Clone, Debug)]
pub enum Geometry {
    Mesh(TriangleMesh),
    Sphere(Sphere),
}

impl Geometry {
    /// Number of BVH primitives this shape contributes.
    pub fn primitive_count(&self) -> usize {
        match self {
            Geometry::Mesh(m) => m.indices.len(),
            Geometry::Sphere(_) => 1,
        }
    }

    pub fn bounds(&self) -> Aabb {
        match self {
            Geometry::Mesh(m) => m.bounds(),
            Geometry::Sphere(s) => s.bounds(),
        }
    }

    /// Total surface area.
    pub fn area(&self) -> f32 {
        match self {
            Geometry::Mesh(m) => m.area(),
            Geometry::Sphere(s) => s.area(),
        }
    }

    /// The surface point of a BVH hit on this shape.
    pub fn intersection(&self, ray: &Ray, hit: &BvhHit) -> Intersection {
        let mut its = match self {
            Geometry::Mesh(m) => m.intersection(hit),
            Geometry::Sphere(s) => s.intersection(ray, hit.t),
        };
        its.shape = hit.shape;
        // The geometric normal defines the front side; orient it to agree
        // with the shading normal so emission and shading see one surface.
        if its.ng.dot(its.shading.n) < 0.0 {
            its.ng = -its.ng;
        }
        its
    }

    /// Applies a transform in place (meshes bake it; spheres need a similarity).
    pub fn transform(&mut self, t: &Transform) -> Result<(), String> {
        match self {
            Geometry::Mesh(m) => {
                m.transform(t);
                Ok(())
            }
            Geometry::Sphere(s) => s.transform(t),
        }
    }
}

/// A point on a surface found by a ray.
#[derive(Clone, Copy, Debug)]
pub struct Intersection {
    /// Ray parameter of the hit.
    pub t: f32,
    pub p: Vec3,
    /// Floating-point error bound of `p` (per axis).
    pub err: Vec3,
    /// Unit geometric normal (facing as the shape defines it, not the ray).
    pub ng: Vec3,
    /// Shading frame (interpolated normal).
    pub shading: Frame,
    pub uv: Vec2,
    /// Index of the shape in the scene.
    pub shape: u32,
}

impl Intersection {
    /// Origin for a ray leaving the surface in direction `w`.
    pub fn spawn(&self, w: Vec3) -> Vec3 {
        crate::math::offset_ray_origin(self.p, self.err, self.ng, w)
    }
}

/// A point sampled on a surface, with its area density.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceSample {
    pub p: Vec3,
    /// Floating-point error bound of `p`.
    pub err: Vec3,
    pub n: Vec3,
    /// Density with respect to area.
    pub pdf_area: f32,
}
