//! Bad scene files: every error and warning names the file, the right line
//! and column, and what went wrong; no input makes the loader panic.

use std::path::{Path, PathBuf};

use tempfile::TempDir;

use lente::load::{load_scene, load_scene_str, SceneError, Warning};

/// Writes `text` as scene.xml in a fresh folder (kept while the TempDir lives).
fn write_scene(text: &str) -> (TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scene.xml");
    std::fs::write(&path, text).unwrap();
    (dir, path)
}

/// Loads the scene from disk and checks the error's position and words.
#[track_caller]
fn assert_error(name: &str, text: &str, line: u32, col: u32, words: &[&str]) -> SceneError {
    let (_dir, path) = write_scene(text);
    let e = match load_scene(&path) {
        Ok(_) => panic!("scene '{name}' should not load"),
        Err(e) => e,
    };
    // With its causes: a missing file's name is in the I/O error.
    let msg = e.report();
    let prefix = format!("{}:{line}:{col}: ", path.display());
    assert!(
        msg.starts_with(&prefix),
        "expected '{prefix}...', got '{msg}'"
    );
    assert_eq!((e.line, e.col), (line, col), "{msg}");
    assert_eq!(e.file, path);
    for w in words {
        assert!(msg.contains(w), "'{msg}' should mention '{w}'");
    }
    e
}

/// Loads the scene and checks that exactly one warning matches.
#[track_caller]
fn assert_warning(name: &str, text: &str, line: u32, col: u32, words: &[&str]) -> Warning {
    let (_dir, path) = write_scene(text);
    let (_, warnings) = match load_scene(&path) {
        Ok(r) => r,
        Err(e) => panic!("scene '{name}' should load, got {e}"),
    };
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    let w = warnings.into_iter().next().unwrap();
    let msg = w.to_string();
    let prefix = format!("{}:{line}:{col}: warning: ", path.display());
    assert!(
        msg.starts_with(&prefix),
        "expected '{prefix}...', got '{msg}'"
    );
    for word in words {
        assert!(msg.contains(word), "'{msg}' should mention '{word}'");
    }
    w
}

#[test]
fn malformed_xml_mismatched_close_tag() {
    let scene = r#"<scene>
    <integrator type="normals"/>
    <camera type="perspective">
        <float name="fov" value="40"/>
    <mesh type="sphere"/>
</scene>
"#;
    assert_error(
        "unclosed",
        scene,
        6,
        1,
        &["malformed XML", "</scene>", "<camera> (opened at 3:5)"],
    );
}

#[test]
fn malformed_xml_unclosed_at_end_of_file() {
    let scene = r#"<scene>
    <integrator type="normals"/>
    <camera type="perspective">
        <float name="fov" value="40"/>
"#;
    assert_error("unclosed-eof", scene, 3, 5, &["<camera>", "never closed"]);
}

#[test]
fn malformed_xml_unquoted_attribute() {
    let scene = r#"<scene>
    <integrator type="normals"/>
    <camera type=perspective/>
</scene>
"#;
    assert_error("unquoted", scene, 3, 18, &["malformed XML", "quote"]);
}

#[test]
fn unknown_tag() {
    let scene = r#"<scene>
    <integrator type="normals"/>
    <camera type="perspective">
        <flaot name="fov" value="40"/>
    </camera>
</scene>
"#;
    assert_error(
        "unknown-tag",
        scene,
        4,
        9,
        &["unknown element <flaot>", "did you mean <float>"],
    );
}

#[test]
fn unknown_type() {
    let scene = r#"<scene>
    <integrator type="path_foo"/>
    <camera type="perspective"/>
</scene>
"#;
    assert_error(
        "unknown-type",
        scene,
        2,
        23,
        &[
            "unknown <integrator> type 'path_foo'",
            "path_mis",
            "normals",
        ],
    );
}

