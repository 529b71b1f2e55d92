//! PNG through the `image` crate: any bit depth and colour type in, decoded
//! from sRGB to linear (alpha ignored); 8-bit sRGB RGB out.

use std::io::Cursor;

use image::{DynamicImage, ImageEncoder};

use super::RawImage;
use crate::color::{srgb_decode, srgb_encode};
use crate::image::Bitmap;

pub(super) fn decode(bytes: &[u8]) -> Result<RawImage, String> {
    let decoder = image::codecs::png::PngDecoder::new(Cursor::new(bytes))
        .map_err(|e| format!("cannot decode PNG: {e}"))?;
    let img = DynamicImage::from_decoder(decoder).map_err(|e| format!("cannot decode PNG: {e}"))?;
    let (width, height) = (img.width() as usize, img.height() as usize);
    let sixteen_bit = matches!(
        img,
        DynamicImage::ImageLuma16(_)
            | DynamicImage::ImageLumaA16(_)
            | DynamicImage::ImageRgb16(_)
            | DynamicImage::ImageRgba16(_)
    );
    let data: Vec<f32> = if sixteen_bit {
        img.into_rgb16()
            .into_raw()
            .into_iter()
            .map(|v| srgb_decode(f32::from(v) / 65535.0))
            .collect()
    } else {
        let lut: Vec<f32> = (0..=255u8)
            .map(|v| srgb_decode(f32::from(v) / 255.0))
            .collect();
        img.into_rgb8()
            .into_raw()
            .into_iter()
            .map(|v| lut[usize::from(v)])
            .collect()
    };
    Ok(RawImage {
        width,
        height,
        channels: 3,
        data,
    })
}

/// 8-bit sRGB-encoded RGB, values clamped to [0, 1] (NaN becomes 0).
pub(super) fn encode(image: &Bitmap) -> Result<Vec<u8>, String> {
    let (w, h) = match (u32::try_from(image.width), u32::try_from(image.height)) {
        (Ok(w), Ok(h)) => (w, h),
        _ => return Err("image is too large for PNG".into()),
    };
    let quantise = |v: f32| {
        if v.is_nan() {
            0
        } else {
            (srgb_encode(v) * 255.0 + 0.5) as u8
        }
    };
    let buf: Vec<u8> = image
        .pixels
        .iter()
        .flat_map(|p| p.to_array().map(quantise))
        .collect();
    let mut out = Vec::new();
    image::codecs::png::PngEncoder::new(&mut out)
        .write_image(&buf, w, h, image::ExtendedColorType::Rgb8)
        .map_err(|e| format!("cannot encode PNG: {e}"))?;
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::super::test_util::{test_image, TempDir};
    use super::super::{load_image, save_image};
    use super::*;
    use crate::color::Rgb;

    fn write_png(
        path: &std::path::Path,
        w: u32,
        h: u32,
        data: &[u8],
        ty: image::ExtendedColorType,
    ) {
        let mut out = Vec::new();
        image::codecs::png::PngEncoder::new(&mut out)
            .write_image(data, w, h, ty)
            .unwrap();
        std::fs::write(path, out).unwrap();
    }

    #[test]
    fn png_round_trip_within_one_step_after_srgb() {
        let dir = TempDir::new("png-rt");
        let mut img = test_image(9, 6);
        img.set(0, 0, Rgb::new(-1.0, 5.0, f32::NAN)); // clamped on save
        img.set(1, 0, Rgb::new(0.0, 1.0, 0.002));
        let path = dir.path("rt.png");
        save_image(&path, &img).unwrap();
        let (back, warnings) = load_image(&path).unwrap();
        assert!(warnings.is_empty());
        assert_eq!((back.width, back.height), (9, 6));
        assert_eq!(back.get(0, 0), Rgb::new(0.0, 1.0, 0.0));
        for (a, b) in img.pixels.iter().zip(&back.pixels).skip(1) {
            for (x, y) in a.to_array().into_iter().zip(b.to_array()) {
                let (ex, ey) = (srgb_encode(x), srgb_encode(y));
                assert!((ex - ey).abs() <= 0.5 / 255.0 + 1e-6, "{x} vs {y}");
            }
        }
    }

    #[test]
    fn png_reads_16_bit_grey_and_alpha() {
        let dir = TempDir::new("png-16");
        // 16-bit RGB, 2x1: exact 16-bit levels survive.
        let levels: [u16; 6] = [0, 1000, 32768, 65535, 12345, 54321];
        let bytes: Vec<u8> = levels.iter().flat_map(|v| v.to_ne_bytes()).collect();
        let path = dir.path("rgb16.png");
        write_png(&path, 2, 1, &bytes, image::ExtendedColorType::Rgb16);
        let (img, _) = load_image(&path).unwrap();
        for (i, &l) in levels.iter().enumerate() {
            let got = img.pixels[i / 3].to_array()[i % 3];
            let want = srgb_decode(l as f32 / 65535.0);
            assert!((got - want).abs() < 1e-6, "{got} vs {want}");
        }
        // 16-bit grey.
        let path = dir.path("l16.png");
        let bytes: Vec<u8> = [0u16, 40000].iter().flat_map(|v| v.to_ne_bytes()).collect();
        write_png(&path, 1, 2, &bytes, image::ExtendedColorType::L16);
        let (img, _) = load_image(&path).unwrap();
        assert_eq!((img.width, img.height), (1, 2));
        assert_eq!(img.get(0, 0), Rgb::ZERO);
        assert!((img.get(0, 1).x - srgb_decode(40000.0 / 65535.0)).abs() < 1e-6);
        assert_eq!(img.get(0, 1).x, img.get(0, 1).z);
        // 8-bit RGBA: alpha ignored; top row first.
        let path = dir.path("rgba8.png");
        write_png(
            &path,
            1,
            2,
            &[255, 128, 0, 7, 10, 20, 30, 0],
            image::ExtendedColorType::Rgba8,
        );
        let (img, _) = load_image(&path).unwrap();
        assert_eq!(
            img.get(0, 0),
            Rgb::new(1.0, srgb_decode(128.0 / 255.0), 0.0)
        );
        assert!((img.get(0, 1).y - srgb_decode(20.0 / 255.0)).abs() < 1e-7);
    }
}
