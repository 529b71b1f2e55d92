//! Scene files in, scene descriptions out.
//!
//! `xml` parses any scene file into a format-neutral tree with positions;
//! `props` gives typed, checked access to a node's properties; `nori` and
//! `mitsuba` map Nori's and Mitsuba 3's dialects onto the scene objects;
//! `nori_testfile` reads Nori's `<test>` files.

mod error;
pub mod mitsuba;
pub mod nori;
pub mod nori_testfile;
mod nori_texture;
mod objects;
pub mod props;
mod reader;
pub mod xml;

use std::path::Path;

pub use error::{Diagnostic, SceneError, Warning};

use crate::render::RenderJob;
use crate::scene::SceneDesc;

/// What a scene file describes: the world, and what to render of it.
#[derive(Clone, Debug)]
pub struct SceneFile {
    pub scene: SceneDesc,
    pub job: RenderJob,
}

/// Reads a scene file: Nori's XML dialect, or Mitsuba 3's
/// (`<scene version="...">`).
pub fn load_scene(path: &Path) -> Result<(SceneFile, Vec<Warning>), SceneError> {
    load_scene_with(path, &[])
}

/// Reads a scene file with `-D name=value` parameters: they set Mitsuba's
/// `$name` substitutions, overriding the file's `<default>`s.
pub fn load_scene_with(
    path: &Path,
    defines: &[(String, String)],
) -> Result<(SceneFile, Vec<Warning>), SceneError> {
    let text = read_text(path, "scene file")?;
    load_scene_str_with(&text, path, defines)
}

/// The text of an XML file (`what` names it in messages: "scene file");
/// an unreadable file or invalid UTF-8 is an error, the latter at its
/// position.
pub(crate) fn read_text(path: &Path, what: &str) -> Result<String, SceneError> {
    let bytes = crate::limits::read_file(path, crate::limits::MAX_SCENE_FILE_BYTES, "scene files")
        .map_err(|e| {
            let err = SceneError::new(path, xml::Pos::default(), format!("cannot read the {what}"));
            match e {
                crate::limits::ReadError::Io(io) => err.caused_by(io),
                other => err.caused_by(other),
            }
        })?;
    decode_utf8(path, bytes, what)
}

/// The element tree of an XML file's text; a syntax error names `path` and
/// its position.
pub(crate) fn parse_xml(text: &str, path: &Path) -> Result<xml::SceneNode, SceneError> {
    xml::parse(text).map_err(|e| SceneError::new(path, e.pos.unwrap_or_default(), e.message))
}

/// The text of a file's bytes; invalid UTF-8 is an error at its position.
pub(crate) fn decode_utf8(path: &Path, bytes: Vec<u8>, what: &str) -> Result<String, SceneError> {
    match String::from_utf8(bytes) {
        Ok(t) => Ok(t),
        Err(e) => {
            let valid = &e.as_bytes()[..e.utf8_error().valid_up_to()];
            let line = valid.iter().filter(|&&b| b == b'\n').count() as u32 + 1;
            let line_start = valid.iter().rposition(|&b| b == b'\n').map_or(0, |i| i + 1);
            let col = String::from_utf8_lossy(&valid[line_start..])
                .chars()
                .count() as u32
                + 1;
            Err(SceneError::new(
                path,
                xml::Pos::new(line, col),
                format!("the {what} is not valid UTF-8"),
            ))
        }
    }
}

/// True if a `<scene version="...">` is written in Nori's syntax: Nori
/// forks' files carry `version="0.5.0"` (Nori's own template had it), and
/// students copy Mitsuba's `version="3.0.0"` into theirs, but only Nori
/// names its objects `<mesh>` and `<camera>` (Mitsuba writes `<shape>` and
/// `<sensor>`). With a Mitsuba 2 or 3 version it takes Nori's `<camera>`
/// (a `<mesh>` alone is more likely a slip in a Mitsuba file); a file with
/// tags of both is left to the Mitsuba reader, which says which tag to use
/// instead.
fn is_nori_syntax(root: &xml::SceneNode) -> bool {
    let has = |tags: &[&str]| root.children.iter().any(|c| tags.contains(&c.tag.as_str()));
    let old = root
        .attr_value("version")
        .is_some_and(|v| v.trim().starts_with("0."));
    !has(&["shape", "sensor"]) && (has(&["camera"]) || (old && has(&["mesh"])))
}

/// Reads a scene from text; `path` names it in messages and is the base of
/// relative file names inside it.
pub fn load_scene_str(text: &str, path: &Path) -> Result<(SceneFile, Vec<Warning>), SceneError> {
    load_scene_str_with(text, path, &[])
}

/// [`load_scene_str`] with `-D name=value` parameters (see [`load_scene_with`]).
pub fn load_scene_str_with(
    text: &str,
    path: &Path,
    defines: &[(String, String)],
) -> Result<(SceneFile, Vec<Warning>), SceneError> {
    let root = parse_xml(text, path)?;
    match root.tag.as_str() {
        "scene" if root.attr("version").is_some() && !is_nori_syntax(&root) => {
            mitsuba::load(&root, path, defines)
        }
        "scene" => {
            let version = root.attr("version").is_some();
            let mut root = root;
            root.attributes.retain(|a| a.name != "version");
            let (desc, mut warnings) = nori::load(&root, path)?;
            if version {
                warnings.push(Warning::new(
                    path,
                    root.pos,
                    "the version attribute is ignored: this is a Nori scene (it has <mesh> or <camera>, which Mitsuba does not write)",
                ));
            }
            if let Some((name, _)) = defines.first() {
                warnings.push(Warning::new(
                    path,
                    root.pos,
                    format!(
                        "-D {name}=... is ignored: only Mitsuba scenes (<scene version=...>) have $parameters"
                    ),
                ));
            }
            Ok((desc, warnings))
        }
        other => Err(SceneError::new(
            path,
            root.pos,
            format!("expected <scene> as the root element, found <{other}>"),
        )),
    }
}
