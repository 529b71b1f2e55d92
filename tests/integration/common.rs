//! Scene builders and estimators shared by the integration tests.
#![allow(dead_code)]

use std::path::Path;

use lente::bsdf::Bsdf;
use lente::camera::CameraParams;
use lente::color::{luminance, Rgb};
use lente::emitter::Emitter;
use lente::geometry::{Geometry, Sphere, TriangleMesh};
use lente::image::Filter;
use lente::integrator::{Integrator, PathParams, Strategy};
use lente::load::{load_scene_str, load_scene_str_with, SceneError, SceneFile, Warning};
use lente::math::{Transform, Vec2, Vec3};
use lente::render::RenderJob;
use lente::sampling::Sampler;
use lente::scene::{Scene, SceneDesc, ShapeDesc};
use lente::stats::MeanVar;

/// Where scene text under test is said to come from, unless a test names
/// another path (relative file names resolve against its folder).
pub const TEST_XML: &str = "test.xml";

/// Loads scene text as read from `path`, with `-D` parameters; panics
/// with the error (and its causes) if it does not load.
#[track_caller]
pub fn load_at(text: &str, path: &Path, defines: &[(&str, &str)]) -> (SceneFile, Vec<Warning>) {
    let defines: Vec<(String, String)> = defines
        .iter()
        .map(|(a, b)| (a.to_string(), b.to_string()))
        .collect();
    match load_scene_str_with(text, path, &defines) {
        Ok(r) => r,
        Err(e) => panic!("scene should load: {}\n{text}", e.report()),
    }
}

/// [`load_at`] `test.xml` without parameters.
#[track_caller]
pub fn load(text: &str) -> (SceneFile, Vec<Warning>) {
    load_at(text, Path::new(TEST_XML), &[])
}

/// Loads scene text that must load without warnings.
#[track_caller]
pub fn load_clean_at(text: &str, path: &Path) -> SceneFile {
    let (file, warnings) = load_at(text, path, &[]);
    assert!(warnings.is_empty(), "unexpected warnings: {warnings:?}");
    file
}

/// [`load_clean_at`], built into a scene with the file's integrator.
#[track_caller]
pub fn built_at(text: &str, path: &Path) -> TestScene {
    let file = load_clean_at(text, path);
    TestScene {
        scene: Scene::new(file.scene).unwrap(),
        integrator: file.job.integrator,
    }
}

/// [`load_clean_at`] `test.xml`.
#[track_caller]
pub fn load_clean(text: &str) -> SceneFile {
    load_clean_at(text, Path::new(TEST_XML))
}

/// The error of scene text that must not load.
#[track_caller]
pub fn load_err_at(text: &str, path: &Path) -> SceneError {
    match load_scene_str(text, path) {
        Ok(_) => panic!("scene should not load:\n{text}"),
        Err(e) => e,
    }
}

/// [`load_err_at`] `test.xml`.
#[track_caller]
pub fn load_err(text: &str) -> SceneError {
    load_err_at(text, Path::new(TEST_XML))
}

/// An axis-aligned box [-h, h]^3 with each face split into `n` x `n` quads
/// sharing vertices (so the mesh is closed), triangles facing outwards.
pub fn cube(h: f32, n: usize) -> TriangleMesh {
    let mut positions = Vec::new();
    let mut indices = Vec::new();
    // (normal axis, sign): build each face as a grid over the two other axes.
    for axis in 0..3 {
        for sign in [-1.0f32, 1.0] {
            let (a1, a2) = ((axis + 1) % 3, (axis + 2) % 3);
            let base = positions.len() as u32;
            for i in 0..=n {
                for j in 0..=n {
                    let mut p = [0.0f32; 3];
                    p[axis] = sign * h;
                    p[a1] = -h + 2.0 * h * i as f32 / n as f32;
                    p[a2] = -h + 2.0 * h * j as f32 / n as f32;
                    positions.push(Vec3::from_array(p));
                }
            }
            let idx = |i: usize, j: usize| base + (i * (n + 1) + j) as u32;
            for i in 0..n {
                for j in 0..n {
                    let (a, b, c, d) = (idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1));
                    // a1 x a2 = axis: counter-clockwise in (a1, a2) faces +axis.
                    if sign > 0.0 {
                        indices.push([a, b, c]);
                        indices.push([a, c, d]);
                    } else {
                        indices.push([a, c, b]);
                        indices.push([a, d, c]);
                    }
                }
            }
        }
    }
    weld(positions, indices)
}

