//! Tests of the environment map: lookups, chi-square tests of sampling
//! against the pdf, unbiasedness, degenerate input.

use super::*;
use crate::math::Mat4;
use crate::sampling::Sampler;
use crate::stats::{chi2_test, sidak};

/// Number of chi-square tests in this module that must pass; Sidak
/// splits the family-wise alpha = 0.01 between them.
const N_CHI2_TESTS: usize = 15;
/// Bins in cos(theta) and in phi.
const NC: usize = 40;
const NP: usize = 80;
const N_SAMPLES: usize = 1_000_000;

/// The complete density.
const C: LightPdf = LightPdf::Complete;

/// A map with lente's cell-centred rows.
fn env_map(
    image: Bitmap,
    scale: f32,
    to_world: Transform,
    filter: EnvFilter,
) -> Result<EnvMap, EnvMapError> {
    EnvMap::new(image, scale, to_world, filter, TexelRows::CellCentres)
}

/// A bilinear map of `image` at scale 1 (the usual test subject).
fn bilinear(image: Bitmap, to_world: Transform) -> EnvMap {
    env_map(image, 1.0, to_world, EnvFilter::Bilinear).unwrap()
}

fn alpha() -> f64 {
    sidak(0.01, N_CHI2_TESTS)
}

fn constant(w: usize, h: usize, c: Rgb) -> Bitmap {
    let mut b = Bitmap::new(w, h);
    b.pixels.iter_mut().for_each(|p| *p = c);
    b
}

fn one_hot(w: usize, h: usize, texels: &[(usize, usize)]) -> Bitmap {
    let mut b = Bitmap::new(w, h);
    for &(i, j) in texels {
        b.set(i, j, Rgb::new(3.0, 1.0, 0.5));
    }
    b
}

fn gradient(w: usize, h: usize) -> Bitmap {
    let mut b = Bitmap::new(w, h);
    for j in 0..h {
        for i in 0..w {
            let (u, v) = ((i as f32 + 0.5) / w as f32, (j as f32 + 0.5) / h as f32);
            b.set(
                i,
                j,
                Rgb::new(0.2 + u, 0.1 + 2.0 * v * v, 0.5 + (6.0 * u).sin().abs()),
            );
        }
    }
    b
}

/// Unit sky with a 2x1-texel sun 10^4 times brighter.
fn sun_map(w: usize, h: usize) -> Bitmap {
    let mut b = constant(w, h, Rgb::new(0.3, 0.5, 1.0));
    let sun = Rgb::new(1.0, 0.9, 0.8) * 1.0e4;
    b.set(w / 3, h / 3, sun);
    b.set(w / 3 + 1, h / 3, sun);
    b
}

fn rot_a() -> Transform {
    let axis = Vec3::new(1.0, 2.0, 3.0).normalize();
    Transform::new(Mat4::from_axis_angle(axis, 0.9)).unwrap()
}

/// A rotation combined with a mirror (Nori cameras and scenes use these).
fn rot_mirror() -> Transform {
    let m = Mat4::from_axis_angle(Vec3::new(-2.0, 0.5, 1.0).normalize(), 2.1)
        * Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0));
    Transform::new(m).unwrap()
}

fn bin_of(d: Vec3) -> usize {
    let d = d.normalize();
    let c = (((1.0 - d.y) * 0.5 * NC as f32) as usize).min(NC - 1);
    let p = ((EnvMap::dir_to_uv(d).x * NP as f32) as usize).min(NP - 1);
    c * NP + p
}

/// Histogram of `n` samples binned on a (cos theta, phi) grid of the
/// frame `frame` (world directions are taken through `frame.inv`).
fn histogram(env: &EnvMap, frame: &Transform, n: usize, seed: u64) -> Vec<f64> {
    histogram_with(env, frame, n, seed, C, None)
}

/// [`histogram`] of the density `which`, for a surface facing `facing` if
/// given.
fn histogram_with(
    env: &EnvMap,
    frame: &Transform,
    n: usize,
    seed: u64,
    which: LightPdf,
    facing: Option<Vec3>,
) -> Vec<f64> {
    let mut s = Sampler::new(seed, 7);
    let mut obs = vec![0.0; NC * NP];
    let mut failed = 0;
    for _ in 0..n {
        match env.sample(s.next_2d(), which, facing) {
            Some((d, _, _)) => obs[bin_of(frame.inv.transform_vector3(d))] += 1.0,
            None => failed += 1,
        }
    }
    assert_eq!(failed, 0, "samples failed");
    obs
}

/// Expected counts on the (cos theta, phi) grid of the map's own frame,
/// for the density `which` (for a surface facing `facing` if given: that
/// density is the map's times a constant per block of cells, so the same
/// rule holds). Each bin is a rectangle in (u, v), and inside
/// each cell of the map's grid the (u, v) density is bilinear or constant,
/// which the midpoint rule integrates exactly over any rectangle: so each
/// bin is cut at the cells' edges and each piece integrated at its middle,
/// with pdf_uv = `pdf(d)` x 2 pi^2 sin(theta) of the public world-space
/// pdf. `jacobian` = false drops the sin(theta) (a deliberately wrong pdf).
fn expected_local_with(
    env: &EnvMap,
    n: usize,
    jacobian: bool,
    which: LightPdf,
    facing: Option<Vec3>,
) -> Vec<f64> {
    let g = &env.grid;
    let w = g.width;
    let col_off = if g.filter == EnvFilter::Bilinear {
        0.5
    } else {
        0.0
    };
    let mut u_cuts: Vec<f64> = (0..=w).map(|c| (c as f64 + col_off) / w as f64).collect();
    u_cuts.retain(|&u| u > 0.0 && u < 1.0);
    let v_cuts: Vec<f64> = (1..g.bands()).map(|k| g.edge(k) as f64).collect();
    let pieces = |lo: f64, hi: f64, cuts: &[f64]| -> Vec<(f64, f64)> {
        let mut pts = vec![lo];
        pts.extend(cuts.iter().copied().filter(|&c| c > lo && c < hi));
        pts.push(hi);
        pts.windows(2).map(|p| (p[0], p[1])).collect()
    };
    let mut exp = vec![0.0; NC * NP];
    let pi = std::f64::consts::PI;
    for c in 0..NC {
        let cos_hi = 1.0 - 2.0 * c as f64 / NC as f64;
        let cos_lo = 1.0 - 2.0 * (c + 1) as f64 / NC as f64;
        let (v0, v1) = (cos_hi.acos() / pi, cos_lo.acos() / pi);
        let v_pieces = pieces(v0, v1, &v_cuts);
        for p in 0..NP {
            let (u0, u1) = (p as f64 / NP as f64, (p + 1) as f64 / NP as f64);
            let mut prob = 0.0;
            for &(l, r) in &pieces(u0, u1, &u_cuts) {
                for &(a, b) in &v_pieces {
                    let mid = Vec2::new((0.5 * (l + r)) as f32, (0.5 * (a + b)) as f32);
                    let local = EnvMap::uv_to_dir(mid);
                    let world = env.to_world.vector(local);
                    let sin = if jacobian {
                        (local.x as f64).hypot(local.z as f64)
                    } else {
                        1.0
                    };
                    prob += env.pdf(world, which, facing) as f64
                        * 2.0
                        * pi
                        * pi
                        * sin
                        * (r - l)
                        * (b - a);
                }
            }
            exp[c * NP + p] = prob;
        }
    }
    let total: f64 = exp.iter().sum();
    if !jacobian {
        exp.iter_mut().for_each(|e| *e /= total);
    } else {
        assert!((total - 1.0).abs() < 1e-3, "pdf integrates to {total}");
    }
    exp.iter().map(|&e| e * n as f64).collect()
}

