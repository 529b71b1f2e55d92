//! Mitsuba 3 scenes: defaults, sensors, references, parameters, includes,
//! values, transforms, error positions and the shipped scenes (shapes,
//! PLY files, emitters, integrators and BSDFs: `mitsuba_objects`).

use std::path::{Path, PathBuf};

use lente::bsdf::Bsdf;
use lente::camera::Camera;
use lente::color::Rgb;
use lente::emitter::Emitter;
use lente::geometry::{Geometry, TriangleMesh};
use lente::image::Filter;
use lente::integrator::{Integrator, PathParams, Strategy};
use lente::load::SceneFile;
use lente::load::{load_scene, load_scene_str_with, load_scene_with, SceneError, Warning};
use lente::math::{Mat4, Transform, Vec2, Vec3, PI};
use lente::sampling::SamplerKind;

use crate::common::{load, load_clean, load_err};

/// [`crate::common::load_at`] `test.xml` with `-D` parameters.
#[track_caller]
pub(crate) fn load_with(text: &str, defines: &[(&str, &str)]) -> (SceneFile, Vec<Warning>) {
    crate::common::load_at(text, Path::new(crate::common::TEST_XML), defines)
}

/// The error must be at line:col and mention every word.
#[track_caller]
pub(crate) fn assert_err(text: &str, line: u32, col: u32, words: &[&str]) {
    let e = load_err(text);
    // With its causes: a missing file's name is in the I/O error.
    let msg = e.report();
    assert!(
        msg.starts_with(&format!("test.xml:{line}:{col}: ")),
        "expected test.xml:{line}:{col}, got {msg}"
    );
    for w in words {
        assert!(msg.contains(w), "'{msg}' should mention '{w}'");
    }
}

#[track_caller]
pub(crate) fn close(a: Vec3, b: Vec3) {
    assert!((a - b).length() < 1e-4, "{a} != {b}");
}

#[track_caller]
pub(crate) fn close_f(a: f32, b: f32, tol: f32) {
    assert!((a - b).abs() <= tol, "{a} != {b}");
}

/// A scene with an integrator and a shape around the given sensor.
pub(crate) fn with_sensor(sensor: &str) -> String {
    format!(
        "<scene version=\"3.0.0\">\n<integrator type=\"path\"/>\n{sensor}\n<shape type=\"sphere\"/>\n</scene>\n"
    )
}

/// A scene with a sensor and integrator around the given body.
pub(crate) fn scene(body: &str) -> String {
    format!(
        "<scene version=\"3.0.0\">\n<integrator type=\"path\"/>\n<sensor type=\"perspective\"/>\n{body}\n</scene>\n"
    )
}

pub(crate) fn mesh(desc: &SceneFile, i: usize) -> &TriangleMesh {
    match &desc.scene.shapes[i].geometry {
        Geometry::Mesh(m) => m,
        g => panic!("shape {i} is not a mesh: {g:?}"),
    }
}

// ---------------------------------------------------------------------------
// Defaults
// ---------------------------------------------------------------------------

#[test]
fn minimal_scene_gets_mitsubas_defaults() {
    let desc = load_clean(&with_sensor("<sensor type=\"perspective\"/>"));
    let c = &desc.scene.camera;
    assert_eq!((c.width, c.height), (768, 576));
    assert_eq!(desc.job.spp, 4);
    assert_eq!(
        desc.job.filter,
        Filter::Gaussian {
            radius: 2.0,
            stddev: 0.5
        }
    );
    assert_eq!((c.near_clip, c.far_clip), (0.01, 10000.0));
    assert_eq!(c.lens_radius, 0.0);
    assert_eq!(c.to_world, Transform::IDENTITY);
    // focal_length 50mm on 35 mm film, along the diagonal.
    let diag_fov = 2.0 * (43.266615f64 / 100.0).atan();
    let aspect = 768.0f64 / 576.0;
    let w = 2.0 * (diag_fov / 2.0).tan() / (1.0 + 1.0 / (aspect * aspect)).sqrt();
    close_f(
        c.fov_x_deg,
        (2.0 * (w / 2.0).atan()).to_degrees() as f32,
        1e-3,
    );
    assert_eq!(
        desc.job.integrator,
        Integrator::Path {
            strategy: Strategy::Mis,
            params: PathParams {
                max_depth: None,
                rr_depth: 5,
                hide_emitters: false
            }
        }
    );
    // A sphere with Mitsuba's defaults and the default BSDF.
    match &desc.scene.shapes[0].geometry {
        Geometry::Sphere(s) => assert_eq!((s.center, s.radius), (Vec3::ZERO, 1.0)),
        g => panic!("{g:?}"),
    }
    assert_eq!(
        desc.scene.shapes[0].bsdf,
        Bsdf::Diffuse(lente::bsdf::Diffuse {
            albedo: Rgb::splat(0.5)
        })
    );
}

#[test]
fn missing_sensor_and_integrator_use_mitsubas_defaults() {
    let (desc, warnings) = load(
        "<scene version=\"2.1.0\">\n<shape type=\"cube\"><transform name=\"to_world\"><translate z=\"3\"/></transform></shape>\n</scene>",
    );
    assert_eq!(warnings.len(), 2, "{warnings:?}");
    assert!(warnings[0].message.contains("no <sensor>"));
    assert!(warnings[1].message.contains("no <integrator>"));
    let c = &desc.scene.camera;
    assert_eq!(c.fov_x_deg, 45.0);
    // The box [-1,1]^2 x [2,4]: distance = 2 / (2 tan 22.5 deg).
    let distance = 1.0 / 22.5f32.to_radians().tan();
    close(
        c.to_world.point(Vec3::ZERO),
        Vec3::new(0.0, 0.0, 2.0 - distance),
    );
    close(c.to_world.vector(Vec3::Z), Vec3::Z);
    close_f(c.near_clip, distance / 100.0, 1e-5);
    assert!(matches!(
        desc.job.integrator,
        Integrator::Path {
            params: PathParams {
                rr_depth: 5,
                max_depth: None,
                ..
            },
            ..
        }
    ));
    // An empty scene loads too (Mitsuba renders it black).
    let (desc, _) = load("<!-- m -->\n<scene version=\"3.0.0\">\n</scene>\n");
    assert!(desc.scene.shapes.is_empty());
}

