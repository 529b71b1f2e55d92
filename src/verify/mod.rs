//! Statistical verification: runs Nori's test files (`lente test`) and
//! chi-square tests of the warps (`lente warptest`).
//!
//! The estimators are Nori's (ttest.cpp, chi2test.cpp, warptest.cpp); the
//! statistics live in [`crate::stats`]. Every sample draws from its own
//! generator derived from (seed, test, sample index), so results do not
//! depend on the thread count.

pub mod warptest;

use rayon::prelude::*;

use crate::bsdf::Bsdf;
use crate::color::luminance;
use crate::integrator::Integrator;
use crate::load::nori_testfile::{NoriTest, TestFile};
use crate::math::{Vec2, Vec3, PI};
use crate::sampling::Sampler;
use crate::scene::Scene;
use crate::stats::nori::{direction_table, table_test, DirectionTable};
use crate::stats::t_test;
use crate::stats::{sidak, MeanVar, TestResult};

/// The result of one hypothesis test of a test file.
#[derive(Clone, Debug)]
pub struct Outcome {
    /// What was tested, e.g. `scene 2/6 at 31:2 (path_mis)`.
    pub label: String,
    /// The estimate against its reference (t-tests) or the table (chi2).
    pub detail: String,
    pub result: TestResult,
    /// The Sidak-corrected significance level of this test.
    pub alpha: f64,
    pub passed: bool,
}

impl Outcome {
    fn new(label: String, detail: String, result: TestResult, alpha: f64) -> Outcome {
        Outcome {
            label,
            detail,
            result,
            alpha,
            passed: result.passes(alpha),
        }
    }
}

impl std::fmt::Display for Outcome {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let r = &self.result;
        write!(
            f,
            "{} {}: {}; p = {:.4e} {} {:.4e}",
            if self.passed { "PASS" } else { "FAIL" },
            self.label,
            self.detail,
            r.p_value,
            if self.passed { ">" } else { "<=" },
            self.alpha
        )
    }
}

/// SplitMix64: derives independent seeds from (seed, a, b).
pub fn derive_seed(seed: u64, a: u64, b: u64) -> u64 {
    let mix = |mut z: u64| {
        z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    };
    mix(mix(mix(seed) ^ a) ^ b.rotate_left(32))
}

/// Samples per parallel work item of the mean estimators.
const CHUNK: u64 = 4096;

/// The generator of sample `index` of a test: state and stream both hashed
/// from (seed, index), so that the streams of neighbouring samples are
/// unrelated (PCG32 streams that share a state are correlated).
pub fn sample_generator(seed: u64, index: u64) -> Sampler {
    Sampler::new(derive_seed(seed, index, 0), derive_seed(seed, index, 1))
}

/// Mean and variance of `f` over `n` samples, each with its own generator
/// [`sample_generator`]; deterministic whatever the thread count.
fn parallel_mean(n: u64, seed: u64, f: impl Fn(&mut Sampler) -> f64 + Sync) -> MeanVar {
    let parts: Vec<MeanVar> = (0..n.div_ceil(CHUNK))
        .into_par_iter()
        .map(|c| {
            let mut mv = MeanVar::default();
            for i in (c * CHUNK)..((c + 1) * CHUNK).min(n) {
                let mut s = sample_generator(seed, i);
                mv.push(f(&mut s));
            }
            mv
        })
        .collect();
    parts.iter().fold(MeanVar::default(), |acc, p| acc.merge(p))
}

/// Nori's ttest estimator for a scene: `n` camera rays through uniformly
/// random image positions with random aperture samples; the luminance of
/// the radiance each brings back.
pub fn scene_mean(scene: &Scene, integrator: &Integrator, n: u64, seed: u64) -> MeanVar {
    let size = Vec2::new(scene.camera.width() as f32, scene.camera.height() as f32);
    parallel_mean(n, seed, |s| {
        let film = s.next_2d() * size;
        let ray = scene.camera.generate_ray(film, s.next_2d());
        luminance(integrator.li(scene, &ray, s)) as f64
    })
}

/// Nori's incident direction for a BSDF t-test: `angle` degrees from the
/// normal, in the xz-plane.
pub fn incident_direction(angle_deg: f32) -> Vec3 {
    let t = angle_deg.to_radians();
    Vec3::new(t.sin(), 0.0, t.cos())
}

/// Nori's ttest estimator for a BSDF: the luminance of the sample weight
/// (eval * cos / pdf), zero for a failed sample, over `n` samples.
pub fn bsdf_weight_mean(bsdf: &Bsdf, wi: Vec3, n: u64, seed: u64) -> MeanVar {
    parallel_mean(n, seed, |s| {
        let u = s.next_2d();
        match bsdf.sample(Vec2::ZERO, wi, u, s.next_1d()) {
            Some(b) => luminance(b.weight) as f64,
            None => 0.0,
        }
    })
}

