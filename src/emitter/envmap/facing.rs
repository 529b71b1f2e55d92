//! Sampling an environment map for a point that only receives light from
//! one side: a reflecting surface with a given normal.
//!
//! A surface that only reflects gets nothing from the half of the sky
//! behind it, and from the sky near its horizon it gets radiance times a
//! small cosine. Drawn from the map's density alone, a third of the light
//! samples of a sphere or a floor under a studio probe land behind the
//! surface and are wasted. Here the density is the map's one times a factor
//! per *block* of cells that bounds the cosine over the block:
//!
//! ```text
//! pdf_facing(w) = pdf(w) * c(bin(n), block(w)) * Z / Z_bin
//! ```
//!
//! - Normals (in the map's frame) fall into [`BINS`] octahedral bins, each
//!   bounded by a cone; blocks of cells, about [`BLOCKS_ACROSS`] x
//!   [`BLOCKS_DOWN`] of them over the map whatever its size (so about 6
//!   degrees square), are bounded by cones too. `c` is the cosine of the smallest angle the two cones allow
//!   between a normal and a direction, and zero when every pair is at 90
//!   degrees or more: so `c >= max(0, n . w)` for every normal of the bin and
//!   direction of the block, and the density is positive wherever the
//!   integrand `L(w) f(w) max(0, n . w)` is.
//! - `Z` is the map's normalisation, `Z_bin` the sum of `c` times the map's
//!   integral over each block.
//!
//! Sampling picks a block with an alias table of the bin, a band of the
//! block from its running sums, a cell of that band's segment from
//! its running sums (one cache line), and the point
//! inside the cell the way the map's own density does. For a diffuse
//! surface under a smooth sky this is close to sampling radiance times
//! cosine.

use super::grid::{CellPoint, TexelGrid};
use super::latlong::uv_to_dir;
use super::warp::{CellPick, EnvWarp};
use crate::math::{Vec2, Vec3, PI};
use crate::sampling::{AliasRows, ONE_MINUS_EPSILON};

/// Octahedral bins per side: normals fall into `BIN_SIDE^2` bins.
const BIN_SIDE: usize = 8;
/// Number of normal bins.
pub(super) const BINS: usize = BIN_SIDE * BIN_SIDE;
/// Blocks along u and along v, about: a block is a power of two of
/// columns and of bands, at most [`MAX_BLOCK_SIDE`] of each (bigger maps
/// get more blocks; a block's running sums stay a cache line or two).
const BLOCKS_ACROSS: usize = 64;
const BLOCKS_DOWN: usize = 32;
const MAX_BLOCK_SIDE: usize = 32;
/// Added to every cone's half-angle (radians) against rounding.
const CONE_SLACK: f32 = 1e-3;

/// A cone of directions: every direction of a region is within
/// `half_angle` of `axis`.
#[derive(Clone, Copy, Debug)]
struct Cone {
    axis: Vec3,
    half_angle: f32,
}

/// A cone as [`cos_bound`] reads it: its axis and the cosine and sine of
/// its half-angle.
#[derive(Clone, Copy, Debug)]
struct ConeTrig {
    axis: Vec3,
    cos: f32,
    sin: f32,
}

impl From<Cone> for ConeTrig {
    fn from(c: Cone) -> ConeTrig {
        ConeTrig {
            axis: c.axis,
            cos: c.half_angle.cos(),
            sin: c.half_angle.sin(),
        }
    }
}

/// The largest cosine between a direction of cone `a` and one of cone
/// `b`, clamped at zero: cos(max(0, theta - alpha - beta)), or zero where
/// theta - alpha - beta >= 90 degrees (theta the angle between the axes,
/// alpha and beta the half-angles). A few multiplications and a square
/// root, so the density can compute it where it is used instead of
/// reading it from a table; built and evaluated by this one function, so
/// the alias tables and the pdf agree to the bit.
#[inline]
fn cos_bound(a: &ConeTrig, b: &ConeTrig) -> f32 {
    // delta = alpha + beta; a cone of half-angle pi has sin 0 and cos -1.
    let cos_d = a.cos * b.cos - a.sin * b.sin;
    let sin_d = a.sin * b.cos + a.cos * b.sin;
    let cos_t = a.axis.dot(b.axis).clamp(-1.0, 1.0);
    if cos_t >= cos_d || sin_d < 0.0 || a.cos <= -1.0 || b.cos <= -1.0 {
        // The cones overlap, or together they are wider than the sphere.
        return 1.0;
    }
    let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
    (cos_t * cos_d + sin_t * sin_d).clamp(0.0, 1.0)
}

