//! Embree 3 (Intel's ray-tracing kernels; Debian's `libembree3-3`), loaded
//! at run time so that `lente bench` can print its closest-hit and any-hit
//! rays per second on the same mesh and the same rays beside lente's. Not
//! a dependency: without the library the bench prints a note instead.
//!
//! Only what a triangle mesh needs: a device, one scene with one triangle
//! geometry, `rtcIntersect1` and `rtcOccluded1` (the single-ray API, as
//! lente traces rays). The structures follow Embree 3's headers
//! (`rtcore_ray.h`, `rtcore_common.h`) for `RTC_MAX_INSTANCE_LEVEL_COUNT`
//! 1, Debian's build; the context is padded so that a build with more
//! instance levels reads our memory, not past it.

use std::ffi::{c_char, c_uint, c_void};
use std::path::Path;

use crate::math::{Ray, Vec3};

type Device = *mut c_void;
type RtcScene = *mut c_void;
type Geometry = *mut c_void;

const GEOMETRY_TYPE_TRIANGLE: c_uint = 0;
const BUFFER_TYPE_INDEX: c_uint = 0;
const BUFFER_TYPE_VERTEX: c_uint = 1;
const FORMAT_UINT3: c_uint = 0x5003;
const FORMAT_FLOAT3: c_uint = 0x9003;
const BUILD_QUALITY_HIGH: c_uint = 2;
const INVALID_ID: c_uint = u32::MAX;

/// `RTCIntersectContext`, zero-filled past the fields Embree 3.13 reads
/// with one instance level.
#[repr(C)]
struct Context {
    flags: c_uint,
    filter: *const c_void,
    inst_id: [c_uint; 8],
}

impl Context {
    /// What `rtcInitIntersectContext` sets: incoherent rays, no filter,
    /// no instance.
    fn new() -> Context {
        Context {
            flags: 0,
            filter: std::ptr::null(),
            inst_id: [INVALID_ID; 8],
        }
    }
}

/// `RTCRay`.
#[repr(C, align(16))]
#[derive(Clone, Copy)]
struct RtcRay {
    org: [f32; 3],
    tnear: f32,
    dir: [f32; 3],
    time: f32,
    tfar: f32,
    mask: c_uint,
    id: c_uint,
    flags: c_uint,
}

/// `RTCHit` (one instance level).
#[repr(C, align(16))]
#[derive(Clone, Copy)]
struct RtcHit {
    ng: [f32; 3],
    u: f32,
    v: f32,
    prim_id: c_uint,
    geom_id: c_uint,
    inst_id: [c_uint; 1],
}

/// `RTCRayHit`.
#[repr(C)]
struct RayHit {
    ray: RtcRay,
    hit: RtcHit,
}

impl RtcRay {
    fn from(ray: &Ray) -> RtcRay {
        RtcRay {
            org: ray.o.to_array(),
            tnear: ray.tmin,
            dir: ray.d.to_array(),
            time: 0.0,
            tfar: ray.tmax,
            mask: u32::MAX,
            id: 0,
            flags: 0,
        }
    }
}

/// Embree 3's C functions this module calls.
struct Api {
    new_device: unsafe extern "C" fn(*const c_char) -> Device,
    release_device: unsafe extern "C" fn(Device),
    device_error: unsafe extern "C" fn(Device) -> c_uint,
    new_scene: unsafe extern "C" fn(Device) -> RtcScene,
    set_build_quality: unsafe extern "C" fn(RtcScene, c_uint),
    commit_scene: unsafe extern "C" fn(RtcScene),
    release_scene: unsafe extern "C" fn(RtcScene),
    new_geometry: unsafe extern "C" fn(Device, c_uint) -> Geometry,
    set_new_buffer:
        unsafe extern "C" fn(Geometry, c_uint, c_uint, c_uint, usize, usize) -> *mut c_void,
    set_geometry_quality: unsafe extern "C" fn(Geometry, c_uint),
    commit_geometry: unsafe extern "C" fn(Geometry),
    attach_geometry: unsafe extern "C" fn(RtcScene, Geometry) -> c_uint,
    release_geometry: unsafe extern "C" fn(Geometry),
    intersect1: unsafe extern "C" fn(RtcScene, *mut Context, *mut RayHit),
    occluded1: unsafe extern "C" fn(RtcScene, *mut Context, *mut RtcRay),
}

/// A triangle mesh committed to Embree, ready for queries from any thread
/// (Embree's committed scenes are safe to query concurrently).
pub struct EmbreeMesh {
    api: Api,
    device: Device,
    scene: RtcScene,
}

