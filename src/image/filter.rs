//! Pixel reconstruction filters with Nori's parameters and defaults.

use crate::math::exp4;
use glam::Vec4;

/// A separable reconstruction filter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Filter {
    Gaussian {
        radius: f32,
        stddev: f32,
    },
    Box {
        radius: f32,
    },
    Tent {
        radius: f32,
    },
    /// Mitchell-Netravali with parameters B and C.
    Mitchell {
        radius: f32,
        b: f32,
        c: f32,
    },
    /// Lanczos' windowed sinc, sinc(x) sinc(x / radius), with `radius`
    /// lobes (Mitsuba's `lanczos`; its negative lobes sharpen).
    Lanczos {
        radius: f32,
    },
}

impl Default for Filter {
    /// Nori's default: gaussian, radius 2, stddev 0.5.
    fn default() -> Self {
        Filter::Gaussian {
            radius: 2.0,
            stddev: 0.5,
        }
    }
}

impl std::fmt::Display for Filter {
    /// As a scene file names it: `gaussian (radius 2, stddev 0.5)`.
    fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        match *self {
            Filter::Gaussian { radius, stddev } => {
                write!(f, "gaussian (radius {radius}, stddev {stddev})")
            }
            Filter::Box { radius } => write!(f, "box (radius {radius})"),
            Filter::Tent { radius } => write!(f, "tent (radius {radius})"),
            Filter::Mitchell { radius, b, c } => {
                write!(f, "mitchell (radius {radius}, B {b}, C {c})")
            }
            Filter::Lanczos { radius } => write!(f, "lanczos ({radius} lobes)"),
        }
    }
}

/// A [`Filter`] whose Gaussian exponent factor and value at the radius are
/// computed once: [`FilterEval::eval_1d`] equals [`Filter::eval_1d`] bit
/// for bit, with one `exp` per call instead of two (the Gaussian's formula
/// lives here; the other filters pass through). The Gaussian's `exp` is
/// [`exp4`], four offsets at a time for the film's 4 x 4 window
/// ([`FilterEval::gaussian_4`]), one lane of it for a single offset: the
/// same bits either way.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FilterEval {
    filter: Filter,
    /// Gaussian: (-1 / (2 stddev^2), its exp at the radius).
    gaussian: Option<(f32, f32)>,
}

impl FilterEval {
    /// One-dimensional filter value at offset `x` (pixels).
    #[inline]
    pub fn eval_1d(&self, x: f32) -> f32 {
        match self.gaussian {
            Some(g) => gaussian(g, Vec4::splat(x)).x,
            None => self.filter.eval_1d(x),
        }
    }

    /// The Gaussian's values at four offsets (None for other filters).
    #[inline]
    pub fn gaussian_4(&self, x: Vec4) -> Option<Vec4> {
        self.gaussian.map(|g| gaussian(g, x))
    }

    /// The Gaussian's values at eight offsets in AVX lanes (None for other
    /// filters): lane by lane the bits [`FilterEval::gaussian_4`] gives.
    ///
    /// # Safety
    /// Call only where the CPU has AVX2.
    #[cfg(target_arch = "x86_64")]
    #[inline]
    #[target_feature(enable = "avx2")]
    pub fn gaussian_8(&self, x: std::arch::x86_64::__m256) -> Option<std::arch::x86_64::__m256> {
        use std::arch::x86_64::*;
        let (alpha, at_radius) = self.gaussian?;
        // gaussian(), in eight lanes: (alpha x) x, exp, less the value at
        // the radius, at least 0 (max with 0 second, as glam's max).
        let e = crate::math::exp8(_mm256_mul_ps(_mm256_mul_ps(_mm256_set1_ps(alpha), x), x));
        Some(_mm256_max_ps(
            _mm256_sub_ps(e, _mm256_set1_ps(at_radius)),
            _mm256_setzero_ps(),
        ))
    }
}

/// exp(alpha x^2) less its value at the radius, at least 0.
#[inline(always)]
fn gaussian((alpha, at_radius): (f32, f32), x: Vec4) -> Vec4 {
    (exp4(alpha * x * x) - at_radius).max(Vec4::ZERO)
}