/// Merges coincident vertices so faces share edges exactly.
fn weld(positions: Vec<Vec3>, indices: Vec<[u32; 3]>) -> TriangleMesh {
    let mut map = std::collections::HashMap::new();
    let mut out = Vec::new();
    let mut remap = Vec::with_capacity(positions.len());
    for p in &positions {
        let key = (p.x.to_bits(), p.y.to_bits(), p.z.to_bits());
        let id = *map.entry(key).or_insert_with(|| {
            out.push(*p);
            out.len() as u32 - 1
        });
        remap.push(id);
    }
    let indices = indices
        .into_iter()
        .map(|t| t.map(|i| remap[i as usize]))
        .collect();
    TriangleMesh::new(out, Vec::new(), Vec::new(), indices).unwrap()
}

/// Reverses the winding (and normals) of a mesh.
pub fn flipped(mut m: TriangleMesh) -> TriangleMesh {
    m.flip_normals();
    m
}

/// Icosphere of radius `r` with `levels` subdivisions, vertices shared.
pub fn icosphere(r: f32, levels: usize) -> TriangleMesh {
    let t = (1.0 + 5.0f32.sqrt()) / 2.0;
    let mut v: Vec<Vec3> = [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| Vec3::new(x, y, z).normalize())
    .collect();
    let mut f: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..levels {
        let mut mid = std::collections::HashMap::new();
        let mut next = Vec::new();
        let mut midpoint = |a: u32, b: u32, v: &mut Vec<Vec3>| -> u32 {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                v.push(((v[a as usize] + v[b as usize]) * 0.5).normalize());
                v.len() as u32 - 1
            })
        };
        for [a, b, c] in f {
            let ab = midpoint(a, b, &mut v);
            let bc = midpoint(b, c, &mut v);
            let ca = midpoint(c, a, &mut v);
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        f = next;
    }
    let normals = v.clone();
    let positions = v.iter().map(|p| *p * r).collect();
    TriangleMesh::new(positions, normals, Vec::new(), f).unwrap()
}

pub fn path(strategy: Strategy) -> Integrator {
    Integrator::Path {
        strategy,
        params: PathParams::default(),
    }
}

/// A camera at `origin` looking at `target` with +y up (Nori's lookat with
/// the usual `scale -1,1,1`).
pub fn look_at(origin: Vec3, target: Vec3, fov: f32, w: u32, h: u32) -> CameraParams {
    let dir = (target - origin).normalize();
    let left = Vec3::Y.cross(dir).normalize();
    let up = dir.cross(left);
    let m = lente::math::Mat4::from_cols(
        left.extend(0.0),
        up.extend(0.0),
        dir.extend(0.0),
        origin.extend(1.0),
    ) * lente::math::Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0));
    CameraParams {
        width: w,
        height: h,
        fov_x_deg: fov,
        fov_axis: lente::camera::FovAxis::X,
        to_world: Transform::new(m).unwrap(),
        ..Default::default()
    }
}

/// A world description with the integrator a test estimates it with
/// (dereferences to the world, so shapes and emitters are pushed directly).
pub struct TestDesc {
    pub desc: SceneDesc,
    pub integrator: Integrator,
}

impl std::ops::Deref for TestDesc {
    type Target = SceneDesc;
    fn deref(&self) -> &SceneDesc {
        &self.desc
    }
}

impl std::ops::DerefMut for TestDesc {
    fn deref_mut(&mut self) -> &mut SceneDesc {
        &mut self.desc
    }
}

impl TestDesc {
    /// Builds the world.
    pub fn build(self) -> TestScene {
        TestScene {
            scene: Scene::new(self.desc).unwrap(),
            integrator: self.integrator,
        }
    }
}

/// A built world with the integrator a test estimates it with
/// (dereferences to the world).
pub struct TestScene {
    pub scene: Scene,
    pub integrator: Integrator,
}

impl std::ops::Deref for TestScene {
    type Target = Scene;
    fn deref(&self) -> &Scene {
        &self.scene
    }
}

impl TestScene {
    /// Renders `spp` samples per pixel with seed `seed` (box filter).
    pub fn render(&self, spp: u32, seed: u64) -> lente::image::Bitmap {
        let opts = lente::render::RenderOptions::new(seed);
        let never = std::sync::atomic::AtomicBool::new(false);
        lente::render::render(self, &job(self.integrator, spp), &opts, &never).image
    }
}

