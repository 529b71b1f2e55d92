//! Reading and writing image files: OpenEXR, Radiance HDR, PFM and PNG.
//!
//! The format is chosen by the file extension (case-insensitive). Loaders
//! return linear RGB with the top row first; bad input never panics but
//! gives an [`ImageError`] naming the file and what was wrong. Savers encode
//! the whole file in memory, write it to a temporary file in the target
//! folder and rename it into place, so a failed save never leaves a
//! half-written file under the final name.

mod exr;
mod hdr;
mod pfm;
pub mod png;

use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use super::Bitmap;
use crate::color::Rgb;
pub use exr::Channels as ExrChannels;
pub use exr::{OutChannel, OutChannels};
pub use png::Transfer;

/// An image file that could not be read or written.
#[derive(Debug, thiserror::Error)]
#[error("{path}: {message}")]
pub struct ImageError {
    pub path: PathBuf,
    pub message: String,
}

impl ImageError {
    pub fn new(path: &Path, message: impl Into<String>) -> ImageError {
        ImageError {
            path: path.to_path_buf(),
            message: message.into(),
        }
    }
}

/// What is wrong inside an image file (the decoders' and encoders'
/// message; [`ImageError`] adds the path).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{0}")]
pub struct Malformed(pub String);

impl From<String> for Malformed {
    fn from(message: String) -> Self {
        Malformed(message)
    }
}

impl From<&str> for Malformed {
    fn from(message: &str) -> Self {
        Malformed(message.to_string())
    }
}

thread_local! {
    /// Whether this thread is inside [`catching_panics`].
    static IN_GUARDED_DECODER: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// True while this thread runs a third-party decoder under
/// `catching_panics`: a panic there becomes an error message, so a
/// panic hook need not report it ([`quiet_panics_in_guarded_decoders`]).
pub fn in_guarded_decoder() -> bool {
    IN_GUARDED_DECODER.with(std::cell::Cell::get)
}

/// Wraps the process's panic hook so that it stays quiet for a panic
/// `catching_panics` catches (that panic becomes the file's error message,
/// and a report of it would be a second, confusing one, or, under
/// libFuzzer, an abort); every other panic reaches the hook as before.
/// Installed once, however often it is called.
pub fn quiet_panics_in_guarded_decoders() {
    static INSTALLED: std::sync::Once = std::sync::Once::new();
    INSTALLED.call_once(|| {
        let hook = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if !in_guarded_decoder() {
                hook(info);
            }
        }));
    });
}

/// Runs a third-party decoder on untrusted bytes: a panic of its, a bug a
/// hostile file can reach (zune-jpeg 0.5.15's AVX2 IDCT stores past its
/// output on some files, found by fuzzing), becomes `failed`'s message
/// instead of taking lente down.
pub(super) fn catching_panics<T>(
    decode: impl FnOnce() -> Result<T, Malformed>,
    failed: impl FnOnce() -> String,
) -> Result<T, Malformed> {
    let outer = IN_GUARDED_DECODER.with(|g| g.replace(true));
    let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(decode));
    IN_GUARDED_DECODER.with(|g| g.set(outer));
    outcome.unwrap_or_else(|_| Err(Malformed(failed())))
}

/// Checks a decoder's header size before any pixel memory is allocated:
/// neither empty nor above [`crate::limits::max_image_pixels`].
pub(crate) fn check_size(width: usize, height: usize) -> Result<(), Malformed> {
    match crate::limits::check_image_size(width as u64, height as u64) {
        None => Ok(()),
        Some(message) => Err(Malformed(message)),
    }
}

/// The file formats lente reads and writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Format {
    Exr,
    Hdr,
    Pfm,
    Png,
    Jpeg,
    Bmp,
}

const SUPPORTED: &str = ".exr, .hdr, .pfm, .png (.jpg/.jpeg and .bmp to read)";

