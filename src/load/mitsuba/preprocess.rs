//! Pass 1 of reading a Mitsuba scene: the version, `$name` parameters
//! (from `-D` and `<default>`) and `<include>`d files, which leave one list
//! of top-level elements with their files.

use std::path::{Path, PathBuf};

use super::{parent_dir, MAX_INCLUDES, MAX_INCLUDE_DEPTH};
use crate::load::props::shorten;
use crate::load::reader::{check_attributes, no_content};
use crate::load::xml::{Pos, SceneNode};
use crate::load::{SceneError, Warning};

type Result<T> = std::result::Result<T, SceneError>;

pub(super) struct Param {
    pub(super) name: String,
    pub(super) value: String,
    pub(super) used: bool,
    pub(super) from_command_line: bool,
}

/// A top-level element and the file it comes from.
pub(super) struct Item {
    pub(super) file: usize,
    pub(super) node: SceneNode,
}

pub(super) struct Pre {
    pub(super) files: Vec<PathBuf>,
    pub(super) params: Vec<Param>,
    pub(super) warnings: Vec<Warning>,
    pub(super) items: Vec<Item>,
    pub(super) include_stack: Vec<PathBuf>,
    /// Files written for Mitsuba 0.x (version < 2), whose elements are
    /// upgraded as Mitsuba 3 upgrades them.
    pub(super) legacy: Vec<usize>,
}

impl Pre {
    pub(super) fn err(&self, file: usize, pos: Pos, message: impl Into<String>) -> SceneError {
        SceneError::new(&self.files[file], pos, message)
    }

    /// The root element: `<scene version="...">`.
    pub(super) fn check_root(&mut self, root: &SceneNode, file: usize) -> Result<()> {
        for a in &root.attributes {
            if !matches!(a.name.as_str(), "version" | "id" | "name" | "type") {
                return Err(self.err(
                    file,
                    a.pos,
                    format!(
                        "unexpected attribute '{}' on <scene> (it takes 'version')",
                        a.name
                    ),
                ));
            }
        }
        let Some(v) = root.attr("version") else {
            return Err(self.err(
                file,
                root.pos,
                "a Mitsuba scene needs a version attribute, e.g. <scene version=\"3.0.0\">",
            ));
        };
        let major = match version_major(&v.value) {
            Some(major) => major,
            None => {
                return Err(self.err(
                    file,
                    v.value_pos,
                    format!(
                        "cannot read '{}' as a version number (expected e.g. 3.0.0)",
                        v.value.trim()
                    ),
                ))
            }
        };
        match major {
            0 | 1 => {
                self.legacy.push(file);
                self.warnings.push(Warning::new(
                    &self.files[file],
                    v.value_pos,
                    format!(
                        "this is a Mitsuba {} scene: upgraded as Mitsuba 3 upgrades it \
                         (camelCase property names such as toWorld, sampleCount, intIOR \
                         become to_world, sample_count, int_ior; a diffuse BSDF's \
                         diffuseReflectance becomes reflectance)",
                        v.value.trim()
                    ),
                ));
                Ok(())
            }
            2 | 3 => Ok(()),
            _ => {
                self.warnings.push(Warning::new(
                    &self.files[file],
                    v.value_pos,
                    format!(
                        "version {} is newer than the Mitsuba 3 format lente knows; reading it as 3.x",
                        v.value.trim()
                    ),
                ));
                Ok(())
            }
        }
    }

    /// Children of a `<scene>` root: each becomes an item, after
    /// substitution; `<default>`s define parameters, `<include>`s splice.
    pub(super) fn top_level(&mut self, children: &[SceneNode], file: usize) -> Result<()> {
        for ch in children {
            let mut node = ch.clone();
            if self.legacy.contains(&file) {
                upgrade_from_v1(&mut node, None);
            }
            self.substitute_attributes(&mut node, file)?;
            match node.tag.as_str() {
                "default" => self.define(&node, file)?,
                "include" => self.include(&node, file)?,
                _ => {
                    self.substitute_children(&mut node, file)?;
                    self.items.push(Item { file, node });
                }
            }
        }
        Ok(())
    }

