//! Mitsuba's stratified samplers: the same image in expectation as the
//! independent sampler, with less error at equal sample counts.

use std::sync::atomic::AtomicBool;

use lente::render::{render, RenderOptions};
use lente::sampling::SamplerKind;
use lente::scene::Scene;
use lente::stats::{sidak, welch_t_test, MeanVar};

use crate::common::load;

/// A diffuse sphere on a floor under a rectangular light and a dim sky,
/// seen through a thin lens focused on the sphere: silhouettes, soft
/// shadows and defocus, all of which stratification smooths.
fn scene(sampler: &str) -> String {
    format!(
        r#"<scene version="3.0.0">
    <integrator type="path"><integer name="max_depth" value="3"/></integrator>
    <sensor type="thinlens">
        <float name="fov" value="35"/>
        <float name="aperture_radius" value="0.08"/>
        <float name="focus_distance" value="4.2"/>
        <transform name="to_world"><lookat origin="0, 1.5, 4" target="0, 0.5, 0" up="0, 1, 0"/></transform>
        <sampler type="{sampler}"><integer name="sample_count" value="16"/></sampler>
        <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="24"/>
            <rfilter type="box"/></film>
    </sensor>
    <emitter type="constant"><rgb name="radiance" value="0.2"/></emitter>
    <shape type="rectangle">
        <transform name="to_world"><scale value="0.4"/><rotate x="1" angle="90"/><translate x="0.6" y="2.5"/></transform>
        <emitter type="area"><rgb name="radiance" value="12"/></emitter>
    </shape>
    <shape type="sphere">
        <point name="center" x="0" y="0.6" z="0"/><float name="radius" value="0.6"/>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.7, 0.5, 0.3"/></bsdf>
    </shape>
    <shape type="rectangle">
        <transform name="to_world"><scale value="5"/><rotate x="1" angle="-90"/></transform>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf>
    </shape>
</scene>"#
    )
}

/// Per seed, the image's pixel luminances.
fn renders(sampler: &str, seeds: u64) -> Vec<Vec<f64>> {
    let (file, _) = load(&scene(sampler));
    let job = file.job;
    let scene = Scene::new(file.scene).unwrap();
    (0..seeds)
        .map(|seed| {
            let out = render(
                &scene,
                &job,
                &RenderOptions::new(seed),
                &AtomicBool::new(false),
            );
            let img = &out.image;
            let mut v = Vec::new();
            for y in 0..24 {
                for x in 0..32 {
                    let c = img.get(x, y);
                    v.push((0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z) as f64);
                }
            }
            v
        })
        .collect()
}

/// `ldsampler` and `independent` agree block by block (Welch's t-test
/// over 12 seeds of 16 spp, 48 blocks of 4 x 4 pixels, Sidak-corrected),
/// and the stratified renders' per-pixel variance over seeds is well below
/// the independent ones'.
#[test]
fn stratified_sampling_is_unbiased_and_less_noisy() {
    let (file, _) = load(&scene("ldsampler"));
    assert_eq!(file.job.sampler, SamplerKind::Stratified);
    assert_eq!(file.job.spp, 16);
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
    let variance = |imgs: &[Vec<f64>]| -> f64 {
        (0..imgs[0].len())
            .map(|i| {
                let mut mv = MeanVar::default();
                imgs.iter().for_each(|img| mv.push(img[i]));
                mv.variance()
            })
            .sum()
    };
    let ratio = variance(&strat) / variance(&indep);
    assert!(
        ratio < 0.7,
        "variance ratio stratified / independent {ratio}"
    );
}
