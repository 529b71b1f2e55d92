//! PNG, JPEG and BMP through the `image` crate: any bit depth and colour type
//! in, decoded from sRGB to linear unless the caller asks for the raw
//! values (Mitsuba's `raw` textures); alpha ignored. 8-bit sRGB RGB PNG out.

use super::Malformed;
use std::io::Cursor;

use image::{DynamicImage, ImageDecoder, ImageEncoder};

use super::RawImage;
use crate::color::{srgb_decode, srgb_encode, Rgb};
use crate::image::Bitmap;

/// How 8- and 16-bit values become floats.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Transfer {
    /// The file's values are sRGB-encoded: decode to linear (the default).
    Srgb,
    /// Use the values as they are, scaled to [0, 1] (data, not colour).
    Raw,
}

/// The decoder's allocation cap: 8 bytes per pixel (16-bit RGBA) of the
/// pixel bound, backing up the header check.
fn limits() -> image::Limits {
    let mut limits = image::Limits::no_limits();
    limits.max_alloc = Some(crate::limits::max_image_pixels().saturating_mul(8));
    limits
}

pub(super) fn decode(bytes: &[u8], transfer: Transfer) -> Result<RawImage, Malformed> {
    guarded("PNG", || {
        let decoder = image::codecs::png::PngDecoder::with_limits(Cursor::new(bytes), limits())
            .map_err(|e| format!("cannot decode PNG: {e}"))?;
        finish_ldr(decoder, "PNG", transfer)
    })
}

pub(super) fn decode_jpeg(bytes: &[u8], transfer: Transfer) -> Result<RawImage, Malformed> {
    guarded("JPEG", || {
        let decoder = image::codecs::jpeg::JpegDecoder::new(Cursor::new(bytes));
        finish_limited(decoder, "JPEG", transfer)
    })
}

pub(super) fn decode_bmp(bytes: &[u8], transfer: Transfer) -> Result<RawImage, Malformed> {
    guarded("BMP", || {
        let decoder = image::codecs::bmp::BmpDecoder::new(Cursor::new(bytes));
        finish_limited(decoder, "BMP", transfer)
    })
}

/// The `image` crate's decoder for `format` run under
/// [`super::catching_panics`], as the exr crate's are.
fn guarded(
    format: &str,
    decode: impl FnOnce() -> Result<RawImage, Malformed>,
) -> Result<RawImage, Malformed> {
    super::catching_panics(decode, || {
        format!("cannot decode {format}: the decoder failed on this file")
    })
}

/// A decoder whose limits are set after it is made (JPEG, BMP): sets them,
/// then [`finish_ldr`].
fn finish_limited(
    decoder: image::ImageResult<impl ImageDecoder>,
    format: &str,
    transfer: Transfer,
) -> Result<RawImage, Malformed> {
    let cannot = |e: image::ImageError| format!("cannot decode {format}: {e}");
    let mut decoder = decoder.map_err(cannot)?;
    decoder.set_limits(limits()).map_err(cannot)?;
    finish_ldr(decoder, format, transfer)
}

/// Checks the header's size before the pixels are decoded, then converts.
fn finish_ldr(
    decoder: impl ImageDecoder,
    format: &str,
    transfer: Transfer,
) -> Result<RawImage, Malformed> {
    let (w, h) = decoder.dimensions();
    super::check_size(w as usize, h as usize)?;
    let img =
        DynamicImage::from_decoder(decoder).map_err(|e| format!("cannot decode {format}: {e}"))?;
    let (width, height) = (img.width() as usize, img.height() as usize);
    let sixteen_bit = matches!(
        img,
        DynamicImage::ImageLuma16(_)
            | DynamicImage::ImageLumaA16(_)
            | DynamicImage::ImageRgb16(_)
            | DynamicImage::ImageRgba16(_)
    );
    let to_float = |v: f32| match transfer {
        Transfer::Srgb => srgb_decode(v),
        Transfer::Raw => v,
    };
    let data: Vec<f32> = if sixteen_bit {
        img.into_rgb16()
            .into_raw()
            .into_iter()
            .map(|v| to_float(f32::from(v) / 65535.0))
            .collect()
    } else {
        let lut: Vec<f32> = (0..=255u8)
            .map(|v| to_float(f32::from(v) / 255.0))
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
pub(super) fn encode(image: &Bitmap, out: impl std::io::Write) -> Result<(), Malformed> {
    encode_pixels(image.width, image.height, |i| image.pixels[i], false, out)
}

/// Like `encode` after multiplying by `scale`; `fast` trades file size
/// for speed (live previews).
pub fn encode_scaled(image: &Bitmap, scale: f32, fast: bool) -> Result<Vec<u8>, Malformed> {
    let mut out = Vec::new();
    encode_pixels(
        image.width,
        image.height,
        |i| image.pixels[i] * scale,
        fast,
        &mut out,
    )?;
    Ok(out)
}

/// A `width` x `height` PNG of the linear colours `pixel(i)` (row-major),
/// sRGB-encoded and clamped to [0, 1], written to `out` as it is encoded:
/// the 8-bit image is the one copy made (no tone-mapped float copy, no
/// copy of the file in memory).
pub fn encode_pixels(
    width: usize,
    height: usize,
    pixel: impl Fn(usize) -> Rgb,
    fast: bool,
    out: impl std::io::Write,
) -> Result<(), Malformed> {
    use image::codecs::png::{CompressionType, FilterType, PngEncoder};
    let (w, h) = match (u32::try_from(width), u32::try_from(height)) {
        (Ok(w), Ok(h)) => (w, h),
        _ => return Err(Malformed::from("image is too large for PNG")),
    };
    let quantise = |v: f32| {
        if v.is_nan() {
            0
        } else {
            (srgb_encode(v) * 255.0 + 0.5) as u8
        }
    };
    let buf: Vec<u8> = (0..width * height)
        .flat_map(|i| pixel(i).to_array().map(quantise))
        .collect();
    let encoder = if fast {
        PngEncoder::new_with_quality(out, CompressionType::Fast, FilterType::Sub)
    } else {
        PngEncoder::new(out)
    };
    encoder
        .write_image(&buf, w, h, image::ExtendedColorType::Rgb8)
        .map_err(|e| Malformed::from(format!("cannot encode PNG: {e}")))
}
