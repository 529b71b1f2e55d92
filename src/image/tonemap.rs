//! Tone mapping: scene-referred linear RGB to display-referred linear RGB in
//! [0, 1], ready for the sRGB-encoding PNG writer.

use std::fmt;
use std::path::Path;
use std::str::FromStr;

use super::io::{save_png_pixels, ImageError};
use super::Bitmap;
use crate::color::Rgb;

/// A tone-mapping operator, applied per channel after the exposure scale.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Tonemap {
    /// Clip to [0, 1].
    #[default]
    Clamp,
    /// Reinhard's simple global operator, x / (1 + x).
    Reinhard,
    /// Krzysztof Narkowicz's fit of the ACES filmic curve,
    /// x (2.51 x + 0.03) / (x (2.43 x + 0.59) + 0.14), clipped to [0, 1].
    Aces,
    /// John Hable's filmic curve (Uncharted 2) with its published
    /// constants, normalised so that its white point 11.2 maps to 1: a toe
    /// that deepens shadows and a long shoulder for highlights.
    Filmic,
}

/// Hable's curve before normalisation.
fn hable(x: f32) -> f32 {
    const A: f32 = 0.15;
    const B: f32 = 0.50;
    const C: f32 = 0.10;
    const D: f32 = 0.20;
    const E: f32 = 0.02;
    const F: f32 = 0.30;
    (x * (A * x + C * B) + D * E) / (x * (A * x + B) + D * F) - E / F
}

impl Tonemap {
    /// [`Tonemap::map`] of each channel.
    pub fn map_rgb(self, c: Rgb) -> Rgb {
        Rgb::new(self.map(c.x), self.map(c.y), self.map(c.z))
    }

    /// Maps one scaled linear value to [0, 1]. Negative values and NaN
    /// become 0; +infinity becomes 1.
    pub fn map(self, x: f32) -> f32 {
        if x.is_nan() || x <= 0.0 {
            return 0.0;
        }
        if x == f32::INFINITY {
            return 1.0;
        }
        let y = match self {
            Tonemap::Clamp => x,
            Tonemap::Reinhard => x / (1.0 + x),
            Tonemap::Aces => {
                // Beyond ~1e4 the ratio is 1 to f32 precision; avoid x*x
                // overflowing to inf/inf = NaN.
                let x = x.min(1e6);
                (x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14)
            }
            Tonemap::Filmic => hable(x.min(1e6)) / hable(11.2),
        };
        y.clamp(0.0, 1.0)
    }

    pub const NAMES: [&'static str; 4] = ["clamp", "reinhard", "aces", "filmic"];
}

impl fmt::Display for Tonemap {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Tonemap::Clamp => "clamp",
            Tonemap::Reinhard => "reinhard",
            Tonemap::Aces => "aces",
            Tonemap::Filmic => "filmic",
        })
    }
}

/// A name that is no tone mapping operator.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("unknown tone mapping operator '{0}' (expected one of: clamp, reinhard, aces, filmic)")]
pub struct UnknownTonemap(pub String);

impl FromStr for Tonemap {
    type Err = UnknownTonemap;

    /// Parses `clamp`, `reinhard`, `aces` or `filmic` (case-insensitive).
    fn from_str(s: &str) -> Result<Tonemap, UnknownTonemap> {
        match s.trim().to_ascii_lowercase().as_str() {
            "clamp" => Ok(Tonemap::Clamp),
            "reinhard" => Ok(Tonemap::Reinhard),
            "aces" => Ok(Tonemap::Aces),
            "filmic" => Ok(Tonemap::Filmic),
            _ => Err(UnknownTonemap(s.to_string())),
        }
    }
}

/// An exposure: a number of stops, or `auto` (from the image).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Exposure {
    Stops(f32),
    /// Maps the image's log-average luminance to middle grey (0.18), as
    /// Reinhard et al. 2002 key an image.
    Auto,
}

impl Default for Exposure {
    fn default() -> Exposure {
        Exposure::Stops(0.0)
    }
}

/// The most stops an exposure may scale by either way.
pub const MAX_EXPOSURE_STOPS: f32 = 64.0;

impl FromStr for Exposure {
    type Err = String;