    fn substitute_children(&mut self, node: &mut SceneNode, file: usize) -> Result<()> {
        let children = std::mem::take(&mut node.children);
        let mut kept = Vec::with_capacity(children.len());
        for mut ch in children {
            self.substitute_attributes(&mut ch, file)?;
            match ch.tag.as_str() {
                "default" => self.define(&ch, file)?,
                "include" => {
                    return Err(self.err(
                        file,
                        ch.pos,
                        "lente supports <include> only directly inside <scene>",
                    ))
                }
                _ => {
                    self.substitute_children(&mut ch, file)?;
                    kept.push(ch);
                }
            }
        }
        node.children = kept;
        Ok(())
    }

    /// Replaces `$name` by the parameter's value in every attribute of
    /// `node` (the longest defined name wins; `\$` is a literal `$`).
    fn substitute_attributes(&mut self, node: &mut SceneNode, file: usize) -> Result<()> {
        for attr in &mut node.attributes {
            if !attr.value.contains('$') {
                continue;
            }
            let v = attr.value.clone();
            let mut out = String::with_capacity(v.len());
            let mut i = 0;
            while i < v.len() {
                let rest = &v[i..];
                if rest.starts_with("\\$") {
                    out.push('$');
                    i += 2;
                    continue;
                }
                if !rest.starts_with('$') {
                    let c = rest.chars().next().unwrap_or(' ');
                    out.push(c);
                    i += c.len_utf8();
                    continue;
                }
                let name_part = &rest[1..];
                let best = self
                    .params
                    .iter_mut()
                    .filter(|p| !p.name.is_empty() && name_part.starts_with(p.name.as_str()))
                    .max_by_key(|p| p.name.len());
                match best {
                    Some(p) => {
                        out.push_str(&p.value);
                        p.used = true;
                        i += 1 + p.name.len();
                    }
                    None => {
                        let name: String = name_part
                            .chars()
                            .take_while(|c| c.is_alphanumeric() || *c == '_')
                            .collect();
                        return Err(SceneError::new(
                            &self.files[file],
                            attr.pos_in_value(i),
                            format!(
                                "undefined parameter ${name}: define it with \
                                 <default name=\"{name}\" value=\"...\"/> before its first use, \
                                 or on the command line with -D {name}=..."
                            ),
                        ));
                    }
                }
            }
            attr.set_value(out);
        }
        Ok(())
    }

    /// `<default name=".." value=".."/>`: defines the parameter unless it
    /// is defined already (by `-D` or an earlier default).
    fn define(&mut self, node: &SceneNode, file: usize) -> Result<()> {
        check_attributes(
            &self.files[file],
            node,
            &["name", "value"],
            &["name", "value"],
        )?;
        no_content(&self.files[file], node)?;
        let name = node.attr_value("name").unwrap_or_default();
        if name.is_empty() {
            return Err(self.err(file, node.pos, "<default> needs a non-empty name"));
        }
        if !self.params.iter().any(|p| p.name == name) {
            self.params.push(Param {
                name: name.to_string(),
                value: node.attr_value("value").unwrap_or_default().to_string(),
                used: false,
                from_command_line: false,
            });
        }
        Ok(())
    }

    /// Where an included file is, as Mitsuba 3 finds it: next to the file
    /// that includes it, else next to each file that includes that one in
    /// turn, out to the scene file (its file resolver gains each including
    /// file's folder). A name found nowhere stays next to the includer, for
    /// the error message.
    fn resolve_include(&self, file: usize, name: &str) -> PathBuf {
        // The top of the include stack is `file` itself.
        let here = parent_dir(&self.files[file]).join(name);
        if Path::new(name).is_absolute() {
            return here;
        }
        self.include_stack
            .iter()
            .rev()
            .map(|f| parent_dir(f).join(name))
            .find(|p| p.exists())
            .unwrap_or(here)
    }

