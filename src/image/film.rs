//! The film: filter-weighted sample accumulation, tile by tile.
//!
//! Each tile accumulates into its own block (the tile plus a border as wide
//! as the filter). Blocks are merged in a fixed order, so the image is the
//! same bit for bit whatever the thread count or completion order.

use super::{Bitmap, Filter, FilterEval, MAX_FILTER_RADIUS};
use crate::color::Rgb;
use crate::math::{ceil_i32, floor_i32, Vec2};
use glam::Vec4;

/// Accumulated weighted radiance and weight for one tile plus its border.
#[derive(Clone, Debug)]
pub struct FilmBlock {
    /// Top-left pixel of the block (may be negative: the border).
    pub x0: i32,
    pub y0: i32,
    pub width: usize,
    pub height: usize,
    /// (sum of w * L, sum of w) per pixel, as (r, g, b, w): one SIMD
    /// multiply-add per cell a sample reaches.
    pub data: Vec<Vec4>,
    /// AOV channels per pixel, and their filter-weighted sums (`aov_channels`
    /// per pixel; the weights are the image's).
    pub aov_channels: usize,
    pub aov: Vec<f32>,
    filter: FilterEval,
    radius: f32,
    /// The filter is Mitsuba's box (radius 1/2): see [`FilmBlock::splat`].
    pixel_box: bool,
    /// The filter is a Gaussian of radius at most 2 (Mitsuba's default is
    /// 2): see [`FilmBlock::gaussian_window`].
    gaussian_4: bool,
    /// The CPU has AVX2: [`FilmBlock::put`] splats a Gaussian sample in
    /// eight lanes.
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    avx2: bool,
}

/// Whether this CPU runs AVX2 code (detected at run time: users build
/// without target-cpu flags).
fn cpu_has_avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    return std::arch::is_x86_feature_detected!("avx2");
    #[cfg(not(target_arch = "x86_64"))]
    false
}

/// Weights along x kept per sample for filters of radius up to 3.5 pixels
/// (box, tent, Gaussian, Mitchell, 3-lobe Lanczos: at most 8 columns);
/// wider ones use room for [`MAX_FILTER_RADIUS`]. Clearing the wide array
/// for every sample cost 1.5% of a render.
const NARROW_COLUMNS: usize = 8;
const WIDE_COLUMNS: usize = 2 * MAX_FILTER_RADIUS as usize + 2;

impl FilmBlock {
    /// A block for the tile at (`x`, `y`) of size `w` x `h`.
    pub fn new(x: u32, y: u32, w: u32, h: u32, filter: Filter) -> FilmBlock {
        let radius = filter.radius();
        let border = radius.ceil() as i32;
        let width = w as usize + 2 * border as usize;
        let height = h as usize + 2 * border as usize;
        FilmBlock {
            x0: x as i32 - border,
            y0: y as i32 - border,
            width,
            height,
            data: vec![Vec4::ZERO; width * height],
            aov_channels: 0,
            aov: Vec::new(),
            filter: filter.evaluator(),
            radius,
            pixel_box: filter == Filter::Box { radius: 0.5 },
            gaussian_4: matches!(filter, Filter::Gaussian { radius, .. } if radius <= 2.0),
            avx2: cpu_has_avx2(),
        }
    }