// ---------------------------------------------------------------------------
// Sensors
// ---------------------------------------------------------------------------

fn fov_x(sensor_body: &str, w: u32, h: u32) -> f32 {
    let s = format!(
        "<sensor type=\"perspective\">{sensor_body}<film type=\"hdrfilm\"><integer name=\"width\" value=\"{w}\"/><integer name=\"height\" value=\"{h}\"/></film></sensor>"
    );
    load_clean(&with_sensor(&s)).scene.camera.fov_x_deg
}

/// `--resolution` with another shape keeps the field of view along the
/// file's `fov_axis`: the camera equals the one the file would give with
/// that film size (Mitsuba's behaviour when its film is resized).
#[test]
fn a_new_resolution_keeps_the_view_along_fov_axis() {
    let body = |axis: &str| {
        format!("<float name=\"fov\" value=\"40\"/><string name=\"fov_axis\" value=\"{axis}\"/>")
    };
    for axis in ["x", "y", "diagonal", "smaller", "larger"] {
        let s = format!(
            "<sensor type=\"perspective\">{}<film type=\"hdrfilm\"><integer name=\"width\" value=\"800\"/><integer name=\"height\" value=\"400\"/></film></sensor>",
            body(axis)
        );
        let mut camera = load_clean(&with_sensor(&s)).scene.camera;
        for (w, h) in [(300, 600), (500, 500), (1000, 250)] {
            camera.set_resolution(w, h);
            close_f(camera.fov_x_deg, fov_x(&body(axis), w, h), 1e-4);
            assert_eq!((camera.width, camera.height), (w, h));
        }
    }
    // focal_length spans the diagonal.
    let f = "<string name=\"focal_length\" value=\"35mm\"/>";
    let s = format!(
        "<sensor type=\"perspective\">{f}<film type=\"hdrfilm\"><integer name=\"width\" value=\"1500\"/><integer name=\"height\" value=\"1000\"/></film></sensor>"
    );
    let mut camera = load_clean(&with_sensor(&s)).scene.camera;
    camera.set_resolution(400, 800);
    close_f(camera.fov_x_deg, fov_x(f, 400, 800), 1e-4);
}

#[test]
fn fov_axes_convert_to_the_horizontal_fov() {
    let fov = |axis: &str, w, h| {
        fov_x(
            &format!(
                "<float name=\"fov\" value=\"40\"/><string name=\"fov_axis\" value=\"{axis}\"/>"
            ),
            w,
            h,
        )
    };
    let t20 = 20.0f64.to_radians().tan();
    let deg = |x: f64| x.to_degrees() as f32;
    // 800 x 400: aspect 2.
    close_f(fov("x", 800, 400), 40.0, 1e-4);
    close_f(fov("y", 800, 400), deg(2.0 * (t20 * 2.0).atan()), 1e-4);
    let diag_w = 2.0 * t20 / (1.0f64 + 0.25).sqrt();
    close_f(
        fov("diagonal", 800, 400),
        deg(2.0 * (diag_w / 2.0).atan()),
        1e-4,
    );
    close_f(fov("smaller", 800, 400), fov("y", 800, 400), 1e-6);
    close_f(fov("larger", 800, 400), 40.0, 1e-6);
    // 300 x 600: aspect 1/2, so the smaller axis is x.
    close_f(fov("smaller", 300, 600), 40.0, 1e-6);
    close_f(fov("larger", 300, 600), deg(2.0 * (t20 * 0.5).atan()), 1e-4);
    close_f(fov("Y", 300, 600), deg(2.0 * (t20 * 0.5).atan()), 1e-4);
    // Square images: every axis but the diagonal is the same.
    close_f(fov("y", 500, 500), 40.0, 1e-4);
    // The default axis is x.
    close_f(
        fov_x("<float name=\"fov\" value=\"33\"/>", 640, 480),
        33.0,
        1e-6,
    );
    // focal_length, 35 mm film convention: 36 x 24 mm at aspect 1.5 gives
    // a horizontal fov of 2 atan(18 / f).
    let f35 = fov_x("<string name=\"focal_length\" value=\"35mm\"/>", 1500, 1000);
    close_f(f35, deg(2.0 * (18.0f64 / 35.0).atan()), 1e-3);
    close_f(
        fov_x("<string name=\"focal_length\" value=\"28\"/>", 1500, 1000),
        deg(2.0 * (18.0f64 / 28.0).atan()),
        1e-3,
    );
}

#[test]
fn fov_errors() {
    assert_err(
        &with_sensor("<sensor type=\"perspective\">\n  <float name=\"fov\" value=\"40\"/><string name=\"fov_axis\" value=\"z\"/></sensor>"),
        4,
        64,
        &["fov_axis", "'z'", "diagonal"],
    );
    assert_err(
        &with_sensor("<sensor type=\"perspective\"><float name=\"fov\" value=\"40\"/>\n<string name=\"focal_length\" value=\"20mm\"/></sensor>"),
        4,
        36,
        &["either 'fov' or 'focal_length'"],
    );
    assert_err(
        &with_sensor(
            "<sensor type=\"perspective\"><string name=\"focal_length\" value=\"fifty\"/></sensor>",
        ),
        3,
        63,
        &["focal length", "fifty"],
    );
    assert_err(
        &with_sensor("<sensor type=\"perspective\"><float name=\"fov\" value=\"180\"/></sensor>"),
        3,
        53,
        &["between 0 and 180"],
    );
}

