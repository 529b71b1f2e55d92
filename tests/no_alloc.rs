//! The per-ray path allocates nothing: camera rays, every integrator, and
//! film splatting run under a counting allocator.

use std::alloc::{GlobalAlloc, Layout, System};
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};

use lente::image::FilmBlock;
use lente::integrator::{Integrator, PathBatch, PathParams, Strategy, BATCH_PATHS};
use lente::load::load_scene;
use lente::math::{Vec2, Vec3};
use lente::sampling::Sampler;
use lente::scene::Scene;

struct Counting;

static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);

thread_local! {
    /// Only allocations made by the thread under test count (the test
    /// harness's own threads allocate when they please).
    static COUNTING: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

fn count() {
    if COUNTING.with(|c| c.get()) {
        ALLOCATIONS.fetch_add(1, Ordering::SeqCst);
    }
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        count();
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        count();
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn rendering_samples_allocates_nothing() {
    COUNTING.with(|c| c.set(true));
    // The counter counts (the test can fail).
    let c0 = ALLOCATIONS.load(Ordering::SeqCst);
    let v = std::hint::black_box(vec![0u8; 10]);
    assert!(ALLOCATIONS.load(Ordering::SeqCst) > c0 && v.len() == 10);

    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let integrators = [
        Integrator::Normals,
        Integrator::Ao {
            length: f32::INFINITY,
        },
        Integrator::AverageVisibility { length: 1.0 },
        Integrator::Simple {
            position: Vec3::new(0.0, 1.5, 0.0),
            energy: Vec3::splat(10.0),
        },
        Integrator::Whitted,
        Integrator::Direct {
            strategy: Strategy::Mis,
        },
        Integrator::Path {
            strategy: Strategy::Mats,
            params: PathParams::default(),
        },
        Integrator::Path {
            strategy: Strategy::Ems,
            params: PathParams::default(),
        },
        Integrator::Path {
            strategy: Strategy::Mis,
            params: PathParams::default(),
        },
    ];
    for file in [
        "scenes/cbox/cbox.xml",
        "scenes/envmap/envmap.xml",
        "scenes/dof/dof.xml",
    ] {
        for integrator in integrators {
            let (loaded, _) = load_scene(&root.join(file)).unwrap();
            let scene = Scene::new(loaded.scene).unwrap();
            let mut block = FilmBlock::new(0, 0, 16, 16, loaded.job.filter);
            let before = ALLOCATIONS.load(Ordering::SeqCst);
            for i in 0..20_000u32 {
                let mut s = Sampler::for_pixel_sample(1, i % 16, i / 16 % 16, i);
                let film = Vec2::new((i % 16) as f32, (i / 16 % 16) as f32) + s.next_2d();
                let ray = scene.camera.generate_ray(film, s.next_2d());
                let l = integrator.li(&scene, &ray, &mut s);
                block.put(film, l);
            }
            let n = ALLOCATIONS.load(Ordering::SeqCst) - before;
            assert_eq!(n, 0, "{file} with {}: {n} allocations", integrator.name());

            // The path tracer's batches: their buffers grow in the first
            // batch of a render unit and are reused after it.
            let Some(cfg) = integrator.path_config() else {
                continue;
            };
            let mut batch = PathBatch::new();
            let mut rays = Vec::with_capacity(BATCH_PATHS);
            let mut samplers = Vec::with_capacity(BATCH_PATHS);
            let mut out = vec![Vec3::ZERO; BATCH_PATHS];
            for round in 0..20u32 {
                let before = ALLOCATIONS.load(Ordering::SeqCst);
                rays.clear();
                samplers.clear();
                for i in 0..BATCH_PATHS as u32 {
                    let mut s = Sampler::for_pixel_sample(2, i % 16, i / 16 % 16, round);
                    let film = Vec2::new((i % 16) as f32, (i / 16 % 16) as f32) + s.next_2d();
                    rays.push(scene.camera.generate_ray(film, s.next_2d()));
                    samplers.push(s);
                }
                batch.radiance(&scene, &cfg, &rays, &mut samplers, &mut out);
                let n = ALLOCATIONS.load(Ordering::SeqCst) - before;
                if round > 0 {
                    assert_eq!(
                        n,
                        0,
                        "{file} with {}, batch {round}: {n} allocations",
                        integrator.name()
                    );
                }
            }
        }
    }
}
