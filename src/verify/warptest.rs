//! `lente warptest`: Nori's warp tester without the window. Each warp's
//! samples are binned (51 x 51 cells over the square, or 51 cells in
//! cos theta by 102 in phi over the sphere, 1000 samples per cell) and
//! compared with the counts its pdf predicts, integrated over each cell,
//! by a chi-square test at significance 0.01.

use crate::bsdf::Bsdf;
use crate::color::{srgb_decode, Rgb};
use crate::image::Bitmap;
use crate::math::{Vec2, Vec3};
use crate::sampling::warp;
use crate::stats::nori::{direction_table, table_test};
use crate::stats::{plane_histogram, Histogram, TestResult};

/// Nori's warp tester's significance level and pooling threshold.
pub const SIGNIFICANCE: f64 = 0.01;
pub const MIN_EXP_FREQUENCY: f64 = 5.0;
/// Cells along each axis of the square, and in cos theta on the sphere.
pub const RESOLUTION: usize = 51;
/// Samples per cell.
pub const SAMPLES_PER_CELL: usize = 1000;

/// A warp Nori's users test, with its parameters.
#[derive(Clone, Debug, PartialEq)]
pub enum Warp {
    Square,
    Tent,
    Disk,
    UniformSphere,
    UniformHemisphere,
    CosineHemisphere,
    Beckmann {
        alpha: f32,
    },
    /// Nori's microfacet BSDF (intIOR 1.5046, extIOR 1.000277) sampled for
    /// the incident direction `angle` degrees from the normal in the
    /// xz-plane (Nori's command-line warptest uses 0).
    MicrofacetBrdf {
        alpha: f32,
        kd: f32,
        angle: f32,
    },
}

/// The warp names, as Nori's warptest spells them, with their parameters.
pub const WARPS: &[(&str, &str)] = &[
    ("square", ""),
    ("tent", ""),
    ("disk", ""),
    ("uniform_sphere", ""),
    ("uniform_hemisphere", ""),
    ("cosine_hemisphere", ""),
    ("beckmann", "ALPHA"),
    ("microfacet_brdf", "ALPHA [KD]"),
];

/// Warp-test arguments that name no warp (the message says why).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{0}")]
pub struct WarpArgsError(pub String);

impl Warp {
    /// The warp `name` with its parameters (numbers as text);
    /// `angle` is the incidence for `microfacet_brdf`.
    pub fn parse(name: &str, params: &[String], angle: f32) -> Result<Warp, WarpArgsError> {
        let usage = |n: &str, p: &str| {
            if p.is_empty() {
                format!("'{n}' takes no parameters")
            } else {
                format!("usage: lente warptest {n} {p}")
            }
        };
        let Some(&(known, args)) = WARPS.iter().find(|(n, _)| *n == name) else {
            let names: Vec<&str> = WARPS.iter().map(|w| w.0).collect();
            return Err(WarpArgsError(format!(
                "unknown warp '{name}'; known warps: {}",
                names.join(", ")
            )));
        };
        let mut values = Vec::new();
        for p in params {
            let v: f32 = p.trim().parse().map_err(|_| {
                WarpArgsError(format!("cannot read the parameter '{p}' as a number"))
            })?;
            if !v.is_finite() {
                return Err(WarpArgsError(format!(
                    "the parameter '{p}' must be a finite number"
                )));
            }
            values.push(v);
        }
        let max = match known {
            "beckmann" => 1,
            "microfacet_brdf" => 2,
            _ => 0,
        };
        if values.len() > max || (max > 0 && values.is_empty()) {
            return Err(WarpArgsError(usage(known, args)));
        }
        let alpha = || {
            let a = values[0];
            if a > 0.0 && a.is_finite() {
                Ok(a)
            } else {
                Err(WarpArgsError(format!(
                    "ALPHA must be positive and finite, found {a}"
                )))
            }
        };
        if !angle.is_finite() || !(-90.0..90.0).contains(&angle) {
            return Err(WarpArgsError(format!(
                "the incidence angle must be between -90 and 90 degrees (exclusive), found {angle}"
            )));
        }
        if angle != 0.0 && known != "microfacet_brdf" {
            return Err(WarpArgsError(format!(
                "--angle applies to microfacet_brdf only, not to '{known}'"
            )));
        }
        Ok(match known {
            "square" => Warp::Square,
            "tent" => Warp::Tent,
            "disk" => Warp::Disk,
            "uniform_sphere" => Warp::UniformSphere,
            "uniform_hemisphere" => Warp::UniformHemisphere,
            "cosine_hemisphere" => Warp::CosineHemisphere,
            "beckmann" => Warp::Beckmann { alpha: alpha()? },
            _ => {
                let kd = values.get(1).copied().unwrap_or(0.0);
                if !(0.0..=1.0).contains(&kd) {
                    return Err(WarpArgsError(format!(
                        "KD must be between 0 and 1, found {kd}"
                    )));
                }
                Warp::MicrofacetBrdf {
                    alpha: alpha()?,
                    kd,
                    angle,
                }
            }
        })
    }

