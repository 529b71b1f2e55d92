//! The GPU device and its compiled kernels, kept for the whole process:
//! creating a device and compiling the path kernel take about 1.5 s on
//! lavapipe with Mesa's shader cache warm (14-17 s cold), which a process
//! that renders many times (the Python package, a distributed worker, the
//! tests) should pay once. Renders take the context in turn; a device that
//! failed is dropped, and the next render creates a fresh one.
//!
//! A device lives as long as the process: its memory stays flat over
//! renders (measured on lavapipe: 291 MB after 50 and after 300 path
//! dispatches), now that no kernel reads a uniform buffer (`Params` is a
//! storage buffer, see `gpu/mod.rs`).

use std::collections::HashMap;
use std::sync::{Arc, Mutex, MutexGuard};

use super::GpuError;

/// A device, its queue, and the pipelines compiled on it.
pub struct GpuContext {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub limits: wgpu::Limits,
    /// The first validation or out-of-memory error wgpu reported since the
    /// last [`GpuContext::take_failure`].
    failure: Arc<Mutex<Option<String>>>,
    /// Compiled pipelines by entry point and pipeline constants.
    pipelines: HashMap<PipelineKey, wgpu::ComputePipeline>,
}

/// An entry point and its pipeline constants (their bits, so that the key
/// is hashable).
type PipelineKey = (&'static str, Vec<(&'static str, u64)>);

/// The process's context: `None` until the first render, and again after
/// a render failed.
static CONTEXT: Mutex<Option<GpuContext>> = Mutex::new(None);

/// Holds the process's GPU context for one render; other renders wait.
pub struct ContextGuard(MutexGuard<'static, Option<GpuContext>>);

impl ContextGuard {
    /// The context (present while the guard lives).
    pub fn get(&mut self) -> &mut GpuContext {
        self.0.as_mut().expect("the guard holds a context")
    }

    /// Drops the context, so that the next render starts on a fresh
    /// device (after a device error, whose device may be lost).
    pub fn discard(mut self) {
        *self.0 = None;
    }
}

/// The process's GPU context, created on first use.
pub fn acquire() -> Result<ContextGuard, GpuError> {
    // A render that panicked left no half-made context: the guard's
    // `Option` is only ever replaced whole.
    let mut guard = CONTEXT.lock().unwrap_or_else(|p| p.into_inner());
    if guard.is_none() {
        *guard = Some(GpuContext::new()?);
    }
    let mut guard = ContextGuard(guard);
    // An error left by an earlier render is not this render's.
    guard.get().take_failure();
    Ok(guard)
}

impl GpuContext {
    fn new() -> Result<GpuContext, GpuError> {
        let adapter = super::adapter().ok_or(GpuError::NoAdapter)?;
        let limits = adapter.limits();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("lente"),
            required_limits: limits.clone(),
            ..Default::default()
        }))
        .map_err(|e| GpuError::Device(e.to_string()))?;
        // wgpu reports validation and out-of-memory errors to a handler
        // that panics by default: record them instead, and fail the render.
        let failure = Arc::new(Mutex::new(None::<String>));
        {
            let failure = failure.clone();
            device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
                let mut f = failure.lock().unwrap_or_else(|p| p.into_inner());
                f.get_or_insert_with(|| e.to_string());
            }));
        }
        Ok(GpuContext {
            device,
            queue,
            limits,
            failure,
            pipelines: HashMap::new(),
        })
    }

    /// The error wgpu reported since the last call, if any.
    pub fn take_failure(&self) -> Option<String> {
        self.failure
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .take()
    }

    /// The compute pipeline of `entry` in `source` with these pipeline
    /// constants, compiled on first use.
    pub fn pipeline(
        &mut self,
        source: &'static str,
        entry: &'static str,
        constants: &[(&'static str, f64)],
    ) -> wgpu::ComputePipeline {
        let key = (
            entry,
            constants.iter().map(|&(n, v)| (n, v.to_bits())).collect(),
        );
        let device = &self.device;
        self.pipelines
            .entry(key)
            .or_insert_with(|| {
                let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
                    label: Some(entry),
                    source: wgpu::ShaderSource::Wgsl(source.into()),
                });
                device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                    label: Some(entry),
                    layout: None,
                    module: &module,
                    entry_point: Some(entry),
                    compilation_options: wgpu::PipelineCompilationOptions {
                        constants,
                        ..Default::default()
                    },
                    cache: None,
                })
            })
            .clone()
    }
}
