//! Mitsuba 3 objects: every shape and the PLY loader, emitters,
//! integrators and BSDFs (the helpers are `mitsuba_parse`'s).

use lente::bsdf::Bsdf;
use lente::color::Rgb;
use lente::emitter::Emitter;
use lente::geometry::{parse_ply, Geometry};
use lente::integrator::{Integrator, PathParams, Strategy};
use lente::load::{load_scene_str, Warning};
use lente::math::{Vec3, PI};

use crate::common::{load, load_clean, load_err};
use crate::mitsuba_parse::{assert_err, close, close_f, mesh, scene};

// ---------------------------------------------------------------------------
// Shapes and meshes
// ---------------------------------------------------------------------------

#[test]
fn every_shape() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("tri.obj"),
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 1\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\nf 2 4 3\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("quad.ply"),
        "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n2 0 0\n2 2 0\n0 2 0\n4 0 1 2 3\n",
    )
    .unwrap();
    let text = scene(
        r#"<shape type="rectangle"><transform name="to_world"><scale x="2" y="3"/></transform></shape>
           <shape type="cube"><transform name="to_world"><scale value="0.5"/></transform></shape>
           <shape type="disk"><transform name="to_world"><scale value="2"/></transform></shape>
           <shape type="cylinder"><point name="p0" value="0, 0, 0"/><point name="p1" value="0, 3, 0"/><float name="radius" value="0.5"/></shape>
           <shape type="sphere"><point name="center" value="1, 2, 3"/><float name="radius" value="0.5"/>
               <transform name="to_world"><scale value="2"/></transform></shape>
           <shape type="obj"><string name="filename" value="tri.obj"/></shape>
           <shape type="ply"><string name="filename" value="quad.ply"/><boolean name="face_normals" value="true"/></shape>
           <shape type="obj"><string name="filename" value="tri.obj"/><boolean name="face_normals" value="true"/></shape>"#,
    );
    let path = dir.path().join("s.xml");
    let (desc, w) = load_scene_str(&text, &path).unwrap();
    assert!(w.is_empty(), "{w:?}");
    close_f(desc.scene.shapes[0].geometry.area(), 4.0 * 6.0, 1e-6);
    close_f(mesh(&desc, 1).area(), 6.0, 1e-4);
    close_f(desc.scene.shapes[2].geometry.area(), 4.0 * PI, 1e-6);
    close_f(mesh(&desc, 3).area(), 2.0 * PI * 0.5 * 3.0, 1e-3);
    // The (analytic) rectangle faces +z, the disk too; cube normals point
    // outward.
    match &desc.scene.shapes[0].geometry {
        Geometry::Rectangle(r) => {
            close(r.frame.n, Vec3::Z);
            close(r.frame.ey, Vec3::Y * 3.0);
        }
        g => panic!("{g:?}"),
    }
    match &desc.scene.shapes[2].geometry {
        Geometry::Disk(d) => {
            close(d.frame.n, Vec3::Z);
            close(d.frame.ex, Vec3::X * 2.0);
        }
        g => panic!("{g:?}"),
    }
    let cube = mesh(&desc, 1);
    for (p, n) in cube.positions().iter().zip(cube.normals()) {
        assert!(p.dot(*n) > 0.0);
        close_f(p.abs().max_element(), 0.5, 1e-6);
    }
    // Cylinder: smooth radial normals around the y axis.
    let cyl = mesh(&desc, 3);
    for (p, n) in cyl.positions().iter().zip(cyl.normals()) {
        close(*n, Vec3::new(p.x, 0.0, p.z).normalize());
        assert!(p.y.abs() < 1e-5 || (p.y - 3.0).abs() < 1e-5);
    }
    // Mitsuba's sphere: to_world applies after center and radius.
    match &desc.scene.shapes[4].geometry {
        Geometry::Sphere(s) => {
            close(s.center, Vec3::new(2.0, 4.0, 6.0));
            close_f(s.radius, 1.0, 1e-6);
        }
        g => panic!("{g:?}"),
    }
    // OBJ without normals gets smooth (angle-weighted) ones, as in Mitsuba;
    // texture coordinates are flipped vertically (flip_tex_coords).
    let obj = mesh(&desc, 5);
    assert_eq!(obj.indices().len(), 2);
    assert_eq!(obj.normals().len(), obj.positions().len());
    assert!(obj.uvs().is_empty() || obj.uvs().iter().any(|uv| uv.y == 1.0));
    // face_normals drops them; PLY polygons are fan-triangulated.
    let ply = mesh(&desc, 6);
    assert_eq!(ply.indices().len(), 2);
    assert!(ply.normals().is_empty());
    close_f(ply.area(), 4.0, 1e-6);
    assert!(mesh(&desc, 7).normals().is_empty());
}

/// Disks and rectangles are analytic, except those that emit: they stay
/// triangles (a fan with the disk's exact area, a pair), so their light
/// samples cover each triangle's solid angle rather than the shape's area.
#[test]
fn emitting_disks_and_rectangles_stay_triangles() {
    let desc = load_clean(&scene(
        r#"<shape type="disk"><transform name="to_world"><scale x="2" y="0.5"/></transform></shape>
           <shape type="disk"><transform name="to_world"><scale x="2" y="0.5"/></transform>
               <emitter type="area"/></shape>
           <shape type="rectangle"><transform name="to_world"><scale x="2" y="0.5"/></transform></shape>
           <shape type="rectangle"><transform name="to_world"><scale x="2" y="0.5"/></transform>
               <emitter type="area"/></shape>"#,
    ));
    assert!(matches!(desc.scene.shapes[0].geometry, Geometry::Disk(_)));
    close_f(desc.scene.shapes[0].geometry.area(), PI, 1e-6);
    close_f(mesh(&desc, 1).area(), PI, 1e-4);
    assert!(matches!(
        desc.scene.shapes[2].geometry,
        Geometry::Rectangle(_)
    ));
    close_f(desc.scene.shapes[2].geometry.area(), 4.0, 1e-6);
    assert_eq!(mesh(&desc, 3).triangle_count(), 2);
    close_f(mesh(&desc, 3).area(), 4.0, 1e-6);
}