    /// `auto`, or a number of stops in [-64, 64].
    fn from_str(s: &str) -> Result<Exposure, String> {
        if s.trim().eq_ignore_ascii_case("auto") {
            return Ok(Exposure::Auto);
        }
        match s.trim().parse::<f32>() {
            Ok(x) if x.is_finite() && x.abs() <= MAX_EXPOSURE_STOPS => Ok(Exposure::Stops(x)),
            _ => Err(format!(
                "expected 'auto' or a number of stops between -64 and 64, found '{s}'"
            )),
        }
    }
}

impl Exposure {
    /// The stops to scale `image` by: the given ones, or for `Auto`
    /// log2(0.18 / log-average luminance) over its finite pixels (0 for an
    /// image with none; within +-20 stops).
    pub fn stops_for(self, image: &Bitmap) -> f32 {
        match self {
            Exposure::Stops(x) => x,
            Exposure::Auto => {
                let (mut sum, mut n) = (0.0f64, 0u64);
                for p in &image.pixels {
                    let l = crate::color::luminance(*p);
                    if l.is_finite() {
                        sum += (1e-4 + l.max(0.0) as f64).ln();
                        n += 1;
                    }
                }
                if n == 0 {
                    return 0.0;
                }
                let log_average = (sum / n as f64).exp();
                ((0.18 / log_average).log2() as f32).clamp(-20.0, 20.0)
            }
        }
    }
}

/// How a PNG shows a linear image: an exposure and a tone-mapping operator.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Look {
    pub exposure: Exposure,
    pub tonemap: Tonemap,
}

impl Look {
    /// Saves `image` as an 8-bit sRGB PNG seen this way (atomically).
    pub fn save_png(&self, path: &Path, image: &Bitmap) -> Result<(), ImageError> {
        save_png_tonemapped(path, image, self.exposure.stops_for(image), self.tonemap)
    }
}

/// The factor of an exposure in stops (1 where it overflows).
fn exposure_scale(stops: f32) -> f32 {
    let scale = stops.exp2();
    if scale.is_finite() {
        scale
    } else {
        1.0
    }
}

/// Multiplies by 2^`exposure_stops`, then applies `op` per channel. The
/// result is linear, in [0, 1].
pub fn tonemap(image: &Bitmap, exposure_stops: f32, op: Tonemap) -> Bitmap {
    let scale = exposure_scale(exposure_stops);
    image.map(|p| op.map_rgb(p * scale))
}

