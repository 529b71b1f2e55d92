//! Spectra given in scene files, turned into linear sRGB the way Mitsuba
//! 3's RGB variants do (`spectrum_list_to_srgb` and `Properties::
//! get_texture`): the spectrum, linearly interpolated between its samples
//! and zero outside them, is integrated against the CIE 1931 observer at
//! 1000 points over 360-830 nm, then taken from XYZ to linear sRGB.
//!
//! How a spectrum is read depends on what it sets ([`SpectrumUse`]):
//! reflectances are lit by D65 (a flat 1 is white) and clipped to [0, 1];
//! emission is integrated as is (a flat spectrum is slightly pink in
//! sRGB, as in Mitsuba); unbounded quantities (a conductor's eta and k)
//! are lit by D65 and only clipped at zero.

use super::cie_tables::{CIE_D65, CIE_MAX, CIE_MIN, CIE_SAMPLES, CIE_X, CIE_Y, CIE_Z};
use super::Rgb;

/// Mitsuba's normalisation of its CIE curves: a flat spectrum of 1 has a
/// luminance of 1 (the integral of y-bar over the tables, as Mitsuba 3.9.1
/// states it).
const CIE_Y_NORMALIZATION: f64 = 1.0 / 106.750_259_399_414_06;

/// Scales the D65 table to a luminance of 1 (Mitsuba's constant).
const CIE_D65_NORMALIZATION: f64 = 1.0 / 98.997_417_518_762_55;

/// Points of the integration (Mitsuba's `steps`).
const STEPS: usize = 1000;

/// What a spectrum sets, which decides how it becomes RGB.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpectrumUse {
    /// A reflectance or transmittance: under D65, clipped to [0, 1].
    Reflectance,
    /// A quantity without upper bound (an index of refraction): under D65,
    /// clipped at zero.
    Unbounded,
    /// Emitted radiance, intensity or irradiance: integrated as it is.
    Emission,
}

/// A spectrum as a scene file gives it.
#[derive(Clone, Debug, PartialEq)]
pub enum Spectrum {
    /// The same value at every wavelength (`<spectrum value="0.5"/>`).
    Uniform(f32),
    /// Samples at increasing wavelengths (nm), linear in between.
    Sampled(SampledSpectrum),
    /// Planck's law at a temperature (kelvin), in W m^-2 sr^-1 nm^-1,
    /// inside a wavelength range (nm).
    Blackbody { kelvin: f32, range: (f32, f32) },
}

/// Why a list of samples is not a spectrum.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SpectrumError {
    #[error("a spectrum needs at least two wavelength:value samples, found {0}")]
    TooFew(usize),
    #[error("wavelengths must increase, but {1} nm follows {0} nm")]
    NotIncreasing(f32, f32),
    #[error("wavelength {0} nm is not a positive finite number")]
    BadWavelength(f32),
    #[error("the value at {0} nm is not a finite number")]
    BadValue(f32),
    #[error("a blackbody temperature must be a positive finite number of kelvin, found {0}")]
    BadTemperature(f32),
}

/// Samples of a spectrum: wavelengths (nm, increasing) and values.
#[derive(Clone, Debug, PartialEq)]
pub struct SampledSpectrum {
    wavelengths: Vec<f64>,
    values: Vec<f64>,
}

impl SampledSpectrum {
    /// Checks the samples: two or more, wavelengths positive and
    /// increasing, values finite.
    pub fn new(samples: &[(f32, f32)]) -> Result<SampledSpectrum, SpectrumError> {
        if samples.len() < 2 {
            return Err(SpectrumError::TooFew(samples.len()));
        }
        for (i, &(w, v)) in samples.iter().enumerate() {
            if !(w.is_finite() && w > 0.0) {
                return Err(SpectrumError::BadWavelength(w));
            }
            if !v.is_finite() {
                return Err(SpectrumError::BadValue(w));
            }
            if i > 0 && w <= samples[i - 1].0 {
                return Err(SpectrumError::NotIncreasing(samples[i - 1].0, w));
            }
        }
        Ok(SampledSpectrum {
            wavelengths: samples.iter().map(|s| s.0 as f64).collect(),
            values: samples.iter().map(|s| s.1 as f64).collect(),
        })
    }