impl Format {
    fn from_path(path: &Path) -> Result<Format, ImageError> {
        let ext = match path.extension().and_then(|e| e.to_str()) {
            Some(ext) => ext.to_ascii_lowercase(),
            None => {
                return Err(ImageError::new(
                    path,
                    format!("no file extension to tell the image format (supported: {SUPPORTED})"),
                ))
            }
        };
        match ext.as_str() {
            "exr" => Ok(Format::Exr),
            "hdr" => Ok(Format::Hdr),
            "pfm" => Ok(Format::Pfm),
            "png" => Ok(Format::Png),
            "jpg" | "jpeg" => Ok(Format::Jpeg),
            "bmp" => Ok(Format::Bmp),
            _ => Err(ImageError::new(
                path,
                format!("unsupported image extension '.{ext}' (supported: {SUPPORTED})"),
            )),
        }
    }
}

/// Decoded texels before validation: `channels` is 1 (grey) or 3 (RGB),
/// interleaved, top row first.
pub(crate) struct RawImage {
    pub width: usize,
    pub height: usize,
    pub channels: usize,
    pub data: Vec<f32>,
}

/// Loads a linear RGB image, choosing the format by extension (`.exr`,
/// `.hdr`, `.pfm`, `.png`). Returns the image and any warnings (e.g. how
/// many negative texels were clamped to zero).
///
/// - EXR: half, float or uint samples; the first layer (part) with `R`,
///   `G`, `B` channels, or else a `Y` channel (read as grey); alpha and other
///   channels are ignored. Any compression the `exr` crate reads.
/// - HDR: Radiance RGBE, run-length encoded or flat scanlines, any of the
///   eight orientations of the resolution line.
/// - PFM: colour (`PF`) or greyscale (`Pf`), either byte order.
/// - PNG: 8 or 16 bit, any colour type; decoded from sRGB to linear.
/// - JPEG: baseline or progressive; decoded from sRGB to linear.
/// - BMP: the bit depths and compressions the `image` crate reads;
///   decoded from sRGB to linear.
///
/// Negative texels are clamped to zero with one warning that counts them;
/// NaN or infinite texels and empty images are errors.
pub fn load_image(path: &Path) -> Result<(Bitmap, Vec<String>), ImageError> {
    load_image_as(path, Transfer::Srgb)
}

/// [`load_image`], with the 8- and 16-bit formats' (PNG, JPEG) values
/// either decoded from sRGB or kept as they are ([`Transfer::Raw`]: data
/// such as normal maps and roughness). Float formats are always linear.
pub fn load_image_as(path: &Path, transfer: Transfer) -> Result<(Bitmap, Vec<String>), ImageError> {
    let format = Format::from_path(path)?;
    let bytes = crate::limits::read_file(path, crate::limits::MAX_DATA_FILE_BYTES, "image files")
        .map_err(|e| ImageError::new(path, format!("cannot read image file: {e}")))?;
    decode(&bytes, format, transfer).map_err(|m| ImageError::new(path, m.0))
}

/// Decodes an image file's bytes as [`load_image`] does, the format named
/// by its extension (`"exr"`, `"hdr"`, `"pfm"`, `"png"`, any case).
pub fn decode_image(bytes: &[u8], extension: &str) -> Result<(Bitmap, Vec<String>), Malformed> {
    let format = Format::from_path(Path::new(&format!("image.{extension}")))
        .map_err(|e| Malformed(e.message))?;
    decode(bytes, format, Transfer::Srgb)
}

fn decode(
    bytes: &[u8],
    format: Format,
    transfer: Transfer,
) -> Result<(Bitmap, Vec<String>), Malformed> {
    let raw = match format {
        Format::Exr => exr::decode(bytes),
        Format::Hdr => hdr::decode(bytes),
        Format::Pfm => pfm::decode(bytes),
        Format::Png => png::decode(bytes, transfer),
        Format::Jpeg => png::decode_jpeg(bytes, transfer),
        Format::Bmp => png::decode_bmp(bytes, transfer),
    }?;
    finish(raw)
}

