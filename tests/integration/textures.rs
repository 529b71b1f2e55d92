//! Textures read from Mitsuba files (`bitmap`, `checkerboard`, `rawconstant`): what the
//! reader builds, shared images, errors that name the property, and the
//! textured BSDF's consistency (weight = eval cos / pdf at every uv).

use std::path::Path;
use std::sync::Arc;

use lente::bsdf::Bsdf;
use lente::color::Rgb;
use lente::load::SceneFile;
use lente::math::{Vec2, Vec3};
use lente::sampling::Sampler;
use lente::texture::Texture;

use crate::mitsuba_parse::scene;

/// Scenes are read as if they stood in tests/conformance, next to its
/// images (tiles.png: 16 x 8 sRGB colour; roughness.png: 8 x 8 grey).
fn load(body: &str) -> SceneFile {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/conformance/t.xml");
    crate::common::load_clean_at(&scene(body), &path)
}

fn load_err(body: &str) -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/conformance/t.xml");
    crate::common::load_err_at(&scene(body), &path).report()
}

fn textures(b: &Bsdf) -> Vec<(lente::bsdf::BsdfParam, Texture)> {
    match b {
        Bsdf::Textured(t) => t.textures().to_vec(),
        Bsdf::TwoSided(t) => textures(&t.front),
        other => panic!("not textured: {other:?}"),
    }
}

#[test]
fn bitmap_and_checkerboard_are_read_and_images_are_shared() {
    let desc = load(
        r#"<texture type="bitmap" id="t"><string name="filename" value="tiles.png"/></texture>
           <shape type="sphere"><bsdf type="diffuse"><ref id="t" name="reflectance"/></bsdf></shape>
           <shape type="sphere"><bsdf type="plastic">
               <texture type="bitmap" name="diffuse_reflectance"><string name="filename" value="tiles.png"/>
                   <string name="filter_type" value="nearest"/></texture></bsdf></shape>
           <shape type="sphere"><bsdf type="twosided"><bsdf type="diffuse">
               <texture type="checkerboard" name="reflectance"><float name="color1" value="0.9"/></texture>
           </bsdf></bsdf></shape>
           <shape type="sphere"><bsdf type="roughconductor">
               <texture type="bitmap" name="alpha"><string name="filename" value="roughness.png"/>
                   <boolean name="raw" value="true"/></texture></bsdf></shape>"#,
    );
    let b: Vec<&Bsdf> = desc.scene.shapes.iter().map(|s| &s.bsdf).collect();
    let (Texture::Bitmap(a), Texture::Bitmap(c)) = (&textures(b[0])[0].1, &textures(b[1])[0].1)
    else {
        panic!("bitmaps expected");
    };
    assert!(Arc::ptr_eq(a.image(), c.image()), "one file, one image");
    assert_eq!((a.image().width(), a.image().height()), (16, 8));
    // The first texel is sRGB (230, 60, 40), decoded to linear.
    let first = a.eval(Vec2::new(0.5 / 16.0, 0.5 / 8.0));
    let want = Rgb::new(
        lente::color::srgb_decode(230.0 / 255.0),
        lente::color::srgb_decode(60.0 / 255.0),
        lente::color::srgb_decode(40.0 / 255.0),
    );
    assert!((first - want).abs().max_element() < 1e-5, "{first}");
    // The checkerboard keeps Mitsuba's defaults where not given.
    let Texture::Checkerboard(k) = &textures(b[2])[0].1 else {
        panic!("checkerboard expected");
    };
    assert_eq!((k.color0, k.color1), (Rgb::splat(0.4), Rgb::splat(0.9)));
    // The raw roughness is the byte value / 255, for both alpha_u and alpha_v.
    let rough = textures(b[3]);
    assert_eq!(rough.len(), 2);
    let Texture::Bitmap(r) = &rough[0].1 else {
        panic!("bitmap expected");
    };
    let v = r.eval(Vec2::new(0.5 / 8.0, 0.5)).x;
    assert!((v - 12.0 / 255.0).abs() < 1e-6, "{v}");
}

