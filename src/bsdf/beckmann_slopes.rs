//! Slopes of the Beckmann normals visible from elevation theta_i (alpha = 1,
//! azimuth 0; Heitz and d'Eon 2014): the y slope is a Gaussian, the x
//! slope inverts a CDF that, in the erf domain x = erf(slope), reads
//! `F(x) = 1 + x + tan(theta_i) exp(-erfinv(x)^2) / sqrt(pi)` on
//! `[-1, erf(cot theta_i)]`.
//!
//! Jakob's routine (Mitsuba's) solves `F(x) = u F(max)` with three Newton
//! steps from the grazing-angle solution: six `exp` and five `log` in f64,
//! 200 ns a call here. A 32 x 64 table of the solution (built once, on
//! first use, by bisection) gives a guess within 4e-3, and one Halley
//! step (cubic convergence; its second derivative costs nothing more)
//! finishes it: three `log` and two `exp`, and a smaller worst CDF error
//! than the three Newton steps (7e-7 against 2e-6; tested). It runs in
//! f32, the same operations as the GPU's copy (`bsdf.wgsl`), with f32 erf
//! and erfinv (the approximations are f32's anyway): 72 ns a call, where
//! the same steps in f64 took 86 ns for the same worst CDF error (6.6e-7
//! against 6.2e-7 on the test's grid).

use crate::math::{exp_or_zero, Vec2};
use std::sync::OnceLock;

/// 1 / sqrt(pi).
const INV_SQRT_PI: f64 = 0.564_189_583_547_756_3;
/// sqrt(pi) / 2 = d erfinv(x) / dx at x = 0.
const HALF_SQRT_PI: f64 = 0.886_226_925_452_758;
/// Table rows: sin(theta_i) from 0 to 1 (smooth in theta_i at normal
/// incidence, where cos(theta_i) is not).
const ROWS: usize = 32;
/// Table columns: w = 1 - sqrt(1 - u) from 0 to 1. The solution has a
/// square-root edge at u = 1 (the density falls linearly to zero at the
/// largest visible slope); in w it is smooth.
const COLS: usize = 64;

/// x and y slopes of a visible normal for `u` in [0, 1)^2.
pub fn beckmann_visible_slopes(cos_theta_i: f32, u: Vec2) -> Vec2 {
    Vec2::new(
        beckmann_visible_slope_x(cos_theta_i, u.x),
        beckmann_visible_slope_y(u.y),
    )
}

/// The y slope of [`beckmann_visible_slopes`]: a Gaussian's, from `uy`
/// alone (the two slopes are drawn independently, which the coating
/// tables' quadrature uses to compute each once per grid line).
#[inline]
pub fn beckmann_visible_slope_y(uy: f32) -> f32 {
    let uy = uy.clamp(1e-6, 1.0 - 1e-6);
    erfinv_f32(2.0 * uy - 1.0)
}

/// The x slope of [`beckmann_visible_slopes`], from the elevation and `ux`
/// alone.
pub fn beckmann_visible_slope_x(cos_theta_i: f32, ux: f32) -> f32 {
    const INV_SQRT_PI32: f32 = INV_SQRT_PI as f32;
    let cos = cos_theta_i.clamp(1e-6, 1.0);
    let sin = (1.0 - cos * cos).max(0.0).sqrt();
    let tan = sin / cos;
    // cot theta_i: infinite at normal incidence, where erf is 1.
    let (max_x, gauss_cot) = erf_and_gauss_f32(cos / sin);
    let ux = ux.clamp(1e-6, 1.0 - 1e-6);
    let target = ux * (1.0 + max_x + INV_SQRT_PI32 * tan * gauss_cot);
    let t = guess(sin, 1.0 - (1.0 - ux).sqrt());
    let mut x = (t * (1.0 + max_x) - 1.0).clamp(-1.0, max_x);
    // One Halley step on F(x) - target.
    let slope = erfinv_f32(x);
    let gauss = (-slope * slope).exp();
    let f = 1.0 + x + INV_SQRT_PI32 * tan * gauss - target;
    let d1 = 1.0 - slope * tan;
    let d2 = -tan * HALF_SQRT_PI as f32 / gauss;
    let denominator = 2.0 * d1 * d1 - f * d2;
    if denominator > 0.0 {
        x = (x - 2.0 * f * d1 / denominator).clamp(-1.0, max_x);
    }
    erfinv_f32(x)
}

