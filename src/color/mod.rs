//! Linear RGB colour helpers. Colours are `glam::Vec3` (linear, scene-referred).

pub use glam::Vec3 as Rgb;

mod cie_tables;
pub mod spectrum;

pub use spectrum::{SampledSpectrum, Spectrum, SpectrumError, SpectrumUse};

/// Luminance with the Rec. 709 weights Nori uses for its t-tests.
pub fn luminance(c: Rgb) -> f32 {
    0.212671 * c.x + 0.715160 * c.y + 0.072169 * c.z
}

/// Largest channel: used for Russian roulette and lobe selection.
pub fn max_component(c: Rgb) -> f32 {
    c.x.max(c.y).max(c.z)
}

/// True if every channel is finite and non-negative.
pub fn is_valid(c: Rgb) -> bool {
    c.is_finite() && c.min_element() >= 0.0
}

/// sRGB opto-electronic transfer function for one linear channel in [0, 1].
pub fn srgb_encode(v: f32) -> f32 {
    let v = v.clamp(0.0, 1.0);
    if v <= 0.003_130_8 {
        12.92 * v
    } else {
        (1.055 * v.powf(1.0 / 2.4) - 0.055).min(1.0)
    }
}

/// Inverse of [`srgb_encode`].
pub fn srgb_decode(v: f32) -> f32 {
    if v <= 0.040_45 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_round_trips() {
        for i in 0..=100 {
            let v = i as f32 / 100.0;
            assert!((srgb_decode(srgb_encode(v)) - v).abs() < 1e-5);
        }
        assert!((srgb_encode(2.0) - 1.0).abs() < 1e-6);
        assert_eq!(srgb_encode(-1.0), 0.0);
    }

    #[test]
    fn luminance_of_white_is_one() {
        assert!((luminance(Rgb::ONE) - 1.0).abs() < 1e-5);
    }
}
