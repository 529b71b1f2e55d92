//! `--denoise`: Intel Open Image Denoise on the beauty, guided by the
//! albedo and normal AOVs. The denoised image must be closer to a
//! high-spp reference than the noisy one, with no firefly left; the noisy
//! image and the film state stay in the file, so a denoised render can
//! still be continued and merged.
//!
//! The library is found as `lente` finds it (`LENTE_OIDN_LIB`, the
//! system, `pyoidn` in python3). Without it the tests that need it are
//! skipped, unless `CI` is set: then they fail (.ci/run installs it).

use crate::cli_util::{run_fails_with, run_ok, write_cbox};
use lente::color::luminance;
use lente::denoise::Denoiser;
use lente::image::{compare, load_exr_channels, load_image, Bitmap};
use lente::render_file::RenderFile;

/// Whether OIDN is at hand (panics under CI when it is not).
fn have_oidn() -> bool {
    match Denoiser::load() {
        Ok(_) => true,
        Err(e) if std::env::var_os("CI").is_some() => {
            panic!("CI is set but OIDN cannot be loaded: {e}")
        }
        Err(e) => {
            println!("skipped: {e}");
            false
        }
    }
}

/// The test Cornell box (a mirror and a glass sphere: caustics, hence
/// fireflies at low spp) with a one-pixel box filter, as `--denoise`
/// renders it, so that its reference has the same expected pixels.
fn box_filtered_cbox(dir: &tempfile::TempDir, size: u32) -> String {
    let path = write_cbox(dir, size, size, 4);
    let xml = std::fs::read_to_string(&path)
        .unwrap()
        .replace("</camera>", "  <rfilter type=\"box\"/>\n  </camera>");
    std::fs::write(&path, xml).unwrap();
    path.to_str().unwrap().to_string()
}

fn layer(exr: &lente::image::ExrChannels, prefix: &str) -> Bitmap {
    let c = |n: &str| exr.channel(&format!("{prefix}{n}")).unwrap().to_vec();
    let (r, g, b) = (c("R"), c("G"), c("B"));
    Bitmap {
        width: exr.width,
        height: exr.height,
        pixels: (0..r.len())
            .map(|i| lente::color::Rgb::new(r[i], g[i], b[i]))
            .collect(),
    }
}

/// Fireflies: pixels over four times as bright as the reference's (at
/// least 0.1) and brighter by more than 0.5.
fn fireflies(image: &Bitmap, reference: &Bitmap) -> usize {
    image
        .pixels
        .iter()
        .zip(&reference.pixels)
        .filter(|(a, b)| {
            let (a, b) = (luminance(**a), luminance(**b));
            a > 4.0 * b.max(0.1) && a > b + 0.5
        })
        .count()
}