#[test]
fn thinlens_and_clip_planes() {
    let desc = load_clean(&with_sensor(
        r#"<sensor type="thinlens">
            <float name="fov" value="30"/>
            <float name="aperture_radius" value="0.2"/>
            <float name="focus_distance" value="7.5"/>
            <float name="near_clip" value="0.5"/>
            <float name="far_clip" value="200"/>
            <transform name="to_world"><lookat origin="1, 2, 3" target="1, 2, 0"/></transform>
        </sensor>"#,
    ));
    let c = &desc.scene.camera;
    assert_eq!((c.lens_radius, c.focal_distance), (0.2, 7.5));
    assert_eq!((c.near_clip, c.far_clip), (0.5, 200.0));
    close(c.to_world.point(Vec3::ZERO), Vec3::new(1.0, 2.0, 3.0));
    close(c.to_world.vector(Vec3::Z), Vec3::NEG_Z);
    // Mitsuba's thin lens focuses at far_clip unless told otherwise.
    let desc = load_clean(&with_sensor(
        "<sensor type=\"thinlens\"><float name=\"aperture_radius\" value=\"0.1\"/></sensor>",
    ));
    assert_eq!(desc.scene.camera.focal_distance, 10000.0);
    // aperture_radius is required.
    assert_err(
        &with_sensor("<sensor type=\"thinlens\"/>"),
        3,
        1,
        &["aperture_radius"],
    );
    // Scale in the camera transform is refused, as in Mitsuba; a mirror is not scale.
    assert_err(
        &with_sensor("<sensor type=\"perspective\"><transform name=\"to_world\"><scale value=\"2\"/></transform></sensor>"),
        3,
        28,
        &["scale", "to_world"],
    );
    load_clean(&with_sensor(
        "<sensor type=\"perspective\"><transform name=\"to_world\"><scale x=\"-1\"/></transform></sensor>",
    ));
    assert_err(
        &with_sensor(
            "<sensor type=\"perspective\"><float name=\"near_clip\" value=\"0\"/></sensor>",
        ),
        3,
        59,
        &["near_clip", "positive"],
    );
}

#[test]
fn mitsuba_camera_is_not_mirrored() {
    // Mitsuba's cbox camera: looking down -z from +z with up +y. The red
    // wall at x = -1 must land on the left of the image.
    let desc = load_clean(&with_sensor(
        r#"<sensor type="perspective">
            <float name="fov" value="40"/>
            <transform name="to_world"><lookat origin="0, 0, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
            <film type="hdrfilm"><integer name="width" value="100"/><integer name="height" value="100"/></film>
        </sensor>"#,
    ));
    let cam = Camera::new(desc.scene.camera.clone()).unwrap();
    let to_cam = desc.scene.camera.to_world.inverse();
    let left_wall = cam.camera_to_film(to_cam.point(Vec3::new(-0.9, 0.0, 0.0)));
    let ceiling = cam.camera_to_film(to_cam.point(Vec3::new(0.0, 0.9, 0.0)));
    assert!(left_wall.x < 50.0, "{left_wall}");
    assert!(ceiling.y < 50.0, "{ceiling}");
    // And the ray through the left half of the image goes towards -x.
    let r = cam.generate_ray(Vec2::new(10.0, 50.0), Vec2::ZERO);
    assert!(r.d.x < 0.0);
}

#[test]
fn films_filters_and_samplers() {
    let desc = load_clean(&with_sensor(
        r#"<sensor type="perspective">
            <film type="hdrfilm">
                <integer name="width" value="320"/>
                <integer name="height" value="200"/>
                <string name="pixel_format" value="rgba"/>
                <string name="component_format" value="float32"/>
                <string name="file_format" value="pfm"/>
                <rfilter type="box"/>
            </film>
            <sampler type="independent"><integer name="sample_count" value="17"/></sampler>
        </sensor>"#,
    ));
    assert_eq!(
        (desc.scene.camera.width, desc.scene.camera.height),
        (320, 200)
    );
    assert_eq!(desc.job.filter, Filter::Box { radius: 0.5 });
    assert_eq!(desc.job.spp, 17);
    let filter = |body: &str| {
        load_clean(&with_sensor(&format!(
            "<sensor type=\"perspective\"><film type=\"hdrfilm\">{body}</film></sensor>"
        )))
        .job
        .filter
    };
    assert_eq!(
        filter("<rfilter type=\"tent\"/>"),
        Filter::Tent { radius: 1.0 }
    );
    assert_eq!(
        filter("<rfilter type=\"gaussian\"><float name=\"stddev\" value=\"0.25\"/></rfilter>"),
        Filter::Gaussian {
            radius: 1.0,
            stddev: 0.25
        }
    );
    assert_eq!(
        filter("<rfilter type=\"mitchell\"/>"),
        Filter::Mitchell {
            radius: 2.0,
            b: 1.0 / 3.0,
            c: 1.0 / 3.0
        }
    );
    assert_eq!(
        filter("<rfilter type=\"lanczos\"/>"),
        Filter::Lanczos { radius: 3.0 }
    );
    assert_eq!(
        filter("<rfilter type=\"lanczos\"><integer name=\"lobes\" value=\"2\"/></rfilter>"),
        Filter::Lanczos { radius: 2.0 }
    );
    assert_eq!(
        filter("<rfilter type=\"catmullrom\"/>"),
        Filter::Mitchell {
            radius: 2.0,
            b: 0.0,
            c: 0.5
        }
    );
    // Mitsuba's stratified samplers get lente's stratified sampling, their
    // counts rounded as Mitsuba 3.9.1 rounds them (with a warning).
    let sampler = |ty: &str, n: u32| {
        load(&with_sensor(&format!(
            "<sensor type=\"perspective\"><sampler type=\"{ty}\"><integer name=\"sample_count\" value=\"{n}\"/></sampler></sensor>"
        )))
    };
    for (ty, n, want) in [
        ("independent", 10, 10),
        ("stratified", 16, 16),
        ("stratified", 10, 16),
        ("ldsampler", 20, 64),
        ("multijitter", 10, 12),
        ("orthogonal", 10, 25),
    ] {
        let (desc, w) = sampler(ty, n);
        assert_eq!(desc.job.spp, want, "{ty} {n}");
        let kind = if ty == "independent" {
            SamplerKind::Independent
        } else {
            SamplerKind::Stratified
        };
        assert_eq!(desc.job.sampler, kind);
        assert_eq!(w.len(), usize::from(n != want), "{w:?}");
        if n != want {
            assert!(w[0].message.contains(&format!("up to {want}")), "{w:?}");
        }
    }
    // Strata centres and orthogonal arrays of other strengths are not
    // rendered as Mitsuba renders them: a warning each.
    for (sampler, name) in [
        (
            "<sampler type=\"stratified\"><boolean name=\"jitter\" value=\"false\"/></sampler>",
            "jitter",
        ),
        (
            "<sampler type=\"orthogonal\"><integer name=\"strength\" value=\"3\"/></sampler>",
            "strength",
        ),
    ] {
        let (_, w) = load(&with_sensor(&format!(
            "<sensor type=\"perspective\">{sampler}</sensor>"
        )));
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(w[0].message.contains(name), "{w:?}");
    }
    // An unknown pixel format is a warning; crop windows are errors.
    let (_, w) = load(&with_sensor(
        "<sensor type=\"perspective\"><film type=\"hdrfilm\"><string name=\"pixel_format\" value=\"cmyk\"/></film></sensor>",
    ));
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(w[0].message.contains("cmyk"));
    assert_err(
        &with_sensor("<sensor type=\"perspective\"><film type=\"hdrfilm\"><integer name=\"crop_width\" value=\"10\"/></film></sensor>"),
        3,
        83,
        &["crop"],
    );
    assert_err(
        &with_sensor("<sensor type=\"perspective\"><film type=\"hdrfilm\"><rfilter type=\"lanczos\"><integer name=\"lobes\" value=\"0\"/></rfilter></film></sensor>"),
        3,
        102,
        &["lobes", "between 1 and 32"],
    );
}