fn expected_local(env: &EnvMap, n: usize, jacobian: bool) -> Vec<f64> {
    expected_local_with(env, n, jacobian, C, None)
}

/// Expected counts on the world (cos theta, phi) grid by numerically
/// integrating the public pdf on a `sub` x `sub` midpoint grid per bin
/// (d omega = d cos(theta) d phi).
fn expected_world_numeric(env: &EnvMap, n: usize, sub: usize) -> Vec<f64> {
    let mut exp = vec![0.0; NC * NP];
    let pi = std::f64::consts::PI;
    let (dc, dp) = (2.0 / (NC * sub) as f64, 2.0 * pi / (NP * sub) as f64);
    for c in 0..NC * sub {
        let cos_t = 1.0 - (c as f64 + 0.5) * dc;
        let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
        for p in 0..NP * sub {
            let phi = (p as f64 + 0.5) * dp;
            let d = Vec3::new(
                (sin_t * phi.sin()) as f32,
                cos_t as f32,
                (-sin_t * phi.cos()) as f32,
            );
            exp[(c / sub) * NP + p / sub] += env.pdf(d, C, None) as f64 * dc * dp;
        }
    }
    exp.iter().map(|&e| e * n as f64).collect()
}

fn chi2_local(env: &EnvMap, seed: u64) -> crate::stats::TestResult {
    let obs = histogram(env, &env.to_world, N_SAMPLES, seed);
    let exp = expected_local(env, N_SAMPLES, true);
    chi2_test(&obs, &exp, 5.0)
}

fn assert_passes(r: crate::stats::TestResult, what: &str) {
    eprintln!("{what}: {r:?}");
    assert!(r.passes(alpha()), "{what}: {r:?} (alpha {})", alpha());
}

#[test]
fn landmark_directions_and_round_trip() {
    let cases = [
        (Vec3::new(0.0, 0.0, -1.0), 0.0),
        (Vec3::new(1.0, 0.0, 0.0), 0.25),
        (Vec3::new(0.0, 0.0, 1.0), 0.5),
        (Vec3::new(-1.0, 0.0, 0.0), 0.75),
    ];
    for (d, u) in cases {
        let uv = EnvMap::dir_to_uv(d);
        assert!(
            (uv.x - u).abs() < 1e-6 && (uv.y - 0.5).abs() < 1e-6,
            "{d} -> {uv}"
        );
        assert!((EnvMap::uv_to_dir(Vec2::new(u, 0.5)) - d).length() < 1e-6);
    }
    assert_eq!(EnvMap::dir_to_uv(Vec3::Y).y, 0.0);
    assert_eq!(EnvMap::dir_to_uv(-Vec3::Y).y, 1.0);
    // Just left of the -z seam wraps to u near 1, never to 1 itself.
    let uv = EnvMap::dir_to_uv(Vec3::new(-1e-9, 0.0, -1.0));
    assert!((0.0..1.0).contains(&uv.x));
    let mut s = Sampler::new(1, 1);
    for _ in 0..10_000 {
        let uv = s.next_2d();
        let d = EnvMap::uv_to_dir(uv);
        assert!((d.length() - 1.0).abs() < 1e-5);
        let back = EnvMap::dir_to_uv(d);
        let du = (back.x - uv.x).abs();
        assert!(
            du.min(1.0 - du) < 1e-4 && (back.y - uv.y).abs() < 1e-4,
            "{uv} {back}"
        );
        // And direction -> uv -> direction.
        assert!((EnvMap::uv_to_dir(back) - d).length() < 1e-4);
    }
}

#[test]
fn lookup_filters_wrap_and_clamp() {
    let (w, h) = (8, 4);
    let mut b = Bitmap::new(w, h);
    for j in 0..h {
        for i in 0..w {
            b.set(i, j, Rgb::new(i as f32, j as f32, 1.0));
        }
    }
    let bil = env_map(b.clone(), 2.0, Transform::IDENTITY, EnvFilter::Bilinear).unwrap();
    let near = env_map(b, 2.0, Transform::IDENTITY, EnvFilter::Nearest).unwrap();
    let at = |u: f32, v: f32| EnvMap::uv_to_dir(Vec2::new(u, v));
    for j in 0..h {
        for i in 0..w {
            let (u, v) = ((i as f32 + 0.5) / w as f32, (j as f32 + 0.5) / h as f32);
            let want = Rgb::new(i as f32, j as f32, 1.0) * 2.0;
            assert!((bil.eval(at(u, v)) - want).length() < 1e-4);
            assert!((near.eval(at(u + 0.3 / w as f32, v - 0.3 / h as f32)) - want).length() < 1e-4);
        }
    }
    // The u = 0 seam averages the last and the first column.
    let seam = bil.eval(at(0.0, 1.5 / h as f32));
    assert!(
        (seam - Rgb::new(3.5, 1.0, 1.0) * 2.0).length() < 1e-3,
        "{seam}"
    );
    // Above the first row's centres v clamps: no blending with the bottom.
    let top = bil.eval(at(0.5 / w as f32, 0.1 / h as f32));
    assert!(
        (top - Rgb::new(0.0, 0.0, 1.0) * 2.0).length() < 1e-3,
        "{top}"
    );
}

#[test]
fn to_world_rotates_the_map() {
    let b = gradient(32, 16);
    let r = Transform::new(Mat4::from_rotation_y(0.5 * PI)).unwrap();
    let plain = bilinear(b.clone(), Transform::IDENTITY);
    let rot = bilinear(b, r);
    let mut s = Sampler::new(5, 5);
    for _ in 0..1000 {
        let d = crate::sampling::warp::square_to_uniform_sphere(s.next_2d());
        let (a, b) = (plain.eval(d), rot.eval(r.vector(d)));
        assert!((a - b).length() < 1e-4 * a.length(), "{a} {b}");
        assert!(
            (plain.pdf(d, C, None) - rot.pdf(r.vector(d), C, None)).abs()
                < 1e-4 * plain.pdf(d, C, None)
        );
    }
    // Rotating +90 degrees about y takes local -z (u = 0) to world -x.
    let want = plain.eval(-Vec3::Z);
    assert!((rot.eval(-Vec3::X) - want).length() < 1e-5);
}

#[test]
fn chi2_one_hot_bilinear() {
    let env = bilinear(one_hot(24, 12, &[(7, 3)]), Transform::IDENTITY);
    assert_passes(chi2_local(&env, 11), "one-hot bilinear");
}

#[test]
fn chi2_one_hot_nearest() {
    let env = env_map(
        one_hot(24, 12, &[(7, 3)]),
        1.0,
        Transform::IDENTITY,
        EnvFilter::Nearest,
    )
    .unwrap();
    assert_passes(chi2_local(&env, 12), "one-hot nearest");
}

#[test]
fn chi2_one_hot_at_seam_and_poles() {
    let img = one_hot(24, 12, &[(0, 0), (23, 11), (23, 4)]);
    let env = bilinear(img, Transform::IDENTITY);
    assert_passes(chi2_local(&env, 13), "one-hot at seam and poles");
}

