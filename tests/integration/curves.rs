//! Mitsuba's round curves (`linearcurve`, `bsplinecurve`): an estimator
//! checked against a closed form, and the reader's errors.

use std::path::Path;

use crate::common::{built_at, estimate, load_at, load_err_at, TestScene};
use lente::geometry::Geometry;
use lente::stats::t_test;

/// A scene in `dir` with a camera at (0, 0, 3) looking at the origin, a
/// constant sky of radiance 1, and `body`.
fn sky(dir: &Path, body: &str) -> TestScene {
    let text = format!(
        r#"<scene version="3.0.0">
<integrator type="path"/>
<sensor type="perspective"><float name="fov" value="20"/>
<transform name="to_world"><lookat origin="0, 0, 3" target="0, 0, 0" up="0, 1, 0"/></transform>
<film type="hdrfilm"><integer name="width" value="16"/><integer name="height" value="16"/></film></sensor>
<emitter type="constant"><rgb name="radiance" value="1"/></emitter>
{body}
</scene>"#
    );
    built_at(&text, &dir.join("scene.xml"))
}

/// A straight tube of radius 0.6 along x fills the whole view. It is
/// convex, so under a uniform sky of 1 a diffuse albedo of 0.5 reflects
/// exactly 0.5 everywhere: light sampling and BSDF sampling both leave
/// the surface without meeting the tube again (a shadow ray or a bounce
/// caught by its own tube would darken it). A 3% darker reference must be
/// rejected.
#[test]
fn convex_tubes_reflect_half_a_uniform_sky() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("rod.txt"),
        "-30 0 0 0.6\n-10 0 0 0.6\n10 0 0 0.6\n30 0 0 0.6\n",
    )
    .unwrap();
    for (i, ty) in ["linearcurve", "bsplinecurve"].into_iter().enumerate() {
        let s = sky(
            dir.path(),
            &format!(
                r#"<shape type="{ty}"><string name="filename" value="rod.txt"/>
<bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf></shape>"#
            ),
        );
        let mv = estimate(&s, 20_000, 400 + i as u64);
        assert!(
            t_test(&mv, 0.5).passes(0.01),
            "{ty}: mean {} (sd {})",
            mv.mean(),
            mv.variance().sqrt()
        );
        assert!(!t_test(&mv, 0.485).passes(0.01), "{ty}: no power");
    }
}

#[test]
fn curves_load_in_world_space_with_their_segments() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("two.txt"),
        "0 0 0 0.1\n1 0 0 0.1\n2 0 0 0.2\n3 0 0 0.1\n\n0 1 0 0.1\n1 1 0 0.1\n",
    )
    .unwrap();
    let text = r#"<scene version="3.0.0">
<shape type="linearcurve"><string name="filename" value="two.txt"/>
<transform name="to_world"><scale value="2"/><translate z="5"/></transform></shape>
</scene>"#;
    let (file, _) = load_at(text, &dir.path().join("scene.xml"), &[]);
    let Geometry::Curve(c) = &file.scene.shapes[0].geometry else {
        panic!("not a curve");
    };
    assert_eq!(c.segment_count(), 4);
    // Positions follow to_world, radii do not (as in Mitsuba).
    let b = c.bounds();
    assert!(
        (b.min - lente::math::Vec3::new(-0.1, -0.2, 4.8)).length() < 1e-5,
        "{b:?}"
    );
    assert!(
        (b.max - lente::math::Vec3::new(6.2, 2.1, 5.2)).length() < 1e-5,
        "{b:?}"
    );
}

#[test]
fn curve_errors_name_the_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("ok.txt"), "0 0 0 0.1\n1 0 0 0.1\n").unwrap();
    std::fs::write(dir.path().join("bad.txt"), "0 0 0 0.1\n1 0 zero 0.1\n").unwrap();
    std::fs::write(
        dir.path().join("short.txt"),
        "0 0 0 0.1\n1 0 0 0.1\n2 0 0 0.1\n",
    )
    .unwrap();
    let scene = dir.path().join("scene.xml");
    let err = |shape: &str| {
        let text = format!("<scene version=\"3.0.0\">\n{shape}\n</scene>");
        let e = load_err_at(&text, &scene);
        assert_eq!(e.file, scene);
        // The line the user sees: the message and its causes.
        e.report()
    };
    let cases = [
        (
            r#"<shape type="linearcurve"><string name="filename" value="none.txt"/></shape>"#,
            "cannot read",
        ),
        (
            r#"<shape type="linearcurve"><string name="filename" value="bad.txt"/></shape>"#,
            "bad.txt' is malformed: line 2: 'zero' is not a finite number",
        ),
        (
            r#"<shape type="bsplinecurve"><string name="filename" value="short.txt"/></shape>"#,
            "line 1: this B-spline curve has 3 control points; it needs at least 4",
        ),
        (
            r#"<shape type="linearcurve"><string name="filename" value="ok.txt"/><boolean name="flip_normals" value="true"/></shape>"#,
            "flip_normals does not apply",
        ),
        (
            r#"<shape type="linearcurve"><string name="filename" value="ok.txt"/><emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>"#,
            "cannot be an area emitter",
        ),
        (
            r#"<medium type="homogeneous" id="m"/><shape type="linearcurve"><string name="filename" value="ok.txt"/><ref id="m" name="interior"/></shape>"#,
            "cannot bound a medium",
        ),
    ];
    for (shape, want) in cases {
        let e = err(shape);
        assert!(e.contains(want), "{shape}\n{e}");
        assert!(e.contains(":2:"), "no line: {e}");
    }
}
