//! Replays the stored fuzz inputs (`fuzz/regressions/TARGET/*`: crashes,
//! hangs and huge allocations the fuzzers or hand-made attacks found,
//! each fixed) through the same entry the cargo-fuzz targets call, on the
//! stable toolchain. Each must give `Ok` or a one-line error, quickly and
//! without a panic. Its own binary: it lowers the process's image bound
//! as the fuzz targets do.

use std::path::Path;
use std::time::{Duration, Instant};

use lente::fuzz::{configure, run, Target};

#[test]
fn stored_fuzz_inputs_load_or_fail_cleanly() {
    configure();
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/regressions");
    let mut replayed = 0;
    for entry in std::fs::read_dir(&root).expect("fuzz/regressions exists") {
        let dir = entry.unwrap().path();
        let name = dir.file_name().unwrap().to_string_lossy().into_owned();
        let target = Target::from_name(&name)
            .unwrap_or_else(|| panic!("fuzz/regressions/{name}: no fuzz target of that name"));
        let mut files: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().path())
            .collect();
        files.sort();
        for file in files {
            let bytes = std::fs::read(&file).unwrap();
            let start = Instant::now();
            let outcome = std::panic::catch_unwind(|| run(target, &bytes));
            let took = start.elapsed();
            let label = file.strip_prefix(&root).unwrap().display().to_string();
            match outcome {
                Ok(Err(message)) => assert!(
                    !message.is_empty() && !message.contains('\n'),
                    "{label}: not one line: {message:?}"
                ),
                Ok(Ok(())) => {}
                Err(_) => panic!("{label}: panicked"),
            }
            assert!(took < Duration::from_secs(5), "{label}: took {took:?}");
            replayed += 1;
        }
    }
    assert!(replayed >= 10, "only {replayed} stored inputs");
}

/// The hand-made attacks of the hardening issue fail with the error they
/// should, not just any error.
#[test]
fn the_known_attacks_fail_for_the_right_reason() {
    configure();
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("fuzz/regressions");
    let cases = [
        (Target::Obj, "obj/far_coordinates.obj", "coordinate range"),
        (
            Target::Obj,
            "obj/relative_uv_index_before_the_first.obj",
            "refers to none",
        ),
        (Target::Ply, "ply/far_coordinates.ply", "coordinate range"),
        (
            Target::NoriScene,
            "nori_scene/far_spheres.xml",
            "coordinate range",
        ),
        (
            Target::MitsubaScene,
            "mitsuba_scene/far_translated_sphere.xml",
            "coordinate range",
        ),
        (
            Target::NoriScene,
            "nori_scene/huge_resolution.xml",
            "pixels",
        ),
        (Target::Pfm, "pfm/zero_width_huge_height.pfm", "empty"),
        (Target::Pfm, "pfm/huge_header.pfm", "pixels"),
        (Target::Png, "png/huge_header.png", "pixels"),
        (Target::Exr, "exr/negative_height_window.exr", "OpenEXR"),
        (Target::Exr, "exr/reversed_x_window.exr", "OpenEXR"),
        (
            Target::Exr,
            "exr/huge_tiles_on_a_small_layer.exr",
            "more than the 12x9 layer they tile",
        ),
    ];
    for (target, file, expected) in cases {
        let bytes = std::fs::read(root.join(file)).unwrap();
        let err = run(target, &bytes).expect_err(file);
        assert!(err.contains(expected), "{file}: {err}");
    }
}