    /// E.g. `beckmann (alpha 0.1)`.
    pub fn describe(&self) -> String {
        match self {
            Warp::Square => "square".into(),
            Warp::Tent => "tent".into(),
            Warp::Disk => "disk".into(),
            Warp::UniformSphere => "uniform_sphere".into(),
            Warp::UniformHemisphere => "uniform_hemisphere".into(),
            Warp::CosineHemisphere => "cosine_hemisphere".into(),
            Warp::Beckmann { alpha } => format!("beckmann (alpha {alpha})"),
            Warp::MicrofacetBrdf { alpha, kd, angle } => {
                format!("microfacet_brdf (alpha {alpha}, kd {kd}, wi at {angle} deg)")
            }
        }
    }

    /// True for warps onto the plane (binned in x and y).
    pub fn is_planar(&self) -> bool {
        matches!(self, Warp::Square | Warp::Tent | Warp::Disk)
    }
}

/// The tables and the verdict of one warp test.
#[derive(Clone, Debug)]
pub struct WarpOutcome {
    /// Rows are y (planar) or cos theta from -1 (spherical); columns x or phi.
    pub hist: Histogram,
    pub result: TestResult,
    pub samples: usize,
    /// Samples that fell outside the domain or were not unit directions.
    pub invalid: usize,
    pub passed: bool,
}

