//! The GPU backend: the same scenes rendered by compute shaders through
//! wgpu (Vulkan, Metal, DX12; no vendor extensions), for
//! `lente render --device gpu`.
//!
//! A pass runs two kernels: `path.wgsl` traces one path per thread for
//! every pixel sample of the pass and writes its radiance and position in
//! the pixel; `film.wgsl` then has each pixel gather the filter-weighted
//! samples around it, in a fixed order, into the film. The film is the CPU
//! renderer's (weighted sums and weights), so render files, resume and
//! merge work as they do on the CPU. Renders are deterministic for a given
//! seed on a given device; their random numbers are not the CPU's, so the
//! images agree with the CPU's statistically (tests/integration/gpu.rs),
//! not bit for bit. What the scene flattening ([`flatten`]) does not
//! support is an error naming it.

mod context;
pub mod flatten;
mod light_groups;

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use wgpu::util::DeviceExt;

use crate::color::Rgb;
use crate::image::Film;
use crate::progress::Progress;
use crate::render::{self, pass_schedule_from, PassInfo, RenderJob, RenderOptions, RenderOutput};
use crate::scene::Scene;
use context::GpuContext;
pub use flatten::{GpuScene, Unsupported};

/// The shaders, one file per stage, concatenated per kernel.
const PATH_SHADER: &str = concat!(
    include_str!("shaders/params.wgsl"),
    include_str!("shaders/sampling.wgsl"),
    include_str!("shaders/intersect.wgsl"),
    include_str!("shaders/texture.wgsl"),
    include_str!("shaders/bsdf.wgsl"),
    include_str!("shaders/principled.wgsl"),
    include_str!("shaders/spherical_triangle.wgsl"),
    include_str!("shaders/light_choice.wgsl"),
    include_str!("shaders/emitter.wgsl"),
    include_str!("shaders/path.wgsl"),
    include_str!("shaders/volpath.wgsl"),
);
const FILM_SHADER: &str = concat!(
    include_str!("shaders/params.wgsl"),
    include_str!("shaders/film.wgsl"),
);

/// At most this many bytes of samples per pass (16 per pixel sample).
const PASS_BYTES: u64 = 128 << 20;

/// Why a render could not run on the GPU.
#[derive(Debug, thiserror::Error)]
pub enum GpuError {
    #[error(transparent)]
    Unsupported(#[from] Unsupported),
    #[error(
        "no GPU adapter found (wgpu: Vulkan, Metal or DX12); render on the CPU (--device cpu)"
    )]
    NoAdapter,
    #[error("the GPU device failed: {0}")]
    Device(String),
}

/// The adapter wgpu picks (high performance first), if any.
pub fn adapter() -> Option<wgpu::Adapter> {
    let instance = wgpu::Instance::new(&wgpu::InstanceDescriptor::from_env_or_default());
    pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
        power_preference: wgpu::PowerPreference::HighPerformance,
        ..Default::default()
    }))
    .ok()
}

fn storage(device: &wgpu::Device, label: &str, data: &[u8]) -> wgpu::Buffer {
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(label),
        contents: data,
        usage: wgpu::BufferUsages::STORAGE,
    })
}

/// Renders samples `opts.first_sample..job.spp` of every pixel on the GPU
/// (added to `opts.film` if given); `cancel` stops the render, keeping
/// the passes done.
pub fn render(
    scene: &Scene,
    job: &RenderJob,
    opts: &RenderOptions,
    cancel: &AtomicBool,
) -> Result<RenderOutput, GpuError> {
    render_with_passes(scene, job, opts, cancel, |_| {})
}

/// Like [`render()`], in the CPU renderer's passes ([`pass_schedule_from`]),
/// reporting progress as `opts.progress` asks and calling `on_pass` with
/// the film after each (for the preview, tev and checkpoints). A pass cut
/// short by `cancel` (or `opts.abandon`) is dropped whole, as on the CPU:
/// the film then holds samples `0..spp` of every pixel, so the render can
/// be continued.
pub fn render_with_passes(
    scene: &Scene,
    job: &RenderJob,
    opts: &RenderOptions,
    cancel: &AtomicBool,
    mut on_pass: impl FnMut(&PassInfo),
) -> Result<RenderOutput, GpuError> {
    if opts.rows.is_some() {
        return Err(Unsupported("rendering a strip of rows".into()).into());
    }
    let start = Instant::now();
    let flat = GpuScene::new(scene, job, opts.seed)?;
    let mut context = context::acquire()?;
    let result = render_on(
        context.get(),
        (scene, &flat),
        job,
        opts,
        cancel,
        &mut on_pass,
        start,
    );
    if result.is_err() {
        // The device may be lost: the next render makes a new one.
        context.discard();
    }
    result
}