#[test]
fn unknown_property_is_a_warning_with_a_suggestion() {
    let scene = r#"<scene>
    <integrator type="normals"/>
    <camera type="perspective">
        <float name="fvo" value="40"/>
    </camera>
</scene>
"#;
    assert_warning(
        "unknown-property",
        scene,
        4,
        9,
        &[
            "unused property 'fvo' of <camera type=\"perspective\">",
            "did you mean 'fov'",
        ],
    );
}

#[test]
fn unknown_property_far_from_any_name_has_no_suggestion() {
    let scene = r#"<scene>
    <integrator type="path_mis">
        <integer name="samples" value="4"/>
    </integrator>
    <camera type="perspective"/>
</scene>
"#;
    let w = assert_warning(
        "unknown-property-2",
        scene,
        3,
        9,
        &["unused property 'samples'"],
    );
    assert!(!w.message.contains("did you mean"), "{w}");
}

#[test]
fn duplicate_property_is_a_warning_and_the_last_wins() {
    let scene = r#"<scene>
    <integrator type="normals"/>
    <camera type="perspective">
        <float name="fov" value="40"/>
        <float name="fov" value="50"/>
    </camera>
</scene>
"#;
    assert_warning(
        "duplicate",
        scene,
        5,
        9,
        &["'fov'", "more than once", "4:9"],
    );
    let (desc, _) = load_scene_str(scene, Path::new("dup.xml")).unwrap();
    assert_eq!(desc.scene.camera.fov_x_deg, 50.0);
}

#[test]
fn wrong_property_type() {
    let scene = r#"<scene>
    <integrator type="normals"/>
    <camera type="perspective">
        <string name="fov" value="40"/>
    </camera>
</scene>
"#;
    assert_error(
        "wrong-type",
        scene,
        4,
        9,
        &["'fov'", "must be a <float>", "given as a <string>"],
    );
}

#[test]
fn float_where_an_integer_is_read() {
    let scene = r#"<scene>
    <integrator type="normals"/>
    <camera type="perspective">
        <float name="width" value="640"/>
    </camera>
</scene>
"#;
    assert_error(
        "float-for-int",
        scene,
        4,
        9,
        &["'width'", "<integer>", "<float>"],
    );
}

#[test]
fn wrong_count_of_numbers() {
    let scene = r#"<scene>
    <integrator type="normals"/>
    <camera type="perspective"/>
    <mesh type="sphere">
        <point name="center" value="1, 2"/>
    </mesh>
</scene>
"#;
    assert_error(
        "wrong-count",
        scene,
        5,
        37,
        &["expected 3 numbers, found 2"],
    );
}

#[test]
fn bad_number_token() {
    let scene = r#"<scene>
    <integrator type="normals"/>
    <camera type="perspective"/>
    <mesh type="sphere">
        <bsdf type="diffuse">
            <color name="albedo" value="0.5, 0.5x,
                                        0.5"/>
        </bsdf>
    </mesh>
</scene>
"#;
    assert_error("bad-token", scene, 6, 46, &["'0.5x'", "number"]);
}

#[test]
fn bad_token_on_a_continuation_line() {
    let scene = r#"<scene>
    <integrator type="normals"/>
    <camera type="perspective"/>
    <mesh type="sphere">
        <point name="center" value="1
                                    two 3"/>
    </mesh>
</scene>
"#;
    assert_error("bad-token-2", scene, 6, 37, &["'two'"]);
}

#[test]
fn bad_integer_and_boolean() {
    let scene = r#"<scene>
    <integrator type="path_mis">
        <integer name="maxDepth" value="4.5"/>
    </integrator>
    <camera type="perspective"/>
</scene>
"#;
    assert_error("bad-int", scene, 3, 41, &["'4.5'", "integer"]);
    let scene = r#"<scene>
    <integrator type="normals"/>
    <camera type="thinlens">
        <boolean name="autofocus" value="yes"/>
    </camera>
</scene>
"#;
    assert_error("bad-bool", scene, 4, 42, &["true or false", "'yes'"]);
}