/// Runs the chi-square test of a warp.
pub fn run_warp_test(w: &Warp, seed: u64) -> WarpOutcome {
    let rows = RESOLUTION;
    let cols = if w.is_planar() { rows } else { 2 * rows };
    let n = rows * cols * SAMPLES_PER_CELL;
    let (hist, invalid, result) = if w.is_planar() {
        type PlaneWarp = (fn(Vec2) -> Vec2, fn(Vec2) -> f32);
        let (domain, (sample, pdf)): ((f32, f32), PlaneWarp) = match w {
            Warp::Square => (
                (0.0, 1.0),
                (
                    warp::square_to_uniform_square,
                    warp::square_to_uniform_square_pdf,
                ),
            ),
            Warp::Tent => (
                (-1.0, 1.0),
                (warp::square_to_tent, warp::square_to_tent_pdf),
            ),
            _ => (
                (-1.0, 1.0),
                (
                    warp::square_to_uniform_disk,
                    warp::square_to_uniform_disk_pdf,
                ),
            ),
        };
        let mut outside = 0;
        let hist = plane_histogram(
            rows,
            cols,
            domain,
            n,
            seed,
            |s| {
                let p = sample(s.next_2d());
                let inside = p.is_finite()
                    && (domain.0..=domain.1).contains(&p.x)
                    && (domain.0..=domain.1).contains(&p.y);
                if !inside {
                    outside += 1;
                }
                Some(p)
            },
            |p| pdf(p) as f64,
        );
        let result = if outside > 0 {
            TestResult {
                statistic: f64::INFINITY,
                dof: 0.0,
                p_value: 0.0,
            }
        } else {
            hist.test(MIN_EXP_FREQUENCY)
        };
        (hist, outside, result)
    } else {
        let table = match *w {
            Warp::MicrofacetBrdf { alpha, kd, angle } => {
                let bsdf = Bsdf::microfacet(alpha, 1.5046, 1.000277, Rgb::splat(kd))
                    .expect("Warp::parse checked alpha and kd");
                let t = angle.to_radians();
                let wi = Vec3::new(t.sin(), 0.0, t.cos().max(1e-4)).normalize();
                direction_table(
                    rows,
                    cols,
                    n,
                    seed,
                    |s| {
                        let u = s.next_2d();
                        bsdf.sample(Vec2::ZERO, wi, u, s.next_1d()).map(|b| b.wo)
                    },
                    |wo| bsdf.pdf(Vec2::ZERO, wi, wo) as f64,
                )
            }
            ref other => {
                let sample = |u: Vec2| -> Vec3 {
                    match other {
                        Warp::UniformSphere => warp::square_to_uniform_sphere(u),
                        Warp::UniformHemisphere => warp::square_to_uniform_hemisphere(u),
                        Warp::CosineHemisphere => warp::square_to_cosine_hemisphere(u),
                        Warp::Beckmann { alpha } => warp::square_to_beckmann(u, *alpha),
                        _ => unreachable!("planar warps are handled above"),
                    }
                };
                let pdf = |v: Vec3| -> f64 {
                    (match other {
                        Warp::UniformSphere => warp::square_to_uniform_sphere_pdf(v),
                        Warp::UniformHemisphere => warp::square_to_uniform_hemisphere_pdf(v),
                        Warp::CosineHemisphere => warp::square_to_cosine_hemisphere_pdf(v),
                        Warp::Beckmann { alpha } => warp::square_to_beckmann_pdf(v, *alpha),
                        _ => unreachable!("planar warps are handled above"),
                    }) as f64
                };
                direction_table(rows, cols, n, seed, |s| Some(sample(s.next_2d())), pdf)
            }
        };
        let result = table_test(&table, MIN_EXP_FREQUENCY);
        (table.hist, table.invalid, result)
    };
    WarpOutcome {
        passed: result.passes(SIGNIFICANCE),
        hist,
        result,
        samples: n,
        invalid,
    }
}

/// Paul Bourke's colour ramp (blue, cyan, green, yellow, red) as Nori's
/// warp tester draws its histograms; `v` in [0, 1]. Display (sRGB) values.
fn ramp(v: f64) -> [f64; 3] {
    let v = v.clamp(0.0, 1.0);
    let mut c = [1.0, 1.0, 1.0];
    if v < 0.25 {
        c[0] = 0.0;
        c[1] = 4.0 * v;
    } else if v < 0.5 {
        c[0] = 0.0;
        c[2] = 1.0 + 4.0 * (0.25 - v);
    } else if v < 0.75 {
        c[0] = 4.0 * (v - 0.5);
        c[2] = 0.0;
    } else {
        c[1] = 1.0 + 4.0 * (0.75 - v);
        c[2] = 0.0;
    }
    c
}

