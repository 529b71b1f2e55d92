//! `lente bench` from the outside: the report has a row per scene and
//! thread count, the geometric means and the ray figures; bad arguments
//! fail with one line.

use crate::cli_util::*;

const ROOT: &str = env!("CARGO_MANIFEST_DIR");

#[test]
fn bench_reports_every_scene_thread_count_and_the_ray_figures() {
    let out = run(&[
        "bench",
        "--root",
        ROOT,
        "--no-mitsuba",
        "--scenes",
        "cbox,constant_cube",
        "--spp",
        "1",
        "--repeat",
        "1",
        "--threads",
        "1,2",
    ]);
    assert!(out.status.success(), "{}", dump(&out));
    let report = text(&out.stdout);
    assert!(
        report.starts_with("machine: ") && report.lines().next().unwrap().contains("AVX-512F"),
        "the machine comes first: {report}"
    );
    for scene in ["cbox", "constant_cube"] {
        for threads in ["1", "2"] {
            let row = report
                .lines()
                .find(|l| {
                    let f: Vec<&str> = l.split_whitespace().collect();
                    f.len() == 8 && f[0] == scene && f[1] == threads
                })
                .unwrap_or_else(|| panic!("no row for {scene} on {threads} thread(s):\n{report}"));
            let f: Vec<&str> = row.split_whitespace().collect();
            let (total, per_core): (f64, f64) = (f[2].parse().unwrap(), f[3].parse().unwrap());
            assert!(total > 0.0 && per_core > 0.0, "{row}");
            let t: f64 = threads.parse().unwrap();
            assert!(
                (total / t - per_core).abs() <= 0.002,
                "per core = total / threads: {row}"
            );
        }
    }
    assert!(report.contains("geometric mean, 1 thread(s)"), "{report}");
    assert!(report.contains("geometric mean, 2 thread(s)"), "{report}");
    assert!(report.contains("Mitsuba 3 not measured"), "{report}");
    assert!(
        report.contains("rays on 102400 triangles, 2 thread(s): closest hit"),
        "{report}"
    );
}

#[test]
fn bench_refuses_a_root_without_the_suite_and_unknown_scenes() {
    let dir = tempfile::tempdir().unwrap();
    let out = run(&[
        "bench",
        "--root",
        dir.path().to_str().unwrap(),
        "--no-mitsuba",
    ]);
    assert!(!out.status.success());
    let err = text(&out.stderr);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.contains("bench/speed"), "{err}");

    let out = run(&["bench", "--root", ROOT, "--no-mitsuba", "--scenes", "nope"]);
    assert!(!out.status.success());
    let err = text(&out.stderr);
    assert!(
        err.contains("unknown suite scene 'nope'") && err.contains("cbox"),
        "{err}"
    );

    let out = run(&["bench", "--root", ROOT, "--no-mitsuba", "--threads", "0"]);
    assert!(!out.status.success(), "{}", dump(&out));
}