#[test]
fn chi2_one_hot_rotated() {
    let env = bilinear(one_hot(24, 12, &[(7, 3)]), rot_a());
    assert_passes(chi2_local(&env, 14), "one-hot rotated");
}

#[test]
fn chi2_gradient() {
    let env = bilinear(gradient(96, 48), Transform::IDENTITY);
    assert_passes(chi2_local(&env, 15), "gradient");
}

#[test]
fn chi2_gradient_rotated_world_bins() {
    let env = bilinear(gradient(96, 48), rot_a());
    let n = 300_000;
    let obs = histogram(&env, &Transform::IDENTITY, n, 16);
    let exp = expected_world_numeric(&env, n, 24);
    let total: f64 = exp.iter().sum::<f64>() / n as f64;
    assert!((total - 1.0).abs() < 2e-3, "pdf integrates to {total}");
    assert_passes(chi2_test(&obs, &exp, 5.0), "gradient rotated, world bins");
}

#[test]
fn chi2_sun() {
    let env = bilinear(sun_map(128, 64), Transform::IDENTITY);
    assert_passes(chi2_local(&env, 17), "sun");
}

#[test]
fn chi2_sun_rotated_mirrored() {
    let env = bilinear(sun_map(128, 64), rot_mirror());
    assert_passes(chi2_local(&env, 18), "sun rotated");
}

#[test]
fn chi2_baked_sky() {
    let p = crate::emitter::sky::SkyParams {
        resolution: 128,
        sun_elevation_deg: 30.0,
        sun_azimuth_deg: 60.0,
        ..Default::default()
    };
    let env = bilinear(crate::emitter::sky::bake_sky(&p), rot_a());
    assert_passes(chi2_local(&env, 19), "baked sky");
}

/// The chi-square machinery must be able to fail.
#[test]
fn chi2_rejects_wrong_pdfs() {
    let env = bilinear(sun_map(128, 64), Transform::IDENTITY);
    let n = 100_000;
    let obs = histogram(&env, &env.to_world, n, 21);
    // Uniform sphere: each bin has the same solid angle.
    let uniform = vec![n as f64 / (NC * NP) as f64; NC * NP];
    let r = chi2_test(&obs, &uniform, 5.0);
    assert!(!r.passes(alpha()), "uniform pdf accepted: {r:?}");
    // The same pdf without the sin(theta) Jacobian.
    let grad = bilinear(gradient(96, 48), Transform::IDENTITY);
    let obs_g = histogram(&grad, &grad.to_world, n, 22);
    let r = chi2_test(&obs_g, &expected_local(&grad, n, false), 5.0);
    assert!(!r.passes(alpha()), "pdf without Jacobian accepted: {r:?}");
    // The sun one texel to the right.
    let mut shifted = sun_map(128, 64);
    shifted.set(128 / 3, 64 / 3, shifted.get(0, 0));
    shifted.set(128 / 3 + 2, 64 / 3, sun_map(128, 64).get(128 / 3, 64 / 3));
    let shifted = bilinear(shifted, Transform::IDENTITY);
    let r = chi2_test(&obs, &expected_local(&shifted, n, true), 5.0);
    assert!(
        !r.passes(alpha()),
        "sun shifted by one texel accepted: {r:?}"
    );
    // Samples with the mirror the pdf does not know about.
    let mirrored = bilinear(sun_map(128, 64), rot_mirror());
    let unmirrored = EnvMap {
        to_world: Transform::new(Mat4::from_axis_angle(
            Vec3::new(-2.0, 0.5, 1.0).normalize(),
            2.1,
        ))
        .unwrap(),
        ..mirrored.clone()
    };
    let obs_m = histogram(&mirrored, &Transform::IDENTITY, n, 23);
    let r = chi2_test(&obs_m, &expected_world_numeric(&unmirrored, n, 8), 5.0);
    assert!(!r.passes(alpha()), "missing mirror accepted: {r:?}");
}

/// Draws `n` samples of `which` and checks each: a unit direction, a
/// positive finite pdf, a finite non-negative weight; and that `pdf(d)` and
/// `eval(d) / pdf(d)` of the returned direction reproduce the returned pdf
/// and weight (computed at the sampled point itself) to 1e-4 relative,
/// except for at most 1 in 1,000 samples (those within rounding of a texel
/// edge where the density jumps, nearest filter, or of an edge where it
/// vanishes). Returns how many disagreed.
fn assert_sample_agrees(env: &EnvMap, which: LightPdf, n: usize, seed: u64, what: &str) -> usize {
    assert_sample_agrees_facing(env, which, None, n, seed, what)
}

/// [`assert_sample_agrees`] for a surface facing `facing` if given.
fn assert_sample_agrees_facing(
    env: &EnvMap,
    which: LightPdf,
    facing: Option<Vec3>,
    n: usize,
    seed: u64,
    what: &str,
) -> usize {
    let mut s = Sampler::new(seed, 3);
    let mut off = 0;
    for _ in 0..n {
        let Some((d, w, pdf)) = env.sample(s.next_2d(), which, facing) else {
            // A surface may face away from all of the light.
            assert!(facing.is_some(), "{what}: no sample");
            continue;
        };
        assert!(
            (d.length() - 1.0).abs() < 1e-5,
            "{what}: |d| = {}",
            d.length()
        );
        assert!(pdf > 0.0 && pdf.is_finite(), "{what}: pdf {pdf}");
        assert!(
            w.is_finite() && w.min_element() >= 0.0,
            "{what}: weight {w}"
        );
        let pdf_d = env.pdf(d, which, facing);
        let want = env.eval(d) / pdf_d;
        let close = (pdf_d - pdf).abs() <= 1e-3 * pdf && (w - want).length() <= 1e-4 * w.length();
        if !close {
            off += 1;
            if off <= 3 {
                eprintln!("{what}: pdf {pdf} vs {pdf_d}, w {w} vs {want}, d {d}");
            }
        }
    }
    assert!(
        off * 1000 <= n,
        "{what}: {off} of {n} samples disagree with pdf/eval"
    );
    off
}

#[test]
fn weight_is_eval_over_pdf() {
    let mut off = 0;
    for (img, t) in [
        (sun_map(128, 64), rot_mirror()),
        (gradient(50, 25), rot_a()),
        (one_hot(16, 8, &[(3, 0)]), Transform::IDENTITY),
    ] {
        for filter in [EnvFilter::Bilinear, EnvFilter::Nearest] {
            let env = env_map(img.clone(), 1.5, t, filter).unwrap();
            off += assert_sample_agrees(&env, C, 50_000, 3, &format!("{filter:?}"));
        }
    }
    // The check is not vacuous: rounding does move a few samples.
    eprintln!("{off} of 300000 samples within rounding of an edge");
}

/// Irradiance on a plane with normal `n`, integrated in (u, v) on a grid
/// of `sub` x `sub` points per texel (the bilinear radiance is
/// continuous, so the midpoint rule converges fast).
fn irradiance_reference(env: &EnvMap, n: Vec3, sub: usize) -> f64 {
    let (w, h) = (env.image.width * sub, env.image.height * sub);
    let pi = std::f64::consts::PI;
    let mut sum = 0.0;
    for j in 0..h {
        let v = (j as f64 + 0.5) / h as f64;
        for i in 0..w {
            let uv = Vec2::new(((i as f64 + 0.5) / w as f64) as f32, v as f32);
            let d = env.to_world.vector(EnvMap::uv_to_dir(uv));
            let c = n.dot(d).max(0.0) as f64;
            sum += luminance(env.eval(d)) as f64 * c * (pi * v).sin();
        }
    }
    sum * 2.0 * pi * pi / (w * h) as f64
}

