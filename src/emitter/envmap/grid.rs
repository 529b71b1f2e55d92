//! Where an environment map's texels sit in (u, v), and the cells its
//! lookup interpolates over: the one place that knows the filter and the
//! row convention, so the lookup and the sampling density share their
//! cells exactly.
//!
//! Columns: texel `i` is centred at `u = (i + 0.5) / W` in both conventions
//! (u wraps). Rows ([`TexelRows`]): lente and Nori centre row `j` at
//! `v = (j + 0.5) / H` and clamp above the first and below the last centre;
//! Mitsuba puts row `j` at `v = j / (H - 1)`, the first and last rows on the
//! poles.
//!
//! The v axis is cut into *bands*. With the bilinear filter a band lies
//! between two rows of interpolation vertices (texel centres, plus, for
//! cell-centred rows, a copy of the first and last row on the poles, which
//! is what clamping means); with the nearest filter a band is the range of
//! v whose nearest row is one texel row. A *cell* is one band by one
//! column step.

use super::EnvFilter;
use crate::color::Rgb;
use crate::math::{clamp_unit_lanes, floor_i32, prefetch, prefetch_at, Vec2, Vec4};

/// Where texel rows sit along v.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TexelRows {
    /// Row `j` centred at `v = (j + 0.5) / H` (lente, Nori, pbrt).
    #[default]
    CellCentres,
    /// Row `j` at `v = j / (H - 1)`: first and last rows on the poles
    /// (Mitsuba's `envmap`). Needs two rows or more.
    PoleToPole,
}

/// A point of the map as a cell and a position inside it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct CellPoint {
    pub col: usize,
    pub band: usize,
    /// Position inside the cell along u and v, in [0, 1].
    pub fx: f32,
    pub fy: f32,
}

/// Four [`CellPoint`]s: their cells per lane, their positions in SIMD
/// lanes.
#[derive(Clone, Copy, Debug)]
pub(super) struct CellLanes {
    pub col: [usize; 4],
    pub band: [usize; 4],
    pub fx: Vec4,
    pub fy: Vec4,
}

impl CellLanes {
    /// Four points in lanes.
    #[inline]
    pub fn from_points(p: &[CellPoint; 4]) -> CellLanes {
        CellLanes {
            col: p.map(|p| p.col),
            band: p.map(|p| p.band),
            fx: Vec4::from_array(p.map(|p| p.fx)),
            fy: Vec4::from_array(p.map(|p| p.fy)),
        }
    }

    /// Lane `k` as a point.
    #[inline]
    pub fn point(&self, k: usize) -> CellPoint {
        CellPoint {
            col: self.col[k],
            band: self.band[k],
            fx: self.fx[k],
            fy: self.fy[k],
        }
    }
}

/// The cells of a W x H map for one filter and row convention.
#[derive(Clone, Debug)]
pub(super) struct TexelGrid {
    pub width: usize,
    pub filter: EnvFilter,
    /// Band of v: floor(v * band_scale + band_offset), clamped.
    pub band_scale: f32,
    pub band_offset: f32,
    /// Band `b` covers [edges[b], edges[b + 1]] of v.
    edges: Vec<f32>,
    inv_heights: Vec<f32>,
    /// Bilinear: the texel row of each interpolation vertex row (bands + 1
    /// of them); nearest: the texel row of each band.
    rows: Vec<usize>,
}

impl TexelGrid {
    /// The grid of a `width` x `height` map (both > 0; `height` >= 2 for
    /// [`TexelRows::PoleToPole`], which the caller checks).
    pub fn new(width: usize, height: usize, filter: EnvFilter, rows: TexelRows) -> TexelGrid {
        let h = height as f32;
        // (scale, offset, bands, position of band edge k, texel row of k)
        let (band_scale, band_offset, bands) = match (filter, rows) {
            (EnvFilter::Bilinear, TexelRows::CellCentres) => (h, 0.5, height + 1),
            (EnvFilter::Nearest, TexelRows::CellCentres) => (h, 0.0, height),
            (EnvFilter::Bilinear, TexelRows::PoleToPole) => (h - 1.0, 0.0, height - 1),
            (EnvFilter::Nearest, TexelRows::PoleToPole) => (h - 1.0, 0.5, height),
        };
        let edges: Vec<f32> = (0..=bands)
            .map(|k| ((k as f32 - band_offset) / band_scale).clamp(0.0, 1.0))
            .collect();
        let inv_heights = edges.windows(2).map(|e| 1.0 / (e[1] - e[0])).collect();
        let rows = match (filter, rows) {
            (EnvFilter::Bilinear, TexelRows::CellCentres) => (0..=bands)
                .map(|k| k.saturating_sub(1).min(height - 1))
                .collect(),
            (EnvFilter::Bilinear, TexelRows::PoleToPole) => (0..=bands).collect(),
            (EnvFilter::Nearest, _) => (0..bands).collect(),
        };
        TexelGrid {
            width,
            filter,
            band_scale,
            band_offset,
            edges,
            inv_heights,
            rows,
        }
    }

