//! `lente compare` and `lente convert` from the outside: results match the
//! library's, and bad input fails with one line and a non-zero exit code.

use std::path::Path;

use crate::cli_util::*;
use lente::color::Rgb;
use lente::image::{compare, load_image, save_image, tonemap, Bitmap, Tonemap};

/// A small image with values well above 1 and near 0.
fn pattern(w: usize, h: usize, gain: f32) -> Bitmap {
    let mut b = Bitmap::new(w, h);
    for y in 0..h {
        for x in 0..w {
            let t = (x + 2 * y) as f32;
            b.set(
                x,
                y,
                gain * Rgb::new(0.01 + 0.3 * x as f32, 0.02 * t * t, 4.0 / (1.0 + t)),
            );
        }
    }
    b
}

fn save(dir: &tempfile::TempDir, name: &str, image: &Bitmap) -> String {
    let p = dir.path().join(name);
    save_image(&p, image).unwrap();
    p.to_str().unwrap().to_string()
}

fn load(p: &str) -> Bitmap {
    load_image(Path::new(p)).unwrap().0
}

/// The value printed on the stdout line starting with `label`.
fn metric(stdout: &str, label: &str) -> f64 {
    let line = stdout
        .lines()
        .find(|l| l.starts_with(label))
        .unwrap_or_else(|| panic!("no {label} in {stdout}"));
    line[label.len()..]
        .split_whitespace()
        .next()
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("bad line {line}"))
}

/// Runs and expects failure with a one-line message containing `needles`.
fn fails(args: &[&str], needles: &[&str]) {
    let out = run(args);
    assert!(!out.status.success(), "{args:?} succeeded");
    let err = text(&out.stderr);
    assert_eq!(err.trim().lines().count(), 1, "{args:?}: {err}");
    assert!(err.starts_with("error: "), "{err}");
    for n in needles {
        assert!(err.contains(n), "{args:?}: {err} lacks {n}");
    }
}