#[test]
fn missing_mesh_file_names_the_path() {
    let scene = r#"<scene>
    <integrator type="normals"/>
    <camera type="perspective"/>
    <mesh type="obj">
        <string name="filename" value="meshes/missing.obj"/>
    </mesh>
</scene>
"#;
    let (_dir, path) = write_scene(scene);
    let tried = path.parent().unwrap().join("meshes/missing.obj");
    let e = load_scene(&path).unwrap_err();
    assert_eq!((e.line, e.col), (5, 40), "at the file name: {e}");
    assert!(
        e.report().contains(&tried.display().to_string()),
        "{e} should name {}",
        tried.display()
    );
}

#[test]
fn bsdf_at_scene_level() {
    let scene = r#"<scene>
    <integrator type="normals"/>
    <camera type="perspective"/>
    <bsdf type="diffuse"/>
</scene>
"#;
    assert_error(
        "bsdf-at-scene",
        scene,
        4,
        5,
        &[
            "<bsdf type=\"diffuse\"> cannot stand inside <scene>",
            "<mesh>",
        ],
    );
}

#[test]
fn two_cameras() {
    let scene = r#"<scene>
    <integrator type="normals"/>
    <camera type="perspective"/>
      <camera type="perspective"/>
</scene>
"#;
    assert_error("two-cameras", scene, 4, 7, &["only one <camera>", "3:5"]);
}

#[test]
fn objects_where_they_may_not_stand() {
    let rfilter_in_mesh = r#"<scene>
    <integrator type="normals"/>
    <camera type="perspective"/>
    <mesh type="sphere">
        <rfilter type="box"/>
    </mesh>
</scene>
"#;
    assert_error(
        "rfilter-in-mesh",
        rfilter_in_mesh,
        5,
        9,
        &["<rfilter", "<camera>"],
    );
    let two_bsdfs = r#"<scene>
    <integrator type="normals"/>
    <camera type="perspective"/>
    <mesh type="sphere">
        <bsdf type="diffuse"/>
        <bsdf type="mirror"/>
    </mesh>
</scene>
"#;
    assert_error("two-bsdfs", two_bsdfs, 6, 9, &["only one <bsdf>", "5:9"]);
    let point_in_mesh = r#"<scene>
    <integrator type="normals"/>
    <camera type="perspective"/>
    <mesh type="sphere">
        <emitter type="point">
            <point name="position" value="0 0 0"/>
            <color name="power" value="1"/>
        </emitter>
    </mesh>
</scene>
"#;
    assert_error(
        "point-in-mesh",
        point_in_mesh,
        5,
        9,
        &["point", "only area emitters"],
    );
    let area_at_scene = r#"<scene>
    <integrator type="normals"/>
    <camera type="perspective"/>
    <emitter type="area">
        <color name="radiance" value="1"/>
    </emitter>
</scene>
"#;
    assert_error(
        "area-at-scene",
        area_at_scene,
        4,
        5,
        &["area emitter", "<mesh>"],
    );
    let op_outside_transform = r#"<scene>
    <integrator type="normals"/>
    <camera type="perspective">
        <translate value="1 2 3"/>
    </camera>
</scene>
"#;
    assert_error(
        "op-outside",
        op_outside_transform,
        4,
        9,
        &["<translate>", "<transform>"],
    );
    let property_in_transform = r#"<scene>
    <integrator type="normals"/>
    <camera type="perspective">
        <transform name="toWorld">
            <float name="fov" value="3"/>
        </transform>
    </camera>
</scene>
"#;
    assert_error(
        "prop-in-transform",
        property_in_transform,
        5,
        13,
        &["<transform> may only contain"],
    );
}

#[test]
fn lens_radius_without_focal_distance() {
    let scene = r#"<scene>
    <integrator type="normals"/>
    <camera type="thinlens">
        <float name="lensRadius" value="0.1"/>
    </camera>
</scene>
"#;
    assert_error(
        "lens-no-focus",
        scene,
        3,
        5,
        &["focalDistance", "autofocus", "lensRadius"],
    );
}

