//! The tables of Nori's test files and warp tester: chi-square tables of
//! sampled directions in Nori's binning (cells uniform in cos theta and
//! phi), whose expected counts integrate the pdf adaptively. (Their t-test
//! is [`super::t_test`], the one `cargo test` uses too.)

use rayon::prelude::*;

use super::quadrature::{adaptive_simpson_2d, Adaptive};
use super::{Histogram, TestResult};
use crate::math::Vec3;
use crate::sampling::Sampler;

/// Observed and expected counts of sampled directions.
#[derive(Clone, Debug)]
pub struct DirectionTable {
    /// Rows are cells in cos theta from -1 (row 0) to 1; columns are cells
    /// in phi from 0 to 2 pi, phi measured from +x towards +y.
    pub hist: Histogram,
    /// Samples that were not finite unit-ish vectors; any of them fails the
    /// test.
    pub invalid: usize,
    /// Samples the sampler declined (returned `None`); not counted.
    pub declined: usize,
}

/// Samples per parallel work item.
const CHUNK: usize = 1 << 16;

/// Histogram of `n` sampled directions in Nori's binning (`rows` cells
/// uniform in cos theta, `cols` in phi) and the counts `pdf` (solid-angle
/// density) predicts, integrated adaptively over each cell. Samples come
/// from `sample`, fed by generators seeded from `seed`, in parallel; the
/// result does not depend on the thread count.
pub fn direction_table(
    rows: usize,
    cols: usize,
    n: usize,
    seed: u64,
    sample: impl Fn(&mut Sampler) -> Option<Vec3> + Sync,
    pdf: impl Fn(Vec3) -> f64 + Sync,
) -> DirectionTable {
    let cells = rows * cols;
    let chunks = n.div_ceil(CHUNK);
    let (observed, invalid, declined) = (0..chunks)
        .into_par_iter()
        .map(|c| {
            // State and stream both vary: PCG32 streams sharing a state
            // are correlated.
            let mut s = Sampler::new(
                seed ^ (c as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15),
                seed.rotate_left(17) ^ c as u64,
            );
            let mut obs = vec![0.0f64; cells];
            let (mut invalid, mut declined) = (0usize, 0usize);
            for _ in (c * CHUNK)..((c + 1) * CHUNK).min(n) {
                let Some(d) = sample(&mut s) else {
                    declined += 1;
                    continue;
                };
                if !d.is_finite() || (d.length_squared() - 1.0).abs() > 1e-3 {
                    invalid += 1;
                    continue;
                }
                obs[direction_cell(d, rows, cols)] += 1.0;
            }
            (obs, invalid, declined)
        })
        .reduce(
            || (vec![0.0; cells], 0, 0),
            |(mut a, ia, da), (b, ib, db)| {
                for (x, y) in a.iter_mut().zip(&b) {
                    *x += y;
                }
                (a, ia + ib, da + db)
            },
        );
    let expected = direction_expected(rows, cols, n, &pdf);
    DirectionTable {
        hist: Histogram {
            rows,
            cols,
            observed,
            expected,
        },
        invalid,
        declined,
    }
}

/// The cell of a unit direction in Nori's binning.
pub fn direction_cell(d: Vec3, rows: usize, cols: usize) -> usize {
    let z = (d.z * 0.5 + 0.5) * rows as f32;
    let row = (z.floor().max(0.0) as usize).min(rows - 1);
    let mut phi = d.y.atan2(d.x) * crate::math::INV_TWO_PI;
    if phi < 0.0 {
        phi += 1.0;
    }
    let col = ((phi * cols as f32).floor().max(0.0) as usize).min(cols - 1);
    row * cols + col
}

/// Expected counts of `n` samples per cell: the pdf integrated over
/// d(cos theta) d(phi), which is the solid-angle measure.
pub fn direction_expected(
    rows: usize,
    cols: usize,
    n: usize,
    pdf: &(impl Fn(Vec3) -> f64 + Sync),
) -> Vec<f64> {
    use std::f64::consts::PI;
    // Error per cell: a hundredth of a sample, or 1e-5 of the count.
    let lim = Adaptive {
        eps: 0.01 / n.max(1) as f64,
        rel: 1e-5,
        min_depth: 2,
        max_depth: 12,
    };
    (0..rows * cols)
        .into_par_iter()
        .map(|cell| {
            let (r, c) = (cell / cols, cell % cols);
            let z0 = -1.0 + 2.0 * r as f64 / rows as f64;
            let z1 = -1.0 + 2.0 * (r + 1) as f64 / rows as f64;
            let p0 = 2.0 * PI * c as f64 / cols as f64;
            let p1 = 2.0 * PI * (c + 1) as f64 / cols as f64;
            let f = |z: f64, phi: f64| {
                let s = (1.0 - z * z).max(0.0).sqrt();
                let d = Vec3::new((s * phi.cos()) as f32, (s * phi.sin()) as f32, z as f32);
                pdf(d)
            };
            adaptive_simpson_2d(f, (z0, p0), (z1, p1), lim) * n as f64
        })
        .collect()
}

/// Runs the chi-square test of a table: a failed test (p = 0) if any
/// sample was invalid or any expected count is negative or not finite.
pub fn table_test(t: &DirectionTable, min_expected: f64) -> TestResult {
    let bad_pdf = t.hist.expected.iter().any(|e| !e.is_finite() || *e < 0.0);
    if t.invalid > 0 || bad_pdf {
        return TestResult {
            statistic: f64::INFINITY,
            dof: 0.0,
            p_value: 0.0,
        };
    }
    t.hist.test(min_expected)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::warp;

    #[test]
    fn cells_follow_noris_binning() {
        assert_eq!(direction_cell(Vec3::new(0.0, 0.0, 1.0), 10, 20), 9 * 20);
        assert_eq!(direction_cell(Vec3::new(0.0, 0.0, -1.0), 10, 20), 0);
        // phi just below 2 pi lands in the last column.
        let d = Vec3::new(1.0, -1e-4, 0.05).normalize();
        assert_eq!(direction_cell(d, 10, 20), 5 * 20 + 19);
    }

    #[test]
    fn expected_counts_sum_to_the_sample_count() {
        let e = direction_expected(10, 20, 1000, &|d: Vec3| {
            warp::square_to_cosine_hemisphere_pdf(d) as f64
        });
        let sum: f64 = e.iter().sum();
        assert!((sum - 1000.0).abs() < 0.05, "{sum}");
        // A narrow Beckmann lobe, all in the top row.
        let e = direction_expected(51, 102, 1000, &|d: Vec3| {
            warp::square_to_beckmann_pdf(d, 0.01) as f64
        });
        let top: f64 = e[50 * 102..].iter().sum();
        assert!((top - 1000.0).abs() < 0.05, "{top}");
    }

    #[test]
    fn accepts_cosine_rejects_uniform_hemisphere() {
        let t = direction_table(
            10,
            20,
            200_000,
            1,
            |s| Some(warp::square_to_cosine_hemisphere(s.next_2d())),
            |d| warp::square_to_cosine_hemisphere_pdf(d) as f64,
        );
        assert!(table_test(&t, 5.0).passes(0.01));
        let t = direction_table(
            10,
            20,
            200_000,
            1,
            |s| Some(warp::square_to_uniform_hemisphere(s.next_2d())),
            |d| warp::square_to_cosine_hemisphere_pdf(d) as f64,
        );
        assert!(!table_test(&t, 5.0).passes(0.01));
    }
}
