//! Mitsuba 3's XML dialect (`<scene version="3.x.y">`; 2.x is read the same).
//!
//! Loading runs in three passes over the format-neutral tree:
//!
//! 1. **Preprocessing**: `$name` parameters are substituted in every
//!    attribute in document order, from `-D name=value` first and then from
//!    `<default name=".." value=".."/>` elements (which only define a name
//!    not defined yet, as in Mitsuba), `\$` stands for a literal `$`;
//!    `<include filename=".."/>` directly inside `<scene>` splices in
//!    another file's objects.
//! 2. **Identifiers**: every object with an `id` (anywhere in the tree) and
//!    every `<alias id=".." as=".."/>` is indexed; `<path value=".."/>`
//!    adds a folder to search for files.
//! 3. **Objects**: each top-level object is built; `<ref id=".."/>` places
//!    the referenced object where the reference stands (references may
//!    point forwards, as in Mitsuba).
//!
//! Names, defaults and conventions are Mitsuba 3's (see each function).
//! BSDFs are read with all their parameters into [`BsdfSpec`];
//! [`BsdfSpec::build`] makes the lente BSDF (Mitsuba's own models), and
//! [`BsdfSpec::approximation`] names what it cannot reproduce, for a
//! warning.

use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};

use super::props::{self, Kind, Props, Value};
use super::props::{int_in, positive, shorten};
use super::xml::{describe, Pos, SceneNode};
use super::{SceneError, Warning};
use crate::bsdf::presets::{conductor_preset_names, ior_preset_names};
use crate::bsdf::{conductor_preset, ior_preset, Bsdf, MicrofacetType};
use crate::camera::{Aperture, CameraParams};
use crate::color::Rgb;
use crate::emitter::{Emitter, EnvFilter, EnvMap};
use crate::geometry::{self, Geometry, Sphere, TriangleMesh};
use crate::image::Filter;
use crate::integrator::{Integrator, PathParams, Strategy};
use crate::math::{Aabb, Frame, Mat3, Mat4, Transform, Vec3, Vec4};
use crate::scene::{SceneDesc, ShapeDesc};

type Result<T> = std::result::Result<T, SceneError>;

/// Element tags that create objects.
const OBJECT_TAGS: &[&str] = &[
    "scene",
    "sensor",
    "film",
    "sampler",
    "rfilter",
    "shape",
    "bsdf",
    "emitter",
    "integrator",
    "texture",
    "medium",
    "phase",
    "volume",
];

/// Element tags that set a property of the enclosing object (`<spectrum>`
/// with a `type` attribute is an object instead).
const PROPERTY_TAGS: &[&str] = &[
    "boolean",
    "integer",
    "float",
    "string",
    "point",
    "vector",
    "rgb",
    "spectrum",
    "transform",
];

/// Operations inside `<transform>`.
const TRANSFORM_OPS: &[&str] = &["translate", "rotate", "scale", "matrix", "lookat"];

/// Elements that may only stand directly inside `<scene>`.
const SCENE_ONLY: &[&str] = &["include", "alias", "path", "default"];

/// Deepest nesting of `<include>` files (Mitsuba's limit is 15).
const MAX_INCLUDE_DEPTH: usize = 15;

/// Most objects one scene may instantiate (references can multiply them).
const MAX_OBJECTS: usize = 1 << 20;

/// Deepest nesting of objects, counting references (real scenes need 4).
const MAX_NESTING: usize = 64;

/// Reads a Mitsuba scene whose root element is `root`, read from `file`.
/// `defines` are `-D name=value` parameters; they take precedence over the
/// file's `<default>`s.
pub fn load(
    root: &SceneNode,
    file: &Path,
    defines: &[(String, String)],
) -> Result<(SceneDesc, Vec<Warning>)> {
    let mut pre = Pre {
        files: vec![file.to_path_buf()],
        params: Vec::new(),
        warnings: Vec::new(),
        items: Vec::new(),
        include_stack: vec![file.to_path_buf()],
    };
    for (name, value) in defines {
        if let Some(p) = pre.params.iter_mut().find(|p| p.name == *name) {
            p.value = value.clone();
        } else {
            pre.params.push(Param {
                name: name.clone(),
                value: value.clone(),
                used: false,
                from_command_line: true,
            });
        }
    }
    pre.check_root(root, 0)?;
    pre.top_level(&root.children, 0)?;
    if let Some(t) = root.text.first() {
        return Err(pre.err(
            0,
            t.pos,
            format!("unexpected text '{}' inside <scene>", shorten(&t.text)),
        ));
    }
    let Pre {
        files,
        params,
        mut warnings,
        items,
        ..
    } = pre;
    for p in params.iter().filter(|p| p.from_command_line && !p.used) {
        warnings.push(Warning::new(
            file,
            root.pos,
            format!(
                "-D {}={} is not used: the scene has no ${}",
                p.name, p.value, p.name
            ),
        ));
    }

    let mut ctx = Ctx::new(&files, &items, warnings)?;
    let desc = ctx.scene(root.pos, &items)?;
    // References repeat the warnings of what they refer to; keep the first.
    let mut seen = HashSet::new();
    let warnings = ctx
        .warnings
        .into_iter()
        .filter(|w| seen.insert((w.file.clone(), w.line, w.col, w.message.clone())))
        .collect();
    Ok((desc, warnings))
}

// ---------------------------------------------------------------------------
// Pass 1: parameters and includes
// ---------------------------------------------------------------------------

struct Param {
    name: String,
    value: String,
    used: bool,
    from_command_line: bool,
}

/// A top-level element and the file it comes from.
struct Item {
    file: usize,
    node: SceneNode,
}

struct Pre {
    files: Vec<PathBuf>,
    params: Vec<Param>,
    warnings: Vec<Warning>,
    items: Vec<Item>,
    include_stack: Vec<PathBuf>,
}

impl Pre {
    fn err(&self, file: usize, pos: Pos, message: impl Into<String>) -> SceneError {
        SceneError::new(&self.files[file], pos, message)
    }

    /// The root element: `<scene version="...">`.
    fn check_root(&mut self, root: &SceneNode, file: usize) -> Result<()> {
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
        let parts: Vec<&str> = v.value.trim().split('.').collect();
        let nums: Option<Vec<u32>> = parts.iter().map(|p| p.trim().parse().ok()).collect();
        let major = match nums {
            Some(n) if (1..=3).contains(&n.len()) => n[0],
            _ => {
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
            0 | 1 => Err(self.err(
                file,
                v.value_pos,
                format!(
                    "this is a Mitsuba {} scene; lente reads Mitsuba 2 and 3 scenes. \
                     Mitsuba 3 renames the properties of older files in memory \
                     (camelCase such as toWorld, sampleCount, intIOR becomes snake_case: \
                     to_world, sample_count, int_ior); do the same in the file and set \
                     version=\"3.0.0\"",
                    v.value.trim()
                ),
            )),
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
    fn top_level(&mut self, children: &[SceneNode], file: usize) -> Result<()> {
        for ch in children {
            let mut node = ch.clone();
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
        let dir = parent_dir(&self.files[file]);
        let path = dir.join(name);
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
        let bytes = std::fs::read(&path).map_err(|e| {
            self.err(
                file,
                node.pos,
                format!("cannot read the included file '{}': {e}", path.display()),
            )
        })?;
        let text = super::decode_utf8(&path, bytes, "scene file")?;
        let root = super::parse_xml(&text, &path)?;
        self.files.push(path.clone());
        let inc = self.files.len() - 1;
        self.include_stack.push(path);
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
            self.substitute_attributes(&mut node, inc)?;
            self.substitute_children(&mut node, inc)?;
            self.items.push(Item { file: inc, node });
        }
        self.include_stack.pop();
        Ok(())
    }
}

// ---------------------------------------------------------------------------
// Passes 2 and 3: identifiers and objects
// ---------------------------------------------------------------------------

/// An object element and the file it was written in.
#[derive(Clone, Copy)]
struct Target<'d> {
    file: usize,
    node: &'d SceneNode,
}

/// A nested object of an object, in document order.
#[derive(Clone, Copy)]
struct Child<'d> {
    /// The property name it is passed as (`name` attribute), if any.
    name: Option<&'d str>,
    node: &'d SceneNode,
    file: usize,
    /// Where it is placed: the element itself, or the `<ref>` to it.
    at: Pos,
}

struct Ctx<'d> {
    files: &'d [PathBuf],
    /// The file of the element being read.
    cur: usize,
    ids: HashMap<&'d str, Target<'d>>,
    /// Extra folders to search for files (`<path>`), latest first.
    search: Vec<PathBuf>,
    warnings: Vec<Warning>,
    /// Ids of the objects being built (to catch reference cycles).
    building: Vec<&'d str>,
    /// Ids that some reference used.
    referenced: HashSet<&'d str>,
    objects: usize,
    /// Objects being built, nested (each inside the one before).
    depth: usize,
    /// BSDFs with tables built so far (see [`Ctx::build_bsdf`]).
    built: Vec<(BsdfSpec, Bsdf)>,
}

/// An emitter read from the file, before it is placed.
enum EmitterDesc {
    Area(Rgb),
    Free { emitter: Emitter, environment: bool },
}

/// A sensor with its film and sampler.
struct SensorDesc {
    camera: CameraParams,
    filter: Filter,
    spp: u32,
}

