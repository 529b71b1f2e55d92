//! The spellings of the Nori forks students use (README, "Nori forks"):
//! ETH Zurich's point light (`point`, `power` in watts), the Universidad de
//! Zaragoza fork's `pointlight` (`radiance`, a radiant intensity in W/sr),
//! its `environment` emitter (`filename` optional, `radiance` a multiplier)
//! and `direct_whitted` integrator, mesh-level `toWorld`; the warnings that
//! say how an ambiguous name is read, and the radiometry of each reading.

use std::path::{Path, PathBuf};
use std::sync::atomic::AtomicBool;

use lente::color::{luminance, Rgb};
use lente::emitter::{Emitter, EnvMap};
use lente::geometry::Geometry;
use lente::image::Bitmap;
use lente::integrator::{Integrator, Strategy};
use lente::load::{SceneError, SceneFile, Warning};
use lente::math::{Vec2, Vec3, PI};
use lente::render::{render, RenderJob, RenderOptions};
use lente::scene::Scene;
use lente::stats::{sidak, t_test};
use lente::verify::scene_mean;

/// Scenes are read as if they stood in tests/scenes, next to its meshes.
fn scene_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/scenes/fork-test.xml")
}

#[track_caller]
fn load(text: &str) -> (SceneFile, Vec<Warning>) {
    crate::common::load_at(text, &scene_path(), &[])
}

#[track_caller]
fn load_clean(text: &str) -> SceneFile {
    crate::common::load_clean_at(text, &scene_path())
}

#[track_caller]
fn load_err(text: &str) -> SceneError {
    crate::common::load_err_at(text, &scene_path())
}

/// The one warning of a scene, which must mention every word of `words`
/// and stand at `line`:`col`.
#[track_caller]
fn one_warning(text: &str, line: u32, col: u32, words: &[&str]) -> SceneFile {
    let (desc, warnings) = load(text);
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    let w = &warnings[0];
    let shown = format!("{}:{}:{}: {}", w.file.display(), w.line, w.col, w.message);
    assert_eq!((w.line, w.col), (line, col), "{shown}");
    for word in words {
        assert!(w.message.contains(word), "'{word}' missing from: {shown}");
    }
    desc
}

fn point_intensity(desc: &SceneFile) -> (Vec3, Rgb) {
    match desc.scene.emitters.as_slice() {
        [Emitter::Point(lente::emitter::PointLight {
            position,
            intensity,
        })] => (*position, *intensity),
        other => panic!("expected one point light, found {other:?}"),
    }
}

#[track_caller]
fn close(a: Vec3, b: Vec3, rel: f32) {
    assert!(
        (a - b).abs().max_element() <= rel * b.abs().max_element().max(1e-6),
        "{a} != {b}"
    );
}

/// A diffuse floor (albedo 0.5, y = 0) seen at its origin by a 1x1 camera,
/// and one emitter.
fn floor_scene(integrator: &str, emitter: &str) -> String {
    format!(
        r#"<scene>
    <integrator type="{integrator}"/>
    <camera type="perspective">
        <transform name="toWorld">
            <lookat origin="0, 0.01, 0" target="0, 0, 0" up="0, 0, 1"/>
        </transform>
        <float name="fov" value="1e-6"/>
        <integer name="width" value="1"/>
        <integer name="height" value="1"/>
    </camera>
    <mesh type="obj">
        <string name="filename" value="meshes/floor.obj"/>
        <bsdf type="diffuse"><color name="albedo" value="0.5"/></bsdf>
    </mesh>
{emitter}
</scene>
"#
    )
}

/// The same small scene (a floor under one point light, seen obliquely)
/// rendered to an image.
fn render_image(desc: SceneFile) -> Bitmap {
    let scene = Scene::new(desc.scene).unwrap();
    let job = RenderJob { spp: 4, ..desc.job };
    render(
        &scene,
        &job,
        &RenderOptions::new(7),
        &AtomicBool::new(false),
    )
    .image
}

fn oblique_scene(emitter: &str) -> String {
    format!(
        r#"<scene>
    <integrator type="path_mis"/>
    <camera type="perspective">
        <transform name="toWorld">
            <lookat origin="0, 3, 6" target="0, 0, 0" up="0, 1, 0"/>
        </transform>
        <integer name="width" value="24"/>
        <integer name="height" value="16"/>
    </camera>
    <mesh type="obj">
        <string name="filename" value="meshes/floor.obj"/>
    </mesh>
    <mesh type="sphere">
        <point name="center" value="0, 1, 0"/>
    </mesh>
{emitter}
</scene>
"#
    )
}

// ---------------------------------------------------------------- point lights

