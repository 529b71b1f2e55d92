//! Shapes, ray intersection, and the acceleration structure.

mod attribute;
mod bvh;
mod curve;
mod disk;
mod instance;
#[cfg(target_arch = "x86_64")]
pub(crate) mod lanes;
mod leaf_rows;
mod mesh;
mod obj;
#[cfg(target_arch = "x86_64")]
mod packet;
mod plane;
mod ply;
mod rectangle;
mod serialized;
mod shapes;
mod sphere;
mod sphere_lanes;
mod triangle;
mod wide_bvh;

pub use attribute::MeshAttribute;
pub use bvh::{build_boxes, BoundsOnly, Bvh, BvhHit, PACKET_LANES, PACKET_MAX_PRIMITIVES};
pub use curve::{load_curve, Curve, CurveBasis, CurveError, CurveSegment};
pub use disk::Disk;
pub use instance::Instance;
#[cfg(target_arch = "x86_64")]
pub use lanes::PacketIsa;
pub use mesh::{MeshError, TriangleMesh};
pub use obj::{load_obj, parse_obj, ObjError};
pub use plane::{PlaneError, PlaneFrame};
pub use ply::{load_ply, load_ply_full, parse_ply, parse_ply_full};
pub use rectangle::Rectangle;
pub use serialized::{
    load_serialized, load_serialized_full, parse_serialized, parse_serialized_full, SerializedError,
};
pub use shapes::{
    cube_mesh, cylinder_mesh, disk_mesh, rectangle_mesh, sphere_mesh, ROUND_SEGMENTS,
};
pub use sphere::{Sphere, SphereError, SphereUv};
pub use sphere_lanes::{sample_cones_lanes, ConeLanes, ConeSample};
pub use triangle::{intersect_triangle, PackedTriangle, RayShear};

use crate::math::{Aabb, Frame, Ray, Transform, Vec2, Vec3};

/// The geometry of one shape.
#[derive(Clone, Debug)]
pub enum Geometry {
    Mesh(TriangleMesh),
    Sphere(Sphere),
    Disk(Disk),
    Rectangle(Rectangle),
    /// Round curves (already in world space: they are placed when read).
    Curve(Curve),
}

impl Geometry {
    /// Number of BVH primitives this shape contributes.
    pub fn primitive_count(&self) -> usize {
        match self {
            Geometry::Mesh(m) => m.triangle_count(),
            Geometry::Sphere(_) | Geometry::Disk(_) | Geometry::Rectangle(_) => 1,
            Geometry::Curve(c) => c.segment_count(),
        }
    }

    pub fn bounds(&self) -> Aabb {
        match self {
            Geometry::Mesh(m) => m.bounds(),
            Geometry::Sphere(s) => s.bounds(),
            Geometry::Disk(d) => d.bounds(),
            Geometry::Rectangle(r) => r.bounds(),
            Geometry::Curve(c) => c.bounds(),
        }
    }

    /// Total surface area (only emitters ask, and curves emit nothing:
    /// their loader refuses an area emitter, as Mitsuba does).
    pub fn area(&self) -> f32 {
        match self {
            Geometry::Mesh(m) => m.area(),
            Geometry::Sphere(s) => s.area(),
            Geometry::Disk(d) => d.area(),
            Geometry::Rectangle(r) => r.area(),
            Geometry::Curve(_) => 0.0,
        }
    }

    /// The surface point of a BVH hit on this shape, in the shape's own
    /// space (the group's, for an instance: see [`Instance::to_world`]).
    pub fn intersection(&self, ray: &Ray, hit: &BvhHit) -> Intersection {
        let mut its = Intersection::UNSET;
        self.intersection_into(ray, hit, &mut its);
        its
    }

    /// [`Geometry::intersection`] written into `out`: each shape stores
    /// its record there field by field. (Returned by value, a record was
    /// built on the stack and copied in 16-byte pieces whose loads of the
    /// smaller stores just made could not be forwarded: a stall `perf` put
    /// at several percent of a Cornell box render.)
    pub fn intersection_into(&self, ray: &Ray, hit: &BvhHit, out: &mut Intersection) {
        match self {
            Geometry::Mesh(m) => m.intersection_into(hit, out),
            Geometry::Sphere(s) => s.intersection_into(ray, hit.t, out),
            Geometry::Disk(d) => d.intersection_into(hit, out),
            Geometry::Rectangle(r) => r.intersection_into(hit, out),
            Geometry::Curve(c) => c.intersection_into(ray, hit, out),
        }
        out.shape = hit.shape;
        // The geometric normal defines the front side; orient it to agree
        // with the shading normal so emission and shading see one surface.
        if out.ng.dot(out.shading.n) < 0.0 {
            out.ng = -out.ng;
        }
    }