#[test]
fn flip_normals_and_mirrors() {
    let desc = load_clean(&scene(
        r#"<shape type="rectangle"><boolean name="flip_normals" value="true"/></shape>
           <shape type="rectangle"><transform name="to_world"><scale z="-1"/></transform></shape>
           <shape type="disk"><boolean name="flip_normals" value="true"/></shape>"#,
    ));
    // flip_normals turns each flat shape's front; a mirror through z
    // turns the rectangle's normal too (inverse transpose).
    for i in 0..3 {
        match &desc.scene.shapes[i].geometry {
            Geometry::Rectangle(r) => close(r.frame.n, Vec3::NEG_Z),
            Geometry::Disk(d) => close(d.frame.n, Vec3::NEG_Z),
            g => panic!("{g:?}"),
        }
    }
    // An emitting rectangle is two triangles, flipped the same way.
    let desc = load_clean(&scene(
        r#"<shape type="rectangle"><boolean name="flip_normals" value="true"/>
               <emitter type="area"/></shape>"#,
    ));
    let m = mesh(&desc, 0);
    for (t, _) in m.indices().iter().enumerate() {
        close(m.geometric_normal(t), Vec3::NEG_Z);
    }
    for n in m.normals() {
        close(*n, Vec3::NEG_Z);
    }
    // A flipped sphere becomes an inward-facing mesh, with a warning.
    let (desc, w) = load(&scene(
        "<shape type=\"sphere\"><boolean name=\"flip_normals\" value=\"true\"/></shape>",
    ));
    assert_eq!(w.len(), 1);
    let m = mesh(&desc, 0);
    for (p, n) in m.positions().iter().zip(m.normals()).step_by(97) {
        assert!(p.dot(*n) < 0.0);
    }
    close_f(m.area(), 4.0 * PI, 0.01);
}

/// pplastic's IOR comes as `eta` or as `int_ior`/`ext_ior`, never both;
/// `eta` must be positive.
#[test]
fn pplastic_ior_errors() {
    assert_err(
        &scene("<shape type=\"sphere\"><bsdf type=\"pplastic\">\n<float name=\"eta\" value=\"1.3\"/><float name=\"int_ior\" value=\"1.5\"/></bsdf></shape>"),
        5,
        26,
        &["either 'eta' or 'int_ior'"],
    );
    assert_err(
        &scene("<shape type=\"sphere\"><bsdf type=\"pplastic\">\n<float name=\"eta\" value=\"-2\"/></bsdf></shape>"),
        5,
        26,
        &["eta", "positive"],
    );
}

#[test]
fn shape_errors() {
    assert_err(
        &scene("<shape type=\"obj\">\n  <string name=\"filename\" value=\"nope.obj\"/></shape>"),
        5,
        34,
        &["nope.obj"],
    );
    assert_err(
        &scene("<shape type=\"sdfgrid\"/>"),
        4,
        14,
        &["sdfgrid", "not supported", "ply"],
    );
    assert_err(&scene("<shape type=\"serialized\"/>"), 4, 1, &["filename"]);
    assert_err(
        &scene("<shape type=\"serialized\">\n  <string name=\"filename\" value=\"a.serialized\"/>\n  <integer name=\"shape_index\" value=\"-1\"/></shape>"),
        6,
        38,
        &["shape_index", "negative"],
    );
    assert_err(
        &scene("<shape type=\"sphere\"><transform name=\"to_world\"><scale x=\"2\"/></transform></shape>"),
        4,
        22,
        &["similarity"],
    );
    assert_err(
        &scene("<shape type=\"sphere\"><bsdf type=\"diffuse\"/>\n<bsdf type=\"diffuse\"/></shape>"),
        5,
        1,
        &["only one <bsdf>", "4:22"],
    );
    assert_err(
        &scene("<shape type=\"sphere\"><emitter type=\"point\"/></shape>"),
        4,
        22,
        &["only area emitters"],
    );
    assert_err(
        &scene("<shape type=\"cube\"><transform name=\"to_world\"><scale value=\"1e30\"/><scale value=\"1e30\"/></transform></shape>"),
        4,
        20,
        &["not finite"],
    );
    assert_err(
        &scene("<shape type=\"cylinder\"><point name=\"p1\" value=\"0 0 0\"/></shape>"),
        4,
        24,
        &["'p0' and 'p1' must differ"],
    );
}

// ---------------------------------------------------------------------------
// PLY
// ---------------------------------------------------------------------------

struct PlyMesh {
    positions: Vec<[f32; 3]>,
    normals: Vec<[f32; 3]>,
    uvs: Vec<[f32; 2]>,
    faces: Vec<Vec<u32>>,
}

fn sample_ply() -> PlyMesh {
    PlyMesh {
        positions: vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.5, 0.5, 1.0],
        ],
        normals: vec![[0.0, 0.0, 1.0]; 5],
        uvs: vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0], [0.5, 0.5]],
        faces: vec![vec![0, 1, 2, 3], vec![0, 1, 4], vec![1, 2, 4]],
    }
}