    /// The linear interpolant at `w`, zero outside the samples (Mitsuba's
    /// loop skips wavelengths outside them).
    fn eval(&self, w: f64) -> f64 {
        let (first, last) = (
            self.wavelengths[0],
            self.wavelengths[self.wavelengths.len() - 1],
        );
        if w < first || w > last {
            return 0.0;
        }
        let i = self
            .wavelengths
            .partition_point(|&x| x <= w)
            .clamp(1, self.wavelengths.len() - 1)
            - 1;
        let (w0, w1) = (self.wavelengths[i], self.wavelengths[i + 1]);
        let (v0, v1) = (self.values[i], self.values[i + 1]);
        ((w - w1) * v0 + (w0 - w) * v1) / (w0 - w1)
    }
}

impl Spectrum {
    /// A blackbody between `range` nm (Mitsuba's defaults: 360-830).
    pub fn blackbody(kelvin: f32, range: (f32, f32)) -> Result<Spectrum, SpectrumError> {
        if !(kelvin.is_finite() && kelvin > 0.0) {
            return Err(SpectrumError::BadTemperature(kelvin));
        }
        Ok(Spectrum::Blackbody { kelvin, range })
    }

    /// Linear sRGB for `use_`, and whether it had to be clipped (Mitsuba
    /// warns then: the colour is out of the sRGB gamut or above 1).
    pub fn to_rgb(&self, use_: SpectrumUse) -> (Rgb, bool) {
        let rgb = match self {
            Spectrum::Uniform(v) => {
                let v = *v as f64;
                return match use_ {
                    // Mitsuba: a flat emission spectrum is xyz_to_srgb(1, 1, 1).
                    SpectrumUse::Emission => (to_f32(xyz_to_srgb([v, v, v])), false),
                    _ => (Rgb::splat(v as f32), false),
                };
            }
            Spectrum::Sampled(s) => integrate(|w| s.eval(w), use_ != SpectrumUse::Emission),
            Spectrum::Blackbody { kelvin, range } => {
                let (t, lo, hi) = (*kelvin as f64, range.0 as f64, range.1 as f64);
                integrate(
                    |w| {
                        if w < lo || w > hi {
                            0.0
                        } else {
                            planck(w, t)
                        }
                    },
                    false,
                )
            }
        };
        let clipped = match use_ {
            SpectrumUse::Reflectance => rgb.map(|c| c.clamp(0.0, 1.0)),
            _ => rgb.map(|c| c.max(0.0)),
        };
        (to_f32(clipped), clipped != rgb)
    }
}

/// Planck's law at `nm` nanometres and `kelvin`, per nanometre (the
/// constants Mitsuba's `blackbody` uses).
fn planck(nm: f64, kelvin: f64) -> f64 {
    const C: f64 = 2.997_924_58e8;
    const H: f64 = 6.626_070_04e-34;
    const K: f64 = 1.380_648_52e-23;
    let l = nm * 1e-9;
    1e-9 * 2.0 * H * C * C / (l.powi(5) * ((H * C / (K * l * kelvin)).exp() - 1.0))
}

