//! The renderable scene: geometry with its BVH, BSDFs, emitters and the
//! camera, built from a [`SceneDesc`] (what a scene file describes).

use crate::bsdf::Bsdf;
use crate::camera::Camera;
use crate::color::Rgb;
use crate::emitter::{AreaLight, Emitter, EmitterContext, EnvPoint, LightChoice, LightPdf};
use crate::geometry::{Bvh, BvhHit, Geometry, Instance, Intersection};
use crate::math::{Aabb, Ray, Vec3};
use crate::medium::{Medium, MediumInterface};

/// A shape as a scene file describes it.
#[derive(Clone, Debug)]
pub struct ShapeDesc {
    pub geometry: Geometry,
    pub bsdf: Bsdf,
    /// Radiance if the shape is an area light (a texture's mean when
    /// `area_texture` is set).
    pub area_radiance: Option<Rgb>,
    /// Radiance varying over the surface (Mitsuba's textured `area`).
    pub area_texture: Option<crate::texture::Texture>,
    /// The media inside and outside it (indices into [`SceneDesc::media`]).
    pub media: MediumInterface,
}

/// The world a scene file describes, before acceleration structures.
#[derive(Clone, Debug)]
pub struct SceneDesc {
    pub camera: crate::camera::CameraParams,
    pub shapes: Vec<ShapeDesc>,
    /// Emitters that are not attached to shapes (point, constant, environment).
    pub emitters: Vec<Emitter>,
    /// Shape groups (Mitsuba's `shapegroup`): shapes that appear only where
    /// instances place them, in the groups' own space, never emitters.
    pub groups: Vec<Vec<ShapeDesc>>,
    /// Placements of the groups.
    pub instances: Vec<Instance>,
    /// Participating media, named by shapes' [`MediumInterface`]s.
    pub media: Vec<Medium>,
    /// The medium the camera sits in.
    pub camera_medium: Option<u32>,
}

/// The world, ready to render: geometry and its BVH, BSDFs, emitters and
/// the camera. What to compute from it is a [`crate::render::RenderJob`].
pub struct Scene {
    pub camera: Camera,
    /// The top-level shapes, then each group's shapes (in the group's space).
    pub geometry: Vec<Geometry>,
    /// Each shape group's range of `geometry` (the top-level shapes are
    /// those before the first); the BVH holds the groups' placements.
    pub group_shapes: Vec<std::ops::Range<usize>>,
    pub bsdfs: Vec<Bsdf>,
    /// For each shape, whether its BSDF reads dp/du and dp/dv (bump maps).
    pub differentials: Vec<bool>,
    /// For each shape, the index of its area emitter.
    pub shape_emitter: Vec<Option<u32>>,
    pub emitters: Vec<Emitter>,
    /// Indices of emitters at infinity (seen by escaping rays).
    pub infinite: Vec<u32>,
    /// Chooses the emitter to sample from a shading point.
    pub light_choice: Option<LightChoice>,
    /// Some emitter at infinity is an environment map. Only then are light
    /// samples worth prefetching when their numbers are drawn
    /// (`LightNumbers::draw_ahead`; elsewhere there is nothing to fetch,
    /// and finding which emitter the numbers choose was wasted), and only
    /// then do new rays have a point to be located at
    /// ([`Scene::locate_escape`], the batch's last stage).
    pub has_environment_map: bool,
    pub bvh: Bvh,
    pub bounds: Aabb,
    pub scene_radius: f32,
    /// Participating media (only `volpath` sees them).
    pub media: Vec<Medium>,
    /// For each shape, the media on its two sides.
    pub shape_media: Vec<MediumInterface>,
    /// The medium the camera sits in.
    pub camera_medium: Option<u32>,
}