#[test]
fn texture_errors_name_the_property() {
    let e = load_err(
        r#"<shape type="sphere"><bsdf type="diffuse"><texture type="bitmap" name="reflectance">
           <string name="filename" value="tiles.png"/><string name="filter_type" value="cubic"/>
           </texture></bsdf></shape>"#,
    );
    assert!(
        e.contains("filter_type") && e.contains("bilinear or nearest"),
        "{e}"
    );
    let e = load_err(
        r#"<shape type="sphere"><bsdf type="diffuse"><texture type="bitmap" name="reflectance">
           <string name="filename" value="missing.png"/></texture></bsdf></shape>"#,
    );
    assert!(
        e.contains("missing.png") && e.contains("cannot load the texture"),
        "{e}"
    );
    let e = load_err(
        r#"<shape type="sphere"><bsdf type="dielectric"><texture type="checkerboard" name="int_ior"/>
           </bsdf></shape>"#,
    );
    assert!(e.contains("int_ior") && e.contains("<texture>"), "{e}");
    let e = load_err(
        r#"<shape type="sphere"><bsdf type="roughplastic"><texture type="checkerboard" name="alpha"/>
           </bsdf></shape>"#,
    );
    assert!(
        e.contains("'alpha'") && e.contains("cannot be a texture"),
        "{e}"
    );
}

/// `rawconstant` hands its float or vector over as it is: no colour
/// conversion, no clamping; a value of another type, or none, is an error
/// at the place.
#[test]
fn rawconstant_values_are_taken_raw() {
    let desc = load(
        r#"<shape type="sphere"><bsdf type="diffuse">
               <texture type="rawconstant" name="reflectance"><vector name="value" value="0.2, 0.5, 0.9"/></texture>
           </bsdf></shape>
           <shape type="sphere"><bsdf type="diffuse">
               <texture type="rawconstant" name="reflectance"><float name="value" value="0.25"/></texture>
           </bsdf></shape>"#,
    );
    let albedo = |i: usize| match &desc.scene.shapes[i].bsdf {
        Bsdf::Diffuse(d) => d.albedo,
        other => panic!("diffuse expected: {other:?}"),
    };
    assert_eq!(albedo(0), Rgb::new(0.2, 0.5, 0.9));
    assert_eq!(albedo(1), Rgb::splat(0.25));
    let e = load_err(
        r#"<shape type="sphere"><bsdf type="diffuse"><texture type="rawconstant" name="reflectance">
           <string name="value" value="red"/></texture></bsdf></shape>"#,
    );
    assert!(e.contains("float or a vector, found a string"), "{e}");
    let e = load_err(
        r#"<shape type="sphere"><bsdf type="diffuse"><texture type="rawconstant" name="reflectance"/>
           </bsdf></shape>"#,
    );
    assert!(e.contains("needs a 'value'"), "{e}");
}

