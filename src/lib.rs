//! lente: a physically based path tracer for Nori and Mitsuba scenes.
//!
//! See `docs/architecture.md` for the data flow and conventions.

pub mod aov;
pub mod bench;
pub mod bsdf;
pub mod camera;
pub mod color;
pub mod denoise;
pub mod emitter;
pub mod fuzz;
pub mod geometry;
#[cfg(feature = "gpu")]
pub mod gpu;
pub mod image;
pub mod integrator;
pub mod limits;
pub mod load;
pub mod math;
pub mod medium;
pub mod preview;
pub mod progress;
pub mod render;
pub mod render_file;
pub mod sampling;
pub mod scene;
pub mod stats;
pub mod tev;
pub mod texture;
pub mod unit_queue;
pub mod verify;