/// Tone maps and saves as an 8-bit sRGB PNG, tone mapping each pixel as
/// it is encoded (atomically, like [`save_image`](crate::image::save_image)). The path must end in `.png`.
pub fn save_png_tonemapped(
    path: &Path,
    image: &Bitmap,
    exposure_stops: f32,
    op: Tonemap,
) -> Result<(), ImageError> {
    let is_png = path
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("png"));
    if !is_png {
        return Err(ImageError {
            path: path.to_path_buf(),
            message: "a tone-mapped image is saved as PNG: the file name must end in .png".into(),
        });
    }
    let scale = exposure_scale(exposure_stops);
    save_png_pixels(path, image.width, image.height, |i| {
        op.map_rgb(image.pixels[i] * scale)
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::image::io::load_image;

    #[test]
    fn operators_map_into_unit_interval_monotonically() {
        for op in [
            Tonemap::Clamp,
            Tonemap::Reinhard,
            Tonemap::Aces,
            Tonemap::Filmic,
        ] {
            let mut prev = 0.0;
            for i in 0..=2000 {
                let x = (i as f32 * 0.01 - 5.0).exp2() - 0.05;
                let y = op.map(x);
                assert!((0.0..=1.0).contains(&y), "{op} {x} -> {y}");
                assert!(y >= prev, "{op} not monotonic at {x}");
                prev = y;
            }
            assert_eq!(op.map(-3.0), 0.0);
            assert_eq!(op.map(f32::NAN), 0.0);
            assert_eq!(op.map(f32::INFINITY), 1.0);
            assert!(op.map(f32::MAX) > 0.99);
        }
        assert_eq!(Tonemap::Clamp.map(0.3), 0.3);
        assert_eq!(Tonemap::Clamp.map(7.0), 1.0);
        assert_eq!(Tonemap::Reinhard.map(1.0), 0.5);
        // Narkowicz: f(1) = 2.54 / 3.16.
        assert!((Tonemap::Aces.map(1.0) - 2.54 / 3.16).abs() < 1e-6);
        assert_eq!(Tonemap::Aces.map(100.0), 1.0);
        // Hable: the white point maps to 1, middle grey well below it.
        assert!((Tonemap::Filmic.map(11.2) - 1.0).abs() < 1e-6);
        assert!((Tonemap::Filmic.map(0.18) - hable(0.18) / hable(11.2)).abs() < 1e-7);
        assert!(Tonemap::Filmic.map(0.18) < 0.1);
    }

    #[test]
    fn auto_exposure_keys_the_log_average_to_middle_grey() {
        let mut img = Bitmap::new(2, 1);
        img.set(0, 0, Rgb::splat(0.01));
        img.set(1, 0, Rgb::splat(0.04));
        // Log-average of 1e-4 + 0.01 and 1e-4 + 0.04.
        let avg = ((0.0101f64).ln() / 2.0 + (0.0401f64).ln() / 2.0).exp();
        let expect = (0.18 / avg).log2() as f32;
        assert!((Exposure::Auto.stops_for(&img) - expect).abs() < 1e-4);
        assert_eq!(Exposure::Stops(-1.5).stops_for(&img), -1.5);
        // NaN pixels are skipped; an image without finite pixels gets 0.
        img.set(1, 0, Rgb::splat(f32::NAN));
        assert!(Exposure::Auto.stops_for(&img).is_finite());
        let mut nan = Bitmap::new(1, 1);
        nan.set(0, 0, Rgb::splat(f32::NAN));
        assert_eq!(Exposure::Auto.stops_for(&nan), 0.0);
        assert_eq!("auto".parse::<Exposure>(), Ok(Exposure::Auto));
        assert_eq!("-2".parse::<Exposure>(), Ok(Exposure::Stops(-2.0)));
        assert!("65".parse::<Exposure>().is_err());
        assert!("bright".parse::<Exposure>().is_err());
    }

    #[test]
    fn exposure_scales_by_powers_of_two() {
        let mut img = Bitmap::new(2, 1);
        img.set(0, 0, Rgb::new(0.1, 0.2, 0.4));
        img.set(1, 0, Rgb::new(1.0, f32::NAN, -1.0));
        let out = tonemap(&img, 1.0, Tonemap::Clamp);
        assert_eq!(out.get(0, 0), Rgb::new(0.2, 0.4, 0.8));
        assert_eq!(out.get(1, 0), Rgb::new(1.0, 0.0, 0.0));
        let out = tonemap(&img, -2.0, Tonemap::Reinhard);
        assert!((out.get(0, 0).z - 0.1 / 1.1).abs() < 1e-6);
    }

    #[test]
    fn names_parse() {
        for op in [
            Tonemap::Clamp,
            Tonemap::Reinhard,
            Tonemap::Aces,
            Tonemap::Filmic,
        ] {
            assert_eq!(op.to_string().parse::<Tonemap>(), Ok(op));
        }
        assert_eq!("ACES".parse::<Tonemap>(), Ok(Tonemap::Aces));
        let err = "agx".parse::<Tonemap>().unwrap_err();
        assert!(
            err.to_string().contains("clamp, reinhard, aces, filmic"),
            "{err}"
        );
    }

    #[test]
    fn save_png_tonemapped_writes_png() {
        let dir = tempfile::tempdir().unwrap();
        let mut img = Bitmap::new(3, 2);
        img.set(0, 0, Rgb::splat(1.0));
        img.set(2, 1, Rgb::splat(1e5));
        let path = dir.path().join("t.png");
        save_png_tonemapped(&path, &img, 0.0, Tonemap::Reinhard).unwrap();
        let (back, _) = load_image(&path).unwrap();
        // 0.5 survives the sRGB round trip within one 8-bit step.
        assert!((back.get(0, 0).x - 0.5).abs() < 0.005);
        assert!(back.get(2, 1).x > 0.99);
        assert_eq!(back.get(1, 0), Rgb::ZERO);
        let err =
            save_png_tonemapped(&dir.path().join("t.exr"), &img, 0.0, Tonemap::Aces).unwrap_err();
        assert!(err.to_string().contains(".png"));
        assert!(!dir.path().join("t.exr").exists());
    }
}