    /// Calls `f(self, cell, w)` for every cell a sample at `pos` reaches
    /// with a nonzero weight `w` ([`Footprint::for_each`]), its weights
    /// along x in an array of [`NARROW_COLUMNS`] where they fit.
    #[inline(always)]
    fn splat(&mut self, pos: Vec2, mut f: impl FnMut(&mut FilmBlock, usize, f32)) {
        // A box of radius 1/2 gives a sample inside a pixel to that pixel
        // alone, with weight 1 (one on a pixel's edge reaches both sides:
        // the general path). The same cell and weight as the general path,
        // without its bounds and weights (4% of a render's instructions).
        if self.pixel_box {
            let (x, y) = (floor_i32(pos.x), floor_i32(pos.y));
            let (cx, cy) = (x.wrapping_sub(self.x0), y.wrapping_sub(self.y0));
            if x as f32 != pos.x
                && y as f32 != pos.y
                && (cx as u32 as usize) < self.width
                && (cy as u32 as usize) < self.height
            {
                f(self, cy as usize * self.width + cx as usize, 1.0);
                return;
            }
        }
        if let Some((first, wx, wy)) = self.gaussian_window(pos) {
            for (j, &wyj) in wy.iter().enumerate() {
                let row = first + j * self.width;
                for (i, &wxi) in wx.iter().enumerate() {
                    f(self, row + i, wyj * wxi);
                }
            }
            return;
        }
        if self.radius <= 0.5 * (NARROW_COLUMNS - 1) as f32 {
            self.footprint::<NARROW_COLUMNS>(pos)
                .for_each(|cell, w| f(self, cell, w));
        } else {
            self.footprint::<WIDE_COLUMNS>(pos)
                .for_each(|cell, w| f(self, cell, w));
        }
    }

    /// A Gaussian of radius r <= 2 reaches, from a sample off the pixel
    /// grid's lines, the 4 x 4 pixels from floor(p - 1/2) - 1 on (the
    /// general path's window for r = 2; for a smaller r the extra cells
    /// have weight 0, as do those at distance r, where the Gaussian is cut
    /// to 0). Away from the block's edges: the window's first cell and the
    /// weights along x and y, for a fixed 4 x 4 loop with the general
    /// path's weights in its order (zero weights add +-0, which leaves
    /// every sum's bits as the general path leaves them). 15% of a
    /// render's instructions on Mitsuba's default filter.
    #[inline(always)]
    fn gaussian_window(&self, pos: Vec2) -> Option<(usize, [f32; 4], [f32; 4])> {
        let (first, x, y) = self.gaussian_offsets(pos)?;
        let weights = |x: Vec4| -> [f32; 4] {
            let w = self.filter.gaussian_4(x);
            w.map_or([0.0; 4], |w| w.to_array())
        };
        Some((first, weights(x), weights(y)))
    }

    /// [`FilmBlock::gaussian_window`]'s first cell and the offsets its
    /// weights are taken at: -1, 0, 1, 2 from floor(p) along x, then y.
    #[inline(always)]
    fn gaussian_offsets(&self, pos: Vec2) -> Option<(usize, Vec4, Vec4)> {
        if !self.gaussian_4 {
            return None;
        }
        let (px, py) = (pos.x - 0.5, pos.y - 0.5);
        let (fx, fy) = (floor_i32(px), floor_i32(py));
        if fx as f32 == px || fy as f32 == py {
            return None;
        }
        let first = self.gaussian_first_cell(fx, fy)?;
        let offsets = |f0: i32, p: f32| {
            Vec4::new(
                (f0 - 1) as f32 - p,
                f0 as f32 - p,
                (f0 + 1) as f32 - p,
                (f0 + 2) as f32 - p,
            )
        };
        Some((first, offsets(fx, px), offsets(fy, py)))
    }

    /// The first cell of the 4 x 4 window whose pixel (`fx`, `fy`) is
    /// floor(p - 1/2): `None` where the window leaves the block (both
    /// Gaussian paths' bounds, saturated or wrapped floors included).
    #[inline(always)]
    fn gaussian_first_cell(&self, fx: i32, fy: i32) -> Option<usize> {
        let cx = fx.wrapping_sub(1).wrapping_sub(self.x0);
        let cy = fy.wrapping_sub(1).wrapping_sub(self.y0);
        if (cx as u32 as usize).saturating_add(4) > self.width
            || (cy as u32 as usize).saturating_add(4) > self.height
        {
            return None;
        }
        Some(cy as usize * self.width + cx as usize)
    }

    /// The same block with room for `channels` AOV values per pixel.
    pub fn with_aovs(mut self, channels: usize) -> FilmBlock {
        self.aov_channels = channels;
        self.aov = vec![0.0; channels * self.width * self.height];
        self
    }