/// A Zaragoza `pointlight` with `radiance` R, an ETH `point` with `power`
/// 4 pi R and a `point` with `intensity` R are one light: the same
/// intensity and, to rounding, the same image. None of them warns.
#[test]
fn pointlight_radiance_r_equals_point_power_4pi_r() {
    let r = Rgb::new(3.0, 2.0, 1.0);
    let p = r * 4.0 * PI;
    let zaragoza = oblique_scene(&format!(
        r#"<emitter type="pointlight">
        <color name="radiance" value="{}, {}, {}"/>
        <point name="position" value="1, 4, 2"/>
    </emitter>"#,
        r.x, r.y, r.z
    ));
    let eth = oblique_scene(&format!(
        r#"<emitter type="point">
        <point name="position" value="1, 4, 2"/>
        <color name="power" value="{:.9}, {:.9}, {:.9}"/>
    </emitter>"#,
        p.x, p.y, p.z
    ));
    let intensity = oblique_scene(&format!(
        r#"<emitter type="point">
        <point name="position" value="1, 4, 2"/>
        <color name="intensity" value="{}, {}, {}"/>
    </emitter>"#,
        r.x, r.y, r.z
    ));
    let descs: Vec<SceneFile> = [&zaragoza, &eth, &intensity]
        .into_iter()
        .map(|s| load_clean(s))
        .collect();
    for d in &descs {
        let (pos, i) = point_intensity(d);
        close(pos, Vec3::new(1.0, 4.0, 2.0), 0.0);
        close(i, r, 1e-6);
    }
    let images: Vec<Bitmap> = descs.into_iter().map(render_image).collect();
    assert!(images[0].mean().max_element() > 0.0, "the light shows");
    for img in &images[1..] {
        for (a, b) in img.pixels.iter().zip(&images[0].pixels) {
            close(*a, *b, 1e-4);
        }
    }
}

/// The Zaragoza reading, statistically: the floor under a `pointlight` of
/// `radiance` R shows rho / pi * R cos(theta) / d^2 (R is an intensity, not
/// a power), with the fork's own `direct_whitted` integrator as with
/// lente's `path_ems`. The ETH reading of the same number (a power, so
/// R / 4 pi) is rejected by the same test.
#[test]
fn pointlight_radiance_is_a_radiant_intensity() {
    let r = Rgb::new(20.0, 10.0, 5.0);
    let emitter = format!(
        r#"<emitter type="pointlight">
        <color name="radiance" value="{}, {}, {}"/>
        <point name="position" value="1, 2, 0.5"/>
    </emitter>"#,
        r.x, r.y, r.z
    );
    let d2 = 1.0 + 4.0 + 0.25;
    let cos = 2.0 / f64::sqrt(d2);
    let expect = 0.5 / std::f64::consts::PI * luminance(r) as f64 * cos / d2;
    let integrators = ["direct_whitted", "path_ems"];
    let alpha = sidak(0.01, integrators.len());
    for (k, integrator) in integrators.into_iter().enumerate() {
        let desc = load_clean(&floor_scene(integrator, &emitter));
        if integrator == "direct_whitted" {
            let ems = Integrator::Direct {
                strategy: Strategy::Ems,
            };
            assert_eq!(desc.job.integrator, ems);
        }
        let scene = Scene::new(desc.scene).unwrap();
        let mv = scene_mean(&scene, &desc.job.integrator, 20_000, 11 + k as u64);
        let t = t_test(&mv, expect);
        assert!(
            t.passes(alpha),
            "{integrator}: {} vs {expect} (p = {})",
            mv.mean(),
            t.p_value
        );
        let as_power = t_test(&mv, expect / (4.0 * std::f64::consts::PI));
        assert!(!as_power.passes(alpha), "{integrator}: test without power");
    }
}

/// `radiance` on a `point` (ETH's type, the Zaragoza fork's parameter)
/// is read as the Zaragoza fork reads it, with a warning saying so.
#[test]
fn radiance_on_a_point_light_warns_how_it_is_read() {
    let text = r#"<scene>
    <integrator type="path_ems"/>
    <camera type="perspective"/>
    <emitter type="point">
        <point name="position" value="0, 1, 0"/>
        <color name="radiance" value="2"/>
    </emitter>
</scene>
"#;
    let desc = one_warning(text, 6, 39, &["Zaragoza", "W/sr", "'power'"]);
    close(point_intensity(&desc).1, Rgb::splat(2.0), 0.0);
}

/// A `pointlight` takes the Zaragoza fork's defaults (at (0, 100, 0),
/// intensity 1), each with a warning; a `point` has none.
#[test]
fn pointlight_defaults_are_the_zaragoza_forks() {
    let text = r#"<scene>
    <integrator type="path_ems"/>
    <camera type="perspective"/>
    <emitter type="pointlight"/>
</scene>
"#;
    let (desc, warnings) = load(text);
    assert_eq!(warnings.len(), 2, "{warnings:?}");
    for w in &warnings {
        assert_eq!((w.line, w.col), (4, 5), "{w:?}");
        assert!(w.message.contains("Zaragoza"), "{w:?}");
    }
    assert!(warnings[0].message.contains("(0, 100, 0)"), "{warnings:?}");
    assert!(warnings[1].message.contains("1 W/sr"), "{warnings:?}");
    let (pos, i) = point_intensity(&desc);
    close(pos, Vec3::new(0.0, 100.0, 0.0), 0.0);
    close(i, Rgb::ONE, 0.0);

    let e = load_err(
        r#"<scene>
    <integrator type="path_ems"/>
    <camera type="perspective"/>
    <emitter type="point">
        <color name="power" value="1"/>
    </emitter>
</scene>
"#,
    );
    assert_eq!((e.line, e.col), (4, 5), "{e}");
    assert!(e.message.contains("'position'"), "{e}");
    let e = load_err(
        r#"<scene>
    <integrator type="path_ems"/>
    <camera type="perspective"/>
    <emitter type="point">
        <point name="position" value="0, 1, 0"/>
    </emitter>
</scene>
"#,
    );
    assert_eq!((e.line, e.col), (4, 5), "{e}");
    for word in ["'power'", "'radiance'", "'intensity'", "watts", "W/sr"] {
        assert!(e.message.contains(word), "'{word}' missing: {e}");
    }
}

