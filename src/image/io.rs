//! Reading and writing image files (EXR, PNG, Radiance HDR, PFM).
//! (Interface stub; the image-I/O work fills it in.)

use std::path::{Path, PathBuf};

use super::Bitmap;

/// An image file that could not be read or written.
#[derive(Debug, thiserror::Error)]
#[error("{path}: {message}")]
pub struct ImageError {
    pub path: PathBuf,
    pub message: String,
}

/// Loads a linear RGB image, choosing the format by extension (`.exr`,
/// `.hdr`, `.pfm`, `.png`). Returns the image and any warnings (e.g. how
/// many negative texels were clamped to zero).
pub fn load_image(path: &Path) -> Result<(Bitmap, Vec<String>), ImageError> {
    Err(ImageError {
        path: path.to_path_buf(),
        message: "image loading is not implemented yet".into(),
    })
}

/// Saves an image, choosing the format by extension. Written atomically:
/// to a temporary file in the same folder, then renamed.
pub fn save_image(path: &Path, _image: &Bitmap) -> Result<(), ImageError> {
    Err(ImageError {
        path: path.to_path_buf(),
        message: "image saving is not implemented yet".into(),
    })
}
