//! Sampling a linear density on [0, 1]: the 1D step of a piecewise-bilinear
//! warp (each cell of a bilinear interpolant is sampled one axis at a time).

use crate::math::{clamp_unit_lanes, Vec4};

/// A point of [0, 1] drawn with density proportional to `(1 - x) a + x b`
/// (`a`, `b` >= 0, not both zero) from `u` in [0, 1): the inverse of its CDF
/// in the form that stays accurate when `a` and `b` differ by orders of
/// magnitude or one is zero.
#[inline]
pub fn sample_linear(a: f32, b: f32, u: f32) -> f32 {
    // Solve ((b - a) / 2) x^2 + a x = u (a + b) / 2; multiplying the usual
    // root by its conjugate avoids the cancellation of -a + sqrt(..).
    let root = ((1.0 - u) * a * a + u * b * b).sqrt();
    let denom = a + root;
    if denom > 0.0 {
        (u * (a + b) / denom).clamp(0.0, 1.0)
    } else {
        0.0
    }
}

/// [`sample_linear`] in four lanes, each bit for bit the scalar routine
/// (the same operations in its order; the branch a select).
#[inline]
pub fn sample_linear_lanes(a: Vec4, b: Vec4, u: Vec4) -> Vec4 {
    let root = ((Vec4::ONE - u) * a * a + u * b * b).sqrt();
    let denom = a + root;
    let x = clamp_unit_lanes(u * (a + b) / denom);
    Vec4::select(denom.cmpgt(Vec4::ZERO), x, Vec4::ZERO)
}

/// Density at `x` in [0, 1] of [`sample_linear`] with the same `a`, `b`.
#[inline]
pub fn linear_pdf(a: f32, b: f32, x: f32) -> f32 {
    let sum = a + b;
    if sum > 0.0 {
        2.0 * ((1.0 - x) * a + x * b) / sum
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Sampler;
    use crate::stats::{chi2_test, sidak};

    /// The lanes give the scalar bits, zero and tiny endpoints included.
    #[test]
    fn lanes_are_the_scalar_bit_for_bit() {
        let ends = [0.0f32, 1e-30, 1e-7, 0.3, 1.0, 7.5, 1e20];
        let us = [0.0f32, 1e-7, 0.25, 0.5, 0.999_999_9];
        let mut cases = Vec::new();
        for &a in &ends {
            for &b in &ends {
                for &u in &us {
                    cases.push((a, b, u));
                }
            }
        }
        while !cases.len().is_multiple_of(4) {
            cases.push((0.0, 0.0, 0.5));
        }
        for four in cases.chunks_exact(4) {
            let lane = |f: fn(&(f32, f32, f32)) -> f32| {
                Vec4::from_array(std::array::from_fn(|k| f(&four[k])))
            };
            let x = sample_linear_lanes(lane(|c| c.0), lane(|c| c.1), lane(|c| c.2));
            for (k, &(a, b, u)) in four.iter().enumerate() {
                assert_eq!(
                    x[k].to_bits(),
                    sample_linear(a, b, u).to_bits(),
                    "{a} {b} {u}"
                );
            }
        }
    }

    /// Expected counts of `bins` equal bins, integrating the linear pdf
    /// exactly (trapezoids).
    fn expected(a: f32, b: f32, bins: usize, n: usize) -> Vec<f64> {
        (0..bins)
            .map(|k| {
                let (x0, x1) = (k as f32 / bins as f32, (k + 1) as f32 / bins as f32);
                let p = 0.5 * (linear_pdf(a, b, x0) + linear_pdf(a, b, x1)) as f64;
                p / bins as f64 * n as f64
            })
            .collect()
    }

    #[test]
    fn chi2_linear_densities() {
        let cases = [(1.0, 1.0), (0.0, 1.0), (1.0, 0.0), (1.0, 1e4), (3e-6, 2.0)];
        let alpha = sidak(0.01, cases.len());
        let (bins, n) = (50, 500_000);
        for (k, &(a, b)) in cases.iter().enumerate() {
            let mut s = Sampler::new(4, k as u64);
            let mut obs = vec![0.0; bins];
            for _ in 0..n {
                let x = sample_linear(a, b, s.next_1d());
                assert!((0.0..=1.0).contains(&x));
                obs[((x * bins as f32) as usize).min(bins - 1)] += 1.0;
            }
            let r = chi2_test(&obs, &expected(a, b, bins, n), 5.0);
            assert!(r.passes(alpha), "({a}, {b}): {r:?}");
            // The test notices the slope reversed.
            if a != b {
                let r = chi2_test(&obs, &expected(b, a, bins, n), 5.0);
                assert!(!r.passes(alpha), "({a}, {b}) reversed accepted: {r:?}");
            }
        }
    }

    #[test]
    fn inverts_the_cdf_and_survives_degenerate_input() {
        for (a, b) in [(2.0f32, 5.0f32), (0.0, 1.0), (7.0, 0.0)] {
            for k in 0..=10 {
                let u = k as f32 / 10.0;
                let x = sample_linear(a, b, u);
                let cdf = (a * x + 0.5 * (b - a) * x * x) / (0.5 * (a + b));
                assert!((cdf - u).abs() < 1e-5, "({a},{b}) u {u}: x {x} cdf {cdf}");
            }
        }
        assert_eq!(sample_linear(0.0, 0.0, 0.5), 0.0);
        assert_eq!(sample_linear(0.0, 3.0, 0.0), 0.0);
        assert_eq!(linear_pdf(0.0, 0.0, 0.5), 0.0);
    }
}
