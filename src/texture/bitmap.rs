//! Mitsuba 3's `bitmap` texture: an image looked up at the hit's uv with
//! Dr.Jit's conventions (uv (0, 0) is the top-left corner of the first
//! row; bilinear filtering interpolates between texel centres at
//! (i + 1/2) / res; nearest takes the texel containing uv), wrapped by
//! `repeat`, `mirror` or `clamp`. The texels are shared: two textures that
//! name one file hold one [`TextureImage`].

use std::sync::Arc;

use super::{bounded, UvTransform};
use crate::color::{luminance, Rgb};
use crate::image::Bitmap;
use crate::math::Vec2;

/// Texels of a loaded image with their summary values.
#[derive(Debug, PartialEq)]
pub struct TextureImage {
    width: usize,
    height: usize,
    texels: Vec<Rgb>,
    mean: Rgb,
    max: f32,
}

impl TextureImage {
    /// Takes a decoded image (finite, non-negative texels, as the image
    /// readers guarantee).
    pub fn new(bitmap: Bitmap) -> TextureImage {
        let n = bitmap.pixels.len().max(1) as f64;
        let sum = bitmap.pixels.iter().fold([0f64; 3], |s, p| {
            [s[0] + p.x as f64, s[1] + p.y as f64, s[2] + p.z as f64]
        });
        let max = bitmap
            .pixels
            .iter()
            .fold(0f32, |m, p| m.max(p.max_element()));
        TextureImage {
            width: bitmap.width,
            height: bitmap.height,
            mean: Rgb::new(
                (sum[0] / n) as f32,
                (sum[1] / n) as f32,
                (sum[2] / n) as f32,
            ),
            max,
            texels: bitmap.pixels,
        }
    }

    pub fn width(&self) -> usize {
        self.width
    }

    /// The same size of image with `f` of every texel.
    pub fn map(&self, f: impl Fn(Rgb) -> Rgb) -> TextureImage {
        TextureImage::new(Bitmap {
            width: self.width,
            height: self.height,
            pixels: self.texels.iter().map(|t| f(*t)).collect(),
        })
    }

    pub fn height(&self) -> usize {
        self.height
    }

    /// Mean over all texels, per channel.
    pub fn mean(&self) -> Rgb {
        self.mean
    }

    /// The largest channel value.
    pub fn max_value(&self) -> f32 {
        self.max
    }

    /// The texels, row by row from the top.
    pub fn texels(&self) -> &[Rgb] {
        &self.texels
    }

    #[inline]
    fn texel(&self, x: usize, y: usize) -> Rgb {
        self.texels[y * self.width + x]
    }
}

/// Mitsuba's `filter_type`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FilterType {
    Bilinear,
    Nearest,
}

/// Mitsuba's `wrap_mode`: what a lookup outside [0, 1]^2 reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WrapMode {
    Repeat,
    Mirror,
    Clamp,
}