impl<'d> Ctx<'d> {
    fn new(files: &'d [PathBuf], items: &'d [Item], warnings: Vec<Warning>) -> Result<Ctx<'d>> {
        let mut ctx = Ctx {
            files,
            cur: 0,
            ids: HashMap::new(),
            search: Vec::new(),
            warnings,
            building: Vec::new(),
            referenced: HashSet::new(),
            objects: 0,
            depth: 0,
            built: Vec::new(),
        };
        for item in items {
            ctx.cur = item.file;
            ctx.index_ids(&item.node)?;
        }
        for item in items {
            ctx.cur = item.file;
            let node = &item.node;
            match node.tag.as_str() {
                "alias" => {
                    ctx.check_attributes(node, &["id", "as"], &["id", "as"])?;
                    ctx.no_content(node)?;
                    let id = node.attr_value("id").unwrap_or_default();
                    let alias = node.attr_value("as").unwrap_or_default();
                    let Some(target) = ctx.ids.get(id).copied() else {
                        return Err(
                            ctx.unknown_id(node.attr("id").map_or(node.pos, |a| a.value_pos), id)
                        );
                    };
                    if let Some(prev) = ctx.ids.get(alias) {
                        let at = prev.node.pos;
                        return Err(ctx.err(
                            node.pos,
                            format!("the id '{alias}' is taken already (by the element at {at})"),
                        ));
                    }
                    ctx.ids.insert(alias, target);
                }
                "path" => {
                    ctx.check_attributes(node, &["value"], &["value"])?;
                    ctx.no_content(node)?;
                    let value = node.attr_value("value").unwrap_or_default();
                    let dir = parent_dir(&files[item.file]).join(value);
                    if !dir.is_dir() {
                        return Err(ctx.err(
                            node.pos,
                            format!("<path>: the folder '{}' does not exist", dir.display()),
                        ));
                    }
                    ctx.search.insert(0, dir);
                }
                _ => {}
            }
        }
        Ok(ctx)
    }

    fn file(&self) -> &'d Path {
        &self.files[self.cur]
    }

    fn err(&self, pos: Pos, message: impl Into<String>) -> SceneError {
        SceneError::new(self.file(), pos, message)
    }

    fn warn(&mut self, pos: Pos, message: impl Into<String>) {
        let w = Warning::new(self.file(), pos, message);
        self.warnings.push(w);
    }

    fn check_attributes(
        &self,
        node: &SceneNode,
        allowed: &[&str],
        required: &[&str],
    ) -> Result<()> {
        check_attributes(self.file(), node, allowed, required)
    }

    fn no_content(&self, node: &SceneNode) -> Result<()> {
        no_content(self.file(), node)
    }

    /// Indexes the ids of `node` and everything inside it.
    fn index_ids(&mut self, node: &'d SceneNode) -> Result<()> {
        let is_object = OBJECT_TAGS.contains(&node.tag.as_str())
            || (node.tag == "spectrum" && node.attr("type").is_some());
        if is_object {
            if let Some(a) = node.attr("id") {
                let target = Target {
                    file: self.cur,
                    node,
                };
                if let Some(prev) = self.ids.insert(&a.value, target) {
                    let where_ = if prev.file == self.cur {
                        prev.node.pos.to_string()
                    } else {
                        format!("{}:{}", self.files[prev.file].display(), prev.node.pos)
                    };
                    return Err(self.err(
                        a.value_pos,
                        format!("the id '{}' is used twice (first at {where_})", a.value),
                    ));
                }
            }
        }
        for ch in &node.children {
            self.index_ids(ch)?;
        }
        Ok(())
    }

    fn unknown_id(&self, pos: Pos, id: &str) -> SceneError {
        let known: Vec<String> = self.ids.keys().map(|k| k.to_string()).collect();
        let hint = known
            .iter()
            .map(|k| (props::edit_distance(id, k), k))
            .filter(|(d, _)| *d <= 2)
            .min_by_key(|(d, _)| *d)
            .map(|(_, k)| format!(" (did you mean '{k}'?)"))
            .unwrap_or_default();
        self.err(pos, format!("no object has the id '{id}'{hint}"))
    }

    /// Finds a file named in the scene: absolute names as they are,
    /// relative ones in the `<path>` folders, then next to the file that
    /// names them, then next to the main scene file.
    fn resolve(&self, name: &str) -> PathBuf {
        let p = Path::new(name);
        if p.is_absolute() {
            return p.to_path_buf();
        }
        let here = parent_dir(self.file());
        let main = parent_dir(&self.files[0]);
        let found = self
            .search
            .iter()
            .chain([&here, &main])
            .map(|d| d.join(p))
            .find(|c| c.exists());
        found.unwrap_or_else(|| here.join(p))
    }

    /// Runs `f` on a child object: in the child's file, guarding against
    /// reference cycles and runaway instantiation.
    fn enter<T>(&mut self, child: &Child<'d>, f: impl FnOnce(&mut Self) -> Result<T>) -> Result<T> {
        self.objects += 1;
        if self.objects > MAX_OBJECTS {
            return Err(self.err(
                child.at,
                format!("the scene builds more than {MAX_OBJECTS} objects (are references nested in a loop?)"),
            ));
        }
        if self.depth >= MAX_NESTING {
            return Err(self.err(
                child.at,
                format!("objects (and references) are nested more than {MAX_NESTING} deep"),
            ));
        }
        let id = child.node.attr_value("id");
        if let Some(id) = id {
            if self.building.contains(&id) {
                return Err(self.err(
                    child.at,
                    format!("the object '{id}' contains a reference to itself"),
                ));
            }
            self.building.push(id);
        }
        let saved = self.cur;
        self.cur = child.file;
        self.depth += 1;
        let r = f(self);
        self.depth -= 1;
        self.cur = saved;
        if id.is_some() {
            self.building.pop();
        }
        r
    }

    /// Checks an object element's attributes and returns its type.
    fn object_type(
        &self,
        node: &'d SceneNode,
        known: &[&str],
        unsupported: &[&str],
    ) -> Result<&'d str> {
        for a in &node.attributes {
            if !matches!(a.name.as_str(), "type" | "id" | "name") {
                return Err(self.err(
                    a.pos,
                    format!(
                        "unexpected attribute '{}' on <{}> (it takes 'type', 'id' and 'name')",
                        a.name, node.tag
                    ),
                ));
            }
        }
        let Some(t) = node.attr("type") else {
            return Err(self.err(
                node.pos,
                format!(
                    "<{}> needs a 'type' attribute (one of: {})",
                    node.tag,
                    known.join(", ")
                ),
            ));
        };
        if !known.contains(&t.value.as_str()) {
            let what = if unsupported.contains(&t.value.as_str()) {
                format!(
                    "Mitsuba's <{} type=\"{}\"> is not supported by lente",
                    node.tag, t.value
                )
            } else {
                format!("unknown <{}> type '{}'", node.tag, t.value)
            };
            return Err(self.err(
                t.value_pos,
                format!("{what}; lente reads: {}", known.join(", ")),
            ));
        }
        Ok(&t.value)
    }

    /// Reads an object's properties; returns them and its nested objects
    /// (references resolved). Named textures become property values.
    fn read_object(
        &mut self,
        node: &'d SceneNode,
        owner: &str,
    ) -> Result<(Props<'d>, Vec<Child<'d>>)> {
        if let Some(t) = node.text.first() {
            return Err(self.err(
                t.pos,
                format!("unexpected text '{}' inside {owner}", shorten(&t.text)),
            ));
        }
        let mut props = Props::new(self.file(), owner, node.pos);
        props.set_color_tag("rgb");
        let mut children = Vec::new();
        for ch in &node.children {
            let tag = ch.tag.as_str();
            if tag == "spectrum" && ch.attr("type").is_some() || OBJECT_TAGS.contains(&tag) {
                children.push(Child {
                    name: ch.attr_value("name"),
                    node: ch,
                    file: self.cur,
                    at: ch.pos,
                });
            } else if PROPERTY_TAGS.contains(&tag) {
                self.read_property(ch, &mut props)?;
            } else if tag == "ref" {
                self.check_attributes(ch, &["id", "name"], &["id"])?;
                self.no_content(ch)?;
                let id_attr = ch.attr("id").expect("checked");
                let Some(target) = self.ids.get(id_attr.value.as_str()).copied() else {
                    return Err(self.unknown_id(id_attr.value_pos, &id_attr.value));
                };
                self.referenced.insert(&id_attr.value);
                children.push(Child {
                    name: ch.attr_value("name"),
                    node: target.node,
                    file: target.file,
                    at: ch.pos,
                });
            } else if TRANSFORM_OPS.contains(&tag) {
                return Err(self.err(
                    ch.pos,
                    format!("<{tag}> may only stand inside a <transform>"),
                ));
            } else if SCENE_ONLY.contains(&tag) {
                return Err(self.err(
                    ch.pos,
                    format!("<{tag}> may only stand directly inside <scene>"),
                ));
            } else {
                return Err(self.unknown_element(ch));
            }
        }
        let mut rest = Vec::with_capacity(children.len());
        for c in children {
            if is_texture(c.node) {
                let Some(name) = c.name else {
                    return Err(self.err(
                        c.at,
                        format!(
                            "a <{}> inside {owner} needs a 'name' attribute (the property it sets)",
                            c.node.tag
                        ),
                    ));
                };
                let value = self.enter(&c, |ctx| ctx.texture(c.node))?;
                props.insert(name, value, c.at, c.at);
            } else {
                rest.push(c);
            }
        }
        Ok((props, rest))
    }

    fn unknown_element(&self, node: &SceneNode) -> SceneError {
        let nori = match node.tag.as_str() {
            "color" => Some("rgb"),
            "mesh" => Some("shape"),
            "camera" => Some("sensor"),
            _ => None,
        };
        if let Some(m) = nori {
            return self.err(
                node.pos,
                format!(
                    "unknown element <{}> (that is Nori's; Mitsuba writes <{m}>)",
                    node.tag
                ),
            );
        }
        let all: Vec<&str> = OBJECT_TAGS
            .iter()
            .chain(PROPERTY_TAGS)
            .chain(TRANSFORM_OPS)
            .chain(SCENE_ONLY)
            .chain(&["ref"])
            .copied()
            .collect();
        let hint = all
            .iter()
            .map(|k| (props::edit_distance(&node.tag, k), k))
            .filter(|(d, _)| *d <= 2)
            .min_by_key(|(d, _)| *d)
            .map(|(_, k)| format!(" (did you mean <{k}>?)"))
            .unwrap_or_default();
        self.err(node.pos, format!("unknown element <{}>{hint}", node.tag))
    }

    /// The error for a nested object that may not stand inside `parent`.
    fn misplaced(&self, child: &Child, parent: &str) -> SceneError {
        let node = child.node;
        let hint = match node.tag.as_str() {
            "film" | "sampler" => "; it belongs inside a <sensor>",
            "rfilter" => "; it belongs inside a <film>",
            "scene" => "; <scene> can only be the root element",
            "medium" | "phase" | "volume" => "; participating media are not supported",
            "sensor" | "integrator" => "; it belongs directly inside <scene>",
            "emitter" => {
                "; an area emitter belongs inside a <shape>, others directly inside <scene>"
            }
            "bsdf" => "; a <bsdf> belongs inside a <shape> (or a twosided <bsdf>)",
            _ => "",
        };
        self.err(
            child.at,
            format!("{} cannot stand inside {parent}{hint}", describe(node)),
        )
    }

    fn no_children(&self, children: &[Child], owner: &str) -> Result<()> {
        match children.first() {
            Some(c) => Err(self.misplaced(c, owner)),
            None => Ok(()),
        }
    }

    // ----- properties -----

    fn read_property(&mut self, node: &SceneNode, props: &mut Props) -> Result<()> {
        let tag = node.tag.as_str();
        let file = self.file();
        if tag != "transform" {
            self.no_content(node)?;
        } else if let Some(t) = node.text.first() {
            return Err(self.err(
                t.pos,
                format!("unexpected text '{}' inside <transform>", shorten(&t.text)),
            ));
        }
        let (value, value_pos) = match tag {
            "boolean" | "integer" | "float" | "string" | "rgb" => {
                self.check_attributes(node, &["name", "value"], &["name", "value"])?;
                let v = node.attr("value").expect("checked");
                let value = match tag {
                    "boolean" => Value::Bool(props::parse_bool(file, v)?),
                    "integer" => Value::Int(props::parse_int(file, v)?),
                    "float" => Value::Float(props::parse_float(file, v)?),
                    "string" => Value::String(v.value.clone()),
                    _ => Value::Color(props::parse_vec3(file, v, true)?),
                };
                (value, v.value_pos)
            }
            "spectrum" => {
                self.check_attributes(node, &["name", "value", "filename"], &["name"])?;
                match (node.attr("value"), node.attr("filename")) {
                    (Some(v), None) => {
                        for (off, tok) in props::tokens(&v.value) {
                            if tok.contains(':') {
                                return Err(self.err(
                                    v.pos_in_value(off),
                                    format!(
                                        "spectral data not supported ('{tok}' is a wavelength:value \
                                         pair); lente renders in RGB: give <rgb name=\"...\" value=\"r, g, b\"/>"
                                    ),
                                ));
                            }
                        }
                        (Value::Color(props::parse_vec3(file, v, true)?), v.value_pos)
                    }
                    (None, Some(f)) => {
                        return Err(self.err(
                            f.value_pos,
                            "spectral data not supported (spectrum files); lente renders in RGB: \
                             give <rgb name=\"...\" value=\"r, g, b\"/>",
                        ))
                    }
                    _ => return Err(self.err(
                        node.pos,
                        "<spectrum> needs either a 'value' or a 'filename' attribute (not both)",
                    )),
                }
            }
            "point" | "vector" => {
                self.check_attributes(node, &["name", "value", "x", "y", "z"], &["name"])?;
                (Value::Point(self.xyz(node, 0.0, true)?), node.pos)
            }
            "transform" => {
                self.check_attributes(node, &["name"], &["name"])?;
                (Value::Transform(self.read_transform(node)?), node.pos)
            }
            _ => unreachable!("only property tags come here"),
        };
        let value = match (tag, value) {
            ("vector", Value::Point(v)) => Value::Vector(v),
            (_, v) => v,
        };
        let name = node.attr_value("name").unwrap_or_default();
        props.insert(name, value, node.pos, value_pos);
        Ok(())
    }

    /// A vector given as `value` (one number for all three, or three) or
    /// as `x`, `y`, `z` attributes (missing ones take `default`).
    fn xyz(&self, node: &SceneNode, default: f32, allow_one: bool) -> Result<Vec3> {
        let file = self.file();
        if let Some(v) = node.attr("value") {
            if let Some(a) = ["x", "y", "z"].iter().find_map(|n| node.attr(n)) {
                return Err(self.err(
                    a.pos,
                    format!(
                        "<{}> takes either 'value' or 'x', 'y', 'z', not both",
                        node.tag
                    ),
                ));
            }
            return props::parse_vec3(file, v, allow_one);
        }
        let mut out = Vec3::splat(default);
        for (i, n) in ["x", "y", "z"].iter().enumerate() {
            if let Some(a) = node.attr(n) {
                out[i] = props::parse_float(file, a)?;
            }
        }
        Ok(out)
    }

    fn finite_xyz(&self, node: &SceneNode, default: f32) -> Result<Vec3> {
        let v = self.xyz(node, default, true)?;
        if !v.is_finite() {
            return Err(self.err(
                node.pos,
                format!(
                    "<{}> needs finite numbers, found {} {} {}",
                    node.tag, v.x, v.y, v.z
                ),
            ));
        }
        Ok(v)
    }

    /// Three finite numbers in the attribute `name`.
    fn vec3_attr(&self, node: &SceneNode, name: &str) -> Result<Vec3> {
        let a = node.attr(name).expect("checked");
        let v = props::parse_vec3(self.file(), a, false)?;
        if !v.is_finite() {
            return Err(self.err(
                a.value_pos,
                format!("expected finite numbers, found '{}'", a.value.trim()),
            ));
        }
        Ok(v)
    }

    /// `<transform>`: its operations in document order, each applied after
    /// the ones before it, i.e. left-multiplied (Mitsuba's
    /// `parse_transform_node`: `transform = op * transform`).
    fn read_transform(&self, node: &SceneNode) -> Result<Transform> {
        let file = self.file();
        let mut m = Mat4::IDENTITY;
        for op in &node.children {
            let tag = op.tag.as_str();
            if !TRANSFORM_OPS.contains(&tag) {
                return Err(self.err(
                    op.pos,
                    format!(
                        "<transform> may only contain <translate>, <rotate>, <scale>, <matrix> \
                         and <lookat>, not <{tag}>"
                    ),
                ));
            }
            self.no_content(op)?;
            let om = match tag {
                "translate" => {
                    self.check_attributes(op, &["value", "x", "y", "z"], &[])?;
                    Mat4::from_translation(self.finite_xyz(op, 0.0)?)
                }
                "scale" => {
                    self.check_attributes(op, &["value", "x", "y", "z"], &[])?;
                    let s = self.finite_xyz(op, 1.0)?;
                    if s.x * s.y * s.z == 0.0 {
                        return Err(self.err(
                            op.pos,
                            "a scale by zero cannot be undone (the transform would be singular)",
                        ));
                    }
                    Mat4::from_scale(s)
                }
                "rotate" => {
                    self.check_attributes(
                        op,
                        &["angle", "value", "x", "y", "z", "axis"],
                        &["angle"],
                    )?;
                    let axis = match op.attr("axis") {
                        Some(_) if ["value", "x", "y", "z"].iter().any(|n| op.attr(n).is_some()) => {
                            return Err(self.err(
                                op.pos,
                                "<rotate> takes its axis either as 'axis', 'value' or 'x', 'y', 'z'",
                            ))
                        }
                        Some(_) => self.vec3_attr(op, "axis")?,
                        None => self.finite_xyz(op, 0.0)?,
                    };
                    let angle_attr = op.attr("angle").expect("checked");
                    let angle = props::parse_float(file, angle_attr)?;
                    if !angle.is_finite() {
                        return Err(self.err(
                            angle_attr.value_pos,
                            format!("the angle must be a finite number, found {angle}"),
                        ));
                    }
                    let len = axis.length();
                    if !(len > 0.0 && len.is_finite()) {
                        return Err(self.err(op.pos, "the rotation axis must not be zero"));
                    }
                    Mat4::from_axis_angle(axis / len, angle.to_radians())
                }
                "matrix" => {
                    self.check_attributes(op, &["value"], &["value"])?;
                    let attr = op.attr("value").expect("checked");
                    let v = props::parse_numbers(file, attr)?;
                    if v.iter().any(|x| !x.is_finite()) {
                        return Err(self.err(attr.value_pos, "the matrix must hold finite numbers"));
                    }
                    let mm = match v.len() {
                        // Written row by row; glam stores columns.
                        16 => Mat4::from_cols_slice(&v).transpose(),
                        9 => Mat4::from_mat3(Mat3::from_cols_slice(&v).transpose()),
                        n => {
                            return Err(self.err(
                                attr.value_pos,
                                format!("a <matrix> needs 16 numbers (4x4) or 9 (3x3), found {n}"),
                            ))
                        }
                    };
                    if (mm.row(3) - Vec4::W).abs().max_element() > 1e-6 {
                        return Err(self.err(
                            attr.value_pos,
                            "the last row of a <matrix> must be 0 0 0 1 (projective transforms are not supported)",
                        ));
                    }
                    mm
                }
                "lookat" => {
                    self.check_attributes(op, &["origin", "target", "up"], &["origin", "target"])?;
                    let origin = self.vec3_attr(op, "origin")?;
                    let target = self.vec3_attr(op, "target")?;
                    let up = if op.attr("up").is_some() {
                        self.vec3_attr(op, "up")?
                    } else {
                        Vec3::ZERO
                    };
                    look_at(origin, target, up).map_err(|msg| self.err(op.pos, msg))?
                }
                _ => unreachable!(),
            };
            m = om * m;
        }
        Transform::new(m).ok_or_else(|| {
            self.err(
                node.pos,
                "this transform is singular or not finite (it cannot be inverted)",
            )
        })
    }

    // ----- textures -----

    /// A constant texture as a property value: `uniform` (a float `value`)
    /// or `srgb` (an rgb `color`).
    fn texture(&mut self, node: &'d SceneNode) -> Result<Value> {
        let ty = self
            .object_type(
                node,
                &["uniform", "srgb"],
                &[
                    "bitmap",
                    "checkerboard",
                    "mesh_attribute",
                    "volume",
                    "d65",
                    "regular",
                    "irregular",
                    "blackbody",
                ],
            )
            .map_err(|mut e| {
                e.message
                    .push_str(" (lente supports only constant textures)");
                e
            })?;
        let owner = describe(node);
        let (mut p, children) = self.read_object(node, &owner)?;
        self.no_children(&children, &owner)?;
        let value = match ty {
            "uniform" => {
                p.get_float("wavelength_min", 360.0)?;
                p.get_float("wavelength_max", 830.0)?;
                Value::Float(p.require_float("value")?)
            }
            _ => {
                let c = p.require_rgb("color")?;
                p.get_bool("unbounded", false)?;
                Value::Color(c)
            }
        };
        p.finish(&mut self.warnings);
        Ok(value)
    }

    // ----- scene -----

    fn scene(&mut self, root_pos: Pos, items: &'d [Item]) -> Result<SceneDesc> {
        let mut sensors: Vec<(SensorDesc, Pos)> = Vec::new();
        let mut integrator: Option<(Integrator, Pos)> = None;
        let mut shapes = Vec::new();
        let mut emitters = Vec::new();
        let mut environment: Option<(usize, Pos)> = None;
        let mut definitions: Vec<Child<'d>> = Vec::new();
        let mut scene_props = Props::new(&self.files[0], "<scene>", root_pos);
        scene_props.set_color_tag("rgb");

        for item in items {
            self.cur = item.file;
            let node = &item.node;
            let tag = node.tag.as_str();
            let child = if tag == "ref" {
                self.check_attributes(node, &["id", "name"], &["id"])?;
                self.no_content(node)?;
                let id_attr = node.attr("id").expect("checked");
                let Some(t) = self.ids.get(id_attr.value.as_str()).copied() else {
                    return Err(self.unknown_id(id_attr.value_pos, &id_attr.value));
                };
                self.referenced.insert(&id_attr.value);
                Child {
                    name: None,
                    node: t.node,
                    file: t.file,
                    at: node.pos,
                }
            } else if OBJECT_TAGS.contains(&tag)
                || (tag == "spectrum" && node.attr("type").is_some())
            {
                Child {
                    name: node.attr_value("name"),
                    node,
                    file: item.file,
                    at: node.pos,
                }
            } else if PROPERTY_TAGS.contains(&tag) {
                if item.file == 0 {
                    self.read_property(node, &mut scene_props)?;
                } else {
                    let mut p = Props::new(self.file(), "<scene>", node.pos);
                    self.read_property(node, &mut p)?;
                    p.finish(&mut self.warnings);
                }
                continue;
            } else if matches!(tag, "alias" | "path") {
                continue;
            } else if TRANSFORM_OPS.contains(&tag) {
                return Err(self.err(
                    node.pos,
                    format!("<{tag}> may only stand inside a <transform>"),
                ));
            } else {
                return Err(self.unknown_element(node));
            };
            match child.node.tag.as_str() {
                "sensor" => {
                    let s = self.enter(&child, |c| c.sensor(child.node))?;
                    sensors.push((s, child.at));
                }
                "integrator" => {
                    if let Some((_, first)) = integrator {
                        return Err(self.err(
                            child.at,
                            format!(
                                "a scene can have only one <integrator> (the first is at {first})"
                            ),
                        ));
                    }
                    let i = self.enter(&child, |c| c.integrator(child.node))?;
                    integrator = Some((i, child.at));
                }
                "shape" => {
                    let s = self.enter(&child, |c| c.shape(child.node))?;
                    shapes.push(s);
                }
                "emitter" => match self.enter(&child, |c| c.emitter(child.node, false))? {
                    EmitterDesc::Free {
                        emitter,
                        environment: env,
                    } => {
                        if env {
                            if let Some((file, first)) = environment {
                                let first = if file == self.cur {
                                    first.to_string()
                                } else {
                                    format!("{}:{first}", self.files[file].display())
                                };
                                return Err(self.err(
                                    child.at,
                                    format!(
                                        "a scene can have only one environment emitter \
                                         (envmap or constant); the first is at {first}"
                                    ),
                                ));
                            }
                            environment = Some((self.cur, child.at));
                        }
                        emitters.push(emitter);
                    }
                    EmitterDesc::Area(_) => unreachable!("checked by emitter()"),
                },
                "bsdf" | "texture" | "spectrum" => {
                    if child.node.attr("id").is_none() && tag != "ref" {
                        self.warn(
                            child.at,
                            format!(
                                "{} directly inside <scene> has no id, so nothing can use it",
                                describe(child.node)
                            ),
                        );
                    }
                    definitions.push(child);
                }
                "medium" | "phase" | "volume" => {
                    return Err(self.err(
                        child.at,
                        format!(
                            "{}: participating media are not supported",
                            describe(child.node)
                        ),
                    ))
                }
                _ => return Err(self.misplaced(&child, "<scene>")),
            }
        }
        scene_props.finish(&mut self.warnings);

        // Definitions nothing refers to are still checked, as Mitsuba does.
        for d in definitions {
            let unused = d
                .node
                .attr_value("id")
                .is_none_or(|id| !self.referenced.contains(id));
            if !unused {
                continue;
            }
            match d.node.tag.as_str() {
                "bsdf" => {
                    self.enter(&d, |c| c.bsdf(d.node))?;
                }
                _ => {
                    self.enter(&d, |c| c.texture(d.node))?;
                }
            }
        }

        self.cur = 0;
        let (sensor, _) = match sensors.len() {
            0 => {
                self.warn(
                    root_pos,
                    "the scene has no <sensor>; using Mitsuba's default: a perspective camera \
                     (fov 45) looking down +z at the whole scene",
                );
                (default_sensor(&shapes), root_pos)
            }
            _ => {
                if sensors.len() > 1 {
                    let at = sensors[1].1;
                    self.warn(at, "lente renders only the first <sensor> of a scene");
                }
                sensors.swap_remove(0)
            }
        };
        let integrator = match integrator {
            Some((i, _)) => i,
            None => {
                self.warn(
                    root_pos,
                    "the scene has no <integrator>; using Mitsuba's default, a path tracer",
                );
                Integrator::Path {
                    strategy: Strategy::Mis,
                    params: PathParams {
                        max_depth: None,
                        rr_depth: 5,
                        hide_emitters: false,
                    },
                }
            }
        };
        Ok(SceneDesc {
            camera: sensor.camera,
            filter: sensor.filter,
            spp: sensor.spp,
            integrator,
            shapes,
            emitters,
            source: self.files[0].clone(),
        })
    }

    // ----- sensor, film, rfilter, sampler -----

    /// `perspective` and `thinlens` (Mitsuba's `sensors/perspective.cpp`,
    /// `thinlens.cpp`, `render/sensor.cpp`): image x runs towards camera -x
    /// and y towards -y, exactly lente's camera, so `to_world` is used as it
    /// is.
    fn sensor(&mut self, node: &'d SceneNode) -> Result<SensorDesc> {
        let ty = self.object_type(
            node,
            &["perspective", "thinlens"],
            &[
                "orthographic",
                "telecentric",
                "radiancemeter",
                "irradiancemeter",
                "distant",
                "batch",
                "fisheye",
            ],
        )?;
        let owner = format!("<sensor type=\"{ty}\">");
        let (mut p, children) = self.read_object(node, &owner)?;
        let mut film: Option<Child> = None;
        let mut sampler: Option<Child> = None;
        for c in children {
            let slot = match c.node.tag.as_str() {
                "film" => &mut film,
                "sampler" => &mut sampler,
                _ => return Err(self.misplaced(&c, &owner)),
            };
            if let Some(first) = slot {
                return Err(self.err(
                    c.at,
                    format!(
                        "a sensor can have only one <{}> (the first is at {})",
                        c.node.tag, first.at
                    ),
                ));
            }
            *slot = Some(c);
        }
        let (width, height, filter) = match &film {
            Some(c) => self.enter(c, |x| x.film(c.node))?,
            None => (768, 576, mitsuba_gaussian(0.5)),
        };
        let spp = match &sampler {
            Some(c) => self.enter(c, |x| x.sampler(c.node))?,
            None => 4,
        };
        let aspect = width as f64 / height as f64;
        let fov_x = horizontal_fov(&mut p, aspect)?;
        let near_clip = p.get_float("near_clip", 1e-2)?;
        let far_clip = p.get_float("far_clip", 1e4)?;
        if near_clip <= 0.0 {
            return Err(p.error(
                "near_clip",
                format!("'near_clip' must be positive, found {near_clip}"),
            ));
        }
        if far_clip <= near_clip {
            return Err(p.error(
                "far_clip",
                format!("'far_clip' ({far_clip}) must be greater than 'near_clip' ({near_clip})"),
            ));
        }
        // Read by both types (Mitsuba's ProjectiveCamera); default far_clip.
        let focus_distance = p.get_float("focus_distance", far_clip)?;
        let to_world = p.get_transform("to_world", Transform::IDENTITY)?;
        if has_scale(&to_world) {
            return Err(p.error(
                "to_world",
                "scale factors in a sensor's to_world are not allowed (Mitsuba refuses them too); \
                 use only rotations, translations and lookat",
            ));
        }
        let lens_radius = if ty == "thinlens" {
            let r = p.require_float("aperture_radius")?;
            if r < 0.0 {
                return Err(p.error(
                    "aperture_radius",
                    format!("'aperture_radius' must not be negative, found {r}"),
                ));
            }
            if r == 0.0 {
                p.warn(
                    "aperture_radius",
                    "'aperture_radius' is 0: this thin lens is a pinhole",
                );
            }
            if r > 0.0 && focus_distance <= 0.0 {
                return Err(p.error(
                    "focus_distance",
                    format!("'focus_distance' must be positive, found {focus_distance}"),
                ));
            }
            r
        } else {
            0.0
        };
        for name in ["principal_point_offset_x", "principal_point_offset_y"] {
            let v = p.get_float(name, 0.0)?;
            if v != 0.0 {
                return Err(p.error(name, format!("'{name}' is not supported (only 0)")));
            }
        }
        let open = p.get_float("shutter_open", 0.0)?;
        let close = p.get_float("shutter_close", 0.0)?;
        if close < open {
            return Err(p.error(
                "shutter_close",
                "'shutter_close' must not come before 'shutter_open'",
            ));
        }
        p.finish(&mut self.warnings);
        Ok(SensorDesc {
            camera: CameraParams {
                width,
                height,
                fov_x_deg: fov_x,
                near_clip,
                far_clip,
                to_world,
                lens_radius,
                focal_distance: focus_distance,
                aperture: Aperture::Circular,
                autofocus: false,
            },
            filter,
            spp,
        })
    }

    /// `hdrfilm` (Mitsuba's `render/film.cpp`, `films/hdrfilm.cpp`):
    /// 768 x 576 and a gaussian filter by default. Output formats are
    /// accepted and ignored (lente writes EXR and PNG).
    fn film(&mut self, node: &'d SceneNode) -> Result<(u32, u32, Filter)> {
        let ty = self.object_type(node, &["hdrfilm"], &["specfilm", "tape"])?;
        let owner = format!("<film type=\"{ty}\">");
        let (mut p, children) = self.read_object(node, &owner)?;
        let width = int_in(&mut p, "width", 768, 1, 65536)? as u32;
        let height = int_in(&mut p, "height", 576, 1, 65536)? as u32;
        let cx = p.get_int("crop_offset_x", 0)?;
        let cy = p.get_int("crop_offset_y", 0)?;
        let cw = p.get_int("crop_width", width as i64)?;
        let ch = p.get_int("crop_height", height as i64)?;
        if (cx, cy, cw, ch) != (0, 0, width as i64, height as i64) {
            let name = [
                "crop_offset_x",
                "crop_offset_y",
                "crop_width",
                "crop_height",
            ]
            .into_iter()
            .find(|n| p.has(n))
            .unwrap_or("crop_width");
            return Err(p.error(
                name,
                "crop windows are not supported: render the full image and crop it afterwards",
            ));
        }
        p.get_bool("sample_border", false)?;
        for (name, default, known) in [
            (
                "pixel_format",
                "rgb",
                &["luminance", "luminance_alpha", "rgb", "rgba", "xyz", "xyza"][..],
            ),
            (
                "component_format",
                "float16",
                &["float16", "float32", "uint32"][..],
            ),
            (
                "file_format",
                "openexr",
                &["openexr", "exr", "rgbe", "pfm"][..],
            ),
        ] {
            let v = p.get_string(name, default.into())?.to_ascii_lowercase();
            if !known.contains(&v.as_str()) {
                p.warn(
                    name,
                    format!(
                        "unknown {name} '{v}' (Mitsuba knows {}); ignored: lente writes RGB EXR and PNG",
                        known.join(", ")
                    ),
                );
            }
        }
        p.finish(&mut self.warnings);
        let mut filter: Option<(Filter, Pos)> = None;
        for c in children {
            if c.node.tag != "rfilter" {
                return Err(self.misplaced(&c, &owner));
            }
            if let Some((_, first)) = filter {
                return Err(self.err(
                    c.at,
                    format!("a film can have only one <rfilter> (the first is at {first})"),
                ));
            }
            filter = Some((self.enter(&c, |x| x.rfilter(c.node))?, c.at));
        }
        Ok((
            width,
            height,
            filter.map_or_else(|| mitsuba_gaussian(0.5), |f| f.0),
        ))
    }

    /// Mitsuba's `rfilters/`: box (radius 0.5), tent (radius 1), gaussian
    /// (stddev 0.5, cut off at 4 stddev), mitchell (B = C = 1/3, radius 2),
    /// catmullrom (Mitchell with B = 0, C = 1/2).
    fn rfilter(&mut self, node: &'d SceneNode) -> Result<Filter> {
        let ty = self.object_type(
            node,
            &["box", "tent", "gaussian", "mitchell", "catmullrom"],
            &["lanczos"],
        )?;
        let owner = format!("<rfilter type=\"{ty}\">");
        let (mut p, children) = self.read_object(node, &owner)?;
        self.no_children(&children, &owner)?;
        let filter = match ty {
            "box" => Filter::Box { radius: 0.5 },
            "tent" => Filter::Tent {
                radius: positive(&mut p, "radius", 1.0)?,
            },
            "gaussian" => mitsuba_gaussian(positive(&mut p, "stddev", 0.5)?),
            "mitchell" => Filter::Mitchell {
                radius: 2.0,
                b: p.get_float("B", 1.0 / 3.0)?,
                c: p.get_float("C", 1.0 / 3.0)?,
            },
            _ => Filter::Mitchell {
                radius: 2.0,
                b: 0.0,
                c: 0.5,
            },
        };
        p.finish(&mut self.warnings);
        Ok(filter)
    }

    /// Samplers: `sample_count` (default 4). lente has one sampler; the
    /// others give the same expected image with different noise.
    fn sampler(&mut self, node: &'d SceneNode) -> Result<u32> {
        let ty = self.object_type(
            node,
            &[
                "independent",
                "stratified",
                "multijitter",
                "ldsampler",
                "orthogonal",
            ],
            &[],
        )?;
        let owner = format!("<sampler type=\"{ty}\">");
        let (mut p, children) = self.read_object(node, &owner)?;
        self.no_children(&children, &owner)?;
        let spp = int_in(&mut p, "sample_count", 4, 1, u32::MAX as i64)? as u32;
        if p.has("seed") {
            p.get_int("seed", 0)?;
            p.warn("seed", "'seed' is ignored; use lente's --seed");
        }
        if ty != "independent" {
            p.get_bool("jitter", true)?;
            p.get_int("strength", 2)?;
            self.warn(
                node.pos,
                format!(
                    "the {ty} sampler is rendered with independent sampling \
                     (the same image in expectation, with different noise)"
                ),
            );
        }
        p.finish(&mut self.warnings);
        Ok(spp)
    }

    // ----- integrator -----

    /// `path` (`integrators/path.cpp`: max_depth -1 = unlimited, rr_depth
    /// 5, hide_emitters false) and `direct` (`direct.cpp`).
    fn integrator(&mut self, node: &'d SceneNode) -> Result<Integrator> {
        let ty = self.object_type(
            node,
            &[
                "path",
                "direct",
                "volpath",
                "volpathmis",
                "prb",
                "prb_basic",
            ],
            &[
                "aov",
                "depth",
                "moment",
                "stokes",
                "ptracer",
                "prbvolpath",
                "direct_projective",
                "prb_projective",
            ],
        )?;
        let owner = format!("<integrator type=\"{ty}\">");
        let (mut p, children) = self.read_object(node, &owner)?;
        self.no_children(&children, &owner)?;
        let hide_emitters = p.get_bool("hide_emitters", false)?;
        let integrator = if ty == "direct" {
            let shading = p.get_int("shading_samples", 1)?;
            let em = p.get_int("emitter_samples", shading)?;
            let bs = p.get_int("bsdf_samples", shading)?;
            if (em, bs) != (1, 1) {
                let name = ["emitter_samples", "bsdf_samples", "shading_samples"]
                    .into_iter()
                    .find(|n| p.has(n))
                    .unwrap_or("emitter_samples");
                p.warn(
                    name,
                    format!(
                        "lente's direct integrator takes one emitter and one BSDF sample per \
                         path (asked for {em} and {bs}); raise sample_count instead"
                    ),
                );
            }
            if hide_emitters {
                // The same estimator as Integrator::Direct, with emitters hidden.
                Integrator::Path {
                    strategy: Strategy::Mis,
                    params: PathParams {
                        max_depth: Some(2),
                        rr_depth: u32::MAX,
                        hide_emitters,
                    },
                }
            } else {
                Integrator::Direct {
                    strategy: Strategy::Mis,
                }
            }
        } else {
            if ty != "path" {
                self.warn(
                    node.pos,
                    format!(
                        "the {ty} integrator is rendered with lente's path tracer (the same \
                         image for scenes without participating media)"
                    ),
                );
            }
            let max_depth = match p.get_int("max_depth", -1)? {
                -1 => None,
                d if (1..=u32::MAX as i64).contains(&d) => Some(d as u32),
                0 => {
                    return Err(p.error(
                        "max_depth",
                        "'max_depth' 0 renders a black image; use 1 (emitters only) or more, \
                         or -1 for unlimited",
                    ))
                }
                d => {
                    return Err(p.error(
                        "max_depth",
                        format!("'max_depth' must be -1 (unlimited) or positive, found {d}"),
                    ))
                }
            };
            let rr_depth = int_in(&mut p, "rr_depth", 5, 1, u32::MAX as i64)? as u32;
            Integrator::Path {
                strategy: Strategy::Mis,
                params: PathParams {
                    max_depth,
                    rr_depth,
                    hide_emitters,
                },
            }
        };
        p.finish(&mut self.warnings);
        Ok(integrator)
    }

    // ----- shapes -----

    /// Shapes (Mitsuba's `shapes/`): obj, ply, sphere, rectangle, cube,
    /// disk, cylinder; `to_world`, `flip_normals`, `face_normals` (meshes).
    fn shape(&mut self, node: &'d SceneNode) -> Result<ShapeDesc> {
        let ty = self.object_type(
            node,
            &[
                "obj",
                "ply",
                "sphere",
                "rectangle",
                "cube",
                "disk",
                "cylinder",
            ],
            &[
                "serialized",
                "shapegroup",
                "instance",
                "bsplinecurve",
                "linearcurve",
                "sdfgrid",
                "ellipsoids",
                "ellipsoidsmesh",
                "merge",
            ],
        )?;
        let owner = format!("<shape type=\"{ty}\">");
        let (mut p, children) = self.read_object(node, &owner)?;
        let to_world = p.get_transform("to_world", Transform::IDENTITY)?;
        let to_world_pos = p.value_pos("to_world");
        let flip_normals = p.get_bool("flip_normals", false)?;

        enum Source {
            Mesh {
                mesh: TriangleMesh,
                /// Normals to compute after the transform (Mitsuba does so
                /// for meshes without them unless face_normals is set).
                smooth: bool,
            },
            Sphere(Sphere),
        }
        let source = match ty {
            "obj" | "ply" => {
                let name = p.require_string("filename")?;
                if name.trim().is_empty() {
                    return Err(p.error("filename", "'filename' is empty"));
                }
                let face_normals = p.get_bool("face_normals", false)?;
                let flip_tex = ty == "obj" && p.get_bool("flip_tex_coords", true)?;
                let path = self.resolve(&name);
                let mut mesh = if ty == "obj" {
                    geometry::load_obj(&path)
                } else {
                    geometry::load_ply(&path)
                }
                .map_err(|e| self.err(node.pos, e))?;
                if flip_tex {
                    for uv in &mut mesh.uvs {
                        uv.y = 1.0 - uv.y;
                    }
                }
                if face_normals {
                    mesh.normals.clear();
                }
                let smooth = !face_normals && mesh.normals.is_empty();
                Source::Mesh { mesh, smooth }
            }
            "rectangle" => Source::Mesh {
                mesh: geometry::rectangle_mesh(),
                smooth: false,
            },
            "cube" => Source::Mesh {
                mesh: geometry::cube_mesh(),
                smooth: false,
            },
            "disk" => Source::Mesh {
                mesh: geometry::disk_mesh(geometry::ROUND_SEGMENTS),
                smooth: false,
            },
            "cylinder" => {
                let p0 = p.get_point("p0", Vec3::ZERO)?;
                let p1 = p.get_point("p1", Vec3::Z)?;
                let radius = positive(&mut p, "radius", 1.0)?;
                let Some(mesh) = geometry::cylinder_mesh(p0, p1, radius, geometry::ROUND_SEGMENTS)
                else {
                    return Err(p.error("p1", "the cylinder's 'p0' and 'p1' must differ"));
                };
                Source::Mesh {
                    mesh,
                    smooth: false,
                }
            }
            _ => {
                let center = p.get_point("center", Vec3::ZERO)?;
                let radius = positive(&mut p, "radius", 1.0)?;
                Source::Sphere(Sphere::new(center, radius))
            }
        };
        p.finish(&mut self.warnings);

        let mut bsdf: Option<(BsdfSpec, Pos)> = None;
        let mut area: Option<(Rgb, Pos)> = None;
        for c in children {
            match c.node.tag.as_str() {
                "bsdf" => {
                    if let Some((_, first)) = bsdf {
                        return Err(self.err(
                            c.at,
                            format!("a shape can have only one <bsdf> (the first is at {first})"),
                        ));
                    }
                    bsdf = Some((self.enter(&c, |x| x.bsdf(c.node))?, c.at));
                }
                "emitter" => {
                    if let Some((_, first)) = area {
                        return Err(self.err(
                            c.at,
                            format!(
                                "a shape can have only one <emitter> (the first is at {first})"
                            ),
                        ));
                    }
                    match self.enter(&c, |x| x.emitter(c.node, true))? {
                        EmitterDesc::Area(radiance) => area = Some((radiance, c.at)),
                        EmitterDesc::Free { .. } => unreachable!("checked by emitter()"),
                    }
                }
                "medium" => {
                    return Err(self.err(
                        c.at,
                        "participating media (interior/exterior) are not supported",
                    ))
                }
                _ => return Err(self.misplaced(&c, &owner)),
            }
        }

        let geometry = match source {
            Source::Mesh { mut mesh, smooth } => {
                geometry::transform_mesh_keep_winding(&mut mesh, &to_world);
                if smooth {
                    geometry::compute_vertex_normals(&mut mesh);
                }
                if flip_normals {
                    geometry::flip_mesh_normals(&mut mesh);
                }
                Geometry::Mesh(mesh)
            }
            Source::Sphere(s) => {
                let mut g = Geometry::Sphere(s);
                g.transform(&to_world)
                    .map_err(|e| self.err(to_world_pos, e))?;
                if flip_normals {
                    let Geometry::Sphere(s) = g else {
                        unreachable!()
                    };
                    self.warn(
                        node.pos,
                        "a sphere with flip_normals is rendered as a fine mesh (normals inward)",
                    );
                    let mut m = geometry::sphere_mesh(s.center, s.radius, 256, 128);
                    geometry::flip_mesh_normals(&mut m);
                    Geometry::Mesh(m)
                } else {
                    g
                }
            }
        };
        let finite = match &geometry {
            Geometry::Mesh(m) => m.positions.iter().all(|p| p.is_finite()) && m.area().is_finite(),
            Geometry::Sphere(s) => s.center.is_finite() && s.radius.is_finite(),
        };
        if !finite {
            return Err(self.err(
                to_world_pos,
                format!("{owner} is not finite after its to_world (coordinates overflow)"),
            ));
        }
        if let Geometry::Mesh(m) = &geometry {
            if m.indices.is_empty() || m.area().is_nan() || m.area() <= 0.0 {
                return Err(self.err(node.pos, format!("{owner} has no area")));
            }
        }
        let bsdf = match bsdf {
            Some((spec, at)) => self.build_bsdf(&spec, at)?,
            // Mitsuba's default (`render/shape.cpp`): diffuse 0.5, but
            // black for an emitter, so lights do not reflect.
            None if area.is_some() => Bsdf::Diffuse { albedo: Rgb::ZERO },
            None => Bsdf::default(),
        };
        Ok(ShapeDesc {
            geometry,
            bsdf,
            area_radiance: area.map(|a| a.0),
        })
    }

    // ----- BSDFs -----

    /// The lente BSDF for a spec. Rough plastics build tables (up to half a
    /// second): shapes that share one (by reference or by equal
    /// parameters) share the build.
    fn build_bsdf(&mut self, spec: &BsdfSpec, at: Pos) -> Result<Bsdf> {
        if let Some((_, b)) = self.built.iter().find(|(s, _)| s == spec) {
            return Ok(b.clone());
        }
        let b = spec.build().map_err(|e| self.err(at, e))?;
        if spec.has_tables() {
            self.built.push((spec.clone(), b.clone()));
        }
        Ok(b)
    }

    /// Mitsuba's BSDFs with their parameters and defaults (`bsdfs/*.cpp`).
    fn bsdf(&mut self, node: &'d SceneNode) -> Result<BsdfSpec> {
        let ty = self.object_type(
            node,
            &[
                "diffuse",
                "dielectric",
                "thindielectric",
                "roughdielectric",
                "conductor",
                "roughconductor",
                "plastic",
                "roughplastic",
                "twosided",
            ],
            &[
                "principled",
                "principledthin",
                "blendbsdf",
                "mask",
                "bumpmap",
                "normalmap",
                "hair",
                "measured",
                "pplastic",
                "polarizer",
                "retarder",
                "circular",
                "null",
            ],
        )?;
        let owner = format!("<bsdf type=\"{ty}\">");
        let (mut p, children) = self.read_object(node, &owner)?;
        let spec = match ty {
            "diffuse" => BsdfSpec::Diffuse {
                reflectance: p.get_rgb_or_float("reflectance", Rgb::splat(0.5))?,
            },
            "dielectric" | "thindielectric" | "roughdielectric" => {
                let int_ior = ior(&mut p, "int_ior", 1.5046)?;
                let ext_ior = ior(&mut p, "ext_ior", 1.000277)?;
                let specular_reflectance = p.get_rgb_or_float("specular_reflectance", Rgb::ONE)?;
                let specular_transmittance =
                    p.get_rgb_or_float("specular_transmittance", Rgb::ONE)?;
                let d = DielectricParams {
                    int_ior,
                    ext_ior,
                    specular_reflectance,
                    specular_transmittance,
                };
                match ty {
                    "dielectric" => BsdfSpec::Dielectric(d),
                    "thindielectric" => BsdfSpec::ThinDielectric(d),
                    _ => BsdfSpec::RoughDielectric(d, roughness(&mut p)?),
                }
            }
            "conductor" | "roughconductor" => {
                let material = p.get_string("material", "none".into())?;
                let ior = if p.has("eta") || p.has("k") || material == "none" {
                    if material != "none" {
                        return Err(p.error(
                            "material",
                            "give either 'material' or 'eta' and 'k', not both",
                        ));
                    }
                    ConductorIor::Custom {
                        eta: p.get_rgb_or_float("eta", Rgb::ZERO)?,
                        k: p.get_rgb_or_float("k", Rgb::ONE)?,
                    }
                } else if conductor_preset(&material).is_some() {
                    ConductorIor::Named(material)
                } else {
                    let names: Vec<&str> = conductor_preset_names().collect();
                    return Err(p.error(
                        "material",
                        format!(
                            "unknown conductor material '{material}'; Mitsuba's are: {}",
                            names.join(", ")
                        ),
                    ));
                };
                let specular_reflectance = p.get_rgb_or_float("specular_reflectance", Rgb::ONE)?;
                if ty == "conductor" {
                    BsdfSpec::Conductor {
                        ior,
                        specular_reflectance,
                    }
                } else {
                    BsdfSpec::RoughConductor {
                        ior,
                        specular_reflectance,
                        roughness: roughness(&mut p)?,
                    }
                }
            }
            "plastic" | "roughplastic" => {
                let params = PlasticParams {
                    diffuse_reflectance: p
                        .get_rgb_or_float("diffuse_reflectance", Rgb::splat(0.5))?,
                    specular_reflectance: p.get_rgb_or_float("specular_reflectance", Rgb::ONE)?,
                    int_ior: ior(&mut p, "int_ior", 1.49)?,
                    ext_ior: ior(&mut p, "ext_ior", 1.000277)?,
                    nonlinear: p.get_bool("nonlinear", false)?,
                };
                if ty == "plastic" {
                    BsdfSpec::Plastic(params)
                } else {
                    let r = roughness(&mut p)?;
                    if r.alpha_u != r.alpha_v {
                        return Err(p.error(
                            "alpha_u",
                            "roughplastic takes one 'alpha' (Mitsuba's roughplastic is \
                             isotropic only)",
                        ));
                    }
                    BsdfSpec::RoughPlastic(params, r)
                }
            }
            _ => {
                let mut inner = Vec::new();
                for c in &children {
                    if c.node.tag != "bsdf" {
                        return Err(self.misplaced(c, &owner));
                    }
                    if inner.len() == 2 {
                        return Err(self.err(c.at, "a twosided BSDF takes one or two <bsdf>s"));
                    }
                    let nested = self.enter(c, |x| x.bsdf(c.node))?;
                    if nested.transmits() {
                        return Err(self.err(
                            c.at,
                            format!(
                                "{} transmits light, and a twosided BSDF can only hold \
                                 BSDFs without transmission (as in Mitsuba); a dielectric \
                                 is two-sided already, use it without twosided",
                                describe(c.node)
                            ),
                        ));
                    }
                    inner.push(nested);
                }
                let mut it = inner.into_iter();
                let Some(front) = it.next() else {
                    return Err(self.err(node.pos, "a twosided BSDF needs a nested <bsdf>"));
                };
                BsdfSpec::TwoSided {
                    front: Box::new(front),
                    back: it.next().map(Box::new),
                }
            }
        };
        if ty != "twosided" {
            self.no_children(&children, &owner)?;
        }
        p.finish(&mut self.warnings);
        if let Some(msg) = spec.approximation() {
            self.warn(node.pos, format!("{owner} {msg}"));
        }
        Ok(spec)
    }

    // ----- emitters -----

    /// Mitsuba's `emitters/`: area (radiance, default 1), point
    /// (intensity, default 1; position or to_world), directional
    /// (irradiance, default 1; direction or to_world, default +z),
    /// constant (radiance, default 1), envmap (filename, scale, to_world;
    /// Mitsuba's lat-long mapping is lente's, see `emitter/envmap.rs`).
    fn emitter(&mut self, node: &'d SceneNode, in_shape: bool) -> Result<EmitterDesc> {
        let ty = self.object_type(
            node,
            &["area", "point", "directional", "constant", "envmap"],
            &[
                "spot",
                "projector",
                "sunsky",
                "sky",
                "sun",
                "directionalarea",
                "smootharea",
            ],
        )?;
        let owner = format!("<emitter type=\"{ty}\">");
        if in_shape && ty != "area" {
            return Err(self.err(
                node.pos,
                format!(
                    "{owner} cannot stand inside a <shape>; only area emitters can, \
                     a {ty} emitter belongs directly inside <scene>"
                ),
            ));
        }
        if !in_shape && ty == "area" {
            return Err(self.err(
                node.pos,
                format!(
                    "{owner} cannot stand inside <scene>; an area emitter belongs inside a <shape>"
                ),
            ));
        }
        let (mut p, children) = self.read_object(node, &owner)?;
        self.no_children(&children, &owner)?;
        let both = |p: &Props, a: &str, b: &str| -> Result<()> {
            if p.has(a) && p.has(b) {
                return Err(p.error(b, format!("give either '{a}' or '{b}', not both")));
            }
            Ok(())
        };
        let desc = match ty {
            "area" => {
                if p.has("to_world") {
                    return Err(p.error(
                        "to_world",
                        "an area emitter takes no to_world: it inherits its shape's",
                    ));
                }
                EmitterDesc::Area(p.get_rgb_or_float("radiance", Rgb::ONE)?)
            }
            "point" => {
                both(&p, "position", "to_world")?;
                let position = match p.opt_point("position")? {
                    Some(v) => v,
                    None => p
                        .get_transform("to_world", Transform::IDENTITY)?
                        .point(Vec3::ZERO),
                };
                EmitterDesc::Free {
                    emitter: Emitter::Point {
                        position,
                        intensity: p.get_rgb_or_float("intensity", Rgb::ONE)?,
                    },
                    environment: false,
                }
            }
            "directional" => {
                both(&p, "direction", "to_world")?;
                let d = match p.opt_vector("direction")? {
                    Some(v) => v,
                    None => p
                        .get_transform("to_world", Transform::IDENTITY)?
                        .vector(Vec3::Z),
                };
                let Some(direction) = d.try_normalize() else {
                    return Err(p.error("direction", "the direction must not be zero"));
                };
                EmitterDesc::Free {
                    emitter: Emitter::Directional {
                        direction,
                        irradiance: p.get_rgb_or_float("irradiance", Rgb::ONE)?,
                    },
                    environment: false,
                }
            }
            "constant" => EmitterDesc::Free {
                emitter: Emitter::Constant {
                    radiance: p.get_rgb_or_float("radiance", Rgb::ONE)?,
                },
                environment: true,
            },
            _ => {
                let name = p.require_string("filename")?;
                if name.trim().is_empty() {
                    return Err(p.error("filename", "'filename' is empty"));
                }
                let scale = p.get_float("scale", 1.0)?;
                if scale < 0.0 {
                    return Err(p.error(
                        "scale",
                        format!("'scale' must not be negative, found {scale}"),
                    ));
                }
                let to_world = p.get_transform("to_world", Transform::IDENTITY)?;
                if !is_rotation(&to_world) {
                    return Err(p.error(
                        "to_world",
                        "an environment map's to_world must be a rotation (an orthogonal matrix)",
                    ));
                }
                p.finish(&mut self.warnings);
                let path = self.resolve(&name);
                let (image, image_warnings) = crate::image::io::load_image(&path).map_err(|e| {
                    self.err(node.pos, format!("cannot load the environment map: {e}"))
                })?;
                for w in image_warnings {
                    self.warn(node.pos, format!("{}: {w}", path.display()));
                }
                let env = EnvMap::new(image, scale, to_world, EnvFilter::Bilinear);
                return Ok(EmitterDesc::Free {
                    emitter: Emitter::Environment(Box::new(env)),
                    environment: true,
                });
            }
        };
        p.finish(&mut self.warnings);
        Ok(desc)
    }
}