/// Writes a PLY file with an extra vertex property (a list), an extra face
/// property, and an extra element before the faces, to check they are
/// skipped correctly.
fn write_ply(m: &PlyMesh, format: &str) -> Vec<u8> {
    let mut out = format!(
        "ply\nformat {format} 1.0\ncomment written by a test\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\nproperty list uchar short junk\nproperty float nx\nproperty float ny\nproperty float nz\nproperty double s\nproperty double t\nelement material 2\nproperty uchar red\nproperty list uint uint ids\nelement face {}\nproperty uchar flags\nproperty list uchar uint vertex_indices\nend_header\n",
        m.positions.len(),
        m.faces.len()
    )
    .into_bytes();
    let ascii = format == "ascii";
    let be = format == "binary_big_endian";
    let f32s = |out: &mut Vec<u8>, v: f32| {
        if ascii {
            out.extend(format!("{v} ").bytes());
        } else if be {
            out.extend(v.to_be_bytes());
        } else {
            out.extend(v.to_le_bytes());
        }
    };
    let int = |out: &mut Vec<u8>, v: u64, size: usize| {
        if ascii {
            out.extend(format!("{v} ").bytes());
        } else {
            let b = v.to_le_bytes();
            let mut b = b[..size].to_vec();
            if be {
                b.reverse();
            }
            out.extend(b);
        }
    };
    for i in 0..m.positions.len() {
        for c in m.positions[i] {
            f32s(&mut out, c);
        }
        int(&mut out, 2, 1);
        int(&mut out, 7, 2);
        int(&mut out, 9, 2);
        for c in m.normals[i] {
            f32s(&mut out, c);
        }
        for c in m.uvs[i] {
            if ascii {
                out.extend(format!("{c} ").bytes());
            } else if be {
                out.extend((c as f64).to_be_bytes());
            } else {
                out.extend((c as f64).to_le_bytes());
            }
        }
        if ascii {
            out.push(b'\n');
        }
    }
    for k in 0..2u64 {
        int(&mut out, 200 + k, 1);
        int(&mut out, k + 1, 4);
        for j in 0..=k {
            int(&mut out, j, 4);
        }
        if ascii {
            out.push(b'\n');
        }
    }
    for f in &m.faces {
        int(&mut out, 1, 1);
        int(&mut out, f.len() as u64, 1);
        for &i in f {
            int(&mut out, i as u64, 4);
        }
        if ascii {
            out.push(b'\n');
        }
    }
    out
}

#[test]
fn ply_round_trips_in_every_format() {
    let m = sample_ply();
    for format in ["ascii", "binary_little_endian", "binary_big_endian"] {
        let bytes = write_ply(&m, format);
        let mesh = parse_ply(&bytes).unwrap_or_else(|e| panic!("{format}: {e}"));
        let p: Vec<[f32; 3]> = mesh.positions().iter().map(|v| v.to_array()).collect();
        assert_eq!(p, m.positions, "{format}");
        let n: Vec<[f32; 3]> = mesh.normals().iter().map(|v| v.to_array()).collect();
        assert_eq!(n, m.normals, "{format}");
        let uv: Vec<[f32; 2]> = mesh.uvs().iter().map(|v| v.to_array()).collect();
        assert_eq!(uv, m.uvs, "{format}");
        assert_eq!(
            mesh.indices(),
            vec![[0, 1, 2], [0, 2, 3], [0, 1, 4], [1, 2, 4]],
            "{format}"
        );
    }
}

