//! The loaders as fuzz targets: one entry per kind of input file, taking
//! the bytes a fuzzer makes and going through the same functions the CLI
//! calls. The cargo-fuzz targets in `fuzz/` call [`run`], and so do the
//! stable regression tests that replay the stored crash inputs
//! (`fuzz/regressions/<target>/`): a fixed crash stays fixed.
//!
//! Whole-scene targets build the [`Scene`] too (BVH, light tables), with
//! relative file names resolved against the repository's example folders,
//! so seeds that reference meshes and probes load them.

use std::path::{Path, PathBuf};

use crate::scene::Scene;

/// What a fuzz target feeds its bytes to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Target {
    /// A Nori scene file, loaded and built.
    NoriScene,
    /// A Mitsuba 3 scene file, loaded and built.
    MitsubaScene,
    /// A Nori `<test>` file.
    NoriTest,
    Obj,
    Ply,
    /// Mitsuba's `.serialized` meshes: shape 0, then shape 1 (the
    /// end-of-file dictionary).
    Serialized,
    /// Mitsuba's `.vol` voxel grids.
    Vol,
    /// Mitsuba's curve text files (`linearcurve`, `bsplinecurve`), read
    /// both ways and intersected.
    Curve,
    Hdr,
    Pfm,
    /// OpenEXR, as an image and as a render file (`--resume`, `merge`).
    Exr,
    Png,
    Jpeg,
    Bmp,
}

impl Target {
    pub const ALL: [Target; 14] = [
        Target::NoriScene,
        Target::MitsubaScene,
        Target::NoriTest,
        Target::Obj,
        Target::Ply,
        Target::Serialized,
        Target::Vol,
        Target::Curve,
        Target::Hdr,
        Target::Pfm,
        Target::Exr,
        Target::Png,
        Target::Jpeg,
        Target::Bmp,
    ];

    /// The cargo-fuzz target's name (and its folders' names).
    pub fn name(self) -> &'static str {
        match self {
            Target::NoriScene => "nori_scene",
            Target::MitsubaScene => "mitsuba_scene",
            Target::NoriTest => "nori_test",
            Target::Obj => "obj",
            Target::Ply => "ply",
            Target::Serialized => "serialized",
            Target::Vol => "vol",
            Target::Curve => "curve",
            Target::Hdr => "hdr",
            Target::Pfm => "pfm",
            Target::Exr => "exr",
            Target::Png => "png",
            Target::Jpeg => "jpeg",
            Target::Bmp => "bmp",
        }
    }

    pub fn from_name(name: &str) -> Option<Target> {
        Target::ALL.into_iter().find(|t| t.name() == name)
    }
}

/// Pixels an image may have while fuzzing: 2^20 (the default bound,
/// [`crate::limits::MAX_IMAGE_PIXELS`], lets a 1 KB file ask for 3 GiB
/// legitimately, which would make every such input a slow run).
pub const FUZZ_IMAGE_PIXELS: u64 = 1 << 20;

/// Sets the process-wide bounds for fuzzing; call once before [`run`].
pub fn configure() {
    crate::limits::set_max_image_pixels(FUZZ_IMAGE_PIXELS);
    // libFuzzer's hook aborts at any panic, even one lente catches and
    // reports: a third-party decoder's is left to its guard (it becomes
    // the file's error); every other panic still aborts.
    crate::image::io::quiet_panics_in_guarded_decoders();
}

/// The repository root (scene targets resolve file names below it).
fn repo_root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// Where a fuzzed scene file pretends to live: beside the example scenes
/// whose seeds reference meshes and probes.
fn scene_path(target: Target) -> PathBuf {
    match target {
        Target::MitsubaScene => repo_root().join("scenes/mitsuba/fuzzed.xml"),
        _ => repo_root().join("scenes/cbox/fuzzed.xml"),
    }
}