/// Mitsuba's `spectrum_list_to_srgb` for the function `f` of wavelength:
/// 1000 evenly spaced wavelengths from 360 to 830 nm, each weighted by the
/// interpolated CIE curves (and by D65 when `d65`), then XYZ to sRGB.
fn integrate(f: impl Fn(f64) -> f64, d65: bool) -> [f64; 3] {
    let mut xyz = [0.0f64; 3];
    let (lo, hi) = (CIE_MIN as f64, CIE_MAX as f64);
    for i in 0..STEPS {
        let w = lo + (i as f64 / (STEPS - 1) as f64) * (hi - lo);
        let v = f(w);
        if v == 0.0 {
            continue;
        }
        let weight = if d65 {
            v * table(&CIE_D65, w) * CIE_D65_NORMALIZATION
        } else {
            v
        };
        xyz[0] += table(&CIE_X, w) * weight;
        xyz[1] += table(&CIE_Y, w) * weight;
        xyz[2] += table(&CIE_Z, w) * weight;
    }
    let scale = (hi - lo) * CIE_Y_NORMALIZATION / STEPS as f64;
    xyz_to_srgb(xyz.map(|c| c * scale))
}

/// A 5-nm CIE table linearly interpolated at `w` nm (zero outside).
fn table(t: &[f32; CIE_SAMPLES], w: f64) -> f64 {
    let (lo, hi) = (CIE_MIN as f64, CIE_MAX as f64);
    if !(lo..=hi).contains(&w) {
        return 0.0;
    }
    let x = (w - lo) * ((CIE_SAMPLES - 1) as f64 / (hi - lo));
    let i0 = (x as usize).min(CIE_SAMPLES - 2);
    let f = x - i0 as f64;
    (1.0 - f) * t[i0] as f64 + f * t[i0 + 1] as f64
}

/// CIE XYZ to linear sRGB (Rec. 709 primaries, D65 white), with the
/// matrix Mitsuba uses.
fn xyz_to_srgb([x, y, z]: [f64; 3]) -> [f64; 3] {
    [
        3.240479 * x - 1.537150 * y - 0.498535 * z,
        -0.969256 * x + 1.875991 * y + 0.041556 * z,
        0.055648 * x - 0.204043 * y + 1.057311 * z,
    ]
}