// ---------------------------------------------------------------------------
// BSDFs: Mitsuba's parameters, and what lente renders them with
// ---------------------------------------------------------------------------

/// Parameters shared by Mitsuba's dielectrics.
#[derive(Clone, Debug, PartialEq)]
pub struct DielectricParams {
    pub int_ior: f32,
    pub ext_ior: f32,
    pub specular_reflectance: Rgb,
    pub specular_transmittance: Rgb,
}

/// A conductor's complex index of refraction.
#[derive(Clone, Debug, PartialEq)]
pub enum ConductorIor {
    /// One of Mitsuba's measured materials (`material="Au"`).
    Named(String),
    /// Explicit `eta` and `k` (`material="none"` gives 0 and 1: a mirror).
    Custom { eta: Rgb, k: Rgb },
}

/// Microfacet roughness (`distribution`, `alpha` or `alpha_u`/`alpha_v`,
/// `sample_visible`).
#[derive(Clone, Debug, PartialEq)]
pub struct Roughness {
    pub distribution: MicrofacetType,
    pub alpha_u: f32,
    pub alpha_v: f32,
    pub sample_visible: bool,
}

#[derive(Clone, Debug, PartialEq)]
pub struct PlasticParams {
    pub diffuse_reflectance: Rgb,
    pub specular_reflectance: Rgb,
    pub int_ior: f32,
    pub ext_ior: f32,
    pub nonlinear: bool,
}