/// Widest filter accepted, in pixels (each tile's film block keeps a
/// border this wide).
pub const MAX_FILTER_RADIUS: f32 = 32.0;

/// The parameter of a [`Filter`] a [`FilterError`] is about.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FilterParam {
    Radius,
    Stddev,
    B,
    C,
}

/// Filter parameters that describe no filter. Each message completes a
/// sentence that starts with the parameter's name.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum FilterError {
    #[error("must be positive and at most {MAX_FILTER_RADIUS} pixels, found {1}")]
    Size(FilterParam, f32),
    #[error("must be a finite number, found {1}")]
    NotFinite(FilterParam, f32),
}

impl FilterError {
    /// The parameter that is wrong.
    pub fn param(&self) -> FilterParam {
        match self {
            FilterError::Size(p, _) | FilterError::NotFinite(p, _) => *p,
        }
    }
}

impl Filter {
    /// Checks the parameters: a radius (and a Gaussian's standard
    /// deviation) in (0, [`MAX_FILTER_RADIUS`]], finite Mitchell B and C.
    pub fn validate(&self) -> Result<(), FilterError> {
        let size = |param, v: f32| {
            if v > 0.0 && v <= MAX_FILTER_RADIUS {
                Ok(())
            } else {
                Err(FilterError::Size(param, v))
            }
        };
        let finite = |param, v: f32| {
            if v.is_finite() {
                Ok(())
            } else {
                Err(FilterError::NotFinite(param, v))
            }
        };
        size(FilterParam::Radius, self.radius())?;
        match *self {
            Filter::Gaussian { stddev, .. } => size(FilterParam::Stddev, stddev),
            Filter::Mitchell { b, c, .. } => {
                finite(FilterParam::B, b)?;
                finite(FilterParam::C, c)
            }
            Filter::Box { .. } | Filter::Tent { .. } | Filter::Lanczos { .. } => Ok(()),
        }
    }

    pub fn radius(&self) -> f32 {
        match *self {
            Filter::Gaussian { radius, .. }
            | Filter::Box { radius }
            | Filter::Tent { radius }
            | Filter::Mitchell { radius, .. }
            | Filter::Lanczos { radius } => radius,
        }
    }

    /// The same filter with its per-offset work prepared (for the film,
    /// which evaluates it several times per sample).
    pub fn evaluator(&self) -> FilterEval {
        let gaussian = match *self {
            Filter::Gaussian { radius, stddev } => {
                let alpha = -1.0 / (2.0 * stddev * stddev);
                Some((alpha, exp4(Vec4::splat(alpha * radius * radius)).x))
            }
            _ => None,
        };
        FilterEval {
            filter: *self,
            gaussian,
        }
    }

    /// One-dimensional filter value at offset `x` (pixels).
    pub fn eval_1d(&self, x: f32) -> f32 {
        match *self {
            // The formula is FilterEval's (one copy of it).
            Filter::Gaussian { .. } => self.evaluator().eval_1d(x),
            Filter::Box { radius } => {
                if x.abs() <= radius {
                    1.0
                } else {
                    0.0
                }
            }
            Filter::Tent { radius } => (1.0 - x.abs() / radius).max(0.0),
            Filter::Mitchell { radius, b, c } => {
                let x = (2.0 * x / radius).abs();
                let x2 = x * x;
                let x3 = x2 * x;
                (if x < 1.0 {
                    (12.0 - 9.0 * b - 6.0 * c) * x3
                        + (-18.0 + 12.0 * b + 6.0 * c) * x2
                        + (6.0 - 2.0 * b)
                } else if x < 2.0 {
                    (-b - 6.0 * c) * x3
                        + (6.0 * b + 30.0 * c) * x2
                        + (-12.0 * b - 48.0 * c) * x
                        + (8.0 * b + 24.0 * c)
                } else {
                    0.0
                }) / 6.0
            }
            Filter::Lanczos { radius } => {
                let x = x.abs();
                if x < f32::EPSILON {
                    1.0
                } else if x > radius {
                    0.0
                } else {
                    let x1 = std::f32::consts::PI * x;
                    let x2 = x1 / radius;
                    x1.sin() * x2.sin() / (x1 * x2)
                }
            }
        }
    }