impl Cone {
    /// A cone around the `n` x `n` grid of directions `dirs` (row-major)
    /// sampled evenly over a region that they map continuously: the angle to
    /// the farthest sample, plus the largest angle between neighbouring
    /// samples (every point of the region is that close to a sample).
    fn around(dirs: &[Vec3], n: usize) -> Cone {
        let sum: Vec3 = dirs.iter().copied().sum();
        let whole = Cone {
            axis: Vec3::Y,
            half_angle: PI,
        };
        if sum.length() < 1e-3 {
            return whole;
        }
        let axis = sum.normalize();
        let angle = |a: Vec3, b: Vec3| a.dot(b).clamp(-1.0, 1.0).acos();
        let far = dirs.iter().map(|&d| angle(axis, d)).fold(0.0, f32::max);
        let mut gap = 0.0f32;
        for i in 0..n {
            for j in 0..n {
                let d = dirs[i * n + j];
                if i + 1 < n {
                    gap = gap.max(angle(d, dirs[(i + 1) * n + j]));
                }
                if j + 1 < n {
                    gap = gap.max(angle(d, dirs[i * n + j + 1]));
                }
            }
        }
        let half_angle = far + gap + CONE_SLACK;
        if half_angle >= PI {
            whole
        } else {
            Cone { axis, half_angle }
        }
    }
}

/// The octahedral coordinates in [-1, 1]^2 of a direction (not zero).
fn octahedral(n: Vec3) -> Vec2 {
    let n = n / (n.x.abs() + n.y.abs() + n.z.abs());
    if n.y >= 0.0 {
        Vec2::new(n.x, n.z)
    } else {
        let fold = |a: f32, b: f32| (1.0 - b.abs()) * if a >= 0.0 { 1.0 } else { -1.0 };
        Vec2::new(fold(n.x, n.z), fold(n.z, n.x))
    }
}

/// The unit direction of octahedral coordinates in [-1, 1]^2 (the inverse
/// of [`octahedral`], continuous over the square).
fn from_octahedral(p: Vec2) -> Vec3 {
    let y = 1.0 - p.x.abs() - p.y.abs();
    let (x, z) = if y >= 0.0 {
        (p.x, p.y)
    } else {
        let unfold = |a: f32, b: f32| (1.0 - b.abs()) * if a >= 0.0 { 1.0 } else { -1.0 };
        (unfold(p.x, p.y), unfold(p.y, p.x))
    };
    Vec3::new(x, y, z).normalize()
}

/// The bin of a local normal; `None` for zero or non-finite input.
#[inline]
pub(super) fn bin_of(n: Vec3) -> Option<usize> {
    let l1 = n.x.abs() + n.y.abs() + n.z.abs();
    if !(l1 > 0.0 && l1.is_finite()) {
        return None;
    }
    let p = octahedral(n);
    let cell = |x: f32| (((x + 1.0) * 0.5 * BIN_SIDE as f32) as usize).min(BIN_SIDE - 1);
    Some(cell(p.y) * BIN_SIDE + cell(p.x))
}

/// The cone of normals of each bin.
fn bin_cones() -> Vec<Cone> {
    const N: usize = 17;
    (0..BINS)
        .map(|b| {
            let (bx, by) = ((b % BIN_SIDE) as f32, (b / BIN_SIDE) as f32);
            let side = 2.0 / BIN_SIDE as f32;
            let mut dirs = Vec::with_capacity(N * N);
            for i in 0..N {
                for j in 0..N {
                    let t = |k: usize| k as f32 / (N - 1) as f32;
                    let p = Vec2::new(-1.0 + (bx + t(j)) * side, -1.0 + (by + t(i)) * side);
                    dirs.push(from_octahedral(p));
                }
            }
            Cone::around(&dirs, N)
        })
        .collect()
}

