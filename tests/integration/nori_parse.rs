//! Valid Nori scenes: defaults, transforms, filters, files, value syntax.

use lente::bsdf::Bsdf;
use lente::camera::{Aperture, CameraParams};
use lente::color::Rgb;
use lente::emitter::Emitter;
use lente::geometry::Geometry;
use lente::image::Filter;
use lente::integrator::{Integrator, PathParams, Strategy};
use lente::load::{load_scene, load_scene_str};
use lente::math::{Transform, Vec3, PI};

use crate::common::load_clean;

#[track_caller]
fn close(a: Vec3, b: Vec3) {
    assert!((a - b).length() < 1e-5, "{a} != {b}");
}

fn camera_scene(camera_body: &str) -> String {
    format!(
        "<scene>\n<integrator type=\"normals\"/>\n<camera type=\"perspective\">\n{camera_body}\n</camera>\n</scene>\n"
    )
}

#[test]
fn minimal_scene_gets_noris_defaults() {
    let desc = load_clean(
        r#"<scene>
            <integrator type="path_mis"/>
            <camera type="perspective"/>
            <mesh type="sphere"/>
        </scene>"#,
    );
    assert_eq!(desc.scene.camera, CameraParams::default());
    assert_eq!(desc.scene.camera.width, 1280);
    assert_eq!(desc.scene.camera.height, 720);
    assert_eq!(desc.scene.camera.fov_x_deg, 30.0);
    assert_eq!(desc.scene.camera.near_clip, 1e-4);
    assert_eq!(desc.scene.camera.far_clip, 1e4);
    assert_eq!(desc.scene.camera.lens_radius, 0.0);
    assert_eq!(desc.scene.camera.aperture, Aperture::Circular);
    assert!(!desc.scene.camera.autofocus);
    assert_eq!(
        desc.job.filter,
        Filter::Gaussian {
            radius: 2.0,
            stddev: 0.5
        }
    );
    assert_eq!(desc.job.spp, 1);
    assert_eq!(
        desc.job.integrator,
        Integrator::Path {
            strategy: Strategy::Mis,
            params: PathParams {
                max_depth: None,
                rr_depth: 3,
                hide_emitters: false
            }
        }
    );
    assert_eq!(desc.scene.shapes.len(), 1);
    let s = &desc.scene.shapes[0];
    assert_eq!(
        s.bsdf,
        Bsdf::Diffuse(lente::bsdf::Diffuse {
            albedo: Rgb::splat(0.5)
        })
    );
    assert!(s.area_radiance.is_none());
    match &s.geometry {
        Geometry::Sphere(sp) => {
            assert_eq!(sp.center, Vec3::ZERO);
            assert_eq!(sp.radius, 1.0);
        }
        g => panic!("expected a sphere, got {g:?}"),
    }
    assert!(desc.scene.emitters.is_empty());
}

#[test]
fn full_camera_and_integrator_settings() {
    let desc = load_clean(
        r#"<scene>
            <integrator type="path_ems">
                <integer name="maxDepth" value="5"/>
                <integer name="rrDepth" value="2"/>
            </integrator>
            <camera type="thinlens">
                <integer name="width" value="320"/>
                <integer name="height" value="200"/>
                <integer name="fov" value="45"/>
                <float name="nearClip" value="0.5"/>
                <float name="farClip" value="50"/>
                <float name="lensRadius" value="0.25"/>
                <float name="focalDistance" value="7.5"/>
                <integer name="apertureBlades" value="6"/>
                <float name="apertureRotation" value="90"/>
                <sampler type="independent">
                    <integer name="sampleCount" value="64"/>
                </sampler>
            </camera>
        </scene>"#,
    );
    let c = &desc.scene.camera;
    assert_eq!((c.width, c.height), (320, 200));
    assert_eq!(c.fov_x_deg, 45.0, "an <integer> stands in for a float");
    assert_eq!((c.near_clip, c.far_clip), (0.5, 50.0));
    assert_eq!((c.lens_radius, c.focal_distance), (0.25, 7.5));
    match c.aperture {
        Aperture::Polygon { blades, rotation } => {
            assert_eq!(blades, 6);
            assert!((rotation - PI / 2.0).abs() < 1e-6);
        }
        a => panic!("expected a polygon, got {a:?}"),
    }
    assert_eq!(desc.job.spp, 64);
    assert_eq!(
        desc.job.integrator,
        Integrator::Path {
            strategy: Strategy::Ems,
            params: PathParams {
                max_depth: Some(5),
                rr_depth: 2,
                hide_emitters: false
            }
        }
    );
}