/// Checks decoded texels and turns them into a bitmap: rejects empty images
/// and non-finite values, clamps negative values to zero (one warning).
fn finish(raw: RawImage) -> Result<(Bitmap, Vec<String>), Malformed> {
    let RawImage {
        width,
        height,
        channels,
        mut data,
    } = raw;
    check_size(width, height)?;
    let n = width * height;
    if data.len() != n * channels || !(channels == 1 || channels == 3) {
        return Err(Malformed::from(format!(
            "internal decoder error: {} values for {width}x{height}x{channels}",
            data.len()
        )));
    }
    let non_finite = data.iter().filter(|v| !v.is_finite()).count();
    if non_finite > 0 {
        return Err(Malformed::from(format!(
            "{non_finite} texel {} NaN or infinite",
            if non_finite == 1 {
                "value is"
            } else {
                "values are"
            }
        )));
    }
    let mut negative = 0usize;
    for v in &mut data {
        if v.is_sign_negative() {
            // -0.0 becomes +0.0 silently; only true negatives are counted.
            negative += usize::from(*v < 0.0);
            *v = 0.0;
        }
    }
    let pixels: Vec<Rgb> = if channels == 3 {
        data.chunks_exact(3)
            .map(|c| Rgb::new(c[0], c[1], c[2]))
            .collect()
    } else {
        data.iter().map(|&v| Rgb::splat(v)).collect()
    };
    let mut warnings = Vec::new();
    if negative > 0 {
        warnings.push(format!(
            "clamped {negative} negative texel {} to zero",
            if negative == 1 { "value" } else { "values" }
        ));
    }
    Ok((
        Bitmap {
            width,
            height,
            pixels,
        },
        warnings,
    ))
}

/// Saves an image, choosing the format by extension:
///
/// - `.exr`: 32-bit float RGB, linear, ZIP compression;
/// - `.png`: 8-bit sRGB-encoded, clamped to [0, 1];
/// - `.hdr`: Radiance RGBE, run-length encoded;
/// - `.pfm`: colour, little-endian.
///
/// Written atomically: to a temporary file in the same folder, then renamed.
pub fn save_image(path: &Path, image: &Bitmap) -> Result<(), ImageError> {
    let format = Format::from_path(path)?;
    check_not_empty(path, image.width, image.height)?;
    if image.width.checked_mul(image.height) != Some(image.pixels.len()) {
        return Err(ImageError::new(
            path,
            format!(
                "bitmap has {} pixels but claims to be {}x{}",
                image.pixels.len(),
                image.width,
                image.height
            ),
        ));
    }
    let bytes = match format {
        // Encoded straight into the file.
        Format::Exr => return write_atomically_with(path, |file| exr::encode(image, file)),
        Format::Png => return write_atomically_with(path, |file| png::encode(image, file)),
        Format::Hdr => hdr::encode(image),
        Format::Pfm => Ok(pfm::encode(image)),
        Format::Jpeg => Err(Malformed::from(
            "lente writes no JPEG (lossy); use .png, .exr, .hdr or .pfm",
        )),
        Format::Bmp => Err(Malformed::from(
            "lente reads BMP but writes none; use .png, .exr, .hdr or .pfm",
        )),
    }
    .map_err(|m| ImageError::new(path, m.0))?;
    write_atomically(path, &bytes)
}

/// An image of no pixels cannot be saved.
fn check_not_empty(path: &Path, width: usize, height: usize) -> Result<(), ImageError> {
    if width == 0 || height == 0 {
        return Err(ImageError::new(
            path,
            format!("cannot save an empty image ({width}x{height} pixels)"),
        ));
    }
    Ok(())
}