/// How a grid's cells are grouped into blocks.
#[derive(Clone, Copy, Debug)]
struct Blocks {
    /// Columns of cells and bands.
    cols: usize,
    bands: usize,
    /// log2 of the columns and bands per block.
    col_shift: u32,
    band_shift: u32,
    /// Blocks along u and v.
    across: usize,
    down: usize,
}

impl Blocks {
    fn of(grid: &TexelGrid) -> Blocks {
        let (cols, bands) = (grid.width, grid.bands());
        let side = |cells: usize, blocks: usize| {
            cells
                .div_ceil(blocks)
                .next_power_of_two()
                .min(MAX_BLOCK_SIDE)
                .trailing_zeros()
        };
        let (col_shift, band_shift) = (side(cols, BLOCKS_ACROSS), side(bands, BLOCKS_DOWN));
        Blocks {
            cols,
            bands,
            col_shift,
            band_shift,
            across: cols.div_ceil(1 << col_shift),
            down: bands.div_ceil(1 << band_shift),
        }
    }

    /// Columns and bands per block.
    fn cols_per(&self) -> usize {
        1 << self.col_shift
    }

    fn bands_per(&self) -> usize {
        1 << self.band_shift
    }

    fn count(&self) -> usize {
        self.across * self.down
    }

    /// The block of a cell.
    #[inline]
    fn of_cell(&self, col: usize, band: usize) -> usize {
        (band >> self.band_shift) * self.across + (col >> self.col_shift)
    }

    /// The columns and bands of block `k`.
    #[inline]
    fn span(&self, k: usize) -> (std::ops::Range<usize>, std::ops::Range<usize>) {
        // In u32: a 64-bit division is several times slower, and a map
        // has far fewer than 2^32 blocks.
        let (k, across) = (k as u32, self.across as u32);
        let (bx, by) = ((k % across) as usize, (k / across) as usize);
        let (cp, bp) = (self.cols_per(), self.bands_per());
        let cols = bx * cp..((bx + 1) * cp).min(self.cols);
        let bands = by * bp..((by + 1) * bp).min(self.bands);
        (cols, bands)
    }
}

/// The cone of directions of each block of `grid`.
fn block_cones(grid: &TexelGrid, blocks: &Blocks) -> Vec<Cone> {
    const N: usize = 9;
    let col_offset = grid.to_uv(CellPoint {
        col: 0,
        band: 0,
        fx: 0.0,
        fy: 0.0,
    });
    let w = grid.width as f32;
    (0..blocks.count())
        .map(|k| {
            let (cols, bands) = blocks.span(k);
            let (v0, v1) = (grid.edge(bands.start), grid.edge(bands.end));
            let mut dirs = Vec::with_capacity(N * N);
            for i in 0..N {
                for j in 0..N {
                    let t = |m: usize| m as f32 / (N - 1) as f32;
                    let u = col_offset.x + (cols.start as f32 + t(j) * cols.len() as f32) / w;
                    let v = v0 + t(i) * (v1 - v0);
                    dirs.push(uv_to_dir(Vec2::new(u, v)));
                }
            }
            Cone::around(&dirs, N)
        })
        .collect()
}

/// The cones of a grid's normal bins and blocks: what every
/// [`FacingWarp`] of a grid shares.
#[derive(Clone, Debug)]
pub(super) struct FacingBounds {
    blocks: Blocks,
    bins: Vec<ConeTrig>,
    cells: Vec<ConeTrig>,
}

impl FacingBounds {
    pub fn new(grid: &TexelGrid) -> FacingBounds {
        let blocks = Blocks::of(grid);
        FacingBounds {
            blocks,
            bins: bin_cones().into_iter().map(ConeTrig::from).collect(),
            cells: block_cones(grid, &blocks)
                .into_iter()
                .map(ConeTrig::from)
                .collect(),
        }
    }

    /// The cosine bound `c` of a bin and a block.
    #[inline]
    fn cos(&self, bin: usize, block: usize) -> f32 {
        cos_bound(&self.bins[bin], &self.cells[block])
    }
}