/// Estimating an integral with `sample` is unbiased (Student t-test), and
/// the test notices a 2% error.
#[test]
fn sampled_irradiance_is_unbiased() {
    use crate::stats::{t_test, MeanVar};
    let cases = [
        (sun_map(128, 64), rot_mirror(), EnvFilter::Bilinear),
        (gradient(96, 48), rot_a(), EnvFilter::Nearest),
        (
            one_hot(24, 12, &[(7, 3), (0, 11)]),
            rot_a(),
            EnvFilter::Bilinear,
        ),
    ];
    let alpha = sidak(0.01, cases.len());
    for (k, (img, t, filter)) in cases.into_iter().enumerate() {
        let env = env_map(img, 2.0, t, filter).unwrap();
        let n = Vec3::new(0.3, 1.0, -0.2).normalize();
        let reference = irradiance_reference(&env, n, 16);
        let mut s = Sampler::new(31, k as u64);
        let mut mv = MeanVar::default();
        for _ in 0..1_500_000 {
            let e = match env.sample(s.next_2d(), C, None) {
                Some((d, w, _)) => luminance(w) as f64 * n.dot(d).max(0.0) as f64,
                None => 0.0,
            };
            mv.push(e);
        }
        let r = t_test(&mv, reference);
        assert!(
            r.passes(alpha),
            "case {k}: {} vs {reference}: {r:?}",
            mv.mean()
        );
        let r = t_test(&mv, reference * 1.02);
        assert!(!r.passes(alpha), "case {k}: 2% bias not detected: {r:?}");
    }
}

/// Midpoint rule on a fine (cos theta, phi) grid over the sphere.
fn integrate_pdf(env: &EnvMap, nc: usize, np: usize) -> f64 {
    let mut sum = 0.0;
    let pi = std::f64::consts::PI;
    for c in 0..nc {
        let cos_t = 1.0 - (c as f64 + 0.5) * 2.0 / nc as f64;
        let sin_t = (1.0 - cos_t * cos_t).sqrt();
        for p in 0..np {
            let phi = (p as f64 + 0.5) * 2.0 * pi / np as f64;
            let d = Vec3::new(
                (sin_t * phi.sin()) as f32,
                cos_t as f32,
                (-sin_t * phi.cos()) as f32,
            );
            sum += env.pdf(d, C, None) as f64;
        }
    }
    sum * (2.0 / nc as f64) * (2.0 * pi / np as f64)
}

#[test]
fn pdf_integrates_to_one() {
    let cases = [
        (gradient(96, 48), rot_a(), EnvFilter::Bilinear, 2e-3),
        (sun_map(128, 64), rot_mirror(), EnvFilter::Bilinear, 5e-3),
        // Coarse texels: the midpoint rule's error is at their edges.
        (one_hot(16, 8, &[(5, 3)]), rot_a(), EnvFilter::Nearest, 5e-3),
    ];
    for (img, t, f, tol) in cases {
        let env = env_map(img, 1.0, t, f).unwrap();
        let i = integrate_pdf(&env, 1500, 3000);
        assert!((i - 1.0).abs() < tol, "integral {i}");
    }
}

#[test]
fn samples_stay_on_the_support_and_the_support_has_pdf() {
    let (w, h, hot) = (64usize, 32usize, (20usize, 9usize));
    for filter in [EnvFilter::Bilinear, EnvFilter::Nearest] {
        let env = env_map(one_hot(w, h, &[hot]), 1.0, rot_a(), filter).unwrap();
        let reach = if filter == EnvFilter::Bilinear { 1 } else { 0 };
        let mut s = Sampler::new(9, 9);
        for _ in 0..100_000 {
            let (d, _, pdf) = env.sample(s.next_2d(), C, None).expect("sample");
            assert!(pdf > 0.0);
            let uv = EnvMap::dir_to_uv(env.to_world.inv.transform_vector3(d));
            let (i, j) = ((uv.x * w as f32) as i64, (uv.y * h as f32) as i64);
            assert!((i - hot.0 as i64).abs() <= reach && (j - hot.1 as i64).abs() <= reach);
        }
        // Everywhere the map shines, the pdf is positive.
        let mut lit = 0;
        for c in 0..800 {
            for p in 0..1600 {
                let uv = Vec2::new((p as f32 + 0.5) / 1600.0, (c as f32 + 0.5) / 800.0);
                let d = env.to_world.vector(EnvMap::uv_to_dir(uv));
                if env.eval(d).max_element() > 0.0 {
                    lit += 1;
                    assert!(env.pdf(d, C, None) > 0.0, "eval > 0 but pdf = 0 at {uv}");
                }
            }
        }
        assert!(lit > 0);
    }
}

#[test]
fn poles_and_degenerate_inputs_are_finite() {
    let maps = [
        env_map(
            one_hot(16, 8, &[(0, 0), (5, 7)]),
            1.0,
            Transform::IDENTITY,
            EnvFilter::Bilinear,
        )
        .unwrap(),
        env_map(sun_map(32, 16), 1.0, rot_a(), EnvFilter::Nearest).unwrap(),
        bilinear(constant(1, 1, Rgb::ONE), Transform::IDENTITY),
    ];
    let dirs = [
        Vec3::Y,
        -Vec3::Y,
        Vec3::new(1e-30, 1.0, 0.0),
        Vec3::new(0.0, -1.0, -1e-38),
        Vec3::new(-0.0, 1.0, -0.0),
        Vec3::new(1e30, 1e30, 0.0),
        Vec3::new(1e-40, 0.0, 0.0),
        Vec3::ZERO,
        Vec3::splat(f32::NAN),
        Vec3::new(f32::INFINITY, 0.0, 0.0),
    ];
    for env in &maps {
        for d in dirs {
            let (e, p) = (env.eval(d), env.pdf(d, C, None));
            assert!(e.is_finite() && e.min_element() >= 0.0, "eval({d}) = {e}");
            assert!(p.is_finite() && p >= 0.0, "pdf({d}) = {p}");
        }
        assert!(env.eval(Vec3::Y).max_element() > 0.0 || env.image.width == 16);
        assert!(
            env.pdf(Vec3::ZERO, C, None) == 0.0 && env.pdf(Vec3::splat(f32::NAN), C, None) == 0.0
        );
        let edge = 1.0 - f32::EPSILON;
        for u in [
            Vec2::ZERO,
            Vec2::new(edge, edge),
            Vec2::new(0.5, 0.0),
            Vec2::new(0.0, edge),
            Vec2::splat(1.0),
            Vec2::splat(f32::NAN),
            Vec2::new(-3.0, 7.0),
        ] {
            if let Some((d, w, p)) = env.sample(u, C, None) {
                assert!(d.is_finite() && w.is_finite() && p.is_finite() && p > 0.0);
            }
        }
    }
}

