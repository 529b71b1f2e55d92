//! lente's integration tests, in one binary: each module is one area
//! (BSDFs, the scene readers, the integrators, the CLI, ...); `common`,
//! `cli_util` and `mutation` are helpers the others share. (The
//! no-allocation test has its own binary, tests/no_alloc.rs: it replaces
//! the global allocator.)

mod cli_util;
mod common;
mod mutation;

mod aov_outputs;
mod bench_cli;
mod bsdf;
mod bsdf_energy;
mod bsdf_mitsuba;
mod bsdf_path;
mod bsdf_sampling;
mod cli_tools;
mod corpus;
mod curves;
mod denoise;
mod determinism;
mod envmap_integrators;
mod furnace;
mod geometry;
#[cfg(feature = "gpu")]
mod gpu;
mod hostile_inputs;
mod instancing;
mod lights;
mod media;
mod microfacet;
mod mitsuba_conformance;
mod mitsuba_mutations;
mod mitsuba_objects;
mod mitsuba_parse;
mod nori_forks;
mod nori_integrators;
mod nori_parse;
mod nori_testfiles;
mod obj_loading;
mod preview_cli;
mod preview_e2e;
mod render_cli;
mod resume_merge;
mod samplers;
mod scene_errors;
mod shading_frames;
mod spectra;
mod tev_stream;
mod textures;
mod thin_lens;
mod warps;
mod warptest_cli;