/// Observed (left) and expected (right) counts side by side as heat maps
/// on one colour scale, separated by a grey gap. The first row of the
/// tables (y = low, or cos theta = -1) is at the bottom.
pub fn heat_map(h: &Histogram) -> Bitmap {
    const PANEL: usize = 408;
    const GAP: usize = 24;
    const MARGIN: usize = 12;
    let cell = (PANEL / h.cols.max(1)).max(1);
    let (pw, ph) = (cell * h.cols, cell * h.rows);
    let width = 2 * MARGIN + 2 * pw + GAP;
    let height = 2 * MARGIN + ph;
    let mut img = Bitmap::new(width, height);
    let grey = srgb_decode(0.25);
    img.pixels.fill(Rgb::splat(grey));
    // Nori's scaling: from half the smallest count to the largest.
    let all = h.observed.iter().chain(&h.expected).copied();
    let max = all.clone().fold(0.0f64, f64::max);
    let min = all.fold(f64::INFINITY, f64::min) / 2.0;
    let scale = if max > min { 1.0 / (max - min) } else { 0.0 };
    for (panel, values) in [&h.observed, &h.expected].into_iter().enumerate() {
        let x0 = MARGIN + panel * (pw + GAP);
        for r in 0..h.rows {
            for c in 0..h.cols {
                let v = values[r * h.cols + c];
                let t = if v.is_finite() {
                    (v - min) * scale
                } else {
                    1.0
                };
                let [cr, cg, cb] = ramp(t);
                let color = Rgb::new(
                    srgb_decode(cr as f32),
                    srgb_decode(cg as f32),
                    srgb_decode(cb as f32),
                );
                let y0 = MARGIN + (h.rows - 1 - r) * cell;
                for y in y0..y0 + cell {
                    for x in x0 + c * cell..x0 + (c + 1) * cell {
                        img.set(x, y, color);
                    }
                }
            }
        }
    }
    img
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(name: &str, params: &[&str]) -> Result<Warp, WarpArgsError> {
        let p: Vec<String> = params.iter().map(|s| s.to_string()).collect();
        Warp::parse(name, &p, 0.0)
    }

    #[test]
    fn parses_names_and_parameters() {
        assert_eq!(parse("disk", &[]), Ok(Warp::Disk));
        assert_eq!(
            parse("beckmann", &["0.1"]),
            Ok(Warp::Beckmann { alpha: 0.1 })
        );
        assert_eq!(
            parse("microfacet_brdf", &["0.2", "0.3"]),
            Ok(Warp::MicrofacetBrdf {
                alpha: 0.2,
                kd: 0.3,
                angle: 0.0
            })
        );
        assert!(parse("beckmann", &[]).unwrap_err().0.contains("ALPHA"));
        assert!(parse("beckmann", &["-1"])
            .unwrap_err()
            .0
            .contains("positive"));
        assert!(parse("disk", &["1"])
            .unwrap_err()
            .0
            .contains("no parameters"));
        assert!(parse("microfacet_brdf", &["0.1", "2"])
            .unwrap_err()
            .0
            .contains("KD"));
        assert!(parse("beckman", &["0.1"])
            .unwrap_err()
            .0
            .contains("known warps"));
        assert!(parse("beckmann", &["x"]).unwrap_err().0.contains("'x'"));
        assert!(Warp::parse("disk", &[], 30.0).is_err());
    }

    #[test]
    fn heat_map_has_two_panels_with_a_gap() {
        let h = Histogram {
            rows: 2,
            cols: 4,
            observed: vec![0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0],
            expected: vec![7.0; 8],
        };
        let img = heat_map(&h);
        let cell = 408 / 4;
        assert_eq!(img.width, 2 * 12 + 2 * 4 * cell + 24);
        assert_eq!(img.height, 2 * 12 + 2 * cell);
        let grey = img.get(0, 0);
        // The gap between the panels is grey; the panels are not.
        let gap_x = 12 + 4 * cell + 12;
        assert_eq!(img.get(gap_x, img.height / 2), grey);
        assert_ne!(img.get(12 + cell / 2, img.height / 2), grey);
        assert_ne!(img.get(gap_x + 12 + cell / 2, img.height / 2), grey);
        // The largest count is red, at the top right of the observed panel
        // (row 1 is drawn on top).
        let hot = img.get(12 + 3 * cell + cell / 2, 12 + cell / 2);
        assert!(hot.x > 0.9 && hot.y < 0.01 && hot.z < 0.01, "{hot:?}");
    }
}