/// A Mitsuba BSDF with all its parameters.
#[derive(Clone, Debug, PartialEq)]
pub enum BsdfSpec {
    Diffuse {
        reflectance: Rgb,
    },
    Dielectric(DielectricParams),
    ThinDielectric(DielectricParams),
    RoughDielectric(DielectricParams, Roughness),
    Conductor {
        ior: ConductorIor,
        specular_reflectance: Rgb,
    },
    RoughConductor {
        ior: ConductorIor,
        specular_reflectance: Rgb,
        roughness: Roughness,
    },
    Plastic(PlasticParams),
    RoughPlastic(PlasticParams, Roughness),
    TwoSided {
        front: Box<BsdfSpec>,
        back: Option<Box<BsdfSpec>>,
    },
}

impl BsdfSpec {
    /// The lente BSDF that renders it: Mitsuba's own model, with every
    /// parameter (see [`BsdfSpec::approximation`] for what is not). An
    /// error only for a twosided BSDF holding a transmissive one (the
    /// parser refuses those at the element already).
    pub fn build(&self) -> std::result::Result<Bsdf, String> {
        Ok(match self {
            BsdfSpec::Diffuse { reflectance } => Bsdf::Diffuse {
                albedo: *reflectance,
            },
            // Lente's smooth dielectric has no tints (see `approximation`).
            BsdfSpec::Dielectric(d) => Bsdf::dielectric(d.int_ior, d.ext_ior),
            BsdfSpec::ThinDielectric(d) => Bsdf::thin_dielectric(
                d.int_ior,
                d.ext_ior,
                d.specular_reflectance,
                d.specular_transmittance,
            ),
            BsdfSpec::RoughDielectric(d, r) => Bsdf::rough_dielectric(
                r.distribution,
                r.alpha_u,
                r.alpha_v,
                d.int_ior,
                d.ext_ior,
                d.specular_reflectance,
                d.specular_transmittance,
                r.sample_visible,
            ),
            BsdfSpec::Conductor {
                ior,
                specular_reflectance,
            } => {
                let (eta, k) = ior.eta_k()?;
                Bsdf::conductor(eta, k, *specular_reflectance)
            }
            BsdfSpec::RoughConductor {
                ior,
                specular_reflectance,
                roughness: r,
            } => {
                let (eta, k) = ior.eta_k()?;
                Bsdf::rough_conductor(
                    r.distribution,
                    r.alpha_u,
                    r.alpha_v,
                    eta,
                    k,
                    *specular_reflectance,
                    r.sample_visible,
                )
            }
            BsdfSpec::Plastic(pl) => Bsdf::plastic(
                pl.int_ior,
                pl.ext_ior,
                pl.diffuse_reflectance,
                pl.specular_reflectance,
                pl.nonlinear,
            ),
            BsdfSpec::RoughPlastic(pl, r) => Bsdf::rough_plastic(
                r.distribution,
                r.alpha_u,
                pl.int_ior,
                pl.ext_ior,
                pl.diffuse_reflectance,
                pl.specular_reflectance,
                pl.nonlinear,
                r.sample_visible,
            ),
            BsdfSpec::TwoSided { front, back } => {
                let back = match back {
                    Some(b) => Some(b.build()?),
                    None => None,
                };
                Bsdf::two_sided(front.build()?, back).ok_or_else(|| {
                    "a twosided BSDF can only hold BSDFs without transmission".to_string()
                })?
            }
        })
    }

