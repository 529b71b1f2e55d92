//! `render --aov`: the output variables land in the EXR under the names
//! denoisers and Mitsuba read, hold the right values where they are known
//! in closed form, leave the image bit for bit unchanged, and continue and
//! merge like the image.

use crate::cli_util::{run_fails_with, run_ok, write_cbox};
use lente::image::{load_exr_channels, ExrChannels};
use lente::render_file::RenderFile;

fn at(exr: &ExrChannels, name: &str, x: usize, y: usize) -> f32 {
    exr.channel(name)
        .unwrap_or_else(|| panic!("no channel {name}"))[y * exr.width + x]
}

#[test]
fn aovs_hold_known_values_and_leave_the_image_unchanged() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_cbox(&dir, 64, 64, 8);
    let s = scene.to_str().unwrap();
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    run_ok(&["render", s, "-q", "-o", &path("plain")]);
    run_ok(&[
        "render",
        s,
        "-q",
        "--aov",
        "albedo,normal,depth,position",
        "-o",
        &path("aov"),
    ]);
    let plain = load_exr_channels(&dir.path().join("plain.exr")).unwrap();
    let aov = load_exr_channels(&dir.path().join("aov.exr")).unwrap();
    for c in [
        "R",
        "G",
        "B",
        "lente.film.R",
        "lente.film.G",
        "lente.film.B",
        "lente.weight.Y",
    ] {
        assert!(
            plain.channel(c) == aov.channel(c),
            "channel {c} changed with --aov"
        );
    }
    // The back wall above the spheres: its albedo exactly (one cosine-
    // weighted sample of a diffuse BSDF weighs its reflectance), its
    // normal towards the camera, and depth = |position - camera|.
    let (x, y) = (32, 22);
    let albedo = ["albedo.R", "albedo.G", "albedo.B"].map(|c| at(&aov, c, x, y));
    for (a, e) in albedo.iter().zip([0.725, 0.71, 0.68]) {
        assert!((a - e).abs() < 1e-5, "albedo {albedo:?}");
    }
    let n = ["normal.X", "normal.Y", "normal.Z"].map(|c| at(&aov, c, x, y));
    assert!(
        n[0].abs() < 1e-5 && n[1].abs() < 1e-5 && (n[2] - 1.0).abs() < 1e-5,
        "normal {n:?}"
    );
    let p = ["position.X", "position.Y", "position.Z"].map(|c| at(&aov, c, x, y));
    let dist = (p[0].powi(2) + (p[1] - 1.0).powi(2) + (p[2] - 3.9).powi(2)).sqrt();
    let depth = at(&aov, "depth.Z", x, y);
    assert!(
        (depth - dist).abs() < 0.02 * dist,
        "depth {depth} vs |p - o| {dist}"
    );
    // The red wall.
    let red = ["albedo.R", "albedo.G", "albedo.B"].map(|c| at(&aov, c, 6, 32));
    for (a, e) in red.iter().zip([0.63, 0.065, 0.05]) {
        assert!((a - e).abs() < 1e-5, "red wall albedo {red:?}");
    }
    // The mirror sphere shows what it reflects: an albedo of the walls',
    // not black.
    let mirror = ["albedo.R", "albedo.G", "albedo.B"].map(|c| at(&aov, c, 22, 50));
    assert!(mirror.iter().sum::<f32>() > 0.1, "mirror albedo {mirror:?}");
    // Mitsuba's Bitmap::split and tev group channels by prefix: no `.W`.
    assert!(aov.channels.iter().all(|(n, _)| !n.ends_with(".W")));

    run_fails_with(
        &["render", s, "-q", "--aov", "albedo,uv"],
        "unknown AOV 'uv'",
    );
}