/// At several uvs of a checkerboard-textured rough conductor and diffuse
/// surface, every sample's weight is eval cos / pdf (the texture is read
/// at the same uv by all three), and the diffuse weight is the texel.
#[test]
fn textured_weights_are_eval_cos_over_pdf_at_the_hit() {
    let desc = load(
        r#"<shape type="sphere"><bsdf type="diffuse">
               <texture type="checkerboard" name="reflectance"><rgb name="color0" value="0.8, 0.5, 0.2"/></texture>
           </bsdf></shape>
           <shape type="sphere"><bsdf type="roughconductor"><string name="distribution" value="ggx"/>
               <texture type="checkerboard" name="alpha"><float name="color0" value="0.05"/><float name="color1" value="0.6"/></texture>
               <texture type="checkerboard" name="specular_reflectance"/>
           </bsdf></shape>"#,
    );
    let mut sampler = Sampler::new(7, 0);
    let wi = Vec3::new(0.3, -0.2, 0.9).normalize();
    for (i, shape) in desc.scene.shapes.iter().enumerate() {
        for uv in [
            Vec2::new(0.1, 0.2),
            Vec2::new(0.7, 0.2),
            Vec2::new(0.6, 0.9),
        ] {
            let mut n = 0;
            for _ in 0..200 {
                let Some(s) = shape
                    .bsdf
                    .sample(uv, wi, sampler.next_2d(), sampler.next_1d())
                else {
                    continue;
                };
                n += 1;
                let f = shape.bsdf.eval(uv, wi, s.wo);
                let pdf = shape.bsdf.pdf(uv, wi, s.wo);
                assert!(
                    (pdf - s.pdf).abs() <= 1e-3 * s.pdf.max(1e-3),
                    "{pdf} {}",
                    s.pdf
                );
                let w = f * s.wo.z / pdf;
                assert!(
                    (w - s.weight).abs().max_element() <= 1e-3 * s.weight.max_element().max(1e-3),
                    "shape {i} uv {uv}: {w} vs {}",
                    s.weight
                );
                if i == 0 {
                    let want = if (uv.x > 0.5) == (uv.y > 0.5) {
                        Rgb::new(0.8, 0.5, 0.2)
                    } else {
                        Rgb::splat(0.2)
                    };
                    assert!((s.weight - want).abs().max_element() < 1e-6);
                }
            }
            assert!(n > 100, "shape {i}: only {n} samples");
        }
    }
    // The two roughness squares give visibly different lobes: the pdf of
    // the mirror direction differs by orders of magnitude.
    let rough = &desc.scene.shapes[1].bsdf;
    let mirror = Vec3::new(-wi.x, -wi.y, wi.z);
    let sharp = rough.pdf(Vec2::new(0.75, 0.25), wi, mirror);
    let wide = rough.pdf(Vec2::new(0.25, 0.25), wi, mirror);
    assert!(sharp > 50.0 * wide, "{sharp} vs {wide}");
}

/// `mesh_attribute`: a PLY's per-vertex colours read at a hit's
/// barycentrics and per-face weights on each of a polygon's triangles
/// (`attributes.ply`: vertex colours as float `r g b`, `weight_0` per
/// face), the scale, and errors: a shape without the attribute names what
/// it has; a name without its kind prefix.
#[test]
fn mesh_attributes_are_read_at_the_hit() {
    use lente::geometry::{parse_ply_full, Geometry};
    use lente::texture::SurfacePoint;
    let bytes = std::fs::read(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/conformance/attributes.ply"),
    )
    .unwrap();
    let (mesh, attributes) = parse_ply_full(&bytes).unwrap();
    let names: Vec<&str> = attributes.iter().map(|a| a.name.as_str()).collect();
    assert_eq!(names, ["vertex_color", "face_weight"]);
    assert_eq!(attributes[0].values.len(), mesh.positions().len());
    assert_eq!(attributes[1].values.len(), mesh.triangle_count());

    let desc = load(
        r#"<shape type="ply"><string name="filename" value="attributes.ply"/>
             <bsdf type="blendbsdf">
               <texture type="mesh_attribute" name="weight"><string name="name" value="face_weight"/></texture>
               <bsdf type="diffuse">
                 <texture type="mesh_attribute" name="reflectance">
                   <string name="name" value="vertex_color"/><float name="scale" value="0.5"/>
                 </texture>
               </bsdf>
               <bsdf type="diffuse"/>
             </bsdf>
           </shape>"#,
    );
    let Geometry::Mesh(m) = &desc.scene.shapes[0].geometry else {
        panic!()
    };
    let Bsdf::Blend(b) = &desc.scene.shapes[0].bsdf else {
        panic!("{:?}", desc.scene.shapes[0].bsdf)
    };
    let [reflectance] = textures(&b.first).try_into().unwrap();
    for tri in [0usize, 5, 17, 40] {
        let [i0, i1, i2] = m.indices()[tri].map(|i| i as usize);
        let bary = Vec2::new(0.2, 0.3);
        let at = SurfacePoint {
            uv: Vec2::ZERO,
            prim: tri as u32,
            bary,
            ..Default::default()
        };
        let c = &attributes[0].values;
        let expect = (c[i0] * 0.5 + c[i1] * 0.2 + c[i2] * 0.3) * 0.5;
        let got = reflectance.1.eval(at);
        assert!((got - expect).abs().max_element() < 1e-6, "{got} {expect}");
        let w = b.weight.eval_1(at);
        assert!((w - attributes[1].values[tri].x).abs() < 1e-6);
    }
    // A shape without it, and a sphere, name what is missing.
    let e = load_err(
        r#"<shape type="ply"><string name="filename" value="attributes.ply"/>
             <bsdf type="diffuse">
               <texture type="mesh_attribute" name="reflectance"><string name="name" value="vertex_uv"/></texture>
             </bsdf></shape>"#,
    );
    assert!(
        e.contains("no attribute 'vertex_uv'") && e.contains("vertex_color, face_weight"),
        "{e}"
    );
    let e = load_err(
        r#"<shape type="sphere"><bsdf type="diffuse">
               <texture type="mesh_attribute" name="reflectance"><string name="name" value="vertex_color"/></texture>
             </bsdf></shape>"#,
    );
    assert!(e.contains("(it has: none)"), "{e}");
    let e = load_err(
        r#"<shape type="sphere"><bsdf type="diffuse">
               <texture type="mesh_attribute" name="reflectance"><string name="name" value="color"/></texture>
             </bsdf></shape>"#,
    );
    assert!(e.contains("'vertex_' or 'face_'"), "{e}");
    // A serialized shape's vertex colours (gems.serialized, shape 1: the
    // octahedron's six vertices are coloured 0.25).
    let bytes = std::fs::read(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/conformance/gems.serialized"),
    )
    .unwrap();
    let (_, a) = lente::geometry::parse_serialized_full(&bytes, 1).unwrap();
    assert_eq!(a.len(), 1);
    assert_eq!(a[0].name, "vertex_color");
    assert_eq!(a[0].values, vec![Rgb::splat(0.25); 6]);
    let (_, a) = lente::geometry::parse_serialized_full(&bytes, 0).unwrap();
    assert!(a.is_empty());
}