/// Two spellings of the light's strength at once is an error at the
/// second, naming both.
#[test]
fn two_strengths_are_an_error() {
    let e = load_err(
        r#"<scene>
    <integrator type="path_ems"/>
    <camera type="perspective"/>
    <emitter type="pointlight">
        <color name="radiance" value="1"/>
        <point name="position" value="0, 1, 0"/>
        <color name="power" value="12.57"/>
    </emitter>
</scene>
"#,
    );
    assert_eq!((e.line, e.col), (7, 36), "{e}");
    assert!(e.message.contains("'radiance' and 'power'"), "{e}");
}

// ----------------------------------------------------------- the environment

/// The Zaragoza fork's `environment` without `filename` is a uniform
/// environment of `radiance` (times `scale`); with neither it is radiance 1,
/// with a warning. lente's own `envmap` still needs a file.
#[test]
fn environment_without_a_file_is_uniform() {
    let desc = load_clean(
        r#"<scene>
    <integrator type="path_mis"/>
    <camera type="perspective"/>
    <emitter type="environment">
        <color name="radiance" value="0.5, 0.25, 1"/>
        <float name="scale" value="2"/>
    </emitter>
</scene>
"#,
    );
    match desc.scene.emitters.as_slice() {
        [Emitter::Constant(lente::emitter::ConstantLight { radiance })] => {
            close(*radiance, Rgb::new(1.0, 0.5, 2.0), 0.0)
        }
        other => panic!("{other:?}"),
    }
    let text = r#"<scene>
    <integrator type="path_mis"/>
    <camera type="perspective"/>
    <emitter type="environment"/>
</scene>
"#;
    let desc = one_warning(text, 4, 5, &["Zaragoza", "'filename'", "radiance 1"]);
    match desc.scene.emitters.as_slice() {
        [Emitter::Constant(lente::emitter::ConstantLight { radiance })] => {
            close(*radiance, Rgb::ONE, 0.0)
        }
        other => panic!("{other:?}"),
    }
    let e = load_err(
        r#"<scene>
    <integrator type="path_mis"/>
    <camera type="perspective"/>
    <emitter type="envmap"/>
</scene>
"#,
    );
    assert!(e.message.contains("'filename'"), "{e}");
}

/// Radiometry of the uniform Zaragoza environment: a diffuse sphere of
/// albedo rho under radiance L shows rho L where the camera sees it.
#[test]
fn uniform_environment_lights_a_diffuse_sphere() {
    let desc = load_clean(
        r#"<scene>
    <integrator type="path_mis"/>
    <camera type="perspective">
        <transform name="toWorld">
            <lookat origin="0, 0, -5" target="0, 0, 0" up="0, 1, 0"/>
        </transform>
        <float name="fov" value="1"/>
        <integer name="width" value="1"/>
        <integer name="height" value="1"/>
    </camera>
    <mesh type="sphere">
        <bsdf type="diffuse"><color name="albedo" value="0.6"/></bsdf>
    </mesh>
    <emitter type="environment">
        <color name="radiance" value="0.8"/>
    </emitter>
</scene>
"#,
    );
    let scene = Scene::new(desc.scene).unwrap();
    let mv = scene_mean(&scene, &desc.job.integrator, 20_000, 3);
    let expect = 0.6 * 0.8;
    assert!(
        t_test(&mv, expect).passes(0.01),
        "{} vs {expect}",
        mv.mean()
    );
    assert!(
        !t_test(&mv, expect * 1.05).passes(0.01),
        "test without power"
    );
}

/// A 4x2 lat-long map with one colour per column, both rows alike.
fn write_columns_map(dir: &Path) -> Vec<Rgb> {
    let cols = vec![
        Rgb::new(1.0, 0.0, 0.0),
        Rgb::new(0.0, 1.0, 0.0),
        Rgb::new(0.0, 0.0, 1.0),
        Rgb::new(1.0, 1.0, 0.0),
    ];
    let mut b = Bitmap::new(4, 2);
    for j in 0..2 {
        for (i, c) in cols.iter().enumerate() {
            b.set(i, j, *c);
        }
    }
    std::fs::create_dir_all(dir).unwrap();
    lente::image::io::save_image(&dir.join("columns.pfm"), &b).unwrap();
    cols
}

fn env_of(desc: &SceneFile) -> &EnvMap {
    match desc.scene.emitters.as_slice() {
        [Emitter::Environment(env)] => env,
        other => panic!("expected one environment map, found {other:?}"),
    }
}