#[test]
fn black_maps_emit_nothing_and_bad_maps_are_refused() {
    let black = bilinear(Bitmap::new(16, 8), Transform::IDENTITY);
    assert!(black.sample(Vec2::splat(0.3), C, None).is_none());
    assert_eq!(black.pdf(Vec3::X, C, None), 0.0);
    assert_eq!(black.mean_luminance(), 0.0);
    assert!(!black.has_light());
    let empty = env_map(
        Bitmap::new(0, 0),
        1.0,
        Transform::IDENTITY,
        EnvFilter::Nearest,
    );
    assert!(matches!(empty, Err(EnvMapError::Empty { .. })));
    let off = env_map(
        sun_map(16, 8),
        0.0,
        Transform::IDENTITY,
        EnvFilter::Bilinear,
    )
    .unwrap();
    assert!(off.sample(Vec2::splat(0.3), C, None).is_none() && off.pdf(Vec3::X, C, None) == 0.0);
    let mut bad = constant(4, 2, Rgb::ONE);
    bad.set(1, 1, Rgb::new(1.0, -1.0, 1.0));
    let texel = env_map(bad.clone(), 1.0, Transform::IDENTITY, EnvFilter::Bilinear);
    assert!(
        matches!(texel, Err(EnvMapError::Texel { x: 1, y: 1, .. })),
        "{texel:?}"
    );
    bad.set(1, 1, Rgb::new(f32::NAN, 0.0, 0.0));
    let nan = env_map(bad, 1.0, Transform::IDENTITY, EnvFilter::Bilinear);
    assert!(matches!(nan, Err(EnvMapError::Texel { .. })));
    let scale = env_map(sun_map(16, 8), f32::INFINITY, rot_a(), EnvFilter::Bilinear);
    assert!(matches!(scale, Err(EnvMapError::Scale(_))));
    let sheared = Transform::new(crate::math::Mat4::from_scale(Vec3::new(1.0, 2.0, 1.0)));
    let shear = env_map(sun_map(16, 8), 1.0, sheared.unwrap(), EnvFilter::Bilinear);
    assert!(matches!(shear, Err(EnvMapError::ToWorld)));
}

#[test]
fn mean_luminance_of_a_constant_map() {
    let c = Rgb::new(0.5, 2.0, 1.0);
    let env = env_map(constant(64, 32, c), 3.0, rot_a(), EnvFilter::Bilinear).unwrap();
    let want = 3.0 * luminance(c);
    assert!((env.mean_luminance() - want).abs() < 1e-3 * want);
    // A constant map is sampled almost uniformly: weights ~ eval / (1/4pi).
    let (_, w, _) = env.sample(Vec2::new(0.3, 0.6), C, None).unwrap();
    assert!((luminance(w) / (4.0 * PI * want) - 1.0).abs() < 0.05);
}

/// A map with Mitsuba's pole-to-pole rows.
fn env_poles(image: Bitmap, to_world: Transform) -> EnvMap {
    EnvMap::new(
        image,
        1.0,
        to_world,
        EnvFilter::Bilinear,
        TexelRows::PoleToPole,
    )
    .unwrap()
}

#[test]
fn chi2_pole_to_pole_rows() {
    // A texel on the top row (on the pole itself), one on the seam, one
    // inside.
    let env = env_poles(one_hot(24, 12, &[(5, 0), (23, 6), (9, 4)]), rot_a());
    assert_passes(chi2_local(&env, 24), "one-hot, pole-to-pole rows");
    let env = env_poles(sun_map(128, 64), Transform::IDENTITY);
    assert_passes(chi2_local(&env, 25), "sun, pole-to-pole rows");
}

#[test]
fn chi2_mis_compensated() {
    let m = LightPdf::MisCompensated;
    for (k, env) in [
        bilinear(sun_map(128, 64), rot_mirror()),
        env_map(gradient(96, 48), 1.0, rot_a(), EnvFilter::Nearest).unwrap(),
    ]
    .into_iter()
    .enumerate()
    {
        let obs = histogram_with(&env, &env.to_world, N_SAMPLES, 26 + k as u64, m, None);
        let exp = expected_local_with(&env, N_SAMPLES, true, m, None);
        assert_passes(chi2_test(&obs, &exp, 5.0), "compensated density");
        // And it is not the complete density.
        let r = chi2_test(&obs, &expected_local(&env, N_SAMPLES, true), 5.0);
        assert!(!r.passes(alpha()), "compensated = complete? {r:?}");
    }
}

/// The compensated density vanishes where the map is dimmer than its mean
/// and keeps the complete density's support where it is brighter; for a
/// constant map it is the complete density.
#[test]
fn mis_compensation_leaves_the_dim_sky_to_bsdf_sampling() {
    let env = bilinear(sun_map(64, 32), Transform::IDENTITY);
    let (m, c) = (LightPdf::MisCompensated, C);
    let sky = EnvMap::uv_to_dir(Vec2::new(0.8, 0.8));
    assert!(env.pdf(sky, c, None) > 0.0);
    assert_eq!(env.pdf(sky, m, None), 0.0);
    let sun = EnvMap::uv_to_dir(Vec2::new(22.0 / 64.0, 10.5 / 32.0));
    assert!(env.pdf(sun, m, None) > env.pdf(sun, c, None));
    let flat = bilinear(constant(16, 8, Rgb::ONE), rot_a());
    for k in 0..100 {
        let d = crate::sampling::warp::square_to_uniform_sphere(Vec2::new(
            (k as f32 * 0.618_034).fract(),
            (k as f32 + 0.5) / 100.0,
        ));
        assert_eq!(flat.pdf(d, m, None), flat.pdf(d, c, None));
    }
}

#[test]
fn weight_is_eval_over_pdf_for_every_density_and_row_convention() {
    for rows in [TexelRows::CellCentres, TexelRows::PoleToPole] {
        for filter in [EnvFilter::Bilinear, EnvFilter::Nearest] {
            let env = EnvMap::new(sun_map(64, 32), 2.0, rot_mirror(), filter, rows).unwrap();
            for which in [LightPdf::Complete, LightPdf::MisCompensated] {
                let what = format!("{rows:?} {filter:?} {which:?}");
                assert_sample_agrees(&env, which, 50_000, 41, &what);
            }
        }
    }
}

/// Light sampling with the compensated density, combined with uniform
/// sphere sampling by the balance heuristic, estimates irradiance without
/// bias (the combination `path_mis` relies on); the complete density alone
/// does too. Student t-tests against the integrated reference.
#[test]
fn mis_with_the_compensated_density_is_unbiased() {
    use crate::sampling::warp::{square_to_uniform_sphere, square_to_uniform_sphere_pdf};
    use crate::stats::{t_test, MeanVar};
    let env = bilinear(sun_map(128, 64), rot_a());
    let n = Vec3::new(0.2, 0.9, 0.3).normalize();
    let reference = irradiance_reference(&env, n, 16);
    let m = LightPdf::MisCompensated;
    let mut s = Sampler::new(77, 2);
    let (mut mis, mut light_only) = (MeanVar::default(), MeanVar::default());
    for _ in 0..1_000_000 {
        let mut e = 0.0;
        if let Some((d, w, pdf)) = env.sample(s.next_2d(), m, None) {
            let pb = square_to_uniform_sphere_pdf(d);
            e += luminance(w) as f64 * n.dot(d).max(0.0) as f64 * (pdf / (pdf + pb)) as f64;
        }
        let d = square_to_uniform_sphere(s.next_2d());
        let (pb, pl) = (square_to_uniform_sphere_pdf(d), env.pdf(d, m, None));
        e += luminance(env.eval(d)) as f64 * n.dot(d).max(0.0) as f64 / (pb + pl) as f64;
        mis.push(e);
        let l = match env.sample(s.next_2d(), C, None) {
            Some((d, w, _)) => luminance(w) as f64 * n.dot(d).max(0.0) as f64,
            None => 0.0,
        };
        light_only.push(l);
    }
    let alpha = sidak(0.01, 2);
    for (name, mv) in [("mis", &mis), ("light only", &light_only)] {
        let r = t_test(mv, reference);
        assert!(
            r.passes(alpha),
            "{name}: {} vs {reference}: {r:?}",
            mv.mean()
        );
        let r = t_test(mv, reference * 1.02);
        assert!(!r.passes(alpha), "{name}: 2% bias not detected: {r:?}");
    }
}