#[test]
fn aovs_continue_and_merge_like_the_image() {
    let dir = tempfile::tempdir().unwrap();
    let scene = write_cbox(&dir, 24, 20, 32);
    let s = scene.to_str().unwrap();
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    run_ok(&[
        "render",
        s,
        "-q",
        "--aov",
        "albedo,normal",
        "--spp",
        "8",
        "-o",
        &path("part"),
    ]);
    run_ok(&["render", "--resume", &path("part.exr"), "--spp", "32", "-q"]);
    run_ok(&[
        "render",
        s,
        "-q",
        "--aov",
        "albedo,normal",
        "-o",
        &path("whole"),
    ]);
    let a = RenderFile::load(&dir.path().join("part.exr")).unwrap();
    let b = RenderFile::load(&dir.path().join("whole.exr")).unwrap();
    assert_eq!(a.meta.aovs.to_string(), "albedo,normal");
    assert!(
        a.film.aov_sums() == b.film.aov_sums(),
        "continued AOVs differ"
    );
    assert!(a.film.data() == b.film.data());
    run_fails_with(
        &[
            "render",
            "--resume",
            &path("whole.exr"),
            "--spp",
            "40",
            "--aov",
            "depth",
        ],
        "keeps them",
    );

    run_ok(&[
        "render",
        s,
        "-q",
        "--aov",
        "albedo,normal",
        "--seed",
        "1",
        "-o",
        &path("s1"),
    ]);
    run_ok(&[
        "merge",
        &path("whole.exr"),
        &path("s1.exr"),
        "-o",
        &path("m"),
    ]);
    let m = load_exr_channels(&dir.path().join("m.exr")).unwrap();
    assert!(m.channel("albedo.R").is_some() && m.channel("lente.film.normal.Z").is_some());
    run_ok(&["render", s, "-q", "--seed", "2", "-o", &path("none")]);
    run_fails_with(
        &[
            "merge",
            &path("whole.exr"),
            &path("none.exr"),
            "-o",
            &path("bad"),
        ],
        "renders with the same --aov only",
    );
}

/// A Mitsuba scene with the `aov` integrator (`INTEGRATOR` replaced):
/// a diffuse sphere in front of a rough-plastic one, a mirror behind,
/// under a constant sky.
const MITSUBA_AOV_SCENE: &str = r#"<scene version="3.0.0">
    INTEGRATOR
    <sensor type="perspective">
        <float name="fov" value="40"/>
        <transform name="to_world"><lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="16"/></sampler>
        <film type="hdrfilm"><integer name="width" value="64"/><integer name="height" value="48"/>
            <rfilter type="box"/></film>
    </sensor>
    <shape type="sphere"><point name="center" value="0.6, 0, 0"/><float name="radius" value="0.8"/>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.2, 0.5, 0.7"/></bsdf></shape>
    <shape type="sphere"><point name="center" value="-1, 0.2, -1"/><float name="radius" value="0.7"/>
        <bsdf type="roughplastic"><rgb name="diffuse_reflectance" value="0.6, 0.3, 0.1"/></bsdf></shape>
    <shape type="rectangle"><transform name="to_world"><scale value="3"/><translate value="0,0,-2"/></transform>
        <bsdf type="conductor"/></shape>
    <emitter type="constant"><rgb name="radiance" value="1"/></emitter>
</scene>
"#;

const AOV_INTEGRATOR: &str = r#"<integrator type="aov">
        <string name="aovs" value="dd:depth,nn:sh_normal,alb:albedo,pp:position,tex:uv,gn:geo_normal,si:shape_index,pi:prim_index"/>
        <integrator type="path" name="my_image"/>
    </integrator>"#;

fn channel_mean(exr: &ExrChannels, name: &str) -> f64 {
    let c = exr
        .channel(name)
        .unwrap_or_else(|| panic!("no channel {name}"));
    c.iter().map(|&v| v as f64).sum::<f64>() / c.len() as f64
}

