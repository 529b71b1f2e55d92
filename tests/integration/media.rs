//! Participating media under `volpath`: estimators checked with t-tests
//! against closed forms, and the reader's media errors.

use std::path::Path;

use crate::common::{built_at, estimate, load, load_at, load_err, load_err_at, TestScene};
use crate::mitsuba_parse::scene;
use lente::color::{luminance, Rgb};
use lente::integrator::Integrator;
use lente::math::{Aabb, Vec3};
use lente::medium::{encode_vol, VolumeGrid};
use lente::scene::Scene;
use lente::stats::{sidak, t_test};

/// A Mitsuba scene: volpath, a 16 x 16 camera at the origin looking down
/// +z with the given medium reference, a constant sky of radiance 1, and
/// `body`.
fn furnace(sensor_medium: &str, body: &str) -> TestScene {
    let text = format!(
        r#"<scene version="3.0.0">
<integrator type="volpath"/>
<sensor type="perspective"><float name="fov" value="60"/>
<transform name="to_world"><lookat origin="0, 0, 0" target="0, 0, 1" up="0, 1, 0"/></transform>
{sensor_medium}
<film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/></film></sensor>
<emitter type="constant"><rgb name="radiance" value="1"/></emitter>
{body}
</scene>"#
    );
    let (file, warnings) = load(&text);
    assert!(warnings.is_empty(), "{warnings:?}");
    assert!(matches!(file.job.integrator, Integrator::VolPath { .. }));
    TestScene {
        scene: Scene::new(file.scene).unwrap(),
        integrator: file.job.integrator,
    }
}

/// A sphere of radius 1 around (0, 0, z) bounded by `bsdf`, holding a
/// homogeneous medium.
fn sphere(z: f32, bsdf: &str, sigma_t: &str, albedo: &str, phase: &str) -> String {
    format!(
        r#"<medium type="homogeneous" id="m"><rgb name="sigma_t" value="{sigma_t}"/><float name="scale" value="4"/>
<rgb name="albedo" value="{albedo}"/>{phase}</medium>
<shape type="sphere"><point name="center" value="0, 0, {z}"/>{bsdf}<ref id="m" name="interior"/></shape>"#
    )
}

/// A white furnace: a medium that scatters without absorbing, inside a
/// null or thin-dielectric boundary, under a uniform sky of radiance 1,
/// is invisible: every ray sees exactly 1, whatever the phase function,
/// the chromatic extinction, the camera inside or outside. Shadow rays
/// through the thin dielectric keep 1 - R of the light and its paths
/// count that crossing as no bounce; any error in either breaks the 1.
#[test]
fn scattering_media_vanish_in_a_white_furnace() {
    let cases = [
        (
            "",
            sphere(
                3.0,
                r#"<bsdf type="null"/>"#,
                "0.5, 0.125, 1",
                "1, 1, 1",
                "",
            ),
        ),
        (
            "",
            sphere(
                3.0,
                r#"<bsdf type="thindielectric"/>"#,
                "0.25, 0.5, 0.75",
                "1, 1, 1",
                r#"<phase type="hg"><float name="g" value="0.7"/></phase>"#,
            ),
        ),
        (
            r#"<ref id="m"/>"#,
            sphere(
                0.0,
                r#"<bsdf type="thindielectric"/>"#,
                "0.5, 0.25, 0.125",
                "1, 1, 1",
                r#"<phase type="hg"><float name="g" value="-0.5"/></phase>"#,
            ),
        ),
    ];
    let alpha = sidak(0.01, cases.len());
    for (i, (sensor, body)) in cases.iter().enumerate() {
        let s = furnace(sensor, body);
        let mv = estimate(&s, 20_000, 300 + i as u64);
        let r = t_test(&mv, 1.0);
        assert!(
            r.passes(alpha),
            "case {i}: mean {} vs 1, p = {}",
            mv.mean(),
            r.p_value
        );
    }
}

/// The furnace test has power: with 3% absorption the same sphere is
/// visible and the estimate must be rejected.
#[test]
fn white_furnace_rejects_an_absorbing_medium() {
    let s = furnace(
        "",
        &sphere(
            3.0,
            r#"<bsdf type="null"/>"#,
            "0.5, 0.5, 0.5",
            "0.97, 0.97, 0.97",
            "",
        ),
    );
    let mv = estimate(&s, 20_000, 310);
    assert!(!t_test(&mv, 1.0).passes(0.01), "mean {}", mv.mean());
}