/// Maps of one row, one column or one texel render (or are refused with
/// a reason), and sample what they look up.
#[test]
fn thin_maps() {
    let one_row = EnvMap::new(
        gradient(8, 1),
        1.0,
        Transform::IDENTITY,
        EnvFilter::Bilinear,
        TexelRows::PoleToPole,
    );
    assert!(matches!(
        one_row,
        Err(EnvMapError::TooFewRows { height: 1 })
    ));
    for (w, h) in [(8, 1), (1, 8), (1, 1), (1, 2)] {
        for rows in [TexelRows::CellCentres, TexelRows::PoleToPole] {
            if rows == TexelRows::PoleToPole && h < 2 {
                continue;
            }
            for filter in [EnvFilter::Bilinear, EnvFilter::Nearest] {
                let env = EnvMap::new(gradient(w, h), 1.0, rot_a(), filter, rows).unwrap();
                assert!(env.has_light());
                let what = format!("{w}x{h} {rows:?} {filter:?}");
                assert_sample_agrees(&env, C, 2000, 5, &what);
                let i = integrate_pdf(&env, 400, 800);
                assert!((i - 1.0).abs() < 5e-3, "{w}x{h} {rows:?} {filter:?}: {i}");
            }
        }
    }
}

/// Mitsuba's rows: texel j of H is seen at theta = pi j / (H - 1), the top
/// and bottom rows exactly at the poles.
#[test]
fn pole_to_pole_rows_are_where_mitsuba_puts_them() {
    let (w, h) = (8, 5);
    let mut b = Bitmap::new(w, h);
    for j in 0..h {
        for i in 0..w {
            b.set(i, j, Rgb::splat(j as f32 + 1.0));
        }
    }
    let env = env_poles(b, Transform::IDENTITY);
    for j in 0..h {
        let v = j as f32 / (h - 1) as f32;
        let e = env.eval(EnvMap::uv_to_dir(Vec2::new(0.3, v)));
        assert!((e.x - (j as f32 + 1.0)).abs() < 1e-4, "row {j}: {e}");
    }
    // The top row shines at the pole: the pdf is positive there.
    let top = env_poles(one_hot(8, 5, &[(2, 0)]), Transform::IDENTITY);
    let d = EnvMap::uv_to_dir(Vec2::new(0.3, 0.01));
    assert!(top.eval(d).max_element() > 0.0 && top.pdf(d, C, None) > 0.0);
}

// Light for a surface that faces one way (`facing.rs`).

/// A map with facing densities whatever their predicted gain.
fn facing_map(image: Bitmap, to_world: Transform, filter: EnvFilter, rows: TexelRows) -> EnvMap {
    EnvMap::build(image, 1.0, to_world, filter, rows, f64::INFINITY).unwrap()
}

fn facing_bilinear(image: Bitmap, to_world: Transform) -> EnvMap {
    facing_map(image, to_world, EnvFilter::Bilinear, TexelRows::CellCentres)
}

/// Facing densities are built only where they are predicted to pay: not
/// for a single small source, not for a smooth gradient.
#[test]
fn facing_densities_only_where_they_pay() {
    for img in [one_hot(64, 32, &[(20, 9)]), gradient(96, 48)] {
        let env = bilinear(img.clone(), rot_a());
        assert!(env.warp.as_ref().unwrap().facing.is_none());
        let forced = facing_bilinear(img, rot_a());
        assert!(forced.warp.as_ref().unwrap().facing.is_some());
        // Without one, a facing normal changes nothing.
        let d = Vec3::new(0.3, 0.5, 0.2).normalize();
        assert_eq!(env.pdf(d, C, Some(Vec3::Y)), env.pdf(d, C, None));
    }
}

/// Normals the facing tests use: up, down-ish, sideways, oblique.
fn facing_normals() -> [Vec3; 4] {
    [
        Vec3::Y,
        Vec3::new(-0.3, -1.0, 0.5).normalize(),
        Vec3::new(1.0, 0.0, 0.3).normalize(),
        Vec3::new(0.2, 0.4, -1.0).normalize(),
    ]
}

#[test]
fn chi2_facing() {
    let m = LightPdf::MisCompensated;
    // (The sun map with the complete density: its compensated density is
    // the sun alone, which one block holds, where the facing density is the
    // map's.)
    let cases = [
        (
            facing_bilinear(sun_map(128, 64), rot_mirror()),
            C,
            facing_normals()[2],
        ),
        (
            facing_map(
                gradient(96, 48),
                rot_a(),
                EnvFilter::Nearest,
                TexelRows::CellCentres,
            ),
            m,
            facing_normals()[1],
        ),
    ];
    for (k, (env, which, n)) in cases.into_iter().enumerate() {
        let facing = Some(n);
        let obs = histogram_with(&env, &env.to_world, N_SAMPLES, 50 + k as u64, which, facing);
        let exp = expected_local_with(&env, N_SAMPLES, true, which, facing);
        assert_passes(chi2_test(&obs, &exp, 5.0), &format!("facing {n}"));
        // And it is not the map's own density.
        let r = chi2_test(
            &obs,
            &expected_local_with(&env, N_SAMPLES, true, which, None),
            5.0,
        );
        assert!(!r.passes(alpha()), "facing density = map's? {r:?}");
    }
}

#[test]
fn weight_is_eval_over_pdf_facing() {
    for rows in [TexelRows::CellCentres, TexelRows::PoleToPole] {
        for filter in [EnvFilter::Bilinear, EnvFilter::Nearest] {
            let env = EnvMap::build(
                sun_map(64, 32),
                2.0,
                rot_mirror(),
                filter,
                rows,
                f64::INFINITY,
            )
            .unwrap();
            for which in [LightPdf::Complete, LightPdf::MisCompensated] {
                for n in facing_normals() {
                    let what = format!("{rows:?} {filter:?} {which:?} facing {n}");
                    assert_sample_agrees_facing(&env, which, Some(n), 10_000, 43, &what);
                }
            }
        }
    }
}

/// The facing density is positive wherever the integrand it serves is:
/// wherever the map shines on the side the normal points to.
#[test]
fn facing_pdf_covers_the_lit_hemisphere() {
    let env = facing_bilinear(gradient(96, 48), rot_a());
    let mut s = Sampler::new(5, 5);
    let mut checked = 0;
    for _ in 0..200_000 {
        let n = crate::sampling::warp::square_to_uniform_sphere(s.next_2d());
        let d = crate::sampling::warp::square_to_uniform_sphere(s.next_2d());
        if n.dot(d) > 0.0 && env.eval(d).max_element() > 0.0 {
            checked += 1;
            for which in [LightPdf::Complete, LightPdf::MisCompensated] {
                let (m, f) = (env.pdf(d, which, None), env.pdf(d, which, Some(n)));
                assert!(m == 0.0 || f > 0.0, "n {n}, d {d}: pdf {m}, facing {f}");
            }
        }
    }
    assert!(checked > 50_000);
}