/// Feeds `bytes` to `target`'s loader. `Ok` or `Err` (the one-line
/// message) are both fine outcomes; a panic, an abort, a hang or a huge
/// allocation is a bug.
pub fn run(target: Target, bytes: &[u8]) -> Result<(), String> {
    use crate::image::io::decode_image;
    match target {
        Target::NoriScene | Target::MitsubaScene => {
            let path = scene_path(target);
            let text = crate::load::decode_utf8(&path, bytes.to_vec(), "scene file")
                .map_err(|e| e.to_string())?;
            let (file, _) = crate::load::load_scene_str(&text, &path).map_err(|e| e.to_string())?;
            Scene::new(file.scene).map_err(|e| e.to_string())?;
            Ok(())
        }
        Target::NoriTest => {
            let path = scene_path(target);
            let text = crate::load::decode_utf8(&path, bytes.to_vec(), "test file")
                .map_err(|e| e.to_string())?;
            crate::load::nori_testfile::load_test_str(&text, &path).map_err(|e| e.to_string())?;
            Ok(())
        }
        Target::Obj => crate::geometry::parse_obj(bytes)
            .map(drop)
            .map_err(|e| e.to_string()),
        Target::Ply => crate::geometry::parse_ply(bytes)
            .map(drop)
            .map_err(|e| e.to_string()),
        Target::Serialized => {
            let first = crate::geometry::parse_serialized(bytes, 0).map(drop);
            let second = crate::geometry::parse_serialized(bytes, 1).map(drop);
            first.and(second).map_err(|e| e.to_string())
        }
        Target::Vol => crate::medium::parse_vol(bytes).map(drop),
        Target::Curve => fuzz_curve(bytes),
        Target::Hdr => decode_image(bytes, "hdr").map(drop).map_err(|e| e.0),
        Target::Pfm => decode_image(bytes, "pfm").map(drop).map_err(|e| e.0),
        Target::Exr => {
            let render = crate::render_file::RenderFile::decode(bytes).map(drop);
            let image = decode_image(bytes, "exr").map(drop).map_err(|e| e.0);
            render.and(image)
        }
        Target::Png => decode_image(bytes, "png").map(drop).map_err(|e| e.0),
        Target::Jpeg => decode_image(bytes, "jpg").map(drop).map_err(|e| e.0),
        Target::Bmp => decode_image(bytes, "bmp").map(drop).map_err(|e| e.0),
    }
}

/// Reads `bytes` as a curve file of both bases and sends rays at the
/// first segments of each (the intersectors must stay finite and bounded
/// on whatever radii and shapes a file holds).
fn fuzz_curve(bytes: &[u8]) -> Result<(), String> {
    use crate::geometry::{Curve, CurveBasis};
    use crate::math::{Transform, Vec3};
    let text = String::from_utf8_lossy(bytes);
    let mut result = Ok(());
    for basis in [CurveBasis::Linear, CurveBasis::BSpline] {
        let curve = match Curve::parse(&text, basis, &Transform::IDENTITY) {
            Ok(c) => c,
            Err(e) => {
                result = Err(e.to_string());
                continue;
            }
        };
        let b = curve.bounds();
        let (centre, reach) = (b.center(), b.diagonal().length() + 1.0);
        for s in 0..curve.segment_count().min(64) {
            let seg = curve.segment(s);
            for d in [Vec3::X, Vec3::Y, Vec3::Z, Vec3::ONE.normalize(), -Vec3::X] {
                if let Some((t, v)) = seg.intersect(centre - reach * d, d, 0.0, f32::INFINITY) {
                    assert!(t.is_finite() && (0.0..=1.0).contains(&v), "{t} {v}");
                }
            }
        }
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_target_has_a_name_that_finds_it() {
        for t in Target::ALL {
            assert_eq!(Target::from_name(t.name()), Some(t));
        }
        assert_eq!(Target::from_name("tga"), None);
    }

    #[test]
    fn repository_files_load_through_their_targets() {
        let root = repo_root();
        let cases = [
            (Target::MitsubaScene, "scenes/mitsuba/cbox.xml"),
            (Target::NoriScene, "scenes/cbox/cbox.xml"),
            (Target::NoriTest, "tests/scenes/chi2test-diffuse.xml"),
            (Target::Obj, "scenes/cbox/floor.obj"),
            (Target::Ply, "scenes/mitsuba/gem.ply"),
            (Target::Serialized, "tests/conformance/gems.serialized"),
            (Target::Vol, "tests/conformance/smoke.vol"),
            (Target::Vol, "tests/conformance/tint.vol"),
            (Target::Curve, "tests/conformance/wave.txt"),
            (Target::Curve, "tests/conformance/polyline.txt"),
            (Target::Pfm, "scenes/mitsuba/sky.pfm"),
            (Target::Bmp, "fuzz/seeds/bmp/small.bmp"),
            (Target::Bmp, "fuzz/seeds/bmp/palette.bmp"),
        ];
        for (target, file) in cases {
            let bytes = std::fs::read(root.join(file)).unwrap();
            run(target, &bytes).unwrap_or_else(|e| panic!("{file}: {e}"));
        }
        let render_file = std::fs::read(root.join("fuzz/seeds/exr/render_file.exr")).unwrap();
        run(Target::Exr, &render_file).unwrap();
        assert!(run(Target::Exr, b"not an exr").is_err());
        assert!(run(Target::NoriScene, b"<scene>\xff</scene>").is_err());
    }
}
