//! `render --aov`: the output variables land in the EXR under the names
//! denoisers and Mitsuba read, hold the right values where they are known
//! in closed form, leave the image bit for bit unchanged, and continue and
//! merge like the image.

use crate::cli_util::{run_fails_with, run_ok, write_cbox};
use lente::image::{load_exr_channels, ExrChannels};
use lente::render_file::RenderFile;

fn at(exr: &ExrChannels, name: &str, x: usize, y: usize) -> f32 {
    exr.channel(name)
        .unwrap_or_else(|| panic!("no channel {name}"))[y * exr.width + x]
}

#[test]
fn aovs_hold_known_values_and_leave_the_image_unchanged() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_cbox(&dir, 64, 64, 8);
    let s = scene.to_str().unwrap();
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    run_ok(&["render", s, "-q", "-o", &path("plain")]);
    run_ok(&[
        "render",
        s,
        "-q",
        "--aov",
        "albedo,normal,depth,position",
        "-o",
        &path("aov"),
    ]);
    let plain = load_exr_channels(&dir.path().join("plain.exr")).unwrap();
    let aov = load_exr_channels(&dir.path().join("aov.exr")).unwrap();
    for c in [
        "R",
        "G",
        "B",
        "lente.film.R",
        "lente.film.G",
        "lente.film.B",
        "lente.weight.Y",
    ] {
        assert!(
            plain.channel(c) == aov.channel(c),
            "channel {c} changed with --aov"
        );
    }
    // The back wall above the spheres: its albedo exactly (one cosine-
    // weighted sample of a diffuse BSDF weighs its reflectance), its
    // normal towards the camera, and depth = |position - camera|.
    let (x, y) = (32, 22);
    let albedo = ["albedo.R", "albedo.G", "albedo.B"].map(|c| at(&aov, c, x, y));
    for (a, e) in albedo.iter().zip([0.725, 0.71, 0.68]) {
        assert!((a - e).abs() < 1e-5, "albedo {albedo:?}");
    }
    let n = ["normal.X", "normal.Y", "normal.Z"].map(|c| at(&aov, c, x, y));
    assert!(
        n[0].abs() < 1e-5 && n[1].abs() < 1e-5 && (n[2] - 1.0).abs() < 1e-5,
        "normal {n:?}"
    );
    let p = ["position.X", "position.Y", "position.Z"].map(|c| at(&aov, c, x, y));
    let dist = (p[0].powi(2) + (p[1] - 1.0).powi(2) + (p[2] - 3.9).powi(2)).sqrt();
    let depth = at(&aov, "depth.Z", x, y);
    assert!(
        (depth - dist).abs() < 0.02 * dist,
        "depth {depth} vs |p - o| {dist}"
    );
    // The red wall.
    let red = ["albedo.R", "albedo.G", "albedo.B"].map(|c| at(&aov, c, 6, 32));
    for (a, e) in red.iter().zip([0.63, 0.065, 0.05]) {
        assert!((a - e).abs() < 1e-5, "red wall albedo {red:?}");
    }
    // The mirror sphere shows what it reflects: an albedo of the walls',
    // not black.
    let mirror = ["albedo.R", "albedo.G", "albedo.B"].map(|c| at(&aov, c, 22, 50));
    assert!(mirror.iter().sum::<f32>() > 0.1, "mirror albedo {mirror:?}");
    // Mitsuba's Bitmap::split and tev group channels by prefix: no `.W`.
    assert!(aov.channels.iter().all(|(n, _)| !n.ends_with(".W")));

    run_fails_with(
        &["render", s, "-q", "--aov", "albedo,uv"],
        "unknown AOV 'uv'",
    );
}

#[test]
fn aovs_continue_and_merge_like_the_image() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_cbox(&dir, 24, 20, 32);
    let s = scene.to_str().unwrap();
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    run_ok(&[
        "render",
        s,
        "-q",
        "--aov",
        "albedo,normal",
        "--spp",
        "8",
        "-o",
        &path("part"),
    ]);
    run_ok(&["render", "--resume", &path("part.exr"), "--spp", "32", "-q"]);
    run_ok(&[
        "render",
        s,
        "-q",
        "--aov",
        "albedo,normal",
        "-o",
        &path("whole"),
    ]);
    let a = RenderFile::load(&dir.path().join("part.exr")).unwrap();
    let b = RenderFile::load(&dir.path().join("whole.exr")).unwrap();
    assert_eq!(a.meta.aovs.to_string(), "albedo,normal");
    assert!(
        a.film.aov_sums() == b.film.aov_sums(),
        "continued AOVs differ"
    );
    assert!(a.film.data() == b.film.data());
    run_fails_with(
        &[
            "render",
            "--resume",
            &path("whole.exr"),
            "--spp",
            "40",
            "--aov",
            "depth",
        ],
        "keeps them",
    );

    run_ok(&[
        "render",
        s,
        "-q",
        "--aov",
        "albedo,normal",
        "--seed",
        "1",
        "-o",
        &path("s1"),
    ]);
    run_ok(&[
        "merge",
        &path("whole.exr"),
        &path("s1.exr"),
        "-o",
        &path("m"),
    ]);
    let m = load_exr_channels(&dir.path().join("m.exr")).unwrap();
    assert!(m.channel("albedo.R").is_some() && m.channel("lente.film.normal.Z").is_some());
    run_ok(&["render", s, "-q", "--seed", "2", "-o", &path("none")]);
    run_fails_with(
        &[
            "merge",
            &path("whole.exr"),
            &path("none.exr"),
            "-o",
            &path("bad"),
        ],
        "renders with the same --aov only",
    );
}