impl Scene {
    /// Builds the acceleration structure and light tables. Fails if the
    /// camera parameters are invalid, or if the camera asks for autofocus
    /// and its optical axis hits nothing.
    pub fn new(desc: SceneDesc) -> Result<Scene, BuildError> {
        let mut geometry = Vec::new();
        let mut bsdfs = Vec::new();
        let mut shape_emitter = Vec::new();
        let mut emitters = Vec::new();
        let top = desc.shapes.len();
        let mut group_ranges = Vec::new();
        for (g, group) in desc.groups.iter().enumerate() {
            if let Some(k) = group.iter().position(|s| s.area_radiance.is_some()) {
                return Err(BuildError::EmitterInGroup { group: g, shape: k });
            }
            let start = group_ranges
                .last()
                .map_or(top, |r: &std::ops::Range<usize>| r.end);
            group_ranges.push(start..start + group.len());
        }
        if let Some(i) = desc
            .instances
            .iter()
            .position(|i| i.group as usize >= desc.groups.len())
        {
            return Err(BuildError::NoSuchGroup(i));
        }
        let all = desc
            .shapes
            .into_iter()
            .chain(desc.groups.into_iter().flatten());
        let n_media = desc.media.len();
        let check_medium = |m: Option<u32>| match m {
            Some(i) if i as usize >= n_media => Err(BuildError::NoSuchMedium(i)),
            _ => Ok(()),
        };
        check_medium(desc.camera_medium)?;
        let mut shape_media = Vec::new();
        for (i, s) in all.enumerate() {
            if s.area_radiance.is_some() && matches!(s.geometry, Geometry::Curve(_)) {
                return Err(BuildError::CurveEmitter(i));
            }
            check_medium(s.media.interior)?;
            check_medium(s.media.exterior)?;
            shape_media.push(s.media);
            bsdfs.push(s.bsdf);
            let emitter = match s.area_radiance {
                Some(radiance) => {
                    let light = match s.area_texture {
                        Some(t) => AreaLight::textured(i as u32, t),
                        None => AreaLight::new(i as u32, radiance),
                    }
                    .map_err(|e| BuildError::AreaLight(i, e))?
                    .with_triangles(&s.geometry);
                    emitters.push(Emitter::Area(light));
                    Some((emitters.len() - 1) as u32)
                }
                None => None,
            };
            shape_emitter.push(emitter);
            geometry.push(s.geometry);
        }
        emitters.extend(desc.emitters);
        let bvh = Bvh::build_instanced(&geometry, top, &group_ranges, desc.instances);
        let mut bounds = bvh.bounds();
        for e in &emitters {
            match e {
                Emitter::Point(light) => bounds = bounds.extend(light.position),
                Emitter::Spot(light) => bounds = bounds.extend(light.position),
                Emitter::Projector(light) => bounds = bounds.extend(light.position),
                _ => {}
            }
        }
        let scene_radius = if bounds.is_empty() {
            1.0
        } else {
            (0.5 * bounds.diagonal().length()).max(1e-3)
        };
        let infinite: Vec<u32> = emitters
            .iter()
            .enumerate()
            .filter(|(_, e)| e.is_infinite())
            .map(|(i, _)| i as u32)
            .collect();
        let ctx = EmitterContext {
            shapes: &geometry,
            scene_radius,
        };
        let light_choice = LightChoice::new(&emitters, &ctx);
        let has_environment_map = (infinite.iter())
            .any(|&i: &u32| matches!(emitters[i as usize], Emitter::Environment(_)));
        let camera = if desc.camera.autofocus {
            Camera::new(autofocus(desc.camera, &bvh, &geometry)?)?
        } else {
            Camera::new(desc.camera)?
        };
        let differentials = bsdfs.iter().map(Bsdf::needs_differentials).collect();
        Ok(Scene {
            camera,
            geometry,
            group_shapes: group_ranges,
            bsdfs,
            differentials,
            shape_emitter,
            emitters,
            infinite,
            light_choice,
            has_environment_map,
            bvh,
            bounds,
            scene_radius,
            media: desc.media,
            shape_media,
            camera_medium: desc.camera_medium,
        })
    }

