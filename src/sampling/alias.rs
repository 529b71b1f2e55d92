//! Walker's alias method (Vose's construction): picks one of `n` cells in
//! proportion to its weight in O(1), one table read per sample, where an
//! inverted CDF needs a binary search of O(log n) cache misses.

use super::ONE_MINUS_EPSILON;
use crate::math::prefetch_at;
use std::hint::select_unpredictable;

/// One cell of the table: keep the cell with probability `keep`, else take
/// `alias`.
#[derive(Clone, Copy, Debug)]
struct Entry {
    keep: f32,
    alias: u32,
}

/// An alias table over `n` cells with non-negative weights.
#[derive(Clone, Debug)]
pub struct AliasTable {
    entries: Vec<Entry>,
    /// Sum of the weights (in f64 while building, then rounded).
    total: f32,
}

impl AliasTable {
    /// A table for `weights` (non-finite and negative weights count as 0).
    /// If every weight is zero the table picks uniformly; check
    /// [`total`](Self::total) first where that matters.
    pub fn new(weights: &[f32]) -> AliasTable {
        assert!(
            !weights.is_empty(),
            "an alias table needs at least one cell"
        );
        assert!(weights.len() <= u32::MAX as usize, "too many cells");
        let n = weights.len();
        let clean = |w: f32| {
            if w.is_finite() && w > 0.0 {
                w as f64
            } else {
                0.0
            }
        };
        let total: f64 = weights.iter().map(|&w| clean(w)).sum();
        if total <= 0.0 {
            let entries = (0..n)
                .map(|i| Entry {
                    keep: 1.0,
                    alias: i as u32,
                })
                .collect();
            return AliasTable {
                entries,
                total: 0.0,
            };
        }
        // Each cell's weight in units of the mean weight: cells below 1 are
        // topped up from a cell above 1, which becomes their alias.
        let mut scaled: Vec<f64> = weights
            .iter()
            .map(|&w| clean(w) * n as f64 / total)
            .collect();
        let mut entries = vec![
            Entry {
                keep: 1.0,
                alias: 0
            };
            n
        ];
        let (mut small, mut large): (Vec<u32>, Vec<u32>) =
            (0..n as u32).partition(|&i| scaled[i as usize] < 1.0);
        while let (Some(&s), Some(&l)) = (small.last(), large.last()) {
            small.pop();
            entries[s as usize] = Entry {
                keep: scaled[s as usize] as f32,
                alias: l,
            };
            scaled[l as usize] -= 1.0 - scaled[s as usize];
            if scaled[l as usize] < 1.0 {
                large.pop();
                small.push(l);
            }
        }
        // What is left is 1 up to round-off; a cell of zero weight left over
        // must still never be picked, so it sends everything to a cell that
        // has weight.
        let some_weighted = weights.iter().position(|&w| clean(w) > 0.0).unwrap_or(0) as u32;
        for i in small.into_iter().chain(large) {
            entries[i as usize] = if clean(weights[i as usize]) > 0.0 {
                Entry {
                    keep: 1.0,
                    alias: i,
                }
            } else {
                Entry {
                    keep: 0.0,
                    alias: some_weighted,
                }
            };
        }
        AliasTable {
            entries,
            total: total as f32,
        }
    }

    pub fn len(&self) -> usize {
        self.entries.len()
    }

    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// Sum of the (cleaned) weights.
    pub fn total(&self) -> f32 {
        self.total
    }

    /// Picks a cell with `u` in [0, 1) and returns it with a fresh uniform
    /// number in [0, 1) made from the bits of `u` the choice did not use
    /// (about 24 - log2(n) of them).
    #[inline]
    pub fn sample(&self, u: f32) -> (usize, f32) {
        sample_entries(&self.entries, u)
    }
}

/// Several alias tables of the same length stored end to end (one per row
/// of a 2D table): one allocation, no pointer to chase per sample.
#[derive(Clone, Debug)]
pub struct AliasRows {
    entries: Vec<Entry>,
    len: usize,
    totals: Vec<f32>,
}

impl AliasRows {
    /// One table per chunk of `len` weights (`weights.len()` a multiple of
    /// `len` > 0).
    pub fn new(weights: &[f32], len: usize) -> AliasRows {
        assert!(
            len > 0 && weights.len().is_multiple_of(len),
            "rows of equal length"
        );
        let mut entries = Vec::with_capacity(weights.len());
        let mut totals = Vec::with_capacity(weights.len() / len);
        for row in weights.chunks_exact(len) {
            let t = AliasTable::new(row);
            entries.extend_from_slice(&t.entries);
            totals.push(t.total);
        }
        AliasRows {
            entries,
            len,
            totals,
        }
    }

    /// Sum of the weights of row `r`.
    pub fn total(&self, r: usize) -> f32 {
        self.totals[r]
    }

    /// The cell [`sample`](Self::sample) starts from in any row, before its
    /// table entry is read: the cell drawn unless the entry sends `u` to
    /// its alias. Knowing it early lets a caller prefetch what it will read
    /// for the cell while the entry itself is fetched.
    #[inline]
    pub fn first_guess(&self, u: f32) -> usize {
        drawn_cell(self.len, u).0
    }

    /// Prefetches the entry of `cell` in row `r` (for a `u` whose
    /// [`AliasRows::first_guess`] it is, the entry [`AliasRows::sample`]
    /// reads), so a caller that knows `u` early can overlap the cache miss
    /// with other work.
    #[inline]
    pub fn prefetch(&self, r: usize, cell: usize) {
        prefetch_at(&self.entries, r * self.len + cell);
    }

