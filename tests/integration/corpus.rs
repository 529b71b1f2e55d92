//! Every example scene in the repository loads, renders and writes finite
//! images (at a tiny size and few samples): the scenes under `scenes/`,
//! and every scene under `tests/`, both the Nori scenes nested in the
//! `<test>` files and any standalone `<scene>` file (Nori or Mitsuba).
//! Scenes that read data from outside the repository (the shared light
//! probes), or name files that are not there, are skipped with a message.

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use lente::image::Bitmap;
use lente::load::nori_testfile::{load_test, NoriTest};
use lente::load::{load_scene, SceneFile};
use lente::render::{render, RenderOptions};
use lente::scene::Scene;

/// Renders `desc` at 32x24, 2 spp; the image must be finite and
/// non-negative (unless the filter has negative lobes), and survive a
/// round trip through EXR and PNG.
fn render_tiny(label: &str, mut file: SceneFile) -> Bitmap {
    file.scene.camera.width = 32;
    file.scene.camera.height = 24;
    file.job.spp = 2;
    let negative_ok = file.job.filter.has_negative_lobes();
    let scene = Scene::new(file.scene).unwrap_or_else(|e| panic!("{label}: {e}"));
    let out = render(
        &scene,
        &file.job,
        &RenderOptions::new(0),
        &AtomicBool::new(false),
    );
    assert!(
        out.image
            .pixels
            .iter()
            .all(|p| p.is_finite() && (negative_ok || p.min_element() >= 0.0)),
        "{label} rendered a non-finite or negative pixel"
    );
    let dir = tempfile::tempdir().unwrap();
    for ext in ["exr", "png"] {
        let p = dir.path().join(format!("out.{ext}"));
        lente::image::io::save_image(&p, &out.image).unwrap();
        let (back, _) = lente::image::io::load_image(&p).unwrap();
        assert_eq!((back.width, back.height), (32, 24), "{label}");
    }
    out.image
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
        let (desc, _warnings) =
            load_scene(f).unwrap_or_else(|e| panic!("{} does not load: {e}", f.display()));
        let image = render_tiny(&f.display().to_string(), desc);
        assert!(
            image.mean().max_element() > 0.0,
            "{} rendered black",
            f.display()
        );
        rendered += 1;
    }
    eprintln!("rendered {rendered} of {} scenes", files.len());
}

/// The value of attribute `name` in the text of one tag, if present.
fn attribute<'t>(tag: &'t str, name: &str) -> Option<&'t str> {
    let mut rest = tag;
    while let Some(i) = rest.find(name) {
        let before = rest[..i].chars().last();
        let after = rest[i + name.len()..].trim_start();
        rest = &rest[i + name.len()..];
        if !before.is_some_and(char::is_whitespace) {
            continue;
        }
        let Some(after) = after.strip_prefix('=') else {
            continue;
        };
        let after = after.trim_start();
        let quote = after.chars().next()?;
        if quote != '"' && quote != '\'' {
            continue;
        }
        let body = &after[1..];
        return body.find(quote).map(|end| &body[..end]);
    }
    None
}

/// Files a scene names (`filename` properties, `<include filename>`) that
/// are not where it says. Names with `$` substitutions and the built-in
/// sky are not checked.
fn missing_files(path: &Path, text: &str) -> Vec<PathBuf> {
    let dir = path.parent().unwrap_or(Path::new("."));
    let mut missing = Vec::new();
    for piece in text.split('<').skip(1) {
        let tag = piece.split('>').next().unwrap_or_default();
        let name = if tag.starts_with("include") {
            attribute(tag, "filename")
        } else if attribute(tag, "name") == Some("filename") {
            attribute(tag, "value")
        } else {
            None
        };
        if let Some(n) = name {
            if n.contains('$') || n.trim() == "@sky" || n.trim().is_empty() {
                continue;
            }
            let p = dir.join(n.trim());
            if !p.exists() {
                missing.push(p);
            }
        }
    }
    missing
}

#[test]
fn missing_files_finds_filenames_and_includes() {
    let text = r#"<scene version="3.0.0">
        <include filename="nowhere.xml"/>
        <shape type="obj"><string name="filename" value='meshes/floor.obj'/></shape>
        <shape type="obj"><string value="gone.obj" name="filename"/></shape>
        <emitter type="envmap"><string name="filename" value="$probe"/></emitter>
        <emitter type="environment"><string name="filename" value="@sky"/></emitter>
        <string name="filenames" value="not-a-file"/>
    </scene>"#;
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/scenes");
    let missing = missing_files(&dir.join("x.xml"), text);
    assert_eq!(missing, vec![dir.join("nowhere.xml"), dir.join("gone.obj")]);
}

/// Every Nori-format scene under `tests/` (those nested in the `<test>`
/// files) and every standalone scene file there (Nori or Mitsuba 3) loads
/// and renders finite images.
#[test]
fn every_scene_under_tests_renders_finite_images() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut files = Vec::new();
    xml_files(&root.join("tests"), &mut files);
    files.sort();
    let (mut rendered, mut skipped) = (0, 0);
    for f in &files {
        let text = std::fs::read_to_string(f).unwrap_or_else(|e| panic!("{}: {e}", f.display()));
        let tree = lente::load::xml::parse(&text)
            .unwrap_or_else(|e| panic!("{} is not XML: {}", f.display(), e.message));
        match tree.tag.as_str() {
            "test" => {
                let (test, _) =
                    load_test(f).unwrap_or_else(|e| panic!("{} does not load: {e}", f.display()));
                if let NoriTest::SceneTTest { scenes, .. } = test.test {
                    for case in scenes {
                        let label = format!("{}:{}", f.display(), case.pos);
                        render_tiny(&label, case.file);
                        rendered += 1;
                    }
                }
            }
            "scene" => {
                let missing = missing_files(f, &text);
                if !missing.is_empty() {
                    eprintln!(
                        "skipped {} (it names missing files: {})",
                        f.display(),
                        missing
                            .iter()
                            .map(|p| p.display().to_string())
                            .collect::<Vec<_>>()
                            .join(", ")
                    );
                    skipped += 1;
                    continue;
                }
                let (desc, _) =
                    load_scene(f).unwrap_or_else(|e| panic!("{} does not load: {e}", f.display()));
                render_tiny(&f.display().to_string(), desc);
                rendered += 1;
            }
            _ => {}
        }
    }
    // tests/scenes alone nests more than 20 scenes in its t-test files.
    assert!(rendered >= 20, "rendered only {rendered} scenes");
    eprintln!("rendered {rendered} scenes under tests/, skipped {skipped}");
}
