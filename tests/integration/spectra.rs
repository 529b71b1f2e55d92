//! Spectra in Mitsuba files: wavelength:value lists, `.spd` files and the
//! spectrum objects become the RGB Mitsuba's RGB variants give, by what
//! they set (reflectance, emission, a conductor's eta/k); bad ones are
//! one-line errors at their place. The conversion itself is tested
//! against Mitsuba's numbers in `lente::color::spectrum`, and rendered in
//! the conformance check (`spectra.xml`).

use std::path::Path;

use lente::bsdf::Bsdf;
use lente::color::{Rgb, SampledSpectrum, Spectrum, SpectrumUse};
use lente::emitter::Emitter;
use lente::load::SceneFile;

use crate::mitsuba_parse::scene;

/// Read as if it stood in tests/conformance, next to reflectance.spd.
fn load(body: &str) -> (SceneFile, Vec<lente::load::Warning>) {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/conformance/t.xml");
    crate::common::load_at(&scene(body), &path, &[])
}

fn load_err(body: &str) -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/conformance/t.xml");
    crate::common::load_err_at(&scene(body), &path).report()
}

fn convert(pairs: &[(f32, f32)], use_: SpectrumUse) -> Rgb {
    Spectrum::Sampled(SampledSpectrum::new(pairs).unwrap())
        .to_rgb(use_)
        .0
}

fn diffuse_albedo(desc: &SceneFile, shape: usize) -> Rgb {
    match &desc.scene.shapes[shape].bsdf {
        Bsdf::Diffuse(d) => d.albedo,
        other => panic!("not diffuse: {other:?}"),
    }
}

/// The same list is a D65-lit reflectance in a BSDF and a bare emission
/// spectrum in an emitter; a single number is a grey reflectance but
/// Mitsuba's pink for an emitter.
#[test]
fn what_a_spectrum_sets_decides_its_colour() {
    let list = "400:0.2, 500:0.4, 600:0.6, 700:0.5";
    let pairs = [(400.0, 0.2), (500.0, 0.4), (600.0, 0.6), (700.0, 0.5)];
    let (desc, w) = load(&format!(
        r#"<shape type="sphere"><bsdf type="diffuse"><spectrum name="reflectance" value="{list}"/></bsdf></shape>
           <shape type="sphere"><bsdf type="diffuse"><spectrum name="reflectance" value="0.25"/></bsdf></shape>
           <shape type="rectangle"><emitter type="area"><spectrum name="radiance" value="{list}"/></emitter></shape>
           <emitter type="constant"><spectrum name="radiance" value="2"/></emitter>"#
    ));
    assert!(w.is_empty(), "{w:?}");
    assert_eq!(
        diffuse_albedo(&desc, 0),
        convert(&pairs, SpectrumUse::Reflectance)
    );
    assert_eq!(diffuse_albedo(&desc, 1), Rgb::splat(0.25));
    let radiance = desc.scene.shapes[2].area_radiance.unwrap();
    assert_eq!(radiance, convert(&pairs, SpectrumUse::Emission));
    assert_ne!(radiance, diffuse_albedo(&desc, 0));
    let pink = Spectrum::Uniform(2.0).to_rgb(SpectrumUse::Emission).0;
    assert!(pink.x > 2.4 && pink.z < 1.9, "{pink}");
    assert!(desc
        .scene
        .emitters
        .iter()
        .any(|e| matches!(e, Emitter::Constant(c) if c.radiance == pink)));
}

/// Spectrum files, and the object forms `irregular`, `regular`,
/// `blackbody` and `d65`, agree with the equivalent value lists.
#[test]
fn files_and_spectrum_objects_read_like_value_lists() {
    let spd = [
        (380.0, 0.08),
        (450.0, 0.15),
        (520.0, 0.62),
        (580.0, 0.45),
        (650.0, 0.12),
        (730.0, 0.10),
    ];
    let (desc, w) = load(
        r#"<shape type="sphere"><bsdf type="diffuse"><spectrum name="reflectance" filename="reflectance.spd"/></bsdf></shape>
           <shape type="sphere"><bsdf type="diffuse"><spectrum type="irregular" name="reflectance">
               <string name="wavelengths" value="400, 550, 700"/><string name="values" value="0.1, 0.5, 0.3"/></spectrum></bsdf></shape>
           <shape type="sphere"><bsdf type="diffuse"><spectrum type="regular" name="reflectance">
               <float name="wavelength_min" value="400"/><float name="wavelength_max" value="700"/>
               <string name="values" value="0.1, 0.5, 0.3"/></spectrum></bsdf></shape>
           <shape type="rectangle"><emitter type="area"><spectrum type="blackbody" name="radiance">
               <float name="temperature" value="3000"/></spectrum></emitter></shape>
           <shape type="sphere"><bsdf type="diffuse"><texture type="d65" name="reflectance">
               <rgb name="color" value="0.2, 0.3, 0.4"/><float name="scale" value="2"/></texture></bsdf></shape>"#,
    );
    assert!(w.is_empty(), "{w:?}");
    assert_eq!(
        diffuse_albedo(&desc, 0),
        convert(&spd, SpectrumUse::Reflectance)
    );
    let three = [(400.0, 0.1), (550.0, 0.5), (700.0, 0.3)];
    let want = convert(&three, SpectrumUse::Reflectance);
    assert_eq!(diffuse_albedo(&desc, 1), want);
    assert_eq!(diffuse_albedo(&desc, 2), want);
    let bb = Spectrum::blackbody(3000.0, (360.0, 830.0))
        .unwrap()
        .to_rgb(SpectrumUse::Emission)
        .0;
    assert_eq!(desc.scene.shapes[3].area_radiance, Some(bb));
    assert!(bb.x > bb.z, "a 3000 K body is red: {bb}");
    assert_eq!(diffuse_albedo(&desc, 4), Rgb::new(0.4, 0.6, 0.8));
}