/// Saves a `width` x `height` 8-bit sRGB PNG of the linear colours
/// `pixel(i)` (row-major), made and encoded as it is written: no float
/// copy of the image (atomically, like [`save_image`]).
pub fn save_png_pixels(
    path: &Path,
    width: usize,
    height: usize,
    pixel: impl Fn(usize) -> Rgb,
) -> Result<(), ImageError> {
    check_not_empty(path, width, height)?;
    write_atomically_with(path, |file| {
        png::encode_pixels(width, height, pixel, false, file)
    })
}

/// Saves named float channels with text attributes as an OpenEXR file,
/// encoded straight into the file (atomically, like [`save_image`]).
pub fn save_exr_channels(path: &Path, image: &OutChannels) -> Result<(), ImageError> {
    write_atomically_with(path, |file| exr::encode_channels(image, file))
}

/// Decodes an OpenEXR file's first layer from its bytes (see
/// [`load_exr_channels`]).
pub fn decode_exr_channels(bytes: &[u8]) -> Result<ExrChannels, Malformed> {
    exr::decode_channels(bytes)
}

/// Reads an OpenEXR file's first layer: every channel and the text
/// attributes of its header.
pub fn load_exr_channels(path: &Path) -> Result<ExrChannels, ImageError> {
    let bytes = crate::limits::read_file(path, crate::limits::MAX_DATA_FILE_BYTES, "image files")
        .map_err(|e| ImageError::new(path, format!("cannot read image file: {e}")))?;
    exr::decode_channels(&bytes).map_err(|m| ImageError::new(path, m.0))
}

/// Writes `bytes` to a temporary file beside `path`, then renames it to
/// `path`. On failure the temporary file is removed.
pub(crate) fn write_atomically(path: &Path, bytes: &[u8]) -> Result<(), ImageError> {
    write_atomically_with(path, |file| {
        file.write_all(bytes)
            .map_err(|e| Malformed::from(format!("cannot write: {e}")))
    })
}

/// Like [`write_atomically`], the contents written by `write` to the
/// temporary file as they are made.
pub(crate) fn write_atomically_with(
    path: &Path,
    write: impl FnOnce(&mut fs::File) -> Result<(), Malformed>,
) -> Result<(), ImageError> {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let (dir, name) = folder_and_name(path)?;
    let tmp = temporary_beside(dir, &name, COUNTER.fetch_add(1, Ordering::Relaxed));
    remove_stale_temporaries(dir, &name);
    let result = (|| -> Result<(), Malformed> {
        let mut file = fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&tmp)
            .map_err(|e| format!("cannot create temporary file {}: {e}", tmp.display()))?;
        write(&mut file)
            .map_err(|m| format!("cannot write temporary file {}: {}", tmp.display(), m.0))?;
        file.sync_all()
            .map_err(|e| format!("cannot write temporary file {}: {e}", tmp.display()))?;
        drop(file);
        fs::rename(&tmp, path)
            .map_err(|e| format!("cannot rename {} into place: {e}", tmp.display()).into())
    })();
    result.map_err(|message| {
        let _ = fs::remove_file(&tmp);
        ImageError::new(path, message.0)
    })
}

/// The folder an output goes in (`.` for a bare name) and its file name.
fn folder_and_name(path: &Path) -> Result<(&Path, String), ImageError> {
    let Some(name) = path.file_name() else {
        return Err(ImageError::new(path, "not a file name"));
    };
    let dir = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    Ok((dir, name.to_string_lossy().into_owned()))
}

/// A temporary file for output `name` in `dir`: `.NAME.tmp-PID-TAG`, the
/// form [`remove_stale_temporaries`] recognises.
fn temporary_beside(dir: &Path, name: &str, tag: impl std::fmt::Display) -> std::path::PathBuf {
    dir.join(format!(".{name}.tmp-{}-{tag}", std::process::id()))
}