/// With an image, the Zaragoza fork's `radiance` multiplies it (and
/// `scale` too). lente keeps Mitsuba's lat-long layout and warns that the
/// fork's differs, giving the rotation that reproduces it; with that
/// rotation each column of the map shows where the Zaragoza fork shows it
/// (u = atan2(z, x) / 2 pi).
#[test]
fn environment_map_as_the_zaragoza_fork_writes_it() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let cols = write_columns_map(dir);
    let path = dir.join("scene.xml");
    let scene = |transform: &str| {
        format!(
            r#"<scene>
    <integrator type="path_mis"/>
    <camera type="perspective"/>
    <emitter type="environment">
        <string name="filename" value="columns.pfm"/>
        <color name="radiance" value="2, 1, 0.5"/>
        <float name="scale" value="1.5"/>
        <string name="filter" value="nearest"/>{transform}
    </emitter>
</scene>
"#
        )
    };
    let gain = Rgb::new(2.0, 1.0, 0.5) * 1.5;

    // As written: lente's layout, with the warning.
    let (desc, warnings) = crate::common::load_at(&scene(""), &path, &[]);
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    let w = &warnings[0];
    assert_eq!((w.line, w.col), (6, 39), "{w:?}");
    for word in ["Zaragoza", "atan2(z, x)", "angle=\"-90\""] {
        assert!(w.message.contains(word), "'{word}' missing: {w:?}");
    }
    let env = env_of(&desc);
    for (i, c) in cols.iter().enumerate() {
        let d = EnvMap::uv_to_dir(Vec2::new((i as f32 + 0.5) / 4.0, 0.25));
        close(env.eval(d), *c * gain, 1e-5);
    }

    // With the rotation the warning gives: the Zaragoza fork's layout.
    let rotated = scene(
        r#"
        <transform name="toWorld"><rotate axis="0,1,0" angle="-90"/></transform>"#,
    );
    let (desc, warnings) = crate::common::load_at(&rotated, &path, &[]);
    assert!(warnings.is_empty(), "{warnings:?}");
    let env = env_of(&desc);
    let theta = 0.25 * PI;
    for (i, c) in cols.iter().enumerate() {
        let phi = 2.0 * PI * (i as f32 + 0.5) / 4.0;
        // The Zaragoza fork's direction for (u, v): phi = atan2(z, x).
        let d = Vec3::new(
            theta.sin() * phi.cos(),
            theta.cos(),
            theta.sin() * phi.sin(),
        );
        close(env.eval(d), *c * gain, 1e-5);
    }
}

// ------------------------------------------------------------ mesh toWorld

/// A mesh-level `toWorld` moves OBJ meshes and spheres alike, its
/// operations applied in document order.
#[test]
fn mesh_to_world_on_obj_and_sphere() {
    let desc = load_clean(
        r#"<scene>
    <integrator type="normals"/>
    <camera type="perspective"/>
    <mesh type="obj">
        <string name="filename" value="meshes/floor.obj"/>
        <transform name="toWorld">
            <scale value="0.1"/>
            <rotate axis="1, 0, 0" angle="90"/>
            <translate value="0, 0, 5"/>
        </transform>
    </mesh>
    <mesh type="sphere">
        <point name="center" value="1, 0, 0"/>
        <float name="radius" value="0.5"/>
        <transform name="toWorld">
            <scale value="2"/>
            <translate value="0, 3, 0"/>
        </transform>
    </mesh>
</scene>
"#,
    );
    match &desc.scene.shapes[0].geometry {
        Geometry::Mesh(m) => {
            // The 20 x 20 floor at y = 0, shrunk to 2 x 2, stood up in the
            // xy-plane (90 degrees about +x takes (x, y, z) to (x, -z, y))
            // and moved to z = 5.
            let b = m.bounds();
            close(b.min, Vec3::new(-1.0, -1.0, 5.0), 1e-5);
            close(b.max, Vec3::new(1.0, 1.0, 5.0), 1e-5);
        }
        other => panic!("{other:?}"),
    }
    match &desc.scene.shapes[1].geometry {
        Geometry::Sphere(s) => {
            close(s.center, Vec3::new(2.0, 3.0, 0.0), 1e-6);
            assert!((s.radius - 1.0).abs() < 1e-6, "{}", s.radius);
        }
        other => panic!("{other:?}"),
    }
}

// ------------------------------------------- names other forks read differently

/// The Zaragoza fork's area emitter reads `scale` and never applies it;
/// lente ignores it too, and says so.
#[test]
fn area_scale_warns_naming_the_zaragoza_fork() {
    let text = r#"<scene>
    <integrator type="path_mis"/>
    <camera type="perspective"/>
    <mesh type="sphere">
        <emitter type="area">
            <color name="radiance" value="1"/>
            <float name="scale" value="3"/>
        </emitter>
    </mesh>
</scene>
"#;
    let desc = one_warning(text, 7, 40, &["Zaragoza", "'scale'", "ignores"]);
    close(desc.scene.shapes[0].area_radiance.unwrap(), Rgb::ONE, 0.0);
}

/// `R0` (the Zaragoza fork's roughconductor) on a microfacet warns.
#[test]
fn microfacet_r0_warns_naming_the_zaragoza_fork() {
    let text = r#"<scene>
    <integrator type="path_mis"/>
    <camera type="perspective"/>
    <mesh type="sphere">
        <bsdf type="microfacet">
            <color name="R0" value="0.9"/>
        </bsdf>
    </mesh>
</scene>
"#;
    one_warning(text, 6, 37, &["Zaragoza", "roughconductor", "'R0'"]);
}

