//! Images: the film that accumulates samples, reconstruction filters, and
//! bitmaps with their file formats.

mod bitmap;
pub mod compare;
pub mod false_colour;
mod film;
mod filter;
pub mod io;
pub mod tonemap;

pub use bitmap::Bitmap;
pub use compare::{compare, difference_image, CompareError, Comparison};
pub use film::{Film, FilmBlock};
pub use filter::{Filter, FilterError, FilterEval, FilterParam, MAX_FILTER_RADIUS};
pub use io::{
    load_exr_channels, load_image, prepare_output, save_exr_channels, save_image, ExrChannels,
    ImageError, OutChannel, OutChannels,
};
pub use tonemap::{save_png_tonemapped, tonemap, Exposure, Look, Tonemap, MAX_EXPOSURE_STOPS};