/// A map's density restricted, bin by bin, to what a surface facing the
/// bin's normals can receive (see the module docs).
#[derive(Clone, Debug)]
pub(super) struct FacingWarp {
    bounds: FacingBounds,
    /// Per bin, an alias table over the blocks (weights c x block integral).
    picks: AliasRows,
    /// Per bin, Z / Z_bin: with `c`, what turns the map's pdf into the
    /// bin's. Zero for a bin that sees no light at all.
    scales: Vec<f32>,
    /// Per block, running sums of its bands' weights (bands per block of
    /// them).
    band_sums: Vec<f32>,
    /// Per cell, the running sum of the cell weights of its band's segment
    /// of a block up to it (row-major, like the cells): a segment's sums
    /// are one cache line.
    cell_sums: Vec<f32>,
    /// Per block, the map's integral over it (what the bins' alias
    /// tables weigh by their cosine bounds; kept for the GPU's tables).
    #[cfg_attr(not(feature = "gpu"), allow(dead_code))]
    block_weights: Vec<f64>,
}

/// A facing density as the GPU backend reads it (`gpu_tables.rs`): how
/// cells group into blocks, each bin's block weights (zero for a bin that
/// sees no light), and the running sums the CPU samples bands and cells
/// with.
#[cfg(feature = "gpu")]
pub(super) struct FacingParts<'a> {
    pub across: u32,
    pub col_shift: u32,
    pub band_shift: u32,
    pub blocks: u32,
    /// `BINS` rows of `blocks` weights, as the alias tables have them.
    pub pick_weights: Vec<f32>,
    pub band_sums: &'a [f32],
    pub cell_sums: &'a [f32],
}

/// Below this predicted ratio of variances (facing density / map's, see
/// [`predicted_variance_ratio`]) a density gets a facing version: a facing
/// sample costs 10-20% of a render's time more, so it must pay. Set from
/// the four Poly Haven probes of `bench/envmap/` (MIS-compensated
/// densities): studio predicts 0.13 and rendered with 0.52x the MSE; sky,
/// sunset and forest predict 0.31-0.48 and rendered with 0.95-1.0x, which
/// did not pay for the time.
pub(super) const WORTH_IT: f64 = 0.2;

/// How much less noisy irradiance on diffuse surfaces is with the facing
/// densities than with the map's, predicted from the blocks alone: per
/// normal bin, the variance of estimating the sum over blocks of
/// `weight x cos+` (cosine between the bin's and the block's axes) by
/// drawing blocks from each density, summed over the bins; their ratio.
/// NaN where neither estimate has any variance (all of the light in one
/// block for every bin).
fn predicted_variance_ratio(bounds: &FacingBounds, weights: &[f64]) -> f64 {
    let z: f64 = weights.iter().sum();
    let (mut map, mut facing) = (0.0, 0.0);
    for (bin, axis) in bounds.bins.iter().map(|b| b.axis).enumerate() {
        let (mut i, mut m_map, mut m_facing, mut seen) = (0.0, 0.0, 0.0, 0.0);
        for (k, &w) in weights.iter().enumerate() {
            let cos = axis.dot(bounds.cells[k].axis).max(0.0) as f64;
            let c = bounds.cos(bin, k) as f64;
            i += w * cos;
            m_map += w * cos * cos;
            seen += c * w;
            if c > 0.0 {
                m_facing += w * cos * cos / c;
            }
        }
        map += z * m_map - i * i;
        facing += seen * m_facing - i * i;
    }
    facing / map
}