/// The Zaragoza fork's `roughconductor` and `roughsubstrate` are read with
/// its defaults and names; at normal incidence (wi = wo = n) their values
/// are the fork's formulas': D = 1 / (pi alpha^2), G = 1, so
/// R0 / (4 pi alpha^2), and F(1) / (4 pi alpha^2) + 28 kd (1 - R0) /
/// (23 pi) (1 - 0.5^5)^2 for the substrate.
#[test]
fn zaragoza_rough_bsdfs_are_the_forks_models() {
    let text = r#"<scene>
    <integrator type="path_mis"/>
    <camera type="perspective"/>
    <mesh type="sphere">
        <bsdf type="roughconductor">
            <float name="alpha" value="0.3"/>
            <color name="R0" value="0.9, 0.6, 0.3"/>
        </bsdf>
    </mesh>
    <mesh type="sphere">
        <point name="center" value="3, 0, 0"/>
        <bsdf type="roughsubstrate">
            <float name="alpha" value="0.2"/>
            <color name="kd" value="0.8, 0.4, 0.2"/>
        </bsdf>
    </mesh>
    <mesh type="sphere">
        <point name="center" value="6, 0, 0"/>
        <bsdf type="roughconductor"/>
    </mesh>
</scene>
"#;
    let desc = load_clean(text);
    let n = Vec3::Z;
    let f = |i: usize| desc.scene.shapes[i].bsdf.eval(Vec2::ZERO, n, n);
    let expect = Rgb::new(0.9, 0.6, 0.3) / (4.0 * PI * 0.09);
    close(f(0), expect, 1e-4 * expect.max_element());
    let r = (1.000277f32 - 1.5046) / (1.000277 + 1.5046);
    let r0 = r * r;
    let coat = r0 / (4.0 * PI * 0.04);
    let base = 28.0 * (1.0 - r0) / (23.0 * PI) * (1.0 - 0.5f32.powi(5)).powi(2);
    let expect = Rgb::splat(coat) + Rgb::new(0.8, 0.4, 0.2) * base;
    close(f(1), expect, 1e-4 * expect.max_element());
    // Defaults: alpha 0.1, R0 0.5.
    let expect = Rgb::splat(0.5 / (4.0 * PI * 0.01));
    close(f(2), expect, 1e-4 * expect.max_element());
    // R0 above 1 is refused at its value.
    let e = load_err(&text.replace("0.9, 0.6, 0.3", "1.2, 0.6, 0.3"));
    assert_eq!((e.line, e.col), (7, 37), "{e}");
    assert!(e.message.contains("'R0'"), "{e}");
}

/// ETH students write their environment map inside a big `<mesh
/// type="sphere">`: it becomes the scene's environment (one warning), the
/// sphere around it is left out; a second environment is still an error,
/// and a point light inside a mesh still cannot stand there.
#[test]
fn an_environment_inside_a_mesh_is_the_scenes_environment() {
    let text = r#"<scene>
    <integrator type="path_mis"/>
    <camera type="perspective"/>
    <mesh type="sphere">
        <float name="radius" value="1000"/>
        <emitter type="envmap">
            <string name="filename" value="ENV"/>
        </emitter>
    </mesh>
    <mesh type="sphere"/>
</scene>
"#;
    let env = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/conformance/stripes.pfm");
    let text = text.replace("ENV", env.to_str().unwrap());
    let desc = one_warning(&text, 6, 9, &["scene's environment", "left out", "<scene>"]);
    assert_eq!(desc.scene.shapes.len(), 1);
    assert!(matches!(
        desc.scene.emitters.as_slice(),
        [Emitter::Environment(_)]
    ));
    let twice = text.replace(
        "<mesh type=\"sphere\"/>",
        "<emitter type=\"environment\"><color name=\"radiance\" value=\"1\"/></emitter>",
    );
    let e = load_err(&twice);
    assert_eq!((e.line, e.col), (10, 5), "{e}");
    assert!(e.message.contains("at most one environment"), "{e}");
    let e = load_err(&text.replace(
        "<emitter type=\"envmap\">",
        "<emitter type=\"point\"><point name=\"position\" value=\"0, 1, 0\"/>",
    ));
    assert_eq!((e.line, e.col), (6, 9), "{e}");
    assert!(e.message.contains("cannot stand inside a <mesh>"), "{e}");
}

/// Object types and elements only the Zaragoza fork has are errors that
/// name it and point to lente's nearest equivalent.
#[test]
fn zaragoza_only_types_are_errors_naming_the_fork() {
    let bsdf = |ty: &str| {
        format!(
            "<scene>\n<integrator type=\"path_mis\"/>\n<camera type=\"perspective\"/>\n\
             <mesh type=\"sphere\">\n<bsdf type=\"{ty}\"/>\n</mesh>\n</scene>\n"
        )
    };
    for (ty, words) in [("roughdielectric", &["Zaragoza", "Mitsuba"][..])] {
        let e = load_err(&bsdf(ty));
        assert_eq!((e.line, e.col), (5, 13), "{e}");
        assert!(
            e.message
                .contains(&format!("<bsdf type=\"{ty}\"> is not supported by lente")),
            "{e}"
        );
        for w in words {
            assert!(e.message.contains(w), "'{w}' missing: {e}");
        }
    }
    let e = load_err(
        "<scene>\n<integrator type=\"depth\"/>\n<camera type=\"perspective\"/>\n</scene>\n",
    );
    assert!(e.message.contains("Zaragoza"), "{e}");
}