/// Irradiance estimated with the facing density is unbiased (t-test, which
/// notices a 2% error), and on a constant map its variance is a fraction
/// of that of the map's density: what the facing density is for (about
/// 0.3 with bins' and blocks' cones of about 35 degrees together; 0 would
/// be cosine sampling).
#[test]
fn facing_irradiance_is_unbiased_and_less_noisy() {
    use crate::stats::{t_test, MeanVar};
    let cases = [
        (
            facing_bilinear(sun_map(128, 64), rot_mirror()),
            facing_normals()[3],
        ),
        (
            facing_bilinear(gradient(96, 48), rot_a()),
            facing_normals()[0],
        ),
        (
            facing_map(
                one_hot(24, 12, &[(7, 3), (0, 11)]),
                rot_a(),
                EnvFilter::Bilinear,
                TexelRows::PoleToPole,
            ),
            facing_normals()[2],
        ),
        (
            facing_bilinear(constant(128, 64, Rgb::ONE), rot_a()),
            facing_normals()[3],
        ),
    ];
    let alpha = sidak(0.01, cases.len());
    for (k, (env, n)) in cases.into_iter().enumerate() {
        // Fine enough that the reference's own error is well below the
        // facing estimate's standard error.
        let sub = (2048 / env.image.width).clamp(16, 64);
        let reference = irradiance_reference(&env, n, sub);
        let mut s = Sampler::new(33, k as u64);
        let (mut facing, mut plain) = (MeanVar::default(), MeanVar::default());
        for _ in 0..1_000_000 {
            let u = s.next_2d();
            for (mv, f) in [(&mut facing, Some(n)), (&mut plain, None)] {
                mv.push(match env.sample(u, C, f) {
                    Some((d, w, _)) => luminance(w) as f64 * n.dot(d).max(0.0) as f64,
                    None => 0.0,
                });
            }
        }
        let r = t_test(&facing, reference);
        assert!(
            r.passes(alpha),
            "case {k}: {} vs {reference}: {r:?}",
            facing.mean()
        );
        let r = t_test(&facing, reference * 1.02);
        assert!(!r.passes(alpha), "case {k}: 2% bias not detected: {r:?}");
        if k == 3 {
            let ratio = facing.variance() / plain.variance();
            assert!(ratio < 0.4, "constant map: variance ratio {ratio}");
        }
    }
}

/// A surface that faces away from all of the light gets no light sample
/// (and a zero pdf), not a sample it would weigh by zero.
#[test]
fn facing_away_from_all_light_samples_nothing() {
    // Light only in the bottom row, seen from a surface facing up (tall
    // enough that the blocks of the bottom rows are well below the
    // horizon).
    let env = facing_bilinear(
        one_hot(64, 256, &[(3, 255), (20, 255)]),
        Transform::IDENTITY,
    );
    let up = Some(Vec3::Y);
    let mut s = Sampler::new(6, 6);
    for _ in 0..1000 {
        assert!(env.sample(s.next_2d(), C, up).is_none());
    }
    let lit = EnvMap::uv_to_dir(Vec2::new(3.5 / 64.0, 255.5 / 256.0));
    assert!(env.eval(lit).max_element() > 0.0);
    assert_eq!(env.pdf(lit, C, up), 0.0);
    assert!(env.pdf(lit, C, Some(-Vec3::Y)) > 0.0);
    // Degenerate normals fall back to the map's own density.
    for bad in [Vec3::ZERO, Vec3::splat(f32::NAN)] {
        assert!(env.sample(Vec2::splat(0.3), C, Some(bad)).is_some());
        assert_eq!(env.pdf(-Vec3::Y, C, Some(bad)), env.pdf(-Vec3::Y, C, None));
    }
}

/// The GPU backend's tables describe the CPU's densities, MIS-compensated
/// (for `path`) and complete (for `path_ems`):
/// a band's and a cell's probabilities from the CDFs, over the cell's
/// (u, v) area, times the density's shape inside it (`emitter.wgsl`'s
/// `env_cell_pdf`), give `pdf` at every direction, for the bilinear and
/// the nearest filter, rotated, with a sun and with a gradient, with
/// lente's and Mitsuba's texel rows.
#[test]
fn gpu_tables_give_the_cpus_density() {
    use crate::sampling::warp::square_to_uniform_sphere;
    let maps = [
        bilinear(sun_map(64, 32), rot_a()),
        env_map(gradient(40, 20), 1.0, rot_mirror(), EnvFilter::Nearest).unwrap(),
        bilinear(
            one_hot(16, 8, &[(3, 2), (4, 2), (10, 6)]),
            Transform::IDENTITY,
        ),
        // The bilinear filter's first and last bands are half as high.
        bilinear(gradient(24, 12), rot_a()),
        env_poles(gradient(24, 12), rot_mirror()),
    ];
    for (k, map) in maps.iter().enumerate() {
        for which in [LightPdf::MisCompensated, LightPdf::Complete] {
            let t = map.gpu_tables(which).expect("the map emits");
            let w = t.width as usize;
            let before = |cdf: &[f32], i: usize| if i > 0 { cdf[i - 1] } else { 0.0 };
            let mut s = Sampler::new(11, k as u64);
            let mut positive = 0;
            // Uniform directions, and directions the density draws (a
            // compensated sun map is zero but near the sun).
            for i in 0..40_000 {
                let d = if i % 2 == 0 {
                    square_to_uniform_sphere(s.next_2d())
                } else {
                    match map.sample(s.next_2d(), which, None) {
                        Some((d, _, _)) => d,
                        None => continue,
                    }
                };
                let cpu = map.pdf(d, which, None);
                let at = map.locate(d).unwrap();
                let (p, sin_theta) = (at.p, at.sin_theta);
                let (b, c) = (p.band, p.col);
                let band_p = t.band_cdf[b] - before(&t.band_cdf, b);
                let row = &t.col_cdf[b * w..(b + 1) * w];
                let col_p = row[c] - before(row, c);
                let shape = if t.bilinear {
                    let c1 = (c + 1) % w;
                    let v = &t.density;
                    let (v00, v10) = (v[b * w + c], v[b * w + c1]);
                    let (v01, v11) = (v[(b + 1) * w + c], v[(b + 1) * w + c1]);
                    let sum = v00 + v10 + v01 + v11;
                    let top = v00 + (v10 - v00) * p.fx;
                    let bottom = v01 + (v11 - v01) * p.fx;
                    if sum > 0.0 {
                        4.0 * (top + (bottom - top) * p.fy) / sum
                    } else {
                        0.0
                    }
                } else {
                    1.0
                };
                let dv = t.edges[b + 1] - t.edges[b];
                let gpu = band_p * col_p * w as f32 / dv * shape
                    / (2.0 * std::f32::consts::PI.powi(2) * sin_theta);
                if cpu > 0.0 {
                    positive += 1;
                }
                assert!(
                    (gpu - cpu).abs() <= 2e-3 * cpu.max(1e-6),
                    "map {k}, {which:?}, {d}: GPU tables {gpu}, CPU {cpu}"
                );
            }
            assert!(
                positive > 10_000,
                "map {k}: {positive} directions with density"
            );
        }
    }
}

