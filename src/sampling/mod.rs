//! Random numbers (independent and stratified), warps with their pdfs, piecewise-constant distributions
//! alias tables and spherical-triangle sampling.

mod alias;
mod distribution;
mod linear;
mod sampler;
mod sobol;
pub mod spherical_triangle;
pub mod warp;

pub use alias::{AliasRows, AliasTable};
pub use distribution::Distribution1D;
pub use linear::{linear_pdf, sample_linear, sample_linear_lanes};
pub use sampler::{mix64, PixelStreams, Sampler, SamplerKind, STRATIFIED_DIMENSIONS};

/// The largest f32 below 1: where a sample in [0, 1) is clamped.
pub const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;
