//! A procedural clear sky baked into a lat-long map.
//! (Interface stub; the environment-map work fills it in.)

use crate::image::Bitmap;

/// Parameters of the procedural sky.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SkyParams {
    pub turbidity: f32,
    /// Sun elevation above the horizon, degrees.
    pub sun_elevation_deg: f32,
    /// Sun azimuth, degrees (see the module docs for the convention).
    pub sun_azimuth_deg: f32,
    /// Multiplier on sky and sun radiance.
    pub scale: f32,
    /// Width of the baked lat-long map (height is half).
    pub resolution: usize,
}

impl Default for SkyParams {
    fn default() -> Self {
        SkyParams {
            turbidity: 3.0,
            sun_elevation_deg: 45.0,
            sun_azimuth_deg: 0.0,
            scale: 1.0,
            resolution: 1024,
        }
    }
}

/// Bakes the sky (and its sun disk) into a linear lat-long bitmap.
pub fn bake_sky(params: &SkyParams) -> Bitmap {
    Bitmap::new(params.resolution, params.resolution / 2)
}
