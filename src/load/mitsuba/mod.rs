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
//! One file per kind of object: `preprocess` (pass 1), `sensor` (sensors,
//! films, filters, samplers), `shape`, `bsdf`, `emitter`, `integrator`,
//! `texture`; this file holds the identifiers, references and the scene.

mod bsdf;
mod emitter;
mod instancing;
mod integrator;
mod medium;
mod preprocess;
mod sensor;
mod shape;
mod spectrum;
mod texture;

use std::collections::{HashMap, HashSet};
use std::path::{Path, PathBuf};

use emitter::EmitterDesc;
use preprocess::{Item, Param, Pre};
use sensor::{default_sensor, SensorDesc};

use super::props::shorten;
use super::props::{self, Props};
use super::reader::{self, Dialect, LookAtError};
use super::xml::{describe, Pos, SceneNode};
use super::{SceneError, SceneFile, Warning};
use crate::integrator::{Integrator, PathParams, Strategy};
use crate::math::{Aabb, Frame, Mat4, Vec3};
use crate::render::RenderJob;
use crate::scene::SceneDesc;

type Result<T> = std::result::Result<T, SceneError>;

/// Mitsuba's vocabulary for the shared object reader.
static MITSUBA: Dialect = Dialect {
    object_tags: &[
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
    ],
    typed_property_objects: &["spectrum"],
    property_tags: &[
        "boolean",
        "integer",
        "float",
        "string",
        "point",
        "vector",
        "rgb",
        "spectrum",
        "transform",
    ],
    transform_ops: &["translate", "rotate", "scale", "matrix", "lookat"],
    scene_only: &["include", "alias", "path", "default"],
    other_tags: &["ref"],
    object_attributes: &["type", "id", "name"],
    color_tag: "rgb",
    xyz_attributes: true,
    matrix3: true,
    pairs: false,
    look_at,
    shape_tag: "shape",
    element_hints: &[
        ("color", "that is Nori's; Mitsuba writes <rgb>"),
        ("mesh", "that is Nori's; Mitsuba writes <shape>"),
        ("camera", "that is Nori's; Mitsuba writes <sensor>"),
    ],
};

/// Deepest nesting of `<include>` files (Mitsuba's limit is 15).
const MAX_INCLUDE_DEPTH: usize = 15;

/// Most `<include>`s one scene may read in all: ten files that each include
/// the next level ten times would otherwise expand to 10^15 reads.
const MAX_INCLUDES: usize = 4096;

