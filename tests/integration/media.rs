//! Participating media under `volpath`: estimators checked with t-tests
//! against closed forms, and the reader's media errors.

use crate::common::{estimate, load, load_err, TestScene};
use crate::mitsuba_parse::scene;
use lente::color::{luminance, Rgb};
use lente::integrator::Integrator;
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
    assert!(
        e(r#"<shape type="sphere"><medium type="heterogeneous" name="interior"/></shape>"#)
            .contains("homogeneous")
    );
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