    /// True if it scatters light through the surface (Mitsuba's twosided
    /// refuses those).
    pub fn transmits(&self) -> bool {
        match self {
            BsdfSpec::Dielectric(_)
            | BsdfSpec::ThinDielectric(_)
            | BsdfSpec::RoughDielectric(..) => true,
            BsdfSpec::TwoSided { front, back } => {
                front.transmits() || back.as_ref().is_some_and(|b| b.transmits())
            }
            _ => false,
        }
    }

    /// True if building it computes tables (worth sharing).
    fn has_tables(&self) -> bool {
        match self {
            BsdfSpec::RoughPlastic(..) => true,
            BsdfSpec::TwoSided { front, back } => {
                front.has_tables() || back.as_ref().is_some_and(|b| b.has_tables())
            }
            _ => false,
        }
    }

    /// What `build` does not reproduce, if anything (for a warning).
    pub fn approximation(&self) -> Option<String> {
        match self {
            BsdfSpec::Dielectric(d)
                if d.specular_reflectance != Rgb::ONE || d.specular_transmittance != Rgb::ONE =>
            {
                Some(
                    "is rendered without its specular_reflectance/specular_transmittance \
                     tints (lente's smooth dielectric has none)"
                        .into(),
                )
            }
            // Nested BSDFs warn for themselves.
            _ => None,
        }
    }
}

