//! Resource bounds for untrusted input: the largest file lente reads, the
//! largest image it decodes or renders, the coordinate range its BVH
//! accepts. Every loader checks against these *before* it allocates, so no
//! scene, mesh or image file can make lente read forever, exhaust memory or
//! overflow its arithmetic: it gets one line saying which bound was hit.
//!
//! The image bound can be lowered for the whole process
//! ([`set_max_image_pixels`]); the fuzz targets do so to keep each run
//! small. Nothing can raise it above [`MAX_IMAGE_PIXELS`].

use std::fs::File;
use std::io::Read;
use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};

/// The largest scene or include file lente reads (XML text).
pub const MAX_SCENE_FILE_BYTES: u64 = 256 << 20;

/// The largest mesh or image file lente reads.
pub const MAX_DATA_FILE_BYTES: u64 = 4 << 30;

/// The most pixels an image may have, read or rendered: 2^28, e.g.
/// 16384 x 16384 (a 16k x 8k probe is half of it). Decoded as float RGB
/// that is 3 GiB.
pub const MAX_IMAGE_PIXELS: u64 = 1 << 28;

/// The largest absolute world-space coordinate of any shape. The BVH
/// builder's surface-area costs (extent squared times primitive count) must
/// stay finite in f32; at 1e12 they do for any primitive count, and f32
/// positions are already ~1e5 units apart there.
pub const MAX_COORDINATE: f32 = 1e12;

static IMAGE_PIXELS: AtomicU64 = AtomicU64::new(MAX_IMAGE_PIXELS);

/// The image bound in force: [`MAX_IMAGE_PIXELS`] unless lowered.
pub fn max_image_pixels() -> u64 {
    IMAGE_PIXELS.load(Ordering::Relaxed)
}

/// Lowers the image bound for this process (values above
/// [`MAX_IMAGE_PIXELS`] are capped to it).
pub fn set_max_image_pixels(pixels: u64) {
    IMAGE_PIXELS.store(pixels.min(MAX_IMAGE_PIXELS), Ordering::Relaxed);
}

/// Checks an image size against the bound in force: `None` if it is
/// neither empty nor too large, else what is wrong with it.
pub fn check_image_size(width: u64, height: u64) -> Option<String> {
    if width == 0 || height == 0 {
        return Some(format!("image is empty ({width}x{height} pixels)"));
    }
    let max = max_image_pixels();
    match width.checked_mul(height) {
        Some(n) if n <= max => None,
        _ => Some(format!(
            "image size {width}x{height} is more than the {max} pixels lente reads or renders"
        )),
    }
}

/// Why an input file was not read.
#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    #[error(transparent)]
    Io(#[from] std::io::Error),
    #[error("it is not a regular file (a folder, device, pipe or socket)")]
    NotAFile,
    #[error("it is {size} bytes, more than the {limit}-byte limit for {what}")]
    TooLarge { size: u64, limit: u64, what: String },
}

/// Reads a whole regular file of at most `limit` bytes (`what` names the
/// kind of file in the error). Devices (`/dev/zero`), pipes and folders
/// are refused before they are opened (opening a pipe would block); a file
/// that grows past the limit while being read is refused too.
pub fn read_file(path: &Path, limit: u64, what: &str) -> Result<Vec<u8>, ReadError> {
    if !std::fs::metadata(path)?.is_file() {
        return Err(ReadError::NotAFile);
    }
    let file = File::open(path)?;
    let meta = file.metadata()?;
    if !meta.is_file() {
        return Err(ReadError::NotAFile);
    }
    let too_large = |size| ReadError::TooLarge {
        size,
        limit,
        what: what.to_string(),
    };
    if meta.len() > limit {
        return Err(too_large(meta.len()));
    }
    let mut bytes = Vec::with_capacity(meta.len() as usize);
    file.take(limit + 1).read_to_end(&mut bytes)?;
    if bytes.len() as u64 > limit {
        return Err(too_large(bytes.len() as u64));
    }
    Ok(bytes)
}

/// Memory this machine can give a new allocation, where the system says
/// (Linux: `MemAvailable` in `/proc/meminfo`); `None` elsewhere.
pub fn available_memory() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    kib.checked_mul(1024)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn devices_folders_and_big_files_are_refused_before_reading() {
        let dir = tempfile::tempdir().unwrap();
        assert!(matches!(
            read_file(dir.path(), 10, "test files"),
            Err(ReadError::NotAFile)
        ));
        if Path::new("/dev/zero").exists() {
            assert!(matches!(
                read_file(Path::new("/dev/zero"), 10, "test files"),
                Err(ReadError::NotAFile)
            ));
        }
        let big = dir.path().join("big");
        std::fs::write(&big, [7u8; 11]).unwrap();
        let err = read_file(&big, 10, "test files").unwrap_err();
        assert_eq!(
            err.to_string(),
            "it is 11 bytes, more than the 10-byte limit for test files"
        );
        assert_eq!(read_file(&big, 11, "test files").unwrap(), [7u8; 11]);
        assert!(matches!(
            read_file(&dir.path().join("missing"), 10, "x"),
            Err(ReadError::Io(_))
        ));
    }

    #[cfg(unix)]
    #[test]
    fn a_symlink_to_a_device_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let link = dir.path().join("scene.xml");
        std::os::unix::fs::symlink("/dev/zero", &link).unwrap();
        assert!(matches!(
            read_file(&link, 1 << 20, "x"),
            Err(ReadError::NotAFile)
        ));
    }

    #[test]
    fn image_sizes_are_checked_without_overflow() {
        assert!(check_image_size(16384, 16384).is_none());
        assert!(check_image_size(0, 5).unwrap().contains("empty"));
        assert!(check_image_size(16385, 16384)
            .unwrap()
            .contains("16385x16384"));
        assert!(check_image_size(u64::MAX, u64::MAX).is_some());
    }

    #[test]
    fn available_memory_is_plausible_where_known() {
        if let Some(bytes) = available_memory() {
            assert!(bytes > 1 << 20, "{bytes}");
        }
    }
}
