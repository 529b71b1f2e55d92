//! The renderable scene: geometry with its BVH, BSDFs, emitters and the
//! camera, built from a [`SceneDesc`] (what a scene file describes).

use std::path::PathBuf;

use crate::bsdf::Bsdf;
use crate::camera::Camera;
use crate::color::Rgb;
use crate::emitter::{Emitter, EmitterContext};
use crate::geometry::{Bvh, Geometry, Intersection};
use crate::image::Filter;
use crate::integrator::Integrator;
use crate::math::{Aabb, Frame, Ray, Vec3};
use crate::sampling::Distribution1D;

/// A shape as a scene file describes it.
#[derive(Clone, Debug)]
pub struct ShapeDesc {
    pub geometry: Geometry,
    pub bsdf: Bsdf,
    /// Radiance if the shape is an area light.
    pub area_radiance: Option<Rgb>,
}

/// Everything a scene file describes, before acceleration structures.
#[derive(Clone, Debug)]
pub struct SceneDesc {
    pub camera: crate::camera::CameraParams,
    pub filter: Filter,
    pub spp: u32,
    pub integrator: Integrator,
    pub shapes: Vec<ShapeDesc>,
    /// Emitters that are not attached to shapes (point, constant, environment).
    pub emitters: Vec<Emitter>,
    /// The file the scene came from (outputs go next to it).
    pub source: PathBuf,
}

/// A scene ready to render.
pub struct Scene {
    pub camera: Camera,
    pub filter: Filter,
    pub spp: u32,
    pub integrator: Integrator,
    pub geometry: Vec<Geometry>,
    pub bsdfs: Vec<Bsdf>,
    /// For each shape, the index of its area emitter.
    pub shape_emitter: Vec<Option<u32>>,
    pub emitters: Vec<Emitter>,
    /// Indices of emitters at infinity (seen by escaping rays).
    pub infinite: Vec<u32>,
    /// Chooses an emitter in proportion to its estimated power.
    pub light_choice: Option<Distribution1D>,
    pub bvh: Bvh,
    pub bounds: Aabb,
    pub scene_radius: f32,
    pub source: PathBuf,
}

impl Scene {
    /// Builds the acceleration structure and light tables. Fails only if
    /// the camera asks for autofocus and its optical axis hits nothing.
    pub fn new(desc: SceneDesc) -> Result<Scene, String> {
        let mut geometry = Vec::new();
        let mut bsdfs = Vec::new();
        let mut shape_emitter = Vec::new();
        let mut emitters = Vec::new();
        for (i, s) in desc.shapes.into_iter().enumerate() {
            geometry.push(s.geometry);
            bsdfs.push(s.bsdf);
            shape_emitter.push(s.area_radiance.map(|radiance| {
                emitters.push(Emitter::Area {
                    shape: i as u32,
                    radiance,
                });
                (emitters.len() - 1) as u32
            }));
        }
        emitters.extend(desc.emitters);
        let bvh = Bvh::build(&geometry);
        let mut bounds = bvh.bounds();
        for e in &emitters {
            if let Emitter::Point { position, .. } = e {
                bounds = bounds.extend(*position);
            }
        }
        let scene_radius = if bounds.is_empty() {
            1.0
        } else {
            (0.5 * bounds.diagonal().length()).max(1e-3)
        };
        let infinite = emitters
            .iter()
            .enumerate()
            .filter(|(_, e)| e.is_infinite())
            .map(|(i, _)| i as u32)
            .collect();
        let ctx = EmitterContext {
            shapes: &geometry,
            scene_radius,
        };
        let powers: Vec<f32> = emitters.iter().map(|e| e.power(&ctx)).collect();
        let light_choice = if powers.iter().any(|&p| p > 0.0) {
            Some(Distribution1D::new(&powers))
        } else {
            None
        };
        let mut scene = Scene {
            camera: Camera::new(desc.camera),
            filter: desc.filter,
            spp: desc.spp,
            integrator: desc.integrator,
            geometry,
            bsdfs,
            shape_emitter,
            emitters,
            infinite,
            light_choice,
            bvh,
            bounds,
            scene_radius,
            source: desc.source,
        };
        if scene.camera.params.autofocus {
            scene.autofocus()?;
        }
        Ok(scene)
    }