impl FacingWarp {
    /// The facing version of `warp`, or `None` where the predicted
    /// variance ratio is not below `worth_it` ([`WORTH_IT`]).
    pub fn new(
        warp: &EnvWarp,
        grid: &TexelGrid,
        bounds: &FacingBounds,
        worth_it: f64,
    ) -> Option<FacingWarp> {
        let blocks = bounds.blocks;
        let bp = blocks.bands_per();
        let mut band_sums = vec![0.0f32; blocks.count() * bp];
        let mut block_weights = vec![0.0f64; blocks.count()];
        for (k, weight) in block_weights.iter_mut().enumerate() {
            let (cols, bands) = blocks.span(k);
            let mut sum = 0.0f64;
            for (s, band) in bands.enumerate() {
                let (v0, v1) = grid.band_range(band);
                let cells: f64 = cols.clone().map(|c| warp.cell_weight(c, band) as f64).sum();
                sum += cells * (v1 - v0) as f64;
                band_sums[k * bp + s] = sum as f32;
            }
            *weight = sum;
        }
        // Decided from the blocks alone, before the per-cell sums are built.
        let predicted = predicted_variance_ratio(bounds, &block_weights);
        if predicted.is_nan() || predicted >= worth_it {
            return None;
        }
        let (w, bands) = (grid.width, grid.bands());
        let mut cell_sums = vec![0.0f32; w * bands];
        for band in 0..bands {
            for start in (0..w).step_by(blocks.cols_per()) {
                let cols = start..(start + blocks.cols_per()).min(w);
                warp.running_cell_weights(cols.clone(), band, &mut cell_sums[band * w..][cols]);
            }
        }
        let mut scales = vec![0.0f32; BINS];
        let pick_weights = pick_weights(bounds, &block_weights, &mut scales);
        Some(FacingWarp {
            bounds: bounds.clone(),
            picks: AliasRows::new(&pick_weights, blocks.count()),
            scales,
            band_sums,
            cell_sums,
            block_weights,
        })
    }

    /// What the GPU backend reads (see [`FacingParts`]).
    #[cfg(feature = "gpu")]
    pub fn parts(&self) -> FacingParts<'_> {
        let b = &self.bounds.blocks;
        let mut scales = vec![0.0f32; BINS];
        FacingParts {
            across: b.across as u32,
            col_shift: b.col_shift,
            band_shift: b.band_shift,
            blocks: b.count() as u32,
            pick_weights: pick_weights(&self.bounds, &self.block_weights, &mut scales),
            band_sums: &self.band_sums,
            cell_sums: &self.cell_sums,
        }
    }

    /// The factor from the map's (u, v) density to bin `bin`'s at a point.
    #[inline]
    pub fn ratio(&self, bin: usize, p: CellPoint) -> f32 {
        let block = self.bounds.blocks.of_cell(p.col, p.band);
        self.bounds.cos(bin, block) * self.scales[bin]
    }

    /// A point drawn from bin `bin`'s density with `u` in [0, 1)^2; `None`
    /// if the bin's surfaces see no light. `prefetch_texels(cols, band)` is
    /// called as soon as the band is known, before its cells are weighed,
    /// so that the caller's reads of the texels of the cell picked among
    /// `cols` overlap with that.
    #[inline]
    pub fn sample(
        &self,
        warp: &EnvWarp,
        bin: usize,
        u: Vec2,
        prefetch_texels: impl Fn(std::ops::Range<usize>, usize),
    ) -> Option<CellPoint> {
        if self.scales[bin] <= 0.0 {
            return None;
        }
        let (block, ux) = self.picks.sample(bin, u.x);
        let (cols, bands) = self.bounds.blocks.span(block);
        let bp = self.bounds.blocks.bands_per();
        let sums = &self.band_sums[block * bp..][..bands.len()];
        let (s, uy) = pick_running(sums, u.y)?;
        let band = bands.start + s;
        prefetch_texels(cols.clone(), band);
        let w = self.cell_sums.len() / self.bounds.blocks.bands;
        let (i, ux) = pick_running(&self.cell_sums[band * w..][cols.clone()], ux)?;
        Some(warp.place(CellPick::new(cols.start + i, band, ux, uy)))
    }
}

/// Per bin, the blocks' weights `c x block weight` (`BINS` rows; a row of
/// zeros for a bin that sees no light), and each bin's `Z / Z_bin` in
/// `scales` (zero for such a bin).
fn pick_weights(bounds: &FacingBounds, block_weights: &[f64], scales: &mut [f32]) -> Vec<f32> {
    let count = block_weights.len();
    let total: f64 = block_weights.iter().sum();
    let mut weights = vec![0.0f32; BINS * count];
    for (bin, scale) in scales.iter_mut().enumerate() {
        let row = &mut weights[bin * count..(bin + 1) * count];
        for (k, (p, &w)) in row.iter_mut().zip(block_weights).enumerate() {
            *p = (bounds.cos(bin, k) as f64 * w) as f32;
        }
        let seen: f64 = row.iter().map(|&p| p as f64).sum();
        if seen > 0.0 && total > 0.0 {
            *scale = (total / seen) as f32;
        } else {
            row.fill(0.0);
        }
    }
    weights
}