impl WrapMode {
    /// The texel index in [0, res) that integer coordinate `i` reads.
    #[inline]
    pub(crate) fn wrap(self, i: i64, res: usize) -> usize {
        let n = res as i64;
        let j = match self {
            WrapMode::Repeat => i.rem_euclid(n),
            WrapMode::Clamp => i.clamp(0, n - 1),
            WrapMode::Mirror => {
                let k = i.rem_euclid(2 * n);
                if k >= n {
                    2 * n - 1 - k
                } else {
                    k
                }
            }
        };
        j as usize
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct BitmapTexture {
    image: Arc<TextureImage>,
    pub filter: FilterType,
    pub wrap: WrapMode,
    pub to_uv: UvTransform,
}

impl BitmapTexture {
    pub fn new(
        image: Arc<TextureImage>,
        filter: FilterType,
        wrap: WrapMode,
        to_uv: UvTransform,
    ) -> BitmapTexture {
        BitmapTexture {
            image,
            filter,
            wrap,
            to_uv,
        }
    }

    pub fn image(&self) -> &Arc<TextureImage> {
        &self.image
    }

    /// The same lookup of a grey image holding each texel's channel mean
    /// (so `eval_1`, the luminance, is the mean of `eval`'s channels).
    pub fn channel_means(&self) -> BitmapTexture {
        let grey = self.image.map(|t| Rgb::splat(super::channel_mean(t)));
        BitmapTexture {
            image: Arc::new(grey),
            ..self.clone()
        }
    }

    /// The filtered texel value at `uv`.
    pub fn eval(&self, uv: Vec2) -> Rgb {
        let img = &*self.image;
        let uv = self.to_uv.apply(uv);
        let (w, h) = (img.width, img.height);
        match self.filter {
            FilterType::Nearest => {
                let x = self.wrap.wrap(bounded(uv.x * w as f32).floor() as i64, w);
                let y = self.wrap.wrap(bounded(uv.y * h as f32).floor() as i64, h);
                img.texel(x, y)
            }
            FilterType::Bilinear => {
                let ([x0, x1, y0, y1], tx, ty) = self.bilinear_cell(uv);
                let top = img.texel(x0, y0) * (1.0 - tx) + img.texel(x1, y0) * tx;
                let bottom = img.texel(x0, y1) * (1.0 - tx) + img.texel(x1, y1) * tx;
                top * (1.0 - ty) + bottom * ty
            }
        }
    }

    /// The four texels a bilinear lookup at `st` (after `to_uv`) mixes,
    /// as columns x0, x1 and rows y0, y1 (wrapped), and the weights of
    /// x1 and y1.
    #[inline]
    fn bilinear_cell(&self, st: Vec2) -> ([usize; 4], f32, f32) {
        let (w, h) = (self.image.width, self.image.height);
        let px = bounded(st.x * w as f32 - 0.5);
        let py = bounded(st.y * h as f32 - 0.5);
        let (fx, fy) = (px.floor(), py.floor());
        let (ix, iy) = (fx as i64, fy as i64);
        let cell = [
            self.wrap.wrap(ix, w),
            self.wrap.wrap(ix.saturating_add(1), w),
            self.wrap.wrap(iy, h),
            self.wrap.wrap(iy.saturating_add(1), h),
        ];
        (cell, px - fx, py - fy)
    }
}

impl BitmapTexture {
    /// The gradient of [`crate::texture::Texture::eval_1`] (the luminance)
    /// with respect to the hit's (u, v), as Mitsuba 3.9.1's bitmap
    /// `eval_1_grad`: the bilinear patch's slopes, taken through `to_uv`
    /// and scaled by the resolution; zero for nearest-neighbour lookups.
    /// Where `to_uv` mixes u and v on a non-square image this is not the
    /// true gradient (the cross terms are scaled by the other side), and
    /// Mitsuba's is not either: checked against its `eval_1_grad` and
    /// finite differences of its `eval_1` (an 8 x 3 image turned 30
    /// degrees), the two agree to 5 digits.
    pub fn eval_1_grad(&self, uv: Vec2) -> Vec2 {
        if self.filter == FilterType::Nearest {
            return Vec2::ZERO;
        }
        let img = &*self.image;
        let (w, h) = (img.width, img.height);
        let ([x0, x1, y0, y1], tx, ty) = self.bilinear_cell(self.to_uv.apply(uv));
        let f = |x, y| luminance(img.texel(x, y));
        let (f00, f10, f01, f11) = (f(x0, y0), f(x1, y0), f(x0, y1), f(x1, y1));
        let dx = (1.0 - ty) * (f10 - f00) + ty * (f11 - f01);
        let dy = (1.0 - tx) * (f01 - f00) + tx * (f11 - f10);
        let m = &self.to_uv;
        Vec2::new(
            (m.row0[0] * dx + m.row1[0] * dy) * w as f32,
            (m.row0[1] * dx + m.row1[1] * dy) * h as f32,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 2x2 image: red, green on the top row; blue, white below.
    fn four() -> Arc<TextureImage> {
        Arc::new(TextureImage::new(Bitmap {
            width: 2,
            height: 2,
            pixels: vec![
                Rgb::new(1.0, 0.0, 0.0),
                Rgb::new(0.0, 1.0, 0.0),
                Rgb::new(0.0, 0.0, 1.0),
                Rgb::ONE,
            ],
        }))
    }

    fn tex(filter: FilterType, wrap: WrapMode) -> BitmapTexture {
        BitmapTexture::new(four(), filter, wrap, UvTransform::IDENTITY)
    }

    #[test]
    fn texel_centres_read_their_texel_and_rows_start_at_the_top() {
        for filter in [FilterType::Nearest, FilterType::Bilinear] {
            let t = tex(filter, WrapMode::Repeat);
            assert_eq!(t.eval(Vec2::new(0.25, 0.25)), Rgb::new(1.0, 0.0, 0.0));
            assert_eq!(t.eval(Vec2::new(0.75, 0.25)), Rgb::new(0.0, 1.0, 0.0));
            assert_eq!(t.eval(Vec2::new(0.25, 0.75)), Rgb::new(0.0, 0.0, 1.0));
        }
        let mean = four().mean();
        assert!((mean - Rgb::new(0.5, 0.5, 0.5)).abs().max_element() < 1e-6);
    }

    #[test]
    fn bilinear_interpolates_between_centres_and_wraps() {
        let t = tex(FilterType::Bilinear, WrapMode::Repeat);
        // Half-way between red and green.
        let v = t.eval(Vec2::new(0.5, 0.25));
        assert!((v - Rgb::new(0.5, 0.5, 0.0)).abs().max_element() < 1e-6);
        // At u = 0 the repeat wrap mixes the last column with the first.
        let v = t.eval(Vec2::new(0.0, 0.25));
        assert!((v - Rgb::new(0.5, 0.5, 0.0)).abs().max_element() < 1e-6);
        // Clamp reads the edge texel alone.
        let c = tex(FilterType::Bilinear, WrapMode::Clamp);
        assert_eq!(c.eval(Vec2::new(0.0, 0.25)), Rgb::new(1.0, 0.0, 0.0));
        // Mirror: u in (1, 2) reads the columns backwards.
        let m = tex(FilterType::Nearest, WrapMode::Mirror);
        assert_eq!(m.eval(Vec2::new(1.25, 0.25)), Rgb::new(0.0, 1.0, 0.0));
        assert_eq!(m.eval(Vec2::new(1.75, 0.25)), Rgb::new(1.0, 0.0, 0.0));
        let r = tex(FilterType::Nearest, WrapMode::Repeat);
        assert_eq!(r.eval(Vec2::new(1.25, 0.25)), Rgb::new(1.0, 0.0, 0.0));
        assert_eq!(r.eval(Vec2::new(-0.25, 0.25)), Rgb::new(0.0, 1.0, 0.0));
    }

    #[test]
    fn any_uv_reads_a_texel() {
        let t = tex(FilterType::Bilinear, WrapMode::Repeat);
        for uv in [
            Vec2::new(f32::NAN, 0.5),
            Vec2::new(1e30, -1e30),
            Vec2::new(f32::INFINITY, f32::NEG_INFINITY),
        ] {
            assert!(t.eval(uv).is_finite(), "{uv}");
        }
    }
}
