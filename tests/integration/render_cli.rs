//! `lente render` as a user meets it: where outputs go, progress in logs,
//! the PNG's exposure and tone mapping, and Ctrl-C.

use std::time::{Duration, Instant};

use crate::cli_util::{dump, run, run_fails_with, text, write_cbox, Running};
use lente::image::{load_image, Tonemap};

fn temporaries(dir: &std::path::Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains(".tmp-"))
        .collect()
}

#[test]
fn output_folders_are_made_and_a_bad_output_fails_before_rendering() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_cbox(&dir, 16, 16, 1);
    let nested = dir.path().join("a/b/out");
    let out = run(&[
        "render",
        scene.to_str().unwrap(),
        "-q",
        "-o",
        nested.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", dump(&out));
    assert!(nested.with_extension("exr").is_file() && nested.with_extension("png").is_file());
    // A folder as -o: the scene's name inside it.
    let folder = dir.path().join("renders");
    std::fs::create_dir(&folder).unwrap();
    let out = run(&[
        "render",
        scene.to_str().unwrap(),
        "-q",
        "-o",
        folder.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", dump(&out));
    let stem = scene.file_stem().unwrap().to_string_lossy().into_owned();
    assert!(
        folder.join(format!("{stem}.exr")).is_file(),
        "{}",
        dump(&out)
    );
    // Under a file: refused at once, not after a 100 000-spp render.
    let file = dir.path().join("plain-file");
    std::fs::write(&file, "x").unwrap();
    let start = Instant::now();
    let bad = file.join("out");
    let out = run(&[
        "render",
        scene.to_str().unwrap(),
        "-q",
        "--spp",
        "100000",
        "-o",
        bad.to_str().unwrap(),
    ]);
    assert!(!out.status.success());
    assert!(
        start.elapsed() < Duration::from_secs(20),
        "it rendered first"
    );
    let err = text(&out.stderr);
    assert!(err.contains("cannot create the output folder"), "{err}");
    assert!(!text(&out.stdout).contains("spp"), "{}", dump(&out));
}

#[test]
fn logs_get_plain_progress_lines() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_cbox(&dir, 32, 32, 8);
    let o = dir.path().join("p");
    // stderr is a pipe here: auto means plain lines.
    let out = run(&[
        "render",
        scene.to_str().unwrap(),
        "-o",
        o.to_str().unwrap(),
        "--progress-every",
        "0",
    ]);
    assert!(out.status.success(), "{}", dump(&out));
    let err = text(&out.stderr);
    let lines: Vec<&str> = err.lines().filter(|l| l.starts_with("render: ")).collect();
    assert!(!lines.is_empty(), "{err}");
    let last = lines.last().unwrap();
    assert!(
        last.contains("/8 spp, pass ") && last.contains(" M samples/s, "),
        "{last}"
    );
    assert!(last.contains(" elapsed, ETA "), "{last}");
    // --progress none (or -q): nothing.
    let out = run(&[
        "render",
        scene.to_str().unwrap(),
        "-o",
        o.to_str().unwrap(),
        "--progress",
        "none",
        "--progress-every",
        "0",
    ]);
    assert!(!text(&out.stderr).contains("render: "), "{}", dump(&out));
}

#[test]
fn exposure_and_tone_mapping_change_the_png_not_the_exr() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_cbox(&dir, 24, 24, 4);
    let render = |name: &str, extra: &[&str]| {
        let base = dir.path().join(name);
        let mut args = vec![
            "render",
            scene.to_str().unwrap(),
            "-q",
            "-o",
            base.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        let out = run(&args);
        assert!(out.status.success(), "{}", dump(&out));
        base
    };
    let plain = render("plain", &[]);
    let bright = render("bright", &["--exposure", "2", "--tonemap", "reinhard"]);
    // The EXRs' channels are the same (their headers differ in render time).
    let exr = |b: &std::path::Path| {
        lente::image::load_exr_channels(&b.with_extension("exr"))
            .unwrap()
            .channels
    };
    assert_eq!(exr(&plain), exr(&bright), "the EXR must stay linear");
    let (linear, _) = load_image(&plain.with_extension("exr")).unwrap();
    let (png, _) = load_image(&bright.with_extension("png")).unwrap();
    let mut checked = 0;
    for (l, p) in linear.pixels.iter().zip(&png.pixels) {
        let expect = Tonemap::Reinhard.map(l.x * 4.0);
        // 8-bit sRGB steps are at most ~1/255 * 2.4 in linear terms.
        assert!((p.x - expect).abs() < 0.01, "{} vs {expect}", p.x);
        checked += 1;
    }
    assert_eq!(checked, 24 * 24);
    // auto: a dim image is brightened.
    let auto = render("auto", &["--exposure", "auto"]);
    let (a, _) = load_image(&auto.with_extension("png")).unwrap();
    let (p, _) = load_image(&plain.with_extension("png")).unwrap();
    let mean = |b: &lente::image::Bitmap| b.pixels.iter().map(|c| c.y as f64).sum::<f64>();
    assert!(mean(&a) != mean(&p));
    run_fails_with(
        &["render", scene.to_str().unwrap(), "--exposure", "bright"],
        "'auto' or a number of stops",
    );
}

#[test]
fn a_second_ctrl_c_still_writes_both_outputs() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_cbox(&dir, 64, 64, 1_000_000);
    let base = dir.path().join("cc");
    let mut r = Running::spawn(&[
        "render",
        scene.to_str().unwrap(),
        "-o",
        base.to_str().unwrap(),
        "--progress",
        "plain",
        "--progress-every",
        "0",
    ]);
    r.wait_line("render: ", Duration::from_secs(60));
    r.interrupt();
    r.wait_line("interrupted:", Duration::from_secs(10));
    r.interrupt();
    let (status, stdout) = r.wait(Duration::from_secs(10));
    assert!(status.success(), "{status:?}: {}", r.stderr_text());
    assert!(stdout.contains("interrupted: partial image"), "{stdout}");
    assert!(base.with_extension("exr").is_file() && base.with_extension("png").is_file());
    assert!(
        temporaries(dir.path()).is_empty(),
        "{:?}",
        temporaries(dir.path())
    );
}