    pub fn bands(&self) -> usize {
        self.edges.len() - 1
    }

    /// Band `b`'s range of v.
    pub fn band_range(&self, b: usize) -> (f32, f32) {
        (self.edges[b], self.edges[b + 1])
    }

    /// The v of vertex row `k` (bilinear) or of band `k`'s edge.
    pub fn edge(&self, k: usize) -> f32 {
        self.edges[k]
    }

    /// Texel row of vertex row `k` (bilinear) or of band `k` (nearest).
    pub fn texel_row(&self, k: usize) -> usize {
        self.rows[k]
    }

    /// Half a column for the bilinear filter (its cells run between texel
    /// centres), none for the nearest.
    pub fn col_offset(&self) -> f32 {
        match self.filter {
            EnvFilter::Bilinear => 0.5,
            EnvFilter::Nearest => 0.0,
        }
    }

    /// The cell containing (u, v), u in [0, 1), v in [0, 1].
    #[inline]
    pub fn locate(&self, uv: Vec2) -> CellPoint {
        let w = self.width;
        let x = uv.x * w as f32 - self.col_offset();
        let xf = floor_i32(x);
        // x is in [-0.5, W): the column wraps by at most one turn.
        let col = match xf {
            c if c < 0 => w - 1,
            c if c as usize >= w => 0,
            c => c as usize,
        };
        let fx = (x - xf as f32).clamp(0.0, 1.0);
        let band = floor_i32(uv.y * self.band_scale + self.band_offset)
            .clamp(0, self.bands() as i32 - 1) as usize;
        let fy = ((uv.y - self.edges[band]) * self.inv_heights[band]).clamp(0.0, 1.0);
        CellPoint { col, band, fx, fy }
    }

    /// [`TexelGrid::locate`] of four points, (u, v) in lanes: the same
    /// cells and fractions bit for bit (tested through
    /// `EnvMap::locate_lanes`).
    #[inline]
    pub fn locate_lanes(&self, u: Vec4, v: Vec4) -> [CellPoint; 4] {
        let w = self.width;
        let x = u * w as f32 - self.col_offset();
        // floor_i32 of values in [-0.5, W] and [-1, bands + 1]: no
        // saturation, so the float floor converts exactly.
        let xf = x.floor().as_ivec4();
        // Back from the integer, as the scalar routine: a -0.0 floor
        // would keep its sign.
        let fx = clamp_unit_lanes(x - xf.as_vec4());
        let cols = xf.to_array();
        let band_of = (v * self.band_scale + self.band_offset).floor().as_ivec4();
        let last = self.bands() as i32 - 1;
        let band: [usize; 4] = std::array::from_fn(|k| band_of[k].clamp(0, last) as usize);
        let edge = Vec4::from_array(band.map(|b| self.edges[b]));
        let inv_height = Vec4::from_array(band.map(|b| self.inv_heights[b]));
        let fy = clamp_unit_lanes((v - edge) * inv_height);
        std::array::from_fn(|k| CellPoint {
            col: match cols[k] {
                c if c < 0 => w - 1,
                c if c as usize >= w => 0,
                c => c as usize,
            },
            band: band[k],
            fx: fx[k],
            fy: fy[k],
        })
    }

    /// The (u, v) of a point of a cell (u wrapped into [0, 1)).
    #[inline]
    pub fn to_uv(&self, p: CellPoint) -> Vec2 {
        let mut u = (p.col as f32 + p.fx + self.col_offset()) / self.width as f32;
        if u >= 1.0 {
            u -= 1.0;
        }
        let (v0, v1) = self.band_range(p.band);
        Vec2::new(u.clamp(0.0, 1.0), v0 + p.fy * (v1 - v0))
    }