#[test]
fn negative_lens_radius() {
    let scene = r#"<scene>
    <integrator type="normals"/>
    <camera type="thinlens">
        <float name="focalDistance" value="3"/>
        <float name="lensRadius" value="-0.1"/>
    </camera>
</scene>
"#;
    assert_error(
        "negative-lens",
        scene,
        5,
        41,
        &["lensRadius", "negative", "-0.1"],
    );
}

#[test]
fn two_aperture_blades() {
    let scene = r#"<scene>
    <integrator type="normals"/>
    <camera type="thinlens">
        <float name="focalDistance" value="3"/>
        <float name="lensRadius" value="0.1"/>
        <integer name="apertureBlades" value="2"/>
    </camera>
</scene>
"#;
    assert_error("two-blades", scene, 6, 47, &["apertureBlades", "found 2"]);
}

#[test]
fn missing_camera() {
    let scene = r#"<?xml version="1.0" encoding="utf-8"?>
<scene>
    <integrator type="normals"/>
</scene>
"#;
    assert_error("no-camera", scene, 2, 1, &["no <camera>"]);
}

#[test]
fn missing_integrator() {
    let scene = r#"<!-- a comment -->
  <scene>
    <camera type="perspective"/>
</scene>
"#;
    assert_error("no-integrator", scene, 2, 3, &["no <integrator>"]);
}

#[test]
fn non_finite_and_out_of_range_numbers() {
    let fov = r#"<scene>
    <integrator type="normals"/>
    <camera type="perspective">
        <float name="fov" value="inf"/>
    </camera>
</scene>
"#;
    assert_error("inf-fov", fov, 4, 34, &["'fov'", "finite"]);
    let fov = r#"<scene>
    <integrator type="normals"/>
    <camera type="perspective">
        <float name="fov" value="180"/>
    </camera>
</scene>
"#;
    assert_error("wide-fov", fov, 4, 34, &["'fov'", "180"]);
    let radius = r#"<scene>
    <integrator type="normals"/>
    <camera type="perspective"/>
    <mesh type="sphere">
        <float name="radius" value="0"/>
    </mesh>
</scene>
"#;
    assert_error("zero-radius", radius, 5, 37, &["'radius'", "positive"]);
    let radiance = r#"<scene>
    <integrator type="normals"/>
    <camera type="perspective"/>
    <mesh type="sphere">
        <emitter type="area">
            <color name="radiance" value="1 -1 1"/>
        </emitter>
    </mesh>
</scene>
"#;
    assert_error(
        "negative-radiance",
        radiance,
        6,
        43,
        &["'radiance'", "negative"],
    );
    let width = r#"<scene>
    <integrator type="normals"/>
    <camera type="perspective">
        <integer name="width" value="0"/>
    </camera>
</scene>
"#;
    assert_error("zero-width", width, 4, 38, &["'width'", "found 0"]);
}

#[test]
fn albedo_above_one_is_a_warning() {
    let scene = r#"<scene>
    <integrator type="normals"/>
    <camera type="perspective"/>
    <mesh type="sphere">
        <bsdf type="diffuse">
            <color name="albedo" value="1.2 0.5 0.5"/>
        </bsdf>
    </mesh>
</scene>
"#;
    assert_warning("bright-albedo", scene, 6, 41, &["albedo", "above 1"]);
}

#[test]
fn missing_required_property() {
    let scene = r#"<scene>
    <integrator type="normals"/>
    <camera type="perspective"/>
    <emitter type="point">
        <point name="position" value="0 1 0"/>
    </emitter>
</scene>
"#;
    assert_error("no-power", scene, 4, 5, &["'power'"]);
}

#[test]
fn unexpected_and_missing_attributes() {
    let scene = r#"<scene>
    <integrator type="normals"/>
    <camera type="perspective" id="cam"/>
</scene>
"#;
    assert_error("extra-attr", scene, 3, 32, &["unexpected attribute 'id'"]);
    let scene = r#"<scene>
    <integrator type="normals"/>
    <camera type="perspective">
        <float name="fov"/>
    </camera>
</scene>
"#;
    assert_error("no-value", scene, 4, 9, &["'value'"]);
    let scene = r#"<scene>
    <integrator/>
    <camera type="perspective"/>
</scene>
"#;
    assert_error("no-type", scene, 2, 5, &["'type'", "path_mis"]);
}

