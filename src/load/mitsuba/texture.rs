//! Textures: Mitsuba's constant `uniform` and `srgb` textures, which
//! become property values of the object they stand in.

use super::Ctx;
use crate::load::props::Value;
use crate::load::xml::{describe, SceneNode};
use crate::load::SceneError;

type Result<T> = std::result::Result<T, SceneError>;

impl<'d> Ctx<'d> {
    /// A constant texture as a property value: `uniform` (a float `value`)
    /// or `srgb` (an rgb `color`).
    pub(super) fn texture(&mut self, node: &'d SceneNode) -> Result<Value> {
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
}

/// True for an element that is a texture (or a spectrum given as an object).
pub(super) fn is_texture(node: &SceneNode) -> bool {
    node.tag == "texture" || (node.tag == "spectrum" && node.attr("type").is_some())
}