    /// [`TexelGrid::to_uv`] of four points: (u, v) in lanes, each bit for
    /// bit the scalar routine's.
    #[inline]
    pub fn to_uv_lanes(&self, p: &CellLanes) -> (Vec4, Vec4) {
        let col = Vec4::from_array(p.col.map(|c| c as f32));
        let u = (col + p.fx + self.col_offset()) / self.width as f32;
        let u = Vec4::select(u.cmpge(Vec4::ONE), u - Vec4::ONE, u);
        let v0 = Vec4::from_array(p.band.map(|b| self.edges[b]));
        let v1 = Vec4::from_array(p.band.map(|b| self.edges[b + 1]));
        (clamp_unit_lanes(u), v0 + p.fy * (v1 - v0))
    }

    /// [`TexelGrid::lookup`] of four points with the bilinear filter:
    /// red, green and blue in lanes, each bit for bit the scalar lookup's
    /// (glam's `lerp`, channel by channel).
    #[inline]
    pub fn lookup_lanes_bilinear(&self, pixels: &[Rgb], p: &CellLanes) -> [Vec4; 3] {
        debug_assert!(self.filter == EnvFilter::Bilinear);
        let w = self.width;
        let texels: [[Rgb; 4]; 4] = std::array::from_fn(|k| {
            let (col, band) = (p.col[k], p.band[k]);
            let c1 = if col + 1 == w { 0 } else { col + 1 };
            let (r0, r1) = (self.rows[band] * w, self.rows[band + 1] * w);
            [
                pixels[r0 + col],
                pixels[r0 + c1],
                pixels[r1 + col],
                pixels[r1 + c1],
            ]
        });
        let (gx, gy) = (Vec4::ONE - p.fx, Vec4::ONE - p.fy);
        std::array::from_fn(|c| {
            let t = |corner: usize| Vec4::from_array(texels.map(|t| t[corner][c]));
            let top = t(0) * gx + t(1) * p.fx;
            let bottom = t(2) * gx + t(3) * p.fx;
            top * gy + bottom * p.fy
        })
    }

    /// The filtered texel value at a point.
    #[inline]
    pub fn lookup(&self, pixels: &[Rgb], p: CellPoint) -> Rgb {
        let w = self.width;
        match self.filter {
            EnvFilter::Nearest => pixels[self.rows[p.band] * w + p.col],
            EnvFilter::Bilinear => {
                let c1 = if p.col + 1 == w { 0 } else { p.col + 1 };
                let (r0, r1) = (self.rows[p.band] * w, self.rows[p.band + 1] * w);
                let top = pixels[r0 + p.col].lerp(pixels[r0 + c1], p.fx);
                let bottom = pixels[r1 + p.col].lerp(pixels[r1 + c1], p.fx);
                top.lerp(bottom, p.fy)
            }
        }
    }

    /// Prefetches the texels [`lookup`](Self::lookup) reads in a cell.
    #[inline]
    pub fn prefetch(&self, pixels: &[Rgb], col: usize, band: usize) {
        let w = self.width;
        match self.filter {
            EnvFilter::Nearest => prefetch_at(pixels, self.rows[band] * w + col),
            EnvFilter::Bilinear => {
                // Column col + 1 shares col's cache line or the next one.
                let c1 = if col + 1 == w { 0 } else { col + 1 };
                for r in [self.rows[band], self.rows[band + 1]] {
                    prefetch_at(pixels, r * w + col);
                    prefetch_at(pixels, r * w + c1);
                }
            }
        }
    }

    /// Prefetches the texels [`lookup`](Self::lookup) may read in cells
    /// `cols` of band `band` (a short run of columns, not wrapping).
    #[inline]
    pub fn prefetch_span(&self, pixels: &[Rgb], cols: std::ops::Range<usize>, band: usize) {
        let w = self.width;
        let rows = match self.filter {
            EnvFilter::Nearest => [self.rows[band], self.rows[band]],
            EnvFilter::Bilinear => [self.rows[band], self.rows[band + 1]],
        };
        // One prefetch per cache line of the run (and the column after it).
        let step = (64 / std::mem::size_of::<Rgb>()).max(1);
        for r in rows {
            let row = &pixels[r * w..(r + 1) * w];
            for c in cols.clone().step_by(step).chain([cols.end.min(w - 1)]) {
                prefetch(&row[c]);
            }
        }
    }