/// The table of guesses, `ROWS` rows (sin(theta_i) from 0 to 1) of `COLS`
/// entries (w = 1 - sqrt(1 - u) from 0 to 1), built on first use: what
/// the GPU's copy of this routine (`bsdf.wgsl`) reads.
pub fn guess_table() -> &'static [f32] {
    TABLE.get_or_init(build_table)
}

/// The table's rows and columns.
pub const GUESS_TABLE_SIZE: (usize, usize) = (ROWS, COLS);

/// The table's bilinear guess of `(x + 1) / (max_x + 1)`.
#[inline]
fn guess(sin: f32, w: f32) -> f32 {
    let table = guess_table();
    let fr = sin * (ROWS - 1) as f32;
    let fc = w * (COLS - 1) as f32;
    let (i, j) = ((fr as usize).min(ROWS - 2), (fc as usize).min(COLS - 2));
    let (a, b) = (fr - i as f32, fc - j as f32);
    let at = |i: usize, j: usize| table[i * COLS + j];
    let top = at(i, j) + (at(i, j + 1) - at(i, j)) * b;
    let bottom = at(i + 1, j) + (at(i + 1, j + 1) - at(i + 1, j)) * b;
    top + (bottom - top) * a
}

static TABLE: OnceLock<Vec<f32>> = OnceLock::new();