    /// Splats AOV values (`aov_channels` of them) at a film position, with
    /// the weights [`FilmBlock::put`] gives the image's sample there.
    pub fn put_aovs(&mut self, pos: Vec2, values: &[f32]) {
        let n = self.aov_channels;
        if n == 0 || values[..n].iter().any(|v| !v.is_finite()) {
            return;
        }
        self.splat(pos, |block, cell, w| {
            for (acc, v) in block.aov[cell * n..cell * n + n].iter_mut().zip(values) {
                *acc += w * v;
            }
        });
    }

    /// Splats a radiance sample at a film position (pixels; pixel centres at
    /// +0.5) onto every pixel within the filter radius.
    #[inline]
    pub fn put(&mut self, pos: Vec2, value: Rgb) {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `avx2` says the CPU has AVX2.
        if self.avx2 && self.gaussian_4 && unsafe { self.put_gaussian_avx2(pos, value) } {
            return;
        }
        self.put_general(pos, value);
    }

    /// [`FilmBlock::put`] of each sample `values[k]` at `positions[k]`, in
    /// order (the same sums, so the same bits). With AVX2 and a Gaussian
    /// the whole loop runs in one AVX2 function, where the splat inlines
    /// (a call per sample was 30 of its 220 instructions).
    pub fn put_all(&mut self, positions: &[Vec2], values: &[Rgb]) {
        #[cfg(target_arch = "x86_64")]
        if self.avx2 && self.gaussian_4 {
            // SAFETY: `avx2` says the CPU has AVX2.
            unsafe { self.put_all_gaussian_avx2(positions, values) };
            return;
        }
        for (&pos, &value) in positions.iter().zip(values) {
            self.put(pos, value);
        }
    }