#[test]
fn autofocus_needs_no_focal_distance() {
    let desc = load_clean(&camera_scene(
        r#"<float name="lensRadius" value="0.1"/>
           <boolean name="autofocus" value="true"/>"#,
    ));
    assert!(desc.scene.camera.autofocus);
    assert_eq!(desc.scene.camera.lens_radius, 0.1);
}

#[test]
fn integrator_variants() {
    let get = |body: &str| {
        load_clean(&format!(
            "<scene><camera type=\"perspective\"/>{body}</scene>"
        ))
        .job
        .integrator
    };
    assert_eq!(get(r#"<integrator type="normals"/>"#), Integrator::Normals);
    assert_eq!(
        get(r#"<integrator type="ao"/>"#),
        Integrator::Ao {
            length: f32::INFINITY
        }
    );
    assert_eq!(
        get(r#"<integrator type="ao"><float name="length" value="2.5"/></integrator>"#),
        Integrator::Ao { length: 2.5 }
    );
    for (name, strategy) in [
        ("path_mats", Strategy::Mats),
        ("path_ems", Strategy::Ems),
        ("path_mis", Strategy::Mis),
        ("path", Strategy::Mis),
    ] {
        match get(&format!("<integrator type=\"{name}\"/>")) {
            Integrator::Path { strategy: s, .. } => assert_eq!(s, strategy, "{name}"),
            i => panic!("{name}: {i:?}"),
        }
    }
}

#[test]
fn transform_ops_apply_in_document_order() {
    let translate_then_scale = load_clean(&camera_scene(
        r#"<transform name="toWorld">
               <translate value="1 0 0"/>
               <scale value="2"/>
           </transform>"#,
    ));
    let scale_then_translate = load_clean(&camera_scene(
        r#"<transform name="toWorld">
               <scale value="2"/>
               <translate value="1 0 0"/>
           </transform>"#,
    ));
    let p = Vec3::new(1.0, 1.0, 1.0);
    // (p + (1,0,0)) * 2
    close(
        translate_then_scale.scene.camera.to_world.point(p),
        Vec3::new(4.0, 2.0, 2.0),
    );
    // p * 2 + (1,0,0)
    close(
        scale_then_translate.scene.camera.to_world.point(p),
        Vec3::new(3.0, 2.0, 2.0),
    );
}

#[test]
fn rotate_matrix_and_nonuniform_scale() {
    let desc = load_clean(&camera_scene(
        r#"<transform name="toWorld">
               <rotate axis="0 0 2" angle="90"/>
               <scale value="1, 2, 3"/>
               <matrix value="1 0 0 5
                              0 1 0 6
                              0 0 1 7
                              0 0 0 1"/>
           </transform>"#,
    ));
    let t = desc.scene.camera.to_world;
    // x -> rotate: y -> scale: (0,2,0) -> translate: (5,8,7)
    close(t.point(Vec3::X), Vec3::new(5.0, 8.0, 7.0));
    close(t.point(Vec3::ZERO), Vec3::new(5.0, 6.0, 7.0));
    // The inverse is carried along.
    close(t.inverse().point(Vec3::new(5.0, 8.0, 7.0)), Vec3::X);
}

#[test]
fn lookat_gives_noris_camera_axes() {
    let desc = load_clean(&camera_scene(
        r#"<transform name="toWorld">
               <lookat origin="1, 2, 3" target="1 2 -7" up="0 5 0"/>
           </transform>"#,
    ));
    let t: Transform = desc.scene.camera.to_world;
    close(t.point(Vec3::ZERO), Vec3::new(1.0, 2.0, 3.0));
    // dir = normalize(target - origin)
    close(t.vector(Vec3::Z), Vec3::new(0.0, 0.0, -1.0));
    // left = normalize(cross(normalize(up), dir)) = y x -z = -x
    close(t.vector(Vec3::X), Vec3::new(-1.0, 0.0, 0.0));
    // newUp = normalize(cross(dir, left)) = -z x -x = y
    close(t.vector(Vec3::Y), Vec3::new(0.0, 1.0, 0.0));

    // The usual Nori camera: a mirror in x before the lookat.
    let desc = load_clean(&camera_scene(
        r#"<transform name="toWorld">
               <scale value="-1,1,1"/>
               <lookat origin="0 0 0" target="1 0 0" up="0 1 0"/>
           </transform>"#,
    ));
    let t = desc.scene.camera.to_world;
    close(t.vector(Vec3::Z), Vec3::X);
    // left = y x x = -z; the mirror flips it to +z.
    close(t.vector(Vec3::X), Vec3::Z);
    assert!(t.flips_handedness());
}

#[test]
fn reconstruction_filters() {
    let filter = |body: &str| load_clean(&camera_scene(body)).job.filter;
    assert_eq!(
        filter(r#"<rfilter type="gaussian"/>"#),
        Filter::Gaussian {
            radius: 2.0,
            stddev: 0.5
        }
    );
    assert_eq!(
        filter(
            r#"<rfilter type="gaussian"><float name="radius" value="3"/><float name="stddev" value="1"/></rfilter>"#
        ),
        Filter::Gaussian {
            radius: 3.0,
            stddev: 1.0
        }
    );
    assert_eq!(
        filter(r#"<rfilter type="box"/>"#),
        Filter::Box { radius: 0.5 }
    );
    assert_eq!(
        filter(r#"<rfilter type="tent"/>"#),
        Filter::Tent { radius: 1.0 }
    );
    assert_eq!(
        filter(r#"<rfilter type="mitchell"/>"#),
        Filter::Mitchell {
            radius: 2.0,
            b: 1.0 / 3.0,
            c: 1.0 / 3.0
        }
    );
    assert_eq!(
        filter(
            r#"<rfilter type="mitchell"><float name="B" value="0"/><float name="C" value="0.5"/></rfilter>"#
        ),
        Filter::Mitchell {
            radius: 2.0,
            b: 0.0,
            c: 0.5
        }
    );
}

const TRI_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

#[test]
fn obj_paths_are_relative_to_the_scene_file() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(dir.path().join("meshes")).unwrap();
    std::fs::write(dir.path().join("meshes/tri.obj"), TRI_OBJ).unwrap();
    let scene = r#"<scene>
    <integrator type="normals"/>
    <camera type="perspective"/>
    <mesh type="obj">
        <string name="filename" value="meshes/tri.obj"/>
        <transform name="toWorld">
            <translate value="0 0 2"/>
        </transform>
        <bsdf type="mirror"/>
        <emitter type="area">
            <color name="radiance" value="1 2 3"/>
        </emitter>
    </mesh>
</scene>
"#;
    let path = dir.path().join("scene.xml");
    std::fs::write(&path, scene).unwrap();
    // Loaded from another working folder: only the scene's folder counts.
    let (desc, warnings) = load_scene(&path).unwrap();
    assert!(warnings.is_empty(), "{warnings:?}");
    let shape = &desc.scene.shapes[0];
    match &shape.geometry {
        Geometry::Mesh(m) => {
            assert_eq!(m.indices().len(), 1);
            close(m.positions()[1], Vec3::new(1.0, 0.0, 2.0));
        }
        g => panic!("expected a mesh, got {g:?}"),
    }
    assert_eq!(shape.bsdf, Bsdf::mirror());
    assert_eq!(shape.area_radiance, Some(Rgb::new(1.0, 2.0, 3.0)));
}

#[test]
fn values_with_newlines_and_mixed_separators() {
    let scene = "<scene>
    <integrator type=\"normals\"/>
    <camera type=\"perspective\">
        <transform name=\"toWorld\">
            <translate value=\"1,2,\n\t3\"/>
        </transform>
    </camera>
    <mesh type=\"sphere\">
        <point name=\"center\" value=\"  1 ,2,,\n   3  \"/>
        <float name=\"radius\" value=\"\n 0.25 \"/>
        <bsdf type=\"diffuse\">
            <color name=\"albedo\" value=\"0.1,0.2 0.3\"/>
        </bsdf>
    </mesh>
    <mesh type=\"sphere\">
        <bsdf type=\"diffuse\">
            <color name=\"albedo\" value=\"0.25\"/>
        </bsdf>
    </mesh>
</scene>";
    let desc = load_clean(scene);
    close(
        desc.scene.camera.to_world.point(Vec3::ZERO),
        Vec3::new(1.0, 2.0, 3.0),
    );
    match &desc.scene.shapes[0].geometry {
        Geometry::Sphere(s) => {
            close(s.center, Vec3::new(1.0, 2.0, 3.0));
            assert_eq!(s.radius, 0.25);
        }
        g => panic!("{g:?}"),
    }
    assert_eq!(
        desc.scene.shapes[0].bsdf,
        Bsdf::Diffuse(lente::bsdf::Diffuse {
            albedo: Rgb::new(0.1, 0.2, 0.3)
        })
    );
    assert_eq!(
        desc.scene.shapes[1].bsdf,
        Bsdf::Diffuse(lente::bsdf::Diffuse {
            albedo: Rgb::splat(0.25)
        }),
        "one number is a grey colour"
    );
}

#[test]
fn sphere_to_world_moves_and_scales_it() {
    let desc = load_clean(
        r#"<scene>
            <integrator type="normals"/>
            <camera type="perspective"/>
            <mesh type="sphere">
                <point name="center" value="1 0 0"/>
                <float name="radius" value="0.5"/>
                <transform name="toWorld">
                    <scale value="2"/>
                    <rotate axis="0 0 1" angle="90"/>
                    <translate value="0 0 1"/>
                </transform>
            </mesh>
        </scene>"#,
    );
    match &desc.scene.shapes[0].geometry {
        Geometry::Sphere(s) => {
            close(s.center, Vec3::new(0.0, 2.0, 1.0));
            assert!((s.radius - 1.0).abs() < 1e-6);
        }
        g => panic!("{g:?}"),
    }
}

#[test]
fn bsdfs() {
    let bsdf = |body: &str| {
        load_clean(&format!(
            "<scene><integrator type=\"normals\"/><camera type=\"perspective\"/>\
             <mesh type=\"sphere\">{body}</mesh></scene>"
        ))
        .scene
        .shapes[0]
            .bsdf
            .clone()
    };
    assert_eq!(
        bsdf(r#"<bsdf type="dielectric"/>"#),
        Bsdf::dielectric(1.5046, 1.000277).unwrap()
    );
    assert_eq!(
        bsdf(
            r#"<bsdf type="dielectric"><float name="intIOR" value="1.33"/><float name="extIOR" value="1"/></bsdf>"#
        ),
        Bsdf::dielectric(1.33, 1.0).unwrap()
    );
    assert_eq!(bsdf(r#"<bsdf type="mirror"/>"#), Bsdf::mirror());
}

#[test]
fn scene_level_emitters() {
    let desc = load_clean(
        r#"<scene>
            <integrator type="path_mis"/>
            <camera type="perspective"/>
            <emitter type="point">
                <point name="position" value="1 2 3"/>
                <color name="power" value="4 8 12"/>
            </emitter>
            <emitter type="constant">
                <color name="radiance" value="0.5"/>
            </emitter>
        </scene>"#,
    );
    assert_eq!(desc.scene.emitters.len(), 2);
    match &desc.scene.emitters[0] {
        Emitter::Point(lente::emitter::PointLight {
            position,
            intensity,
        }) => {
            close(*position, Vec3::new(1.0, 2.0, 3.0));
            close(*intensity, Vec3::new(4.0, 8.0, 12.0) / (4.0 * PI));
        }
        e => panic!("{e:?}"),
    }
    match &desc.scene.emitters[1] {
        Emitter::Constant(lente::emitter::ConstantLight { radiance }) => {
            close(*radiance, Rgb::splat(0.5))
        }
        e => panic!("{e:?}"),
    }
}

#[test]
fn sky_becomes_an_environment_map() {
    let desc = load_clean(
        r#"<scene>
            <integrator type="path_mis"/>
            <camera type="perspective"/>
            <emitter type="sky">
                <float name="turbidity" value="5"/>
                <float name="sunElevation" value="30"/>
                <float name="sunAzimuth" value="90"/>
                <integer name="resolution" value="64"/>
                <boolean name="visible" value="false"/>
            </emitter>
        </scene>"#,
    );
    match &desc.scene.emitters[0] {
        Emitter::Environment(env) => {
            assert!(!env.visible);
            assert_eq!(env.image().width, 64);
            assert_eq!(*env.to_world(), Transform::IDENTITY);
            assert_eq!(env.scale(), 1.0);
        }
        e => panic!("{e:?}"),
    }
    let desc = load_clean(
        r#"<scene><integrator type="path_mis"/><camera type="perspective"/>
           <emitter type="sky"><integer name="resolution" value="32"/></emitter></scene>"#,
    );
    match &desc.scene.emitters[0] {
        Emitter::Environment(env) => assert!(env.visible, "visible by default"),
        e => panic!("{e:?}"),
    }
}

#[test]
fn environment_map_loads_relative_to_the_scene() {
    // Image loading is implemented elsewhere; whatever it answers, the
    // loader must ask for the file next to the scene and report it there.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("scene.xml");
    let scene = r#"<scene>
    <integrator type="path_mis"/>
    <camera type="perspective"/>
    <emitter type="environment">
        <string name="filename" value="probes/sky.exr"/>
        <float name="scale" value="2"/>
        <string name="filter" value="nearest"/>
        <boolean name="visible" value="false"/>
        <transform name="toWorld">
            <rotate axis="0 1 0" angle="90"/>
        </transform>
    </emitter>
</scene>
"#;
    match load_scene_str(scene, &path) {
        Err(e) => {
            // At the file name, and the report names the file tried.
            assert_eq!((e.line, e.col), (5, 40), "{e}");
            let tried = dir.path().join("probes/sky.exr");
            assert!(e.report().contains(&tried.display().to_string()), "{e}");
        }
        Ok((desc, _)) => match &desc.scene.emitters[0] {
            Emitter::Environment(env) => {
                assert!(!env.visible);
                assert_eq!(env.scale(), 2.0);
                assert_eq!(env.filter(), lente::emitter::EnvFilter::Nearest);
            }
            e => panic!("{e:?}"),
        },
    }
}

#[test]
fn comments_declarations_and_whitespace_are_ignored() {
    let desc = load_clean(
        "\u{feff}<?xml version=\"1.0\" encoding=\"utf-8\"?>\n<!-- Nori scene -->\n<scene>\n  <!-- camera -->\n  <camera type=\"perspective\">\n    <integer name=\"width\" value=\" 64 \"/>\n  </camera>\n  <integrator type=\"normals\"/>\n</scene>\n",
    );
    assert_eq!(desc.scene.camera.width, 64);
}

/// Nori forks' files often carry `version="0.5.0"`: their `<mesh>` and
/// `<camera>` say they are Nori scenes, read as such with one warning;
/// a Mitsuba 0.5 file (`<shape>`, `<sensor>`) is upgraded as Mitsuba 3 does.
#[test]
fn a_nori_scene_with_a_version_attribute_is_read_as_nori() {
    let path = std::path::Path::new("fork.xml");
    let nori = r#"<scene version="0.5.0">
  <integrator type="normals"/>
  <camera type="perspective"><integer name="width" value="4"/><integer name="height" value="3"/></camera>
  <mesh type="sphere"><point name="center" value="0, 0, -5"/><float name="radius" value="1"/></mesh>
</scene>"#;
    let (file, warnings) = load_scene_str(nori, path).unwrap();
    assert_eq!(file.scene.shapes.len(), 1);
    assert_eq!(file.scene.camera.width, 4);
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    assert!(warnings[0].message.contains("version attribute is ignored"));
    let mitsuba = r#"<scene version="0.5.0">
  <shape type="sphere"/>
</scene>"#;
    let (file, warnings) = load_scene_str(mitsuba, path).unwrap();
    assert_eq!(file.scene.shapes.len(), 1);
    assert!(
        warnings
            .iter()
            .any(|w| w.message.contains("Mitsuba 0.5.0 scene: upgraded")),
        "{warnings:?}"
    );
}