/// [`render_with_passes`] on the process's GPU context.
fn render_on(
    ctx: &mut GpuContext,
    (scene, flat): (&Scene, &GpuScene),
    job: &RenderJob,
    opts: &RenderOptions,
    cancel: &AtomicBool,
    on_pass: &mut impl FnMut(&PassInfo),
    start: Instant,
) -> Result<RenderOutput, GpuError> {
    let trace = ctx.pipeline(PATH_SHADER, "trace_samples", &flat.shader_constants());
    let gather = ctx.pipeline(FILM_SHADER, "gather", &[]);
    let ctx = &*ctx;
    let (device, queue, limits) = (&ctx.device, &ctx.queue, &ctx.limits);
    let failed = || -> Result<(), GpuError> {
        match ctx.take_failure() {
            Some(e) => Err(GpuError::Device(e)),
            None => Ok(()),
        }
    };
    let (w, h) = (flat.params.width, flat.params.height);
    let pixels = w as u64 * h as u64;
    let first = opts.first_sample.min(job.spp);
    let todo = job.spp - first;
    let max_bytes = PASS_BYTES
        .min(limits.max_storage_buffer_binding_size as u64)
        .min(limits.max_buffer_size);
    let spp_pass = ((max_bytes / (16 * pixels.max(1))) as u32).clamp(1, todo.max(1));

    // A storage buffer, not a uniform one: Mesa's lavapipe inlines the
    // values of uniforms that steer control flow into the kernel and
    // compiles a variant for each new set of them, so every pass (its
    // `sample_base` changes) recompiled the path kernel (about 80 ms a
    // dispatch with Mesa's disk cache warm, 10 s cold, and 7 MB kept per
    // variant). Measured on lavapipe: a 16-spp render of 48x32 pixels
    // 0.57 s -> 0.14 s once compiled.
    let params = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("params"),
        size: std::mem::size_of::<flatten::Params>() as u64,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let nodes = storage(device, "nodes", bytemuck::cast_slice(&flat.nodes));
    let prims = storage(device, "prims", bytemuck::cast_slice(&flat.prims));
    let normals = storage(device, "normals", bytemuck::cast_slice(&flat.normals));
    let shapes = storage(device, "shapes", bytemuck::cast_slice(&flat.shapes));
    let lights = storage(device, "lights", bytemuck::cast_slice(&flat.lights));
    let filter = storage(device, "filter", bytemuck::cast_slice(&flat.filter_table));
    let env = storage(device, "env", bytemuck::cast_slice(&flat.env_data));
    let samples = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("samples"),
        size: 16 * pixels * spp_pass as u64,
        usage: wgpu::BufferUsages::STORAGE,
        mapped_at_creation: false,
    });
    let film_bytes = 16 * pixels;
    let gpu_film = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("film"),
        size: film_bytes,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    });
    let readback = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size: film_bytes,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });

    let bind = |p: &wgpu::ComputePipeline, buffers: &[&wgpu::Buffer]| {
        let entries: Vec<wgpu::BindGroupEntry> = buffers
            .iter()
            .enumerate()
            .map(|(i, b)| wgpu::BindGroupEntry {
                binding: i as u32,
                resource: b.as_entire_binding(),
            })
            .collect();
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &p.get_bind_group_layout(0),
            entries: &entries,
        })
    };
    let trace_group = bind(
        &trace,
        &[
            &params, &nodes, &prims, &normals, &shapes, &lights, &samples, &env,
        ],
    );
    let gather_group = bind(&gather, &[&params, &filter, &samples, &gpu_film]);

    let max_groups = limits.max_compute_workgroups_per_dimension.max(1);
    let never = AtomicBool::new(false);
    let abandon = opts.abandon.as_deref().unwrap_or(&never);
    let stop = || cancel.load(Ordering::Relaxed) || abandon.load(Ordering::Relaxed);
    let passes = pass_schedule_from(first, job.spp);
    let progress = Progress::new(opts.progress, pixels, todo, passes.len());
    // The film of the passes done (with `opts.film` added), read back
    // after each pass.
    let mut film = match &opts.film {
        Some(f) => f.clone(),
        None => Film::new(w as usize, h as usize).with_aovs(opts.aovs.channel_count()),
    };
    let mut spp_done = first;
    let mut samples_taken = 0u64;
    // The AOVs of the passes done, computed on the CPU while the GPU
    // traces each pass (`render::render_aovs`).
    let aov_channels = opts.aovs.channel_count();
    let mut aov_film = Film::new(w as usize, h as usize).with_aovs(aov_channels);
    std::thread::scope(|threads| -> Result<(), GpuError> {
        'passes: for (index, &(s0, s1)) in passes.iter().enumerate() {
            progress.start_pass(index);
            let aov_pass = (aov_channels > 0).then(|| {
                threads.spawn(move || {
                    render::render_aovs(scene, job, (s0, s1), opts.seed, &opts.aovs, cancel)
                })
            });
            let mut done = s0;
            let mut pass_samples = 0u64;
            while done < s1 {
                if stop() {
                    break 'passes;
                }
                let n = spp_pass.min(s1 - done);
                let mut p = flat.params;
                p.sample_base = done;
                p.spp_pass = n;
                queue.write_buffer(&params, 0, bytemuck::bytes_of(&p));
                let groups = (pixels * n as u64).div_ceil(64);
                let gx = groups.min(max_groups as u64) as u32;
                let gy = groups.div_ceil(gx as u64) as u32;
                let mut encoder = device.create_command_encoder(&Default::default());
                {
                    let mut pass = encoder.begin_compute_pass(&Default::default());
                    pass.set_pipeline(&trace);
                    pass.set_bind_group(0, &trace_group, &[]);
                    pass.dispatch_workgroups(gx, gy, 1);
                    pass.set_pipeline(&gather);
                    pass.set_bind_group(0, &gather_group, &[]);
                    pass.dispatch_workgroups(w.div_ceil(8), h.div_ceil(8), 1);
                }
                queue.submit([encoder.finish()]);
                device
                    .poll(wgpu::PollType::wait_indefinitely())
                    .map_err(|e| GpuError::Device(e.to_string()))?;
                failed()?;
                done += n;
                pass_samples += pixels * n as u64;
                progress.add(pixels * n as u64);
            }
            let mut pass_film = read_film(device, queue, &gpu_film, &readback, (w, h))?;
            failed()?;
            if let Some(aov_pass) = aov_pass {
                match aov_pass.join() {
                    Ok(Some(aovs)) => aov_film.add(&aovs),
                    // Cancelled while the GPU finished the pass: drop it.
                    Ok(None) => break 'passes,
                    Err(_) => return Err(GpuError::Device("the AOV thread panicked".into())),
                }
                pass_film
                    .set_aov_sums(aov_channels, aovs_for(&aov_film, &pass_film))
                    .ok_or_else(|| GpuError::Device("the AOV film has the wrong size".into()))?;
            }
            if let Some(before) = &opts.film {
                pass_film.add(before);
            }
            film = pass_film;
            spp_done = s1;
            samples_taken += pass_samples;
            on_pass(&PassInfo {
                film: &film,
                spp_done,
                spp_total: job.spp,
                samples: samples_taken,
                elapsed: start.elapsed(),
            });
        }
        Ok(())
    })?;
    progress.finish();
    Ok(RenderOutput {
        image: film.to_bitmap(),
        film,
        spp: spp_done,
        elapsed: start.elapsed(),
        samples: samples_taken,
        cancelled: cancel.load(Ordering::Relaxed),
    })
}