    /// [`FilmBlock::put_all`]'s loop compiled for AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    fn put_all_gaussian_avx2(&mut self, positions: &[Vec2], values: &[Rgb]) {
        // Eight samples' weights first (independent work the CPU runs side
        // by side), then their sums in order, the others' general path in
        // its turn: the same sums in the same order as one at a time.
        const GROUP: usize = 8;
        for (pos, val) in positions.chunks(GROUP).zip(values.chunks(GROUP)) {
            let splats: [Option<GaussianSplat>; GROUP] = std::array::from_fn(|k| {
                let (p, v) = (pos.get(k)?, val.get(k)?);
                self.gaussian_splat_avx2(*p, *v)
            });
            for ((&p, &v), splat) in pos.iter().zip(val).zip(&splats) {
                match splat {
                    Some(splat) => self.add_splat_avx2(splat),
                    None => self.put_general(p, v),
                }
            }
        }
    }

    /// [`FilmBlock::put`] without its AVX2 fast path.
    #[inline(never)]
    fn put_general(&mut self, pos: Vec2, value: Rgb) {
        if !value.is_finite() {
            return;
        }
        // (w r, w g, w b, w 1): the products and sums the separate
        // fields took, lane by lane.
        let value = value.extend(1.0);
        if let Some((first, wx, wy)) = self.gaussian_window(pos) {
            // Row by row: one bounds check a row, the row's four weights
            // wy_j wx_i in one multiply (the same products, so the same
            // bits, as one at a time).
            let wx = Vec4::from(wx);
            for (j, &wyj) in wy.iter().enumerate() {
                let start = first + j * self.width;
                let w = (wx * wyj).to_array();
                for (cell, &wij) in self.data[start..start + 4].iter_mut().zip(&w) {
                    *cell += wij * value;
                }
            }
            return;
        }
        self.splat(pos, |block, cell, w| {
            block.data[cell] += w * value;
        });
    }

    /// [`FilmBlock::put`]'s 4 x 4 Gaussian splat in AVX lanes, for a finite
    /// sample whose window [`FilmBlock::gaussian_offsets`] takes (false,
    /// and nothing added, for the others: the caller's general path sees
    /// to them): [`FilmBlock::gaussian_splat_avx2`], then
    /// [`FilmBlock::add_splat_avx2`].
    #[cfg(target_arch = "x86_64")]
    #[inline]
    #[target_feature(enable = "avx2")]
    fn put_gaussian_avx2(&mut self, pos: Vec2, value: Rgb) -> bool {
        match self.gaussian_splat_avx2(pos, value) {
            Some(splat) => {
                self.add_splat_avx2(&splat);
                true
            }
            None => false,
        }
    }

    /// What a Gaussian sample adds, in AVX lanes: the window's floor and
    /// offsets, the eight weights along x and y in one
    /// [`FilterEval::gaussian_8`], the sixteen products wy_j wx_i in two
    /// multiplies. The same products as the four-lane loop, so the same
    /// bits (tested); `None` where [`FilmBlock::put_gaussian_avx2`] is
    /// false. Reads the block's shape only, so a batch computes several
    /// before it adds them (their exponentials' chains overlap).
    #[cfg(target_arch = "x86_64")]
    #[inline]
    #[target_feature(enable = "avx2")]
    fn gaussian_splat_avx2(&self, pos: Vec2, value: Rgb) -> Option<GaussianSplat> {
        use std::arch::x86_64::*;
        // value.extend(1.0), finite in every lane (NaN compares false).
        let v = _mm_setr_ps(value.x, value.y, value.z, 1.0);
        let magnitude = _mm_andnot_ps(_mm_set1_ps(-0.0), v);
        if _mm_movemask_ps(_mm_cmplt_ps(magnitude, _mm_set1_ps(f32::INFINITY))) != 0xF {
            return None;
        }
        let (px, py) = (pos.x - 0.5, pos.y - 0.5);
        let p = _mm256_setr_ps(px, px, px, px, py, py, py, py);
        let floor = _mm256_floor_ps(p);
        let (fx, fy) = (
            _mm256_cvtss_f32(floor),
            _mm_cvtss_f32(_mm256_extractf128_ps::<1>(floor)),
        );
        // Beyond i32 (or NaN) the conversion gives i32::MIN, which the
        // bounds below refuse; within them the floor is floor_i32's.
        let i = _mm256_cvttps_epi32(floor);
        let (ix, iy) = (_mm256_extract_epi32::<0>(i), _mm256_extract_epi32::<4>(i));
        if fx == px || fy == py {
            return None;
        }
        let first = self.gaussian_first_cell(ix, iy)?;
        // (floor - 1) - p .. (floor + 2) - p: integers this small are exact
        // in f32, so these are gaussian_offsets' (f0 + k) as f32 - p.
        let steps = _mm256_setr_ps(-1.0, 0.0, 1.0, 2.0, -1.0, 0.0, 1.0, 2.0);
        let offsets = _mm256_sub_ps(_mm256_add_ps(floor, steps), p);
        let w = self
            .filter
            .gaussian_8(offsets)
            .unwrap_or(_mm256_setzero_ps());
        // Lanes 0-3 hold wx, 4-7 wy: (wx, wx) times (wy_j x4, wy_j+1 x4).
        let wx = _mm256_permute2f128_ps::<0x00>(w, w);
        let idx = |a: i32, b: i32| _mm256_setr_epi32(a, a, a, a, b, b, b, b);
        let rows = [
            _mm256_mul_ps(wx, _mm256_permutevar8x32_ps(w, idx(4, 5))),
            _mm256_mul_ps(wx, _mm256_permutevar8x32_ps(w, idx(6, 7))),
        ];
        Some(GaussianSplat {
            first,
            rows,
            value: _mm256_set_m128(v, v),
        })
    }

    /// Adds a [`GaussianSplat`]: two cells (eight floats) per multiply and
    /// add, half of the four-lane loop's instructions.
    #[cfg(target_arch = "x86_64")]
    #[inline]
    #[target_feature(enable = "avx2")]
    fn add_splat_avx2(&mut self, splat: &GaussianSplat) {
        use std::arch::x86_64::*;
        let idx = |a: i32, b: i32| _mm256_setr_epi32(a, a, a, a, b, b, b, b);
        // Each cell's weight spread over its four floats: cells (0, 1) and
        // (2, 3) of a row, from lanes (4 r, 4 r + 1) and (4 r + 2, 4 r + 3).
        let spread = [idx(0, 1), idx(2, 3), idx(4, 5), idx(6, 7)];
        for j in 0..4 {
            let start = splat.first + j * self.width;
            let row = &mut self.data[start..start + 4];
            let ptr = row.as_mut_ptr() as *mut f32;
            let pair = splat.rows[j / 2];
            for half in 0..2 {
                let wij = _mm256_permutevar8x32_ps(pair, spread[2 * (j % 2) + half]);
                // SAFETY: `row` holds four cells of four floats each: the
                // eight floats at 8 x half are inside it.
                unsafe {
                    let cell = ptr.add(8 * half);
                    let sum = _mm256_add_ps(_mm256_loadu_ps(cell), _mm256_mul_ps(wij, splat.value));
                    _mm256_storeu_ps(cell, sum);
                }
            }
        }
    }

    /// The block's pixels a sample at film position `pos` reaches, with
    /// the filter's weights along x (at most `N` columns: see
    /// [`NARROW_COLUMNS`]).
    #[inline(always)]
    fn footprint<const N: usize>(&self, pos: Vec2) -> Footprint<N> {
        let px = pos.x - 0.5;
        let py = pos.y - 0.5;
        let xmin = ceil_i32(px - self.radius).max(self.x0);
        let xmax = floor_i32(px + self.radius).min(self.x0 + self.width as i32 - 1);
        let ymin = ceil_i32(py - self.radius).max(self.y0);
        let ymax = floor_i32(py + self.radius).min(self.y0 + self.height as i32 - 1);
        // The filter is separable: its weights along x are the same for
        // every row, so they are evaluated once (at most 2 r + 1 of them).
        let mut wx = [0.0f32; N];
        for (x, w) in (xmin..=xmax).zip(wx.iter_mut()) {
            *w = self.filter.eval_1d(x as f32 - px);
        }
        Footprint {
            wx,
            xmin,
            xmax,
            ymin,
            ymax,
            py,
            filter: self.filter,
            x0: self.x0,
            y0: self.y0,
            width: self.width,
        }
    }
}