impl ConductorIor {
    /// The complex index of refraction, per RGB channel, as Mitsuba's RGB
    /// variants use it.
    pub fn eta_k(&self) -> std::result::Result<(Rgb, Rgb), String> {
        match self {
            ConductorIor::Custom { eta, k } => Ok((*eta, *k)),
            ConductorIor::Named(name) => {
                conductor_preset(name).ok_or_else(|| format!("unknown conductor material '{name}'"))
            }
        }
    }
}

/// An index of refraction: a number, or one of Mitsuba's names.
fn ior(p: &mut Props, name: &str, default: f32) -> Result<f32> {
    let v = if p.kind_of(name) == Some(Kind::String) {
        let s = p.require_string(name)?;
        match ior_preset(s.trim()) {
            Some(v) => v,
            None => {
                let names: Vec<&str> = ior_preset_names().collect();
                return Err(p.error(
                    name,
                    format!(
                        "unknown index of refraction '{s}'; give a number or one of: {}",
                        names.join(", ")
                    ),
                ));
            }
        }
    } else {
        p.get_float(name, default)?
    };
    if v <= 0.0 {
        return Err(p.error(name, format!("'{name}' must be positive, found {v}")));
    }
    Ok(v)
}

/// `distribution` (beckmann or ggx, default beckmann), `alpha` (0.1) or
/// both `alpha_u` and `alpha_v`, `sample_visible` (true).
fn roughness(p: &mut Props) -> Result<Roughness> {
    let dist = p.get_string("distribution", "beckmann".into())?;
    let Some(distribution) = MicrofacetType::from_name(dist.trim()) else {
        return Err(p.error(
            "distribution",
            format!("unknown distribution '{dist}'; use beckmann or ggx"),
        ));
    };
    let (alpha_u, alpha_v) = if p.has("alpha_u") || p.has("alpha_v") {
        if p.has("alpha") {
            return Err(p.error("alpha", "give either 'alpha' or 'alpha_u' and 'alpha_v'"));
        }
        (
            non_negative_req(p, "alpha_u")?,
            non_negative_req(p, "alpha_v")?,
        )
    } else {
        let a = p.get_float("alpha", 0.1)?;
        if a < 0.0 {
            return Err(p.error("alpha", format!("'alpha' must not be negative, found {a}")));
        }
        (a, a)
    };
    Ok(Roughness {
        distribution,
        alpha_u,
        alpha_v,
        sample_visible: p.get_bool("sample_visible", true)?,
    })
}

