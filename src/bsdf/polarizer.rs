//! Mitsuba's `polarizer` as its RGB variants render it. There light carries
//! no polarisation state, so a linear polariser passes half of it (times
//! `transmittance`) whatever its angle `theta`: a pure pass-through (its
//! null lobe, sampled as a delta transmission straight on). As at any
//! surface in Mitsuba's `path`, shadow rays stop at it.

use super::params::{self, BsdfError, BsdfParam};
use super::BsdfSample;
use crate::color::Rgb;
use crate::math::Vec3;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Polarizer {
    /// Mitsuba's `transmittance` (1): what passes is half of it.
    pub transmittance: Rgb,
}

impl Polarizer {
    pub fn new(transmittance: Rgb) -> Result<Polarizer, BsdfError> {
        Ok(Polarizer {
            transmittance: params::color(BsdfParam::SpecularTransmittance, transmittance)?,
        })
    }

    /// Straight through, from either side.
    pub fn sample(&self, wi: Vec3) -> Option<BsdfSample> {
        Some(BsdfSample {
            wo: -wi,
            weight: self.transmittance * 0.5,
            pdf: 1.0,
            specular: true,
            eta: 1.0,
            null: true,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Straight through from either side with half the transmittance;
    /// nothing to evaluate.
    #[test]
    fn passes_half_straight_on() {
        let p = Polarizer::new(Rgb::new(1.0, 0.5, 0.2)).unwrap();
        for wi in [Vec3::new(0.3, -0.2, 0.9), Vec3::new(0.1, 0.4, -0.8)] {
            let s = p.sample(wi).unwrap();
            assert_eq!(s.wo, -wi);
            assert_eq!(s.weight, Rgb::new(0.5, 0.25, 0.1));
            assert!(s.specular && s.pdf == 1.0 && s.eta == 1.0);
        }
        assert!(Polarizer::new(Rgb::new(-1.0, 0.0, 0.0)).is_err());
    }
}