/// The AOV sums of `aovs` (a film from [`render::render_aovs`]) for the
/// image film `film`, which divides them by its own weight sums: the GPU
/// draws its samples elsewhere in the pixel than the CPU drew the AOVs',
/// so each pixel's sums are rescaled by the ratio of the two weight sums
/// (exactly 1 with a box filter of radius 1/2, whose samples all weigh 1).
fn aovs_for(aovs: &Film, film: &Film) -> Vec<f32> {
    let n = aovs.aov_channels();
    let (mine, theirs) = (film.data(), aovs.data());
    let mut sums = aovs.aov_sums().to_vec();
    for (i, pixel) in sums.chunks_mut(n.max(1)).enumerate() {
        let scale = if theirs[i].1 != 0.0 {
            mine[i].1 / theirs[i].1
        } else {
            0.0
        };
        if scale != 1.0 {
            pixel.iter_mut().for_each(|v| *v *= scale);
        }
    }
    sums
}

/// The film the GPU has accumulated so far, copied back to memory.
fn read_film(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    film: &wgpu::Buffer,
    readback: &wgpu::Buffer,
    (w, h): (u32, u32),
) -> Result<Film, GpuError> {
    let bytes = film.size();
    let mut encoder = device.create_command_encoder(&Default::default());
    encoder.copy_buffer_to_buffer(film, 0, readback, 0, bytes);
    queue.submit([encoder.finish()]);
    readback.slice(..).map_async(wgpu::MapMode::Read, |_| {});
    device
        .poll(wgpu::PollType::wait_indefinitely())
        .map_err(|e| GpuError::Device(e.to_string()))?;
    let data: Vec<(Rgb, f32)> = {
        let mapped = readback.slice(..).get_mapped_range();
        bytemuck::cast_slice::<u8, [f32; 4]>(&mapped)
            .iter()
            .map(|v| (Rgb::new(v[0], v[1], v[2]), v[3]))
            .collect()
    };
    readback.unmap();
    Film::from_data(w as usize, h as usize, data)
        .ok_or_else(|| GpuError::Device("the film read back has the wrong size".into()))
}
