//! Random numbers, warps with their pdfs, and piecewise-constant distributions.

mod distribution;
mod sampler;
pub mod warp;

pub use distribution::{Distribution1D, Distribution2D};
pub use sampler::Sampler;