/// The Zaragoza fork's first assignment scene, as its students write it
/// (`direct_whitted`, a `pointlight` with `radiance`, a default BSDF),
/// loads without a word and renders.
#[test]
fn a_zaragoza_assignment_scene_loads_and_renders() {
    let desc = load_clean(
        r#"<scene>
	<sampler type="independent">
		<integer name="sampleCount" value="1"/>
	</sampler>
    <integrator type="direct_whitted"/>
	<mesh type="obj">
		<string name="filename" value="meshes/floor.obj"/>
		<bsdf type="diffuse"/>
	</mesh>
	<emitter type="pointlight">
		<color name="radiance" value="120, 90, 90"/>
		<point name="position" value="-2.5, 5, 0"/>
	</emitter>
	<camera type="perspective">
		<transform name="toWorld">
			<lookat target="0, 0, 0" origin="3, 2, 4" up="0, 1, 0"/>
		</transform>
		<float name="fov" value="45"/>
		<integer name="width" value="32"/>
		<integer name="height" value="24"/>
	</camera>
</scene>
"#,
    );
    let img = render_image(desc);
    assert!(img.pixels.iter().all(|p| p.is_finite()));
    assert!(img.mean().max_element() > 0.0);
}

/// tests/scenes/fork-lights.xml (a Nori t-test file that `lente test`
/// runs with the others) holds the references its comment derives, and
/// its lights are the intensities it says.
#[test]
fn fork_lights_test_file_references_are_the_closed_forms() {
    use lente::load::nori_testfile::{load_test, NoriTest};
    use std::f64::consts::PI as PI64;
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/scenes/fork-lights.xml");
    let (file, warnings) = load_test(&path).unwrap();
    assert!(warnings.is_empty(), "{warnings:?}");
    let NoriTest::SceneTTest {
        scenes, references, ..
    } = file.test
    else {
        panic!("a scene t-test");
    };
    let lum = |c: [f64; 3]| 0.212671 * c[0] + 0.715160 * c[1] + 0.072169 * c[2];
    let on_axis = 0.5 / PI64 / 4.0;
    let d2: f64 = 5.25;
    let off_axis = 0.5 / PI64 * lum([2.0, 1.0, 0.5]) * (2.0 / d2.sqrt()) / d2;
    let want = [on_axis, on_axis, off_axis, off_axis, off_axis, 0.4];
    assert_eq!(references.len(), want.len());
    for (r, w) in references.iter().zip(want) {
        assert!((r - w).abs() <= 1e-8 * w, "{r} vs {w}");
    }
    let i = |k: usize| point_intensity(&scenes[k].file).1;
    close(i(0), Rgb::ONE, 0.0);
    for k in 2..5 {
        close(i(k), Rgb::new(2.0, 1.0, 0.5), 1e-6);
    }
    match scenes[5].file.scene.emitters.as_slice() {
        [Emitter::Constant(lente::emitter::ConstantLight { radiance })] => {
            close(*radiance, Rgb::splat(0.8), 0.0)
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn a_plain_direct_integrator_is_direct_lighting_with_mis() {
    let desc =
        load_clean(r#"<scene><integrator type="direct"/><camera type="perspective"/></scene>"#);
    assert_eq!(
        desc.job.integrator,
        Integrator::Direct {
            strategy: Strategy::Mis
        }
    );
}

/// The diffuse colour a loaded shape's BSDF has at `uv` (straight-down
/// light and view, so eval = albedo / pi).
fn albedo_at(desc: &SceneFile, shape: usize, uv: Vec2) -> Rgb {
    desc.scene.shapes[shape].bsdf.eval(uv, Vec3::Z, Vec3::Z) * PI
}

#[track_caller]
fn near(a: Rgb, b: Rgb) {
    assert!((a - b).abs().max_element() < 1e-5, "{a} vs {b}");
}

/// ETH's course textures: `checkerboard_color` with `scale` and `delta` as
/// two numbers, value1 where the squares' parities agree (the course's
/// reference images), on a sphere whose (u, v) is the course's
/// (1/2 + atan2(y, x) / 2pi, 1/2 + asin(z) / pi); one warning says that
/// ETH's camera mirrors the image.
#[test]
fn eth_textures_read_as_the_course_defines_them() {
    let text = r#"<scene>
  <integrator type="direct"/>
  <camera type="perspective"/>
  <mesh type="sphere">
    <point name="center" value="0,0,3"/>
    <float name="radius" value="2"/>
    <bsdf type="diffuse">
      <texture type="checkerboard_color" name="albedo">
        <vector name="scale" value="0.1,0.2"/>
        <point name="delta" value="0.5,0.5"/>
        <color name="value1" value="0.8,0.8,0.8"/>
        <color name="value2" value="0.2,0.3,0.4"/>
      </texture>
    </bsdf>
  </mesh>
  <mesh type="sphere">
    <point name="center" value="0,0,-3"/>
    <bsdf type="diffuse">
      <texture type="constant_float" name="albedo"><float name="value" value="0.25"/></texture>
    </bsdf>
  </mesh>
</scene>"#;
    let desc = one_warning(text, 8, 7, &["ETH", "mirrors", "<scale value=\"-1,1,1\"/>"]);
    let (v1, v2) = (Rgb::splat(0.8), Rgb::new(0.2, 0.3, 0.4));
    // floor(u / 0.1 - 0.5), floor(v / 0.2 - 0.5): (-1, -1), (0, -1), (0, 0).
    near(albedo_at(&desc, 0, Vec2::new(0.02, 0.02)), v1);
    near(albedo_at(&desc, 0, Vec2::new(0.12, 0.02)), v2);
    near(albedo_at(&desc, 0, Vec2::new(0.12, 0.15)), v1);
    near(albedo_at(&desc, 1, Vec2::new(0.7, 0.1)), Rgb::splat(0.25));
    let Geometry::Sphere(s) = &desc.scene.shapes[0].geometry else {
        panic!("a sphere");
    };
    // The top (+z) is v = 1; -x is u = 1 (atan2(0, -1) = pi); +y is 3/4.
    let uv = |p: Vec3| s.normal_uv(Vec3::new(0.0, 0.0, 3.0) + 2.0 * p).1;
    assert!((uv(Vec3::Z).y - 1.0).abs() < 1e-6);
    assert!((uv(Vec3::NEG_Z).y).abs() < 1e-6);
    assert!((uv(Vec3::NEG_X).x - 1.0).abs() < 1e-6);
    assert!((uv(Vec3::Y) - Vec2::new(0.75, 0.5)).length() < 1e-6);
}

/// The Zaragoza fork's `checker` (0.9 and 0.1 squares, int scales) and
/// `textmap` (an 8-bit image read raw, times `color`) on its diffuse,
/// roughconductor and area emitter.
#[test]
fn zaragoza_textures_read_as_the_fork_defines_them() {
    let dir = tempfile::tempdir().unwrap();
    // 2x1 texels: red-ish on the left, blue-ish on the right.
    let img = image::RgbImage::from_fn(2, 1, |x, _| {
        if x == 0 {
            image::Rgb([255, 51, 0])
        } else {
            image::Rgb([0, 102, 204])
        }
    });
    img.save(dir.path().join("tex.png")).unwrap();
    let text = r#"<scene>
  <integrator type="path_mis"/>
  <camera type="perspective"/>
  <mesh type="obj">
    <string name="filename" value="quad.obj"/>
    <bsdf type="diffuse">
      <texture type="checker" name="albedo">
        <integer name="scalex" value="4"/>
        <integer name="scaley" value="4"/>
      </texture>
    </bsdf>
  </mesh>
  <mesh type="obj">
    <string name="filename" value="quad.obj"/>
    <bsdf type="roughconductor">
      <texture type="checker" name="R0"/>
      <float name="alpha" value="0.2"/>
    </bsdf>
    <emitter type="area">
      <texture type="textmap" name="radiance">
        <string name="filename" value="tex.png"/>
        <color name="color" value="2,2,2"/>
      </texture>
    </emitter>
  </mesh>
</scene>"#;
    std::fs::write(
        dir.path().join("quad.obj"),
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n",
    )
    .unwrap();
    let path = dir.path().join("zaragoza.xml");
    let desc = crate::common::load_clean_at(text, &path);
    // Squares of 1/4: (0, 0) and (1, 1) are 0.9, (1, 0) is 0.1.
    near(albedo_at(&desc, 0, Vec2::new(0.1, 0.1)), Rgb::splat(0.9));
    near(albedo_at(&desc, 0, Vec2::new(0.3, 0.3)), Rgb::splat(0.9));
    near(albedo_at(&desc, 0, Vec2::new(0.3, 0.1)), Rgb::splat(0.1));
    // The R0 texture reaches the conductor: brighter on a 0.9 square.
    let f = |uv: Vec2| desc.scene.shapes[1].bsdf.eval(uv, Vec3::Z, Vec3::Z);
    let (bright, dark) = (f(Vec2::new(0.1, 0.1)), f(Vec2::new(1.5, 0.1)));
    assert!(bright.x > 5.0 * dark.x, "{bright} vs {dark}");
    // textmap: u reversed and read between texel corners, so u = 1 is the
    // left texel; raw bytes / 255 times color 2.
    let t = desc.scene.shapes[1]
        .area_texture
        .as_ref()
        .expect("textured");
    near(t.eval(Vec2::new(1.0, 0.5)), Rgb::new(2.0, 0.4, 0.0));
    near(t.eval(Vec2::new(0.5, 0.5)), Rgb::new(0.0, 0.8, 1.6));
    near(t.eval(Vec2::new(0.75, 0.5)), Rgb::new(1.0, 0.6, 0.8));
    let mean = desc.scene.shapes[1].area_radiance.unwrap();
    near(mean, Rgb::new(1.0, 0.6, 0.8));
}

#[test]
fn texture_mistakes_are_located_errors() {
    let scene = |bsdf: &str| {
        format!(
            "<scene>\n<integrator type=\"direct\"/>\n<camera type=\"perspective\"/>\n<mesh type=\"sphere\">\n{bsdf}\n</mesh>\n</scene>"
        )
    };
    let cases: &[(&str, u32, &[&str])] = &[
        (
            "<bsdf type=\"diffuse\"><texture type=\"checker\" name=\"kd\"/></bsdf>",
            5,
            &["no texture 'kd'", "'albedo'"],
        ),
        (
            "<bsdf type=\"mirror\"><texture type=\"checker\" name=\"albedo\"/></bsdf>",
            5,
            &["takes no textures"],
        ),
        (
            "<bsdf type=\"diffuse\"><color name=\"albedo\" value=\"0.5\"/><texture type=\"checker\" name=\"albedo\"/></bsdf>",
            5,
            &["given twice"],
        ),
        (
            "<bsdf type=\"diffuse\"><texture type=\"perlin_noise\" name=\"albedo\"/></bsdf>",
            5,
            &["unknown <texture> type 'perlin_noise'", "textmap", "image_texture"],
        ),
        (
            "<bsdf type=\"diffuse\"><texture type=\"image_texture\" name=\"albedo\"/></bsdf>",
            5,
            &["needs the property 'filename'"],
        ),
        (
            "<bsdf type=\"diffuse\"><texture type=\"image_texture\" name=\"albedo\"><string name=\"filename\" value=\"probe.exr\"/></texture></bsdf>",
            5,
            &["8-bit images"],
        ),
        (
            "<bsdf type=\"diffuse\"><texture type=\"checker\"/></bsdf>",
            5,
            &["needs a 'name' attribute"],
        ),
        (
            "<bsdf type=\"diffuse\"><texture type=\"checkerboard_color\" name=\"albedo\"><vector name=\"scale\" value=\"0,1\"/></texture></bsdf>",
            5,
            &["cannot be 0"],
        ),
        (
            "<bsdf type=\"diffuse\"><texture type=\"textmap\" name=\"albedo\"><string name=\"filename\" value=\"probe.exr\"/></texture></bsdf>",
            5,
            &["8-bit images"],
        ),
    ];
    for (bsdf, line, words) in cases {
        let e = load_err(&scene(bsdf));
        assert_eq!(e.line, *line, "{e}");
        for w in *words {
            assert!(e.message.contains(w), "'{w}' missing from: {e}");
        }
    }
}

/// What students' files carry that Nori's parser (pugixml) accepts: a
/// Mitsuba `version="3.0.0"` on a Nori file, an XML declaration after a
/// blank line; and ETH students' `focalLength` for the focus distance.
#[test]
fn students_files_load_as_nori_does() {
    let text = "\n  <?xml version=\"1.0\"?>\n<scene version=\"3.0.0\">\n  <integrator type=\"path_mis\"/>\n  <camera type=\"perspective\">\n    <float name=\"lensRadius\" value=\"0.1\"/>\n    <float name=\"focalLength\" value=\"7\"/>\n  </camera>\n</scene>\n";
    let (desc, warnings) = load(text);
    assert_eq!(desc.scene.camera.focal_distance, 7.0);
    assert_eq!(desc.scene.camera.lens_radius, 0.1);
    assert_eq!(warnings.len(), 2, "{warnings:?}");
    assert!(warnings[1].message.contains("version attribute is ignored"));
    assert_eq!((warnings[0].line, warnings[0].col), (7, 38));
    assert!(warnings[0]
        .message
        .contains("distance to the plane in focus"));
    // A broken file still reports the right line after the blanked
    // declaration.
    let e =
        load_err("\n<?xml version=\"1.0\"?>\n<scene>\n  <camera type=\"perspective\"\n</scene>\n");
    assert_eq!(e.line, 5, "{e}");
}

// ------------------------------------------------------- ETH students' lights

/// The ETH students' `directional` light: `power` is the irradiance of a
/// surface facing it, `direction` where the light travels (normalised,
/// with a warning, where the fork uses it as given). A diffuse floor of
/// albedo 0.5 under irradiance 0.8 from straight above has radiance
/// 0.5 / pi * 0.8.
#[test]
fn eth_directional_light_power_is_irradiance() {
    let text = floor_scene(
        "direct",
        r#"<emitter type="directional">
    <vector name="direction" value="0, -2, 0"/>
    <color name="power" value="0.8, 0.8, 0.8"/>
</emitter>"#,
    );
    let desc = one_warning(&text, 16, 37, &["unnormalised", "2.000"]);
    let pixel = render_image(desc).pixels[0];
    let want = 0.5 / std::f32::consts::PI * 0.8;
    assert!(
        (pixel - Rgb::splat(want)).abs().max_element() < 1e-4 * want,
        "{pixel} vs {want}"
    );
    let err = load_err(&floor_scene(
        "direct",
        r#"<emitter type="directional"><color name="power" value="1"/></emitter>"#,
    ));
    assert!(err.to_string().contains("direction"), "{err}");
}

/// The ETH course's `photonmapper` is rendered with `path_mis` (the image
/// photon mapping converges to), with one warning at the integrator; its
/// parameters are read and checked.
#[test]
fn photonmapper_is_rendered_by_the_path_tracer() {
    let with = |params: &str| {
        floor_scene("path_mis", "").replace(
            r#"<integrator type="path_mis"/>"#,
            &format!(r#"<integrator type="photonmapper">{params}</integrator>"#),
        )
    };
    let text = with(
        r#"<integer name="photonCount" value="100000"/><float name="photonRadius" value="0.05"/>"#,
    );
    let desc = one_warning(&text, 2, 5, &["photonmapper", "path_mis", "ignored"]);
    assert!(
        matches!(
            desc.job.integrator,
            Integrator::Path {
                strategy: Strategy::Mis,
                ..
            }
        ),
        "{:?}",
        desc.job.integrator
    );
    let bad = with(r#"<float name="photonRadius" value="-1"/>"#);
    assert!(load_err(&bad).message.contains("must not be negative"));
}