    /// `<include filename=".."/>`: a `<scene>` file contributes its
    /// children, any other file its root object.
    fn include(&mut self, node: &SceneNode, file: usize) -> Result<()> {
        check_attributes(
            &self.files[file],
            node,
            &["filename", "name"],
            &["filename"],
        )?;
        no_content(&self.files[file], node)?;
        let name = node.attr_value("filename").unwrap_or_default();
        let path = self.resolve_include(file, name);
        // `files` holds the scene file and every include read so far.
        if self.files.len() > MAX_INCLUDES {
            return Err(self.err(
                file,
                node.pos,
                format!("the scene reads more than {MAX_INCLUDES} <include> files in all"),
            ));
        }
        if self.include_stack.len() > MAX_INCLUDE_DEPTH {
            return Err(self.err(
                file,
                node.pos,
                format!("<include> files are nested more than {MAX_INCLUDE_DEPTH} deep"),
            ));
        }
        let canonical = std::fs::canonicalize(&path).unwrap_or_else(|_| path.clone());
        if self
            .include_stack
            .iter()
            .any(|f| std::fs::canonicalize(f).unwrap_or_else(|_| f.clone()) == canonical)
        {
            return Err(self.err(
                file,
                node.pos,
                format!("'{}' includes itself", path.display()),
            ));
        }
        let bytes =
            crate::limits::read_file(&path, crate::limits::MAX_SCENE_FILE_BYTES, "scene files")
                .map_err(|e| {
                    self.err(
                        file,
                        node.pos,
                        format!("cannot read the included file '{}': {e}", path.display()),
                    )
                })?;
        let text = crate::load::decode_utf8(&path, bytes, "scene file")?;
        let root = crate::load::parse_xml(&text, &path)?;
        self.files.push(path.clone());
        let inc = self.files.len() - 1;
        self.include_stack.push(path);
        if root.tag != "scene" {
            // An included object's version decides its upgrade too.
            let major = root.attr("version").and_then(|a| version_major(&a.value));
            if major.is_some_and(|m| m < 2) {
                self.legacy.push(inc);
            }
        }
        if root.tag == "scene" {
            self.check_root(&root, inc)?;
            if let Some(t) = root.text.first() {
                return Err(self.err(
                    inc,
                    t.pos,
                    format!("unexpected text '{}' inside <scene>", shorten(&t.text)),
                ));
            }
            self.top_level(&root.children, inc)?;
        } else {
            let mut node = root;
            if node.attr("version").is_none() {
                return Err(self.err(
                    inc,
                    node.pos,
                    format!(
                        "the root element <{}> of an included file needs a version attribute",
                        node.tag
                    ),
                ));
            }
            node.attributes.retain(|a| a.name != "version");
            if self.legacy.contains(&inc) {
                upgrade_from_v1(&mut node, None);
            }
            self.substitute_attributes(&mut node, inc)?;
            self.substitute_children(&mut node, inc)?;
            self.items.push(Item { file: inc, node });
        }
        self.include_stack.pop();
        Ok(())
    }
}

/// The major number of a `version` attribute ("3.0.0", "0.6", "2"), if it
/// is one to three numbers.
fn version_major(value: &str) -> Option<u32> {
    let nums: Option<Vec<u32>> = value
        .trim()
        .split('.')
        .map(|p| p.trim().parse().ok())
        .collect();
    nums.filter(|n| (1..=3).contains(&n.len())).map(|n| n[0])
}

/// Mitsuba 3's `upgrade_from_v1` on an element of a 0.x file and its
/// children: property and object names from camelCase to snake_case, and a
/// diffuse BSDF's `diffuse_reflectance` to `reflectance`. `owner_type` is
/// the type of the object the element stands in. (`<default>` names are
/// parameters, not properties: kept.)
fn upgrade_from_v1(node: &mut SceneNode, owner_type: Option<&str>) {
    if node.tag != "default" {
        if let Some(a) = node.attributes.iter_mut().find(|a| a.name == "name") {
            let mut new = camel_to_snake(&a.value);
            if owner_type == Some("diffuse") && new == "diffuse_reflectance" {
                new = "reflectance".to_string();
            }
            a.set_value(new);
        }
    }
    let ty = node.attr_value("type").map(str::to_string);
    for ch in &mut node.children {
        upgrade_from_v1(ch, ty.as_deref());
    }
    uv_offsets_to_transform(node);
}