#[test]
fn ply_errors_are_clear() {
    let m = sample_ply();
    let good = write_ply(&m, "binary_little_endian");
    let err = |bytes: &[u8]| parse_ply(bytes).unwrap_err().to_string();
    // Truncated anywhere in the body or the header.
    let header_end = good.windows(11).position(|w| w == b"end_header\n").unwrap() + 11;
    for cut in [5, 20, header_end - 3, header_end + 7, good.len() - 1] {
        let e = err(&good[..cut]);
        assert!(!e.is_empty(), "cut {cut}");
    }
    assert!(err(b"plx\n").contains("'ply'"));
    assert!(err(b"ply\nformat xml 1.0\nend_header\n").contains("unknown format"));
    assert!(
        err(b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n1\n")
            .contains("x, y, z")
    );
    assert!(err(b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n3 0 1 2\n")
        .contains("refers to vertex 1"));
    assert!(err(b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n2 0 0\n")
        .contains("2 vertices"));
    assert!(err(b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\nzero 0 0\n")
        .contains("'zero'"));
    assert!(err(b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nproperty wibble w\nend_header\n")
        .contains("unknown property type"));
    // A load error names the file.
    let dir = tempfile::tempdir().unwrap();
    let e = lente::geometry::load_ply(&dir.path().join("missing.ply")).unwrap_err();
    assert!(e.to_string().contains("missing.ply"), "{e}");
    // Random corruption never panics.
    let mut rng = 0x1234_5678_u64;
    for _ in 0..3000 {
        let mut b = good.clone();
        for _ in 0..3 {
            rng = rng
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            let at = (rng >> 33) as usize % b.len();
            b[at] = (rng >> 20) as u8;
        }
        let _ = parse_ply(&b);
        let _ = parse_ply(&b[..(rng as usize >> 7) % b.len()]);
    }
}

// ---------------------------------------------------------------------------
// Emitters, integrators, BSDFs
// ---------------------------------------------------------------------------

#[test]
fn emitters() {
    let dir = tempfile::tempdir().unwrap();
    // A 4 x 2 PFM environment map.
    let mut pfm = b"PF\n4 2\n-1.0\n".to_vec();
    for i in 0..8 {
        for c in [1.0f32, 0.5, 0.25] {
            pfm.extend((c * (i + 1) as f32).to_le_bytes());
        }
    }
    std::fs::write(dir.path().join("sky.pfm"), pfm).unwrap();
    let text = scene(
        r#"<emitter type="envmap">
               <string name="filename" value="sky.pfm"/>
               <float name="scale" value="2"/>
               <transform name="to_world"><rotate y="1" angle="90"/></transform>
           </emitter>
           <emitter type="point"><transform name="to_world"><translate value="1, 2, 3"/></transform></emitter>
           <emitter type="directional"/>
           <emitter type="directional"><transform name="to_world"><lookat origin="0, 0, 0" target="0, -1, 0" up="0, 0, 1"/></transform></emitter>
           <shape type="rectangle"><emitter type="area"/></shape>
           <shape type="rectangle"><emitter type="area"><rgb name="radiance" value="3, 2, 1"/></emitter></shape>
           <shape type="rectangle"><bsdf type="diffuse"/><emitter type="area"/></shape>
           <shape type="rectangle"/>"#,
    );
    let (desc, w) = load_scene_str(&text, &dir.path().join("s.xml")).unwrap();
    assert!(w.is_empty(), "{w:?}");
    match &desc.scene.emitters[0] {
        Emitter::Environment(env) => {
            assert_eq!(env.scale(), 2.0);
            close(env.to_world().vector(Vec3::Z), Vec3::X);
        }
        e => panic!("{e:?}"),
    }
    match &desc.scene.emitters[1] {
        Emitter::Point(lente::emitter::PointLight {
            position,
            intensity,
        }) => {
            close(*position, Vec3::new(1.0, 2.0, 3.0));
            assert_eq!(*intensity, Rgb::ONE);
        }
        e => panic!("{e:?}"),
    }
    match (&desc.scene.emitters[2], &desc.scene.emitters[3]) {
        (
            Emitter::Directional(lente::emitter::DirectionalLight {
                direction: d1,
                irradiance,
            }),
            Emitter::Directional(lente::emitter::DirectionalLight { direction: d2, .. }),
        ) => {
            close(*d1, Vec3::Z);
            assert_eq!(*irradiance, Rgb::ONE);
            close(*d2, Vec3::NEG_Y);
        }
        e => panic!("{e:?}"),
    }
    assert_eq!(desc.scene.shapes[0].area_radiance, Some(Rgb::ONE));
    assert_eq!(
        desc.scene.shapes[1].area_radiance,
        Some(Rgb::new(3.0, 2.0, 1.0))
    );
    // Mitsuba's default BSDF is diffuse 0.5, but black on an emitter
    // (`render/shape.cpp`); a BSDF given explicitly is kept.
    let black = Bsdf::Diffuse(lente::bsdf::Diffuse { albedo: Rgb::ZERO });
    assert_eq!(desc.scene.shapes[0].bsdf, black);
    assert_eq!(desc.scene.shapes[1].bsdf, black);
    assert_eq!(desc.scene.shapes[2].bsdf, Bsdf::default());
    assert_eq!(desc.scene.shapes[3].bsdf, Bsdf::default());
    assert_eq!(desc.scene.shapes[3].area_radiance, None);

    let e = |body: &str| load_err(&scene(body));
    assert!(
        e("<emitter type=\"constant\"/><emitter type=\"constant\"/>")
            .message
            .contains("only one environment emitter")
    );
    assert!(e("<emitter type=\"point\"><point name=\"position\" value=\"0\"/><transform name=\"to_world\"/></emitter>")
        .message
        .contains("either 'position' or 'to_world'"));
    assert!(e("<emitter type=\"area\"/>")
        .message
        .contains("inside a <shape>"));
    assert!(e("<emitter type=\"sunsky\"/>")
        .message
        .contains("not supported"));
    assert!(
        e("<emitter type=\"envmap\"><string name=\"filename\" value=\"none.exr\"/></emitter>")
            .report()
            .contains("none.exr")
    );
    assert!(e("<shape type=\"rectangle\"><emitter type=\"area\"><transform name=\"to_world\"/></emitter></shape>")
        .message
        .contains("inherits"));
}

#[test]
fn integrators() {
    let integ = |body: &str| -> (Integrator, Vec<Warning>) {
        let (d, w) = load(&format!(
            "<scene version=\"3.0.0\">\n<sensor type=\"perspective\"/>\n{body}\n</scene>"
        ));
        (d.job.integrator, w)
    };
    let (i, w) = integ(
        "<integrator type=\"path\"><integer name=\"max_depth\" value=\"8\"/><integer name=\"rr_depth\" value=\"2\"/><boolean name=\"hide_emitters\" value=\"true\"/></integrator>",
    );
    assert!(w.is_empty());
    assert_eq!(
        i,
        Integrator::Path {
            strategy: Strategy::Mis,
            params: PathParams {
                max_depth: Some(8),
                rr_depth: 2,
                hide_emitters: true
            }
        }
    );
    let (i, w) = integ("<integrator type=\"direct\"/>");
    assert!(w.is_empty());
    assert_eq!(
        i,
        Integrator::Direct {
            strategy: Strategy::Mis
        }
    );
    let (_, w) = integ(
        "<integrator type=\"direct\"><integer name=\"emitter_samples\" value=\"4\"/></integrator>",
    );
    assert_eq!(w.len(), 1);
    assert!(w[0].message.contains("one emitter and one BSDF sample"));
    // volpath and volpathmis: lente's volpath, with Mitsuba's defaults.
    for ty in ["volpath", "volpathmis"] {
        let (i, w) = integ(&format!(
            "<integrator type=\"{ty}\"><integer name=\"max_depth\" value=\"7\"/></integrator>"
        ));
        assert!(w.is_empty(), "{w:?}");
        assert_eq!(
            i,
            Integrator::VolPath {
                params: PathParams {
                    max_depth: Some(7),
                    rr_depth: 5,
                    hide_emitters: false
                }
            }
        );
    }
    let (i, w) = integ("<integrator type=\"prb\"/>");
    assert_eq!(w.len(), 1);
    assert!(matches!(i, Integrator::Path { .. }));
    // The light tracer: path tracing with its parameters, and one warning.
    let (i, w) = integ(
        "<integrator type=\"ptracer\"><integer name=\"max_depth\" value=\"4\"/><integer name=\"samples_per_pass\" value=\"1024\"/></integrator>",
    );
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(w[0].message.contains("same expected image"));
    assert_eq!(
        i,
        Integrator::Path {
            strategy: Strategy::Mis,
            params: PathParams {
                max_depth: Some(4),
                rr_depth: 5,
                hide_emitters: false
            }
        }
    );
    let (i, w) = integ(
        "<integrator type=\"moment\"><integrator type=\"path\"><integer name=\"max_depth\" value=\"3\"/></integrator><integrator type=\"direct\"/></integrator>",
    );
    assert_eq!(w.len(), 2, "{w:?}");
    assert!(w.iter().any(|w| w.message.contains("no moment channels")));
    assert!(w.iter().any(|w| w.message.contains("only the first")));
    assert!(matches!(
        i,
        Integrator::Path {
            params: PathParams {
                max_depth: Some(3),
                ..
            },
            ..
        }
    ));
    assert_err(
        "<scene version=\"3.0.0\">\n<integrator type=\"moment\"/>\n</scene>",
        2,
        1,
        &["moment", "nested <integrator>"],
    );
    assert_err(
        "<scene version=\"3.0.0\">\n<integrator type=\"aov\"/>\n</scene>",
        2,
        1,
        &["'aovs' must list NAME:TYPE pairs"],
    );
    assert_err(
        "<scene version=\"3.0.0\">\n<integrator type=\"path\"><integer name=\"max_depth\" value=\"-2\"/></integrator>\n</scene>",
        2,
        58,
        &["max_depth"],
    );
    assert_err(
        "<scene version=\"3.0.0\">\n<integrator type=\"path\"><integer name=\"rr_depth\" value=\"0\"/></integrator>\n</scene>",
        2,
        57,
        &["rr_depth"],
    );
}

#[test]
fn bsdfs() {
    use lente::bsdf::{conductor_preset, MicrofacetType};
    let (desc, w) = load(&scene(
        r#"<shape type="sphere"><bsdf type="dielectric"/></shape>
           <shape type="sphere"><bsdf type="dielectric"><string name="int_ior" value="water"/><float name="ext_ior" value="1.1"/></bsdf></shape>
           <shape type="sphere"><bsdf type="conductor"/></shape>
           <shape type="sphere"><bsdf type="conductor"><string name="material" value="none"/></bsdf></shape>
           <shape type="sphere"><bsdf type="roughconductor"><string name="material" value="Au"/><float name="alpha" value="0.2"/><string name="distribution" value="ggx"/></bsdf></shape>
           <shape type="sphere"><bsdf type="plastic"><rgb name="diffuse_reflectance" value="0.1, 0.2, 0.3"/></bsdf></shape>
           <shape type="sphere"><bsdf type="twosided"><bsdf type="diffuse"><rgb name="reflectance" value="0.4"/></bsdf></bsdf></shape>
           <shape type="sphere"><bsdf type="thindielectric"/></shape>
           <shape type="sphere"><bsdf type="roughdielectric"><float name="alpha_u" value="0.1"/><float name="alpha_v" value="0.3"/></bsdf></shape>
           <shape type="sphere"><bsdf type="conductor"><string name="material" value="Cu"/><rgb name="specular_reflectance" value="0.9, 0.8, 0.7"/></bsdf></shape>
           <shape type="sphere"><bsdf type="conductor"><rgb name="eta" value="0.2, 0.9, 1.1"/><rgb name="k" value="3.9, 2.4, 2.1"/></bsdf></shape>
           <shape type="sphere"><bsdf type="roughconductor"/></shape>
           <shape type="sphere"><bsdf type="roughconductor"><float name="alpha_u" value="0.05"/><float name="alpha_v" value="0.3"/><string name="distribution" value="Beckmann"/><boolean name="sample_visible" value="false"/></bsdf></shape>
           <shape type="sphere"><bsdf type="thindielectric"><string name="int_ior" value="diamond"/><string name="ext_ior" value="water"/><rgb name="specular_reflectance" value="0.5"/><rgb name="specular_transmittance" value="0.25, 0.5, 0.75"/></bsdf></shape>
           <shape type="sphere"><bsdf type="roughdielectric"><string name="distribution" value="ggx"/><float name="alpha" value="0.3"/><float name="int_ior" value="1.33"/><rgb name="specular_transmittance" value="0.9"/></bsdf></shape>
           <shape type="sphere"><bsdf type="plastic"><string name="int_ior" value="bk7"/><rgb name="specular_reflectance" value="0.5"/><boolean name="nonlinear" value="true"/></bsdf></shape>
           <shape type="sphere"><bsdf type="roughplastic"><string name="distribution" value="ggx"/><float name="alpha" value="0.25"/><rgb name="diffuse_reflectance" value="0.6, 0.1, 0.1"/></bsdf></shape>
           <shape type="sphere"><bsdf type="twosided"><bsdf type="conductor"/><bsdf type="diffuse"/></bsdf></shape>"#,
    ));
    // Every BSDF is Mitsuba's own: no warnings.
    assert!(w.is_empty(), "{w:?}");
    let b = |i: usize| desc.scene.shapes[i].bsdf.clone();
    let (au_eta, au_k) = conductor_preset("Au").unwrap();
    let (cu_eta, cu_k) = conductor_preset("Cu").unwrap();
    let mirror = Bsdf::conductor(Rgb::ZERO, Rgb::ONE, Rgb::ONE).unwrap();
    assert_eq!(b(0), Bsdf::dielectric(1.5046, 1.000277).unwrap());
    assert_eq!(b(1), Bsdf::dielectric(1.333, 1.1).unwrap());
    // Mitsuba's default material is none: eta 0, k 1, a perfect mirror.
    assert_eq!(b(2), mirror);
    assert_eq!(b(3), mirror);
    assert_eq!(
        b(4),
        Bsdf::rough_conductor(MicrofacetType::Ggx, 0.2, 0.2, au_eta, au_k, Rgb::ONE, true).unwrap()
    );
    assert_eq!(
        b(5),
        Bsdf::plastic(1.49, 1.000277, Rgb::new(0.1, 0.2, 0.3), Rgb::ONE, false).unwrap()
    );
    assert_eq!(
        b(6),
        Bsdf::two_sided(
            Bsdf::Diffuse(lente::bsdf::Diffuse {
                albedo: Rgb::splat(0.4)
            }),
            None
        )
        .unwrap()
    );
    assert_eq!(
        b(7),
        Bsdf::thin_dielectric(1.5046, 1.000277, Rgb::ONE, Rgb::ONE).unwrap()
    );
    assert_eq!(
        b(8),
        Bsdf::rough_dielectric(
            MicrofacetType::Beckmann,
            0.1,
            0.3,
            1.5046,
            1.000277,
            Rgb::ONE,
            Rgb::ONE,
            true
        )
        .unwrap()
    );
    assert_eq!(
        b(9),
        Bsdf::conductor(cu_eta, cu_k, Rgb::new(0.9, 0.8, 0.7)).unwrap()
    );
    assert_eq!(
        b(10),
        Bsdf::conductor(Rgb::new(0.2, 0.9, 1.1), Rgb::new(3.9, 2.4, 2.1), Rgb::ONE).unwrap()
    );
    // Mitsuba's defaults: beckmann, alpha 0.1, material none, visible normals.
    assert_eq!(
        b(11),
        Bsdf::rough_conductor(
            MicrofacetType::Beckmann,
            0.1,
            0.1,
            Rgb::ZERO,
            Rgb::ONE,
            Rgb::ONE,
            true
        )
        .unwrap()
    );
    assert_eq!(
        b(12),
        Bsdf::rough_conductor(
            MicrofacetType::Beckmann,
            0.05,
            0.3,
            Rgb::ZERO,
            Rgb::ONE,
            Rgb::ONE,
            false
        )
        .unwrap()
    );
    assert_eq!(
        b(13),
        Bsdf::thin_dielectric(2.419, 1.333, Rgb::splat(0.5), Rgb::new(0.25, 0.5, 0.75)).unwrap()
    );
    assert_eq!(
        b(14),
        Bsdf::rough_dielectric(
            MicrofacetType::Ggx,
            0.3,
            0.3,
            1.33,
            1.000277,
            Rgb::ONE,
            Rgb::splat(0.9),
            true
        )
        .unwrap()
    );
    assert_eq!(
        b(15),
        Bsdf::plastic(1.5046, 1.000277, Rgb::splat(0.5), Rgb::splat(0.5), true).unwrap()
    );
    match b(16) {
        Bsdf::RoughPlastic(p) => {
            assert_eq!(p.distr.kind, MicrofacetType::Ggx);
            assert_eq!((p.distr.alpha_u, p.distr.alpha_v), (0.25, 0.25));
            assert!(p.distr.sample_visible);
            assert!((p.eta - 1.49 / 1.000277).abs() < 1e-6);
            assert_eq!(p.diffuse_reflectance, Rgb::new(0.6, 0.1, 0.1));
            assert_eq!(p.specular_reflectance, Rgb::ONE);
            assert!(!p.nonlinear);
        }
        other => panic!("expected a rough plastic, found {other:?}"),
    }
    assert_eq!(
        b(17),
        Bsdf::two_sided(mirror.clone(), Some(Bsdf::default())).unwrap()
    );

    // Only what lente cannot reproduce warns: tinted smooth dielectrics.
    let (_, w) = load(&scene(
        r#"<shape type="sphere"><bsdf type="dielectric"><rgb name="specular_transmittance" value="0.5"/></bsdf></shape>"#,
    ));
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(w[0].message.contains("tints"), "{}", w[0]);

    // Shapes sharing a rough plastic (by reference) share one build.
    let (desc, w) = load(&scene(
        r#"<bsdf type="roughplastic" id="rp"><float name="alpha" value="0.3"/></bsdf>
           <shape type="sphere"><ref id="rp"/></shape>
           <shape type="sphere"><ref id="rp"/></shape>
           <shape type="sphere"><bsdf type="twosided"><ref id="rp"/></bsdf></shape>"#,
    ));
    assert!(w.is_empty(), "{w:?}");
    assert_eq!(desc.scene.shapes[0].bsdf, desc.scene.shapes[1].bsdf);
    assert!(matches!(
        desc.scene.shapes[0].bsdf,
        Bsdf::RoughPlastic(ref p) if p.distr.kind == MicrofacetType::Beckmann && p.distr.alpha_u == 0.3
    ));
    assert!(matches!(
        desc.scene.shapes[2].bsdf,
        Bsdf::TwoSided(lente::bsdf::TwoSided { .. })
    ));

    // A twosided BSDF cannot hold a transmissive one: an error at the
    // nested element (or at the reference to it).
    assert_err(
        &scene("<shape type=\"sphere\">\n<bsdf type=\"twosided\">\n  <bsdf type=\"dielectric\"/></bsdf></shape>"),
        6,
        3,
        &["<bsdf type=\"dielectric\">", "twosided", "transmission"],
    );
    assert_err(
        &scene("<bsdf type=\"roughdielectric\" id=\"g\"/>\n<shape type=\"sphere\"><bsdf type=\"twosided\"><bsdf type=\"diffuse\"/>\n <ref id=\"g\"/></bsdf></shape>"),
        6,
        2,
        &["roughdielectric", "transmission"],
    );
    assert_err(
        &scene("<shape type=\"sphere\"><bsdf type=\"twosided\">\n<bsdf type=\"thindielectric\"/></bsdf></shape>"),
        5,
        1,
        &["thindielectric", "transmission"],
    );
    // Mitsuba's roughplastic is isotropic only.
    assert!(load_err(&scene(
        "<shape type=\"sphere\"><bsdf type=\"roughplastic\"><float name=\"alpha_u\" value=\"0.1\"/><float name=\"alpha_v\" value=\"0.2\"/></bsdf></shape>"
    ))
    .message
    .contains("isotropic"));
    // W_palik has no data in Mitsuba 3.9.1; CuZn was Mitsuba 0.6's.
    for bad in ["W_palik", "CuZn"] {
        assert!(load_err(&scene(&format!(
            "<shape type=\"sphere\"><bsdf type=\"conductor\"><string name=\"material\" value=\"{bad}\"/></bsdf></shape>"
        )))
        .message
        .contains("unknown conductor material"));
    }
    let e = |body: &str| load_err(&scene(body)).message;
    assert!(e("<shape type=\"sphere\"><bsdf type=\"dielectric\"><string name=\"int_ior\" value=\"glass\"/></bsdf></shape>")
        .contains("bk7"));
    assert!(e("<shape type=\"sphere\"><bsdf type=\"conductor\"><string name=\"material\" value=\"Gold\"/></bsdf></shape>")
        .contains("Au"));
    assert!(e("<shape type=\"sphere\"><bsdf type=\"conductor\"><string name=\"material\" value=\"Au\"/><rgb name=\"eta\" value=\"1\"/></bsdf></shape>")
        .contains("not both"));
    assert!(e("<shape type=\"sphere\"><bsdf type=\"roughconductor\"><string name=\"distribution\" value=\"phong\"/></bsdf></shape>")
        .contains("beckmann or ggx"));
    assert!(e("<shape type=\"sphere\"><bsdf type=\"principledthin\"><float name=\"eta\" value=\"0\"/></bsdf></shape>")
        .contains("must be positive"));
    assert!(e("<shape type=\"sphere\"><bsdf type=\"principledthin\"><float name=\"diff_trans\" value=\"3\"/></bsdf></shape>")
        .contains("[0, 2]"));
    assert!(e("<shape type=\"sphere\"><bsdf type=\"principledthin\"><float name=\"diffuse_transmittance_sampling_rate\" value=\"-1\"/></bsdf></shape>")
        .contains("must not be negative"));
    assert!(e("<shape type=\"sphere\"><bsdf type=\"principled\"><float name=\"eta\" value=\"1.4\"/><float name=\"specular\" value=\"0.5\"/></bsdf></shape>")
        .contains("not both"));
    assert!(e("<shape type=\"sphere\"><bsdf type=\"principled\"><float name=\"specular\" value=\"13\"/></bsdf></shape>")
        .contains("below 12.5"));
    assert!(e("<shape type=\"sphere\"><bsdf type=\"principled\"><float name=\"eta\" value=\"-1\"/></bsdf></shape>")
        .contains("positive"));
    assert!(e("<shape type=\"sphere\"><bsdf type=\"twosided\"/></shape>").contains("nested"));
}

/// A conductor's `eta` and `k` with negative components (RGB fits of
/// measured data, as Bitterli's living-room-2 has them): Mitsuba renders
/// them, and its Fresnel term squares them, so lente takes their
/// magnitudes, with one warning each.
#[test]
fn conductor_negative_ior_components_take_their_magnitude() {
    let (file, warnings) = load(&scene(
        "<shape type=\"sphere\"><bsdf type=\"roughconductor\">\n<rgb name=\"eta\" value=\"-0.0485, 4.14, 4.67\"/>\n<rgb name=\"k\" value=\"-0.0364, 0.0938, 1.30\"/></bsdf></shape>",
    ));
    let want = Bsdf::rough_conductor(
        lente::bsdf::MicrofacetType::Beckmann,
        0.1,
        0.1,
        Rgb::new(0.0485, 4.14, 4.67),
        Rgb::new(0.0364, 0.0938, 1.30),
        Rgb::ONE,
        true,
    )
    .unwrap();
    assert_eq!(file.scene.shapes[0].bsdf, want);
    assert_eq!(warnings.len(), 2, "{warnings:?}");
    assert!(warnings[0]
        .message
        .contains("'eta' has negative components"));
    assert!(warnings[1].message.contains("'k' has negative components"));
    assert_eq!((warnings[0].line, warnings[1].line), (5, 6));
}

/// `principled`: Mitsuba's defaults (base colour and roughness 0.5,
/// specular 0.5 as an IOR), parameters given as zero are absent (its
/// has_* flags), textures kept; eta = 1 with transmission is nudged.
#[test]
fn principled_parameters() {
    use lente::bsdf::Principled;
    use lente::texture::Texture;
    let get = |body: &str| -> Principled {
        let (desc, _) = load(&scene(&format!("<shape type=\"sphere\">{body}</shape>")));
        match &desc.scene.shapes[0].bsdf {
            Bsdf::Principled(p) => (**p).clone(),
            b => panic!("not principled: {b:?}"),
        }
    };
    let p = get(r#"<bsdf type="principled"/>"#);
    assert_eq!(p.base_color, Texture::Constant(Rgb::splat(0.5)));
    assert_eq!(p.roughness, Texture::Constant(Rgb::splat(0.5)));
    // specular 0.5: R0 = 0.04, eta = 1.5.
    close_f(p.eta, 1.5, 1e-5);
    assert!(p.metallic.is_none() && p.spec_trans.is_none() && p.clearcoat.is_none());
    let p = get(
        r#"<bsdf type="principled"><float name="metallic" value="0"/><float name="sheen" value="0.3"/>
           <texture type="checkerboard" name="clearcoat"/><float name="spec_trans" value="1"/><float name="eta" value="1"/></bsdf>"#,
    );
    assert!(p.metallic.is_none());
    assert_eq!(p.sheen, Some(Texture::Constant(Rgb::splat(0.3))));
    assert!(matches!(p.clearcoat, Some(Texture::Checkerboard(_))));
    close_f(p.eta, 1.001, 1e-6);
}

/// `principledthin`: Mitsuba's defaults (base colour and roughness 0.5,
/// eta 1.5, rates 1), parameters given as zero absent (its has_* flags),
/// textures kept, eta as a texture.
#[test]
fn principled_thin_parameters() {
    use lente::bsdf::PrincipledThin;
    use lente::texture::Texture;
    let get = |body: &str| -> PrincipledThin {
        let (desc, w) = load(&scene(&format!("<shape type=\"sphere\">{body}</shape>")));
        assert!(w.is_empty(), "{w:?}");
        match &desc.scene.shapes[0].bsdf {
            Bsdf::PrincipledThin(p) => (**p).clone(),
            b => panic!("not principledthin: {b:?}"),
        }
    };
    let p = get(r#"<bsdf type="principledthin"/>"#);
    assert_eq!(p.base_color, Texture::Constant(Rgb::splat(0.5)));
    assert_eq!(p.roughness, Texture::Constant(Rgb::splat(0.5)));
    assert_eq!(p.eta, Texture::Constant(Rgb::splat(1.5)));
    assert!(p.spec_trans.is_none() && p.diff_trans.is_none() && p.sheen.is_none());
    assert_eq!(
        (
            p.spec_refl_rate,
            p.spec_trans_rate,
            p.diff_refl_rate,
            p.diff_trans_rate
        ),
        (1.0, 1.0, 1.0, 1.0)
    );
    let p = get(
        r#"<bsdf type="principledthin"><float name="spec_trans" value="0"/><float name="diff_trans" value="1.5"/>
           <texture type="checkerboard" name="eta"/><float name="diffuse_reflectance_sampling_rate" value="3"/></bsdf>"#,
    );
    assert!(p.spec_trans.is_none());
    assert_eq!(p.diff_trans, Some(Texture::Constant(Rgb::splat(1.5))));
    assert!(matches!(p.eta, Texture::Checkerboard(_)));
    assert_eq!(p.diff_refl_rate, 3.0);
}

/// `mask`: opacity (0.5) as a number, colour or texture over one nested
/// BSDF; like Mitsuba, twosided refuses a mask inside it (the holes
/// transmit) and takes one outside.
#[test]
fn masks() {
    use lente::texture::Texture;
    let (desc, w) = load(&scene(
        r#"<shape type="sphere"><bsdf type="mask"><bsdf type="diffuse"/></bsdf></shape>
           <shape type="sphere"><bsdf type="mask"><float name="opacity" value="0.25"/><bsdf type="twosided"><bsdf type="diffuse"/></bsdf></bsdf></shape>
           <shape type="sphere"><bsdf type="mask"><texture type="checkerboard" name="opacity"/><bsdf type="conductor"/></bsdf></shape>"#,
    ));
    assert!(w.is_empty(), "{w:?}");
    let b = |i: usize| desc.scene.shapes[i].bsdf.clone();
    let grey = Bsdf::diffuse(Rgb::splat(0.5)).unwrap();
    assert_eq!(
        b(0),
        Bsdf::mask(Texture::Constant(Rgb::splat(0.5)), grey.clone()).unwrap()
    );
    assert_eq!(
        b(1),
        Bsdf::mask(
            Texture::Constant(Rgb::splat(0.25)),
            Bsdf::two_sided(grey, None).unwrap()
        )
        .unwrap()
    );
    match b(2) {
        Bsdf::Mask(m) => assert!(matches!(m.opacity, Texture::Checkerboard(_))),
        other => panic!("{other:?}"),
    }
    let e = |body: &str| load_err(&scene(body)).report();
    assert!(
        e(r#"<shape type="sphere"><bsdf type="mask"/></shape>"#).contains("needs a nested <bsdf>")
    );
    assert!(e(r#"<shape type="sphere"><bsdf type="mask"><bsdf type="diffuse"/><bsdf type="diffuse"/></bsdf></shape>"#)
        .contains("takes one nested <bsdf>"));
    assert!(e(r#"<shape type="sphere"><bsdf type="twosided"><bsdf type="mask"><bsdf type="diffuse"/></bsdf></bsdf></shape>"#)
        .contains("put the twosided inside the mask"));
    assert!(e(r#"<shape type="sphere"><bsdf type="mask"><float name="opacity" value="-1"/><bsdf type="diffuse"/></bsdf></shape>"#)
        .contains("opacity"));
}
