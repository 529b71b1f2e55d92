//! Emitters: area, point, spot, projector, directional, constant and envmap.

use super::Ctx;
use crate::color::{Rgb, SpectrumUse};
use crate::emitter::{
    ConstantLight, DirectionalLight, Emitter, EmitterError, EnvFilter, PointLight, Projector,
    ProjectorError, SpotError, SpotLight, TexelRows,
};
use crate::load::objects::{self, EnvMapNames, EnvMapSpec, Texels};
use crate::load::props::Props;
use crate::load::xml::SceneNode;
use crate::load::SceneError;
use crate::math::{Transform, Vec3};
use crate::texture::Texture;

type Result<T> = std::result::Result<T, SceneError>;

/// Mitsuba's names of an environment map's properties.
const MITSUBA_ENVMAP_NAMES: EnvMapNames = EnvMapNames {
    filename: "filename",
    scale: "scale",
    to_world: "to_world",
};

/// An emitter read from the file, before it is placed.
pub(super) enum EmitterDesc {
    /// An area light's radiance: a colour (a constant texture) or a texture.
    Area(crate::texture::Texture),
    Free {
        emitter: Emitter,
        environment: bool,
    },
}

impl<'d> Ctx<'d> {
    /// Mitsuba's `emitters/`: area (radiance, default 1, or a texture), point
    /// (intensity, default 1; position or to_world), directional
    /// (irradiance, default 1; direction or to_world, default +z),
    /// constant (radiance, default 1), envmap (filename, scale, to_world;
    /// Mitsuba's lat-long mapping is lente's, see `emitter/envmap.rs`).
    pub(super) fn emitter(&mut self, node: &'d SceneNode, in_shape: bool) -> Result<EmitterDesc> {
        let ty = self.object_type(
            node,
            &[
                "area",
                "point",
                "spot",
                "projector",
                "directional",
                "constant",
                "envmap",
            ],
            &["sunsky", "sky", "sun", "directionalarea", "smootharea"],
        )?;
        let owner = format!("<emitter type=\"{ty}\">");
        super::MITSUBA.check_emitter_place(self.file(), node, ty, in_shape)?;
        let (mut p, children) = self.read_object(node, &owner)?;
        // Emitted spectra are integrated as they are, not lit by D65.
        p.set_spectrum_use(SpectrumUse::Emission);
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
                EmitterDesc::Area(p.get_texture("radiance", Rgb::ONE)?)
            }
            "point" => {
                both(&p, "position", "to_world")?;
                let position = match p.opt_point("position")? {
                    Some(v) => v,
                    None => p
                        .get_transform("to_world", Transform::IDENTITY)?
                        .point(Vec3::ZERO),
                };
                let intensity = p.get_rgb_or_float("intensity", Rgb::ONE)?;
                let light = PointLight::new(position, intensity).map_err(|e| match e {
                    EmitterError::Position(_) if !p.has("position") => {
                        p.param_error("to_world", &e)
                    }
                    EmitterError::Position(_) => p.param_error("position", &e),
                    _ => p.param_error("intensity", &e),
                })?;
                EmitterDesc::Free {
                    emitter: Emitter::Point(light),
                    environment: false,
                }
            }
            "spot" => {
                let to_world = p.get_transform("to_world", Transform::IDENTITY)?;
                let intensity = p.get_rgb_or_float("intensity", Rgb::ONE)?;
                let cutoff = p.get_float("cutoff_angle", 20.0)?;
                let beam = p.get_float("beam_width", cutoff * 0.75)?;
                let texture = p.opt_texture("texture")?;
                if matches!(texture, Some(Texture::MeshAttribute(_))) {
                    return Err(p.error(
                        "texture",
                        "'texture' cannot be a mesh_attribute: a spot light has no mesh",
                    ));
                }
                if texture.as_ref().is_some_and(|t| !t.is_varying()) {
                    return Err(p.error(
                        "texture",
                        "'texture' must vary over the beam (a bitmap or checkerboard), as \
                         Mitsuba requires; fold a constant into 'intensity'",
                    ));
                }
                let light = SpotLight::new(&to_world, intensity, cutoff, beam, texture).map_err(
                    |e| match e {
                        SpotError::Cutoff(_) => p.param_error("cutoff_angle", &e),
                        SpotError::Beam { .. } => p.param_error("beam_width", &e),
                        SpotError::Texture(_) => p.param_error("texture", &e),
                        SpotError::Emitter(EmitterError::Radiance(_)) => {
                            p.param_error("intensity", &e)
                        }
                        _ => p.param_error("to_world", &e),
                    },
                )?;
                EmitterDesc::Free {
                    emitter: Emitter::Spot(Box::new(light)),
                    environment: false,
                }
            }
            "projector" => {
                let to_world = p.get_transform("to_world", Transform::IDENTITY)?;
                let irradiance = p.get_texture("irradiance", Rgb::ONE)?;
                if matches!(irradiance, Texture::MeshAttribute(_)) {
                    return Err(p.error(
                        "irradiance",
                        "'irradiance' cannot be a mesh_attribute: a projector has no mesh",
                    ));
                }
                let scale = p.get_float("scale", 1.0)?;
                // The image's shape sets the field of view's (Mitsuba reads
                // a constant as 1 x 1).
                let aspect = match &irradiance {
                    Texture::Bitmap(b) => b.image().width() as f64 / b.image().height() as f64,
                    _ => 1.0,
                };
                let (fov_x, _) = super::sensor::horizontal_fov(&mut p, aspect)?;
                let light = Projector::new(&to_world, irradiance, scale, fov_x, aspect as f32)
                    .map_err(|e| match e {
                        ProjectorError::Scale(_) => p.param_error("scale", &e),
                        ProjectorError::Emitter(EmitterError::Radiance(_)) => {
                            p.param_error("irradiance", &e)
                        }
                        _ => p.param_error("to_world", &e),
                    })?;
                EmitterDesc::Free {
                    emitter: Emitter::Projector(Box::new(light)),
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
                let irradiance = p.get_rgb_or_float("irradiance", Rgb::ONE)?;
                let light = DirectionalLight::new(d, irradiance).map_err(|e| match e {
                    EmitterError::Direction(_) if !p.has("direction") => {
                        p.param_error("to_world", &e)
                    }
                    EmitterError::Direction(_) => p.param_error("direction", &e),
                    _ => p.param_error("irradiance", &e),
                })?;
                EmitterDesc::Free {
                    emitter: Emitter::Directional(light),
                    environment: false,
                }
            }
            "constant" => {
                let radiance = p.get_rgb_or_float("radiance", Rgb::ONE)?;
                let light =
                    ConstantLight::new(radiance).map_err(|e| p.param_error("radiance", &e))?;
                EmitterDesc::Free {
                    emitter: Emitter::Constant(light),
                    environment: true,
                }
            }
            _ => {
                let name = p.require_string("filename")?;
                if name.trim().is_empty() {
                    return Err(p.error("filename", "'filename' is empty"));
                }
                let spec = EnvMapSpec {
                    texels: Texels::File(self.resolve(&name)),
                    tint: Rgb::ONE,
                    scale: p.get_float("scale", 1.0)?,
                    to_world: p.get_transform("to_world", Transform::IDENTITY)?,
                    filter: EnvFilter::Bilinear,
                    rows: TexelRows::PoleToPole,
                };
                let env = objects::envmap(&p, &MITSUBA_ENVMAP_NAMES, spec, &mut self.warnings)?;
                p.finish(&mut self.warnings);
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