// SAFETY: Embree documents rtcIntersect1/rtcOccluded1 on a committed scene
// as thread-safe; the handles are only released in Drop.
unsafe impl Send for EmbreeMesh {}
unsafe impl Sync for EmbreeMesh {}

/// The library's default name: Embree 3's soname.
pub const DEFAULT_LIBRARY: &str = "libembree3.so.3";

impl EmbreeMesh {
    /// Loads Embree 3 from `library` (a bare name goes to the system's
    /// loader) and builds its BVH over the mesh, at Embree's high build
    /// quality (an SAH build, as lente's PLOC + SAH collapse is).
    pub fn build(
        library: &Path,
        positions: &[Vec3],
        indices: &[[u32; 3]],
    ) -> Result<EmbreeMesh, String> {
        let err = |m: String| format!("{}: {m}", library.display());
        // SAFETY: loading runs Embree's static initialisers, which ask
        // nothing of the caller. The library is never unloaded: the
        // worker threads of its task scheduler (TBB) outlive its devices
        // and crash the process once their code is unmapped.
        let lib = unsafe { libloading::Library::new(library) }.map_err(|e| err(e.to_string()))?;
        let lib: &'static libloading::Library = Box::leak(Box::new(lib));
        macro_rules! symbol {
            ($name:literal) => {
                // SAFETY: the type is the function's C signature in Embree
                // 3's headers; `lib` stays loaded for the process's life.
                *unsafe { lib.get(concat!($name, "\0").as_bytes()) }
                    .map_err(|e| err(format!("{}: {e}", $name)))?
            };
        }
        let api = Api {
            new_device: symbol!("rtcNewDevice"),
            release_device: symbol!("rtcReleaseDevice"),
            device_error: symbol!("rtcGetDeviceError"),
            new_scene: symbol!("rtcNewScene"),
            set_build_quality: symbol!("rtcSetSceneBuildQuality"),
            commit_scene: symbol!("rtcCommitScene"),
            release_scene: symbol!("rtcReleaseScene"),
            new_geometry: symbol!("rtcNewGeometry"),
            set_new_buffer: symbol!("rtcSetNewGeometryBuffer"),
            set_geometry_quality: symbol!("rtcSetGeometryBuildQuality"),
            commit_geometry: symbol!("rtcCommitGeometry"),
            attach_geometry: symbol!("rtcAttachGeometry"),
            release_geometry: symbol!("rtcReleaseGeometry"),
            intersect1: symbol!("rtcIntersect1"),
            occluded1: symbol!("rtcOccluded1"),
        };
        let config = c"";
        // SAFETY: plain calls of Embree's C API with handles it returned;
        // the buffers it allocates are filled within their sizes.
        unsafe {
            let device = (api.new_device)(config.as_ptr());
            if device.is_null() {
                return Err(err("rtcNewDevice failed".into()));
            }
            let scene = (api.new_scene)(device);
            let mesh = EmbreeMesh { api, device, scene };
            let api = &mesh.api;
            (api.set_build_quality)(scene, BUILD_QUALITY_HIGH);
            let geometry = (api.new_geometry)(device, GEOMETRY_TYPE_TRIANGLE);
            (api.set_geometry_quality)(geometry, BUILD_QUALITY_HIGH);
            // Embree reads vertices with 16-byte loads: one float of slack.
            let vertices = (api.set_new_buffer)(
                geometry,
                BUFFER_TYPE_VERTEX,
                0,
                FORMAT_FLOAT3,
                12,
                positions.len() + 1,
            ) as *mut f32;
            let triangles = (api.set_new_buffer)(
                geometry,
                BUFFER_TYPE_INDEX,
                0,
                FORMAT_UINT3,
                12,
                indices.len(),
            ) as *mut u32;
            if vertices.is_null() || triangles.is_null() {
                (api.release_geometry)(geometry);
                return Err(err("rtcSetNewGeometryBuffer failed".into()));
            }
            for (i, p) in positions.iter().enumerate() {
                vertices
                    .add(3 * i)
                    .copy_from_nonoverlapping(p.to_array().as_ptr(), 3);
            }
            for (i, t) in indices.iter().enumerate() {
                triangles.add(3 * i).copy_from_nonoverlapping(t.as_ptr(), 3);
            }
            (api.commit_geometry)(geometry);
            (api.attach_geometry)(scene, geometry);
            (api.release_geometry)(geometry);
            (api.commit_scene)(scene);
            match (api.device_error)(device) {
                0 => Ok(mesh),
                code => Err(err(format!("Embree error {code} while building"))),
            }
        }
    }