#[test]
fn denoised_image_is_closer_to_the_reference_and_has_no_fireflies() {
    if !have_oidn() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let scene = box_filtered_cbox(&dir, 96);
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    run_ok(&["render", &scene, "-q", "--spp", "1024", "-o", &path("ref")]);
    let out = run_ok(&[
        "render",
        &scene,
        "-q",
        "--spp",
        "16",
        "--seed",
        "7",
        "--denoise",
        "-o",
        &path("dn"),
    ]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("denoised: Open Image Denoise"), "{stdout}");
    let reference = load_image(std::path::Path::new(&path("ref.exr")))
        .unwrap()
        .0;
    let exr = load_exr_channels(std::path::Path::new(&path("dn.exr"))).unwrap();
    let denoised = layer(&exr, "");
    let noisy = layer(&exr, "noisy.");
    // The PNG shows the denoised image, the noisy layer the film's.
    let file = RenderFile::load(std::path::Path::new(&path("dn.exr"))).unwrap();
    assert!(file.image().pixels == noisy.pixels);
    assert!(file.meta.box_filter && file.meta.denoiser.is_some());
    let (noisy_error, denoised_error) = (
        compare(&noisy, &reference).unwrap(),
        compare(&denoised, &reference).unwrap(),
    );
    let (fireflies_noisy, fireflies_denoised) = (
        fireflies(&noisy, &reference),
        fireflies(&denoised, &reference),
    );
    println!(
        "against 1024 spp: MSE noisy {:.3e}, denoised {:.3e}; relative MSE noisy {:.3e}, \
         denoised {:.3e}; fireflies noisy {fireflies_noisy}, denoised {fireflies_denoised}",
        noisy_error.mse, denoised_error.mse, noisy_error.relative_mse, denoised_error.relative_mse
    );
    // MSE is dominated by the light's edge pixels (values ~12, partly
    // covered): relative MSE weighs the whole image.
    assert!(denoised_error.mse < 0.7 * noisy_error.mse);
    assert!(denoised_error.relative_mse < 0.2 * noisy_error.relative_mse);
    // The noisy image has fireflies (caustics through the glass sphere:
    // else this test proves nothing), the denoised one none.
    assert!(fireflies_noisy >= 20, "{fireflies_noisy} fireflies");
    assert_eq!(fireflies_denoised, 0);
}

#[test]
fn denoised_renders_continue_and_merge_like_any_other() {
    if !have_oidn() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let scene = write_cbox(&dir, 32, 24, 8);
    let s = scene.to_str().unwrap();
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    run_ok(&[
        "render",
        s,
        "-q",
        "--denoise",
        "--spp",
        "4",
        "-o",
        &path("a"),
    ]);
    // Continued without --denoise: the box filter and AOVs come from the
    // file, and the film equals a straight 8-spp --denoise render's.
    run_ok(&["render", "-q", "--resume", &path("a.exr"), "--spp", "8"]);
    run_ok(&[
        "render",
        s,
        "-q",
        "--denoise",
        "--spp",
        "8",
        "-o",
        &path("b"),
    ]);
    let (a, b) = (
        RenderFile::load(std::path::Path::new(&path("a.exr"))).unwrap(),
        RenderFile::load(std::path::Path::new(&path("b.exr"))).unwrap(),
    );
    assert!(a.film.data() == b.film.data());
    assert!(a.meta.box_filter && a.meta.denoiser.is_none());
    // A merge with a render of the scene's own (Gaussian) filter is refused.
    run_ok(&[
        "render",
        s,
        "-q",
        "--seed",
        "1",
        "--aov",
        "albedo,normal",
        "-o",
        &path("c"),
    ]);
    run_fails_with(
        &["merge", &path("b.exr"), &path("c.exr"), "-o", &path("m")],
        "box filter",
    );
    run_ok(&[
        "render",
        s,
        "-q",
        "--seed",
        "1",
        "--denoise",
        "-o",
        &path("d"),
    ]);
    let out = run_ok(&[
        "merge",
        &path("b.exr"),
        &path("d.exr"),
        "--denoise",
        "-o",
        &path("m"),
    ]);
    assert!(String::from_utf8_lossy(&out.stdout).contains("albedo and normal"));
}

#[test]
fn a_missing_library_is_reported_before_rendering() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_cbox(&dir, 16, 16, 1);
    let out = dir.path().join("out");
    let missing = dir.path().join("no-such-lib.so");
    let result = std::process::Command::new(crate::cli_util::LENTE)
        .args(["render", scene.to_str().unwrap(), "-q", "--denoise", "-o"])
        .arg(&out)
        .env(lente::denoise::LIBRARY_VARIABLE, &missing)
        .output()
        .unwrap();
    assert!(!result.status.success());
    let stderr = String::from_utf8_lossy(&result.stderr);
    assert!(
        stderr.contains("cannot load Open Image Denoise from") && stderr.contains("no-such-lib"),
        "{stderr}"
    );
    assert!(!out.with_extension("exr").exists() && !out.with_extension("png").exists());
}