    /// Where the BSDF of the shape hit is read: uv, triangle and
    /// barycentrics, and for bump maps dp/du, dp/dv and the geometric
    /// normal in the shading frame.
    #[inline]
    pub fn surface_point(&self, its: &Intersection) -> crate::texture::SurfacePoint {
        let mut at = crate::texture::SurfacePoint::default();
        self.set_surface_point(&mut at, its);
        at
    }

    /// [`Scene::surface_point`] stored into `at`, where the caller keeps
    /// it. (Returned, the point was built on the stack and copied by
    /// loads that straddled the stores just made: a stall per bounce.)
    #[inline(always)]
    pub fn set_surface_point(&self, at: &mut crate::texture::SurfacePoint, its: &Intersection) {
        *at = its.surface_point();
        if self.differentials[its.shape as usize] {
            self.add_differentials(its, at);
        }
    }

    /// The bump-map part of [`Scene::surface_point`].
    #[inline(never)]
    fn add_differentials(&self, its: &Intersection, at: &mut crate::texture::SurfacePoint) {
        let shape = &self.geometry[its.shape as usize];
        let (dp_du, dp_dv) = if its.instance == BvhHit::NO_INSTANCE {
            shape.dpdu_dpdv(its)
        } else {
            let to_world = self.bvh.instance(its.instance).to_world;
            let local = Intersection {
                p: to_world.inverse().point(its.p),
                ..*its
            };
            let (du, dv) = shape.dpdu_dpdv(&local);
            (to_world.vector(du), to_world.vector(dv))
        };
        at.dp_du = its.shading.to_local(dp_du);
        at.dp_dv = its.shading.to_local(dp_dv);
        at.ng = its.shading.to_local(its.ng);
    }

    /// The shading point `p` with normal `n` as the light choice sees it.
    pub fn choice_point(&self, p: Vec3, n: Vec3) -> crate::emitter::ChoicePoint {
        let mut at = crate::emitter::ChoicePoint::default();
        self.set_choice_point(&mut at, p, n, None, true);
        at
    }

    /// [`Scene::choice_point`] with its `facing` normal, stored into `at`
    /// ([`crate::emitter::LightChoice::set_at`]). Unless `weigh`, only
    /// placed ([`crate::emitter::ChoicePoint::place`]): the caller weighs
    /// the lights itself, several points at once
    /// ([`crate::emitter::LightChoice::weigh_points`]).
    #[inline]
    pub fn set_choice_point(
        &self,
        at: &mut crate::emitter::ChoicePoint,
        p: Vec3,
        n: Vec3,
        facing: Option<Vec3>,
        weigh: bool,
    ) {
        match &self.light_choice {
            Some(c) if weigh => c.set_at(at, p, n, facing),
            Some(_) => crate::emitter::ChoicePoint::place(at, p, n, facing),
            None => *at = crate::emitter::ChoicePoint::default().facing(facing),
        }
    }