    /// True if some weights are negative (Mitchell-Netravali's and
    /// Lanczos' outer lobes): a pixel beside a bright edge may then come
    /// out negative, as in Mitsuba.
    pub fn has_negative_lobes(&self) -> bool {
        matches!(self, Filter::Mitchell { .. } | Filter::Lanczos { .. })
    }

    /// Separable 2D weight.
    pub fn eval(&self, dx: f32, dy: f32) -> f32 {
        self.eval_1d(dx) * self.eval_1d(dy)
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn invalid_filters_name_the_parameter() {
        assert_eq!(Filter::default().validate(), Ok(()));
        let bad = |f: Filter| f.validate().unwrap_err().param();
        assert_eq!(bad(Filter::Box { radius: 0.0 }), FilterParam::Radius);
        assert_eq!(bad(Filter::Tent { radius: 1e6 }), FilterParam::Radius);
        let g = Filter::Gaussian {
            radius: 2.0,
            stddev: -1.0,
        };
        assert_eq!(bad(g), FilterParam::Stddev);
        let m = Filter::Mitchell {
            radius: 2.0,
            b: f32::NAN,
            c: 0.0,
        };
        assert_eq!(bad(m), FilterParam::B);
    }

    use super::*;

    /// Mitchell-Netravali with the recommended B = C = 1/3.
    fn mitchell() -> Filter {
        Filter::Mitchell {
            radius: 2.0,
            b: 1.0 / 3.0,
            c: 1.0 / 3.0,
        }
    }

    #[test]
    fn filters_vanish_at_their_radius() {
        for f in [
            Filter::default(),
            Filter::Tent { radius: 1.0 },
            mitchell(),
            Filter::Lanczos { radius: 3.0 },
        ] {
            assert!(f.eval_1d(f.radius()).abs() < 1e-6, "{f:?}");
            assert!(f.eval_1d(0.0) > 0.0);
        }
        assert_eq!(Filter::Box { radius: 0.5 }.eval_1d(0.6), 0.0);
        // Nori's Gaussian: exp(-x^2 / 2 s^2) less its value at the radius.
        let g = Filter::default().eval_1d(1.0);
        assert!(
            (g - ((-2.0f32).exp() - (-8.0f32).exp())).abs() < 1e-6,
            "{g}"
        );
        // Lanczos: 1 at the centre, zero at every integer, negative in
        // its second lobe.
        let l = Filter::Lanczos { radius: 3.0 };
        assert_eq!(l.eval_1d(0.0), 1.0);
        assert!(l.eval_1d(1.0).abs() < 1e-6 && l.eval_1d(2.0).abs() < 1e-6);
        assert!(l.eval_1d(1.5) < 0.0 && l.eval_1d(2.5) > 0.0);
        let want = (std::f32::consts::FRAC_PI_2).sin() * (std::f32::consts::PI / 6.0).sin()
            / (std::f32::consts::FRAC_PI_2 * std::f32::consts::PI / 6.0);
        assert!((l.eval_1d(0.5) - want).abs() < 1e-6);
    }

    #[test]
    fn the_evaluator_is_the_filter_bit_for_bit() {
        for f in [
            Filter::default(),
            Filter::Gaussian {
                radius: 5.0,
                stddev: 1.7,
            },
            Filter::Box { radius: 0.5 },
            Filter::Tent { radius: 1.5 },
            mitchell(),
            Filter::Lanczos { radius: 3.0 },
        ] {
            let e = f.evaluator();
            for i in -700..=700 {
                let x = i as f32 * 0.00731;
                assert_eq!(
                    e.eval_1d(x).to_bits(),
                    f.eval_1d(x).to_bits(),
                    "{f:?} at {x}"
                );
            }
        }
    }
}