    /// [`AliasTable::sample`] in row `r`.
    #[inline]
    pub fn sample(&self, r: usize, u: f32) -> (usize, f32) {
        sample_entries(&self.entries[r * self.len..(r + 1) * self.len], u)
    }
}

/// The cell of `n` that `u` draws before its entry is read, and `u`
/// scaled to [0, n]. NaN and negative input count as 0.
///
/// In u32 (tables are far shorter than 2^32 entries: an entry is 8 bytes):
/// a float to and from u32 is one instruction each way, to and from usize
/// a branch or a fix-up, and this runs a few times per path vertex.
#[inline]
fn drawn_cell(n: usize, u: f32) -> (usize, f32) {
    debug_assert!(n <= u32::MAX as usize);
    let u = if u >= 0.0 { u.min(1.0) } else { 0.0 };
    let x = u * n as u32 as f32;
    ((x as u32 as usize).min(n - 1), x)
}

#[inline]
fn sample_entries(entries: &[Entry], u: f32) -> (usize, f32) {
    let (i, x) = drawn_cell(entries.len(), u);
    let frac = (x - i as f32).clamp(0.0, 1.0);
    let e = entries[i];
    // Without a branch: which side `u` falls on is a coin toss, and a
    // branch on it mispredicted half the time (a tenth of the env-lit
    // stands' render sat in the environment's prefetch, on this branch).
    // The same operations on the side chosen, so the same bits.
    let keep = frac < e.keep;
    let cell = select_unpredictable(keep, i, e.alias as usize);
    let above = select_unpredictable(keep, frac, frac - e.keep);
    let width = select_unpredictable(keep, e.keep, 1.0 - e.keep);
    (cell, (above / width).clamp(0.0, ONE_MINUS_EPSILON))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Sampler;
    use crate::stats::chi2_test;

    fn histogram(t: &AliasTable, n: usize, seed: u64) -> Vec<f64> {
        let mut s = Sampler::new(seed, 1);
        let mut h = vec![0.0; t.len()];
        for _ in 0..n {
            h[t.sample(s.next_1d()).0] += 1.0;
        }
        h
    }

    fn expected(weights: &[f32], n: usize) -> Vec<f64> {
        let total: f64 = weights.iter().map(|&w| w.max(0.0) as f64).sum();
        weights
            .iter()
            .map(|&w| w.max(0.0) as f64 / total * n as f64)
            .collect()
    }

    #[test]
    fn chi2_matches_weights_and_detects_a_wrong_table() {
        let mut weights: Vec<f32> = (0..500).map(|i| ((i * 37) % 11) as f32).collect();
        weights[17] = 3000.0; // a "sun"
        weights[18] = 0.0;
        let t = AliasTable::new(&weights);
        let n = 1_000_000;
        let obs = histogram(&t, n, 3);
        assert_eq!(obs[18], 0.0);
        let r = chi2_test(&obs, &expected(&weights, n), 5.0);
        assert!(r.passes(0.01), "{r:?}");
        let mut wrong = weights.clone();
        wrong[17] *= 1.05;
        let r = chi2_test(&obs, &expected(&wrong, n), 5.0);
        assert!(!r.passes(0.01), "5% off accepted: {r:?}");
    }

    #[test]
    fn zero_weights_are_never_picked_and_the_rest_is_uniform() {
        let weights = [0.0, 1.0, 0.0, 0.0, 1e-30, 0.0, f32::NAN, -1.0];
        let t = AliasTable::new(&weights);
        let mut s = Sampler::new(5, 5);
        for _ in 0..100_000 {
            let (i, rest) = t.sample(s.next_1d());
            assert!(i == 1 || i == 4, "picked {i}");
            assert!((0.0..1.0).contains(&rest));
        }
        // Edges of the unit interval and garbage stay in range.
        for u in [0.0, ONE_MINUS_EPSILON, 1.0, -1.0, f32::NAN] {
            let (i, rest) = t.sample(u);
            assert!(i == 1 || i == 4, "{u}: picked {i}");
            assert!((0.0..1.0).contains(&rest), "{u}: {rest}");
        }
        let none = AliasTable::new(&[0.0; 4]);
        assert_eq!(none.total(), 0.0);
        assert_eq!(none.sample(0.6).0, 2);
    }

    /// The leftover uniform is uniform and independent of the cell.
    #[test]
    fn rows_are_the_tables_of_their_chunks() {
        let weights: Vec<f32> = (0..60).map(|i| ((i * 7) % 5) as f32).collect();
        let rows = AliasRows::new(&weights, 12);
        let mut s = Sampler::new(2, 2);
        for r in 0..5 {
            let table = AliasTable::new(&weights[r * 12..(r + 1) * 12]);
            assert_eq!(rows.total(r), table.total());
            for _ in 0..1000 {
                let u = s.next_1d();
                assert_eq!(rows.sample(r, u), table.sample(u));
            }
        }
    }

    #[test]
    fn chi2_leftover_uniform() {
        let weights = [1.0, 5.0, 0.5, 2.5];
        let t = AliasTable::new(&weights);
        let bins = 20;
        let n = 400_000;
        let mut obs = vec![0.0; weights.len() * bins];
        let mut s = Sampler::new(8, 8);
        for _ in 0..n {
            let (i, rest) = t.sample(s.next_1d());
            obs[i * bins + (rest * bins as f32) as usize] += 1.0;
        }
        let exp: Vec<f64> = expected(&weights, n)
            .iter()
            .flat_map(|&e| std::iter::repeat_n(e / bins as f64, bins))
            .collect();
        let r = chi2_test(&obs, &exp, 5.0);
        assert!(r.passes(0.01), "{r:?}");
    }
}
