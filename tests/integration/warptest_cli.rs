//! `lente warptest`: Nori's warps pass their chi-square tests, the heat
//! map is written, and bad arguments are refused.

use std::process::Output;

use crate::cli_util::dump;
use lente::image::io::load_image;

fn warptest(args: &[&str]) -> Output {
    let all: Vec<&str> = std::iter::once("warptest")
        .chain(args.iter().copied())
        .collect();
    crate::cli_util::run(&all)
}

fn passes(args: &[&str]) {
    let out = warptest(args);
    assert!(out.status.success(), "{args:?}: {}", dump(&out));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.starts_with("PASS "), "{stdout}");
    assert!(stdout.contains("p = "), "{stdout}");
}

#[test]
fn planar_warps() {
    for w in ["square", "tent", "disk"] {
        passes(&[w]);
    }
}

#[test]
fn spherical_warps() {
    for w in ["uniform_sphere", "uniform_hemisphere", "cosine_hemisphere"] {
        passes(&[w]);
    }
}

#[test]
fn beckmann() {
    // Nori's own list of warp tests.
    for alpha in ["0.05", "0.1", "0.3"] {
        passes(&["beckmann", alpha]);
    }
}

#[test]
fn microfacet_brdf() {
    passes(&["microfacet_brdf", "0.1"]);
    passes(&["microfacet_brdf", "0.3", "0.5"]);
    passes(&["microfacet_brdf", "0.3", "0.2", "--angle", "60"]);
}

#[test]
fn png_shows_observed_and_expected_side_by_side() {
    let dir = tempfile::tempdir().unwrap();
    for (warp, height) in [
        ("disk", 2 * 12 + 51 * 8),
        ("cosine_hemisphere", 2 * 12 + 51 * 4),
    ] {
        let png = dir.path().join(format!("{warp}.png"));
        let out = warptest(&[warp, "--png", png.to_str().unwrap()]);
        assert!(out.status.success(), "{}", dump(&out));
        let (img, _) = load_image(&png).unwrap();
        // Two 408-pixel panels, a 24-pixel gap, 12-pixel margins.
        assert_eq!((img.width, img.height), (2 * 12 + 2 * 408 + 24, height));
        let background = img.get(0, 0);
        let mid = img.height / 2;
        assert_eq!(img.get(12 + 408 + 12, mid), background, "the gap");
        // Both panels have content in the middle row, and they agree: the
        // left (observed) and right (expected) halves look alike.
        let left = img.get(12 + 204, mid);
        let right = img.get(12 + 408 + 24 + 204, mid);
        assert_ne!(left, background);
        assert_ne!(right, background);
        assert!(
            (left - right).abs().max_element() < 0.25,
            "{left:?} vs {right:?}"
        );
    }
}

#[test]
fn bad_arguments_are_refused() {
    for (args, msg) in [
        (&["beckman", "0.1"][..], "unknown warp 'beckman'"),
        (&["beckmann"][..], "usage: lente warptest beckmann ALPHA"),
        (&["beckmann", "-0.1"][..], "ALPHA must be positive"),
        (&["beckmann", "abc"][..], "cannot read the parameter 'abc'"),
        (&["disk", "1"][..], "'disk' takes no parameters"),
        (
            &["microfacet_brdf", "0.1", "1.5"][..],
            "KD must be between 0 and 1",
        ),
        (
            &["disk", "--angle", "30"][..],
            "--angle applies to microfacet_brdf only",
        ),
    ] {
        let out = warptest(args);
        assert!(!out.status.success(), "{args:?}: {}", dump(&out));
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(msg), "{args:?}: {err}");
    }
}