/// A Gaussian sample's 4 x 4 window in a [`FilmBlock`]: its first cell,
/// the weights of rows (0, 1) and (2, 3) (four per row), and the sample's
/// (r, g, b, 1) twice.
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
struct GaussianSplat {
    first: usize,
    rows: [std::arch::x86_64::__m256; 2],
    value: std::arch::x86_64::__m256,
}

/// The cells one sample reaches in a [`FilmBlock`] (see
/// [`FilmBlock::footprint`]).
struct Footprint<const N: usize> {
    wx: [f32; N],
    xmin: i32,
    xmax: i32,
    ymin: i32,
    ymax: i32,
    py: f32,
    filter: FilterEval,
    x0: i32,
    y0: i32,
    width: usize,
}

impl<const N: usize> Footprint<N> {
    /// Calls `f(cell, w)` for every cell with a nonzero weight `w`, cells
    /// indexed row-major in the block, rows in order.
    #[inline(always)]
    fn for_each(&self, mut f: impl FnMut(usize, f32)) {
        for y in self.ymin..=self.ymax {
            let wy = self.filter.eval_1d(y as f32 - self.py);
            if wy == 0.0 {
                continue;
            }
            let row = (y - self.y0) as usize * self.width;
            for (x, &wxi) in (self.xmin..=self.xmax).zip(self.wx.iter()) {
                let w = wy * wxi;
                if w == 0.0 {
                    continue;
                }
                f(row + (x - self.x0) as usize, w);
            }
        }
    }
}

/// The whole image's accumulation buffer.
#[derive(Clone, Debug)]
pub struct Film {
    pub width: usize,
    pub height: usize,
    data: Vec<(Rgb, f32)>,
    /// AOV channels per pixel and their weighted sums (see [`FilmBlock`]).
    aov_channels: usize,
    aov: Vec<f32>,
}