/// An empty world seen by `camera`, estimated with `integrator`.
pub fn desc(camera: CameraParams, integrator: Integrator) -> TestDesc {
    TestDesc {
        desc: SceneDesc {
            camera,
            shapes: Vec::new(),
            emitters: Vec::new(),
            groups: Vec::new(),
            instances: Vec::new(),
            media: Vec::new(),
            camera_medium: None,
        },
        integrator,
    }
}

/// A render job: `spp` samples of `integrator` through a box filter.
pub fn job(integrator: Integrator, spp: u32) -> RenderJob {
    RenderJob {
        integrator,
        spp,
        sampler: Default::default(),
        filter: Filter::Box { radius: 0.5 },
        aovs: Default::default(),
    }
}

pub fn shape(geometry: Geometry, bsdf: Bsdf, radiance: Option<Rgb>) -> ShapeDesc {
    ShapeDesc {
        geometry,
        bsdf,
        area_radiance: radiance,
        area_texture: None,
        media: Default::default(),
    }
}

pub fn diffuse(a: f32) -> Bsdf {
    Bsdf::Diffuse(lente::bsdf::Diffuse {
        albedo: Rgb::splat(a),
    })
}

pub fn sphere(center: Vec3, radius: f32) -> Geometry {
    Geometry::Sphere(Sphere::new(center, radius).unwrap())
}

/// An independent random stream per (seed, sample index): hashed seeds,
/// since PCG streams that differ only in their increment are correlated.
pub fn stream(seed: u64, i: usize) -> Sampler {
    Sampler::for_pixel_sample(seed, i as u32, (i >> 32) as u32, 0x5a11)
}

/// Nori's `ttest` estimator: `n` camera rays through uniformly random image
/// positions (and aperture samples), mean and variance of the luminance.
pub fn estimate(scene: &TestScene, n: usize, seed: u64) -> MeanVar {
    let (w, h) = (scene.camera.width() as f32, scene.camera.height() as f32);
    let mut mv = MeanVar::default();
    for i in 0..n {
        let mut s = stream(seed, i);
        let film = s.next_2d() * Vec2::new(w, h);
        let ray = scene.camera.generate_ray(film, s.next_2d());
        let l = scene.integrator.li(scene, &ray, &mut s);
        mv.push(luminance(l) as f64);
    }
    mv
}

/// Like [`estimate`] but restricted to a sub-rectangle of the image
/// (fractions of width and height).
pub fn estimate_region(scene: &TestScene, n: usize, seed: u64, lo: Vec2, hi: Vec2) -> MeanVar {
    let (w, h) = (scene.camera.width() as f32, scene.camera.height() as f32);
    let mut mv = MeanVar::default();
    for i in 0..n {
        let mut s = stream(seed, i);
        let f = lo + s.next_2d() * (hi - lo);
        let ray = scene.camera.generate_ray(f * Vec2::new(w, h), s.next_2d());
        let l = scene.integrator.li(scene, &ray, &mut s);
        mv.push(luminance(l) as f64);
    }
    mv
}

pub fn point_light(position: Vec3, power: Rgb) -> Emitter {
    Emitter::Point(lente::emitter::PointLight {
        position,
        intensity: power / (4.0 * std::f32::consts::PI),
    })
}

/// A square of half-width `half` centred at `c` in a plane y = const,
/// facing +y if `y_normal_up`, else -y.
pub fn quad(c: Vec3, half: f32, y_normal_up: bool) -> TriangleMesh {
    let p = vec![
        c + Vec3::new(-half, 0.0, -half),
        c + Vec3::new(half, 0.0, -half),
        c + Vec3::new(half, 0.0, half),
        c + Vec3::new(-half, 0.0, half),
    ];
    let idx = if y_normal_up {
        vec![[0, 2, 1], [0, 3, 2]]
    } else {
        vec![[0, 1, 2], [0, 2, 3]]
    };
    TriangleMesh::new(p, Vec::new(), Vec::new(), idx).unwrap()
}

/// The surface coordinates a BSDF tested on its own is read at (constant
/// parameters do not depend on them).
pub const UV0: lente::math::Vec2 = lente::math::Vec2::ZERO;