// ---------------------------------------------------------------------------
// References, parameters, includes
// ---------------------------------------------------------------------------

#[test]
fn references_place_objects_where_they_stand() {
    let desc = load_clean(&scene(
        r#"<shape type="sphere"><ref id="red"/></shape>
           <bsdf type="diffuse" id="red"><rgb name="reflectance" value="0.8, 0.1, 0.1"/></bsdf>
           <shape type="sphere"><ref name="bsdf" id="red"/></shape>
           <alias id="red" as="crimson"/>
           <shape type="sphere"><ref id="crimson"/></shape>
           <texture type="srgb" id="tex"><rgb name="color" value="0.2, 0.3, 0.4"/></texture>
           <shape type="sphere"><bsdf type="diffuse"><ref name="reflectance" id="tex"/></bsdf></shape>
           <shape type="sphere"><bsdf type="diffuse"><texture type="uniform" name="reflectance"><float name="value" value="0.25"/></texture></bsdf></shape>
           <shape type="sphere"><bsdf type="diffuse"><float name="reflectance" value="0.75"/></bsdf></shape>"#,
    ));
    let red = Bsdf::Diffuse(lente::bsdf::Diffuse {
        albedo: Rgb::new(0.8, 0.1, 0.1),
    });
    assert_eq!(desc.scene.shapes.len(), 6);
    for s in &desc.scene.shapes[..3] {
        assert_eq!(s.bsdf, red);
    }
    let albedo = |i: usize| match &desc.scene.shapes[i].bsdf {
        Bsdf::Diffuse(lente::bsdf::Diffuse { albedo }) => *albedo,
        b => panic!("{b:?}"),
    };
    assert_eq!(albedo(3), Rgb::new(0.2, 0.3, 0.4));
    assert_eq!(albedo(4), Rgb::splat(0.25));
    assert_eq!(albedo(5), Rgb::splat(0.75));
}

#[test]
fn reference_errors() {
    assert_err(
        &scene(
            "<bsdf type=\"diffuse\" id=\"red\"/>\n<shape type=\"sphere\"><ref id=\"rde\"/></shape>",
        ),
        5,
        31,
        &["no object has the id 'rde'", "did you mean 'red'"],
    );
    assert_err(
        &scene("<bsdf type=\"diffuse\" id=\"a\"/>\n<bsdf type=\"diffuse\" id=\"a\"/>"),
        5,
        26,
        &["'a' is used twice", "first at 4:1"],
    );
    assert_err(
        &scene("<bsdf type=\"twosided\" id=\"loop\">\n<ref id=\"loop\"/></bsdf>\n<shape type=\"sphere\"><ref id=\"loop\"/></shape>"),
        5,
        1,
        &["reference to itself"],
    );
    assert_err(
        &scene("<shape type=\"sphere\"><bsdf type=\"diffuse\"><texture type=\"volume\" name=\"reflectance\"/></bsdf></shape>"),
        4,
        58,
        &["volume", "lente's textures: bitmap, checkerboard"],
    );
    assert_err(
        &scene("<shape type=\"sphere\"><bsdf type=\"diffuse\">\n<texture type=\"uniform\"/></bsdf></shape>"),
        5,
        1,
        &["needs a 'name'"],
    );
    // A long chain of references is an error, not a stack overflow.
    let mut chain = String::new();
    for i in 0..200 {
        chain.push_str(&format!(
            "<bsdf type=\"twosided\" id=\"b{i}\"><ref id=\"b{}\"/></bsdf>\n",
            i + 1
        ));
    }
    chain.push_str(
        "<bsdf type=\"diffuse\" id=\"b200\"/>\n<shape type=\"sphere\"><ref id=\"b0\"/></shape>",
    );
    let e = load_err(&scene(&chain));
    assert!(e.message.contains("nested more than"), "{e}");
}

#[test]
fn defaults_and_parameters() {
    let text = r#"<scene version="3.0.0">
    <default name="spp" value="16"/>
    <default name="res" value="64"/>
    <default name="resolution" value="$res"/>
    <integrator type="path"><integer name="max_depth" value="$depth"/></integrator>
    <sensor type="perspective">
        <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
        <film type="hdrfilm">
            <integer name="width" value="$resolution"/>
            <integer name="height" value="$res"/>
        </film>
    </sensor>
    <shape type="sphere"><float name="radius" value="$r\$"/></shape>
</scene>"#;
    // $depth and $r have no default: without -D they are errors.
    let e = load_err(text);
    assert_eq!((e.line, e.col), (5, 62), "{e}");
    assert!(e.message.contains("undefined parameter $depth"), "{e}");
    // -D defines them and overrides defaults; the longest name wins
    // ($resolution is not $res followed by "olution").
    let (desc, w) = load_with(
        text.replace("$r\\$", "$r").as_str(),
        &[("depth", "3"), ("r", "2.5"), ("res", "48")],
    );
    assert!(w.is_empty(), "{w:?}");
    assert_eq!(
        (desc.scene.camera.width, desc.scene.camera.height),
        (48, 48)
    );
    assert_eq!(desc.job.spp, 16);
    match &desc.scene.shapes[0].geometry {
        Geometry::Sphere(s) => assert_eq!(s.radius, 2.5),
        g => panic!("{g:?}"),
    }
    assert!(matches!(
        desc.job.integrator,
        Integrator::Path {
            params: PathParams {
                max_depth: Some(3),
                ..
            },
            ..
        }
    ));
    // An escaped dollar is a literal one (here: not a number).
    let e = load_with_err(text, &[("depth", "3"), ("r", "2")]);
    assert!(e.message.contains("'2$'"), "{e}");
    // Unused -D names are warnings.
    let (_, w) = load_with(
        &text.replace("$r\\$", "1"),
        &[("depth", "3"), ("colour", "red")],
    );
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(w[0].message.contains("colour"));
}