/// Mitsuba 3 turns 0.x's `uoffset`, `voffset`, `uscale`, `vscale` into
/// `to_uv` = scale(uscale, vscale) · translate(uoffset, voffset): here the
/// property elements become a `<transform name="to_uv">` of `<translate>`s
/// and then `<scale>`s, keeping their file positions for errors.
fn uv_offsets_to_transform(node: &mut SceneNode) {
    let is_uv = |c: &SceneNode| {
        c.tag != "transform"
            && matches!(
                c.attr_value("name"),
                Some("uoffset" | "voffset" | "uscale" | "vscale")
            )
    };
    if !node.children.iter().any(is_uv) {
        return;
    }
    let at = node.children.iter().position(is_uv).expect("checked");
    let (uv, rest): (Vec<SceneNode>, Vec<SceneNode>) = std::mem::take(&mut node.children)
        .into_iter()
        .partition(is_uv);
    node.children = rest;
    let mut name = None;
    let mut ops = Vec::with_capacity(uv.len());
    for mut c in uv {
        let which = c.attr_value("name").unwrap_or_default().to_string();
        let (tag, axis) = match which.as_str() {
            "uoffset" => ("translate", "x"),
            "voffset" => ("translate", "y"),
            "uscale" => ("scale", "x"),
            _ => ("scale", "y"),
        };
        let i = c
            .attributes
            .iter()
            .position(|a| a.name == "name")
            .expect("matched");
        let mut n = c.attributes.remove(i);
        n.set_value("to_uv".to_string());
        name.get_or_insert(n);
        for a in &mut c.attributes {
            if a.name == "value" {
                a.name = axis.to_string();
            }
        }
        c.tag = tag.to_string();
        ops.push(c);
    }
    // Translations first: each later operation applies after the ones before.
    ops.sort_by_key(|c| c.tag != "translate");
    let first = ops[0].pos;
    // `at` counts the other children before the first of them, so it is
    // where the transform takes their place.
    node.children.insert(
        at,
        SceneNode {
            tag: "transform".to_string(),
            pos: first,
            attributes: name.into_iter().collect(),
            children: ops,
            text: Vec::new(),
        },
    );
}

/// Mitsuba 3's `camel_to_underscore_case`: an upper-case letter after a
/// lower-case one starts a word (`intIOR` -> `int_ior`, `toWorld` ->
/// `to_world`).
fn camel_to_snake(name: &str) -> String {
    let chars: Vec<char> = name.chars().collect();
    let mut out = String::with_capacity(name.len() + 4);
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        if i > 0 && chars[i - 1].is_ascii_lowercase() && c.is_ascii_uppercase() {
            out.push('_');
            out.push(c.to_ascii_lowercase());
            while i + 1 < chars.len() && chars[i + 1].is_ascii_uppercase() {
                i += 1;
                out.push(chars[i].to_ascii_lowercase());
            }
        } else {
            out.push(c);
        }
        i += 1;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::camel_to_snake;

    #[test]
    fn camel_case_becomes_snake_case_as_in_mitsuba() {
        for (old, new) in [
            ("toWorld", "to_world"),
            ("intIOR", "int_ior"),
            ("sampleCount", "sample_count"),
            ("fovAxis", "fov_axis"),
            ("specularReflectance", "specular_reflectance"),
            ("maxDepth", "max_depth"),
            ("alpha", "alpha"),
            ("to_world", "to_world"),
            ("IOR", "IOR"),
            ("aB", "a_b"),
        ] {
            assert_eq!(camel_to_snake(old), new, "{old}");
        }
    }
}
