//! The sampling density of an environment map over (u, v): on the cells
//! of its [`TexelGrid`], bilinear in the luminance x sin(theta) of the
//! interpolation vertices for the bilinear filter (so it follows the
//! lookup inside each cell, not just the cell's mean), constant per texel
//! for the nearest filter.
//!
//! Sampling is O(1): an alias table picks the band, a second one the cell
//! in it, and the position inside the cell inverts the linear marginal in u
//! and then the linear conditional in v ([`sample_linear`]). The density
//! at a point is one cell lookup and a bilinear blend.

use super::grid::{CellLanes, CellPoint, TexelGrid};
use super::EnvFilter;
use crate::math::{prefetch_at, Vec2, Vec4};
use crate::sampling::{sample_linear, sample_linear_lanes, AliasRows, AliasTable};

/// A cell picked by [`EnvWarp::pick`], with uniform numbers in [0, 1)
/// left for the position inside it.
#[derive(Clone, Copy, Debug)]
pub(super) struct CellPick {
    col: usize,
    band: usize,
    ux: f32,
    uy: f32,
}

/// The corner values of four bilinear cells, corner by corner in lanes
/// (top-left, top-right, bottom-left, bottom-right).
#[derive(Clone, Copy, Debug)]
pub(super) struct CornerLanes {
    v00: Vec4,
    v10: Vec4,
    v01: Vec4,
    v11: Vec4,
}

/// A normalised density over (u, v) in [0, 1]^2.
#[derive(Clone, Debug)]
pub(super) struct EnvWarp {
    /// Bilinear: values at the (bands + 1) x W interpolation vertices;
    /// nearest: values of the bands x W cells. Row-major.
    values: Vec<f32>,
    width: usize,
    bilinear: bool,
    /// Picks a band, then a cell of it.
    bands: AliasTable,
    cells: AliasRows,
    /// 1 / (integral of the unnormalised density over (u, v)).
    inv_integral: f32,
}

impl CellPick {
    /// Cell (`col`, `band`) with `ux`, `uy` in [0, 1) to place a point in it.
    pub fn new(col: usize, band: usize, ux: f32, uy: f32) -> CellPick {
        CellPick { col, band, ux, uy }
    }
}

impl EnvWarp {
    /// The density proportional to `weight` (one value per texel, >= 0)
    /// times sin(theta), filtered as `grid` filters lookups. `None` if it
    /// is zero everywhere.
    pub fn new(grid: &TexelGrid, weight: &[f32]) -> Option<EnvWarp> {
        let w = grid.width;
        let bilinear = grid.filter == EnvFilter::Bilinear;
        let value_rows = if bilinear {
            grid.bands() + 1
        } else {
            grid.bands()
        };
        let mut values = vec![0.0f32; value_rows * w];
        for k in 0..value_rows {
            // sin(theta) averaged over the v this row stands for: the band
            // (nearest), or half of each band beside the vertex (bilinear).
            // Never zero, not even on a pole, so the density is positive
            // wherever the lookup is.
            let (v0, v1) = if bilinear {
                let below = if k > 0 { grid.edge(k - 1) } else { 0.0 };
                let above = if k < grid.bands() {
                    grid.edge(k + 1)
                } else {
                    1.0
                };
                (0.5 * (below + grid.edge(k)), 0.5 * (grid.edge(k) + above))
            } else {
                grid.band_range(k)
            };
            let sin_theta = mean_sin(v0, v1);
            let src = &weight[grid.texel_row(k) * w..][..w];
            for (dst, &x) in values[k * w..(k + 1) * w].iter_mut().zip(src) {
                *dst = if x.is_finite() && x > 0.0 {
                    x * sin_theta
                } else {
                    0.0
                };
            }
        }
        let cell_weights: Vec<f32> = (0..grid.bands())
            .flat_map(|b| (0..w).map(move |c| (c, b)))
            .map(|(c, b)| cell_weight(&values, w, bilinear, c, b))
            .collect();
        let cells = AliasRows::new(&cell_weights, w);
        let band_weights: Vec<f64> = (0..grid.bands())
            .map(|b| band_integral(grid, b, cells.total(b) as f64))
            .collect();
        let integral: f64 = band_weights.iter().sum();
        if !(integral > 0.0 && integral.is_finite()) {
            return None;
        }
        let band_weights: Vec<f32> = band_weights.iter().map(|&x| x as f32).collect();
        let inv_integral = (1.0 / integral) as f32;
        if !(inv_integral.is_finite() && inv_integral > 0.0) {
            return None;
        }
        Some(EnvWarp {
            values,
            width: w,
            bilinear,
            bands: AliasTable::new(&band_weights),
            cells,
            inv_integral,
        })
    }