fn load_with_err(text: &str, defines: &[(&str, &str)]) -> SceneError {
    let defines: Vec<(String, String)> = defines
        .iter()
        .map(|(a, b)| (a.to_string(), b.to_string()))
        .collect();
    match load_scene_str_with(text, Path::new("test.xml"), &defines) {
        Ok(_) => panic!("should not load"),
        Err(e) => e,
    }
}

#[test]
fn command_line_defines() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("s.xml");
    std::fs::write(
        &path,
        r#"<scene version="3.0.0">
    <default name="w" value="64"/>
    <sensor type="perspective"><film type="hdrfilm">
        <integer name="width" value="$w"/><integer name="height" value="32"/>
    </film></sensor>
    <shape type="sphere"/>
</scene>"#,
    )
    .unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_lente"))
        .args(["info", path.to_str().unwrap(), "-D", "w=80"])
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains("80x32"), "{stdout}");
    let (desc, _) = load_scene_with(&path, &[("w".into(), "100".into())]).unwrap();
    assert_eq!(desc.scene.camera.width, 100);
    let (desc, _) = load_scene(&path).unwrap();
    assert_eq!(desc.scene.camera.width, 64);
}

#[test]
fn includes_splice_files() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("parts.xml"),
        "<scene version=\"3.0.0\">\n<bsdf type=\"diffuse\" id=\"grey\"><rgb name=\"reflectance\" value=\"$g\"/></bsdf>\n<shape type=\"sphere\"><ref id=\"grey\"/></shape>\n</scene>\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("bad.xml"),
        "<scene version=\"3.0.0\">\n  <shape type=\"sphre\"/>\n</scene>\n",
    )
    .unwrap();
    let path = dir.path().join("main.xml");
    std::fs::write(
        &path,
        "<scene version=\"3.0.0\">\n<default name=\"g\" value=\"0.3\"/>\n<sensor type=\"perspective\"/>\n<include filename=\"parts.xml\"/>\n<shape type=\"sphere\"><ref id=\"grey\"/></shape>\n</scene>\n",
    )
    .unwrap();
    let (desc, w) = load_scene(&path).unwrap();
    assert_eq!(desc.scene.shapes.len(), 2);
    assert_eq!(
        desc.scene.shapes[1].bsdf,
        Bsdf::Diffuse(lente::bsdf::Diffuse {
            albedo: Rgb::splat(0.3)
        })
    );
    assert_eq!(w.len(), 1, "{w:?}"); // no integrator
                                     // Errors in included files name the included file.
    std::fs::write(
        &path,
        "<scene version=\"3.0.0\">\n<include filename=\"bad.xml\"/>\n</scene>\n",
    )
    .unwrap();
    let e = load_scene(&path).unwrap_err();
    assert_eq!(e.file, dir.path().join("bad.xml"));
    assert_eq!((e.line, e.col), (2, 16), "{e}");
    std::fs::write(
        &path,
        "<scene version=\"3.0.0\">\n<include filename=\"main.xml\"/>\n</scene>\n",
    )
    .unwrap();
    assert!(load_scene(&path)
        .unwrap_err()
        .message
        .contains("includes itself"));
}

/// Mitsuba 3.9.1's resolver: a nested include is looked for next to the
/// file that includes it, then next to each file further out (here the
/// scene's folder); a `<path>` folder likewise falls back to the scene's.
#[test]
fn nested_includes_and_paths_fall_back_to_the_including_files_folders() {
    let dir = tempfile::tempdir().unwrap();
    let inc = dir.path().join("include");
    std::fs::create_dir_all(inc.join("include")).unwrap();
    std::fs::create_dir_all(dir.path().join("meshes")).unwrap();
    // include/base.xml names "include/grey.xml": not in include/include/,
    // but in the scene's folder's include/.
    std::fs::write(
        inc.join("base.xml"),
        "<scene version=\"3.0.0\">\n<path value=\"meshes\"/>\n<include filename=\"include/grey.xml\"/>\n</scene>\n",
    )
    .unwrap();
    std::fs::write(
        inc.join("grey.xml"),
        "<scene version=\"3.0.0\">\n<bsdf type=\"diffuse\" id=\"grey\"/>\n</scene>\n",
    )
    .unwrap();
    let path = dir.path().join("main.xml");
    std::fs::write(
        &path,
        "<scene version=\"3.0.0\">\n<include filename=\"include/base.xml\"/>\n<shape type=\"sphere\"><ref id=\"grey\"/></shape>\n</scene>\n",
    )
    .unwrap();
    let (desc, _) = load_scene(&path).unwrap();
    assert_eq!(desc.scene.shapes.len(), 1);
    // A file next to the includer wins over one further out.
    std::fs::write(
        inc.join("include").join("grey.xml"),
        "<scene version=\"3.0.0\">\n<bsdf type=\"diffuse\" id=\"grey\"><rgb name=\"reflectance\" value=\"0.25\"/></bsdf>\n</scene>\n",
    )
    .unwrap();
    let (desc, _) = load_scene(&path).unwrap();
    assert_eq!(
        desc.scene.shapes[0].bsdf,
        Bsdf::Diffuse(lente::bsdf::Diffuse {
            albedo: Rgb::splat(0.25)
        })
    );
    // Found nowhere: the error names the place next to the includer.
    std::fs::write(
        inc.join("base.xml"),
        "<scene version=\"3.0.0\">\n<include filename=\"nothere.xml\"/>\n</scene>\n",
    )
    .unwrap();
    let e = load_scene(&path).unwrap_err();
    assert_eq!(e.file, inc.join("base.xml"));
    assert!(e.message.contains("include/nothere.xml"), "{e}");
}

