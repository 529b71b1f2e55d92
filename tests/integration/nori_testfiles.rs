//! `lente test` on the project's own Nori test files (tests/scenes/*.xml):
//! all of them pass, wrong references fail, and the references are what
//! the formulas in the files' comments say.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use crate::cli_util::dump;
use lente::bsdf::Bsdf;
use lente::color::Rgb;
use lente::load::nori_testfile::{load_test, NoriTest};
use lente::stats::quadrature::{adaptive_simpson_2d, Adaptive};

fn scenes_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/scenes")
}

fn test_files() -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(scenes_dir())
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "xml"))
        .collect();
    files.sort();
    files
}

fn lente_test(files: &[PathBuf]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_lente"))
        .arg("test")
        .args(files)
        .output()
        .unwrap()
}

/// The PASS/FAIL lines of the output, one per hypothesis test.
fn test_lines(out: &Output) -> Vec<String> {
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter(|l| l.starts_with("PASS ") || l.starts_with("FAIL "))
        .map(str::to_string)
        .collect()
}

#[test]
fn all_test_files_pass() {
    let files = test_files();
    assert!(files.len() >= 10, "{files:?}");
    let out = lente_test(&files);
    assert!(out.status.success(), "{}", dump(&out));
    let lines = test_lines(&out);
    // One line per hypothesis test of every file.
    let expected: usize = files
        .iter()
        .map(|f| load_test(f).unwrap().0.test.test_count())
        .sum();
    assert_eq!(lines.len(), expected, "{}", dump(&out));
    for l in &lines {
        assert!(l.starts_with("PASS "), "{l}");
        assert!(l.contains("p = "), "{l}");
    }
    // Nothing to warn about in our own files.
    assert!(out.stderr.is_empty(), "{}", dump(&out));
}

/// A copy of a test file with every reference multiplied by `factor`,
/// written where it can still find the meshes.
fn with_scaled_references(name: &str, factor: f64) -> (tempfile::TempDir, PathBuf) {
    let text = std::fs::read_to_string(scenes_dir().join(name)).unwrap();
    let key = "name=\"references\" value=\"";
    let start = text.find(key).unwrap() + key.len();
    let end = start + text[start..].find('"').unwrap();
    let scaled: Vec<String> = text[start..end]
        .split([',', ' ', '\n', '\t'])
        .filter(|t| !t.is_empty())
        .map(|t| format!("{}", t.parse::<f64>().unwrap() * factor))
        .collect();
    let meshes = scenes_dir().join("meshes");
    let text = format!("{}{}{}", &text[..start], scaled.join(", "), &text[end..])
        .replace("\"meshes/", &format!("\"{}/", meshes.display()));
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(format!("{factor}-{name}"));
    std::fs::write(&path, text).unwrap();
    (dir, path)
}

#[test]
fn references_two_percent_off_fail() {
    for name in ["furnace.xml", "ttest-dielectric.xml"] {
        let (_dir, path) = with_scaled_references(name, 1.02);
        let out = lente_test(std::slice::from_ref(&path));
        assert!(!out.status.success(), "{}", dump(&out));
        let lines = test_lines(&out);
        assert!(!lines.is_empty(), "{}", dump(&out));
        for l in &lines {
            assert!(
                l.starts_with("FAIL "),
                "{name}: a 2% bias went unnoticed: {l}"
            );
        }
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains("tests failed"), "{err}");
        // The unscaled copy passes: the failures are the references' doing.
        let (_same_dir, same) = with_scaled_references(name, 1.0);
        let out = lente_test(&[same]);
        assert!(out.status.success(), "{}", dump(&out));
    }
}

#[test]
fn a_broken_file_is_reported_with_its_position_and_fails() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("broken.xml");
    std::fs::write(
        &path,
        "<test type=\"ttest\">\n  <string name=\"angles\" value=\"0\"/>\n  \
         <string name=\"references\" value=\"0.5,\n      zero\"/>\n  <bsdf type=\"diffuse\"/>\n</test>\n",
    )
    .unwrap();
    let good = scenes_dir().join("ttest-diffuse.xml");
    let out = lente_test(&[path.clone(), good]);
    assert!(!out.status.success(), "{}", dump(&out));
    let stderr = String::from_utf8_lossy(&out.stderr);
    let want = format!("error: {}:4:7: cannot read 'zero'", path.display());
    assert!(stderr.contains(&want), "{}", dump(&out));
    let stdout = String::from_utf8_lossy(&out.stdout);
    // The good file still ran.
    assert!(
        stdout.contains("ttest-diffuse.xml: passed 10/10"),
        "{stdout}"
    );
}