fn non_negative_req(p: &mut Props, name: &str) -> Result<f32> {
    let v = p.require_float(name)?;
    if v < 0.0 {
        return Err(p.error(name, format!("'{name}' must not be negative, found {v}")));
    }
    Ok(v)
}

// ---------------------------------------------------------------------------
// Helpers
// ---------------------------------------------------------------------------

/// The horizontal field of view in degrees from `fov` + `fov_axis` or
/// `focal_length` (Mitsuba's `parse_fov` in `render/sensor.cpp`; `aspect`
/// is width / height).
fn horizontal_fov(p: &mut Props, aspect: f64) -> Result<f32> {
    if p.has("fov") && p.has("focal_length") {
        return Err(p.error(
            "focal_length",
            "give either 'fov' or 'focal_length', not both",
        ));
    }
    let (fov, axis, from) = if p.has("fov") {
        let fov = p.require_float("fov")? as f64;
        if !(fov > 0.0 && fov < 180.0) {
            return Err(p.error(
                "fov",
                format!("'fov' must be between 0 and 180 degrees (exclusive), found {fov}"),
            ));
        }
        let mut axis = p.get_string("fov_axis", "x".into())?.to_ascii_lowercase();
        if axis == "smaller" {
            axis = if aspect > 1.0 { "y" } else { "x" }.into();
        } else if axis == "larger" {
            axis = if aspect > 1.0 { "x" } else { "y" }.into();
        }
        (fov, axis, "fov")
    } else {
        let f = if p.kind_of("focal_length") == Some(Kind::Float)
            || p.kind_of("focal_length") == Some(Kind::Int)
        {
            p.require_float("focal_length")? as f64
        } else {
            let s = p.get_string("focal_length", "50mm".into())?;
            let t = s.trim();
            let t = t.strip_suffix("mm").unwrap_or(t).trim();
            t.parse::<f64>().map_err(|_| {
                p.error(
                    "focal_length",
                    format!("cannot read the focal length '{s}' (expected e.g. 50mm)"),
                )
            })?
        };
        if !(f > 0.0 && f.is_finite()) {
            return Err(p.error(
                "focal_length",
                format!("the focal length must be positive, found {f}"),
            ));
        }
        // The diagonal of 35 mm film (36 x 24 mm).
        let diag = (36.0f64 * 36.0 + 24.0 * 24.0).sqrt();
        (
            2.0 * (diag / (2.0 * f)).atan().to_degrees(),
            "diagonal".to_string(),
            "focal_length",
        )
    };
    let half = (0.5 * fov).to_radians();
    let x = match axis.as_str() {
        "x" => fov,
        "y" => 2.0 * (half.tan() * aspect).atan().to_degrees(),
        "diagonal" => {
            let diagonal = 2.0 * half.tan();
            let width = diagonal / (1.0 + 1.0 / (aspect * aspect)).sqrt();
            2.0 * (0.5 * width).atan().to_degrees()
        }
        other => {
            return Err(p.error(
                "fov_axis",
                format!("unknown fov_axis '{other}'; use x, y, diagonal, smaller or larger"),
            ))
        }
    };
    if !(x > 0.0 && x < 180.0) {
        return Err(p.error(
            from,
            format!("the horizontal field of view must be between 0 and 180 degrees, found {x}"),
        ));
    }
    Ok(x as f32)
}