/// A saturated reflectance is clipped into [0, 1] with a warning, as
/// Mitsuba does.
#[test]
fn out_of_gamut_reflectances_are_clipped_with_a_warning() {
    let (desc, w) = load(
        r#"<shape type="sphere"><bsdf type="diffuse"><spectrum name="reflectance" value="500:0, 530:1, 560:0"/></bsdf></shape>"#,
    );
    let c = diffuse_albedo(&desc, 0);
    assert!(c.min_element() >= 0.0 && c.max_element() <= 1.0, "{c}");
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(w[0].message.contains("outside the sRGB gamut"), "{w:?}");
    assert_eq!((w[0].line, w[0].col), (4, 79), "{w:?}");
}

#[test]
fn bad_spectra_are_errors_at_their_place() {
    let cases: &[(&str, &str)] = &[
        (
            r#"<shape type="sphere"><bsdf type="diffuse"><spectrum name="reflectance" value="400:0.5, 500"/></bsdf></shape>"#,
            "t.xml:4:88: cannot read '500' as a wavelength:value pair",
        ),
        (
            // Spaces around ':' are joined; the error is still at '500'.
            r#"<shape type="sphere"><bsdf type="diffuse"><spectrum name="reflectance" value="400 : 0.5, 500"/></bsdf></shape>"#,
            "t.xml:4:90: cannot read '500' as a wavelength:value pair",
        ),
        (
            r#"<shape type="sphere"><bsdf type="diffuse"><spectrum name="reflectance" value="500:0.5, 400:0.2"/></bsdf></shape>"#,
            "wavelengths must increase, but 400 nm follows 500 nm",
        ),
        (
            r#"<shape type="sphere"><bsdf type="diffuse"><spectrum name="reflectance" value="500:0.5"/></bsdf></shape>"#,
            "at least two wavelength:value samples",
        ),
        (
            r#"<shape type="sphere"><bsdf type="diffuse"><spectrum name="reflectance" filename="missing.spd"/></bsdf></shape>"#,
            "t.xml:4:82: cannot read",
        ),
        (
            r#"<shape type="sphere"><bsdf type="diffuse"><spectrum name="reflectance" filename="tiles.png"/></bsdf></shape>"#,
            "must be .spd text files",
        ),
        (
            r#"<shape type="rectangle"><emitter type="area"><spectrum type="blackbody" name="radiance"><float name="temperature" value="-3"/></spectrum></emitter></shape>"#,
            "positive finite number of kelvin",
        ),
        (
            r#"<shape type="sphere"><bsdf type="diffuse"><spectrum type="irregular" name="reflectance"><string name="wavelengths" value="400, 500"/><string name="values" value="1"/></spectrum></bsdf></shape>"#,
            "'values' has 1 numbers but 'wavelengths' has 2",
        ),
    ];
    for (body, want) in cases {
        let e = load_err(body);
        assert!(e.contains(want), "{body}\n gave: {e}\n want: {want}");
    }
}

/// A malformed .spd file is named with its line.
#[test]
fn a_bad_spd_line_is_named() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("s.spd"), "# comment\n400 0.5\n500 0.5 7\n").unwrap();
    let path = dir.path().join("s.xml");
    let text = scene(
        r#"<shape type="sphere"><bsdf type="diffuse"><spectrum name="reflectance" filename="s.spd"/></bsdf></shape>"#,
    );
    let e = crate::common::load_err_at(&text, &path).report();
    assert!(
        e.contains("s.spd:3: a line holds a wavelength and a value, found 3 numbers"),
        "{e}"
    );
}