/// Table of a sampling routine's directions for incident direction `wi`
/// against the density `pdf(wi, wo)` claims for them (Nori's chi2test:
/// `resolution` cells in cos theta, twice as many in phi).
pub fn direction_chi2_table(
    wi: Vec3,
    sample: impl Fn(Vec3, &mut Sampler) -> Option<Vec3> + Sync,
    pdf: impl Fn(Vec3, Vec3) -> f64 + Sync,
    resolution: usize,
    sample_count: usize,
    seed: u64,
) -> DirectionTable {
    direction_table(
        resolution,
        2 * resolution,
        sample_count,
        seed,
        |s| sample(wi, s),
        |wo| pdf(wi, wo),
    )
}

/// The table of a BSDF's `sample` against its `pdf`.
pub fn bsdf_chi2_table(
    bsdf: &Bsdf,
    wi: Vec3,
    resolution: usize,
    sample_count: usize,
    seed: u64,
) -> DirectionTable {
    direction_chi2_table(
        wi,
        |wi, s| {
            let u = s.next_2d();
            bsdf.sample(Vec2::ZERO, wi, u, s.next_1d()).map(|b| b.wo)
        },
        |wi, wo| bsdf.pdf(Vec2::ZERO, wi, wo) as f64,
        resolution,
        sample_count,
        seed,
    )
}

/// Nori's random incident directions for chi2test: cos theta and phi
/// uniform over the upper hemisphere (cos theta in (0, 1]).
pub fn random_incident_direction(s: &mut Sampler) -> Vec3 {
    let cos_theta = 1.0 - s.next_1d();
    let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    let phi = 2.0 * PI * s.next_1d();
    Vec3::new(phi.cos() * sin_theta, phi.sin() * sin_theta, cos_theta)
}

fn describe_table(t: &DirectionTable, r: &TestResult) -> String {
    let mut s = format!(
        "chi2 = {:.2}, dof = {}, {} samples",
        r.statistic,
        r.dof,
        t.hist.observed.iter().sum::<f64>()
    );
    if t.declined > 0 {
        s.push_str(&format!(" ({} declined)", t.declined));
    }
    if t.invalid > 0 {
        s.push_str(&format!(", {} samples not unit directions", t.invalid));
    }
    if t.hist.expected.iter().any(|e| !e.is_finite() || *e < 0.0) {
        s.push_str(", the pdf is negative or not finite somewhere");
    }
    s
}

/// A scene of a test file that cannot be built.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{file}:{pos}: {error}")]
pub struct TestRunError {
    pub file: String,
    pub pos: crate::load::xml::Pos,
    pub error: crate::scene::BuildError,
}

/// Runs every test of a file, reporting each outcome to `report` as soon
/// as it is known. Fails only if a scene cannot be built.
pub fn run_test_file(
    file: &TestFile,
    seed: u64,
    mut report: impl FnMut(&Outcome),
) -> Result<Vec<Outcome>, TestRunError> {
    let alpha = sidak(file.significance, file.test.test_count());
    let name = file.path.display().to_string();
    let mut out = Vec::new();
    let mut push = |o: Outcome| {
        report(&o);
        out.push(o);
    };
    match &file.test {
        NoriTest::SceneTTest {
            scenes,
            references,
            sample_count,
        } => {
            for (i, (case, &reference)) in scenes.iter().zip(references).enumerate() {
                let scene = Scene::new(case.file.scene.clone()).map_err(|error| TestRunError {
                    file: name.clone(),
                    pos: case.pos,
                    error,
                })?;
                let integrator = &case.file.job.integrator;
                let mv = scene_mean(
                    &scene,
                    integrator,
                    *sample_count as u64,
                    derive_seed(seed, 1, i as u64),
                );
                let r = t_test(&mv, reference);
                push(Outcome::new(
                    format!(
                        "{name}:{} scene {}/{} ({})",
                        case.pos,
                        i + 1,
                        scenes.len(),
                        integrator.name()
                    ),
                    t_detail(&mv, reference, &r),
                    r,
                    alpha,
                ));
            }
        }
        NoriTest::BsdfTTest {
            bsdfs,
            angles,
            references,
            sample_count,
        } => {
            for (b, case) in bsdfs.iter().enumerate() {
                for (a, &angle) in angles.iter().enumerate() {
                    let k = b * angles.len() + a;
                    let reference = references[k];
                    let mv = bsdf_weight_mean(
                        &case.bsdf,
                        incident_direction(angle),
                        *sample_count as u64,
                        derive_seed(seed, 2, k as u64),
                    );
                    let r = t_test(&mv, reference);
                    push(Outcome::new(
                        format!(
                            "{name}:{} {} {}/{} at {angle} deg",
                            case.pos,
                            case.name,
                            b + 1,
                            bsdfs.len()
                        ),
                        t_detail(&mv, reference, &r),
                        r,
                        alpha,
                    ));
                }
            }
        }
        NoriTest::Chi2Test {
            bsdfs,
            resolution,
            min_exp_frequency,
            sample_count,
            test_count,
        } => {
            for (b, case) in bsdfs.iter().enumerate() {
                let mut dirs = Sampler::new(derive_seed(seed, 3, b as u64), 0);
                for t in 0..*test_count {
                    let wi = random_incident_direction(&mut dirs);
                    let table = bsdf_chi2_table(
                        &case.bsdf,
                        wi,
                        *resolution as usize,
                        *sample_count as usize,
                        derive_seed(seed, 4 + b as u64, t as u64),
                    );
                    let r = table_test(&table, *min_exp_frequency);
                    push(Outcome::new(
                        format!(
                            "{name}:{} {} {}/{} test {}/{} (wi at {:.1} deg from the normal)",
                            case.pos,
                            case.name,
                            b + 1,
                            bsdfs.len(),
                            t + 1,
                            test_count,
                            wi.z.clamp(-1.0, 1.0).acos().to_degrees()
                        ),
                        describe_table(&table, &r),
                        r,
                        alpha,
                    ));
                }
            }
        }
    }
    Ok(out)
}