/// How far from orthonormal a sensor rotation may be (Mitsuba's `has_scale`
/// tolerance on M M^T).
const ROTATION_TOLERANCE: f32 = 1e-3;

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
) -> Result<(SceneFile, Vec<Warning>)> {
    let mut pre = Pre {
        files: vec![file.to_path_buf()],
        params: Vec::new(),
        warnings: Vec::new(),
        items: Vec::new(),
        include_stack: vec![file.to_path_buf()],
        legacy: Vec::new(),
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
    /// BSDFs built so far.
    built: bsdf::BuiltBsdfs,
    /// Images read for textures, shared between textures naming one file.
    texture_images: crate::load::objects::TextureImages,
    /// Shape groups built so far.
    groups: instancing::ShapeGroups,
    /// The AOVs an `aov` integrator asks for.
    aovs: crate::aov::AovList,
    /// Participating media built so far.
    media: medium::BuiltMedia,
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
            built: bsdf::BuiltBsdfs::default(),
            texture_images: Default::default(),
            groups: Default::default(),
            aovs: Default::default(),
            media: Default::default(),
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
                    // Next to its file, else (Mitsuba's file resolver) next
                    // to the scene file.
                    let here = parent_dir(&files[item.file]).join(value);
                    let dir = if here.is_dir() {
                        here
                    } else {
                        parent_dir(&files[0]).join(value)
                    };
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
        reader::check_attributes(self.file(), node, allowed, required)
    }

    fn no_content(&self, node: &SceneNode) -> Result<()> {
        reader::no_content(self.file(), node)
    }

    /// Indexes the ids of `node` and everything inside it.
    fn index_ids(&mut self, node: &'d SceneNode) -> Result<()> {
        if MITSUBA.is_object(node) {
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

    /// Checks an object element's attributes and returns its type, one of
    /// `known`; one of Mitsuba's types in `unsupported` is named as such.
    fn object_type(
        &self,
        node: &'d SceneNode,
        known: &[&str],
        unsupported: &[&str],
    ) -> Result<&'d str> {
        MITSUBA.object_type(self.file(), node, known, unsupported, &|_| None)
    }

    /// Reads an object's properties; returns them and its nested objects
    /// (references resolved). Named textures become property values.
    fn read_object(
        &mut self,
        node: &'d SceneNode,
        owner: &str,
    ) -> Result<(Props<'d>, Vec<Child<'d>>)> {
        let file = self.file();
        let this = &*self;
        let (mut props, nodes) =
            MITSUBA.read_object(file, node, owner, &|n| this.spectrum_property(file, n))?;
        let mut children = Vec::with_capacity(nodes.len());
        for ch in nodes {
            children.push(self.child(ch)?);
        }
        let mut rest = Vec::with_capacity(children.len());
        for c in children {
            if texture::is_texture(c.node) {
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

    /// A nested object element as a child, or the object a `<ref>` names.
    fn child(&mut self, node: &'d SceneNode) -> Result<Child<'d>> {
        if node.tag != "ref" {
            return Ok(Child {
                name: node.attr_value("name"),
                node,
                file: self.cur,
                at: node.pos,
            });
        }
        self.check_attributes(node, &["id", "name"], &["id"])?;
        self.no_content(node)?;
        let id_attr = node.attr("id").expect("checked");
        let Some(target) = self.ids.get(id_attr.value.as_str()).copied() else {
            return Err(self.unknown_id(id_attr.value_pos, &id_attr.value));
        };
        self.referenced.insert(&id_attr.value);
        Ok(Child {
            name: node.attr_value("name"),
            node: target.node,
            file: target.file,
            at: node.pos,
        })
    }

    /// The error for a nested object that may not stand inside `parent`.
    fn misplaced(&self, child: &Child, parent: &str) -> SceneError {
        let node = child.node;
        let hint = match node.tag.as_str() {
            "film" | "sampler" => "; it belongs inside a <sensor>",
            "rfilter" => "; it belongs inside a <film>",
            "scene" => "; <scene> can only be the root element",
            "medium" => {
                "; a <medium> belongs inside a <shape> (as its interior or exterior) or a <sensor>"
            }
            "phase" | "volume" => "; it belongs inside a <medium>",
            "sensor" | "integrator" => "; it belongs directly inside <scene>",
            "emitter" => {
                "; an area emitter belongs inside a <shape>, others directly inside <scene>"
            }
            "bsdf" => "; a <bsdf> belongs inside a <shape> (or a twosided <bsdf>)",
            _ => "",
        };
        reader::misplaced(self.file(), node, child.at, parent, hint)
    }

    fn no_children(&self, children: &[Child], owner: &str) -> Result<()> {
        match children.first() {
            Some(c) => Err(self.misplaced(c, owner)),
            None => Ok(()),
        }
    }

    fn scene(&mut self, root_pos: Pos, items: &'d [Item]) -> Result<SceneFile> {
        let mut sensors: Vec<(SensorDesc, Pos)> = Vec::new();
        let mut integrator: Option<(Integrator, Pos)> = None;
        let mut shapes = Vec::new();
        let mut instances = Vec::new();
        let mut emitters = Vec::new();
        let mut environment: Option<(usize, Pos)> = None;
        let mut definitions: Vec<Child<'d>> = Vec::new();
        let mut scene_props = Props::new(&self.files[0], "<scene>", root_pos);
        scene_props.set_color_tag(MITSUBA.color_tag);

        for item in items {
            self.cur = item.file;
            let node = &item.node;
            let tag = node.tag.as_str();
            let child = if MITSUBA.is_object(node) || tag == "ref" {
                self.child(node)?
            } else if MITSUBA.is_property(node) {
                let file = self.file();
                let this = &*self;
                let special = |n: &SceneNode| this.spectrum_property(file, n);
                if item.file == 0 {
                    MITSUBA.read_property(file, node, &mut scene_props, &special)?;
                } else {
                    let mut p = MITSUBA.props(file, "<scene>", node);
                    MITSUBA.read_property(file, node, &mut p, &special)?;
                    p.finish(&mut self.warnings);
                }
                continue;
            } else if matches!(tag, "alias" | "path") {
                continue;
            } else {
                return Err(MITSUBA.out_of_place(self.file(), node));
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
                "shape" if child.node.attr_value("type") == Some("shapegroup") => {
                    // Built where first met; unused groups are still checked.
                    self.enter(&child, |c| c.shape_group(child.node))?;
                }
                "shape" if child.node.attr_value("type") == Some("instance") => {
                    instances.push(self.enter(&child, |c| c.instance(child.node))?);
                }
                "shape" => {
                    let s = self.enter(&child, |c| c.shape(child.node))?;
                    shapes.push(s);
                }
                // Mitsuba lets an area emitter be declared at the top level
                // with an id, for shapes to `<ref>`; it is built where used.
                "emitter"
                    if tag == "emitter"
                        && child.node.attr_value("type") == Some("area")
                        && child.node.attr("id").is_some() =>
                {
                    definitions.push(child)
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
                // Mitsuba lets any object be declared at the top level with an
                // id and referenced where it belongs (samplers in sensors, ...).
                "sampler" | "film" | "rfilter" if child.node.attr("id").is_some() => {
                    definitions.push(child)
                }
                "bsdf" | "texture" | "spectrum" | "medium" => {
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
                "emitter" => {
                    let id = d.node.attr_value("id").unwrap_or_default();
                    return Err(self.err(
                        d.at,
                        format!(
                            "the area emitter '{id}' stands inside <scene> but no shape uses it; \
                             reference it from a <shape> with <ref id=\"{id}\"/>"
                        ),
                    ));
                }
                "bsdf" => {
                    self.enter(&d, |c| c.bsdf(d.node))?;
                }
                "medium" => {
                    self.medium_index(&d)?;
                }
                "sampler" => {
                    self.enter(&d, |c| c.sampler(d.node))?;
                }
                "film" => {
                    self.enter(&d, |c| c.film(d.node))?;
                }
                "rfilter" => {
                    self.enter(&d, |c| c.rfilter(d.node))?;
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
                let bounds_of = |shapes: &[crate::scene::ShapeDesc]| {
                    shapes
                        .iter()
                        .fold(Aabb::EMPTY, |b, s| b.union(s.geometry.bounds()))
                };
                let groups: Vec<Aabb> = self.groups.shapes.iter().map(|g| bounds_of(g)).collect();
                let bounds = instances
                    .iter()
                    .map(|i: &crate::geometry::Instance| i.world_bounds(groups[i.group as usize]))
                    .fold(bounds_of(&shapes), Aabb::union);
                (default_sensor(bounds), root_pos)
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
        if !self.media.media.is_empty() && !matches!(integrator, Integrator::VolPath { .. }) {
            self.warn(
                root_pos,
                format!(
                    "the scene has participating media, which the {} integrator ignores (as \
                     Mitsuba's does); use <integrator type=\"volpath\"> to render them",
                    integrator.name()
                ),
            );
        }
        Ok(SceneFile {
            scene: SceneDesc {
                camera: sensor.camera,
                shapes,
                emitters,
                groups: std::mem::take(&mut self.groups.shapes),
                instances,
                media: std::mem::take(&mut self.media.media),
                camera_medium: sensor.medium,
            },
            job: RenderJob {
                integrator,
                spp: sensor.spp,
                sampler: sensor.sampler,
                filter: sensor.filter,
                aovs: std::mem::take(&mut self.aovs),
            },
        })
    }
}

/// Mitsuba's `look_at`: columns (left, up, dir, origin) with left =
/// up x dir; a zero `up` takes the first tangent of Mitsuba's
/// `coordinate_system(dir)` (the same frame as [`Frame::from_normal`]).
fn look_at(origin: Vec3, target: Vec3, up: Option<Vec3>) -> std::result::Result<Mat4, LookAtError> {
    let up = up.unwrap_or(Vec3::ZERO);
    let to = target - origin;
    let len = to.length();
    if !(len > 0.0 && len.is_finite()) {
        return Err(LookAtError::TargetAtOrigin);
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
        return Err(LookAtError::ParallelUp);
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
        let m = look_at(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Some(Vec3::Y)).unwrap();
        assert!((m.transform_vector3(Vec3::Z) - Vec3::NEG_Z).length() < 1e-6);
        assert!((m.transform_vector3(Vec3::Y) - Vec3::Y).length() < 1e-6);
        // left = up x dir = Y x -Z = -X
        assert!((m.transform_vector3(Vec3::X) - Vec3::NEG_X).length() < 1e-6);
        assert!(look_at(Vec3::ZERO, Vec3::Y, Some(Vec3::Y)).is_err());
        assert!(look_at(Vec3::ZERO, Vec3::ZERO, Some(Vec3::Y)).is_err());
        // Without up: an orthonormal frame around the direction.
        let m = look_at(Vec3::ZERO, Vec3::new(1.0, 2.0, 3.0), None).unwrap();
        let t = crate::math::Transform::new(m).unwrap();
        assert!(t.is_rotation(ROTATION_TOLERANCE));
    }
}