#[test]
fn mitsubas_aov_integrator_writes_its_channels_with_its_values() {
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, integrator: &str| {
        let p = dir.path().join(name);
        std::fs::write(&p, MITSUBA_AOV_SCENE.replace("INTEGRATOR", integrator)).unwrap();
        p.to_str().unwrap().to_string()
    };
    let aov = write("aov.xml", AOV_INTEGRATOR);
    let plain = write("plain.xml", r#"<integrator type="path"/>"#);
    let out = |name: &str| dir.path().join(name).to_str().unwrap().to_string();
    run_ok(&["render", &aov, "-q", "-o", &out("aov")]);
    run_ok(&["render", &plain, "-q", "-o", &out("plain")]);
    let a = load_exr_channels(&dir.path().join("aov.exr")).unwrap();
    let p = load_exr_channels(&dir.path().join("plain.exr")).unwrap();
    // The image is the nested path tracer's, bit for bit.
    for c in ["R", "G", "B"] {
        assert!(a.channel(c) == p.channel(c), "channel {c}");
    }
    // Mitsuba's channel names; the list is recorded for --resume.
    for c in [
        "dd.T", "nn.X", "nn.Y", "nn.Z", "alb.R", "alb.G", "alb.B", "pp.X", "pp.Y", "pp.Z", "tex.U",
        "tex.V", "gn.X", "gn.Y", "gn.Z", "si.I", "pi.I",
    ] {
        assert!(a.channel(c).is_some(), "no channel {c}");
    }
    let file = RenderFile::load(&dir.path().join("aov.exr")).unwrap();
    assert_eq!(file.meta.aovs.mitsuba().len(), 8);
    // The pixel at the diffuse sphere's centre (x 0.6 at depth 4.2 from
    // the camera): its reflectance, the normal toward the camera, the
    // second shape; the conductor behind (upper right) has albedo 0.
    let px = |name: &str, x: usize, y: usize| a.channel(name).unwrap()[y * 64 + x];
    let (x, y) = (
        32 + (0.6 / (4.2 * (20f32).to_radians().tan()) * 32.0) as usize,
        24,
    );
    let albedo = [px("alb.R", x, y), px("alb.G", x, y), px("alb.B", x, y)];
    for (a, e) in albedo.iter().zip([0.2, 0.5, 0.7]) {
        assert!((a - e).abs() < 1e-5, "{albedo:?}");
    }
    assert!(px("nn.Z", x, y) > 0.99, "{}", px("nn.Z", x, y));
    assert!(
        (px("dd.T", x, y) - 4.2).abs() < 0.05,
        "{}",
        px("dd.T", x, y)
    );
    assert_eq!(px("si.I", x, y), 1.0);
    assert_eq!([px("alb.R", 62, 2), px("alb.G", 62, 2)], [0.0, 0.0]);
    assert_eq!(px("si.I", 62, 2), 3.0);

    // What lente does not do is refused with Mitsuba's words.
    let bad = write("bad.xml", &AOV_INTEGRATOR.replace("dd:depth", "dd:dp_du"));
    run_fails_with(
        &["render", &bad],
        "AOV type 'dp_du' is not supported by lente",
    );
    let alone = write(
        "alone.xml",
        r#"<integrator type="aov"><string name="aovs" value="dd:depth"/></integrator>"#,
    );
    run_fails_with(&["render", &alone], "without a nested <integrator>");

    // Beside Mitsuba 3 (where installed; CI has it): the same channels
    // with the same means over the image (the samples differ, so only
    // edge pixels do).
    let python = match crate::mitsuba_conformance::mitsuba_python() {
        Ok((python, _)) => python,
        Err(why) if std::env::var_os("CI").is_some() => panic!("CI is set: {why}"),
        Err(why) => {
            println!("skipped the comparison with Mitsuba: {why}");
            return;
        }
    };
    let script = format!(
        "import mitsuba as mi\nmi.set_variant('scalar_rgb')\nscene = mi.load_file({aov:?})\n\
         mi.render(scene, spp=64)\nscene.sensors()[0].film().bitmap().write({:?})\n",
        out("mitsuba.exr")
    );
    let ran = std::process::Command::new(&python)
        .args(["-c", &script])
        .output()
        .unwrap();
    assert!(
        ran.status.success(),
        "{}",
        String::from_utf8_lossy(&ran.stderr)
    );
    let m = load_exr_channels(&dir.path().join("mitsuba.exr")).unwrap();
    for c in [
        "dd.T", "nn.X", "nn.Y", "nn.Z", "alb.R", "alb.G", "alb.B", "pp.X", "pp.Y", "pp.Z", "tex.U",
        "tex.V", "gn.X", "gn.Y", "gn.Z", "si.I",
    ] {
        // (Not pi.I: lente's rectangle is two triangles, Mitsuba's one
        // analytic primitive.)
        let (ours, theirs) = (channel_mean(&a, c), channel_mean(&m, c));
        assert!(
            (ours - theirs).abs() < 0.01 * theirs.abs().max(1.0),
            "{c}: lente {ours}, Mitsuba {theirs}"
        );
    }
}