impl Film {
    pub fn new(width: usize, height: usize) -> Film {
        Film {
            width,
            height,
            data: vec![(Rgb::ZERO, 0.0); width * height],
            aov_channels: 0,
            aov: Vec::new(),
        }
    }

    /// The same film with room for `channels` AOV values per pixel.
    pub fn with_aovs(mut self, channels: usize) -> Film {
        self.aov_channels = channels;
        self.aov = vec![0.0; channels * self.width * self.height];
        self
    }

    /// AOV channels per pixel.
    pub fn aov_channels(&self) -> usize {
        self.aov_channels
    }

    /// The weighted AOV sums, `aov_channels` per pixel, row-major.
    pub fn aov_sums(&self) -> &[f32] {
        &self.aov
    }

    /// Sets the weighted AOV sums (`channels` per pixel); `None` unless
    /// there are that many per pixel.
    pub fn set_aov_sums(&mut self, channels: usize, sums: Vec<f32>) -> Option<()> {
        (channels.checked_mul(self.width * self.height) == Some(sums.len())).then(|| {
            self.aov_channels = channels;
            self.aov = sums;
        })
    }

    /// AOV channel `c` normalised by the image's weights (0 where no
    /// sample landed).
    pub fn aov_channel(&self, c: usize) -> Vec<f32> {
        (0..self.data.len()).map(|i| self.aov_value(i, c)).collect()
    }

    /// AOV channel `c` of pixel `i` (row-major): weighted sum over weight,
    /// 0 where no sample landed.
    pub fn aov_value(&self, i: usize, c: usize) -> f32 {
        let w = self.data[i].1;
        if w != 0.0 {
            self.aov[i * self.aov_channels + c] / w
        } else {
            0.0
        }
    }

    /// A film from its accumulated (sum of w * L, sum of w) per pixel,
    /// row-major; `None` unless there are `width * height` of them.
    pub fn from_data(width: usize, height: usize, data: Vec<(Rgb, f32)>) -> Option<Film> {
        (width.checked_mul(height) == Some(data.len())).then_some(Film {
            width,
            height,
            data,
            aov_channels: 0,
            aov: Vec::new(),
        })
    }

    /// The accumulated (sum of w * L, sum of w) per pixel, row-major.
    pub fn data(&self) -> &[(Rgb, f32)] {
        &self.data
    }

    /// Adds another film of the same size pixel by pixel: the film of the
    /// two renders' samples together.
    pub fn add(&mut self, other: &Film) {
        assert_eq!((self.width, self.height), (other.width, other.height));
        assert_eq!(self.aov_channels, other.aov_channels);
        for (dst, src) in self.data.iter_mut().zip(&other.data) {
            dst.0 += src.0;
            dst.1 += src.1;
        }
        for (dst, src) in self.aov.iter_mut().zip(&other.aov) {
            *dst += src;
        }
    }

    /// Adds a block's contents (clipped to the image).
    pub fn merge(&mut self, block: &FilmBlock) {
        // The block's columns inside the film, the same for every row:
        // each row is then one run of additions, without a bounds test per
        // pixel (the same sums in the same order).
        let x_lo = block.x0.max(0);
        let x_hi = (block.x0 + block.width as i32).min(self.width as i32);
        if x_lo >= x_hi {
            return;
        }
        let (bx, n) = ((x_lo - block.x0) as usize, (x_hi - x_lo) as usize);
        let channels = self.aov_channels;
        let aovs = channels > 0 && block.aov_channels == channels;
        for by in 0..block.height {
            let y = block.y0 + by as i32;
            if y < 0 || y >= self.height as i32 {
                continue;
            }
            let (s, d) = (
                by * block.width + bx,
                y as usize * self.width + x_lo as usize,
            );
            for (dst, src) in self.data[d..d + n].iter_mut().zip(&block.data[s..s + n]) {
                dst.0 += src.truncate();
                dst.1 += src.w;
            }
            if aovs {
                let (s, d) = (s * channels, d * channels);
                let dst = &mut self.aov[d..d + n * channels];
                for (a, b) in dst.iter_mut().zip(&block.aov[s..s + n * channels]) {
                    *a += b;
                }
            }
        }
    }