/// Mitsuba's gaussian filter: cut off at 4 standard deviations.
fn mitsuba_gaussian(stddev: f32) -> Filter {
    Filter::Gaussian {
        radius: 4.0 * stddev,
        stddev,
    }
}

/// Mitsuba's camera for a scene without a sensor (`render/scene.cpp`): fov
/// 45 along x, looking down +z from in front of the bounding box, centred
/// on it and far enough back to see all of it.
fn default_sensor(shapes: &[ShapeDesc]) -> SensorDesc {
    let bounds = shapes
        .iter()
        .fold(Aabb::EMPTY, |b, s| b.union(s.geometry.bounds()));
    let mut camera = CameraParams {
        width: 768,
        height: 576,
        fov_x_deg: 45.0,
        near_clip: 1e-2,
        far_clip: 1e4,
        to_world: Transform::IDENTITY,
        lens_radius: 0.0,
        focal_distance: 1e4,
        aperture: Aperture::Circular,
        autofocus: false,
    };
    if !bounds.is_empty() {
        let c = bounds.center();
        let ext = bounds.diagonal();
        let max = ext.max_element();
        let distance = max / (2.0 * 22.5f32.to_radians().tan());
        if max > 0.0 && distance.is_finite() {
            camera.far_clip = max * 5.0 + distance;
            camera.near_clip = distance / 100.0;
            camera.focal_distance = distance + ext.z / 2.0;
            camera.to_world = Transform::new(Mat4::from_translation(Vec3::new(
                c.x,
                c.y,
                bounds.min.z - distance,
            )))
            .unwrap_or(Transform::IDENTITY);
        }
    }
    SensorDesc {
        camera,
        filter: mitsuba_gaussian(0.5),
        spp: 4,
    }
}

/// Mitsuba's `look_at`: columns (left, up, dir, origin) with left =
/// up x dir; a zero `up` takes the first tangent of Mitsuba's
/// `coordinate_system(dir)` (the same frame as [`Frame::from_normal`]).
fn look_at(origin: Vec3, target: Vec3, up: Vec3) -> std::result::Result<Mat4, String> {
    let to = target - origin;
    let len = to.length();
    if !(len > 0.0 && len.is_finite()) {
        return Err(
            "invalid <lookat>: target must differ from origin (at a finite distance)".into(),
        );
    }
    let dir = to / len;
    let up = if up == Vec3::ZERO {
        Frame::from_normal(dir).s
    } else {
        up
    };
    let left = up.cross(dir);
    let l = left.length();
    if !(l > 1e-6 * up.length() && l.is_finite()) {
        return Err("invalid <lookat>: the up vector is parallel to the viewing direction".into());
    }
    let left = left / l;
    let new_up = dir.cross(left);
    Ok(Mat4::from_cols(
        left.extend(0.0),
        new_up.extend(0.0),
        dir.extend(0.0),
        origin.extend(1.0),
    ))
}

/// Mitsuba's `Transform::has_scale`: M M^T differs from the identity by
/// more than 1e-3 somewhere (mirrors do not count as scale).
fn has_scale(t: &Transform) -> bool {
    let m = t.linear();
    let g = m * m.transpose();
    (g - Mat3::IDENTITY)
        .to_cols_array()
        .iter()
        .any(|x| x.is_nan() || x.abs() > 1e-3)
}

/// Orthonormal linear part (rotations, possibly with a mirror).
fn is_rotation(t: &Transform) -> bool {
    !has_scale(t)
}

fn is_texture(node: &SceneNode) -> bool {
    node.tag == "texture" || (node.tag == "spectrum" && node.attr("type").is_some())
}

fn check_attributes(
    file: &Path,
    node: &SceneNode,
    allowed: &[&str],
    required: &[&str],
) -> Result<()> {
    for a in &node.attributes {
        if !allowed.contains(&a.name.as_str()) {
            let expected = if allowed.is_empty() {
                "it takes none".to_string()
            } else {
                format!(
                    "it takes {}",
                    allowed
                        .iter()
                        .map(|n| format!("'{n}'"))
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            };
            return Err(SceneError::new(
                file,
                a.pos,
                format!(
                    "unexpected attribute '{}' on <{}> ({expected})",
                    a.name, node.tag
                ),
            ));
        }
    }
    for r in required {
        if node.attr(r).is_none() {
            return Err(SceneError::new(
                file,
                node.pos,
                format!("<{}> needs a '{r}' attribute", node.tag),
            ));
        }
    }
    Ok(())
}

/// No child elements and no text.
fn no_content(file: &Path, node: &SceneNode) -> Result<()> {
    if let Some(ch) = node.children.first() {
        return Err(SceneError::new(
            file,
            ch.pos,
            format!("<{}> cannot stand inside <{}>", ch.tag, node.tag),
        ));
    }
    if let Some(t) = node.text.first() {
        return Err(SceneError::new(
            file,
            t.pos,
            format!(
                "unexpected text '{}' inside <{}>",
                shorten(&t.text),
                node.tag
            ),
        ));
    }
    Ok(())
}

fn parent_dir(file: &Path) -> PathBuf {
    match file.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn look_at_matches_mitsuba() {
        let m = look_at(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y).unwrap();
        assert!((m.transform_vector3(Vec3::Z) - Vec3::NEG_Z).length() < 1e-6);
        assert!((m.transform_vector3(Vec3::Y) - Vec3::Y).length() < 1e-6);
        // left = up x dir = Y x -Z = -X
        assert!((m.transform_vector3(Vec3::X) - Vec3::NEG_X).length() < 1e-6);
        assert!(look_at(Vec3::ZERO, Vec3::Y, Vec3::Y).is_err());
        assert!(look_at(Vec3::ZERO, Vec3::ZERO, Vec3::Y).is_err());
        // Without up: an orthonormal frame around the direction.
        let m = look_at(Vec3::ZERO, Vec3::new(1.0, 2.0, 3.0), Vec3::ZERO).unwrap();
        let t = Transform::new(m).unwrap();
        assert!(!has_scale(&t));
    }

    #[test]
    fn specs_build_mitsubas_bsdfs() {
        let mirror = BsdfSpec::Conductor {
            ior: ConductorIor::Custom {
                eta: Rgb::ZERO,
                k: Rgb::ONE,
            },
            specular_reflectance: Rgb::ONE,
        };
        assert_eq!(
            mirror.build().unwrap(),
            Bsdf::conductor(Rgb::ZERO, Rgb::ONE, Rgb::ONE)
        );
        assert!(mirror.approximation().is_none());
        let gold = BsdfSpec::Conductor {
            ior: ConductorIor::Named("Au".into()),
            specular_reflectance: Rgb::ONE,
        };
        let (eta, k) = conductor_preset("Au").unwrap();
        assert_eq!(gold.build().unwrap(), Bsdf::conductor(eta, k, Rgb::ONE));
        assert!(gold.approximation().is_none());
        let glass = DielectricParams {
            int_ior: 1.5,
            ext_ior: 1.0,
            specular_reflectance: Rgb::ONE,
            specular_transmittance: Rgb::ONE,
        };
        let two = BsdfSpec::TwoSided {
            front: Box::new(BsdfSpec::Diffuse {
                reflectance: Rgb::ONE,
            }),
            back: Some(Box::new(BsdfSpec::Dielectric(glass.clone()))),
        };
        assert!(two.transmits());
        assert!(two.build().is_err());
        let tinted = BsdfSpec::Dielectric(DielectricParams {
            specular_reflectance: Rgb::splat(0.5),
            ..glass
        });
        assert!(tinted.approximation().unwrap().contains("tints"));
    }
}