/// `locate_lanes` finds the points `locate` finds, bit for bit: random
/// directions, the axes and poles (signed zeros), directions a rounding
/// away from the seam at u = 0, and bad input (zero, NaN, infinite), for
/// both filters, both row conventions and a turned, mirrored map.
#[test]
fn locating_four_at_once_is_locating_one_at_a_time() {
    let mut dirs = vec![
        Vec3::X,
        -Vec3::X,
        Vec3::Y,
        -Vec3::Y,
        Vec3::Z,
        -Vec3::Z,
        Vec3::new(-0.0, 1.0, -0.0),
        Vec3::new(-1e-9, 0.0, -1.0),
        Vec3::new(1e-9, 0.0, -1.0),
        Vec3::new(-1e-30, 0.3, -1.0),
        // u = -0.0 (the seam, from a negative zero).
        Vec3::new(-0.0, 0.5, -1.0),
        Vec3::new(-0.0, -0.5, -1.0),
        Vec3::ZERO,
        Vec3::new(f32::NAN, 0.0, 1.0),
        Vec3::new(0.0, f32::INFINITY, 1.0),
        Vec3::new(3e-25, 1e-24, -2e-25),
        Vec3::new(1e25, -3e24, 2e25),
    ];
    let mut s = Sampler::new(11, 5);
    for _ in 0..40_000 {
        let u = s.next_2d();
        dirs.push(crate::sampling::warp::square_to_uniform_sphere(u));
    }
    for rows in [TexelRows::CellCentres, TexelRows::PoleToPole] {
        for filter in [EnvFilter::Bilinear, EnvFilter::Nearest] {
            for to_world in [Transform::IDENTITY, rot_mirror()] {
                let env = EnvMap::new(gradient(37, 19), 1.0, to_world, filter, rows).unwrap();
                for four in dirs.chunks(4) {
                    let d: [Vec3; 4] = std::array::from_fn(|k| four[k % four.len()]);
                    let lanes = env.locate_lanes(d.each_ref());
                    for k in 0..4 {
                        let one = env.locate(d[k]);
                        let key = |p: Option<EnvPoint>| {
                            p.map(|p| {
                                (
                                    p.p.col,
                                    p.p.band,
                                    p.p.fx.to_bits(),
                                    p.p.fy.to_bits(),
                                    p.sin_theta.to_bits(),
                                )
                            })
                        };
                        assert_eq!(key(lanes[k]), key(one), "{:?} ({rows:?}, {filter:?})", d[k]);
                    }
                }
            }
        }
    }
}

/// `sample_lanes` returns what `sample` returns, bit for bit: both
/// densities (the compensated one has edges where it vanishes, which send
/// lanes to the scalar retry), both filters and row conventions, turned
/// and mirrored maps, with and without facing densities and normals, and
/// u at its ends.
#[test]
fn sampling_four_at_once_is_sampling_one_at_a_time() {
    let mut us = vec![
        Vec2::ZERO,
        Vec2::new(0.999_999_94, 0.999_999_94),
        Vec2::new(0.0, 0.999_999_94),
        Vec2::new(0.5, 0.0),
    ];
    let mut s = Sampler::new(5, 9);
    for _ in 0..20_000 {
        us.push(s.next_2d());
    }
    let normals = [None, Some(Vec3::Y), Some(Vec3::new(0.3, -0.2, 0.9))];
    let key = |x: Option<(Vec3, Rgb, f32)>| {
        x.map(|(d, w, p)| {
            (
                d.to_array().map(f32::to_bits),
                w.to_array().map(f32::to_bits),
                p.to_bits(),
            )
        })
    };
    let (mut compared, mut retried) = (0, 0);
    for rows in [TexelRows::CellCentres, TexelRows::PoleToPole] {
        for filter in [EnvFilter::Bilinear, EnvFilter::Nearest] {
            for (image, to_world, worth_it) in [
                (sun_map(64, 32), Transform::IDENTITY, facing::WORTH_IT),
                (gradient(37, 19), rot_mirror(), f64::INFINITY),
                (sun_map(40, 21), rot_a(), f64::INFINITY),
            ] {
                let env = EnvMap::build(image, 2.5, to_world, filter, rows, worth_it).unwrap();
                for which in [LightPdf::Complete, LightPdf::MisCompensated] {
                    for (c, four) in us.chunks(4).enumerate() {
                        let u: [Vec2; 4] = std::array::from_fn(|k| four[k % four.len()]);
                        let facing: [Option<Vec3>; 4] =
                            std::array::from_fn(|k| normals[(c + k) % 7 / 3 % 3]);
                        let lanes = env.sample_lanes(&u, which, &facing);
                        for k in 0..4 {
                            let one = env.sample(u[k], which, facing[k]);
                            assert_eq!(
                                key(lanes[k]),
                                key(one),
                                "u {:?} ({rows:?}, {filter:?}, {which:?})",
                                u[k]
                            );
                            compared += one.is_some() as usize;
                            retried += one.is_none() as usize;
                        }
                    }
                }
            }
        }
    }
    assert!(compared > 400_000, "{compared} samples compared");
    eprintln!("{compared} samples compared, {retried} without a sample");
}

/// `eval_pdf_at_lanes` returns what `eval_pdf_at` returns, bit for bit, at
/// points located from random directions, the poles and the seam, for
/// both densities, filters and row conventions, turned maps, with and
/// without facing densities and normals.
#[test]
fn looking_up_four_at_once_is_looking_up_one_at_a_time() {
    let mut dirs = vec![Vec3::Y, -Vec3::Y, -Vec3::Z, Vec3::new(-0.0, 0.5, -1.0)];
    let mut s = Sampler::new(17, 2);
    for _ in 0..20_000 {
        dirs.push(crate::sampling::warp::square_to_uniform_sphere(s.next_2d()));
    }
    let normals = [None, Some(Vec3::Y), Some(Vec3::new(0.3, -0.2, 0.9))];
    let mut compared = 0;
    for rows in [TexelRows::CellCentres, TexelRows::PoleToPole] {
        for filter in [EnvFilter::Bilinear, EnvFilter::Nearest] {
            for (image, to_world, worth_it) in [
                (sun_map(64, 32), Transform::IDENTITY, facing::WORTH_IT),
                (gradient(37, 19), rot_mirror(), f64::INFINITY),
            ] {
                let env = EnvMap::build(image, 1.5, to_world, filter, rows, worth_it).unwrap();
                for which in [LightPdf::Complete, LightPdf::MisCompensated] {
                    for (c, four) in dirs.chunks(4).enumerate() {
                        let at: [EnvPoint; 4] =
                            std::array::from_fn(|k| env.locate(four[k % four.len()]).unwrap());
                        let facing: [Option<Vec3>; 4] =
                            std::array::from_fn(|k| normals[(c + k) % 7 / 3 % 3]);
                        let lanes = env.eval_pdf_at_lanes(&at, which, &facing);
                        for k in 0..4 {
                            let (le, pdf) = env.eval_pdf_at(at[k], which, facing[k]);
                            assert_eq!(
                                (le.to_array().map(f32::to_bits), pdf.to_bits()),
                                (
                                    lanes[k].0.to_array().map(f32::to_bits),
                                    lanes[k].1.to_bits()
                                ),
                                "{:?} ({rows:?}, {filter:?}, {which:?})",
                                four[k % four.len()]
                            );
                            compared += 1;
                        }
                    }
                }
            }
        }
    }
    assert!(compared > 300_000, "{compared} points compared");
}