/// Makes sure `path` can be written before anything long is done to fill
/// it: creates its missing folders, refuses a folder in its place, removes
/// stale temporaries a killed run left beside it, and creates and deletes
/// the temporary file [`save_image`] would write.
pub fn prepare_output(path: &Path) -> Result<(), ImageError> {
    let (dir, name) = folder_and_name(path)?;
    fs::create_dir_all(dir).map_err(|e| {
        ImageError::new(
            path,
            format!("cannot create the output folder {}: {e}", dir.display()),
        )
    })?;
    if path.is_dir() {
        return Err(ImageError::new(path, "is a folder, not a file"));
    }
    remove_stale_temporaries(dir, &name);
    let probe = temporary_beside(dir, &name, "probe");
    fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&probe)
        .map_err(|e| ImageError::new(path, format!("cannot write in {}: {e}", dir.display())))?;
    let _ = fs::remove_file(&probe);
    Ok(())
}

/// Removes the temporary files a killed run left beside `dir/name`
/// (`.NAME.tmp-PID-N`): those whose process is gone (where `/proc` tells)
/// or, elsewhere, that are more than a day old. Others' files in flight
/// are left alone; failures are ignored (this is tidying, not writing).
fn remove_stale_temporaries(dir: &Path, name: &str) {
    let prefix = format!(".{name}.tmp-");
    let Ok(entries) = fs::read_dir(dir) else {
        return;
    };
    let have_proc = Path::new("/proc/self").exists();
    let me = std::process::id();
    for entry in entries.flatten() {
        let file_name = entry.file_name();
        let Some(rest) = file_name.to_str().and_then(|n| n.strip_prefix(&prefix)) else {
            continue;
        };
        let Some(pid) = rest.split('-').next().and_then(|p| p.parse::<u32>().ok()) else {
            continue;
        };
        let stale = if pid == me {
            false
        } else if have_proc {
            !Path::new(&format!("/proc/{pid}")).exists()
        } else {
            entry
                .metadata()
                .and_then(|m| m.modified())
                .ok()
                .and_then(|t| t.elapsed().ok())
                .is_some_and(|age| age.as_secs() > 24 * 3600)
        };
        if stale && entry.file_type().is_ok_and(|t| t.is_file()) {
            let _ = fs::remove_file(entry.path());
        }
    }
}

#[cfg(test)]
pub(crate) mod test_util {

    use crate::color::Rgb;
    use crate::image::Bitmap;

    /// A small test image with varied, positive values over a wide range;
    /// width != height so transposition or flips show up.
    pub fn test_image(width: usize, height: usize) -> Bitmap {
        let mut b = Bitmap::new(width, height);
        for y in 0..height {
            for x in 0..width {
                let t = (x + 3 * y) as f32;
                b.set(
                    x,
                    y,
                    Rgb::new(
                        0.01 + x as f32 * 0.37,
                        (y as f32 * 0.61 + 0.05).powi(2),
                        (1.3f32).powf(t * 0.5) * 0.02,
                    ),
                );
            }
        }
        b
    }
}

#[cfg(test)]
mod tests {
    use super::test_util::test_image;
    use super::*;

    #[test]
    fn bmp_is_decoded_from_srgb_or_raw_with_its_rows_from_the_top() {
        // Red on the top row, a grey of 128 below.
        let mut img = image::RgbImage::from_pixel(4, 2, image::Rgb([128, 128, 128]));
        for x in 0..4 {
            img.put_pixel(x, 0, image::Rgb([255, 0, 0]));
        }
        let mut bytes = Vec::new();
        image::codecs::bmp::BmpEncoder::new(&mut bytes)
            .encode(img.as_raw(), 4, 2, image::ExtendedColorType::Rgb8)
            .unwrap();
        let (srgb, _) = decode(&bytes, Format::Bmp, Transfer::Srgb).unwrap();
        let (raw, _) = decode(&bytes, Format::Bmp, Transfer::Raw).unwrap();
        assert_eq!((srgb.width, srgb.height), (4, 2));
        assert_eq!(srgb.pixels[0], crate::color::Rgb::new(1.0, 0.0, 0.0));
        let v = raw.pixels[4].x;
        assert!((v - 128.0 / 255.0).abs() < 1e-6, "{v}");
        assert!((srgb.pixels[4].x - crate::color::srgb_decode(v)).abs() < 1e-6);
        assert!(decode(&bytes[..20], Format::Bmp, Transfer::Srgb).is_err());
    }

