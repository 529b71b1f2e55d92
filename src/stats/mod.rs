//! Statistical tests used by the test suite and `lente test`: Pearson's
//! chi-square goodness-of-fit test and Student's t-test, as Nori runs them.

pub mod histogram;
pub mod nori;
pub mod quadrature;

pub use histogram::{plane_histogram, sphere_histogram, Histogram};

use statrs::distribution::{ChiSquared, ContinuousCDF, StudentsT};

/// Outcome of a hypothesis test.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TestResult {
    /// The test statistic (chi^2 or t).
    pub statistic: f64,
    /// Degrees of freedom.
    pub dof: f64,
    /// Probability of a statistic at least this extreme under the null hypothesis.
    pub p_value: f64,
}

impl TestResult {
    /// True if the null hypothesis survives at significance `alpha`.
    pub fn passes(&self, alpha: f64) -> bool {
        self.p_value.is_finite() && self.p_value > alpha
    }
}

/// Sidak correction: per-test significance so that `n` tests together have
/// family-wise significance `alpha`.
pub fn sidak(alpha: f64, n: usize) -> f64 {
    1.0 - (1.0 - alpha).powf(1.0 / n.max(1) as f64)
}

/// Chi-square goodness-of-fit test of observed counts against expected
/// counts. Cells whose expected count is below `min_expected` are pooled
/// (in ascending order of expectation, as Nori does) until the pool reaches
/// it. Samples in cells of zero expectation thus land in a pool and count
/// against the sampler; if nothing at all was expected there, p = 0.
pub fn chi2_test(observed: &[f64], expected: &[f64], min_expected: f64) -> TestResult {
    assert_eq!(observed.len(), expected.len());
    let mut cells: Vec<(f64, f64)> = expected
        .iter()
        .copied()
        .zip(observed.iter().copied())
        .collect();
    cells.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut stat = 0.0;
    let mut dof: i64 = -1;
    let (mut pool_e, mut pool_o) = (0.0, 0.0);
    for &(e, o) in &cells {
        pool_e += e;
        pool_o += o;
        if pool_e >= min_expected {
            stat += (pool_o - pool_e) * (pool_o - pool_e) / pool_e;
            dof += 1;
            pool_e = 0.0;
            pool_o = 0.0;
        }
    }
    if pool_e > 0.0 || pool_o > 0.0 {
        // Leftover pool (possibly with zero expectation: samples where the
        // pdf says there can be none make the statistic infinite).
        stat += if pool_e > 0.0 {
            (pool_o - pool_e) * (pool_o - pool_e) / pool_e
        } else if pool_o > 0.0 {
            f64::INFINITY
        } else {
            0.0
        };
        dof += 1;
    }
    if !stat.is_finite() {
        return TestResult {
            statistic: stat,
            dof: dof.max(0) as f64,
            p_value: 0.0,
        };
    }
    if dof < 1 {
        return TestResult {
            statistic: stat,
            dof: 0.0,
            p_value: 1.0,
        };
    }
    let dist = ChiSquared::new(dof as f64).expect("positive degrees of freedom");
    TestResult {
        statistic: stat,
        dof: dof as f64,
        p_value: 1.0 - dist.cdf(stat),
    }
}

/// Running mean and variance (Welford), accumulated in f64.
#[derive(Clone, Copy, Debug, Default)]
pub struct MeanVar {
    pub n: u64,
    mean: f64,
    m2: f64,
}

impl MeanVar {
    pub fn push(&mut self, x: f64) {
        self.n += 1;
        let d = x - self.mean;
        self.mean += d / self.n as f64;
        self.m2 += d * (x - self.mean);
    }

    pub fn mean(&self) -> f64 {
        self.mean
    }

    /// Unbiased sample variance.
    pub fn variance(&self) -> f64 {
        if self.n < 2 {
            0.0
        } else {
            self.m2 / (self.n - 1) as f64
        }
    }

    /// Combines two accumulators (Chan et al.).
    pub fn merge(&self, o: &MeanVar) -> MeanVar {
        if self.n == 0 {
            return *o;
        }
        if o.n == 0 {
            return *self;
        }
        let n = self.n + o.n;
        let d = o.mean - self.mean;
        MeanVar {
            n,
            mean: self.mean + d * o.n as f64 / n as f64,
            m2: self.m2 + o.m2 + d * d * (self.n as f64 * o.n as f64) / n as f64,
        }
    }
}

/// Smallest standard error the t-test assumes, relative to the larger of
/// the mean and the reference. An estimator with (almost) no variance
/// would otherwise fail on the rounding of f32 arithmetic; a bias larger
/// than about 1e-4 relative still fails. (Nori floors the variance at an
/// absolute 1e-5 instead, which makes tests of small means toothless.)
pub const RELATIVE_SE_FLOOR: f64 = 1e-5;

/// Two-sided one-sample Student t-test of a sample mean against a
/// reference, with the standard error floored at [`RELATIVE_SE_FLOOR`]
/// (the one rule for samples with no variance: `cargo test` and `lente
/// test` share it).
pub fn t_test(sample: &MeanVar, reference: f64) -> TestResult {
    let n = sample.n as f64;
    let mean = sample.mean();
    let se = if sample.n >= 2 {
        (sample.variance() / n).sqrt()
    } else {
        0.0
    };
    let se = se.max(RELATIVE_SE_FLOOR * mean.abs().max(reference.abs()));
    two_sided(mean - reference, se, n - 1.0)
}