// ---------------------------------------------------------------------------
// The references, recomputed from the formulas in the files' comments.

fn references(name: &str) -> (NoriTest, Vec<f64>) {
    let (file, _) = load_test(&scenes_dir().join(name)).unwrap();
    let refs = match &file.test {
        NoriTest::SceneTTest { references, .. } | NoriTest::BsdfTTest { references, .. } => {
            references.clone()
        }
        NoriTest::Chi2Test { .. } => Vec::new(),
    };
    (file.test, refs)
}

fn assert_close(name: &str, got: f64, want: f64, rel: f64) {
    assert!(
        (got - want).abs() <= rel * want.abs().max(1e-300),
        "{name}: file says {got}, formula gives {want}"
    );
}

fn luminance(c: [f64; 3]) -> f64 {
    0.212671 * c[0] + 0.715160 * c[1] + 0.072169 * c[2]
}

/// Unpolarised Fresnel reflectance for a wave arriving at cosine `ci`
/// (positive) from index `ni` onto index `nt`; 1 beyond the critical angle.
fn fresnel(ci: f64, ni: f64, nt: f64) -> f64 {
    let st2 = (ni / nt).powi(2) * (1.0 - ci * ci).max(0.0);
    if st2 >= 1.0 {
        return 1.0;
    }
    let ct = (1.0 - st2).sqrt();
    let rs = (ni * ci - nt * ct) / (ni * ci + nt * ct);
    let rp = (nt * ci - ni * ct) / (nt * ci + ni * ct);
    0.5 * (rs * rs + rp * rp)
}

fn vertices(obj: &str) -> Vec<[f64; 3]> {
    std::fs::read_to_string(scenes_dir().join("meshes").join(obj))
        .unwrap()
        .lines()
        .filter_map(|l| l.strip_prefix("v "))
        .map(|l| {
            let v: Vec<f64> = l.split_whitespace().map(|t| t.parse().unwrap()).collect();
            [v[0], v[1], v[2]]
        })
        .collect()
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}

#[test]
fn polygon_light_references_follow_lamberts_formula() {
    use std::f64::consts::PI;
    let (_, refs) = references("polygon-lights.xml");
    let x = [0.0; 3];
    let n = [0.0, 1.0, 0.0];
    for (k, obj) in ["pentagon.obj", "triangle.obj"].iter().enumerate() {
        let v: Vec<[f64; 3]> = vertices(obj).into_iter().map(|p| sub(p, x)).collect();
        let mut sum = 0.0;
        for i in 0..v.len() {
            let (a, b) = (v[i], v[(i + 1) % v.len()]);
            let theta = (dot(a, b) / (norm(a) * norm(b))).acos();
            let g = cross(a, b);
            sum += theta * dot(g, n) / norm(g);
        }
        let e = 0.5 * sum.abs();
        let radiance = 0.5 / PI * e;
        for r in &refs[3 * k..3 * k + 3] {
            assert_close(obj, *r, radiance, 1e-8);
        }
    }
}

#[test]
fn closed_form_references() {
    use std::f64::consts::PI;
    let (_, r) = references("point-lights.xml");
    let on_axis = 0.5 / PI * 10.0 / (4.0 * PI) / 4.0;
    let d2: f64 = 1.0 + 4.0 + 0.25;
    let off_axis = 0.5 / PI * luminance([20.0, 10.0, 5.0]) / (4.0 * PI) * (2.0 / d2.sqrt()) / d2;
    for (i, want) in [on_axis, on_axis, on_axis, off_axis, off_axis, off_axis]
        .iter()
        .enumerate()
    {
        assert_close("point light", r[i], *want, 1e-8);
    }
    let (_, r) = references("constant-environment.xml");
    for v in r {
        assert_close(
            "environment",
            v,
            luminance([0.8 * 1.0, 0.5 * 2.0, 0.2 * 0.5]),
            1e-12,
        );
    }
    let (_, r) = references("thin-lens.xml");
    let t = 20f64.to_radians().tan();
    for v in &r[..7] {
        assert_close("thin lens", *v, 4.0 / (100.0 * t * t), 1e-8);
    }
    assert_close(
        "thin lens (filled)",
        r[7],
        luminance([0.5, 1.0, 2.0]),
        1e-12,
    );
    let (_, r) = references("furnace.xml");
    assert_eq!(r, [2.0, 2.0, 5.0, 5.0, 2.0, 2.0, 2.0, 5.0]);
}