#[test]
fn compare_prints_the_library_metrics() {
    let dir = tempfile::tempdir().unwrap();
    let reference = pattern(7, 5, 1.0);
    let mut noisy = reference.clone();
    noisy.set(3, 2, Rgb::new(5.0, 5.0, 1.0));
    noisy.set(0, 4, Rgb::splat(0.5));
    let a = save(&dir, "a.pfm", &noisy);
    let b = save(&dir, "b.exr", &reference);
    let diff = dir.path().join("diff.png");
    let out = run(&["compare", &a, &b, "--diff", diff.to_str().unwrap()]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let stdout = text(&out.stdout);
    let want = compare(&noisy, &reference).unwrap();
    let close = |x: f64, y: f64| (x - y).abs() <= 1e-5 * y.abs();
    assert!(close(metric(&stdout, "MSE"), want.mse), "{stdout}");
    assert!(
        close(metric(&stdout, "relative MSE"), want.relative_mse),
        "{stdout}"
    );
    assert!(
        (metric(&stdout, "PSNR") - want.psnr).abs() < 0.006,
        "{stdout}"
    );
    let d = load(diff.to_str().unwrap());
    assert_eq!((d.width, d.height), (7, 5));
    // The largest error is red, no error is blue.
    assert!(d.get(3, 2).x > 0.9 && d.get(3, 2).z < 0.1);
    assert!(d.get(1, 1).z > 0.9 && d.get(1, 1).x < 0.1);

    // Identical images.
    let out = run(&["compare", &b, &b]);
    assert!(out.status.success());
    let stdout = text(&out.stdout);
    assert_eq!(metric(&stdout, "MSE"), 0.0);
    assert!(stdout.contains("PSNR          inf"), "{stdout}");
}

#[test]
fn compare_errors() {
    let dir = tempfile::tempdir().unwrap();
    let a = save(&dir, "a.exr", &pattern(4, 3, 1.0));
    let b = save(&dir, "b.hdr", &pattern(3, 4, 1.0));
    fails(&["compare", &a, &b], &["4x3", "3x4", "a.exr", "b.hdr"]);
    let missing = dir.path().join("missing.exr");
    fails(
        &["compare", &a, missing.to_str().unwrap()],
        &["missing.exr", "cannot read"],
    );
    let jpg = dir.path().join("photo.jpg");
    std::fs::write(&jpg, b"not really").unwrap();
    fails(
        &["compare", jpg.to_str().unwrap(), &a],
        &["photo.jpg", ".jpg"],
    );
    let bad_diff = dir.path().join("diff.tiff");
    fails(
        &["compare", &a, &a, "--diff", bad_diff.to_str().unwrap()],
        &["diff.tiff", "unsupported"],
    );
    assert!(!bad_diff.exists());
    let garbage = dir.path().join("garbage.exr");
    std::fs::write(&garbage, b"\x76\x2f\x31\x01garbage").unwrap();
    fails(
        &["compare", garbage.to_str().unwrap(), &a],
        &["garbage.exr"],
    );
}

#[test]
fn convert_between_formats() {
    let dir = tempfile::tempdir().unwrap();
    let img = pattern(9, 4, 1.0);
    let exr = save(&dir, "in.exr", &img);

    // Float to float without options is lossless (PFM and EXR are f32).
    let pfm = dir.path().join("out.pfm");
    let out = run(&["convert", &exr, pfm.to_str().unwrap()]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(text(&out.stdout).contains("9x4"));
    assert!(load(pfm.to_str().unwrap()).pixels == img.pixels);
    let back = dir.path().join("back.EXR");
    assert!(
        run(&["convert", pfm.to_str().unwrap(), back.to_str().unwrap()])
            .status
            .success()
    );
    assert!(load(back.to_str().unwrap()).pixels == img.pixels);

    // Exposure scales float outputs exactly, without clamping.
    let half = dir.path().join("half.exr");
    let out = run(&["convert", &exr, half.to_str().unwrap(), "--exposure", "-1"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    let h = load(half.to_str().unwrap());
    for (p, q) in h.pixels.iter().zip(&img.pixels) {
        assert_eq!(*p, *q * 0.5);
    }
    assert!(h.pixels.iter().any(|p| p.max_element() > 1.0));

    // RGBE keeps about 1% precision.
    let hdr = dir.path().join("out.hdr");
    assert!(run(&["convert", &exr, hdr.to_str().unwrap()])
        .status
        .success());
    for (p, q) in load(hdr.to_str().unwrap()).pixels.iter().zip(&img.pixels) {
        assert!((*p - *q).abs().max_element() <= 0.01 * q.max_element() + 1e-6);
    }

    // PNG: exposure and tone mapping, then 8-bit sRGB.
    for (op, name) in [
        (Tonemap::Clamp, "clamp"),
        (Tonemap::Reinhard, "reinhard"),
        (Tonemap::Aces, "aces"),
    ] {
        let png = dir.path().join(format!("{name}.png"));
        let out = run(&[
            "convert",
            &exr,
            png.to_str().unwrap(),
            "--exposure",
            "0.5",
            "--tonemap",
            name,
        ]);
        assert!(out.status.success(), "{}", text(&out.stderr));
        let want = tonemap(&img, 0.5, op);
        let got = load(png.to_str().unwrap());
        for (p, q) in got.pixels.iter().zip(&want.pixels) {
            // Within one 8-bit sRGB step.
            assert!((*p - *q).abs().max_element() < 0.01, "{name}: {p} vs {q}");
        }
    }
    // Tone mapping a float output only when asked.
    let aces = dir.path().join("aces.pfm");
    let out = run(&["convert", &exr, aces.to_str().unwrap(), "--tonemap", "ACES"]);
    assert!(out.status.success(), "{}", text(&out.stderr));
    assert!(load(aces.to_str().unwrap()).pixels == tonemap(&img, 0.0, Tonemap::Aces).pixels);

    // PNG in, float out.
    let png = dir.path().join("clamp.png");
    let from_png = dir.path().join("from_png.exr");
    assert!(
        run(&["convert", png.to_str().unwrap(), from_png.to_str().unwrap()])
            .status
            .success()
    );
    assert!(load(from_png.to_str().unwrap()).pixels == load(png.to_str().unwrap()).pixels);
}

#[test]
fn convert_errors() {
    let dir = tempfile::tempdir().unwrap();
    let exr = save(&dir, "in.exr", &pattern(3, 3, 1.0));
    let missing = dir.path().join("nope.pfm");
    let out = dir.path().join("out.exr");
    fails(
        &["convert", missing.to_str().unwrap(), out.to_str().unwrap()],
        &["nope.pfm"],
    );
    let jpg = dir.path().join("out.jpg");
    fails(
        &["convert", &exr, jpg.to_str().unwrap()],
        &["out.jpg", "unsupported", ".png"],
    );
    let noext = dir.path().join("out");
    fails(&["convert", &exr, noext.to_str().unwrap()], &["extension"]);
    fails(
        &["convert", &exr, out.to_str().unwrap(), "--exposure", "NaN"],
        &["--exposure"],
    );
    fails(
        &["convert", &exr, out.to_str().unwrap(), "--exposure", "200"],
        &["--exposure"],
    );
    // Overflow to infinity is refused rather than written.
    let big = save(&dir, "big.pfm", &pattern(2, 2, 1e37));
    fails(
        &["convert", &big, out.to_str().unwrap(), "--exposure", "10"],
        &["overflows"],
    );
    assert!(!out.exists() && !jpg.exists() && !noext.exists());
    // Unknown operator: clap's error, non-zero.
    let r = run(&["convert", &exr, out.to_str().unwrap(), "--tonemap", "agx"]);
    assert!(!r.status.success());
    assert!(
        text(&r.stderr).contains("reinhard, aces, filmic"),
        "{}",
        text(&r.stderr)
    );
    assert!(!out.exists());
}
