//! The Nori forks' `<texture type="..." name="...">` children, which set
//! a colour or a number of the object they stand in (README, "Nori
//! forks"):
//!
//! - ETH Zurich's course framework: `checkerboard_color`,
//!   `checkerboard_float` (`value1`, `value2`, `scale` and `delta` as two
//!   numbers), `constant_color`, `constant_float` (`value`), and the
//!   students' `image_texture` (an 8-bit image, nearest texel, v
//!   reversed, `scale` and `shift`, sRGB-decoded unless `linear_rgb` is
//!   false);
//! - the Universidad de Zaragoza fork: `checker` (`scalex`, `scaley`
//!   integers; its squares are 0.9 and 0.1, and its `color`, read for both,
//!   makes the texture uniform) and `textmap` (an 8-bit image read as it
//!   is, without sRGB decoding, times `color`; bilinear between texel
//!   corners, u and v both reversed, repeated).

use std::path::Path;
use std::sync::Arc;

use super::objects::TextureImages;
use super::props::{int_in, non_negative, Props};
use super::reader::{check_attributes, Dialect};
use super::xml::{Pos, SceneNode};
use super::{SceneError, Warning};
use crate::color::Rgb;
use crate::image::io::Transfer;
use crate::math::Vec2;
use crate::texture::{
    BitmapTexture, CheckerRule, FilterType, NoriChecker, Texture, UvTransform, WrapMode,
};

type Result<T> = std::result::Result<T, SceneError>;

/// The texture types lente reads in Nori files.
pub(super) const TEXTURE_TYPES: &[&str] = &[
    "checkerboard_color",
    "checkerboard_float",
    "constant_color",
    "constant_float",
    "checker",
    "textmap",
    "image_texture",
];

/// A texture child: the property it sets, where, and its value.
pub(super) struct NamedTexture {
    pub name: String,
    pub pos: Pos,
    pub texture: Texture,
    /// One of ETH's types.
    pub eth: bool,
}

/// Reads a `<texture>` element (a `type` and the `name` of the property
/// it sets); relative file names are resolved against `dir`.
pub(super) fn read_texture(
    dialect: &Dialect,
    file: &Path,
    dir: &Path,
    node: &SceneNode,
    images: &mut TextureImages,
    warnings: &mut Vec<Warning>,
) -> Result<NamedTexture> {
    check_attributes(file, node, &["type", "name"], &["type", "name"])?;
    let ty = dialect.type_of(file, node, TEXTURE_TYPES, &[], &|_| None)?;
    let name = node.attr_value("name").unwrap_or_default().to_string();
    let owner = format!("<texture type=\"{ty}\" name=\"{name}\">");
    let (mut p, children) = dialect.read_object(file, node, &owner, &super::reader::no_special)?;
    if let Some(ch) = children.first() {
        return Err(super::reader::misplaced(file, ch, ch.pos, &owner, ""));
    }
    let texture = match ty {
        "checkerboard_color" | "checkerboard_float" => eth_checkerboard(&mut p, ty)?,
        "constant_color" => Texture::Constant(p.get_rgb("value", Rgb::ZERO)?),
        "constant_float" => Texture::Constant(Rgb::splat(non_negative(&mut p, "value", 0.0)?)),
        "checker" => zaragoza_checker(&mut p)?,
        "image_texture" => eth_image_texture(&mut p, dir, images, warnings)?,
        _ => textmap(&mut p, dir, images, warnings)?,
    };
    p.finish(warnings);
    Ok(NamedTexture {
        name,
        pos: node.pos,
        texture,
        eth: !matches!(ty, "checker" | "textmap"),
    })
}

/// ETH's `Checkerboard<T>`: `value1` where the squares' parities agree,
/// `value2` where they differ (defaults 0 and 1), as the course's
/// reference images have it (students' own versions vary).
fn eth_checkerboard(p: &mut Props, ty: &str) -> Result<Texture> {
    let (value1, value2) = if ty == "checkerboard_color" {
        (
            p.get_rgb("value1", Rgb::ZERO)?,
            p.get_rgb("value2", Rgb::ONE)?,
        )
    } else {
        (
            Rgb::splat(non_negative(p, "value1", 0.0)?),
            Rgb::splat(non_negative(p, "value2", 1.0)?),
        )
    };
    let delta = p.get_pair("delta", Vec2::ZERO)?;
    let scale = p.get_pair("scale", Vec2::ONE)?;
    if scale.x == 0.0 || scale.y == 0.0 {
        return Err(p.error(
            "scale",
            format!(
                "'scale' is the size of a square and cannot be 0, found {} {}",
                scale.x, scale.y
            ),
        ));
    }
    Ok(Texture::NoriChecker(NoriChecker {
        scale: Vec2::ONE / scale,
        offset: -delta,
        rule: CheckerRule::Eth,
        same: value1,
        differ: value2,
    }))
}

