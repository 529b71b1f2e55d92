//! Every example scene in the repository loads, renders and writes finite
//! images (at a tiny size and few samples). Scenes that read data from
//! outside the repository (the shared light probes) are skipped with a
//! message when that data is absent.

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use lente::render::{render, RenderOptions};
use lente::scene::{load_scene, Scene};

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

/// True if the scene names a file outside the repository that is missing.
fn needs_missing_shared_data(path: &Path) -> bool {
    let text = std::fs::read_to_string(path).unwrap_or_default();
    text.contains("shared/data/")
        && !Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../shared/data")
            .exists()
}

#[test]
fn every_example_scene_renders_finite_images() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = Vec::new();
    xml_files(&root.join("scenes"), &mut files);
    files.sort();
    assert!(files.len() >= 8, "found only {} scenes", files.len());
    let mut rendered = 0;
    for f in &files {
        if needs_missing_shared_data(f) {
            eprintln!(
                "skipped {} (needs ../shared/data, which is absent)",
                f.display()
            );
            continue;
        }
        let (mut desc, _warnings) =
            load_scene(f).unwrap_or_else(|e| panic!("{} does not load: {e}", f.display()));
        desc.camera.width = 32;
        desc.camera.height = 24;
        let scene = Scene::new(desc).unwrap_or_else(|e| panic!("{}: {e}", f.display()));
        let out = render(
            &scene,
            &RenderOptions {
                spp: 2,
                seed: 0,
                progress: false,
            },
            &AtomicBool::new(false),
        );
        assert!(
            out.image
                .pixels
                .iter()
                .all(|p| p.is_finite() && p.min_element() >= 0.0),
            "{} rendered a non-finite or negative pixel",
            f.display()
        );
        assert!(
            out.image.mean().max_element() > 0.0,
            "{} rendered black",
            f.display()
        );
        // And the files are written.
        let dir = std::env::temp_dir().join(format!("lente-corpus-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        for ext in ["exr", "png"] {
            let p = dir.join(format!("out.{ext}"));
            lente::image::io::save_image(&p, &out.image).unwrap();
            let (back, _) = lente::image::io::load_image(&p).unwrap();
            assert_eq!((back.width, back.height), (32, 24));
        }
        rendered += 1;
    }
    eprintln!("rendered {rendered} of {} scenes", files.len());
}
