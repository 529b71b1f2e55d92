//! Benchmarks: BVH construction, ray casting, and camera samples per second
//! on the example scenes. Run with `cargo bench`.

use std::path::Path;
use std::sync::atomic::AtomicBool;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use lente::geometry::{Bvh, Geometry, TriangleMesh};
use lente::load::load_scene;
use lente::math::{Ray, Vec3};
use lente::render::{render, RenderOptions};
use lente::sampling::{warp, Sampler};
use lente::scene::Scene;

/// A UV sphere with `n` x 2n quads (4 n^2 triangles).
fn uv_sphere(n: usize) -> TriangleMesh {
    let mut p = Vec::new();
    for i in 0..=n {
        let theta = std::f32::consts::PI * i as f32 / n as f32;
        for j in 0..2 * n {
            let phi = std::f32::consts::PI * j as f32 / n as f32;
            p.push(Vec3::new(
                theta.sin() * phi.cos(),
                theta.cos(),
                theta.sin() * phi.sin(),
            ));
        }
    }
    let mut idx = Vec::new();
    let w = 2 * n;
    for i in 0..n {
        for j in 0..w {
            let a = (i * w + j) as u32;
            let b = (i * w + (j + 1) % w) as u32;
            let c = ((i + 1) * w + (j + 1) % w) as u32;
            let d = ((i + 1) * w + j) as u32;
            idx.push([a, b, c]);
            idx.push([a, c, d]);
        }
    }
    TriangleMesh::new(p, Vec::new(), Vec::new(), idx).unwrap()
}

fn bvh(c: &mut Criterion) {
    let mesh = vec![Geometry::Mesh(uv_sphere(400))]; // 640k triangles
    let mut g = c.benchmark_group("bvh");
    g.sample_size(10);
    g.throughput(Throughput::Elements(640_000));
    g.bench_function("build 640k triangles", |b| b.iter(|| Bvh::build(&mesh)));
    let bvh = Bvh::build(&mesh);
    let mut s = Sampler::new(1, 1);
    let rays: Vec<Ray> = (0..100_000)
        .map(|_| {
            let o = warp::square_to_uniform_sphere(s.next_2d()) * 3.0;
            let d = (warp::square_to_uniform_sphere(s.next_2d()) * 0.5 - o).normalize();
            Ray::new(o, d)
        })
        .collect();
    g.throughput(Throughput::Elements(rays.len() as u64));
    g.bench_function("closest hit, 100k rays", |b| {
        b.iter(|| rays.iter().filter(|r| bvh.intersect(r).is_some()).count())
    });
    g.finish();
}

fn samples_per_second(c: &mut Criterion) {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut g = c.benchmark_group("render");
    g.sample_size(10);
    for file in [
        "scenes/cbox/cbox.xml",
        "scenes/envmap/envmap.xml",
        "scenes/showcase/showcase-mirror.xml",
    ] {
        let (mut loaded, _) = load_scene(&root.join(file)).unwrap();
        loaded.scene.camera.width = 128;
        loaded.scene.camera.height = 128;
        loaded.job.spp = 4;
        let scene = Scene::new(loaded.scene).unwrap();
        let opts = RenderOptions::new(0);
        g.throughput(Throughput::Elements(128 * 128 * 4));
        g.bench_function(file, |b| {
            b.iter(|| render(&scene, &loaded.job, &opts, &AtomicBool::new(false)))
        });
    }
    g.finish();
}

criterion_group!(benches, bvh, samples_per_second);
criterion_main!(benches);