/// The forks' image textures read 8-bit files only (stb_image's and
/// their own LDR loaders): an error at `filename` for any other extension.
fn eight_bit_only(p: &Props, path: &Path, name: &str, reader: &str) -> Result<()> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or_default()
        .to_ascii_lowercase();
    if matches!(ext.as_str(), "png" | "jpg" | "jpeg" | "bmp") {
        return Ok(());
    }
    Err(p.error(
        "filename",
        format!("{reader} reads 8-bit images (PNG, JPEG, BMP), found '{name}'"),
    ))
}

/// The ETH students' `image_texture` (e.g. gianluca-m's
/// `src/image_texture.cpp`): texel (int(u W sx + shift_x W) mod W,
/// int((1 - v) H sy + shift_y H) mod H) from the top row, no filtering,
/// decoded from sRGB when `linear_rgb` (default true). The fork's C `%`
/// keeps the sign of negative coordinates (reading outside the image);
/// lente repeats the image there.
fn eth_image_texture(
    p: &mut Props,
    dir: &Path,
    images: &mut TextureImages,
    warnings: &mut Vec<Warning>,
) -> Result<Texture> {
    let scale = p.get_pair("scale", Vec2::ONE)?;
    let shift = p.get_pair("shift", Vec2::ZERO)?;
    let srgb = p.get_bool("linear_rgb", true)?;
    let name = p.require_string("filename")?;
    let path = dir.join(name.trim());
    eight_bit_only(p, &path, &name, "image_texture")?;
    let transfer = if srgb { Transfer::Srgb } else { Transfer::Raw };
    let image = images.load(p, "filename", path, transfer, warnings)?;
    Ok(Texture::Bitmap(BitmapTexture::new(
        image,
        FilterType::Nearest,
        WrapMode::Repeat,
        UvTransform {
            row0: [scale.x, 0.0, shift.x],
            row1: [0.0, -scale.y, scale.y + shift.y],
        },
    )))
}

/// The Zaragoza fork's `checker`.
fn zaragoza_checker(p: &mut Props) -> Result<Texture> {
    const LIMIT: i64 = 1 << 24;
    let scale = Vec2::new(
        int_in(p, "scalex", 1, -LIMIT, LIMIT)? as f32,
        int_in(p, "scaley", 1, -LIMIT, LIMIT)? as f32,
    );
    let (same, differ) = match p.opt_rgb("color")? {
        Some(c) => {
            p.warn(
                "color",
                "the Zaragoza fork's checker reads 'color' for both of its squares, so the \
                 texture is this one colour everywhere (as there); leave 'color' out for its \
                 0.9 and 0.1 squares",
            );
            (c, c)
        }
        None => (Rgb::splat(0.9), Rgb::splat(0.1)),
    };
    Ok(Texture::NoriChecker(NoriChecker {
        scale,
        offset: Vec2::ZERO,
        rule: CheckerRule::Zaragoza,
        same,
        differ,
    }))
}