    /// Sets the focal distance to the camera-space depth of the first
    /// surface hit by the pinhole ray through the image centre.
    fn autofocus(&mut self) -> Result<(), String> {
        let mut params = self.camera.params.clone();
        params.lens_radius = 0.0;
        let pinhole = Camera::new(params.clone());
        let centre = crate::math::Vec2::new(0.5 * params.width as f32, 0.5 * params.height as f32);
        let ray = pinhole.generate_ray(centre, crate::math::Vec2::ZERO);
        let its = self.intersect(&ray).ok_or_else(|| {
            "autofocus: the ray through the image centre hits nothing".to_string()
        })?;
        let p_cam = params.to_world.inverse().point(its.p);
        let mut focused = self.camera.params.clone();
        focused.focal_distance = p_cam.z;
        focused.autofocus = false;
        self.camera = Camera::new(focused);
        Ok(())
    }

    pub fn emitter_context(&self) -> EmitterContext<'_> {
        EmitterContext {
            shapes: &self.geometry,
            scene_radius: self.scene_radius,
        }
    }

    /// Closest surface along the ray.
    pub fn intersect(&self, ray: &Ray) -> Option<Intersection> {
        let h = self.bvh.intersect(ray)?;
        let p = ray.at(h.t);
        let (ng, ns, dpdu, uv, p, err) = match &self.geometry[h.shape as usize] {
            Geometry::Mesh(m) => {
                let tri = h.index as usize;
                let ng = m.geometric_normal(tri);
                let (ns, uv) = m.shading(tri, h.b1, h.b2);
                // Recompute the point from barycentrics: more precise than o + t d.
                let [a, b, c] = m.vertices(tri);
                let b0 = 1.0 - h.b1 - h.b2;
                let pb = a * b0 + b * h.b1 + c * h.b2;
                let err = crate::math::barycentric_error(b0, h.b1, h.b2, a, b, c);
                (ng, ns, m.dpdu(tri), uv, pb, err)
            }
            Geometry::Sphere(s) => {
                let (n, uv) = s.normal_uv(p);
                // Reproject onto the surface to remove the error of o + t d.
                let pp = s.center + n * s.radius;
                (n, n, s.dpdu(n), uv, pp, s.point_error(n))
            }
        };
        // The geometric normal defines the front side; orient it to agree
        // with the shading normal so emission and shading see one surface.
        let ng = if ng.dot(ns) < 0.0 { -ng } else { ng };
        Some(Intersection {
            t: h.t,
            p,
            err,
            ng,
            shading: Frame::from_normal_tangent(ns, dpdu),
            uv,
            shape: h.shape,
        })
    }

    /// True if something blocks the segment between two points, each moved
    /// off its surface by [`crate::math::offset_ray_origin`] beforehand.
    pub fn occluded_segment(&self, from: Vec3, to: Vec3) -> bool {
        let ray = Ray::with_range(from, to - from, 0.0, 1.0 - 1e-4);
        self.bvh.occluded(&ray)
    }

    /// True if the light sample `ls` taken from the surface point `its` is
    /// not blocked (both ends moved off their surfaces).
    pub fn unoccluded(&self, its: &Intersection, ls: &crate::emitter::LightSample) -> bool {
        let from = its.spawn(ls.wi);
        if ls.dist.is_infinite() {
            !self.occluded_ray(from, ls.wi)
        } else if ls.n == Vec3::ZERO {
            !self.occluded_segment(from, ls.p)
        } else {
            let to = crate::math::offset_ray_origin(ls.p, ls.err, ls.n, -ls.wi);
            !self.occluded_segment(from, to)
        }
    }

    /// True if something blocks the ray towards infinity.
    pub fn occluded_ray(&self, from: Vec3, d: Vec3) -> bool {
        self.bvh.occluded(&Ray::new(from, d))
    }

    /// Radiance from emitters at infinity along an escaping direction.
    pub fn eval_infinite(&self, d: Vec3) -> Rgb {
        self.infinite
            .iter()
            .map(|&i| self.emitters[i as usize].eval_infinite(d))
            .sum()
    }

    /// Number of triangles in all meshes.
    pub fn triangle_count(&self) -> usize {
        self.geometry
            .iter()
            .map(|g| match g {
                Geometry::Mesh(m) => m.indices.len(),
                Geometry::Sphere(_) => 0,
            })
            .sum()
    }
}
