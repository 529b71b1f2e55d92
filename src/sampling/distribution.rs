//! Piecewise-constant 1D distributions for importance sampling tables
//! (light selection, mesh areas).

use super::ONE_MINUS_EPSILON;

/// A discrete/piecewise-constant 1D distribution over `n` equal cells of [0, 1).
#[derive(Clone, Debug)]
pub struct Distribution1D {
    func: Vec<f32>,
    cdf: Vec<f32>,
    integral: f32,
}

impl Distribution1D {
    /// Builds from non-negative weights. If all are zero, falls back to uniform
    /// so callers never divide by zero (check [`integral`](Self::integral)).
    pub fn new(weights: &[f32]) -> Distribution1D {
        assert!(!weights.is_empty(), "distribution needs at least one cell");
        let n = weights.len();
        let func: Vec<f32> = weights
            .iter()
            .map(|&w| if w.is_finite() && w > 0.0 { w } else { 0.0 })
            .collect();
        let mut cdf = Vec::with_capacity(n + 1);
        let mut acc = 0.0f64;
        cdf.push(0.0);
        for &f in &func {
            acc += f as f64 / n as f64;
            cdf.push(acc as f32);
        }
        let integral = acc as f32;
        if integral > 0.0 {
            for c in cdf.iter_mut() {
                *c /= integral;
            }
        } else {
            for (i, c) in cdf.iter_mut().enumerate() {
                *c = i as f32 / n as f32;
            }
        }
        cdf[n] = 1.0;
        Distribution1D {
            func,
            cdf,
            integral,
        }
    }

    pub fn len(&self) -> usize {
        self.func.len()
    }

    pub fn is_empty(&self) -> bool {
        self.func.is_empty()
    }

    /// Integral of the weights over [0, 1) (mean weight).
    pub fn integral(&self) -> f32 {
        self.integral
    }

    /// The running sums: `n + 1` values from 0 to exactly 1 (uniform where
    /// every weight is zero); cell `i` is picked for `u` in
    /// `[cdf[i], cdf[i + 1])`.
    pub fn cdf(&self) -> &[f32] {
        &self.cdf
    }

    /// Probability of picking cell `i` as a discrete choice.
    pub fn discrete_pdf(&self, i: usize) -> f32 {
        self.cdf[i + 1] - self.cdf[i]
    }

    /// Density (w.r.t. [0,1)) of the continuous sample in cell `i`.
    pub fn pdf(&self, i: usize) -> f32 {
        if self.integral > 0.0 {
            self.func[i] / self.integral
        } else {
            1.0
        }
    }

    /// Picks a cell; returns (index, probability): the choice of
    /// [`Distribution1D::sample_discrete`] without the rescaled number
    /// (a division), for callers that do not reuse it.
    #[inline]
    pub fn sample_index(&self, u: f32) -> (usize, f32) {
        if self.func.len() == 1 {
            return (0, 1.0);
        }
        let i = self.find(u);
        (i, self.discrete_pdf(i))
    }

    /// Picks a cell; returns (index, probability, u rescaled to [0,1) within the cell).
    ///
    /// Inlined for the one-cell case (a scene's single sky or probe, chosen
    /// every bounce), which is what the general case computes without the
    /// search; the search stays out of line.
    #[inline]
    pub fn sample_discrete(&self, u: f32) -> (usize, f32, f32) {
        if self.func.len() == 1 {
            return (0, 1.0, u.clamp(0.0, 1.0 - f32::EPSILON));
        }
        self.sample_discrete_searched(u)
    }

    /// [`Distribution1D::sample_discrete`] with more than one cell.
    #[inline(never)]
    fn sample_discrete_searched(&self, u: f32) -> (usize, f32, f32) {
        let (i, p) = self.sample_index(u);
        let du = if p > 0.0 {
            ((u - self.cdf[i]) / p).clamp(0.0, 1.0 - f32::EPSILON)
        } else {
            0.0
        };
        (i, p, du)
    }