/// Solves every entry by bisection (F is increasing in x): 2048 entries,
/// about a millisecond, once per process.
fn build_table() -> Vec<f32> {
    let mut table = vec![0.0f32; ROWS * COLS];
    for i in 0..ROWS {
        let sin = i as f64 / (ROWS - 1) as f64;
        let cos = (1.0 - sin * sin).max(0.0).sqrt().max(1e-4);
        let tan = sin / cos;
        let max_x = erf_and_gauss_f32((cos / sin) as f32).0 as f64;
        let cdf = |x: f64| {
            // (f32's erfinv: the bisection's answer is stored in f32.)
            let s = erfinv_f32(x as f32) as f64;
            1.0 + x + INV_SQRT_PI * tan * (-s * s).exp()
        };
        let total = cdf(max_x);
        for j in 0..COLS {
            let w = j as f64 / (COLS - 1) as f64;
            let u = 1.0 - (1.0 - w) * (1.0 - w);
            let (mut lo, mut hi) = (-1.0, max_x);
            for _ in 0..60 {
                let mid = 0.5 * (lo + hi);
                if cdf(mid) < u * total {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            table[i * COLS + j] = ((0.5 * (lo + hi) + 1.0) / (max_x + 1.0)) as f32;
        }
    }
    table
}

/// erf(x), Abramowitz and Stegun 7.1.26 (absolute error < 1.5e-7 in
/// exact arithmetic), and exp(-x^2), which it computes on the way.
#[inline]
fn erf_and_gauss_f32(x: f32) -> (f32, f32) {
    let gauss = exp_or_zero(-x * x);
    let t = 1.0 / (1.0 + 0.327_591_1 * x.abs());
    let poly = t
        * (0.254_829_6
            + t * (-0.284_496_74 + t * (1.421_413_8 + t * (-1.453_152 + t * 1.061_405_4))));
    let y = 1.0 - poly * gauss;
    let erf = if x.is_nan() {
        x
    } else if x < 0.0 {
        -y
    } else {
        y
    };
    (erf, gauss)
}

/// Inverse of erf on (-1, 1), Giles' single-precision approximation
/// ("Approximating the erfinv function", 2010; relative error ~1e-7);
/// the argument is clamped to the largest f32 inside (-1, 1).
#[inline]
fn erfinv_f32(x: f32) -> f32 {
    let x = x.clamp(-0.999_999_94, 0.999_999_94);
    let mut w = -((1.0 - x) * (1.0 + x)).ln();
    let p = if w < 5.0 {
        w -= 2.5;
        let mut p = 2.810_226_4e-8;
        p = 3.432_739_4e-7 + p * w;
        p = -3.523_387_7e-6 + p * w;
        p = -4.391_506_5e-6 + p * w;
        p = 0.000_218_580_87 + p * w;
        p = -0.001_253_725 + p * w;
        p = -0.004_177_681_6 + p * w;
        p = 0.246_640_73 + p * w;
        1.501_409_4 + p * w
    } else {
        w = w.sqrt() - 3.0;
        let mut p = -0.000_200_214_26;
        p = 0.000_100_950_56 + p * w;
        p = 0.001_349_343_2 + p * w;
        p = -0.003_673_428_4 + p * w;
        p = 0.005_739_507_7 + p * w;
        p = -0.007_622_461 + p * w;
        p = 0.009_438_870_5 + p * w;
        p = 1.001_674 + p * w;
        2.832_976_8 + p * w
    };
    p * x
}

#[cfg(test)]
mod tests {
    use super::*;
    use statrs::function::erf as reference;

    /// The exact normalised CDF of the visible x slope at `cos`, with
    /// statrs' erf.
    fn cdf(cos: f64, slope: f64) -> f64 {
        let tan = (1.0 - cos * cos).sqrt() / cos;
        let cot = 1.0 / tan;
        let f = |s: f64| 1.0 + reference::erf(s) + INV_SQRT_PI * tan * (-s * s).exp();
        f(slope.min(cot)) / f(cot)
    }

    /// The largest |CDF(sampled slope) - u| over a grid of elevations and
    /// u, for a slope routine.
    fn worst_cdf_error(slopes: impl Fn(f32, f32) -> f32) -> f64 {
        let mut worst: f64 = 0.0;
        for ci in 1..200 {
            let cos = ci as f64 / 200.0;
            for ui in 0..=400 {
                let u = (ui as f64 / 400.0).clamp(1e-5, 1.0 - 1e-5);
                let s = slopes(cos as f32, u as f32) as f64;
                // u in f32, as callers pass it.
                worst = worst.max((cdf(cos, s) - u as f32 as f64).abs());
            }
        }
        worst
    }

    /// The sampled slopes invert the CDF to 1e-6 everywhere (measured
    /// 6.6e-7; the same steps in f64: 6.2e-7; Jakob's three Newton steps:
    /// 2e-6). Control: the table's guess alone, without the Halley step,
    /// is far off.
    #[test]
    fn x_slopes_invert_the_cdf() {
        let err = worst_cdf_error(|c, u| beckmann_visible_slopes(c, Vec2::new(u, 0.5)).x);
        assert!(err < 1e-6, "worst CDF error {err:.2e}");
        let guess_only = worst_cdf_error(|c, u| {
            let cos = c as f64;
            let sin = (1.0 - cos * cos).sqrt();
            let max_x = erf_and_gauss_f32((cos / sin) as f32).0 as f64;
            let t = guess(sin as f32, 1.0 - (1.0 - u).sqrt()) as f64;
            erfinv_f32((t * (1.0 + max_x) - 1.0).clamp(-1.0, max_x) as f32)
        });
        assert!(guess_only > 1e-4, "the control's error {guess_only:.2e}");
    }

    /// The y slope is Gaussian with variance 1/2: its CDF at the sample is u.
    #[test]
    fn y_slopes_are_gaussian() {
        for i in 1..1000 {
            let u = i as f32 / 1000.0;
            let s = beckmann_visible_slopes(0.6, Vec2::new(0.3, u)).y as f64;
            let back = 0.5 * (1.0 + reference::erf(s));
            assert!((back - u as f64).abs() < 1e-6, "u {u}: {back}");
        }
    }

    /// Normal and grazing incidence, and u at its ends, give finite slopes.
    #[test]
    fn extremes_are_finite() {
        for cos in [0.0, 1e-7, 1e-3, 0.5, 1.0 - 1e-7, 1.0] {
            for u in [0.0, 1e-7, 0.5, 1.0 - 1e-7, 1.0] {
                let s = beckmann_visible_slopes(cos, Vec2::new(u, u));
                assert!(s.is_finite(), "cos {cos} u {u}: {s}");
            }
        }
    }

    /// erf and erfinv agree with statrs to f32's precision (at the f32
    /// argument: near +-1 erfinv magnifies the argument's rounding).
    #[test]
    fn erf_and_erfinv_match_statrs() {
        for i in -400..=400 {
            let x = i as f32 / 100.0;
            let (e, g) = erf_and_gauss_f32(x);
            let x = x as f64;
            assert!((e as f64 - reference::erf(x)).abs() < 4e-7, "erf({x})");
            assert!((g as f64 - (-x * x).exp()).abs() < 1e-7, "gauss({x})");
        }
        for i in 1..2000 {
            let y = -1.0 + i as f32 / 1000.0;
            let (a, b) = (erfinv_f32(y) as f64, reference::erf_inv(y as f64));
            assert!(
                (a - b).abs() <= 2e-6 * b.abs().max(1e-3),
                "erfinv({y}): {a} vs {b}"
            );
        }
        for y in [0.999_999_94f32, -0.999_999_94, 0.999_99] {
            let (a, b) = (erfinv_f32(y) as f64, reference::erf_inv(y as f64));
            assert!((a - b).abs() <= 1e-5 * b.abs(), "erfinv({y}): {a} vs {b}");
        }
    }
}