    #[test]
    fn jpeg_is_decoded_from_srgb_or_raw() {
        // A flat grey JPEG: lossy, but a flat image keeps its value.
        let mut bytes = Vec::new();
        let grey = image::RgbImage::from_pixel(16, 8, image::Rgb([128, 128, 128]));
        image::codecs::jpeg::JpegEncoder::new_with_quality(&mut bytes, 95)
            .encode_image(&grey)
            .unwrap();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("grey.jpeg");
        fs::write(&path, &bytes).unwrap();
        let (srgb, _) = load_image(&path).unwrap();
        let (raw, _) = load_image_as(&path, Transfer::Raw).unwrap();
        assert_eq!((srgb.width, srgb.height), (16, 8));
        let v = raw.pixels[40].x;
        assert!((v - 128.0 / 255.0).abs() < 2.0 / 255.0, "{v}");
        let lin = srgb.pixels[40].x;
        assert!((lin - crate::color::srgb_decode(v)).abs() < 1e-6, "{lin}");
    }

    #[test]
    fn unknown_extension_is_an_error_listing_formats() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("picture.tga");
        fs::write(&path, b"whatever").unwrap();
        let err = load_image(&path).unwrap_err();
        let msg = err.to_string();
        assert!(msg.contains("picture.tga"), "{msg}");
        for ext in [".exr", ".hdr", ".pfm", ".png", ".jpg"] {
            assert!(msg.contains(ext), "{msg}");
        }
        let err = save_image(&path, &test_image(2, 2)).unwrap_err();
        assert!(err.to_string().contains(".pfm"), "{err}");
        // JPEG is read, never written (lossy).
        let err = save_image(&dir.path().join("out.jpg"), &test_image(2, 2)).unwrap_err();
        assert!(err.to_string().contains("no JPEG"), "{err}");
        let err = load_image(&dir.path().join("noext")).unwrap_err();
        assert!(err.to_string().contains("extension"), "{err}");
    }

    #[test]
    fn extension_is_case_insensitive() {
        let dir = tempfile::tempdir().unwrap();
        let img = test_image(3, 2);
        for name in ["a.PFM", "b.Exr", "c.HDR", "d.PnG"] {
            let path = dir.path().join(name);
            save_image(&path, &img).unwrap();
            let (back, _) = load_image(&path).unwrap();
            assert_eq!((back.width, back.height), (3, 2), "{name}");
        }
    }

    #[test]
    fn missing_file_is_an_error_naming_the_path() {
        let dir = tempfile::tempdir().unwrap();
        for name in ["nothere.exr", "nothere.hdr", "nothere.pfm", "nothere.png"] {
            let path = dir.path().join(name);
            let err = load_image(&path).unwrap_err();
            assert_eq!(err.path, path);
            assert!(err.to_string().contains(name), "{err}");
        }
    }

    #[test]
    fn truncated_files_are_errors_not_panics() {
        let dir = tempfile::tempdir().unwrap();
        let img = test_image(37, 23);
        for name in ["t.exr", "t.hdr", "t.pfm", "t.png"] {
            let path = dir.path().join(name);
            save_image(&path, &img).unwrap();
            let bytes = fs::read(&path).unwrap();
            // Cut at many places, including inside the header. A PNG whose
            // pixel data are complete but whose 12-byte end marker (IEND) is
            // cut still loads, so cut PNGs before it.
            let end = if name.ends_with("png") {
                bytes.len() - 12
            } else {
                bytes.len()
            };
            let cuts = [0, 1, 5, 11, 20, bytes.len() / 3, bytes.len() / 2]
                .into_iter()
                .chain([end - 7, end - 1]);
            for cut in cuts {
                fs::write(&path, &bytes[..cut]).unwrap();
                let result = load_image(&path);
                assert!(
                    result.is_err(),
                    "{name} cut at {cut} of {} loaded",
                    bytes.len()
                );
                let msg = result.unwrap_err().to_string();
                assert!(msg.contains(name), "{msg}");
            }
        }
    }

    #[test]
    fn garbage_files_are_errors_not_panics() {
        let dir = tempfile::tempdir().unwrap();
        // A simple deterministic byte generator.
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state as u8
        };
        for name in ["g.exr", "g.hdr", "g.pfm", "g.png"] {
            let path = dir.path().join(name);
            for len in [3usize, 64, 1000] {
                let bytes: Vec<u8> = (0..len).map(|_| next()).collect();
                fs::write(&path, &bytes).unwrap();
                assert!(load_image(&path).is_err(), "{name}");
            }
        }
    }

    #[test]
    fn empty_image_is_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("e.pfm");
        fs::write(&path, b"PF\n0 0\n-1\n").unwrap();
        let err = load_image(&path).unwrap_err();
        assert!(err.to_string().contains("empty"), "{err}");
        let err = save_image(&path, &Bitmap::new(0, 0)).unwrap_err();
        assert!(err.to_string().contains("empty"), "{err}");
    }

    #[test]
    fn negative_texels_give_one_counting_warning() {
        let dir = tempfile::tempdir().unwrap();
        let mut img = test_image(5, 4);
        img.set(0, 0, Rgb::new(-1.0, 0.5, -2.0));
        img.set(3, 2, Rgb::new(0.5, -0.25, 0.5));
        img.set(4, 3, Rgb::new(-0.0, 0.0, 0.0)); // negative zero is not negative
        for name in ["n.pfm", "n.exr"] {
            let path = dir.path().join(name);
            save_image(&path, &img).unwrap();
            let (back, warnings) = load_image(&path).unwrap();
            assert_eq!(
                warnings,
                vec!["clamped 3 negative texel values to zero".to_string()],
                "{name}"
            );
            assert_eq!(back.get(0, 0), Rgb::new(0.0, 0.5, 0.0));
            assert_eq!(back.get(3, 2), Rgb::new(0.5, 0.0, 0.5));
            assert!(back.pixels.iter().all(|p| p.min_element() >= 0.0));
        }
        let (_, warnings) = load_image(&{
            let p = dir.path().join("clean.pfm");
            save_image(&p, &test_image(5, 4)).unwrap();
            p
        })
        .unwrap();
        assert!(warnings.is_empty());
    }

    #[test]
    fn nan_and_infinite_texels_are_errors_with_a_count() {
        let dir = tempfile::tempdir().unwrap();
        let mut img = test_image(4, 3);
        img.set(1, 1, Rgb::new(f32::NAN, 0.0, 0.0));
        img.set(2, 1, Rgb::new(0.0, f32::INFINITY, f32::NEG_INFINITY));
        for name in ["nan.pfm", "nan.exr"] {
            let path = dir.path().join(name);
            save_image(&path, &img).unwrap();
            let err = load_image(&path).unwrap_err();
            let msg = err.to_string();
            assert!(msg.contains(name), "{msg}");
            assert!(msg.contains("3 texel values are NaN or infinite"), "{msg}");
        }
    }

    fn leftover_temp_files(dir: &Path) -> Vec<String> {
        fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| n.contains(".tmp-"))
            .collect()
    }

    #[test]
    fn atomic_save_leaves_no_temp_files() {
        let dir = tempfile::tempdir().unwrap();
        let img = test_image(16, 9);
        for name in ["a.exr", "a.hdr", "a.pfm", "a.png"] {
            let path = dir.path().join(name);
            save_image(&path, &img).unwrap();
            // Overwriting an existing file works too.
            save_image(&path, &img).unwrap();
            assert!(load_image(&path).is_ok());
        }
        assert_eq!(leftover_temp_files(dir.path()), Vec::<String>::new());
        let mut names: Vec<String> = fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        assert_eq!(names, ["a.exr", "a.hdr", "a.pfm", "a.png"]);
    }

    #[test]
    fn a_killed_runs_temporary_files_are_removed_by_the_next_save() {
        let dir = tempfile::tempdir().unwrap();
        let me = std::process::id();
        // A process id above Linux's largest (2^22) belongs to no process.
        let dead = ".out.exr.tmp-999999999-0";
        let mine = format!(".out.exr.tmp-{me}-77");
        let other_output = ".other.exr.tmp-999999999-0";
        for name in [dead, mine.as_str(), other_output] {
            fs::write(dir.path().join(name), b"partial").unwrap();
        }
        save_image(&dir.path().join("out.exr"), &test_image(4, 3)).unwrap();
        let left = leftover_temp_files(dir.path());
        if Path::new("/proc/self").exists() {
            assert!(!left.contains(&dead.to_string()), "{left:?}");
        }
        assert!(left.contains(&mine), "{left:?}");
        assert!(left.contains(&other_output.to_string()), "{left:?}");
    }

    #[test]
    fn failed_save_leaves_nothing_behind() {
        let dir = tempfile::tempdir().unwrap();
        // Renaming a file onto an existing non-empty directory fails after
        // the temporary file was written: it must be cleaned up.
        let target = dir.path().join("taken.pfm");
        fs::create_dir(&target).unwrap();
        fs::write(target.join("keep"), b"x").unwrap();
        let err = save_image(&target, &test_image(3, 3)).unwrap_err();
        assert_eq!(err.path, target);
        assert_eq!(leftover_temp_files(dir.path()), Vec::<String>::new());
        // A missing folder is an error naming the path.
        let path = dir.path().join("no/such/folder/x.png");
        let err = save_image(&path, &test_image(3, 3)).unwrap_err();
        assert!(err.to_string().contains("x.png"), "{err}");
        // A bitmap whose pixel count does not match its size is refused.
        let bad = Bitmap {
            width: 4,
            height: 4,
            pixels: vec![Rgb::ZERO; 3],
        };
        assert!(save_image(&dir.path().join("bad.exr"), &bad).is_err());
        assert!(!dir.path().join("bad.exr").exists());
        assert_eq!(leftover_temp_files(dir.path()), Vec::<String>::new());
    }

    /// Loads the shared light probes when they are present (optional).
    #[test]
    fn shared_envmaps_load_with_sensible_values() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/envmaps");
        if !dir.is_dir() {
            println!("skipped: {} not found", dir.display());
            return;
        }
        let mut found = 0;
        let mut entries: Vec<PathBuf> = fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect();
        entries.sort();
        for path in entries {
            let ext = path
                .extension()
                .and_then(|e| e.to_str())
                .unwrap_or("")
                .to_ascii_lowercase();
            if !["exr", "hdr", "pfm", "png"].contains(&ext.as_str()) {
                continue;
            }
            let start = std::time::Instant::now();
            let (img, warnings) =
                load_image(&path).unwrap_or_else(|e| panic!("failed to load: {e}"));
            let elapsed = start.elapsed();
            let mean = img.mean();
            let max = img
                .pixels
                .iter()
                .map(|p| p.max_element())
                .fold(0.0f32, f32::max);
            println!(
                "{}: {}x{} mean {:?} max {max} {warnings:?} in {:.1} ms",
                path.display(),
                img.width,
                img.height,
                mean,
                elapsed.as_secs_f64() * 1e3
            );
            assert_eq!(img.width, 2 * img.height, "lat-long maps are 2:1");
            assert!(mean.min_element() > 1e-4 && mean.max_element() < 100.0);
            assert!(max > mean.max_element() && max < 1e6);
            found += 1;
        }
        assert!(found > 0);
    }
}