fn t_detail(mv: &MeanVar, reference: f64, r: &TestResult) -> String {
    let rel = if reference != 0.0 {
        format!(
            " ({:+.3}%)",
            100.0 * (mv.mean() - reference) / reference.abs()
        )
    } else {
        String::new()
    };
    format!(
        "mean {:.6} vs reference {reference}{rel}, t = {:.3}, {} samples",
        mv.mean(),
        r.statistic,
        mv.n
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::color::Rgb;
    use crate::sampling::warp;

    fn microfacet() -> Bsdf {
        Bsdf::microfacet(0.3, 1.5046, 1.000277, Rgb::new(0.2, 0.1, 0.3)).unwrap()
    }

    /// The chi-square test accepts a BSDF's sampling against its own pdf
    /// and rejects it against a pdf that is subtly wrong.
    #[test]
    fn chi2_rejects_a_wrong_pdf() {
        let bsdf = microfacet();
        let wi = Vec3::new(0.5, 0.2, 0.8).normalize();
        let n = 10 * 20 * 5000;
        let t = bsdf_chi2_table(&bsdf, wi, 10, n, 11);
        let r = table_test(&t, 5.0);
        assert!(r.passes(0.01), "correct pdf rejected: {r:?}");

        // The pdf of a microfacet BSDF whose lobe is 10% wider than the
        // one sampled.
        let wider = Bsdf::microfacet(0.33, 1.5046, 1.000277, Rgb::new(0.2, 0.1, 0.3)).unwrap();
        let t = direction_chi2_table(
            wi,
            |wi, s| {
                let u = s.next_2d();
                bsdf.sample(Vec2::ZERO, wi, u, s.next_1d()).map(|b| b.wo)
            },
            |wi, wo| wider.pdf(Vec2::ZERO, wi, wo) as f64,
            10,
            n,
            11,
        );
        let r = table_test(&t, 5.0);
        assert!(!r.passes(0.01), "wrong pdf accepted: {r:?}");

        // A diffuse BSDF's cosine-weighted samples against a uniform pdf.
        let diffuse = Bsdf::default();
        let t = direction_chi2_table(
            wi,
            |wi, s| {
                let u = s.next_2d();
                diffuse.sample(Vec2::ZERO, wi, u, s.next_1d()).map(|b| b.wo)
            },
            |_, wo| warp::square_to_uniform_hemisphere_pdf(wo) as f64,
            10,
            n,
            12,
        );
        assert!(!table_test(&t, 5.0).passes(0.01));
    }

    #[test]
    fn bsdf_weight_of_diffuse_is_its_albedo() {
        let bsdf = Bsdf::Diffuse(crate::bsdf::Diffuse {
            albedo: Rgb::splat(0.7),
        });
        let mv = bsdf_weight_mean(&bsdf, incident_direction(40.0), 1000, 1);
        assert!(t_test(&mv, 0.7).passes(0.01));
        assert!(!t_test(&mv, 0.7 * 1.02).passes(0.01));
        // Below the horizon: every sample fails, the mean is zero.
        let mv = bsdf_weight_mean(&bsdf, incident_direction(120.0), 1000, 1);
        assert_eq!(mv.mean(), 0.0);
    }

    #[test]
    fn seeds_differ() {
        assert_ne!(derive_seed(0, 1, 0), derive_seed(0, 1, 1));
        assert_ne!(derive_seed(0, 1, 0), derive_seed(0, 2, 0));
        assert_ne!(derive_seed(0, 1, 0), derive_seed(1, 1, 0));
    }
}