/// The Zaragoza fork's `textmap`; without a `filename` it is its `color`.
fn textmap(
    p: &mut Props,
    dir: &Path,
    images: &mut TextureImages,
    warnings: &mut Vec<Warning>,
) -> Result<Texture> {
    let color = p.get_rgb("color", Rgb::ONE)?;
    for axis in ["scalex", "scaley"] {
        if p.has(axis) {
            let _ = p.get_float(axis, 1.0)?;
            p.warn(
                axis,
                format!("the Zaragoza fork's textmap reads '{axis}' but never applies it; so does lente"),
            );
        }
    }
    let Some(name) = p.opt_string("filename")? else {
        return Ok(Texture::Constant(color));
    };
    if name.trim().is_empty() {
        return Err(p.error("filename", "'filename' is empty"));
    }
    let path = dir.join(&name);
    eight_bit_only(p, &path, &name, "the Zaragoza fork's textmap")?;
    let image = images.load(p, "filename", path, Transfer::Raw, warnings)?;
    let image = if color == Rgb::ONE {
        image
    } else {
        Arc::new(image.map(|t| t * color))
    };
    // The fork reads texel (x, y) at x = (1 - u) w, y = (1 - v) h and
    // interpolates towards x + 1, y + 1; lente's bilinear lookup is
    // centred on texels, hence the half-texel shift.
    let (w, h) = (image.width() as f32, image.height() as f32);
    let to_uv = UvTransform {
        row0: [-1.0, 0.0, 1.0 + 0.5 / w],
        row1: [0.0, -1.0, 1.0 + 0.5 / h],
    };
    Ok(Texture::Bitmap(BitmapTexture::new(
        image,
        FilterType::Bilinear,
        WrapMode::Repeat,
        to_uv,
    )))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::texture::TextureImage;

    /// ETH's ImageTexture::eval, written out, against the lookup
    /// `image_texture` builds (scale 2 x 1.5, shift 0.25 x 0.1) on a 3x2
    /// image, at uv off the texel edges.
    #[test]
    fn image_texture_reads_texels_as_eth() {
        let texels: Vec<Rgb> = (0..6).map(|i| Rgb::splat(i as f32)).collect();
        let bitmap = crate::image::Bitmap {
            width: 3,
            height: 2,
            pixels: texels.clone(),
        };
        let image = Arc::new(TextureImage::new(bitmap));
        let (scale, shift) = (Vec2::new(2.0, 1.5), Vec2::new(0.25, 0.1));
        let tex = BitmapTexture::new(
            image,
            FilterType::Nearest,
            WrapMode::Repeat,
            UvTransform {
                row0: [scale.x, 0.0, shift.x],
                row1: [0.0, -scale.y, scale.y + shift.y],
            },
        );
        let eth = |u: f32, v: f32| {
            let x = ((u * 3.0 * scale.x + shift.x * 3.0) as i32) % 3;
            let y = (((1.0 - v) * 2.0 * scale.y + shift.y * 2.0) as i32) % 2;
            texels[(x + y * 3) as usize]
        };
        for i in 0..40 {
            for j in 0..40 {
                let (u, v) = ((i as f32 + 0.37) / 40.0, (j as f32 + 0.61) / 40.0);
                assert_eq!(tex.eval(Vec2::new(u, v)), eth(u, v), "({u}, {v})");
            }
        }
    }

    /// The fork's LDRBitmap::eval, written out, against the lookup
    /// `textmap` builds: equal on a 3x2 image over uv in [0, 1]^2.
    #[test]
    fn textmap_reads_texels_as_the_zaragoza_fork() {
        let texels: Vec<Rgb> = (0..6)
            .map(|i| Rgb::new(i as f32 / 8.0, 0.5, 1.0 - i as f32 / 8.0))
            .collect();
        let bitmap = crate::image::Bitmap {
            width: 3,
            height: 2,
            pixels: texels.clone(),
        };
        let image = Arc::new(TextureImage::new(bitmap));
        let tex = BitmapTexture::new(
            image,
            FilterType::Bilinear,
            WrapMode::Repeat,
            UvTransform {
                row0: [-1.0, 0.0, 1.0 + 0.5 / 3.0],
                row1: [0.0, -1.0, 1.0 + 0.5 / 2.0],
            },
        );
        let fork = |u: f32, v: f32| {
            let (x, y) = ((1.0 - u) * 3.0, (1.0 - v) * 2.0);
            let (ix, iy) = (x as i32, y as i32);
            let (wx, wy) = (x - ix as f32, y - iy as f32);
            let at = |i: i32, j: i32| texels[(j.rem_euclid(2) * 3 + i.rem_euclid(3)) as usize];
            at(ix, iy) * ((1.0 - wx) * (1.0 - wy))
                + at(ix + 1, iy) * (wx * (1.0 - wy))
                + at(ix, iy + 1) * ((1.0 - wx) * wy)
                + at(ix + 1, iy + 1) * (wx * wy)
        };
        for i in 0..=20 {
            for j in 0..=20 {
                let (u, v) = (i as f32 / 20.0, j as f32 / 20.0);
                let (a, b) = (tex.eval(Vec2::new(u, v)), fork(u, v));
                assert!((a - b).abs().max_element() < 1e-5, "({u}, {v}): {a} vs {b}");
            }
        }
    }
}