/// Beer-Lambert: from the centre of a purely absorbing sphere of radius
/// 1, every ray travels exactly 1 through the medium, so the sky is seen
/// through exp(-sigma_t) per channel (exactly: media that do not scatter
/// pass their transmittance without sampling collisions).
#[test]
fn absorbing_medium_follows_beer_lambert() {
    let s = furnace(
        r#"<ref id="m"/>"#,
        &sphere(
            0.0,
            r#"<bsdf type="null"/>"#,
            "0.1, 0.25, 0.5",
            "0, 0, 0",
            "",
        ),
    );
    let sigma = Rgb::new(0.1, 0.25, 0.5) * 4.0;
    let want = luminance(Rgb::new(
        (-sigma.x).exp(),
        (-sigma.y).exp(),
        (-sigma.z).exp(),
    )) as f64;
    let mv = estimate(&s, 20_000, 320);
    let r = t_test(&mv, want);
    assert!(
        r.passes(0.01),
        "mean {} vs {want}, p = {}",
        mv.mean(),
        r.p_value
    );
    assert!(!t_test(&mv, want * 1.02).passes(0.01));
}

/// The reader's media errors name the element and what was wrong.
#[test]
fn medium_errors() {
    let e = |body: &str| load_err(&scene(body)).message;
    assert!(
        e(r#"<shape type="sphere"><medium type="homogeneous" name="inside"/></shape>"#)
            .contains("'interior' or 'exterior'")
    );
    assert!(e(r#"<shape type="sphere"><medium type="homogeneous" name="interior"><rgb name="sigma_t" value="2, 1, 1"/></medium></shape>"#)
        .contains("'scale'"));
    assert!(e(r#"<shape type="sphere"><medium type="homogeneous" name="interior"><phase type="hg"><float name="g" value="1"/></phase></medium></shape>"#)
        .contains("between -1 and 1"));
    assert!(e(r#"<shape type="sphere"><medium type="homogeneous" name="interior"><float name="albedo" value="1.5"/></medium></shape>"#)
        .contains("at most 1"));
    assert!(e(r#"<shape type="sphere"><medium type="homogeneous" name="interior"/><medium type="homogeneous" name="interior"/></shape>"#)
        .contains("only one interior"));
}

/// Media in a scene rendered by `path` are ignored, as Mitsuba's path
/// tracer ignores them, with one warning.
#[test]
fn path_ignores_media_with_a_warning() {
    let text =
        scene(r#"<shape type="sphere"><medium type="homogeneous" name="interior"/></shape>"#);
    let (file, warnings) = load(&text);
    assert!(matches!(file.job.integrator, Integrator::Path { .. }));
    assert_eq!(file.scene.media.len(), 1);
    assert!(
        warnings.iter().any(|w| w.message.contains("ignores")),
        "{warnings:?}"
    );
}

/// Writes a `.vol` grid of `channels` values per voxel into `dir`.
fn write_grid(dir: &Path, name: &str, res: [usize; 3], channels: usize, data: Vec<f32>) {
    let grid = VolumeGrid {
        res,
        channels,
        bbox: Aabb {
            min: Vec3::ZERO,
            max: Vec3::ONE,
        },
        data,
    };
    std::fs::write(dir.join(name), encode_vol(&grid)).unwrap();
}

/// A 4 x 3 x 5 grid of three channels, varying along every axis and per
/// channel (zero in some voxels), values in [0, 1].
fn lumpy_grid() -> Vec<f32> {
    let mut data = Vec::new();
    for z in 0..5 {
        for y in 0..3 {
            for x in 0..4 {
                let v = ((x * 7 + y * 5 + z * 3) % 6) as f32 / 5.0;
                data.extend([v, 1.0 - v, ((x + z) % 3) as f32 / 2.0]);
            }
        }
    }
    data
}

/// Scene text for `volpath` with a camera at the origin looking down +z
/// (`fov` degrees, `res` pixels square, in `sensor_medium`), a constant
/// sky of radiance 1, and `body`.
fn sky_scene(fov: f32, res: u32, sensor_medium: &str, body: &str) -> String {
    format!(
        r#"<scene version="3.0.0">
<integrator type="volpath"/>
<sensor type="perspective"><float name="fov" value="{fov}"/>
<transform name="to_world"><lookat origin="0, 0, 0" target="0, 0, 1" up="0, 1, 0"/></transform>
{sensor_medium}
<film type="hdrfilm"><integer name="width" value="{res}"/><integer name="height" value="{res}"/></film></sensor>
<emitter type="constant"><rgb name="radiance" value="1"/></emitter>
{body}
</scene>"#
    )
}

fn loaded(text: &str, dir: &Path) -> TestScene {
    built_at(text, &dir.join("scene.xml"))
}

/// The white furnace with heterogeneous media: a chromatic extinction
/// grid that scatters without absorbing is invisible under a sky of 1,
/// seen from outside its null box (delta tracking's null collisions and
/// channel weights, ratio-tracked shadow rays) and from inside it (the
/// camera's medium, its box around the camera). A 3% absorbing albedo
/// grid must be rejected.
#[test]
fn heterogeneous_media_vanish_in_a_white_furnace() {
    let dir = tempfile::tempdir().unwrap();
    write_grid(dir.path(), "lumpy.vol", [4, 3, 5], 3, lumpy_grid());
    write_grid(dir.path(), "white.vol", [1, 1, 1], 1, vec![1.0]);
    write_grid(dir.path(), "grey.vol", [2, 1, 1], 1, vec![0.97, 0.97]);
    let medium = |albedo: &str| {
        format!(
            r#"<medium type="heterogeneous" id="m">
<volume type="gridvolume" name="sigma_t"><string name="filename" value="lumpy.vol"/>
<transform name="to_world"><scale value="2"/><translate x="-1" y="-1" z="-1"/></transform></volume>
<float name="scale" value="3"/>
<volume type="gridvolume" name="albedo"><string name="filename" value="{albedo}"/></volume>
<phase type="hg"><float name="g" value="0.4"/></phase></medium>"#
        )
    };
    let null_box = r#"<shape type="cube"><transform name="to_world"><translate z="3"/></transform>
<bsdf type="null"/><ref id="m" name="interior"/></shape>"#;
    // The medium's box is [-1, 1]^3: around the camera, or moved to z = 3
    // inside the null cube.
    let outside = |albedo: &str| {
        medium(albedo).replace(
            r#"<translate x="-1" y="-1" z="-1"/>"#,
            r#"<translate x="-1" y="-1" z="2"/>"#,
        ) + null_box
    };
    let cases = [
        sky_scene(60.0, 16, "", &outside("white.vol")),
        sky_scene(60.0, 16, r#"<ref id="m"/>"#, &medium("white.vol")),
    ];
    let alpha = sidak(0.01, cases.len());
    for (i, text) in cases.iter().enumerate() {
        let s = loaded(text, dir.path());
        let mv = estimate(&s, 20_000, 330 + i as u64);
        let r = t_test(&mv, 1.0);
        assert!(
            r.passes(alpha),
            "case {i}: mean {} vs 1, p = {}",
            mv.mean(),
            r.p_value
        );
    }
    let absorbing = loaded(&sky_scene(60.0, 16, "", &outside("grey.vol")), dir.path());
    let mv = estimate(&absorbing, 20_000, 339);
    assert!(!t_test(&mv, 1.0).passes(0.01), "mean {}", mv.mean());
}

/// Transmittance through a slab of grid extinction: the camera (in the
/// medium, looking down +z within a 0.2-degree field) sees the sky through
/// a 1-thick slab whose extinction varies along z per channel. Trilinear
/// interpolation with clamping keeps each channel's integral over the
/// slab the mean of its voxels, so the sky is seen through exp(-scale *
/// mean) per channel. Nothing scatters (albedo 0): delta tracking ends a
/// path at its first real collision.
#[test]
fn heterogeneous_transmittance_follows_the_optical_depth() {
    let dir = tempfile::tempdir().unwrap();
    let data = vec![0.2, 0.9, 0.0, 0.6, 0.3, 0.5, 1.0, 0.1, 0.25];
    write_grid(dir.path(), "slab.vol", [1, 1, 3], 3, data.clone());
    let body = r#"<medium type="heterogeneous" id="m">
<volume type="gridvolume" name="sigma_t"><string name="filename" value="slab.vol"/>
<transform name="to_world"><scale x="100" y="100" z="1"/><translate x="-50" y="-50" z="1"/></transform></volume>
<float name="scale" value="1.5"/><float name="albedo" value="0"/></medium>"#;
    let s = loaded(&sky_scene(0.2, 1, r#"<ref id="m"/>"#, body), dir.path());
    let mean = |c: usize| (data[c] + data[3 + c] + data[6 + c]) as f64 / 3.0;
    let depth = |c: usize| (-1.5 * mean(c)).exp() as f32;
    let want = luminance(Rgb::new(depth(0), depth(1), depth(2))) as f64;
    let mv = estimate(&s, 40_000, 340);
    let r = t_test(&mv, want);
    assert!(
        r.passes(0.01),
        "mean {} vs {want}, p = {}",
        mv.mean(),
        r.p_value
    );
    assert!(!t_test(&mv, want * 1.03).passes(0.01));
}

/// The reader's grid errors name the element and what was wrong, and a
/// constant extinction in a heterogeneous medium warns that it fills the
/// unit cube only.
#[test]
fn grid_volume_errors() {
    let dir = tempfile::tempdir().unwrap();
    write_grid(dir.path(), "six.vol", [1, 1, 1], 6, vec![0.5; 6]);
    write_grid(dir.path(), "bright.vol", [2, 1, 1], 1, vec![0.5, 1.5]);
    write_grid(dir.path(), "negative.vol", [2, 1, 1], 1, vec![0.5, -0.5]);
    write_grid(dir.path(), "dense.vol", [1, 1, 1], 1, vec![1e7]);
    std::fs::write(dir.path().join("bad.vol"), b"VOL\x03 not a grid").unwrap();
    let path = dir.path().join("scene.xml");
    let medium = |ty: &str, inner: &str| {
        scene(&format!(
            r#"<shape type="sphere"><medium type="{ty}" name="interior">{inner}</medium></shape>"#
        ))
    };
    let grid = |name: &str, file: &str, extra: &str| {
        format!(
            r#"<volume type="gridvolume" name="{name}"><string name="filename" value="{file}"/>{extra}</volume>"#
        )
    };
    let e = |text: String| load_err_at(&text, &path).report();
    let cases = [
        (
            medium("heterogeneous", &grid("sigma_t", "missing.vol", "")),
            "cannot load the volume grid",
        ),
        (
            medium("heterogeneous", &grid("sigma_t", "bad.vol", "")),
            "shorter than the 48-byte header",
        ),
        (
            medium("heterogeneous", &grid("sigma_t", "six.vol", "")),
            "6 channels",
        ),
        (
            medium("heterogeneous", &grid("albedo", "bright.vol", "")),
            "must lie in [0, 1]",
        ),
        (
            medium("heterogeneous", &grid("sigma_t", "negative.vol", "")),
            "must not be negative",
        ),
        (
            medium("heterogeneous", &grid("sigma_t", "dense.vol", "")),
            "too dense",
        ),
        (
            medium("homogeneous", &grid("sigma_t", "bright.vol", "")),
            "must be constant",
        ),
        (
            medium(
                "heterogeneous",
                &grid(
                    "sigma_t",
                    "bright.vol",
                    r#"<string name="filter_type" value="cubic"/>"#,
                ),
            ),
            "use trilinear or nearest",
        ),
        (
            medium(
                "heterogeneous",
                &grid(
                    "sigma_t",
                    "bright.vol",
                    r#"<string name="wrap_mode" value="border"/>"#,
                ),
            ),
            "use clamp, repeat or mirror",
        ),
        (
            medium(
                "heterogeneous",
                &format!(
                    "{}{}",
                    grid("sigma_t", "bright.vol", ""),
                    r#"<float name="sigma_t" value="1"/>"#
                ),
            ),
            "given twice",
        ),
        (
            medium(
                "heterogeneous",
                r#"<volume type="gridvolume" name="density"><string name="filename" value="bright.vol"/></volume>"#,
            ),
            "sets 'sigma_t' or 'albedo'",
        ),
    ];
    for (text, want) in cases {
        let message = e(text);
        assert!(message.contains(want), "{message:?} should say {want:?}");
        assert!(message.contains("scene.xml:"), "{message}");
    }
    let (_, warnings) = load_at(
        &medium("heterogeneous", r#"<float name="sigma_t" value="2"/>"#),
        &path,
        &[],
    );
    assert!(
        warnings.iter().any(|w| w.message.contains("unit cube")),
        "{warnings:?}"
    );
}