    /// The density's values: at the (bands + 1) x W interpolation
    /// vertices (bilinear) or the bands x W cells (nearest), row-major,
    /// unnormalised (the GPU backend's tables, `gpu_tables.rs`).
    #[cfg(feature = "gpu")]
    pub fn values(&self) -> &[f32] {
        &self.values
    }

    /// Cell (`col`, `band`)'s weight: its integral is that times its
    /// band's height / W (/ 4 for the bilinear filter).
    #[inline]
    pub fn cell_weight(&self, col: usize, band: usize) -> f32 {
        cell_weight(&self.values, self.width, self.bilinear, col, band)
    }

    /// Running sums of the weights of cells `cols` of band `band` (each
    /// as [`EnvWarp::cell_weight`] gives it) into `out[..cols.len()]`.
    #[inline]
    pub fn running_cell_weights(&self, cols: std::ops::Range<usize>, band: usize, out: &mut [f32]) {
        let mut sum = 0.0f32;
        for (r, c) in out.iter_mut().zip(cols) {
            sum += self.cell_weight(c, band);
            *r = sum;
        }
    }

    /// The four corner values of a bilinear cell: (top-left, top-right,
    /// bottom-left, bottom-right).
    #[inline]
    fn corners(&self, col: usize, band: usize) -> (f32, f32, f32, f32) {
        let w = self.width;
        let c1 = if col + 1 == w { 0 } else { col + 1 };
        let (t, b) = (band * w, (band + 1) * w);
        let v = &self.values;
        (v[t + col], v[t + c1], v[b + col], v[b + c1])
    }

    /// Sampling a point with `u` in [0, 1)^2, first half: the cell, from
    /// the alias tables, with the unused randomness. It prefetches
    /// nothing: a caller that knows `u` early calls
    /// [`EnvWarp::prefetch_pick`] first, so that the alias entry, the
    /// corner values and the texels arrive while it does other work.
    #[inline]
    pub fn pick(&self, u: Vec2) -> CellPick {
        let (band, uy) = self.bands.sample(u.y);
        let (col, ux) = self.cells.sample(band, u.x);
        CellPick { col, band, ux, uy }
    }

    /// Prefetches what [`EnvWarp::pick`] with `u` reads (the cell's alias
    /// entry, and the corner values of the cell it most likely names: the
    /// one drawn, since an alias is a bright cell, which stays cached; that
    /// cell is also passed to `prefetch_texels(col, band)`), without
    /// waiting for any of it: for a caller that knows `u` well before it
    /// samples.
    #[inline]
    pub fn prefetch_pick(&self, u: Vec2, prefetch_texels: impl Fn(usize, usize)) {
        let (band, _) = self.bands.sample(u.y);
        let guess = self.cells.first_guess(u.x);
        self.prefetch_cell(guess, band);
        prefetch_texels(guess, band);
        self.cells.prefetch(band, guess);
    }

    /// Prefetches the values [`EnvWarp::pdf`] reads for a point of cell
    /// (`col`, `band`).
    #[inline]
    pub fn prefetch_cell(&self, col: usize, band: usize) {
        let w = self.width;
        prefetch_at(&self.values, band * w + col);
        if self.bilinear {
            prefetch_at(&self.values, (band + 1) * w + col);
        }
    }

    /// Sampling, second half: the point inside the picked cell.
    #[inline]
    pub fn place(&self, pick: CellPick) -> CellPoint {
        let CellPick { col, band, ux, uy } = pick;
        if !self.bilinear {
            return CellPoint {
                col,
                band,
                fx: ux,
                fy: uy,
            };
        }
        let (v00, v10, v01, v11) = self.corners(col, band);
        // Marginal in u: linear between the column sums; conditional in v:
        // linear between the top and bottom edges at that u.
        let fx = sample_linear(v00 + v01, v10 + v11, ux);
        let top = v00 + (v10 - v00) * fx;
        let bottom = v01 + (v11 - v01) * fx;
        let fy = sample_linear(top, bottom, uy);
        CellPoint { col, band, fx, fy }
    }

    /// Whether the density is bilinear inside cells (else constant).
    pub fn is_bilinear(&self) -> bool {
        self.bilinear
    }

