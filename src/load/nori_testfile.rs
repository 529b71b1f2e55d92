//! Nori's test files: `<test type="ttest">` and `<test type="chi2test">`.
//!
//! A test file holds one `<test>` element whose properties use Nori's
//! names and defaults, and whose children are complete Nori `<scene>`s
//! (built by [`super::nori`]) or `<bsdf>`s. This module only reads the
//! file; `crate::verify` runs the tests.
//!
//! - `ttest` with scenes: `references` holds one mean luminance per scene;
//!   `sampleCount` (default 100000) camera rays per scene, which replaces
//!   the scene's own sampler.
//! - `ttest` with BSDFs: `angles` (degrees) lists incident directions;
//!   `references` holds one mean sample weight per BSDF and angle, BSDF by
//!   BSDF (all angles of the first BSDF, then the next).
//! - `chi2test` with BSDFs: `resolution` (10) cells in cos theta and twice
//!   as many in phi, `minExpFrequency` (5), `sampleCount` (default 5000 per
//!   cell) samples per test, `testCount` (5) random incident directions
//!   per BSDF.
//!
//! Both take `significanceLevel` (0.01), which is Sidak-corrected over the
//! number of tests in the file.

use std::path::{Path, PathBuf};

use super::props::{self, Props};
use super::xml::{Pos, SceneNode};
use super::{nori, SceneError, SceneFile, Warning};
use crate::bsdf::Bsdf;

type Result<T> = std::result::Result<T, SceneError>;

const TEST_TYPES: &[&str] = &["ttest", "chi2test"];

/// Most samples one test may ask for (Nori's counts are 32-bit integers).
const MAX_SAMPLES: i64 = i32::MAX as i64;

/// A BSDF of a test file, with where it was written.
#[derive(Clone, Debug)]
pub struct BsdfCase {
    pub bsdf: Bsdf,
    /// `<bsdf type="...">` as written.
    pub name: String,
    pub pos: Pos,
}

/// A scene of a test file, with where it was written.
#[derive(Clone, Debug)]
pub struct SceneCase {
    pub file: SceneFile,
    pub pos: Pos,
}

/// What a test file asks for.
#[derive(Clone, Debug)]
pub enum NoriTest {
    /// Mean luminance seen by each scene's camera against `references`.
    SceneTTest {
        scenes: Vec<SceneCase>,
        references: Vec<f64>,
        sample_count: u32,
    },
    /// Mean sample weight of each BSDF at each incidence angle (degrees,
    /// measured from the normal, in the xz-plane) against `references`,
    /// indexed `bsdf * angles.len() + angle`.
    BsdfTTest {
        bsdfs: Vec<BsdfCase>,
        angles: Vec<f32>,
        references: Vec<f64>,
        sample_count: u32,
    },
    /// Chi-square tests of each BSDF's sampled directions against its pdf.
    Chi2Test {
        bsdfs: Vec<BsdfCase>,
        /// Cells in cos theta; phi has twice as many.
        resolution: u32,
        min_exp_frequency: f64,
        /// Samples per test.
        sample_count: u32,
        /// Incident directions (tests) per BSDF.
        test_count: u32,
    },
}

impl NoriTest {
    /// Number of hypothesis tests in the file (the Sidak correction's n).
    pub fn test_count(&self) -> usize {
        match self {
            NoriTest::SceneTTest { references, .. } | NoriTest::BsdfTTest { references, .. } => {
                references.len()
            }
            NoriTest::Chi2Test {
                bsdfs, test_count, ..
            } => bsdfs.len() * *test_count as usize,
        }
    }
}

/// A parsed test file.
#[derive(Clone, Debug)]
pub struct TestFile {
    pub path: PathBuf,
    pub test: NoriTest,
    /// Family-wise significance level (before the Sidak correction).
    pub significance: f64,
}

/// Reads a Nori test file.
pub fn load_test(path: &Path) -> Result<(TestFile, Vec<Warning>)> {
    let text = super::read_text(path, "test file")?;
    load_test_str(&text, path)
}