    /// dp/du and dp/dv at a hit on this shape (world space).
    pub fn dpdu_dpdv(&self, its: &Intersection) -> (Vec3, Vec3) {
        match self {
            Geometry::Mesh(m) => m.dpdu_dpdv(its.prim as usize),
            Geometry::Sphere(s) => s.dpdu_dpdv((its.p - s.center).normalize_or_zero()),
            Geometry::Disk(d) => d.dpdu_dpdv(its.p),
            Geometry::Rectangle(r) => r.dpdu_dpdv(),
            Geometry::Curve(c) => c.dpdu_dpdv(its),
        }
    }

    /// Applies a transform in place (meshes bake it; spheres need a similarity).
    pub fn transform(&mut self, t: &Transform) -> Result<(), ShapeError> {
        match self {
            Geometry::Mesh(m) => Ok(m.transform(t)?),
            Geometry::Sphere(s) => Ok(s.transform(t)?),
            Geometry::Disk(d) => d.transform(t).map_err(ShapeError::Disk),
            Geometry::Rectangle(r) => r.transform(t).map_err(ShapeError::Rectangle),
            Geometry::Curve(c) => {
                c.transform(t);
                Ok(())
            }
        }
    }
}

/// A shape that breaks its invariants (the message embeds the shape's
/// own error, so it is no `source()`).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ShapeError {
    #[error("the mesh {0}")]
    Mesh(MeshError),
    #[error("the sphere's {} {}", .0.describe_param(), .0)]
    Sphere(SphereError),
    #[error("the disk {0}")]
    Disk(PlaneError),
    #[error("the rectangle {0}")]
    Rectangle(PlaneError),
}

impl From<MeshError> for ShapeError {
    fn from(e: MeshError) -> Self {
        ShapeError::Mesh(e)
    }
}

impl From<SphereError> for ShapeError {
    fn from(e: SphereError) -> Self {
        ShapeError::Sphere(e)
    }
}

/// The bytes of a mesh file, read within [`crate::limits::MAX_DATA_FILE_BYTES`]
/// (the OBJ, PLY and serialized loaders share it).
fn read_mesh_file(path: &std::path::Path) -> Result<Vec<u8>, MeshFileError> {
    crate::limits::read_file(path, crate::limits::MAX_DATA_FILE_BYTES, "mesh files").map_err(
        |source| MeshFileError::Read {
            path: path.to_path_buf(),
            source,
        },
    )
}

/// A mesh file that cannot be loaded.
#[derive(Debug, thiserror::Error)]
pub enum MeshFileError {
    #[error("cannot read '{}'", path.display())]
    Read {
        path: std::path::PathBuf,
        #[source]
        source: crate::limits::ReadError,
    },
    #[error("cannot read the OBJ file '{}'", path.display())]
    Obj {
        path: std::path::PathBuf,
        #[source]
        source: tobj::LoadError,
    },
    #[error("the OBJ file '{}' is malformed at line {line}: {message}", path.display())]
    ObjFace {
        path: std::path::PathBuf,
        line: usize,
        message: String,
    },
    #[error("the PLY file '{}' is malformed: {message}", path.display())]
    Ply {
        path: std::path::PathBuf,
        message: String,
    },
    #[error("the Mitsuba .serialized file '{}' is malformed: {message}", path.display())]
    Serialized {
        path: std::path::PathBuf,
        message: String,
    },
    #[error("the curve file '{}' is malformed: {error}", path.display())]
    Curve {
        path: std::path::PathBuf,
        error: CurveError,
    },
    #[error("the mesh in '{}' {error}", path.display())]
    Invalid {
        path: std::path::PathBuf,
        error: MeshError,
    },
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
    /// Barycentrics (b1, b2) of the hit in its triangle (zero on spheres).
    pub bary: Vec2,
    /// Index of the shape in the scene.
    pub shape: u32,
    /// The instance hit ([`BvhHit::NO_INSTANCE`] for a top-level shape).
    pub instance: u32,
    /// Triangle index within its mesh (0 for spheres).
    pub prim: u32,
}

impl Intersection {
    /// All zeros: what a buffer of hits holds in slots not yet written
    /// (never read as a surface).
    pub const UNSET: Intersection = Intersection {
        t: 0.0,
        p: Vec3::ZERO,
        err: Vec3::ZERO,
        ng: Vec3::ZERO,
        shading: crate::math::Frame {
            s: Vec3::ZERO,
            t: Vec3::ZERO,
            n: Vec3::ZERO,
        },
        uv: Vec2::ZERO,
        bary: Vec2::ZERO,
        shape: 0,
        instance: 0,
        prim: 0,
    };

    /// Where textures and BSDFs are read.
    #[inline]
    pub fn surface_point(&self) -> crate::texture::SurfacePoint {
        crate::texture::SurfacePoint {
            uv: self.uv,
            prim: self.prim,
            bary: self.bary,
            ..Default::default()
        }
    }

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
    /// The triangle and its barycentrics (zero on spheres): where a
    /// textured emitter reads its radiance.
    pub prim: u32,
    pub bary: Vec2,
}
