//! Renders every example scene of the repository at a fixed small size,
//! sample count and seed, and prints one digest of the image's bits per
//! scene: the scenes under `scenes/` and `tests/` (standalone scene files,
//! and the scenes nested in Nori `<test>` files).
//!
//! ```text
//! cargo run --release --example render_digests -- [REPO_ROOT]
//! ```
//!
//! `scripts/same-images.sh` runs it from two revisions on the same scene
//! files: a change that must not alter images (a refactoring) shows no
//! differing line. Scenes whose files are missing are reported as skipped.

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use lente::image::Bitmap;
use lente::load::nori_testfile::{load_test, NoriTest};
use lente::load::{load_scene, SceneFile};
use lente::render::{render, RenderOptions};
use lente::scene::Scene;

const WIDTH: u32 = 48;
const HEIGHT: u32 = 36;
const SPP: u32 = 16;
const SEED: u64 = 7;

fn render_small(mut file: SceneFile) -> Result<Bitmap, String> {
    file.scene.camera.width = WIDTH;
    file.scene.camera.height = HEIGHT;
    file.job.spp = SPP;
    let scene = Scene::new(file.scene).map_err(|e| e.to_string())?;
    let opts = RenderOptions::new(SEED);
    Ok(render(&scene, &file.job, &opts, &AtomicBool::new(false)).image)
}

/// FNV-1a over the pixels' f32 bit patterns.
fn digest(image: &Bitmap) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    for p in &image.pixels {
        for c in [p.x, p.y, p.z] {
            for b in c.to_bits().to_le_bytes() {
                h ^= b as u64;
                h = h.wrapping_mul(0x0100_0000_01b3);
            }
        }
    }
    h
}

fn xml_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let p = e.path();
        if p.is_dir() {
            xml_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "xml") {
            out.push(p);
        }
    }
}

fn report(label: &str, result: Result<Bitmap, String>) {
    match result {
        Ok(image) => println!("{label} {:016x}", digest(&image)),
        Err(e) => println!("{label} error: {e}"),
    }
}

fn main() {
    let root = PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| ".".into()));
    let mut files = Vec::new();
    xml_files(&root.join("scenes"), &mut files);
    xml_files(&root.join("tests"), &mut files);
    files.sort();
    for f in &files {
        let label = f.strip_prefix(&root).unwrap_or(f).display().to_string();
        let text = std::fs::read_to_string(f).unwrap_or_default();
        let is_test = lente::load::xml::parse(&text).is_ok_and(|root| root.tag == "test");
        if is_test {
            match load_test(f) {
                Ok((test, _)) => {
                    if let NoriTest::SceneTTest { scenes, .. } = test.test {
                        for case in scenes {
                            report(&format!("{label}:{}", case.pos), render_small(case.file));
                        }
                    }
                }
                Err(e) => println!("{label} skipped: {e}"),
            }
            continue;
        }
        match load_scene(f) {
            Ok((file, _)) => report(&label, render_small(file)),
            Err(e) => println!("{label} skipped: {e}"),
        }
    }
}