    /// The normalised image: weighted radiance over weight (black where no
    /// sample landed).
    pub fn to_bitmap(&self) -> Bitmap {
        let mut bmp = Bitmap::new(self.width, self.height);
        for (i, dst) in bmp.pixels.iter_mut().enumerate() {
            *dst = self.value(i);
        }
        bmp
    }

    /// Pixel `i` (row-major) as viewers see it: weighted radiance over
    /// weight, black where no sample landed.
    pub fn value(&self, i: usize) -> Rgb {
        let (sum, w) = self.data[i];
        if w != 0.0 {
            sum / w
        } else {
            Rgb::ZERO
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Merging adds each block cell inside the film to its pixel and
    /// drops the rest (blocks over every edge and corner of the film, and
    /// one beside it), AOVs alike: the sums of a pixel-by-pixel merge,
    /// bit for bit.
    #[test]
    fn merging_adds_the_cells_inside_the_film() {
        let mut s = crate::sampling::Sampler::new(5, 1);
        let (w, h) = (13usize, 9usize);
        let mut film = Film::new(w, h).with_aovs(2);
        let mut reference = film.clone();
        // (x, y, width, height) of tiles whose blocks (2-pixel borders)
        // cross the film's edges, cover it, or miss it.
        for (x, y, tw, th) in [
            (0, 0, 4, 4),
            (9, 0, 4, 5),
            (10, 6, 3, 3),
            (0, 5, 13, 4),
            (4, 0, 5, 9),
            (20, 2, 3, 3),
        ] {
            let mut block = FilmBlock::new(x, y, tw, th, Filter::default()).with_aovs(2);
            for _ in 0..200 {
                let pos = Vec2::new(
                    x as f32 + tw as f32 * s.next_1d(),
                    y as f32 + th as f32 * s.next_1d(),
                );
                block.put(pos, Rgb::new(s.next_1d(), 2.0 * s.next_1d(), -s.next_1d()));
                block.put_aovs(pos, &[s.next_1d(), 1.0]);
            }
            film.merge(&block);
            for by in 0..block.height {
                for bx in 0..block.width {
                    let (x, y) = (block.x0 + bx as i32, block.y0 + by as i32);
                    if x < 0 || y < 0 || x >= w as i32 || y >= h as i32 {
                        continue;
                    }
                    let (src, dst) = (by * block.width + bx, y as usize * w + x as usize);
                    let cell = block.data[src];
                    reference.data[dst].0 += cell.truncate();
                    reference.data[dst].1 += cell.w;
                    for c in 0..2 {
                        reference.aov[2 * dst + c] += block.aov[2 * src + c];
                    }
                }
            }
        }
        let bits = |f: &Film| {
            let image: Vec<[u32; 4]> = (f.data.iter())
                .map(|(c, w)| [c.x, c.y, c.z, *w].map(f32::to_bits))
                .collect();
            (image, f.aov.iter().map(|a| a.to_bits()).collect::<Vec<_>>())
        };
        assert!(
            film.data.iter().all(|p| p.1 > 0.0),
            "every pixel was reached"
        );
        assert_eq!(bits(&film), bits(&reference));
    }

    /// The 4 x 4 Gaussian path (in AVX2 lanes where the CPU has them, and
    /// in four lanes) leaves every cell's bits as the general path does:
    /// samples anywhere in a tile, on the pixel grid's lines,
    /// at the block's edges, with negative and zero values, for radii 2,
    /// 1.5 and 1 (and AOVs alike).
    #[test]
    fn the_gaussian_fast_path_adds_what_the_general_path_adds() {
        let mut s = crate::sampling::Sampler::new(11, 0);
        for (radius, stddev) in [(2.0, 0.5), (1.5, 0.4), (1.0, 0.5)] {
            let f = Filter::Gaussian { radius, stddev };
            let mut fast = FilmBlock::new(16, 16, 8, 8, f).with_aovs(2);
            let mut general = fast.clone();
            general.gaussian_4 = false;
            general.avx2 = false;
            // The four-lane loop, where `fast` takes the AVX2 splat.
            let mut four = fast.clone();
            four.avx2 = false;
            // All the samples at once (`put_all`), the edge and
            // non-finite ones left to the general path in the loop.
            let mut all = fast.clone();
            let (mut positions, mut values) = (Vec::new(), Vec::new());
            assert!(fast.gaussian_4);
            assert_eq!(fast.avx2, cpu_has_avx2());
            for i in 0..4000 {
                let mut pos = Vec2::new(16.0 + 8.0 * s.next_1d(), 16.0 + 8.0 * s.next_1d());
                match i % 5 {
                    0 => pos.x = pos.x.floor() + 0.5,
                    1 => pos.y = 16.0,
                    2 => pos = Vec2::new(23.999, 16.0 + 1e-3),
                    _ => {}
                }
                let mut v = Rgb::new(s.next_1d() - 0.3, 2.0 * s.next_1d(), 0.0);
                if i % 7 == 3 {
                    v.y = f32::NAN;
                }
                positions.push(pos);
                values.push(v);
                fast.put(pos, v);
                four.put(pos, v);
                general.put(pos, v);
                fast.put_aovs(pos, &[v.x, -v.y]);
                general.put_aovs(pos, &[v.x, -v.y]);
            }
            let bits = |b: &FilmBlock| -> Vec<u32> {
                (b.data.iter().flat_map(|c| c.to_array()))
                    .chain(b.aov.iter().copied())
                    .map(f32::to_bits)
                    .collect()
            };
            all.put_all(&positions, &values);
            let image = |b: &FilmBlock| bits(b)[..4 * b.data.len()].to_vec();
            assert_eq!(bits(&fast), bits(&general), "radius {radius}");
            assert_eq!(image(&all), image(&general), "radius {radius}, all at once");
            assert_eq!(bits(&four).len(), bits(&general).len());
            assert_eq!(
                bits(&four)[..4 * four.data.len()],
                bits(&general)[..4 * general.data.len()],
                "radius {radius}, four lanes"
            );
        }
    }

    /// A sample lands on every cell within the radius with the product of
    /// the filter's weights along x and y, for filters whose weights along
    /// x fit the narrow array and for wider ones, and for Mitsuba's box
    /// (its own path) inside a pixel, on an edge (two pixels) and on a
    /// corner (four), at the tile's border too.
    #[test]
    fn a_sample_gets_the_filter_weights_narrow_and_wide() {
        for f in [
            Filter::Box { radius: 0.5 },
            Filter::default(),
            Filter::Lanczos { radius: 3.0 },
            Filter::Gaussian {
                radius: 3.6,
                stddev: 1.0,
            },
            Filter::Lanczos { radius: 6.0 },
        ] {
            for pos in [
                Vec2::new(20.3, 17.8),
                Vec2::new(16.5, 16.5),
                Vec2::new(23.99, 16.01),
                Vec2::new(20.0, 17.5),
                Vec2::new(19.0, 18.0),
                Vec2::new(16.0, 23.999),
                Vec2::new(24.0, 24.0),
            ] {
                let mut block = FilmBlock::new(16, 16, 8, 8, f);
                block.put(pos, Rgb::splat(2.0));
                for (i, &lw) in block.data.iter().enumerate() {
                    let (l, w) = (lw.truncate(), lw.w);
                    let x = block.x0 + (i % block.width) as i32;
                    let y = block.y0 + (i / block.width) as i32;
                    let dx = x as f32 - (pos.x - 0.5);
                    let dy = y as f32 - (pos.y - 0.5);
                    let inside = dx.abs() <= f.radius() && dy.abs() <= f.radius();
                    let want = if inside {
                        f.eval_1d(dx) * f.eval_1d(dy)
                    } else {
                        0.0
                    };
                    assert_eq!(w, want, "{f:?} at {pos:?}, pixel ({x}, {y})");
                    assert_eq!(l, Rgb::splat(2.0 * want));
                }
            }
        }
    }
}
