//! Scene objects both dialects build the same way from their properties:
//! environment maps (the image is read once, here, and [`EnvMap::new`]
//! checks the map), spheres, and the names of filter parameters. Errors point at the property that names
//! the wrong value.

use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::Arc;

use super::props::Props;
use super::{SceneError, Warning};
use crate::color::Rgb;
use crate::emitter::{EnvFilter, EnvMap, EnvMapParam, TexelRows};
use crate::geometry::{Sphere, SphereError};
use crate::image::io::Transfer;
use crate::image::{Bitmap, FilterParam};
use crate::math::{Transform, Vec3};
use crate::texture::TextureImage;

/// Where a map's texels come from.
pub(crate) enum Texels {
    /// An image file.
    File(PathBuf),
    /// An image made in memory (the built-in sky).
    Image(Bitmap),
}

/// A dialect's names of an environment map's properties.
pub(crate) struct EnvMapNames {
    pub filename: &'static str,
    pub scale: &'static str,
    pub to_world: &'static str,
}

/// What a scene file says about an environment map.
pub(crate) struct EnvMapSpec {
    pub texels: Texels,
    /// Per-channel multiplier of the texels (the Zaragoza fork's
    /// `radiance`; one for everyone else).
    pub tint: Rgb,
    pub scale: f32,
    pub to_world: Transform,
    pub filter: EnvFilter,
    /// Where the dialect puts texel rows.
    pub rows: TexelRows,
}

/// Builds the map; the image's warnings go to `warnings` at the object.
pub(crate) fn envmap(
    p: &Props,
    names: &EnvMapNames,
    spec: EnvMapSpec,
    warnings: &mut Vec<Warning>,
) -> Result<EnvMap, SceneError> {
    let mut image = match spec.texels {
        Texels::Image(image) => image,
        Texels::File(path) => {
            let (image, image_warnings) = crate::image::io::load_image(&path).map_err(|e| {
                p.error(names.filename, "cannot load the environment map")
                    .caused_by(e)
            })?;
            for w in image_warnings {
                warnings.push(p.object_warning(format!("{}: {w}", path.display())));
            }
            image
        }
    };
    if spec.tint != Rgb::ONE {
        for px in &mut image.pixels {
            *px *= spec.tint;
        }
    }
    EnvMap::new(image, spec.scale, spec.to_world, spec.filter, spec.rows).map_err(|e| {
        match e.param() {
            EnvMapParam::Image => p.error(names.filename, format!("the environment map {e}")),
            EnvMapParam::Scale => p.param_error(names.scale, &e),
            EnvMapParam::ToWorld => p.param_error(names.to_world, &e),
        }
    })
}

/// A sphere from `center` (default the origin) and `radius` (default 1),
/// the names both dialects use.
pub(crate) fn sphere(p: &mut Props) -> Result<Sphere, SceneError> {
    let center = p.get_point("center", Vec3::ZERO)?;
    let radius = p.get_float("radius", 1.0)?;
    Sphere::new(center, radius).map_err(|e| match e {
        SphereError::Radius(_) => p.param_error("radius", &e),
        _ => p.param_error("center", &e),
    })
}

/// The name of a filter parameter (Nori's and Mitsuba's).
pub(crate) fn filter_name(param: FilterParam) -> &'static str {
    match param {
        FilterParam::Radius => "radius",
        FilterParam::Stddev => "stddev",
        FilterParam::B => "B",
        FilterParam::C => "C",
    }
}

/// Images read for textures, by file and transfer: textures that name one
/// file share its texels.
#[derive(Default)]
pub(crate) struct TextureImages(HashMap<(PathBuf, Transfer), Arc<TextureImage>>);

impl TextureImages {
    /// The texels of `path` (read once per file and transfer); errors and
    /// the image's warnings point at property `filename` of `p`.
    pub(crate) fn load(
        &mut self,
        p: &Props,
        filename: &str,
        path: PathBuf,
        transfer: Transfer,
        warnings: &mut Vec<Warning>,
    ) -> Result<Arc<TextureImage>, SceneError> {
        let key = (std::fs::canonicalize(&path).unwrap_or(path), transfer);
        if let Some(image) = self.0.get(&key) {
            return Ok(image.clone());
        }
        let (image, image_warnings) = crate::image::io::load_image_as(&key.0, transfer)
            .map_err(|e| p.error(filename, "cannot load the texture").caused_by(e))?;
        for w in image_warnings {
            warnings.push(p.object_warning(format!("{}: {w}", key.0.display())));
        }
        let image = Arc::new(TextureImage::new(image));
        self.0.insert(key, image.clone());
        Ok(image)
    }
}