/// Welch's two-sample t-test: do two estimators have the same mean? The
/// standard error of the difference is floored as [`t_test`]'s is.
pub fn welch_t_test(a: &MeanVar, b: &MeanVar) -> TestResult {
    let (na, nb) = (a.n as f64, b.n as f64);
    if a.n < 2 || b.n < 2 {
        return two_sided(a.mean() - b.mean(), 0.0, 0.0);
    }
    let (va, vb) = (a.variance() / na, b.variance() / nb);
    let floor = RELATIVE_SE_FLOOR * a.mean().abs().max(b.mean().abs());
    let se2 = va + vb;
    let dof = if se2 > floor * floor {
        // Welch-Satterthwaite.
        se2 * se2 / (va * va / (na - 1.0) + vb * vb / (nb - 1.0))
    } else {
        na + nb - 2.0
    };
    two_sided(a.mean() - b.mean(), se2.max(floor * floor).sqrt(), dof)
}

/// The two-sided test of a difference `diff` with standard error `se`
/// against Student's t with `dof` degrees of freedom: a zero difference
/// passes, a non-finite one fails, and so does any other difference when
/// `se` or `dof` is zero (too few samples to judge).
fn two_sided(diff: f64, se: f64, dof: f64) -> TestResult {
    let dof = dof.max(0.0);
    if !diff.is_finite() {
        return TestResult {
            statistic: f64::NAN,
            dof,
            p_value: 0.0,
        };
    }
    if diff == 0.0 {
        return TestResult {
            statistic: 0.0,
            dof,
            p_value: 1.0,
        };
    }
    if se.is_nan() || se <= 0.0 || dof <= 0.0 {
        return TestResult {
            statistic: f64::INFINITY.copysign(diff),
            dof,
            p_value: 0.0,
        };
    }
    let t = diff / se;
    let dist = StudentsT::new(0.0, 1.0, dof).expect("positive degrees of freedom");
    TestResult {
        statistic: t,
        dof,
        p_value: 2.0 * (1.0 - dist.cdf(t.abs())),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Sampler;

    #[test]
    fn chi2_accepts_uniform_and_rejects_skewed() {
        let mut s = Sampler::new(1, 2);
        let n = 20;
        let mut obs = vec![0.0; n];
        let mut skew = vec![0.0; n];
        for _ in 0..100_000 {
            let u = s.next_1d();
            obs[(u * n as f32) as usize] += 1.0;
            skew[((u * u) * n as f32) as usize] += 1.0;
        }
        let exp = vec![100_000.0 / n as f64; n];
        assert!(chi2_test(&obs, &exp, 5.0).passes(0.01));
        assert!(!chi2_test(&skew, &exp, 5.0).passes(0.01));
    }

    #[test]
    fn chi2_fails_on_impossible_samples() {
        let r = chi2_test(&[30.0, 30.0, 40.0], &[50.0, 50.0, 0.0], 5.0);
        assert!(r.p_value < 1e-3, "{r:?}");
        let r = chi2_test(&[0.0, 20.0, 20.0], &[0.0, 20.0, 20.0], 5.0);
        assert!(r.passes(0.01));
    }

    #[test]
    fn t_test_floors_the_standard_error() {
        let mut mv = MeanVar::default();
        for _ in 0..1000 {
            mv.push(0.5);
        }
        assert!(t_test(&mv, 0.5).passes(0.01));
        // f32 rounding of the reference.
        assert!(t_test(&mv, 0.5 * (1.0 + 1e-6)).passes(0.01));
        assert!(!t_test(&mv, 0.51).passes(0.01));
        assert!(!t_test(&mv, 0.5 * (1.0 + 1e-3)).passes(0.01));
        let zero = MeanVar::default();
        assert!(!t_test(&zero, 1.0).passes(0.01));
    }

    #[test]
    fn t_test_on_noise() {
        let mut s = Sampler::new(5, 6);
        let mut mv = MeanVar::default();
        for _ in 0..100_000 {
            mv.push(s.next_1d() as f64);
        }
        assert!(t_test(&mv, 0.5).passes(0.01));
        assert!(!t_test(&mv, 0.5 * 1.02).passes(0.01));
    }

    #[test]
    fn welch_floors_the_standard_error_as_the_t_test_does() {
        let mut a = MeanVar::default();
        let mut b = MeanVar::default();
        for _ in 0..1000 {
            a.push(0.5);
            b.push(0.5 * (1.0 + 1e-6));
        }
        assert!(welch_t_test(&a, &b).passes(0.01));
        let mut c = MeanVar::default();
        for _ in 0..1000 {
            c.push(0.51);
        }
        assert!(!welch_t_test(&a, &c).passes(0.01));
    }

    #[test]
    fn t_test_accepts_truth_and_rejects_two_percent_bias() {
        let mut s = Sampler::new(3, 4);
        let mut mv = MeanVar::default();
        for _ in 0..200_000 {
            mv.push(s.next_1d() as f64);
        }
        assert!(t_test(&mv, 0.5).passes(0.01));
        assert!(!t_test(&mv, 0.51).passes(0.01));
    }

    #[test]
    fn merge_matches_single_pass() {
        let xs: Vec<f64> = (0..100).map(|i| (i * i % 17) as f64).collect();
        let mut all = MeanVar::default();
        let (mut a, mut b) = (MeanVar::default(), MeanVar::default());
        for (i, &x) in xs.iter().enumerate() {
            all.push(x);
            if i < 37 {
                a.push(x)
            } else {
                b.push(x)
            }
        }
        let m = a.merge(&b);
        assert!((m.mean() - all.mean()).abs() < 1e-12);
        assert!((m.variance() - all.variance()).abs() < 1e-9);
    }

    #[test]
    fn sidak_is_exact_for_one_test() {
        assert!((sidak(0.01, 1) - 0.01).abs() < 1e-12);
        assert!(sidak(0.01, 10) < 0.01 / 9.0);
    }
}