    pub fn emitter_context(&self) -> EmitterContext<'_> {
        EmitterContext {
            shapes: &self.geometry,
            scene_radius: self.scene_radius,
        }
    }

    /// Closest surface along the ray.
    pub fn intersect(&self, ray: &Ray) -> Option<Intersection> {
        let hit = self.bvh.intersect(ray)?;
        Some(hit_intersection(&self.bvh, &self.geometry, ray, &hit))
    }

    /// [`Scene::intersect`] writing the hit into `out` (left as it was if
    /// there is none): a batch keeps its paths' hits in place rather than
    /// copying a 108-byte `Option` twice per ray.
    #[inline]
    pub fn intersect_into(&self, ray: &Ray, out: &mut Intersection) -> bool {
        let Some(hit) = self.bvh.intersect(ray) else {
            return false;
        };
        hit_intersection_into(&self.bvh, &self.geometry, ray, &hit, out);
        true
    }

    /// Whether [`Scene::intersect_packet_into`] traces its rays together
    /// (a small scene on a CPU with AVX2: [`Bvh::walks_packets`]).
    pub fn walks_packets(&self) -> bool {
        self.bvh.walks_packets()
    }

    /// [`Scene::intersect_into`] of each of `rays` (at most
    /// [`crate::geometry::PACKET_LANES`]): `found[k]` says whether ray `k`
    /// meets a surface, and the surfaces met are written to `out` in the
    /// rays' order; returns how many. The rays are traced by one walk of
    /// the packet where [`Scene::walks_packets`] (ties of two surfaces at
    /// exactly one distance aside, the same surfaces).
    #[inline]
    pub fn intersect_packet_into(
        &self,
        rays: &[Ray],
        found: &mut [bool],
        out: &mut [Intersection],
    ) -> usize {
        let mut hits = [None; crate::geometry::PACKET_LANES];
        self.bvh.intersect_packet(rays, &mut hits);
        let mut n = 0;
        for (k, (hit, f)) in hits
            .iter()
            .zip(found.iter_mut())
            .enumerate()
            .take(rays.len())
        {
            *f = hit.is_some();
            if let Some(hit) = hit {
                hit_intersection_into(&self.bvh, &self.geometry, &rays[k], hit, &mut out[n]);
                n += 1;
            }
        }
        n
    }

    /// True if something blocks the segment between two points, each moved
    /// off its surface by [`crate::math::offset_ray_origin`] beforehand.
    pub fn occluded_segment(&self, from: Vec3, to: Vec3) -> bool {
        let ray = Ray::with_range(from, to - from, 0.0, Scene::SEGMENT_END);
        self.bvh.occluded(&ray)
    }

    /// True if the light sample `ls` taken from the surface point `its` is
    /// not blocked (both ends moved off their surfaces).
    pub fn unoccluded(&self, its: &Intersection, ls: &crate::emitter::LightSample) -> bool {
        !self.bvh.occluded(&Scene::shadow_ray(its, ls))
    }

    /// The ray [`Scene::unoccluded`] tests: from `its` towards the light
    /// sample, both ends moved off their surfaces (the rays of
    /// [`Scene::occluded_ray`] and [`Scene::occluded_segment`]).
    #[inline]
    pub fn shadow_ray(its: &Intersection, ls: &crate::emitter::LightSample) -> Ray {
        let from = its.spawn(ls.wi);
        if ls.dist.is_infinite() {
            Ray::new(from, ls.wi)
        } else {
            let to = if ls.n == Vec3::ZERO {
                ls.p
            } else {
                crate::math::offset_ray_origin(ls.p, ls.err, ls.n, -ls.wi)
            };
            Ray::with_range(from, to - from, 0.0, Scene::SEGMENT_END)
        }
    }

    /// Where a segment's ray stops short of its far end (a fraction of
    /// its length).
    const SEGMENT_END: f32 = 1.0 - 1e-4;

    /// Whether something blocks each of `rays` (at most
    /// [`crate::geometry::PACKET_LANES`]), into `blocked`: one walk of the
    /// packet where [`Scene::walks_packets`], the same answers.
    #[inline]
    pub fn occluded_packet(&self, rays: &[Ray], blocked: &mut [bool]) {
        self.bvh.occluded_packet(rays, blocked);
    }

    /// True if something blocks the ray towards infinity.
    pub fn occluded_ray(&self, from: Vec3, d: Vec3) -> bool {
        self.bvh.occluded(&Ray::new(from, d))
    }

    /// The first environment map among the emitters at infinity, and where
    /// `d` meets it, with what evaluating it there with `which` reads
    /// prefetched ([`Emitter::locate_escape`]): for a path about to trace
    /// a ray along `d` that may escape to it.
    #[inline]
    pub fn locate_escape(&self, d: Vec3, which: LightPdf) -> Option<(u32, EnvPoint)> {
        self.infinite
            .iter()
            .find_map(|&i| Some((i, self.emitters[i as usize].locate_escape(d, which)?)))
    }

    /// [`Scene::locate_escape`] of four directions, their angles on the
    /// map in SIMD lanes ([`EnvMap::locate_lanes`](crate::emitter::EnvMap::locate_lanes)):
    /// the same points.
    #[inline]
    pub fn locate_escape_lanes(
        &self,
        d: [&Vec3; 4],
        which: LightPdf,
    ) -> [Option<(u32, EnvPoint)>; 4] {
        let first_map = self
            .infinite
            .iter()
            .find_map(|&i| match &self.emitters[i as usize] {
                Emitter::Environment(e) => Some((i, e)),
                _ => None,
            });
        let Some((i, map)) = first_map else {
            return [None; 4];
        };
        let at = map.locate_lanes(d);
        std::array::from_fn(|k| match at[k] {
            Some(at) => {
                map.prefetch_point(at, which);
                Some((i, at))
            }
            // Bad input: whatever the scalar search makes of it.
            None => self.locate_escape(*d[k], which),
        })
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
                Geometry::Mesh(m) => m.triangle_count(),
                Geometry::Sphere(_)
                | Geometry::Disk(_)
                | Geometry::Rectangle(_)
                | Geometry::Curve(_) => 0,
            })
            .sum()
    }
}