/// Picks an entry of running sums `sums` (non-decreasing) with `u` in
/// [0, 1): the first whose sum exceeds `u` times the last, with `u` rescaled
/// to [0, 1) inside it. `None` if the sums are all zero.
#[inline]
fn pick_running(sums: &[f32], u: f32) -> Option<(usize, f32)> {
    let total = *sums.last()?;
    if total.is_nan() || total <= 0.0 {
        return None;
    }
    let t = u * total;
    // The sums are sorted, so the count of those <= t is where t goes: a
    // count has no branch to mispredict, and the compiler vectorises it.
    let mut i = sums.iter().filter(|&&s| s <= t).count().min(sums.len() - 1);
    // Where rounding sent t to the end, step back over empty entries.
    while i > 0 && sums[i] <= sums[i - 1] {
        i -= 1;
    }
    let lo = if i > 0 { sums[i - 1] } else { 0.0 };
    let width = sums[i] - lo;
    let rest = if width > 0.0 {
        ((t - lo) / width).clamp(0.0, ONE_MINUS_EPSILON)
    } else {
        0.5
    };
    Some((i, rest))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Sampler;

    #[test]
    fn octahedral_round_trips_and_bins_hold_their_normals() {
        let cones = bin_cones();
        let mut s = Sampler::new(1, 1);
        for _ in 0..200_000 {
            let n = crate::sampling::warp::square_to_uniform_sphere(s.next_2d());
            let back = from_octahedral(octahedral(n));
            assert!((back - n).length() < 1e-5, "{n} -> {back}");
            let b = bin_of(n).unwrap();
            let c = cones[b];
            assert!(
                c.axis.dot(n).clamp(-1.0, 1.0).acos() <= c.half_angle,
                "{n} outside bin {b}'s cone {c:?}"
            );
        }
        assert_eq!(bin_of(Vec3::ZERO), None);
        assert_eq!(bin_of(Vec3::new(f32::NAN, 0.0, 1.0)), None);
        // The cones are tight enough to matter.
        let widest = cones.iter().map(|c| c.half_angle).fold(0.0, f32::max);
        assert!(widest < 0.6, "widest bin cone {widest}");
    }

    #[test]
    fn cosine_bound_holds_for_every_normal_and_direction() {
        use super::super::EnvFilter;
        use super::super::TexelRows;
        for (w, h, rows) in [
            (64, 32, TexelRows::CellCentres),
            (40, 21, TexelRows::PoleToPole),
            (3, 2, TexelRows::CellCentres),
        ] {
            let grid = TexelGrid::new(w, h, EnvFilter::Bilinear, rows);
            let bounds = FacingBounds::new(&grid);
            let blocks = bounds.blocks;
            let mut s = Sampler::new(2, 1);
            for _ in 0..100_000 {
                let n = crate::sampling::warp::square_to_uniform_sphere(s.next_2d());
                let uv = Vec2::new(s.next_1d(), s.next_1d());
                let d = uv_to_dir(uv);
                let p = grid.locate(uv);
                let bin = bin_of(n).unwrap();
                let c = bounds.cos(bin, blocks.of_cell(p.col, p.band));
                assert!(c >= n.dot(d) - 1e-6, "{w}x{h}: c {c} < {}", n.dot(d));
            }
        }
    }

    #[test]
    fn pick_running_skips_empty_entries() {
        let sums = [0.0, 2.0, 2.0, 4.0];
        assert_eq!(pick_running(&sums, 0.0).unwrap().0, 1);
        assert_eq!(pick_running(&sums, 0.49).unwrap().0, 1);
        assert_eq!(pick_running(&sums, 0.5).unwrap().0, 3);
        assert_eq!(pick_running(&sums, ONE_MINUS_EPSILON).unwrap().0, 3);
        let (_, r) = pick_running(&sums, 0.75).unwrap();
        assert!((r - 0.5).abs() < 1e-6);
        assert!(pick_running(&[0.0, 0.0], 0.3).is_none());
    }
}