/// Polygons of a PLY file are fan-triangulated; a face attribute is
/// repeated on each triangle of its polygon.
#[test]
fn a_polygons_face_attribute_covers_its_triangles() {
    let ply = "ply\nformat ascii 1.0\nelement vertex 5\nproperty float x\nproperty float y\n\
               property float z\nproperty float red\nproperty float green\nproperty float blue\n\
               element face 2\nproperty list uchar int vertex_indices\nproperty float w_0\nend_header\n\
               0 0 0 1 0 0\n1 0 0 0 1 0\n1 1 0 0 0 1\n0 1 0 1 1 1\n2 2 0 0 0 0\n\
               4 0 1 2 3 0.25\n3 1 4 2 0.75\n";
    let (mesh, a) = lente::geometry::parse_ply_full(ply.as_bytes()).unwrap();
    assert_eq!(mesh.triangle_count(), 3);
    assert_eq!(a[0].name, "vertex_color");
    assert_eq!(a[0].values[2], Rgb::new(0.0, 0.0, 1.0));
    assert_eq!(a[1].name, "face_w");
    let w: Vec<f32> = a[1].values.iter().map(|v| v.x).collect();
    assert_eq!(w, [0.25, 0.25, 0.75]);
}

/// A projector's image sets its aspect ratio (tiles.png is 16 x 8: the
/// projection is half as high as wide), and a negative scale is refused
/// at the property.
#[test]
fn projector_images_set_the_projections_shape() {
    use lente::emitter::Emitter;
    let desc = load(
        r#"<emitter type="projector">
             <texture type="bitmap" name="irradiance"><string name="filename" value="tiles.png"/></texture>
             <float name="fov" value="40"/>
           </emitter>"#,
    );
    let [Emitter::Projector(p)] = desc.scene.emitters.as_slice() else {
        panic!("{:?}", desc.scene.emitters)
    };
    let t = 20f32.to_radians().tan();
    // The corner of the image: (t, t / 2) at z = 1.
    let corner = (1.0 + t * t * 1.25f32).sqrt().recip();
    assert!((p.cos_cone() - corner).abs() < 1e-6);
    // Inside the image, just below its top edge, and just above it.
    let at = |y: f32| p.sample(Vec3::new(0.0, y, 1.0)).is_some();
    assert!(at(0.49 * t) && !at(0.51 * t));
    let e = load_err(r#"<emitter type="projector"><float name="scale" value="-1"/></emitter>"#);
    assert!(e.contains("'scale'") || e.contains("scale"), "{e}");
}
