//! `shapegroup` and `instance`: a group of shapes built once, placed by
//! instances (Mitsuba's rules: groups hold neither emitters, nor groups,
//! nor instances; an instance names exactly one group).

use super::{describe, Child, Ctx};
use crate::geometry::Instance;
use crate::load::xml::SceneNode;
use crate::load::SceneError;
use crate::math::Transform;
use crate::scene::ShapeDesc;

type Result<T> = std::result::Result<T, SceneError>;

/// The shape groups read so far, each built once.
#[derive(Default)]
pub(super) struct ShapeGroups {
    pub(super) shapes: Vec<Vec<ShapeDesc>>,
    index: std::collections::HashMap<*const SceneNode, u32>,
}

/// Whether a `<shape>` element is a group or an instance.
pub(super) fn is_instancing(node: &SceneNode) -> bool {
    matches!(node.attr_value("type"), Some("shapegroup" | "instance"))
}

impl<'d> Ctx<'d> {
    /// A `shapegroup`'s index in [`ShapeGroups`], built the first time it
    /// is met (declared or referenced).
    pub(super) fn shape_group(&mut self, node: &'d SceneNode) -> Result<u32> {
        if let Some(&i) = self.groups.index.get(&(node as *const _)) {
            return Ok(i);
        }
        self.object_type(node, &["shapegroup"], &[])?;
        let owner = "<shape type=\"shapegroup\">";
        let (p, children) = self.read_object(node, owner)?;
        p.finish(&mut self.warnings);
        let mut shapes = Vec::with_capacity(children.len());
        for c in children {
            if c.node.tag != "shape" {
                return Err(self.misplaced(&c, owner));
            }
            if is_instancing(c.node) {
                return Err(self.err(
                    c.at,
                    "a shapegroup cannot hold a shapegroup or an instance \
                     (nested instancing is not permitted, as in Mitsuba)",
                ));
            }
            let shape = self.enter(&c, |x| x.shape(c.node))?;
            if shape.area_radiance.is_some() {
                return Err(self.err(
                    c.at,
                    "a shape in a shapegroup cannot be an emitter (Mitsuba does not instance \
                     emitters); declare the emitting shape outside the group",
                ));
            }
            shapes.push(shape);
        }
        let i = self.groups.shapes.len() as u32;
        self.groups.shapes.push(shapes);
        self.groups.index.insert(node as *const _, i);
        Ok(i)
    }

    /// An `instance`: the one shapegroup it references, placed by `to_world`.
    pub(super) fn instance(&mut self, node: &'d SceneNode) -> Result<Instance> {
        self.object_type(node, &["instance"], &[])?;
        let owner = "<shape type=\"instance\">";
        let (mut p, children) = self.read_object(node, owner)?;
        let to_world = p.get_transform("to_world", Transform::IDENTITY)?;
        p.finish(&mut self.warnings);
        let mut group: Option<Child> = None;
        for c in children {
            let is_group = c.node.tag == "shape" && c.node.attr_value("type") == Some("shapegroup");
            if !is_group {
                return Err(self.err(
                    c.at,
                    format!(
                        "{owner} holds only a reference to a shapegroup, found {}",
                        describe(c.node)
                    ),
                ));
            }
            if group.is_some() {
                return Err(self.err(c.at, "an instance references only one shapegroup"));
            }
            group = Some(c);
        }
        let Some(c) = group else {
            return Err(self.err(
                node.pos,
                "an instance needs a shapegroup: add <ref id=\"...\"/> naming one",
            ));
        };
        let group = self.enter(&c, |x| x.shape_group(c.node))?;
        Ok(Instance { group, to_world })
    }
}