    /// The closest hit's distance and triangle index.
    pub fn intersect(&self, ray: &Ray) -> Option<(f32, u32)> {
        let mut context = Context::new();
        let mut rh = RayHit {
            ray: RtcRay::from(ray),
            hit: RtcHit {
                ng: [0.0; 3],
                u: 0.0,
                v: 0.0,
                prim_id: INVALID_ID,
                geom_id: INVALID_ID,
                inst_id: [INVALID_ID],
            },
        };
        // SAFETY: a committed scene, and structures laid out as Embree's.
        unsafe { (self.api.intersect1)(self.scene, &mut context, &mut rh) };
        (rh.hit.geom_id != INVALID_ID).then_some((rh.ray.tfar, rh.hit.prim_id))
    }

    /// True if the mesh blocks the ray within its range.
    pub fn occluded(&self, ray: &Ray) -> bool {
        let mut context = Context::new();
        let mut r = RtcRay::from(ray);
        // SAFETY: as in `intersect`; Embree sets tfar to -inf on a hit.
        unsafe { (self.api.occluded1)(self.scene, &mut context, &mut r) };
        r.tfar == f32::NEG_INFINITY
    }
}

impl Drop for EmbreeMesh {
    fn drop(&mut self) {
        // SAFETY: the handles came from this library, which stays loaded.
        unsafe {
            (self.api.release_scene)(self.scene);
            (self.api.release_device)(self.device);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Bvh, Geometry, TriangleMesh};
    use crate::sampling::{warp, Sampler};

    /// A wavy 40 x 40 heightfield over [-1, 1]^2 (3,200 triangles).
    fn heightfield() -> TriangleMesh {
        let n = 41;
        let mut p = Vec::new();
        for j in 0..n {
            for i in 0..n {
                let (x, z) = (i as f32 / 20.0 - 1.0, j as f32 / 20.0 - 1.0);
                p.push(Vec3::new(x, 0.2 * (5.0 * x).sin() * (3.0 * z).cos(), z));
            }
        }
        let mut tris = Vec::new();
        for j in 0..n - 1 {
            for i in 0..n - 1 {
                let a = (j * n + i) as u32;
                let (b, c, d) = (a + 1, a + 1 + n as u32, a + n as u32);
                tris.push([a, b, c]);
                tris.push([a, c, d]);
            }
        }
        TriangleMesh::new(p, vec![], vec![], tris).unwrap()
    }

    /// Embree and lente find the same closest hits and the same occlusions
    /// on random rays through a heightfield (where Embree is installed;
    /// CI installs it and fails without it).
    #[test]
    fn embree_answers_what_lente_answers() {
        let mesh = heightfield();
        let embree =
            match EmbreeMesh::build(Path::new(DEFAULT_LIBRARY), mesh.positions(), mesh.indices()) {
                Ok(e) => e,
                Err(why) if std::env::var_os("CI").is_some() => panic!("CI is set: {why}"),
                Err(why) => {
                    eprintln!("skipped: {why}");
                    return;
                }
            };
        let bvh = Bvh::build(&[Geometry::Mesh(mesh)]);
        let mut s = Sampler::new(3, 0);
        let (mut hits, mut blocked) = (0, 0);
        for _ in 0..20_000 {
            let o = warp::square_to_uniform_sphere(s.next_2d()) * 2.0;
            let target = Vec3::new(2.0 * s.next_1d() - 1.0, 0.0, 2.0 * s.next_1d() - 1.0);
            let d = (target - o).normalize();
            let ray = Ray::with_range(o, d, 0.0, 1.0 + 2.0 * s.next_1d());
            let (a, b) = (bvh.intersect(&ray), embree.intersect(&ray));
            match (a, b) {
                (None, None) => {}
                (Some(a), Some((t, tri))) => {
                    hits += 1;
                    assert!(
                        a.index == tri || (a.t - t).abs() < 1e-5,
                        "{ray:?}: lente {a:?}, Embree t {t} triangle {tri}"
                    );
                    assert!((a.t - t).abs() < 1e-4 * t.max(1.0));
                }
                (a, b) => panic!("{ray:?}: lente {a:?}, Embree {b:?}"),
            }
            let occluded = embree.occluded(&ray);
            assert_eq!(occluded, bvh.occluded(&ray), "{ray:?}");
            blocked += usize::from(occluded);
        }
        // Rays of random length: both answers occur often.
        assert!(
            hits > 2_000 && blocked > 2_000 && blocked < 18_000,
            "{hits} {blocked}"
        );
    }
}
