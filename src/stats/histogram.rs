//! Chi-square tests of sampling routines against their pdfs, in the style of
//! Nori's warp tester: histogram the samples, integrate the pdf over each
//! cell for the expected counts, pool sparse cells, test.

use super::{chi2_test, TestResult};
use crate::math::{Vec2, Vec3, PI};
use crate::sampling::Sampler;

/// Observed and expected counts of one histogram test, row-major
/// (`rows` x `cols`), kept so they can be drawn.
#[derive(Clone, Debug)]
pub struct Histogram {
    pub rows: usize,
    pub cols: usize,
    pub observed: Vec<f64>,
    pub expected: Vec<f64>,
}

impl Histogram {
    pub fn test(&self, min_expected: f64) -> TestResult {
        chi2_test(&self.observed, &self.expected, min_expected)
    }
}

/// Sub-cell resolution used to integrate the pdf over each cell.
const SUB: usize = 16;

/// Histogram of directions over the sphere on a grid of (theta, phi)
/// cells (`rows` in theta from 0 to pi, `cols` in phi from 0 to 2pi).
/// `sample` returns a unit direction or None (rejected sample, counted
/// nowhere); `pdf` is the solid-angle density. Expected counts integrate
/// the pdf over each cell with the midpoint rule on a fine grid.
pub fn sphere_histogram(
    rows: usize,
    cols: usize,
    n: usize,
    seed: u64,
    mut sample: impl FnMut(&mut Sampler) -> Option<Vec3>,
    pdf: impl Fn(Vec3) -> f64,
) -> Histogram {
    let mut sampler = Sampler::new(seed, 0x5eed);
    let mut observed = vec![0.0; rows * cols];
    for _ in 0..n {
        let Some(d) = sample(&mut sampler) else {
            continue;
        };
        if !d.is_finite() {
            continue;
        }
        let theta = d.z.clamp(-1.0, 1.0).acos();
        let row = ((theta / PI * rows as f32) as usize).min(rows - 1);
        let phi = d.y.atan2(d.x).rem_euclid(2.0 * PI);
        let col = ((phi / (2.0 * PI) * cols as f32) as usize).min(cols - 1);
        observed[row * cols + col] += 1.0;
    }
    let mut expected = vec![0.0; rows * cols];
    let dtheta = std::f64::consts::PI / (rows * SUB) as f64;
    let dphi = 2.0 * std::f64::consts::PI / (cols * SUB) as f64;
    for (cell, e) in expected.iter_mut().enumerate() {
        let (r, c) = (cell / cols, cell % cols);
        let mut acc = 0.0;
        for i in 0..SUB {
            let theta = ((r * SUB + i) as f64 + 0.5) * dtheta;
            let (s, z) = theta.sin_cos();
            for j in 0..SUB {
                let phi = ((c * SUB + j) as f64 + 0.5) * dphi;
                let d = Vec3::new((s * phi.cos()) as f32, (s * phi.sin()) as f32, z as f32);
                acc += pdf(d) * s;
            }
        }
        *e = acc * dtheta * dphi * n as f64;
    }
    Histogram {
        rows,
        cols,
        observed,
        expected,
    }
}

/// Histogram of 2D points over the rectangle [lo, hi]^2.
pub fn plane_histogram(
    rows: usize,
    cols: usize,
    (lo, hi): (f32, f32),
    n: usize,
    seed: u64,
    mut sample: impl FnMut(&mut Sampler) -> Option<Vec2>,
    pdf: impl Fn(Vec2) -> f64,
) -> Histogram {
    let mut sampler = Sampler::new(seed, 0x5eed);
    let mut observed = vec![0.0; rows * cols];
    let w = hi - lo;
    for _ in 0..n {
        let Some(p) = sample(&mut sampler) else {
            continue;
        };
        let fx = (p.x - lo) / w;
        let fy = (p.y - lo) / w;
        if !(0.0..=1.0).contains(&fx) || !(0.0..=1.0).contains(&fy) {
            // Outside the domain: make it count against the pdf.
            observed[0] += 1.0;
            continue;
        }
        let c = ((fx * cols as f32) as usize).min(cols - 1);
        let r = ((fy * rows as f32) as usize).min(rows - 1);
        observed[r * cols + c] += 1.0;
    }
    let mut expected = vec![0.0; rows * cols];
    let dx = w as f64 / (cols * SUB) as f64;
    let dy = w as f64 / (rows * SUB) as f64;
    for (cell, e) in expected.iter_mut().enumerate() {
        let (r, c) = (cell / cols, cell % cols);
        let mut acc = 0.0;
        for i in 0..SUB {
            let y = lo as f64 + ((r * SUB + i) as f64 + 0.5) * dy;
            for j in 0..SUB {
                let x = lo as f64 + ((c * SUB + j) as f64 + 0.5) * dx;
                acc += pdf(Vec2::new(x as f32, y as f32));
            }
        }
        *e = acc * dx * dy * n as f64;
    }
    Histogram {
        rows,
        cols,
        observed,
        expected,
    }
}
