//! No Mitsuba scene makes the loader panic: random mutations of a scene
//! that uses every part of the dialect either load or fail with a located
//! error.

use lente::load::load_scene_str_with;

/// A valid scene that touches every part of the dialect.
const RICH_SCENE: &str = r#"<?xml version="1.0"?>
<scene version="3.0.0">
    <default name="spp" value="16"/>
    <default name="radius" value="0.5"/>
    <path value="."/>
    <integrator type="path">
        <integer name="max_depth" value="8"/>
        <integer name="rr_depth" value="4"/>
        <boolean name="hide_emitters" value="false"/>
    </integrator>
    <sensor type="thinlens">
        <float name="fov" value="35"/>
        <string name="fov_axis" value="smaller"/>
        <float name="aperture_radius" value="0.05"/>
        <float name="focus_distance" value="5"/>
        <float name="near_clip" value="0.1"/>
        <transform name="to_world">
            <lookat origin="0, 1, 5" target="0, 0, 0" up="0, 1, 0"/>
            <rotate y="1" angle="10"/>
            <translate x="0.1"/>
        </transform>
        <sampler type="independent">
            <integer name="sample_count" value="$spp"/>
        </sampler>
        <film type="hdrfilm">
            <integer name="width" value="64"/>
            <integer name="height" value="48"/>
            <string name="pixel_format" value="rgb"/>
            <rfilter type="gaussian">
                <float name="stddev" value="0.4"/>
            </rfilter>
        </film>
    </sensor>
    <bsdf type="diffuse" id="grey">
        <rgb name="reflectance" value="0.5, 0.5, 0.5"/>
    </bsdf>
    <texture type="srgb" id="tint">
        <rgb name="color" value="0.2, 0.4, 0.6"/>
    </texture>
    <alias id="grey" as="gray"/>
    <shape type="obj">
        <string name="filename" value="tri.obj"/>
        <transform name="to_world">
            <matrix value="1 0 0 0  0 1 0 0  0 0 1 0  0 0 0 1"/>
            <scale value="2"/>
        </transform>
        <bsdf type="dielectric">
            <string name="int_ior" value="water"/>
            <float name="ext_ior" value="1.0"/>
        </bsdf>
    </shape>
    <shape type="ply">
        <string name="filename" value="quad.ply"/>
        <boolean name="face_normals" value="true"/>
        <ref id="gray"/>
    </shape>
    <shape type="sphere">
        <point name="center" x="0" y="1" z="0"/>
        <float name="radius" value="$radius"/>
        <bsdf type="diffuse">
            <ref name="reflectance" id="tint"/>
        </bsdf>
        <emitter type="area">
            <rgb name="radiance" value="4"/>
        </emitter>
    </shape>
    <shape type="rectangle">
        <boolean name="flip_normals" value="false"/>
        <bsdf type="twosided">
            <bsdf type="conductor"/>
        </bsdf>
    </shape>
    <shape type="cube"><ref id="grey"/></shape>
    <shape type="disk"><bsdf type="plastic"/></shape>
    <shape type="cylinder">
        <point name="p0" value="0, 0, 0"/>
        <point name="p1" value="0, 1, 0"/>
        <float name="radius" value="0.2"/>
    </shape>
    <emitter type="point">
        <point name="position" value="0, 3, 0"/>
        <spectrum name="intensity" value="10"/>
    </emitter>
    <emitter type="directional">
        <vector name="direction" value="0, -1, 0"/>
        <rgb name="irradiance" value="1, 1, 1"/>
    </emitter>
    <emitter type="envmap">
        <string name="filename" value="sky.pfm"/>
        <float name="scale" value="0.5"/>
        <transform name="to_world"><rotate y="1" angle="90"/></transform>
    </emitter>
</scene>
"#;

const TRI_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
const QUAD_PLY: &str = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n";

fn sky_pfm() -> Vec<u8> {
    let mut pfm = b"PF\n4 2\n-1.0\n".to_vec();
    for i in 0..24 {
        pfm.extend((0.1 * i as f32).to_le_bytes());
    }
    pfm
}

#[test]
fn random_mutations_never_panic() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("tri.obj"), TRI_OBJ).unwrap();
    std::fs::write(dir.path().join("quad.ply"), QUAD_PLY).unwrap();
    std::fs::write(dir.path().join("sky.pfm"), sky_pfm()).unwrap();
    let path = dir.path().join("scene.xml");
    let defines = vec![("radius".to_string(), "0.75".to_string())];
    let (desc, warnings) =
        load_scene_str_with(RICH_SCENE, &path, &defines).expect("the base scene must load");
    // Every BSDF in it is Mitsuba's own model now: nothing to warn about.
    assert!(warnings.is_empty(), "{warnings:?}");
    assert_eq!(desc.scene.shapes.len(), 7);
    assert_eq!(desc.scene.emitters.len(), 3);

    crate::mutation::loads_or_fails_located(
        RICH_SCENE,
        "<>/=\"' ,.-+e0123456789\n\t&;!?xyz$\\:é\u{0}\u{feff}",
        0x3175_0BA5,
        |text| load_scene_str_with(text, &path, &defines),
    );
}
