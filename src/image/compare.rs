//! Image comparison: error metrics against a reference and a false-colour
//! map of where two images differ.

use super::false_colour::false_colour;
use super::Bitmap;
use crate::color::luminance;

/// Error of an image against a reference, over all pixels and channels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Comparison {
    /// Mean of (a - b)^2.
    pub mse: f64,
    /// Mean of (a - b)^2 / (b^2 + 0.01), b being the reference.
    pub relative_mse: f64,
    /// 10 log10(peak^2 / MSE) in dB, peak being the reference's largest
    /// value (1 if that is 0); +infinity when the images are identical.
    pub psnr: f64,
}

/// Two images that cannot be compared.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum CompareError {
    #[error("image sizes differ: {0}x{1} vs {2}x{3} (reference)")]
    Size(usize, usize, usize, usize),
    #[error("cannot compare empty images")]
    Empty,
    #[error("a bitmap's pixel count does not match its size")]
    PixelCount,
}

/// Compares `a` against the reference `b`. The sizes must match and the
/// images must not be empty.
pub fn compare(a: &Bitmap, b: &Bitmap) -> Result<Comparison, CompareError> {
    if (a.width, a.height) != (b.width, b.height) {
        return Err(CompareError::Size(a.width, a.height, b.width, b.height));
    }
    let n = a.width * a.height;
    if n == 0 {
        return Err(CompareError::Empty);
    }
    if a.pixels.len() != n || b.pixels.len() != n {
        return Err(CompareError::PixelCount);
    }
    let mut sq = 0.0f64;
    let mut rel = 0.0f64;
    let mut peak = 0.0f64;
    for (p, q) in a.pixels.iter().zip(&b.pixels) {
        for (x, y) in p.to_array().into_iter().zip(q.to_array()) {
            let (x, y) = (f64::from(x), f64::from(y));
            let d2 = (x - y) * (x - y);
            sq += d2;
            rel += d2 / (y * y + 1e-2);
            peak = peak.max(y);
        }
    }
    let count = (3 * n) as f64;
    let mse = sq / count;
    let relative_mse = rel / count;
    let peak = if peak > 0.0 { peak } else { 1.0 };
    let psnr = if mse == 0.0 {
        f64::INFINITY
    } else {
        10.0 * (peak * peak / mse).log10()
    };
    Ok(Comparison {
        mse,
        relative_mse,
        psnr,
    })
}

/// A false-colour map of the per-pixel absolute luminance error |L(a) -
/// L(b)|, normalised by its maximum: blue is no error, red the largest (an
/// identical pair is all blue; non-finite errors show red). Values are in
/// [0, 1], ready for the PNG writer. If the sizes differ, the map covers the
/// overlapping top-left region (call [`compare`] first to catch that).
pub fn difference_image(a: &Bitmap, b: &Bitmap) -> Bitmap {
    let (w, h) = (a.width.min(b.width), a.height.min(b.height));
    let valid = |m: &Bitmap| m.pixels.len() == m.width * m.height;
    if !valid(a) || !valid(b) {
        return Bitmap::new(0, 0);
    }
    let mut err = Vec::with_capacity(w * h);
    for y in 0..h {
        for x in 0..w {
            err.push((luminance(a.get(x, y)) - luminance(b.get(x, y))).abs());
        }
    }
    let max = err
        .iter()
        .copied()
        .filter(|e| e.is_finite())
        .fold(0.0f32, f32::max);
    Bitmap {
        width: w,
        height: h,
        pixels: err
            .into_iter()
            .map(|e| {
                if !e.is_finite() {
                    false_colour(1.0)
                } else if max > 0.0 {
                    false_colour(e / max)
                } else {
                    false_colour(0.0)
                }
            })
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::color::Rgb;

    fn filled(w: usize, h: usize, c: Rgb) -> Bitmap {
        Bitmap {
            width: w,
            height: h,
            pixels: vec![c; w * h],
        }
    }

    #[test]
    fn identical_images_have_zero_error_and_infinite_psnr() {
        let a = crate::image::io::test_util::test_image(5, 3);
        let c = compare(&a, &a).unwrap();
        assert_eq!(c.mse, 0.0);
        assert_eq!(c.relative_mse, 0.0);
        assert_eq!(c.psnr, f64::INFINITY);
    }

    #[test]
    fn metrics_match_hand_computation() {
        let b = filled(2, 1, Rgb::new(2.0, 0.0, 1.0)); // reference, peak 2
        let mut a = b.clone();
        a.set(1, 0, Rgb::new(2.0, 0.5, 1.0)); // one value off by 0.5
        let c = compare(&a, &b).unwrap();
        let mse = 0.25 / 6.0;
        assert!((c.mse - mse).abs() < 1e-12);
        assert!((c.relative_mse - 0.25 / 0.01 / 6.0).abs() < 1e-9);
        assert!((c.psnr - 10.0 * (4.0 / mse).log10()).abs() < 1e-9);
        // Black reference: peak 1.
        let z = filled(2, 1, Rgb::ZERO);
        let c = compare(&filled(2, 1, Rgb::splat(0.1)), &z).unwrap();
        assert!((c.psnr - 20.0).abs() < 1e-5);
    }

    #[test]
    fn size_mismatch_is_an_error() {
        let err = compare(&filled(2, 2, Rgb::ONE), &filled(2, 3, Rgb::ONE))
            .unwrap_err()
            .to_string();
        assert!(err.contains("2x2") && err.contains("2x3"), "{err}");
        assert!(compare(&Bitmap::new(0, 0), &Bitmap::new(0, 0)).is_err());
    }

    #[test]
    fn difference_image_is_blue_to_red() {
        let b = filled(3, 1, Rgb::splat(0.5));
        let mut a = b.clone();
        a.set(1, 0, Rgb::splat(0.75)); // half the largest error
        a.set(2, 0, Rgb::splat(0.0)); // largest error
        let d = difference_image(&a, &b);
        assert_eq!((d.width, d.height), (3, 1));
        assert_eq!(d.get(0, 0), Rgb::new(0.0, 0.0, 1.0));
        assert!((d.get(1, 0) - Rgb::new(0.0, 1.0, 0.0)).abs().max_element() < 1e-4);
        assert_eq!(d.get(2, 0), Rgb::new(1.0, 0.0, 0.0));
        assert!(d
            .pixels
            .iter()
            .all(|p| p.min_element() >= 0.0 && p.max_element() <= 1.0));
        // Identical: all blue, no NaN.
        let d = difference_image(&b, &b);
        assert!(d.pixels.iter().all(|&p| p == Rgb::new(0.0, 0.0, 1.0)));
        // Different sizes: the overlap.
        let d = difference_image(&filled(4, 2, Rgb::ONE), &b);
        assert_eq!((d.width, d.height), (3, 1));
    }
}