    /// [`EnvWarp::place`] of four picks of a bilinear density, each lane
    /// bit for bit the scalar routine's, with the cells' corner values
    /// (for [`EnvWarp::pdf_lanes`]).
    #[inline]
    pub fn place_lanes(&self, picks: &[CellPick; 4]) -> (CellLanes, CornerLanes) {
        debug_assert!(self.bilinear);
        let (col, band) = (picks.map(|p| p.col), picks.map(|p| p.band));
        let corners = self.corners_of(&col, &band);
        let CornerLanes { v00, v10, v01, v11 } = corners;
        let fx = sample_linear_lanes(v00 + v01, v10 + v11, Vec4::from_array(picks.map(|p| p.ux)));
        let top = v00 + (v10 - v00) * fx;
        let bottom = v01 + (v11 - v01) * fx;
        let fy = sample_linear_lanes(top, bottom, Vec4::from_array(picks.map(|p| p.uy)));
        let cells = CellLanes { col, band, fx, fy };
        (cells, corners)
    }

    /// The corner values of the cells of four points of a bilinear
    /// density.
    #[inline]
    pub fn corner_lanes(&self, p: &CellLanes) -> CornerLanes {
        self.corners_of(&p.col, &p.band)
    }

    /// The corner values of cells (`col[k]`, `band[k]`), in lanes.
    #[inline]
    fn corners_of(&self, col: &[usize; 4], band: &[usize; 4]) -> CornerLanes {
        let c: [(f32, f32, f32, f32); 4] = std::array::from_fn(|k| self.corners(col[k], band[k]));
        CornerLanes {
            v00: Vec4::from_array(c.map(|c| c.0)),
            v10: Vec4::from_array(c.map(|c| c.1)),
            v01: Vec4::from_array(c.map(|c| c.2)),
            v11: Vec4::from_array(c.map(|c| c.3)),
        }
    }

    /// [`EnvWarp::pdf`] of four points of a bilinear density whose cells'
    /// corners are `corners`, bit for bit.
    #[inline]
    pub fn pdf_lanes(&self, p: &CellLanes, corners: &CornerLanes) -> Vec4 {
        let CornerLanes { v00, v10, v01, v11 } = *corners;
        let top = v00 + (v10 - v00) * p.fx;
        let bottom = v01 + (v11 - v01) * p.fx;
        (top + (bottom - top) * p.fy) * self.inv_integral
    }

    /// Density w.r.t. area in (u, v) at a point.
    #[inline]
    pub fn pdf(&self, p: CellPoint) -> f32 {
        let value = if self.bilinear {
            let (v00, v10, v01, v11) = self.corners(p.col, p.band);
            let top = v00 + (v10 - v00) * p.fx;
            let bottom = v01 + (v11 - v01) * p.fx;
            top + (bottom - top) * p.fy
        } else {
            self.values[p.band * self.width + p.col]
        };
        value * self.inv_integral
    }
}

/// Band `band`'s integral over (u, v) from the sum of its cells' weights
/// ([`EnvWarp::cell_weight`]): times its height / W (/ 4 for the bilinear
/// filter, whose weights sum four corners).
pub(super) fn band_integral(grid: &TexelGrid, band: usize, cell_weights: f64) -> f64 {
    let (v0, v1) = grid.band_range(band);
    let scale = if grid.filter == EnvFilter::Bilinear {
        0.25
    } else {
        1.0
    };
    cell_weights * scale * (v1 - v0) as f64 / grid.width as f64
}

/// A cell's weight from the density's values (rows of `w`): the sum of its
/// corners (bilinear) or its value (nearest).
#[inline]
fn cell_weight(values: &[f32], w: usize, bilinear: bool, col: usize, band: usize) -> f32 {
    if bilinear {
        let c1 = if col + 1 == w { 0 } else { col + 1 };
        let (top, bottom) = (&values[band * w..][..w], &values[(band + 1) * w..][..w]);
        top[col] + top[c1] + bottom[col] + bottom[c1]
    } else {
        values[band * w + col]
    }
}

/// The mean of sin(pi v) over [v0, v1] (v0 < v1 in [0, 1]).
fn mean_sin(v0: f32, v1: f32) -> f32 {
    let (v0, v1) = (v0 as f64, v1 as f64);
    let pi = std::f64::consts::PI;
    let m = if v1 > v0 {
        ((pi * v0).cos() - (pi * v1).cos()) / (pi * (v1 - v0))
    } else {
        (pi * v0).sin()
    };
    m.max(0.0) as f32
}
