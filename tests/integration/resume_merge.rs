//! Render files as a user meets them: an interrupted render continued with
//! `--resume` is the uninterrupted render bit for bit; sample slices and
//! seeds merge with `lente merge`; files that do not belong together are
//! refused with a message naming them.

use std::time::Duration;

use crate::cli_util::{run_fails_with, run_ok, write_cbox, Running};
use lente::render_file::RenderFile;

fn load(path: &std::path::Path) -> RenderFile {
    RenderFile::load(path).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn an_interrupted_render_continues_to_the_uninterrupted_one_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_cbox(&dir, 24, 24, 1500);
    let s = scene.to_str().unwrap();
    let part = dir.path().join("part");
    let mut r = Running::spawn(&[
        "render",
        s,
        "-o",
        part.to_str().unwrap(),
        "--progress",
        "plain",
        "--progress-every",
        "0",
    ]);
    r.wait_line("render: ", Duration::from_secs(60));
    r.interrupt();
    let (status, stdout) = r.wait(Duration::from_secs(60));
    assert!(status.success(), "{status:?}: {}", r.stderr_text());
    assert!(stdout.contains("interrupted: partial image"), "{stdout}");
    let cut = load(&part.with_extension("exr"));
    let done = cut.meta.spp();
    assert!(done < 1500, "{done}");
    assert_eq!(cut.meta.spp_target, 1500);

    // Continued from the file alone (it names the scene), then whole.
    run_ok(&[
        "render",
        "--resume",
        part.with_extension("exr").to_str().unwrap(),
        "-q",
    ]);
    let whole = dir.path().join("whole");
    run_ok(&["render", s, "-q", "-o", whole.to_str().unwrap()]);
    let (a, b) = (
        load(&part.with_extension("exr")),
        load(&whole.with_extension("exr")),
    );
    assert_eq!(a.meta.spp(), 1500);
    assert_eq!(a.meta.ranges, b.meta.ranges);
    assert!(a.film.data() == b.film.data(), "the continued film differs");
    assert_eq!(a.image(), b.image());
    assert!(a.meta.render_seconds > cut.meta.render_seconds);

    // A finished render goes further with --spp, and no further without.
    run_fails_with(
        &[
            "render",
            "--resume",
            whole.with_extension("exr").to_str().unwrap(),
            "-q",
        ],
        "already holds samples up to 1500",
    );
    // Another seed or size is refused: a continued render keeps both.
    run_fails_with(
        &[
            "render",
            "--resume",
            whole.with_extension("exr").to_str().unwrap(),
            "--spp",
            "1600",
            "--seed",
            "4",
        ],
        "rendered with seed 0, not 4",
    );
    run_fails_with(
        &[
            "render",
            "--resume",
            whole.with_extension("exr").to_str().unwrap(),
            "--spp",
            "1600",
            "--resolution",
            "8x8",
        ],
        "keeps its size",
    );
    // An edited scene is refused.
    let xml = std::fs::read_to_string(&scene).unwrap();
    std::fs::write(&scene, xml.replace("0.725", "0.5")).unwrap();
    run_fails_with(
        &[
            "render",
            "--resume",
            whole.with_extension("exr").to_str().unwrap(),
            "--spp",
            "1600",
        ],
        "changed since",
    );
}

#[test]
fn slices_and_seeds_merge_and_mismatches_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_cbox(&dir, 20, 16, 64);
    let s = scene.to_str().unwrap();
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    run_ok(&["render", s, "-q", "--samples", "0..24", "-o", &path("a")]);
    run_ok(&["render", s, "-q", "--samples", "24..64", "-o", &path("b")]);
    run_ok(&["render", s, "-q", "-o", &path("whole")]);
    run_ok(&["merge", &path("b.exr"), &path("a.exr"), "-o", &path("m")]);
    let (m, whole) = (
        load(&dir.path().join("m.exr")),
        load(&dir.path().join("whole.exr")),
    );
    assert_eq!(m.meta.ranges, whole.meta.ranges);
    // Equal to the whole render up to the order of float additions: each
    // film value is a sum of at most 64 * 9 terms, so a relative 1e-5
    // bounds the rounding (measured: about 1e-7).
    let (mi, wi) = (m.image(), whole.image());
    let mut worst = 0.0f32;
    for (p, q) in mi.pixels.iter().zip(&wi.pixels) {
        for (x, y) in [(p.x, q.x), (p.y, q.y), (p.z, q.z)] {
            worst = worst.max((x - y).abs() / y.abs().max(1e-6));
        }
    }
    assert!(
        worst < 1e-5,
        "merged slices differ from the whole render by {worst}"
    );

    // Two seeds: 128 spp; the same samples twice: refused.
    run_ok(&["render", s, "-q", "--seed", "1", "-o", &path("s1")]);
    run_ok(&[
        "merge",
        &path("whole.exr"),
        &path("s1.exr"),
        "-o",
        &path("two"),
    ]);
    assert_eq!(load(&dir.path().join("two.exr")).meta.spp(), 128);
    run_fails_with(
        &[
            "merge",
            &path("whole.exr"),
            &path("a.exr"),
            "-o",
            &path("bad"),
        ],
        "the same samples (seed 0: 0..24 and 0..64)",
    );
    // Another size, another scene, not a render file.
    run_ok(&[
        "render",
        s,
        "-q",
        "--seed",
        "2",
        "--resolution",
        "10x8",
        "-o",
        &path("small"),
    ]);
    run_fails_with(
        &[
            "merge",
            &path("whole.exr"),
            &path("small.exr"),
            "-o",
            &path("bad"),
        ],
        "is 20x16 but",
    );
    run_ok(&[
        "render",
        s,
        "-q",
        "--seed",
        "3",
        "-D",
        "unused=1",
        "-o",
        &path("other"),
    ]);
    run_fails_with(
        &[
            "merge",
            &path("whole.exr"),
            &path("other.exr"),
            "-o",
            &path("bad"),
        ],
        "renders of different scenes",
    );
    run_ok(&["convert", &path("whole.exr"), &path("plain.exr")]);
    run_fails_with(
        &[
            "merge",
            &path("whole.exr"),
            &path("plain.exr"),
            "-o",
            &path("bad"),
        ],
        "plain.exr: not a lente render file",
    );
    assert!(!dir.path().join("bad.exr").exists());
}