    /// Continuous sample in [0,1): returns (x, density, cell index).
    pub fn sample_continuous(&self, u: f32) -> (f32, f32, usize) {
        let (i, _, du) = self.sample_discrete(u);
        let x = ((i as f32 + du) / self.len() as f32).min(ONE_MINUS_EPSILON);
        (x, self.pdf(i), i)
    }

    /// Last cell whose cdf is <= u and whose probability is non-zero.
    fn find(&self, u: f32) -> usize {
        // partition_point: first index with cdf > u, so cell = that - 1.
        // In a short table the same index is the count of entries <= u
        // (the cdf never decreases), which takes no branch: a binary
        // search's branches follow u, a random number, and mispredict (2%
        // of the Cornell box's render went to choosing one of its light's
        // two triangles).
        let idx = if self.cdf.len() <= SHORT_CDF {
            self.cdf.iter().filter(|&&c| c <= u).count()
        } else {
            self.cdf.partition_point(|&c| c <= u)
        };
        self.cell_before(idx)
    }

    /// The cell ending at cdf entry `idx` (the first entry above u), or
    /// the nearest with a non-zero probability (u exactly on a plateau).
    fn cell_before(&self, idx: usize) -> usize {
        let n = self.func.len();
        let mut i = idx.saturating_sub(1).min(n - 1);
        if self.cdf[i + 1] - self.cdf[i] <= 0.0 {
            if let Some(j) = (i..n).find(|&j| self.cdf[j + 1] > self.cdf[j]) {
                i = j;
            } else if let Some(j) = (0..i).rev().find(|&j| self.cdf[j + 1] > self.cdf[j]) {
                i = j;
            }
        }
        i
    }
}

/// The longest cdf [`Distribution1D::find`] counts through rather than
/// searches (16 cells).
const SHORT_CDF: usize = 17;

#[cfg(test)]
mod tests {
    use super::*;

    /// `find` by counting (short tables) finds the cell the binary search
    /// finds, for tables with plateaus and zero cells, at and between cdf values.
    #[test]
    fn counting_finds_what_the_search_finds() {
        let mut s = crate::sampling::Sampler::new(2, 4);
        for n in 1..=SHORT_CDF {
            for _ in 0..50 {
                let w: Vec<f32> = (0..n)
                    .map(|_| if s.next_1d() < 0.3 { 0.0 } else { s.next_1d() })
                    .collect();
                if w.iter().all(|&x| x == 0.0) {
                    continue;
                }
                let d = Distribution1D::new(&w);
                let mut us: Vec<f32> = (0..40).map(|_| s.next_1d()).collect();
                us.extend(d.cdf.iter().copied());
                us.extend([0.0, ONE_MINUS_EPSILON, f32::NAN]);
                for u in us {
                    // `find` as it was, by binary search alone.
                    let searched = d.cell_before(d.cdf.partition_point(|&c| c <= u));
                    assert_eq!(d.find(u), searched, "{w:?} at {u}");
                }
            }
        }
    }

    #[test]
    fn discrete_matches_weights() {
        let d = Distribution1D::new(&[1.0, 0.0, 3.0]);
        assert!((d.discrete_pdf(0) - 0.25).abs() < 1e-6);
        assert_eq!(d.discrete_pdf(1), 0.0);
        assert!((d.discrete_pdf(2) - 0.75).abs() < 1e-6);
        for k in 0..1000 {
            let (i, _, _) = d.sample_discrete(k as f32 / 1000.0);
            assert_ne!(i, 1, "zero-weight cell sampled");
        }
        assert_eq!(d.sample_discrete(0.25).0, 2);
    }

    #[test]
    fn zero_weights_fall_back_to_uniform() {
        let d = Distribution1D::new(&[0.0, 0.0]);
        assert_eq!(d.integral(), 0.0);
        let (x, pdf, _) = d.sample_continuous(0.7);
        assert!((0.0..1.0).contains(&x) && pdf > 0.0);
    }
}
