//! Textures: Mitsuba's constant `uniform` and `srgb` textures, which
//! become property values of the object they stand in, and the varying
//! `bitmap` and `checkerboard` (`textures/*.cpp`: names, defaults).

use super::Ctx;
use crate::image::io::Transfer;
use crate::load::props::{Kind, Props, Value};
use crate::load::xml::{describe, SceneNode};
use crate::load::SceneError;
use crate::math::{Transform, Vec3};
use crate::texture::{
    BitmapTexture, Checkerboard, FilterType, MeshAttributeTexture, Texture, UvTransform, WrapMode,
};

type Result<T> = std::result::Result<T, SceneError>;

impl<'d> Ctx<'d> {
    /// A texture as a property value: `uniform` (a float `value`) and
    /// `srgb` (an rgb `color`) as constants, `bitmap` and `checkerboard`
    /// as textures.
    pub(super) fn texture(&mut self, node: &'d SceneNode) -> Result<Value> {
        let ty = self
            .object_type(
                node,
                &[
                    "uniform",
                    "srgb",
                    "rawconstant",
                    "bitmap",
                    "checkerboard",
                    "mesh_attribute",
                    "blackbody",
                    "regular",
                    "irregular",
                    "d65",
                ],
                &["volume"],
            )
            .map_err(|mut e| {
                e.message
                    .push_str(" (lente's textures: bitmap, checkerboard, mesh_attribute, uniform, srgb, rawconstant; spectra: blackbody, regular, irregular, d65)");
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
            "srgb" => {
                let c = p.require_rgb("color")?;
                p.get_bool("unbounded", false)?;
                Value::Color(c)
            }
            "rawconstant" => raw_constant(&mut p)?,
            "blackbody" | "regular" | "irregular" | "d65" => {
                super::spectrum::spectrum_object(ty, &mut p)?
            }
            "checkerboard" => Value::Texture(Texture::Checkerboard(Checkerboard {
                color0: constant(&mut p, "color0", 0.4)?,
                color1: constant(&mut p, "color1", 0.2)?,
                to_uv: to_uv(&mut p)?,
            })),
            "mesh_attribute" => {
                let name = p.require_string("name")?;
                if !(name.starts_with("vertex_") || name.starts_with("face_")) {
                    return Err(p.error(
                        "name",
                        format!(
                            "a mesh attribute's 'name' starts with 'vertex_' or 'face_' \
                             (e.g. vertex_color), found '{name}'"
                        ),
                    ));
                }
                let scale = p.get_float("scale", 1.0)?;
                if !scale.is_finite() {
                    return Err(p.error("scale", format!("'scale' must be finite, found {scale}")));
                }
                Value::Texture(Texture::MeshAttribute(Box::new(MeshAttributeTexture::new(
                    name, scale,
                ))))
            }
            _ => Value::Texture(Texture::Bitmap(self.bitmap(&mut p)?)),
        };
        p.finish(&mut self.warnings);
        Ok(value)
    }

    /// `bitmap`: `filename`, `filter_type` (bilinear), `wrap_mode`
    /// (repeat), `raw` (false: 8- and 16-bit files are sRGB-decoded),
    /// `to_uv`. Texels are shared between textures naming one file.
    fn bitmap(&mut self, p: &mut Props<'d>) -> Result<BitmapTexture> {
        let name = p.require_string("filename")?;
        if name.trim().is_empty() {
            return Err(p.error("filename", "'filename' is empty"));
        }
        let filter = match p.get_string("filter_type", "bilinear".into())?.as_str() {
            "bilinear" => FilterType::Bilinear,
            "nearest" => FilterType::Nearest,
            other => {
                return Err(p.error(
                    "filter_type",
                    format!("unknown filter_type '{other}'; use bilinear or nearest"),
                ))
            }
        };
        let wrap = wrap_mode(p, WrapMode::Repeat)?;
        let transfer = if p.get_bool("raw", false)? {
            Transfer::Raw
        } else {
            Transfer::Srgb
        };
        // Storage hints with no effect on the image.
        p.get_bool("accel", true)?;
        p.get_string("format", "variant".into())?;
        let to_uv = to_uv(p)?;
        let path = self.resolve(&name);
        let image = self
            .texture_images
            .load(p, "filename", path, transfer, &mut self.warnings)?;
        Ok(BitmapTexture::new(image, filter, wrap, to_uv))
    }
}

/// `wrap_mode` of bitmaps and grid volumes (`default` when absent); an
/// unknown one is an error listing the modes, the default first.
pub(super) fn wrap_mode(p: &mut Props, default: WrapMode) -> Result<WrapMode> {
    const MODES: [(&str, WrapMode); 3] = [
        ("repeat", WrapMode::Repeat),
        ("mirror", WrapMode::Mirror),
        ("clamp", WrapMode::Clamp),
    ];
    let name = |mode: WrapMode| MODES.iter().find(|m| m.1 == mode).map_or("", |m| m.0);
    let given = p.get_string("wrap_mode", name(default).into())?;
    if let Some(&(_, mode)) = MODES.iter().find(|m| m.0 == given) {
        return Ok(mode);
    }
    let others: Vec<&str> = MODES
        .iter()
        .filter(|m| m.1 != default)
        .map(|m| m.0)
        .collect();
    Err(p.error(
        "wrap_mode",
        format!(
            "unknown wrap_mode '{given}'; use {}, {} or {}",
            name(default),
            others[0],
            others[1]
        ),
    ))
}

/// `rawconstant` (`spectra/rawconstant.cpp`): a float or a 3-vector
/// `value` taken as it is, with no colour conversion (a constant normal
/// map, say).
fn raw_constant(p: &mut Props) -> Result<Value> {
    match p.kind_of("value") {
        Some(Kind::Float) => Ok(Value::Float(p.require_float("value")?)),
        Some(kind @ (Kind::Vector | Kind::Point)) => {
            let v = if kind == Kind::Vector {
                p.opt_vector("value")?
            } else {
                p.opt_point("value")?
            };
            let v = v.unwrap_or(Vec3::ZERO);
            Ok(Value::Color(crate::color::Rgb::new(v.x, v.y, v.z)))
        }
        Some(other) => Err(p.error(
            "value",
            format!(
                "a rawconstant's 'value' is a float or a vector, found a {}",
                other.name()
            ),
        )),
        None => Err(p.object_error("a rawconstant needs a 'value' (a float or a vector)")),
    }
}

/// A constant colour or number (a checkerboard's colours).
fn constant(p: &mut Props, name: &str, default: f32) -> Result<crate::color::Rgb> {
    match p
        .get_texture(name, crate::color::Rgb::splat(default))?
        .constant()
    {
        Some(c) => Ok(c),
        None => Err(p.error(
            name,
            format!(
                "'{name}' must be a constant colour or number (nested textures are not supported)"
            ),
        )),
    }
}

/// `to_uv` (identity): the 2D part of the transform.
fn to_uv(p: &mut Props) -> Result<UvTransform> {
    let t = p.get_transform("to_uv", Transform::IDENTITY)?;
    Ok(UvTransform::from_mat4(&t.m))
}

/// True for an element that is a texture (or a spectrum given as an object).
pub(super) fn is_texture(node: &SceneNode) -> bool {
    node.tag == "texture" || (node.tag == "spectrum" && node.attr("type").is_some())
}
