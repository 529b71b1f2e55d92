//! Mitsuba's stratified samplers: the same image in expectation as the
//! independent sampler, with less error at equal sample counts.

use std::path::Path;
use std::sync::atomic::AtomicBool;

use lente::color::luminance;
use lente::image::Bitmap;
use lente::load::load_scene_with;
use lente::render::{render, RenderJob, RenderOptions};
use lente::sampling::SamplerKind;
use lente::scene::Scene;
use lente::stats::{sidak, welch_t_test, MeanVar};

/// `tests/gpu/stratified.xml` (a thin lens, a sphere on a floor under a
/// rectangular light: silhouettes, soft shadows and defocus) with this
/// Mitsuba sampler, and its job.
pub fn stratified_scene(sampler: &str) -> (Scene, RenderJob) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/gpu/stratified.xml");
    let defines = [("sampler".to_string(), sampler.to_string())];
    let (file, _) = load_scene_with(&path, &defines).unwrap_or_else(|e| panic!("{e}"));
    (Scene::new(file.scene).unwrap(), file.job)
}

/// Per-pixel variance over renders, summed over the image.
pub fn summed_variance(imgs: &[Vec<f64>]) -> f64 {
    (0..imgs[0].len())
        .map(|i| {
            let mut mv = MeanVar::default();
            imgs.iter().for_each(|img| mv.push(img[i]));
            mv.variance()
        })
        .sum()
}

/// An image's pixel luminances, row by row.
pub fn luminances(img: &Bitmap) -> Vec<f64> {
    let mut v = Vec::new();
    for y in 0..img.height {
        for x in 0..img.width {
            v.push(luminance(img.get(x, y)) as f64);
        }
    }
    v
}

/// Per seed, the image's pixel luminances.
fn renders(sampler: &str, seeds: u64) -> Vec<Vec<f64>> {
    let (scene, job) = stratified_scene(sampler);
    (0..seeds)
        .map(|seed| {
            let out = render(
                &scene,
                &job,
                &RenderOptions::new(seed),
                &AtomicBool::new(false),
            );
            luminances(&out.image)
        })
        .collect()
}

/// `ldsampler` and `independent` agree block by block (Welch's t-test
/// over 12 seeds of 16 spp, 48 blocks of 4 x 4 pixels, Sidak-corrected),
/// and the stratified renders' per-pixel variance over seeds is well below
/// the independent ones'.
#[test]
fn stratified_sampling_is_unbiased_and_less_noisy() {
    let (_, job) = stratified_scene("ldsampler");
    assert_eq!(job.sampler, SamplerKind::Stratified);
    assert_eq!(job.spp, 16);
    let seeds = 12;
    let strat = renders("ldsampler", seeds);
    let indep = renders("independent", seeds);
    let block = |imgs: &[Vec<f64>], b: usize| {
        let (bx, by) = (b % 8, b / 8);
        let mut mv = MeanVar::default();
        for img in imgs {
            let mut sum = 0.0;
            for y in by * 4..by * 4 + 4 {
                for x in bx * 4..bx * 4 + 4 {
                    sum += img[y * 32 + x];
                }
            }
            mv.push(sum / 16.0);
        }
        mv
    };
    let alpha = sidak(0.01, 48);
    for b in 0..48 {
        let r = welch_t_test(&block(&strat, b), &block(&indep, b));
        assert!(r.passes(alpha), "block {b}: p = {}", r.p_value);
    }
    let ratio = summed_variance(&strat) / summed_variance(&indep);
    assert!(
        ratio < 0.7,
        "variance ratio stratified / independent {ratio}"
    );
}