/// Why a scene description cannot become a scene.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum BuildError {
    #[error("the camera's {} {}", .0.param().describe(), .0)]
    Camera(crate::camera::CameraError),
    #[error("autofocus: the ray through the image centre hits nothing")]
    NothingToFocusOn,
    #[error("the area light on shape {0}: its radiance {1}")]
    AreaLight(usize, crate::emitter::EmitterError),
    #[error("shape {0} is a curve, which cannot be an area light (nor can it in Mitsuba)")]
    CurveEmitter(usize),
    #[error("shape {shape} of shape group {group} is an emitter; groups cannot hold emitters")]
    EmitterInGroup { group: usize, shape: usize },
    #[error("instance {0} places a shape group that does not exist")]
    NoSuchGroup(usize),
    #[error("a medium index ({0}) names no medium of the scene")]
    NoSuchMedium(u32),
}

/// The world-space surface point of a BVH hit (through its instance's
/// transform if it has one).
fn hit_intersection(bvh: &Bvh, geometry: &[Geometry], ray: &Ray, hit: &BvhHit) -> Intersection {
    let mut its = Intersection::UNSET;
    hit_intersection_into(bvh, geometry, ray, hit, &mut its);
    its
}

/// [`hit_intersection`] written into `out` by the shape itself: the
/// record is stored field by field where it stays, not built on the stack
/// and copied in 16-byte pieces, whose loads of the smaller stores just
/// made could not be forwarded (a stall `perf` put at 2.5% of a Cornell
/// box render).
#[inline]
fn hit_intersection_into(
    bvh: &Bvh,
    geometry: &[Geometry],
    ray: &Ray,
    hit: &BvhHit,
    out: &mut Intersection,
) {
    let shape = &geometry[hit.shape as usize];
    if hit.instance == BvhHit::NO_INSTANCE {
        shape.intersection_into(ray, hit, out);
    } else {
        let instance = bvh.instance(hit.instance);
        let local = shape.intersection(&instance.to_local(ray), hit);
        *out = instance.to_world(&local, hit.instance);
    }
}

impl From<crate::camera::CameraError> for BuildError {
    fn from(e: crate::camera::CameraError) -> Self {
        BuildError::Camera(e)
    }
}

/// The camera with its focal distance set to the camera-space depth of
/// the first surface the pinhole ray through the image centre hits.
fn autofocus(
    mut params: crate::camera::CameraParams,
    bvh: &Bvh,
    geometry: &[Geometry],
) -> Result<crate::camera::CameraParams, BuildError> {
    let pinhole = Camera::new(crate::camera::CameraParams {
        lens_radius: 0.0,
        ..params.clone()
    })?;
    let centre = crate::math::Vec2::new(0.5 * params.width as f32, 0.5 * params.height as f32);
    let ray = pinhole.generate_ray(centre, crate::math::Vec2::ZERO);
    let hit = bvh.intersect(&ray).ok_or(BuildError::NothingToFocusOn)?;
    let p = hit_intersection(bvh, geometry, &ray, &hit).p;
    params.focal_distance = params.to_world.inverse().point(p).z;
    params.autofocus = false;
    Ok(params)
}