#[test]
fn dielectric_references_follow_fresnel() {
    let (test, refs) = references("ttest-dielectric.xml");
    let NoriTest::BsdfTTest { bsdfs, angles, .. } = test else {
        panic!("not a BSDF t-test")
    };
    assert_eq!(bsdfs[0].bsdf, Bsdf::dielectric(1.5046, 1.000277).unwrap());
    let eta = 1.5046f64 / 1.000277;
    for (a, r) in angles.iter().zip(&refs) {
        let c = (*a as f64).to_radians().cos();
        let (ni, nt) = if c >= 0.0 { (1.0, eta) } else { (eta, 1.0) };
        let f = fresnel(c.abs(), ni, nt);
        let want = f + (1.0 - f) * (ni / nt).powi(2);
        assert_close(&format!("dielectric at {a}"), *r, want, 1e-8);
    }
}

/// Walter et al.'s rational approximation of Smith's G1 for Beckmann.
fn g1(v: [f64; 3], m: [f64; 3], alpha: f64) -> f64 {
    if dot(v, m) * v[2] <= 0.0 {
        return 0.0;
    }
    let sin = (1.0 - v[2] * v[2]).max(0.0).sqrt();
    if sin == 0.0 {
        return 1.0;
    }
    let b = v[2] / (alpha * sin);
    if b >= 1.6 {
        1.0
    } else {
        (3.535 * b + 2.181 * b * b) / (1.0 + 2.276 * b + 2.577 * b * b)
    }
}

/// Directional albedo of the specular lobe of Nori's microfacet model
/// (without ks): the integral of D F G / (4 cos_i cos_o) cos_o over the
/// hemisphere of wo, by adaptive Simpson over (theta_o, phi_o).
fn specular_albedo(theta_i: f64, alpha: f64, eta: f64) -> f64 {
    use std::f64::consts::PI;
    let wi = [theta_i.sin(), 0.0, theta_i.cos()];
    let f = |t: f64, p: f64| {
        let wo = [t.sin() * p.cos(), t.sin() * p.sin(), t.cos()];
        let h = [wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]];
        let l = norm(h);
        let h = [h[0] / l, h[1] / l, h[2] / l];
        if h[2] <= 0.0 || wo[2] <= 0.0 {
            return 0.0;
        }
        let c2 = h[2] * h[2];
        let d = (-(1.0 - c2) / c2 / (alpha * alpha)).exp() / (PI * alpha * alpha * c2 * c2);
        let fr = fresnel(dot(h, wi), 1.0, eta);
        let g = g1(wi, h, alpha) * g1(wo, h, alpha);
        d * fr * g / (4.0 * wi[2] * wo[2]) * wo[2] * t.sin()
    };
    let lim = Adaptive {
        eps: 1e-10,
        rel: 0.0,
        min_depth: 5,
        max_depth: 24,
    };
    adaptive_simpson_2d(f, (0.0, 0.0), (0.5 * PI, 2.0 * PI), lim)
}

#[test]
fn microfacet_references_are_the_integrals() {
    let (test, refs) = references("ttest-microfacet.xml");
    let NoriTest::BsdfTTest { bsdfs, angles, .. } = test else {
        panic!("not a BSDF t-test")
    };
    for (b, case) in bsdfs.iter().enumerate() {
        let Bsdf::Microfacet(lente::bsdf::Microfacet { alpha, eta, kd, ks }) = case.bsdf else {
            panic!("not a microfacet BSDF")
        };
        let kd: Rgb = kd;
        for (a, angle) in angles.iter().enumerate() {
            let s = specular_albedo((*angle as f64).to_radians(), alpha as f64, eta as f64);
            let want = luminance([kd.x as f64, kd.y as f64, kd.z as f64]) + ks as f64 * s;
            let got = refs[b * angles.len() + a];
            assert_close(
                &format!("microfacet alpha {alpha} at {angle}"),
                got,
                want,
                1e-6,
            );
        }
    }
}