/// Reads a test file from text; `path` names it in messages and is the
/// base of relative file names inside it.
pub fn load_test_str(text: &str, path: &Path) -> Result<(TestFile, Vec<Warning>)> {
    let root = super::parse_xml(text, path)?;
    if root.tag != "test" {
        let hint = if root.tag == "scene" {
            "; this is a scene file: render it with `lente render`"
        } else {
            ""
        };
        return Err(SceneError::new(
            path,
            root.pos,
            format!(
                "expected <test> as the root element of a test file, found <{}>{hint}",
                root.tag
            ),
        ));
    }
    read_test(&root, path)
}

fn read_test(root: &SceneNode, file: &Path) -> Result<(TestFile, Vec<Warning>)> {
    let ty = nori::object_type(root, file, TEST_TYPES)?;
    let owner = format!("<test type=\"{ty}\">");
    let (mut p, objects) = nori::read_object(root, file, &owner)?;
    let mut warnings = Vec::new();

    // Through the shortest decimal that gives the f32, so 0.01 stays 0.01.
    let significance = p.get_float("significanceLevel", 0.01)?;
    let significance: f64 = significance
        .to_string()
        .parse()
        .unwrap_or(significance as f64);
    if !(significance > 0.0 && significance < 1.0) {
        return Err(p.error(
            "significanceLevel",
            format!(
                "'significanceLevel' must be between 0 and 1 (exclusive), found {significance}"
            ),
        ));
    }

    // Children first: their number decides how many references are needed.
    let mut scenes = Vec::new();
    let mut bsdfs = Vec::new();
    for node in &objects {
        match node.tag.as_str() {
            "scene" if ty == "ttest" => {
                let (scene, w) = nori::load(node, file)?;
                warnings.extend(w);
                scenes.push(SceneCase {
                    file: scene,
                    pos: node.pos,
                });
            }
            "bsdf" => {
                let (bsdf, w) = nori::load_bsdf(node, file)?;
                warnings.extend(w);
                bsdfs.push(BsdfCase {
                    bsdf,
                    name: format!("<bsdf type=\"{}\">", node.attr_value("type").unwrap_or("?")),
                    pos: node.pos,
                });
            }
            other => {
                let holds = if ty == "ttest" {
                    "<scene>s or <bsdf>s"
                } else {
                    "<bsdf>s"
                };
                return Err(SceneError::new(
                    file,
                    node.pos,
                    format!("<{other}> cannot stand inside {owner}; it holds {holds}"),
                ));
            }
        }
    }

    let test = if ty == "ttest" {
        let sample_count = count(&mut p, "sampleCount", 100_000, 2)?;
        let angles_text = p.get_string("angles", String::new())?;
        let references_text = p.get_string("references", String::new())?;
        let references = numbers(root, file, &p, "references", &references_text)?;
        if !scenes.is_empty() && !bsdfs.is_empty() {
            let later = scenes[0].pos.max(bsdfs[0].pos);
            return Err(SceneError::new(
                file,
                later,
                format!("{owner} cannot test scenes and BSDFs at the same time"),
            ));
        }
        if scenes.is_empty() && bsdfs.is_empty() {
            return Err(p.object_error(format!("{owner} holds no <scene> or <bsdf> to test")));
        }
        if !scenes.is_empty() {
            if !angles_text.trim().is_empty() {
                p.warn(
                    "angles",
                    "'angles' is ignored: it applies to BSDF tests only",
                );
            }
            if references.len() != scenes.len() {
                return Err(p.error(
                    "references",
                    format!(
                        "{owner} holds {} <scene>{} but 'references' has {} value{}; \
                         it needs one per scene",
                        scenes.len(),
                        plural(scenes.len()),
                        references.len(),
                        plural(references.len())
                    ),
                ));
            }
            NoriTest::SceneTTest {
                scenes,
                references,
                sample_count,
            }
        } else {
            let angles: Vec<f32> = numbers(root, file, &p, "angles", &angles_text)?
                .into_iter()
                .map(|a| a as f32)
                .collect();
            if angles.is_empty() {
                return Err(if p.has("angles") {
                    p.error("angles", "'angles' lists no angle")
                } else {
                    p.object_error(format!(
                        "{owner} with <bsdf>s needs the property 'angles' (a <string> of \
                         incidence angles in degrees)"
                    ))
                });
            }
            let want = bsdfs.len() * angles.len();
            if references.len() != want {
                return Err(p.error(
                    "references",
                    format!(
                        "{owner} holds {} <bsdf>{} and 'angles' lists {} angle{}, so \
                         'references' needs {want} values (one per BSDF and angle, BSDF by \
                         BSDF), but it has {}",
                        bsdfs.len(),
                        plural(bsdfs.len()),
                        angles.len(),
                        plural(angles.len()),
                        references.len()
                    ),
                ));
            }
            NoriTest::BsdfTTest {
                bsdfs,
                angles,
                references,
                sample_count,
            }
        }
    } else {
        let resolution = p.get_int("resolution", 10)?;
        if !(1..=100).contains(&resolution) {
            return Err(p.error(
                "resolution",
                format!("'resolution' must be between 1 and 100, found {resolution}"),
            ));
        }
        let cells = 2 * resolution * resolution;
        let min_exp = p.get_int("minExpFrequency", 5)?;
        if min_exp < 1 {
            return Err(p.error(
                "minExpFrequency",
                format!("'minExpFrequency' must be at least 1, found {min_exp}"),
            ));
        }
        // Nori: -1 (the default) means about 5000 samples per cell.
        let sample_count = match p.get_int("sampleCount", -1)? {
            -1 => (cells * 5000).min(MAX_SAMPLES) as u32,
            _ => count(&mut p, "sampleCount", 0, 1)?,
        };
        let test_count = p.get_int("testCount", 5)?;
        if !(1..=100_000).contains(&test_count) {
            return Err(p.error(
                "testCount",
                format!("'testCount' must be between 1 and 100000, found {test_count}"),
            ));
        }
        if bsdfs.is_empty() {
            return Err(p.object_error(format!("{owner} holds no <bsdf> to test")));
        }
        for b in &bsdfs {
            if b.bsdf.is_specular() {
                return Err(SceneError::new(
                    file,
                    b.pos,
                    format!(
                        "{} cannot be chi-square tested: its directions are Dirac deltas \
                         that no density describes",
                        b.name
                    ),
                ));
            }
        }
        NoriTest::Chi2Test {
            bsdfs,
            resolution: resolution as u32,
            min_exp_frequency: min_exp as f64,
            sample_count,
            test_count: test_count as u32,
        }
    };
    p.finish(&mut warnings);
    Ok((
        TestFile {
            path: file.to_path_buf(),
            test,
            significance,
        },
        warnings,
    ))
}