    /// The mean over the sphere of the filtered lookup of `values` (one per
    /// texel), integrated exactly: per band, the lookup is linear in v
    /// between its vertex rows (bilinear) or constant (nearest), and is
    /// integrated against sin(theta) in closed form; along u each column's
    /// value has weight 1 / W either way.
    pub fn sphere_mean(&self, values: &[f32]) -> f64 {
        let pi = std::f64::consts::PI;
        let w = self.width;
        let row_sum =
            |r: usize| -> f64 { values[r * w..(r + 1) * w].iter().map(|&x| x as f64).sum() };
        let mut total = 0.0;
        for b in 0..self.bands() {
            let (v0, v1) = (self.edges[b] as f64, self.edges[b + 1] as f64);
            let (h, c0, c1) = (v1 - v0, (pi * v0).cos(), (pi * v1).cos());
            // S = int sin(pi v) dv over the band; T = int t sin(pi v) dv with
            // t = (v - v0) / h rising from 0 to 1 across it.
            let s = (c0 - c1) / pi;
            match self.filter {
                EnvFilter::Nearest => total += s * row_sum(self.rows[b]),
                EnvFilter::Bilinear => {
                    let t = if h > 0.0 {
                        (-h * c1 / pi + ((pi * v1).sin() - (pi * v0).sin()) / (pi * pi)) / h
                    } else {
                        0.0
                    };
                    total += (s - t) * row_sum(self.rows[b]) + t * row_sum(self.rows[b + 1]);
                }
            }
        }
        // (1 / 4 pi) int L d omega = (1 / 4 pi) int L 2 pi^2 sin du dv.
        0.5 * pi * total / w as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grids() -> Vec<TexelGrid> {
        let mut g = Vec::new();
        for (w, h) in [(8, 4), (1, 1), (3, 2), (5, 7)] {
            for f in [EnvFilter::Bilinear, EnvFilter::Nearest] {
                g.push(TexelGrid::new(w, h, f, TexelRows::CellCentres));
                if h >= 2 {
                    g.push(TexelGrid::new(w, h, f, TexelRows::PoleToPole));
                }
            }
        }
        g
    }

    #[test]
    fn locate_and_to_uv_are_inverse_and_bands_tile_v() {
        for g in grids() {
            assert_eq!(g.edge(0), 0.0);
            assert_eq!(g.edge(g.bands()), 1.0);
            for b in 0..g.bands() {
                let (v0, v1) = g.band_range(b);
                assert!(v1 > v0, "{g:?}: empty band {b}");
            }
            for k in 0..=200 {
                for m in 0..=100 {
                    let uv = Vec2::new((k as f32 / 201.0).min(0.999), m as f32 / 100.0);
                    let p = g.locate(uv);
                    let (v0, v1) = g.band_range(p.band);
                    assert!(uv.y >= v0 - 1e-6 && uv.y <= v1 + 1e-6, "{g:?} {uv} {p:?}");
                    let back = g.to_uv(p);
                    let du = (back.x - uv.x).abs();
                    assert!(du.min(1.0 - du) < 1e-5 && (back.y - uv.y).abs() < 1e-5);
                }
            }
        }
    }

    #[test]
    fn rows_sit_where_each_convention_puts_them() {
        let (w, h) = (4, 5);
        let mut px = vec![Rgb::ZERO; w * h];
        for j in 0..h {
            for i in 0..w {
                px[j * w + i] = Rgb::new(i as f32, j as f32, 1.0);
            }
        }
        let centres = TexelGrid::new(w, h, EnvFilter::Bilinear, TexelRows::CellCentres);
        let poles = TexelGrid::new(w, h, EnvFilter::Bilinear, TexelRows::PoleToPole);
        for j in 0..h {
            let u = 2.5 / w as f32;
            let c = centres.lookup(
                &px,
                centres.locate(Vec2::new(u, (j as f32 + 0.5) / h as f32)),
            );
            let p = poles.lookup(&px, poles.locate(Vec2::new(u, j as f32 / (h - 1) as f32)));
            assert!((c - Rgb::new(2.0, j as f32, 1.0)).length() < 1e-5, "{c}");
            assert!((p - Rgb::new(2.0, j as f32, 1.0)).length() < 1e-5, "{p}");
        }
        // Cell-centred rows clamp above the first centre; pole-to-pole rows
        // blend all the way.
        let c = centres.lookup(&px, centres.locate(Vec2::new(0.5, 0.02)));
        assert!((c.y - 0.0).abs() < 1e-6, "{c}");
        let p = poles.lookup(&px, poles.locate(Vec2::new(0.5, 0.125)));
        assert!((p.y - 0.5).abs() < 1e-5, "{p}");
    }

    #[test]
    fn sphere_mean_of_a_constant_is_the_constant() {
        for g in grids() {
            let height = g.rows.iter().max().unwrap() + 1;
            let ones = vec![1.0; g.width * height];
            let m = g.sphere_mean(&ones);
            assert!((m - 1.0).abs() < 1e-6, "{g:?}: {m}");
        }
    }
}