/// An area emitter declared at the top level with an id and referenced
/// from shapes (Mitsuba's cbox-rgb.xml, where the reference comes first).
#[test]
fn a_top_level_area_emitter_can_be_referenced_by_shapes() {
    let desc = load_clean(&scene(
        r#"<shape type="rectangle"><ref id="lamp"/></shape>
           <emitter type="area" id="lamp"><rgb name="radiance" value="2, 3, 4"/></emitter>"#,
    ));
    assert_eq!(
        desc.scene.shapes[0].area_radiance,
        Some(Rgb::new(2.0, 3.0, 4.0))
    );
    // Used by no shape: an error, as it has nowhere to emit from.
    assert_err(
        &scene(r#"<emitter type="area" id="lamp"/>"#),
        4,
        1,
        &["'lamp'", "no shape uses it", "<ref id=\"lamp\"/>"],
    );
    // Without an id nothing can use it.
    assert_err(
        &scene(r#"<emitter type="area"/>"#),
        4,
        1,
        &["cannot stand inside <scene>"],
    );
}

/// Samplers, films and filters may also stand at the top level with an id
/// (mitsuba-data's sampler scenes do), built where a sensor refers to them.
#[test]
fn top_level_samplers_films_and_filters_can_be_referenced() {
    let text = r#"<scene version="3.0.0"><integrator type="path"/>
<sampler type="independent" id="s"><integer name="sample_count" value="9"/></sampler>
<rfilter type="box" id="f"/>
<film type="hdrfilm" id="film">
  <integer name="width" value="40"/><integer name="height" value="30"/><ref id="f"/>
</film>
<sensor type="perspective"><ref id="s"/><ref id="film"/></sensor>
<shape type="sphere"/>
</scene>
"#;
    let desc = load_clean(text);
    assert_eq!(desc.job.spp, 9);
    assert_eq!(desc.job.filter, Filter::Box { radius: 0.5 });
    assert_eq!(
        (desc.scene.camera.width, desc.scene.camera.height),
        (40, 30)
    );
    // An unused one is still checked.
    assert_err(
        &scene(
            r#"<sampler type="independent" id="s"><integer name="sample_count" value="-1"/></sampler>"#,
        ),
        4,
        72,
        &["sample_count"],
    );
}

/// `spot`: Mitsuba's defaults (cutoff 20, beam 3/4 of it), and the
/// angles or a constant texture refused at the property.
#[test]
fn spot_lights() {
    let desc = load_clean(&scene(
        r#"<emitter type="spot"><rgb name="intensity" value="3"/></emitter>"#,
    ));
    match desc.scene.emitters.as_slice() {
        [Emitter::Spot(s)] => {
            assert!((s.cos_cutoff() - 20f32.to_radians().cos()).abs() < 1e-6);
            assert_eq!(s.axis, Vec3::Z);
            assert_eq!(s.intensity, Rgb::splat(3.0));
        }
        e => panic!("{e:?}"),
    }
    assert_err(
        &scene(
            r#"<emitter type="spot"><float name="cutoff_angle" value="10"/><float name="beam_width" value="12"/></emitter>"#,
        ),
        4,
        93,
        &["beam_width", "cutoff angle"],
    );
    assert_err(
        &scene(r#"<emitter type="spot"><rgb name="texture" value="1, 0, 0"/></emitter>"#),
        4,
        49,
        &["texture", "vary"],
    );
}

// ---------------------------------------------------------------------------
// Values and transforms
// ---------------------------------------------------------------------------

/// Where a transform puts the origin and the x and y axes, read back from
/// a rectangle's corners (-1,-1,0), (1,-1,0), (1,1,0).
struct Mapped {
    origin: Vec3,
    x: Vec3,
    y: Vec3,
}

fn transform_of(ops: &str) -> Mapped {
    let desc = load_clean(&scene(&format!(
        "<shape type=\"rectangle\"><transform name=\"to_world\">{ops}</transform></shape>"
    )));
    let p = rectangle_corners(&desc, 0);
    Mapped {
        origin: (p[0] + p[2]) * 0.5,
        x: (p[1] - p[0]) * 0.5,
        y: (p[2] - p[1]) * 0.5,
    }
}

/// The corners of the (analytic) rectangle shape `i`, at object
/// (-1, -1), (1, -1), (1, 1), (-1, 1).
pub(crate) fn rectangle_corners(desc: &SceneFile, i: usize) -> [Vec3; 4] {
    let Geometry::Rectangle(r) = &desc.scene.shapes[i].geometry else {
        panic!("shape {i} is not a rectangle");
    };
    let f = &r.frame;
    [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)]
        .map(|(x, y)| f.center + x * f.ex + y * f.ey)
}

#[test]
fn transforms_apply_in_document_order() {
    // translate, then rotate 90 about z, then scale x by 2:
    // M = S * R * T; the point (1, 0, 0) goes to (2, 0, 0) -> (0, 2, 0) -> (0, 2, 0).
    let desc = load_clean(&with_sensor(
        r#"<sensor type="perspective"/>
           <emitter type="point"><transform name="to_world">
               <translate x="1"/>
               <rotate z="1" angle="90"/>
               <scale x="2"/>
           </transform></emitter>"#,
    ));
    // The light sits at to_world * origin = S R T (0,0,0) = S R (1,0,0)
    // = S (0,1,0) = (0,1,0) (scale x only; y and z default to 1).
    match &desc.scene.emitters[0] {
        Emitter::Point(lente::emitter::PointLight { position, .. }) => {
            close(*position, Vec3::new(0.0, 1.0, 0.0))
        }
        e => panic!("{e:?}"),
    }
    // The same ops on a rectangle, checked point by point against the
    // hand-computed M = S R T.
    let desc = load_clean(&scene(
        r#"<shape type="rectangle"><transform name="to_world">
               <translate value="1, 2, 3"/>
               <rotate x="0" y="0" z="1" angle="90"/>
               <scale x="2" y="3"/>
           </transform></shape>"#,
    ));
    let s = Mat4::from_scale(Vec3::new(2.0, 3.0, 1.0));
    let r = Mat4::from_rotation_z(PI / 2.0);
    let t = Mat4::from_translation(Vec3::new(1.0, 2.0, 3.0));
    let m = s * r * t;
    let rect = [
        Vec3::new(-1.0, -1.0, 0.0),
        Vec3::new(1.0, -1.0, 0.0),
        Vec3::new(1.0, 1.0, 0.0),
        Vec3::new(-1.0, 1.0, 0.0),
    ];
    for (p, q) in rectangle_corners(&desc, 0).iter().zip(rect) {
        close(*p, m.transform_point3(q));
    }
    // matrix (row-major, 16 or 9 values), lookat, uniform scale.
    let t = transform_of("<matrix value=\"0 -1 0 5  1 0 0 6  0 0 1 7  0 0 0 1\"/>");
    close(t.origin, Vec3::new(5.0, 6.0, 7.0));
    close(t.x, Vec3::Y);
    close(t.y, Vec3::NEG_X);
    let t = transform_of("<matrix value=\"0 -1 0  1 0 0  0 0 1\"/>");
    close(t.x, Vec3::Y);
    close(t.origin, Vec3::ZERO);
    let t = transform_of("<scale value=\"3\"/><translate y=\"1\"/>");
    close(t.origin, Vec3::Y);
    close(t.x, Vec3::X * 3.0);
    // lookat: camera +x is "left" = up x dir; here up = y, dir = -z.
    let t = transform_of("<lookat origin=\"1, 0, 0\" target=\"1, 0, -5\" up=\"0, 1, 0\"/>");
    close(t.origin, Vec3::X);
    close(t.x, Vec3::NEG_X);
    close(t.y, Vec3::Y);
    // Nori-style axis attribute works too.
    let t = transform_of("<rotate axis=\"0, 0, 1\" angle=\"90\"/>");
    close(t.x, Vec3::Y);
}

#[test]
fn points_vectors_colours_and_spectra() {
    let desc = load_clean(&scene(
        r#"<emitter type="point"><point name="position" x="1" z="3"/><spectrum name="intensity" value="5"/></emitter>
           <emitter type="point"><point name="position" value="2"/><spectrum name="intensity" value="1, 2, 3"/></emitter>
           <emitter type="directional"><vector name="direction" y="-2"/><rgb name="irradiance" value="0.5"/></emitter>"#,
    ));
    match &desc.scene.emitters[..] {
        [Emitter::Point(lente::emitter::PointLight {
            position: p1,
            intensity: i1,
        }), Emitter::Point(lente::emitter::PointLight {
            position: p2,
            intensity: i2,
        }), Emitter::Directional(lente::emitter::DirectionalLight {
            direction,
            irradiance,
        })] => {
            close(*p1, Vec3::new(1.0, 0.0, 3.0));
            // A flat emission spectrum is Mitsuba's xyz_to_srgb(1, 1, 1).
            let pink = lente::color::Spectrum::Uniform(5.0)
                .to_rgb(lente::color::SpectrumUse::Emission)
                .0;
            assert_eq!(*i1, pink);
            close(*p2, Vec3::splat(2.0));
            assert_eq!(*i2, Rgb::new(1.0, 2.0, 3.0));
            close(*direction, Vec3::NEG_Y);
            assert_eq!(*irradiance, Rgb::splat(0.5));
        }
        e => panic!("{e:?}"),
    }
    // Spectra are read (tests/integration/spectra.rs); a malformed one
    // is an error at its token.
    assert_err(
        &scene("<emitter type=\"point\">\n  <spectrum name=\"intensity\" value=\"400:0.1, 500\"/></emitter>"),
        5,
        46,
        &["cannot read '500' as a wavelength:value pair"],
    );
    assert_err(
        &scene(
            "<emitter type=\"point\"><point name=\"position\" value=\"1 2\" x=\"1\"/></emitter>",
        ),
        4,
        58,
        &["either 'value' or 'x'"],
    );
    assert_err(
        &scene("<emitter type=\"point\"><rgb name=\"intensity\" value=\"1, 2\"/></emitter>"),
        4,
        52,
        &["3 numbers"],
    );
}

/// A Mitsuba 0.x file is upgraded as Mitsuba 3.9.1 upgrades it (one
/// warning): camelCase names become snake_case, a diffuse BSDF's
/// diffuseReflectance its reflectance; an included 0.x file too, inside a
/// 3.0 scene.
#[test]
fn mitsuba_0x_files_are_upgraded() {
    let old = r#"<scene version="0.6.0">
  <integrator type="path"><integer name="maxDepth" value="3"/></integrator>
  <sensor type="perspective">
    <float name="fov" value="30"/><string name="fovAxis" value="y"/>
    <transform name="toWorld"><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
    <sampler type="independent"><integer name="sampleCount" value="7"/></sampler>
    <film type="hdrfilm"><integer name="width" value="40"/><integer name="height" value="20"/></film>
  </sensor>
  <shape type="sphere">
    <bsdf type="diffuse"><rgb name="diffuseReflectance" value="0.2, 0.3, 0.4"/></bsdf>
  </shape>
  <shape type="sphere">
    <bsdf type="plastic"><float name="intIOR" value="1.7"/><rgb name="diffuseReflectance" value="0.1"/></bsdf>
  </shape>
</scene>"#;
    let (desc, w) = load(old);
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(
        w[0].message.contains("Mitsuba 0.6.0 scene: upgraded"),
        "{w:?}"
    );
    assert_eq!(desc.job.spp, 7);
    assert_eq!(desc.scene.camera.width, 40);
    match &desc.job.integrator {
        Integrator::Path { params, .. } => assert_eq!(params.max_depth, Some(3)),
        i => panic!("{i:?}"),
    }
    assert_eq!(
        desc.scene.shapes[0].bsdf,
        Bsdf::diffuse(Rgb::new(0.2, 0.3, 0.4)).unwrap()
    );
    assert_eq!(
        desc.scene.shapes[1].bsdf,
        Bsdf::plastic(1.7, 1.000277, Rgb::splat(0.1), Rgb::ONE, false).unwrap()
    );
    // fov 30 along y on a 2:1 image: the horizontal view is wider.
    let tan_x = (desc.scene.camera.fov_x_deg.to_radians() / 2.0).tan();
    assert!(
        (tan_x - 2.0 * 15f32.to_radians().tan()).abs() < 1e-5,
        "{tan_x}"
    );
    // The same scene as 3.0 leaves camelCase alone: unused, with warnings.
    let (_, w) = load(&old.replace("0.6.0", "3.0.0"));
    assert!(w.iter().any(|w| w.message.contains("'maxDepth'")), "{w:?}");
}

/// 0.x's `uoffset`/`voffset`/`uscale`/`vscale` become `to_uv` =
/// scale(uscale, vscale) translate(uoffset, voffset), as Mitsuba 3
/// upgrades them, whatever order they are written in.
#[test]
fn mitsuba_0x_uv_offsets_and_scales_become_to_uv() {
    use lente::texture::{Texture, UvTransform};
    let old = r#"<scene version="0.5.0">
  <integrator type="path"/>
  <sensor type="perspective"/>
  <shape type="sphere">
    <bsdf type="diffuse">
      <texture type="checkerboard" name="reflectance">
        <float name="uscale" value="4"/><float name="voffset" value="0.5"/>
        <float name="vscale" value="2"/><float name="uoffset" value="0.25"/>
      </texture>
    </bsdf>
  </shape>
</scene>"#;
    let (desc, _) = load(old);
    let Bsdf::Textured(t) = &desc.scene.shapes[0].bsdf else {
        panic!("{:?}", desc.scene.shapes[0].bsdf);
    };
    let Texture::Checkerboard(c) = &t.textures()[0].1 else {
        panic!("{t:?}");
    };
    let expect = UvTransform {
        row0: [4.0, 0.0, 1.0],
        row1: [0.0, 2.0, 1.0],
    };
    assert_eq!(c.to_uv, expect);
}

// ---------------------------------------------------------------------------
// File structure errors
// ---------------------------------------------------------------------------

#[test]
fn structure_errors_are_located() {
    assert_err(
        "<scene version=\"three\">\n</scene>",
        1,
        17,
        &["version number"],
    );
    assert_err(
        "<scene version=\"3.0.0\">\n  <mesh type=\"obj\"/>\n</scene>",
        2,
        3,
        &["<mesh>", "Nori", "<shape>"],
    );
    assert_err(
        "<scene version=\"3.0.0\">\n  <shap type=\"obj\"/>\n</scene>",
        2,
        3,
        &["did you mean <shape>"],
    );
    assert_err(
        "<scene version=\"3.0.0\">\n  <shape type=\"sphere\" size=\"2\"/>\n</scene>",
        2,
        24,
        &["unexpected attribute 'size'"],
    );
    assert_err(
        "<scene version=\"3.0.0\">\n  <sensor type=\"perspective\"><translate x=\"1\"/></sensor>\n</scene>",
        2,
        30,
        &["<translate>", "inside a <transform>"],
    );
    assert_err(
        "<scene version=\"3.0.0\">\n  <film type=\"hdrfilm\"/>\n</scene>",
        2,
        3,
        &["<film type=\"hdrfilm\">", "inside a <sensor>"],
    );
    assert_err(
        "<scene version=\"3.0.0\">\n  <shape type=\"sphere\"><float name=\"radius\" value=\"1,5\"/></shape>\n</scene>",
        2,
        52,
        &["1 number"],
    );
    assert_err(
        "<scene version=\"3.0.0\">\n  <shape type=\"sphere\"><integer name=\"radius\" value=\"x\"/></shape>\n</scene>",
        2,
        54,
        &["'x'", "integer"],
    );
    assert_err(
        "<scene version=\"3.0.0\">\n  <shape type=\"sphere\"><rgb name=\"radius\" value=\"1\"/></shape>\n</scene>",
        2,
        24,
        &["<float>", "<rgb>"],
    );
    assert_err(
        "<scene version=\"3.0.0\">\n  <shape type=\"rectangle\"><transform name=\"to_world\"><scale y=\"0\"/></transform></shape>\n</scene>",
        2,
        54,
        &["scale by zero"],
    );
    assert_err(
        "<scene version=\"3.0.0\">\n  <shape type=\"rectangle\"><transform name=\"to_world\"><lookat origin=\"0 0 0\" target=\"0 1 0\" up=\"0 1 0\"/></transform></shape>\n</scene>",
        2,
        54,
        &["parallel"],
    );
    assert_err(
        "<scene version=\"3.0.0\">\n  <shape type=\"rectangle\"><transform name=\"to_world\"><matrix value=\"1 0 0 1 0 1\"/></transform></shape>\n</scene>",
        2,
        69,
        &["16 numbers", "9"],
    );
}

#[test]
fn unused_properties_warn_with_suggestions() {
    let (_, w) = load(&scene(
        "<shape type=\"sphere\">\n  <float name=\"raduis\" value=\"2\"/></shape>",
    ));
    assert_eq!(w.len(), 1, "{w:?}");
    assert_eq!((w[0].line, w[0].col), (5, 3));
    assert!(w[0].message.contains("did you mean 'radius'"), "{}", w[0]);
}

// ---------------------------------------------------------------------------
// Shipped scenes
// ---------------------------------------------------------------------------

fn shipped(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes/mitsuba")
        .join(name)
}

#[test]
fn shipped_scenes_load_without_warnings() {
    for name in ["cbox.xml", "envmap.xml", "sunlight.xml", "showcase.xml"] {
        let (desc, w) = load_scene(&shipped(name)).unwrap_or_else(|e| panic!("{e}"));
        assert!(w.is_empty(), "{name}: {w:?}");
        assert!(!desc.scene.shapes.is_empty());
    }
}

#[test]
fn rendered_cbox_has_the_red_wall_on_the_left() {
    use lente::render::{render, RenderOptions};
    use std::sync::atomic::AtomicBool;
    let defines = [
        ("res".to_string(), "24".to_string()),
        ("max_depth".to_string(), "2".to_string()),
    ];
    let (desc, _) = load_scene_with(&shipped("cbox.xml"), &defines).unwrap();
    let scene = lente::scene::Scene::new(desc.scene).unwrap();
    let opts = RenderOptions::new(1);
    let job = lente::render::RenderJob {
        spp: 16,
        ..desc.job
    };
    let out = render(&scene, &job, &opts, &AtomicBool::new(false));
    let img = &out.image;
    // Mean redness (r - g) of the leftmost and rightmost columns of the box.
    let redness = |x: usize| -> f32 {
        (6..18)
            .map(|y| {
                let c = img.get(x, y);
                c.x - c.y
            })
            .sum::<f32>()
    };
    let (left, right) = (redness(3), redness(20));
    assert!(left > 0.0 && right < 0.0, "left {left}, right {right}");
}

#[test]
fn defines_on_a_nori_scene_are_a_warning() {
    let (_, w) = load_with(
        "<scene>\n<integrator type=\"normals\"/>\n<camera type=\"perspective\"/>\n</scene>",
        &[("spp", "4")],
    );
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(w[0].message.contains("-D spp"), "{}", w[0]);
}
