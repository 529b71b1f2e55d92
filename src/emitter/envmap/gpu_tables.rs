//! An environment map as the GPU backend reads it (`src/gpu/`): the scaled
//! texels, the grid's cells exactly as [`TexelGrid`] lays them out (so the
//! GPU's lookup is this one), the rotation both ways, and the CPU's own
//! MIS-compensated sampling density (`warp.rs`: bilinear in each cell for
//! the bilinear filter, what `path`'s MIS samples with) as its values and
//! CDFs over bands and cells in place of the alias tables (binary searches
//! suit a GPU), and that density's facing version where it has one
//! (`facing.rs`: per normal bin a CDF over blocks, then the CPU's own
//! running sums over a block's bands and a band's cells).

use super::warp::band_integral;
use super::{EnvFilter, EnvMap};
use crate::emitter::LightPdf;
use crate::sampling::Distribution1D;

/// The tables (see the module's doc).
pub struct EnvGpuTables {
    pub width: u32,
    pub bands: u32,
    pub bilinear: bool,
    pub band_scale: f32,
    pub band_offset: f32,
    pub col_offset: f32,
    /// Scaled texels, RGB, row-major.
    pub texels: Vec<[f32; 3]>,
    /// Band `b` covers `edges[b]..edges[b + 1]` of v.
    pub edges: Vec<f32>,
    pub inv_heights: Vec<f32>,
    /// The texel row of each vertex row (bilinear) or band (nearest).
    pub rows: Vec<u32>,
    /// CDF over bands, then per band a CDF over its columns (each ending
    /// at 1; a band of zero weight has a uniform one).
    pub band_cdf: Vec<f32>,
    pub col_cdf: Vec<f32>,
    /// The density's values (`EnvWarp::values`): per vertex row
    /// (bilinear; a cell's shape inside it) or per band (nearest).
    pub density: Vec<f32>,
    /// Rows of the rotation to the world and back.
    pub to_world: [[f32; 3]; 3],
    pub to_local: [[f32; 3]; 3],
    pub visible: bool,
    /// The facing density's tables, where the map has one.
    pub facing: Option<EnvGpuFacing>,
}

/// A facing density's tables (see `facing.rs`).
pub struct EnvGpuFacing {
    /// Blocks along u; log2 of the columns and of the bands per block.
    pub across: u32,
    pub col_shift: u32,
    pub band_shift: u32,
    pub blocks: u32,
    /// Per normal bin (`facing::BINS` of them), the upper ends of its CDF
    /// over the blocks; all zeros for a bin that sees no light.
    pub block_cdf: Vec<f32>,
    /// Per block, running sums over its bands (`1 << band_shift` each).
    pub band_sums: Vec<f32>,
    /// Per cell (row-major), the running sum over its band's segment of
    /// its block up to it.
    pub cell_sums: Vec<f32>,
}

/// The upper ends of `weights`' CDF cells (a [`Distribution1D`]'s running
/// sums without the leading 0): what the GPU's binary searches read.
fn cdf(weights: &[f32]) -> Vec<f32> {
    Distribution1D::new(weights).cdf()[1..].to_vec()
}

impl EnvMap {
    /// The map's tables for the GPU, with the density `which` light
    /// sampling draws from (the MIS-compensated one for `path`, the
    /// complete one for `path_ems`); `None` if it emits nothing.
    pub fn gpu_tables(&self, which: LightPdf) -> Option<EnvGpuTables> {
        if !self.emits() {
            return None;
        }
        let g = &self.grid;
        let w = g.width;
        let bands = g.bands();
        let bilinear = g.filter == EnvFilter::Bilinear;
        let px = &self.image.pixels;
        let warp = &self.warp(which)?.map;
        // Band and cell weights as `EnvWarp::new` gives them to its alias
        // tables.
        let mut band_w = Vec::with_capacity(bands);
        let mut col_cdf = Vec::with_capacity(bands * w);
        for b in 0..bands {
            let cells: Vec<f32> = (0..w).map(|c| warp.cell_weight(c, b)).collect();
            let total: f64 = cells.iter().map(|&c| c as f64).sum();
            band_w.push(band_integral(g, b, total) as f32);
            col_cdf.extend(cdf(&cells));
        }
        let rows = if bilinear { bands + 1 } else { bands };
        let m = self.to_world.m;
        let inv = self.to_world.inv;
        let rot = |m: glam::Mat4| [0, 1, 2].map(|r| [0, 1, 2].map(|c| m.col(c)[r]));
        Some(EnvGpuTables {
            width: w as u32,
            bands: bands as u32,
            bilinear,
            band_scale: g.band_scale,
            band_offset: g.band_offset,
            col_offset: g.col_offset(),
            texels: px.iter().map(|p| (*p * self.scale).to_array()).collect(),
            edges: (0..=bands).map(|k| g.edge(k)).collect(),
            inv_heights: (0..bands)
                .map(|b| 1.0 / (g.edge(b + 1) - g.edge(b)))
                .collect(),
            rows: (0..rows).map(|k| g.texel_row(k) as u32).collect(),
            band_cdf: cdf(&band_w),
            col_cdf,
            density: warp.values().to_vec(),
            to_world: rot(m),
            to_local: rot(inv),
            visible: self.visible,
            facing: self.warp(which)?.facing.as_ref().map(|f| {
                let parts = f.parts();
                let mut block_cdf = Vec::with_capacity(parts.pick_weights.len());
                for row in parts.pick_weights.chunks(parts.blocks as usize) {
                    if row.iter().any(|&w| w > 0.0) {
                        block_cdf.extend(cdf(row));
                    } else {
                        block_cdf.extend(std::iter::repeat_n(0.0, row.len()));
                    }
                }
                EnvGpuFacing {
                    across: parts.across,
                    col_shift: parts.col_shift,
                    band_shift: parts.band_shift,
                    blocks: parts.blocks,
                    block_cdf,
                    band_sums: parts.band_sums.to_vec(),
                    cell_sums: parts.cell_sums.to_vec(),
                }
            }),
        })
    }
}