#[test]
fn transform_errors() {
    let lookat = r#"<scene>
    <integrator type="normals"/>
    <camera type="perspective">
        <transform name="toWorld">
            <lookat origin="0 0 0" target="0 1 0" up="0 1 0"/>
        </transform>
    </camera>
</scene>
"#;
    assert_error("bad-lookat", lookat, 5, 13, &["up", "parallel"]);
    let matrix = r#"<scene>
    <integrator type="normals"/>
    <camera type="perspective">
        <transform name="toWorld">
            <matrix value="1 0 0 0  0 1 0 0  1 1 0 0  0 0 0 1"/>
        </transform>
    </camera>
</scene>
"#;
    assert_error("singular-matrix", matrix, 5, 13, &["singular"]);
    let short = r#"<scene>
    <integrator type="normals"/>
    <camera type="perspective">
        <transform name="toWorld">
            <matrix value="1 0 0 0"/>
        </transform>
    </camera>
</scene>
"#;
    assert_error(
        "short-matrix",
        short,
        5,
        28,
        &["needs 16 numbers (4x4), found 4"],
    );
    let sphere = r#"<scene>
    <integrator type="normals"/>
    <camera type="perspective"/>
    <mesh type="sphere">
        <transform name="toWorld">
            <scale value="1 2 1"/>
        </transform>
    </mesh>
</scene>
"#;
    assert_error("stretched-sphere", sphere, 5, 9, &["similarity"]);
}

#[test]
fn environment_errors() {
    let missing = r#"<scene>
    <integrator type="path_mis"/>
    <camera type="perspective"/>
    <emitter type="envmap">
        <string name="filename" value="probe.exr"/>
    </emitter>
</scene>
"#;
    let (_dir, path) = write_scene(missing);
    let e = load_scene(&path).unwrap_err();
    assert_eq!((e.line, e.col), (5, 40), "at the file name: {e}");
    let tried = path.parent().unwrap().join("probe.exr");
    assert!(e.report().contains(&tried.display().to_string()), "{e}");

    let two = r#"<scene>
    <integrator type="path_mis"/>
    <camera type="perspective"/>
    <emitter type="constant">
        <color name="radiance" value="1"/>
    </emitter>
    <emitter type="sky">
        <integer name="resolution" value="16"/>
    </emitter>
</scene>
"#;
    assert_error(
        "two-environments",
        two,
        7,
        5,
        &["at most one environment", "4:5"],
    );
    let filter = r#"<scene>
    <integrator type="path_mis"/>
    <camera type="perspective"/>
    <emitter type="envmap">
        <string name="filename" value="probe.exr"/>
        <string name="filter" value="cubic"/>
    </emitter>
</scene>
"#;
    assert_error(
        "env-filter",
        filter,
        6,
        38,
        &["'cubic'", "bilinear", "nearest"],
    );
}

#[test]
fn other_roots() {
    // A version attribute selects the Mitsuba dialect.
    assert_error(
        "mitsuba",
        "<!-- m -->\n<scene version=\"3.0.0\">\n<camera type=\"perspective\"/>\n<shape type=\"sphere\"/>\n</scene>\n",
        3,
        1,
        &["<camera>", "Mitsuba writes <sensor>"],
    );
    assert_error(
        "test-root",
        "<test type=\"ttest\">\n</test>\n",
        1,
        1,
        &["expected <scene>", "<test>"],
    );
}

#[test]
fn unreadable_file_has_no_position() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("nope.xml");
    let e = load_scene(&path).unwrap_err();
    assert_eq!((e.line, e.col), (0, 0));
    assert!(e
        .to_string()
        .starts_with(&format!("{}:0:0: ", path.display())));
}