fn plural(n: usize) -> &'static str {
    if n == 1 {
        ""
    } else {
        "s"
    }
}

/// An integer property within [min, 2^31 - 1].
fn count(p: &mut Props, name: &str, default: i64, min: i64) -> Result<u32> {
    let v = p.get_int(name, default)?;
    if !(min..=MAX_SAMPLES).contains(&v) {
        return Err(p.error(
            name,
            format!("'{name}' must be between {min} and {MAX_SAMPLES}, found {v}"),
        ));
    }
    Ok(v as u32)
}

/// The numbers of a list-valued string property (commas and/or
/// whitespace between them), each finite; a bad token is reported where
/// it stands in the file.
fn numbers(root: &SceneNode, file: &Path, p: &Props, name: &str, value: &str) -> Result<Vec<f64>> {
    // The element that set the property (the last one wins, as in Props).
    let attr = root
        .children
        .iter()
        .rev()
        .find(|c| c.tag == "string" && c.attr_value("name") == Some(name))
        .and_then(|c| c.attr("value"));
    let located = attr.filter(|a| a.value == value);
    let pos = |off: usize| located.map_or(p.value_pos(name), |a| a.pos_in_value(off));
    let mut out = Vec::new();
    for (off, tok) in props::tokens(value) {
        let v: f64 = tok.parse().map_err(|_| {
            SceneError::new(
                file,
                pos(off),
                format!("cannot read '{tok}' in '{name}' as a number"),
            )
        })?;
        if !v.is_finite() {
            return Err(SceneError::new(
                file,
                pos(off),
                format!("'{name}' must hold finite numbers, found '{tok}'"),
            ));
        }
        out.push(v);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn load(text: &str) -> Result<(TestFile, Vec<Warning>)> {
        load_test_str(text, Path::new("t.xml"))
    }

    const BSDF_TTEST: &str = r#"<test type="ttest">
    <string name="angles" value="0, 30
        60"/>
    <string name="references" value="0.5 0.5,0.5,
        0.8, 0.8 0.8"/>
    <integer name="sampleCount" value="1000"/>
    <bsdf type="diffuse"/>
    <bsdf type="diffuse"><color name="albedo" value="0.8"/></bsdf>
</test>"#;

    #[test]
    fn bsdf_ttest_with_multiline_lists() {
        let (t, w) = load(BSDF_TTEST).unwrap();
        assert!(w.is_empty(), "{w:?}");
        assert_eq!(t.significance, 0.01);
        match t.test {
            NoriTest::BsdfTTest {
                bsdfs,
                angles,
                references,
                sample_count,
            } => {
                assert_eq!(bsdfs.len(), 2);
                assert_eq!(angles, [0.0, 30.0, 60.0]);
                assert_eq!(references, [0.5, 0.5, 0.5, 0.8, 0.8, 0.8]);
                assert_eq!(sample_count, 1000);
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn chi2test_defaults_are_noris() {
        let (t, _) = load(r#"<test type="chi2test"><bsdf type="diffuse"/></test>"#).unwrap();
        assert_eq!(t.test.test_count(), 5);
        match t.test {
            NoriTest::Chi2Test {
                resolution,
                min_exp_frequency,
                sample_count,
                test_count,
                ..
            } => {
                assert_eq!(resolution, 10);
                assert_eq!(min_exp_frequency, 5.0);
                assert_eq!(sample_count, 10 * 20 * 5000);
                assert_eq!(test_count, 5);
            }
            other => panic!("{other:?}"),
        }
    }

    fn err(text: &str) -> SceneError {
        load(text).unwrap_err()
    }

    #[test]
    fn bad_reference_token_is_located() {
        let e = err(r#"<test type="ttest">
    <string name="angles" value="0"/>
    <string name="references" value="0.5,
        x0.5"/>
    <bsdf type="diffuse"/>
</test>"#);
        assert_eq!((e.line, e.col), (4, 9), "{e}");
        assert!(e.message.contains("x0.5"), "{e}");
    }

    #[test]
    fn reference_count_must_match() {
        let e = err(r#"<test type="ttest">
    <string name="references" value="1 2"/>
    <scene>
        <camera type="perspective"/>
        <integrator type="normals"/>
    </scene>
</test>"#);
        assert_eq!((e.line, e.col), (2, 38), "{e}");
        assert!(
            e.message.contains("1 <scene> but 'references' has 2"),
            "{e}"
        );
    }

    #[test]
    fn structural_errors() {
        let e = err(r#"<scene><camera type="perspective"/></scene>"#);
        assert!(e.message.contains("lente render"), "{e}");
        let e = err(r#"<test type="ztest"/>"#);
        assert!(e.message.contains("unknown <test> type 'ztest'"), "{e}");
        let e = err("<test type=\"chi2test\">\n  <mesh type=\"obj\"/>\n</test>");
        assert_eq!((e.line, e.col), (2, 3), "{e}");
        let e = err("<test type=\"chi2test\">\n  <bsdf type=\"dielectric\"/>\n</test>");
        assert!(e.message.contains("Dirac"), "{e}");
        let e = err(
            r#"<test type="ttest"><float name="significanceLevel" value="1.5"/><bsdf type="diffuse"/></test>"#,
        );
        assert!(e.message.contains("significanceLevel"), "{e}");
        let e = err(
            r#"<test type="ttest"><string name="references" value="1"/><bsdf type="diffuse"/></test>"#,
        );
        assert!(e.message.contains("'angles'"), "{e}");
        let e = err(
            r#"<test type="ttest"><string name="references" value="inf"/><string name="angles" value="0"/><bsdf type="diffuse"/></test>"#,
        );
        assert!(e.message.contains("finite"), "{e}");
    }

    #[test]
    fn unused_properties_warn() {
        let (_, w) = load(
            r#"<test type="chi2test"><integer name="testCont" value="3"/><bsdf type="diffuse"/></test>"#,
        )
        .unwrap();
        assert_eq!(w.len(), 1);
        assert!(
            w[0].message.contains("did you mean 'testCount'"),
            "{}",
            w[0]
        );
    }
}