fn to_f32(c: [f64; 3]) -> Rgb {
    Rgb::new(c[0] as f32, c[1] as f32, c[2] as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sampled(s: &[(f32, f32)]) -> Spectrum {
        Spectrum::Sampled(SampledSpectrum::new(s).unwrap())
    }

    fn close(a: Rgb, b: Rgb, tol: f32) -> bool {
        (a - b).abs().max_element() <= tol
    }

    /// A flat reflectance of 1 over the whole range is white under D65
    /// (the D65 table's luminance is normalised to 1, as in Mitsuba), and
    /// a flat 0.5 is grey 0.5.
    #[test]
    fn a_flat_reflectance_is_grey() {
        let (white, clipped) =
            sampled(&[(360.0, 1.0), (830.0, 1.0)]).to_rgb(SpectrumUse::Unbounded);
        assert!(!clipped);
        assert!(close(white, Rgb::ONE, 0.01), "{white}");
        let (half, _) = sampled(&[(360.0, 0.5), (830.0, 0.5)]).to_rgb(SpectrumUse::Reflectance);
        assert!(close(half, Rgb::splat(0.5), 0.005), "{half}");
    }

    /// Emission is not lit by D65: a flat 1 has luminance 1 (the
    /// normalisation) but is pink in sRGB (1.20, 0.95, 0.91), the same colour a uniform
    /// emission spectrum gets.
    #[test]
    fn a_flat_emission_is_mitsubas_purple() {
        let (flat, _) = sampled(&[(360.0, 1.0), (830.0, 1.0)]).to_rgb(SpectrumUse::Emission);
        let (uniform, _) = Spectrum::Uniform(1.0).to_rgb(SpectrumUse::Emission);
        assert!(close(flat, uniform, 0.01), "{flat} vs {uniform}");
        assert!((super::super::luminance(flat) - 1.0).abs() < 0.01, "{flat}");
        assert!(flat.x > 1.2 && flat.z < 0.95, "{flat}");
        // A reflectance given as a single number stays that number.
        assert_eq!(
            Spectrum::Uniform(0.3).to_rgb(SpectrumUse::Reflectance).0,
            Rgb::splat(0.3)
        );
    }

    /// Values from Mitsuba 3.9.1 (`mi.spectrum_list_to_srgb`, scalar_rgb):
    /// a red-leaning reflectance and an emission line (out of gamut, so
    /// clipped at zero), and flat spectra.
    #[test]
    fn matches_mitsubas_conversion() {
        let red = sampled(&[(400.0, 0.1), (500.0, 0.2), (600.0, 0.8), (700.0, 0.9)]);
        let (c, _) = red.to_rgb(SpectrumUse::Reflectance);
        assert!(close(c, MITSUBA_RED, 2e-4), "{c} vs {MITSUBA_RED}");
        let line = sampled(&[(540.0, 0.0), (550.0, 10.0), (560.0, 0.0)]);
        let (c, _) = line.to_rgb(SpectrumUse::Emission);
        assert!(close(c, MITSUBA_LINE, 2e-4), "{c} vs {MITSUBA_LINE}");
        let flat = sampled(&[(360.0, 1.0), (830.0, 1.0)]);
        let (c, _) = flat.to_rgb(SpectrumUse::Emission);
        assert!(close(c, Rgb::new(1.20488, 0.948229, 0.909267), 2e-4), "{c}");
        let (c, _) = flat.to_rgb(SpectrumUse::Unbounded);
        assert!(
            close(c, Rgb::new(0.998983, 0.998872, 0.998802), 2e-4),
            "{c}"
        );
    }

    const MITSUBA_RED: Rgb = Rgb::new(0.95869, 0.446356, 0.10571);
    const MITSUBA_LINE: Rgb = Rgb::new(0.0, 1.3451, 0.0);

    /// Saturated reflectances leave the gamut and are clipped, and say so.
    #[test]
    fn out_of_gamut_reflectances_are_clipped() {
        let green = sampled(&[(500.0, 0.0), (530.0, 1.0), (560.0, 0.0)]);
        let (c, clipped) = green.to_rgb(SpectrumUse::Reflectance);
        assert!(
            clipped && c.min_element() >= 0.0 && c.max_element() <= 1.0,
            "{c}"
        );
        let (u, clipped) = green.to_rgb(SpectrumUse::Unbounded);
        assert!(clipped && u.min_element() == 0.0, "{u}");
    }

    /// A 6504 K blackbody has D65's chromaticity (near enough: D65 is a
    /// daylight, not a Planckian, spectrum): its sRGB is nearly grey.
    /// Hotter is bluer, cooler is redder.
    #[test]
    fn blackbodies_run_from_red_to_blue() {
        let rgb = |k| {
            Spectrum::blackbody(k, (360.0, 830.0))
                .unwrap()
                .to_rgb(SpectrumUse::Emission)
                .0
        };
        let d = rgb(6504.0);
        let n = d / d.max_element();
        assert!(n.min_element() > 0.85, "{n}");
        let (warm, cool) = (rgb(2700.0), rgb(12000.0));
        assert!(warm.x / warm.z > 3.0 && cool.z > cool.x, "{warm} {cool}");
        // Stefan-Boltzmann-like growth: much brighter when hotter.
        assert!(super::super::luminance(rgb(6000.0)) > 10.0 * super::super::luminance(rgb(3000.0)));
        assert!(Spectrum::blackbody(-5.0, (360.0, 830.0)).is_err());
    }

    #[test]
    fn bad_samples_are_named() {
        assert_eq!(
            SampledSpectrum::new(&[(400.0, 1.0)]),
            Err(SpectrumError::TooFew(1))
        );
        assert_eq!(
            SampledSpectrum::new(&[(500.0, 1.0), (400.0, 1.0)]),
            Err(SpectrumError::NotIncreasing(500.0, 400.0))
        );
        assert!(SampledSpectrum::new(&[(400.0, f32::NAN), (500.0, 1.0)]).is_err());
    }
}