#[test]
fn invalid_utf8_is_located() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scene.xml");
    std::fs::write(&path, b"<scene>\n  <camera type=\"\xff\"/>\n</scene>\n").unwrap();
    let e = load_scene(&path).unwrap_err();
    assert_eq!((e.line, e.col), (2, 17), "{e}");
    assert!(
        e.message.contains("the scene file is not valid UTF-8"),
        "{e}"
    );
}

#[test]
fn nori_test_files_share_the_scene_reader_errors() {
    use lente::load::nori_testfile::load_test;
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("test.xml");
    std::fs::write(&path, b"<test type=\"ttest\">\n\n  <x\xc3/>\n</test>\n").unwrap();
    let e = load_test(&path).unwrap_err();
    assert_eq!((e.line, e.col), (3, 5), "{e}");
    assert!(
        e.message.contains("the test file is not valid UTF-8"),
        "{e}"
    );
    let e = load_test(&dir.path().join("missing.xml")).unwrap_err();
    assert_eq!(e.message, "cannot read the test file", "{e}");
    assert!(
        e.cause.as_ref().is_some_and(|c| c.is::<std::io::Error>()),
        "the I/O error is kept as the cause: {e:?}"
    );
}

/// A valid scene that touches every part of the dialect.
const RICH_SCENE: &str = r#"<?xml version="1.0"?>
<scene>
    <integrator type="path_mis">
        <integer name="maxDepth" value="8"/>
        <integer name="rrDepth" value="4"/>
    </integrator>
    <sampler type="independent">
        <integer name="sampleCount" value="16"/>
    </sampler>
    <camera type="thinlens">
        <transform name="toWorld">
            <scale value="-1,1,1"/>
            <lookat origin="0, 1, 5" target="0 0 0" up="0,1,0"/>
            <rotate axis="0 1 0" angle="10"/>
            <translate value="0.1 0 0"/>
        </transform>
        <float name="fov" value="35"/>
        <integer name="width" value="64"/>
        <integer name="height" value="48"/>
        <float name="lensRadius" value="0.05"/>
        <float name="focalDistance" value="5"/>
        <integer name="apertureBlades" value="6"/>
        <float name="apertureRotation" value="15"/>
        <rfilter type="mitchell">
            <float name="B" value="0.3"/>
        </rfilter>
    </camera>
    <mesh type="obj">
        <string name="filename" value="tri.obj"/>
        <transform name="toWorld">
            <matrix value="1 0 0 0
                           0 1 0 0
                           0 0 1 0
                           0 0 0 1"/>
        </transform>
        <bsdf type="dielectric">
            <float name="intIOR" value="1.33"/>
        </bsdf>
    </mesh>
    <mesh type="sphere">
        <point name="center" value="0 1 0"/>
        <float name="radius" value="0.5"/>
        <bsdf type="diffuse">
            <color name="albedo" value="0.2, 0.4, 0.6"/>
        </bsdf>
        <emitter type="area">
            <color name="radiance" value="4"/>
        </emitter>
    </mesh>
    <emitter type="point">
        <point name="position" value="0 3 0"/>
        <color name="power" value="10 10 10"/>
    </emitter>
    <emitter type="sky">
        <float name="turbidity" value="4"/>
        <integer name="resolution" value="16"/>
        <boolean name="visible" value="false"/>
    </emitter>
</scene>
"#;

const TRI_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

#[test]
fn random_mutations_never_panic() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("tri.obj"), TRI_OBJ).unwrap();
    let path = dir.path().join("scene.xml");
    let (_, warnings) = load_scene_str(RICH_SCENE, &path).expect("the base scene must load");
    assert!(warnings.is_empty(), "{warnings:?}");

    crate::mutation::loads_or_fails_located(
        RICH_SCENE,
        "<>/=\"' ,.-+e0123456789\n\t&;!?xyzé\u{0}\u{feff}",
        0x5EED_1E47,
        |text| load_scene_str(text, &path),
    );
}
