//! Nori's XML dialect.
//!
//! Maps wjakob/nori's element and property names, with Nori's defaults,
//! onto lente's scene objects. The rules of the file format (which object
//! may stand where, how properties and transforms are written) are Nori's;
//! the emitters Nori leaves to its students (point, area, environment) use
//! the names its assignments use, plus lente's own `sky`.
//!
//! The forks students use spell some of those differently, and lente reads
//! them too (README, "Nori forks"): ETH Zurich's `<emitter type="point">`
//! with `power` in watts; the Universidad de Zaragoza fork's
//! `<emitter type="pointlight">` with `radiance` (a radiant intensity, W/sr),
//! its `<emitter type="environment">` (`filename` optional, `radiance` a
//! colour multiplier) and its `direct_whitted` integrator. Where a name is
//! read differently by different forks, lente picks one reading and warns
//! when the other is likely; names another fork reads and lente does not
//! get a warning (or, for whole object types, an error) naming that fork.

use std::path::{Path, PathBuf};

use super::nori_texture::{read_texture, NamedTexture};
use super::objects::{self, EnvMapNames, EnvMapSpec, Texels, TextureImages};
use super::props::{int_in, non_negative};
use super::props::{Kind, Props};
use super::reader::{self, Dialect, LookAtError};
use super::xml::{Pos, SceneNode};
use super::{SceneError, SceneFile, Warning};
use crate::bsdf::{Bsdf, BsdfParam, Mirror, RoughSubstrate, SchlickConductor};
use crate::camera::{Aperture, CameraParam, CameraParams, MAX_RESOLUTION};
use crate::color::Rgb;
use crate::emitter::sky::{bake_sky, SkyParams};
use crate::emitter::{
    ConstantLight, DirectionalLight, Emitter, EmitterError, EnvFilter, PointLight, TexelRows,
};
use crate::geometry::{load_obj, Geometry, Sphere, SphereUv};
use crate::image::Filter;
use crate::integrator::{Integrator, PathParams, Strategy};
use crate::math::{Mat4, Transform, Vec3, PI};
use crate::render::RenderJob;
use crate::sampling::SamplerKind;
use crate::scene::{SceneDesc, ShapeDesc};
use crate::texture::Texture;

type Result<T> = std::result::Result<T, SceneError>;

/// Nori's vocabulary for the shared object reader.
static NORI: Dialect = Dialect {
    object_tags: &[
        "scene",
        "mesh",
        "bsdf",
        "emitter",
        "camera",
        "integrator",
        "sampler",
        "rfilter",
        "test",
        "medium",
        "phase",
    ],
    typed_property_objects: &[],
    property_tags: &[
        "boolean",
        "integer",
        "float",
        "string",
        "point",
        "vector",
        "color",
        "transform",
    ],
    transform_ops: &["translate", "matrix", "rotate", "scale", "lookat"],
    scene_only: &[],
    // Textures take a `name` too: read by nori_texture.
    other_tags: &["texture"],
    object_attributes: &["type"],
    color_tag: "color",
    xyz_attributes: false,
    matrix3: false,
    pairs: true,
    look_at,
    shape_tag: "mesh",
    element_hints: &[
        ("rgb", "that is Mitsuba's; Nori writes <color>"),
        ("shape", "that is Mitsuba's; Nori writes <mesh>"),
        ("sensor", "that is Mitsuba's; Nori writes <camera>"),
    ],
};

const CAMERA_TYPES: &[&str] = &["perspective", "thinlens"];
const SAMPLER_TYPES: &[&str] = &["independent"];
const INTEGRATOR_TYPES: &[&str] = &[
    "normals",
    "ao",
    "av",
    "simple",
    "whitted",
    "direct",
    "direct_ems",
    "direct_mats",
    "direct_mis",
    "direct_whitted",
    "path_mats",
    "path_ems",
    "path_mis",
    "path",
    "photonmapper",
];
const MESH_TYPES: &[&str] = &["obj", "sphere"];
const BSDF_TYPES: &[&str] = &[
    "diffuse",
    "mirror",
    "dielectric",
    "microfacet",
    "roughconductor",
    "roughsubstrate",
];
/// `filename` value of an environment emitter that means the built-in
/// procedural sky (Preetham, turbidity 3, sun at 45 degrees elevation).
pub const BUILTIN_SKY: &str = "@sky";
/// Display exposure applied to the built-in sky (its native unit is
/// 10^4 cd/m^2, which would overexpose a scene meant for light probes).
pub const BUILTIN_SKY_EXPOSURE: f32 = 0.35;

const EMITTER_TYPES: &[&str] = &[
    "area",
    "point",
    "pointlight",
    "directional",
    "environment",
    "envmap",
    "constant",
    "sky",
];

/// Where the Zaragoza fork's `pointlight` stands when it has no `position`.
pub const ZARAGOZA_POINT_POSITION: Vec3 = Vec3::new(0.0, 100.0, 0.0);

/// Object types other Nori forks define and lente does not.
const FORK_TYPES: &[&str] = &["roughdielectric", "depth"];

/// Object types other Nori forks define and lente does not: what they are
/// there, and what to use instead (appended to the unknown-type error).
fn fork_type_hint(tag: &str, ty: &str) -> Option<&'static str> {
    Some(match (tag, ty) {
        ("bsdf", "roughdielectric") => {
            "'roughdielectric' is the Zaragoza fork's rough glass; lente reads rough \
             glass only from Mitsuba 3 scenes"
        }
        ("integrator", "depth") => {
            "'depth' is the Zaragoza fork's first assignment; lente has no depth integrator"
        }
        _ => return None,
    })
}

const RFILTER_TYPES: &[&str] = &["gaussian", "box", "tent", "mitchell"];

/// Builds a scene from a Nori `<scene>` element.
pub fn load(root: &SceneNode, file: &Path) -> Result<(SceneFile, Vec<Warning>)> {
    let mut ctx = Ctx::new(file);
    let desc = ctx.scene(root)?;
    Ok((desc, ctx.warnings))
}

/// Reads a `<bsdf>` element on its own (the BSDFs of a test file), with
/// relative paths resolved against `file`'s folder.
pub(crate) fn load_bsdf(node: &SceneNode, file: &Path) -> Result<(Bsdf, Vec<Warning>)> {
    let mut ctx = Ctx::new(file);
    let bsdf = ctx.bsdf(node)?;
    Ok((bsdf, ctx.warnings))
}

/// Reads the property elements of an object Nori's scene builder does not
/// know (a `<test>`): its properties, and its child objects in document
/// order for the caller to place. Errors as for any object.
pub(crate) fn read_object<'a, 'n>(
    node: &'n SceneNode,
    file: &'a Path,
    owner: &str,
) -> Result<(Props<'a>, Vec<&'n SceneNode>)> {
    NORI.read_object(file, node, owner, &reader::no_special)
}

/// Checks that an object element has only a `type` attribute, one of
/// `known`, and returns it.
pub(crate) fn object_type<'n>(node: &'n SceneNode, file: &Path, known: &[&str]) -> Result<&'n str> {
    NORI.object_type(file, node, known, &[], &|_| None)
}

struct Ctx<'a> {
    file: &'a Path,
    /// Relative file names are resolved against this folder.
    dir: PathBuf,
    warnings: Vec<Warning>,
    /// Images read for `textmap` textures, shared by file.
    texture_images: TextureImages,
    /// The ETH camera warning was given.
    eth_warned: bool,
}

/// A camera with its filter and the sampler nested in it, if any.
type CameraDesc = (CameraParams, Filter, Option<(u32, Pos)>);

/// An emitter read from the file, before it is placed.
enum EmitterDesc {
    /// An area emitter's radiance, and its texture if it varies.
    Area(Rgb, Option<Texture>),
    Free {
        emitter: Emitter,
        environment: bool,
    },
}

impl<'a> Ctx<'a> {
    fn new(file: &'a Path) -> Ctx<'a> {
        let dir = match file.parent() {
            Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
            _ => PathBuf::from("."),
        };
        Ctx {
            file,
            dir,
            warnings: Vec::new(),
            texture_images: TextureImages::default(),
            eth_warned: false,
        }
    }

    fn err(&self, pos: Pos, message: impl Into<String>) -> SceneError {
        SceneError::new(self.file, pos, message)
    }

    fn warn(&mut self, pos: Pos, message: impl Into<String>) {
        self.warnings.push(Warning::new(self.file, pos, message));
    }

    /// Reads an object's property elements; returns them and its child
    /// objects in document order.
    fn read_object<'n>(
        &mut self,
        node: &'n SceneNode,
        owner: &str,
    ) -> Result<(Props<'a>, Vec<&'n SceneNode>)> {
        NORI.read_object(self.file, node, owner, &reader::no_special)
    }

    /// Checks an object element's attributes and returns its type.
    fn object_type<'n>(&self, node: &'n SceneNode, known: &[&str]) -> Result<&'n str> {
        NORI.object_type(self.file, node, known, FORK_TYPES, &|ty| {
            fork_type_hint(&node.tag, ty)
        })
    }

    fn scene(&mut self, root: &SceneNode) -> Result<SceneFile> {
        reader::check_attributes(self.file, root, &[], &[])?;
        let (props, objects) = self.read_object(root, "<scene>")?;
        props.finish(&mut self.warnings);

        let mut camera: Option<(CameraParams, Filter, Pos)> = None;
        let mut sampler: Option<(u32, Pos)> = None;
        let mut integrator: Option<(Integrator, Pos)> = None;
        let mut shapes = Vec::new();
        let mut emitters = Vec::new();
        let mut environment: Option<Pos> = None;
        // A light not on a shape; at most one environment.
        let mut handle_free = |ctx: &mut Self, desc: EmitterDesc, at: Pos| -> Result<()> {
            let EmitterDesc::Free {
                emitter,
                environment: env,
            } = desc
            else {
                unreachable!("checked by emitter()")
            };
            if env {
                if let Some(first) = environment {
                    return Err(ctx.err(
                        at,
                        format!(
                            "a scene can have at most one environment emitter \
                             (environment, envmap, sky or constant); the first is at {first}"
                        ),
                    ));
                }
                environment = Some(at);
            }
            emitters.push(emitter);
            Ok(())
        };
        for node in objects {
            match node.tag.as_str() {
                "camera" => {
                    if let Some((_, _, first)) = &camera {
                        return Err(self.err(
                            node.pos,
                            format!("a scene can have only one <camera> (the first is at {first})"),
                        ));
                    }
                    let (params, filter, nested) = self.camera(node)?;
                    if let Some((spp, pos)) = nested {
                        set_sampler(self, &mut sampler, spp, pos)?;
                    }
                    camera = Some((params, filter, node.pos));
                }
                "sampler" => {
                    let spp = self.sampler(node)?;
                    set_sampler(self, &mut sampler, spp, node.pos)?;
                }
                "integrator" => {
                    if let Some((_, first)) = &integrator {
                        return Err(self.err(
                            node.pos,
                            format!(
                                "a scene can have only one <integrator> (the first is at {first})"
                            ),
                        ));
                    }
                    integrator = Some((self.integrator(node)?, node.pos));
                }
                "mesh" => match self.environment_in_mesh(node)? {
                    None => shapes.push(self.mesh(node)?),
                    Some(env) => handle_free(self, env, node.pos)?,
                },
                "emitter" => match self.emitter(node, false)? {
                    free @ EmitterDesc::Free { .. } => handle_free(self, free, node.pos)?,
                    EmitterDesc::Area(..) => unreachable!("checked by emitter()"),
                },
                _ => return Err(self.misplaced(node, "<scene>")),
            }
        }
        let Some((camera, filter, _)) = camera else {
            return Err(self.err(root.pos, "the scene has no <camera>"));
        };
        let Some((integrator, _)) = integrator else {
            return Err(self.err(root.pos, "the scene has no <integrator>"));
        };
        Ok(SceneFile {
            scene: SceneDesc {
                camera,
                shapes,
                emitters,
                groups: Vec::new(),
                instances: Vec::new(),
                media: Vec::new(),
                camera_medium: None,
            },
            job: RenderJob {
                integrator,
                spp: sampler.map_or(1, |s| s.0),
                sampler: SamplerKind::Independent,
                filter,
                aovs: Default::default(),
            },
        })
    }

    /// The error for an object element that may not stand inside `parent`.
    fn misplaced(&self, node: &SceneNode, parent: &str) -> SceneError {
        let hint = match node.tag.as_str() {
            "bsdf" => "; a <bsdf> belongs inside a <mesh>",
            "rfilter" => "; an <rfilter> belongs inside the <camera>",
            "scene" => "; <scene> can only be the root element",
            "test" => "; <test> can only be the root element of a test file",
            "medium" | "phase" => "; participating media are not supported",
            "camera" | "integrator" | "mesh" => "; it belongs directly inside <scene>",
            "sampler" => "; it belongs inside <scene> or the <camera>",
            "texture" => "; a <texture> sets a colour of the <bsdf> or area <emitter> it stands in",
            "emitter" => {
                "; an area emitter belongs inside a <mesh>, others directly inside <scene>"
            }
            _ => "",
        };
        reader::misplaced(self.file, node, node.pos, parent, hint)
    }

    fn camera(&mut self, node: &SceneNode) -> Result<CameraDesc> {
        let ty = self.object_type(node, CAMERA_TYPES)?;
        let owner = format!("<camera type=\"{ty}\">");
        let (mut p, objects) = self.read_object(node, &owner)?;
        let d = CameraParams::default();
        let width = int_in(&mut p, "width", 1280, 1, MAX_RESOLUTION as i64)? as u32;
        let height = int_in(&mut p, "height", 720, 1, MAX_RESOLUTION as i64)? as u32;
        let fov = p.get_float("fov", 30.0)?;
        let near_clip = p.get_float("nearClip", 1e-4)?;
        let far_clip = p.get_float("farClip", 1e4)?;
        let to_world = p.get_transform("toWorld", Transform::IDENTITY)?;
        let lens_radius = p.get_float("lensRadius", 0.0)?;
        let mut focal_distance = p.opt_float("focalDistance")?;
        if focal_distance.is_none() && p.has("focalLength") {
            // ETH students' thin lenses (pbrt's, section 6.2.3) name the
            // distance to the plane in focus so.
            focal_distance = p.opt_float("focalLength")?;
            p.warn(
                "focalLength",
                "'focalLength' is read as the distance to the plane in focus, as ETH students' \
                 thin-lens cameras use it (lente's name: 'focalDistance')",
            );
        }
        let autofocus = p.get_bool("autofocus", false)?;
        let blades = p.get_int("apertureBlades", 0)?;
        let rotation = p.get_float("apertureRotation", 0.0)?;
        if lens_radius > 0.0 && focal_distance.is_none() && !autofocus {
            return Err(p.object_error(format!(
                "{owner} has lensRadius {lens_radius} > 0 and so needs 'focalDistance' \
                 (or <boolean name=\"autofocus\" value=\"true\"/>)"
            )));
        }
        if autofocus && focal_distance.is_some() {
            p.warn(
                "focalDistance",
                "'focalDistance' is ignored because 'autofocus' is true",
            );
        }
        let params = CameraParams {
            width,
            height,
            fov_x_deg: fov,
            fov_axis: crate::camera::FovAxis::X,
            near_clip,
            far_clip,
            to_world,
            lens_radius,
            focal_distance: focal_distance.unwrap_or(d.focal_distance),
            aperture: if blades == 0 {
                Aperture::Circular
            } else {
                Aperture::Polygon {
                    blades: u32::try_from(blades).unwrap_or(u32::MAX),
                    rotation: rotation.to_radians(),
                }
            },
            autofocus,
            projection: crate::camera::Projection::Perspective,
        };
        params
            .validate()
            .map_err(|e| p.param_error(nori_camera_name(e.param()), e))?;
        p.finish(&mut self.warnings);

        let mut filter: Option<(Filter, Pos)> = None;
        let mut sampler: Option<(u32, Pos)> = None;
        for ch in objects {
            match ch.tag.as_str() {
                "rfilter" => {
                    if let Some((_, first)) = filter {
                        return Err(self.err(
                            ch.pos,
                            format!(
                                "a camera can have only one <rfilter> (the first is at {first})"
                            ),
                        ));
                    }
                    filter = Some((self.rfilter(ch)?, ch.pos));
                }
                "sampler" => {
                    let spp = self.sampler(ch)?;
                    set_sampler(self, &mut sampler, spp, ch.pos)?;
                }
                _ => return Err(self.misplaced(ch, &owner)),
            }
        }
        Ok((
            params,
            filter.map_or_else(Filter::default, |f| f.0),
            sampler,
        ))
    }

    fn rfilter(&mut self, node: &SceneNode) -> Result<Filter> {
        let ty = self.object_type(node, RFILTER_TYPES)?;
        let owner = format!("<rfilter type=\"{ty}\">");
        let (mut p, objects) = self.read_object(node, &owner)?;
        let filter = match ty {
            "gaussian" => Filter::Gaussian {
                radius: p.get_float("radius", 2.0)?,
                stddev: p.get_float("stddev", 0.5)?,
            },
            "box" => Filter::Box {
                radius: p.get_float("radius", 0.5)?,
            },
            "tent" => Filter::Tent {
                radius: p.get_float("radius", 1.0)?,
            },
            "mitchell" => Filter::Mitchell {
                radius: p.get_float("radius", 2.0)?,
                b: p.get_float("B", 1.0 / 3.0)?,
                c: p.get_float("C", 1.0 / 3.0)?,
            },
            _ => unreachable!(),
        };
        filter
            .validate()
            .map_err(|e| p.param_error(objects::filter_name(e.param()), &e))?;
        p.finish(&mut self.warnings);
        self.no_children(objects, &owner)?;
        Ok(filter)
    }

    fn no_children(&self, objects: Vec<&SceneNode>, owner: &str) -> Result<()> {
        match objects.first() {
            Some(ch) => Err(self.misplaced(ch, owner)),
            None => Ok(()),
        }
    }

    fn sampler(&mut self, node: &SceneNode) -> Result<u32> {
        let ty = self.object_type(node, SAMPLER_TYPES)?;
        let owner = format!("<sampler type=\"{ty}\">");
        let (mut p, objects) = self.read_object(node, &owner)?;
        let spp = int_in(&mut p, "sampleCount", 1, 1, u32::MAX as i64)? as u32;
        p.finish(&mut self.warnings);
        self.no_children(objects, &owner)?;
        Ok(spp)
    }

    fn integrator(&mut self, node: &SceneNode) -> Result<Integrator> {
        let ty = self.object_type(node, INTEGRATOR_TYPES)?;
        let owner = format!("<integrator type=\"{ty}\">");
        let (mut p, objects) = self.read_object(node, &owner)?;
        let strategy = match ty {
            "path_mats" => Some(Strategy::Mats),
            "path_ems" => Some(Strategy::Ems),
            "path_mis" | "path" => Some(Strategy::Mis),
            _ => None,
        };
        let integrator = match (ty, strategy) {
            ("normals", _) => Integrator::Normals,
            ("ao", _) | ("av", _) => {
                let length = p.get_float_or_inf("length", f32::INFINITY)?;
                if length <= 0.0 {
                    return Err(p.error(
                        "length",
                        format!("'length' must be positive, found {length}"),
                    ));
                }
                if ty == "ao" {
                    Integrator::Ao { length }
                } else {
                    Integrator::AverageVisibility { length }
                }
            }
            ("simple", _) => {
                let position = p.require_point("position")?;
                let energy = p.require_rgb("energy")?;
                Integrator::Simple { position, energy }
            }
            ("whitted", _) => Integrator::Whitted,
            // The Zaragoza fork's direct_whitted samples every light at the
            // first hit; one light chosen by power has the same expectation.
            ("direct_ems", _) | ("direct_whitted", _) => Integrator::Direct {
                strategy: Strategy::Ems,
            },
            ("direct_mats", _) => Integrator::Direct {
                strategy: Strategy::Mats,
            },
            // Forks name their direct-lighting integrator plainly `direct`;
            // every strategy has the same expectation, MIS the least noise.
            ("direct_mis", _) | ("direct", _) => Integrator::Direct {
                strategy: Strategy::Mis,
            },
            // The ETH course's photon mapper (its fourth assignment):
            // rendered with the path tracer, the image it converges to as
            // its radius shrinks, without the photon map's blur.
            ("photonmapper", _) => {
                int_in(&mut p, "photonCount", 1_000_000, 1, u32::MAX as i64)?;
                let radius = p.get_float("photonRadius", 0.0)?;
                if !(radius >= 0.0 && radius.is_finite()) {
                    return Err(p.error(
                        "photonRadius",
                        format!("'photonRadius' must not be negative, found {radius}"),
                    ));
                }
                let w = p.object_warning(
                    "the photonmapper integrator is rendered with lente's path_mis, the image \
                     photon mapping converges to (without the photon map's blur); photonCount \
                     and photonRadius are ignored",
                );
                self.warnings.push(w);
                Integrator::Path {
                    strategy: Strategy::Mis,
                    params: PathParams {
                        max_depth: None,
                        rr_depth: 3,
                        hide_emitters: false,
                    },
                }
            }
            (_, Some(strategy)) => {
                let max_depth = match p.opt_int("maxDepth")? {
                    None => None,
                    Some(d) if (1..=u32::MAX as i64).contains(&d) => Some(d as u32),
                    Some(d) => {
                        return Err(p.error(
                            "maxDepth",
                            format!("'maxDepth' must be at least 1, found {d}"),
                        ))
                    }
                };
                let rr_depth = int_in(&mut p, "rrDepth", 3, 0, u32::MAX as i64)? as u32;
                Integrator::Path {
                    strategy,
                    params: PathParams {
                        max_depth,
                        rr_depth,
                        hide_emitters: false,
                    },
                }
            }
            _ => unreachable!(),
        };
        p.finish(&mut self.warnings);
        self.no_children(objects, &owner)?;
        Ok(integrator)
    }

    /// An environment emitter written inside a `<mesh>` (ETH students
    /// wrap theirs in a big sphere): read as the scene's environment, the
    /// mesh around it dropped (it would hide the environment), with a
    /// warning. `None` for a mesh without one.
    fn environment_in_mesh(&mut self, node: &SceneNode) -> Result<Option<EmitterDesc>> {
        const ENVIRONMENTS: &[&str] = &["environment", "envmap", "sky", "constant"];
        let Some(ch) = node.children.iter().find(|c| {
            c.tag == "emitter"
                && c.attr_value("type")
                    .is_some_and(|t| ENVIRONMENTS.contains(&t))
        }) else {
            return Ok(None);
        };
        let ty = ch.attr_value("type").unwrap_or_default();
        let desc = self.emitter(ch, false)?;
        self.warn(
            ch.pos,
            format!(
                "<emitter type=\"{ty}\"> inside a <mesh> is read as the scene's environment; \
                 the mesh around it is left out (it would hide the environment): write the \
                 emitter directly inside <scene>"
            ),
        );
        Ok(Some(desc))
    }

    fn mesh(&mut self, node: &SceneNode) -> Result<ShapeDesc> {
        let ty = self.object_type(node, MESH_TYPES)?;
        let owner = format!("<mesh type=\"{ty}\">");
        let (mut p, objects) = self.read_object(node, &owner)?;
        let mut bsdf: Option<(Bsdf, Pos)> = None;
        let mut area: Option<(Rgb, Option<Texture>, Pos)> = None;

        enum Source {
            Obj(PathBuf),
            Sphere(Sphere),
        }
        let source = match ty {
            "obj" => {
                let name = p.require_string("filename")?;
                if name.trim().is_empty() {
                    return Err(p.error("filename", "'filename' is empty"));
                }
                Source::Obj(self.dir.join(name))
            }
            "sphere" => {
                let mut sphere = objects::sphere(&mut p)?;
                // ETH's course gives its spheres this (u, v) for textures.
                sphere.uv = SphereUv::Eth;
                Source::Sphere(sphere)
            }
            _ => unreachable!(),
        };
        let filename_pos = p.value_pos("filename");
        let to_world = p.opt_transform("toWorld")?;
        let to_world_pos = p.value_pos("toWorld");
        p.finish(&mut self.warnings);

        for ch in objects {
            match ch.tag.as_str() {
                "bsdf" => {
                    if let Some((_, first)) = bsdf {
                        return Err(self.err(
                            ch.pos,
                            format!("a mesh can have only one <bsdf> (the first is at {first})"),
                        ));
                    }
                    bsdf = Some((self.bsdf(ch)?, ch.pos));
                }
                "emitter" => {
                    if let Some((_, _, first)) = area {
                        return Err(self.err(
                            ch.pos,
                            format!("a mesh can have only one <emitter> (the first is at {first})"),
                        ));
                    }
                    match self.emitter(ch, true)? {
                        EmitterDesc::Area(radiance, texture) => {
                            area = Some((radiance, texture, ch.pos))
                        }
                        EmitterDesc::Free { .. } => unreachable!("checked by emitter()"),
                    }
                }
                _ => return Err(self.misplaced(ch, &owner)),
            }
        }

        let mut geometry = match source {
            Source::Obj(path) => Geometry::Mesh(
                load_obj(&path)
                    .map_err(|e| self.err(filename_pos, "cannot load the mesh").caused_by(e))?,
            ),
            Source::Sphere(s) => Geometry::Sphere(s),
        };
        if let Some(t) = &to_world {
            geometry
                .transform(t)
                .map_err(|e| self.err(to_world_pos, format!("after its toWorld, {e}")))?;
        }
        Ok(ShapeDesc {
            media: Default::default(),
            geometry,
            bsdf: bsdf.map_or_else(Bsdf::default, |b| b.0),
            area_radiance: area.as_ref().map(|a| a.0),
            area_texture: area.and_then(|a| a.1),
        })
    }

    fn bsdf(&mut self, node: &SceneNode) -> Result<Bsdf> {
        let ty = self.object_type(node, BSDF_TYPES)?;
        let owner = format!("<bsdf type=\"{ty}\">");
        let (mut p, objects) = self.read_object(node, &owner)?;
        // The properties the forks' textures may set, by BSDF.
        let texturable: &[(&str, BsdfParam)] = match ty {
            "diffuse" => &[("albedo", BsdfParam::Diffuse)],
            "roughconductor" => &[
                ("R0", BsdfParam::SpecularReflectance),
                ("alpha", BsdfParam::Alpha),
            ],
            "roughsubstrate" => &[("kd", BsdfParam::Diffuse), ("alpha", BsdfParam::Alpha)],
            _ => &[],
        };
        let names: Vec<&str> = texturable.iter().map(|(n, _)| *n).collect();
        let mut textures: Vec<(BsdfParam, Texture)> = Vec::new();
        for ch in objects {
            let (i, t) = self.texture_child(ch, &owner, &p, &names)?;
            let param = texturable[i].1;
            // The fork reads a roughness texture's channel mean.
            let texture = match (param, t.texture) {
                (BsdfParam::Alpha, Texture::Bitmap(b)) => Texture::Bitmap(b.channel_means()),
                (_, t) => t,
            };
            textures.push((param, texture));
        }
        // A textured parameter's constant is its texture's mean.
        let mean = |name: &str| {
            let (_, param) = texturable.iter().find(|(n, _)| *n == name)?;
            let (_, t) = textures.iter().find(|(q, _)| q == param)?;
            Some(t.mean())
        };
        let rgb = |p: &mut Props, name: &str, default: f32| match mean(name) {
            Some(m) => Ok(m),
            None => p.get_rgb(name, Rgb::splat(default)),
        };
        let float = |p: &mut Props, name: &str, default: f32| match mean(name) {
            Some(m) => Ok(crate::texture::channel_mean(m)),
            None => p.get_float(name, default),
        };
        let bsdf = match ty {
            "diffuse" => {
                let albedo = rgb(&mut p, "albedo", 0.5)?;
                if albedo.max_element() > 1.0 {
                    p.warn(
                        "albedo",
                        format!(
                            "albedo {} {} {} is above 1: the surface reflects more light than it receives",
                            albedo.x, albedo.y, albedo.z
                        ),
                    );
                }
                Bsdf::diffuse(albedo)
            }
            "mirror" => Ok(Bsdf::Mirror(Mirror)),
            "dielectric" => {
                let int_ior = p.get_float("intIOR", 1.5046)?;
                let ext_ior = p.get_float("extIOR", 1.000277)?;
                Bsdf::dielectric(int_ior, ext_ior)
            }
            "microfacet" => {
                let alpha = p.get_float("alpha", 0.1)?;
                let int_ior = p.get_float("intIOR", 1.5046)?;
                let ext_ior = p.get_float("extIOR", 1.000277)?;
                let kd = p.get_rgb("kd", Rgb::splat(0.5))?;
                fork_hint(
                    &mut p,
                    "R0",
                    "'R0' (Schlick's reflectance at normal incidence) is read by the Zaragoza \
                     fork's roughconductor; lente's microfacet takes its Fresnel term from \
                     'intIOR' and 'extIOR' and ignores 'R0'",
                )?;
                Bsdf::microfacet(alpha, int_ior, ext_ior, kd)
            }
            // The Zaragoza fork's rough metal and coated diffuse.
            "roughconductor" => {
                let alpha = float(&mut p, "alpha", 0.1)?;
                let r0 = rgb(&mut p, "R0", 0.5)?;
                SchlickConductor::new(alpha, r0).map(Bsdf::SchlickConductor)
            }
            "roughsubstrate" => {
                let alpha = float(&mut p, "alpha", 0.1)?;
                let int_ior = p.get_float("intIOR", 1.5046)?;
                let ext_ior = p.get_float("extIOR", 1.000277)?;
                let kd = rgb(&mut p, "kd", 0.5)?;
                RoughSubstrate::new(alpha, int_ior, ext_ior, kd).map(Bsdf::RoughSubstrate)
            }
            _ => unreachable!(),
        };
        let bsdf = bsdf
            .and_then(|b| Bsdf::textured(b, textures))
            .map_err(|e| p.param_error(nori_bsdf_name(ty, e.param()), &e))?;
        p.finish(&mut self.warnings);
        Ok(bsdf)
    }

    /// A `<texture>` child of `owner`, which takes textures for the
    /// properties `texturable` names, and the index there of the one it
    /// sets; the property may not be given as a value too.
    fn texture_child(
        &mut self,
        ch: &SceneNode,
        owner: &str,
        p: &Props,
        texturable: &[&str],
    ) -> Result<(usize, NamedTexture)> {
        if ch.tag != "texture" {
            return Err(self.misplaced(ch, owner));
        }
        let t = read_texture(
            &NORI,
            self.file,
            &self.dir,
            ch,
            &mut self.texture_images,
            &mut self.warnings,
        )?;
        if t.eth && !self.eth_warned {
            self.eth_warned = true;
            self.warn(
                t.pos,
                "this texture type is ETH Zurich's Nori course framework's, whose camera \
                 mirrors images left to right (its sample-to-camera x scale is +1/2, Nori's \
                 -1/2); lente renders Nori's and Mitsuba's image. For ETH's, put <scale \
                 value=\"-1,1,1\"/> first in the camera's toWorld",
            );
        }
        let Some(i) = texturable.iter().position(|n| *n == t.name) else {
            let takes = if texturable.is_empty() {
                "takes no textures".to_string()
            } else {
                let names: Vec<String> = texturable.iter().map(|n| format!("'{n}'")).collect();
                format!("takes textures for {}", names.join(", "))
            };
            return Err(self.err(
                t.pos,
                format!("{owner} has no texture '{}'; it {takes}", t.name),
            ));
        };
        if p.has(&t.name) {
            return Err(self.err(
                t.pos,
                format!(
                    "'{}' is given twice, as a value at {} and as this texture; give one",
                    t.name,
                    p.value_pos(&t.name)
                ),
            ));
        }
        Ok((i, t))
    }

    /// The radiant intensity (W/sr) of a point light, from whichever of
    /// the forks' spellings it is given in: `power` (ETH: watts, so
    /// I = power / 4pi), `radiance` (the Zaragoza fork: I itself) or
    /// `intensity` (Mitsuba and some Nori derivatives: I itself).
    fn point_intensity(
        &mut self,
        p: &mut Props,
        pos: Pos,
        owner: &str,
        zaragoza: bool,
    ) -> Result<Rgb> {
        let mut given: Vec<&str> = ["power", "radiance", "intensity"]
            .into_iter()
            .filter(|n| p.has(n))
            .collect();
        given.sort_by_key(|n| p.value_pos(n));
        if let [first, second, ..] = given[..] {
            return Err(p.error(
                second,
                format!(
                    "{owner} gives both '{first}' and '{second}'; give one: 'power' (watts, \
                     as ETH's Nori writes it), 'radiance' (W/sr, as the Zaragoza fork writes \
                     it) or 'intensity' (W/sr)"
                ),
            ));
        }
        match given.first().copied() {
            Some("power") => Ok(p.require_rgb("power")? / (4.0 * PI)),
            Some("radiance") => {
                let r = p.require_rgb("radiance")?;
                if !zaragoza {
                    p.warn(
                        "radiance",
                        "'radiance' of a point light is read as the Zaragoza fork's pointlight \
                         reads it: a radiant intensity in W/sr (the light emits 4pi x radiance \
                         watts); ETH's point light takes 'power' in watts instead",
                    );
                }
                Ok(r)
            }
            Some(_) => p.require_rgb("intensity"),
            None if zaragoza => {
                self.warn(
                    pos,
                    format!(
                        "{owner} has no 'radiance'; as in the Zaragoza fork, its radiant \
                         intensity is 1 W/sr"
                    ),
                );
                Ok(Rgb::ONE)
            }
            None => Err(p.object_error(format!(
                "{owner} needs the property 'power' (a <color>: the light's power in watts), \
                 or 'radiance' or 'intensity' (its radiant intensity in W/sr)"
            ))),
        }
    }

    fn emitter(&mut self, node: &SceneNode, in_mesh: bool) -> Result<EmitterDesc> {
        let ty = self.object_type(node, EMITTER_TYPES)?;
        let owner = format!("<emitter type=\"{ty}\">");
        NORI.check_emitter_place(self.file, node, ty, in_mesh)?;
        let (mut p, objects) = self.read_object(node, &owner)?;
        // Only the Zaragoza fork's area emitter takes a texture.
        let texturable: &[&str] = if ty == "area" { &["radiance"] } else { &[] };
        let mut texture = None;
        for ch in objects {
            if texture.is_some() {
                return Err(self.err(ch.pos, format!("{owner} has only one texture, 'radiance'")));
            }
            texture = Some(self.texture_child(ch, &owner, &p, texturable)?.1.texture);
        }
        let desc = match ty {
            "area" => {
                fork_hint(
                    &mut p,
                    "scale",
                    "'scale' is read by the Zaragoza fork's area emitter, which never applies \
                     it; lente ignores it too (scale 'radiance' instead)",
                )?;
                match texture {
                    Some(Texture::Constant(c)) => EmitterDesc::Area(c, None),
                    Some(t) => EmitterDesc::Area(t.mean(), Some(t)),
                    None => EmitterDesc::Area(p.require_rgb("radiance")?, None),
                }
            }
            "point" | "pointlight" => {
                let zaragoza = ty == "pointlight";
                let position = match p.opt_point("position")? {
                    Some(x) => x,
                    None if zaragoza => {
                        let v = ZARAGOZA_POINT_POSITION;
                        self.warn(
                            node.pos,
                            format!(
                                "{owner} has no 'position'; as in the Zaragoza fork, it stands \
                                 at ({}, {}, {})",
                                v.x, v.y, v.z
                            ),
                        );
                        v
                    }
                    None => p.require_point("position")?,
                };
                let intensity = self.point_intensity(&mut p, node.pos, &owner, zaragoza)?;
                let light = PointLight::new(position, intensity).map_err(|e| match e {
                    EmitterError::Position(_) => p.param_error("position", &e),
                    _ => p.object_error(format!("{owner}: its intensity {e}")),
                })?;
                EmitterDesc::Free {
                    emitter: Emitter::Point(light),
                    environment: false,
                }
            }
            "directional" => {
                // ETH students' `directionallight.cpp` (gianluca-m's):
                // `power` is the irradiance on a surface facing the light;
                // `direction` is where the light travels.
                let d = p.require_vector("direction")?;
                let irradiance = p.require_rgb("power")?;
                let length = d.length();
                if length.is_finite() && length > 0.0 && (length - 1.0).abs() > 1e-3 {
                    p.warn(
                        "direction",
                        format!(
                            "the fork's directional light uses 'direction' unnormalised, which \
                             scales its direct light by the length ({length:.3} here); lente \
                             normalises it, as Mitsuba does"
                        ),
                    );
                }
                let light = DirectionalLight::new(d, irradiance).map_err(|e| match e {
                    EmitterError::Direction(_) => p.param_error("direction", &e),
                    _ => p.param_error("power", &e),
                })?;
                EmitterDesc::Free {
                    emitter: Emitter::Directional(light),
                    environment: false,
                }
            }
            "constant" => {
                let radiance = p.require_rgb("radiance")?;
                let light =
                    ConstantLight::new(radiance).map_err(|e| p.param_error("radiance", &e))?;
                EmitterDesc::Free {
                    emitter: Emitter::Constant(light),
                    environment: true,
                }
            }
            "environment" | "envmap" => {
                let name = if ty == "environment" {
                    p.opt_string("filename")?
                } else {
                    Some(p.require_string("filename")?)
                };
                // The Zaragoza fork's colour multiplier (default 1).
                let radiance = p.opt_rgb("radiance")?;
                let scale = non_negative(&mut p, "scale", 1.0)?;
                let Some(name) = name else {
                    // The Zaragoza fork: no image means a uniform
                    // environment of 'radiance'.
                    if radiance.is_none() {
                        self.warn(
                            node.pos,
                            format!(
                                "{owner} has no 'filename'; as in the Zaragoza fork, it is a \
                                 uniform environment of radiance 1 (give 'filename' for an \
                                 image, or 'radiance' for a uniform colour)"
                            ),
                        );
                    }
                    let radiance = radiance.unwrap_or(Rgb::ONE) * scale;
                    let light =
                        ConstantLight::new(radiance).map_err(|e| p.param_error("radiance", &e))?;
                    p.finish(&mut self.warnings);
                    return Ok(EmitterDesc::Free {
                        emitter: Emitter::Constant(light),
                        environment: true,
                    });
                };
                if name.trim().is_empty() {
                    return Err(p.error("filename", "'filename' is empty"));
                }
                if radiance.is_some() && !p.has("toWorld") && name.trim() != BUILTIN_SKY {
                    p.warn(
                        "radiance",
                        "'radiance' is the Zaragoza fork's multiplier of the map, and lente \
                         applies it; but that fork lays the map out with u = atan2(z, x) / 2pi \
                         (its left edge looks down +x) where lente follows Mitsuba (left edge \
                         down -z): to see the map as the Zaragoza fork shows it, add \
                         <transform name=\"toWorld\"><rotate axis=\"0,1,0\" angle=\"-90\"/></transform>",
                    );
                }
                let to_world = p.get_transform("toWorld", Transform::IDENTITY)?;
                let filter = match p.get_string("filter", "bilinear".into())?.as_str() {
                    "bilinear" => EnvFilter::Bilinear,
                    "nearest" => EnvFilter::Nearest,
                    other => {
                        return Err(p.error(
                            "filter",
                            format!("unknown filter '{other}'; known filters: bilinear, nearest"),
                        ))
                    }
                };
                let visible = p.get_bool("visible", true)?;
                let texels = if name.trim() == BUILTIN_SKY {
                    // The built-in sky, so a scene can switch between it and
                    // a probe by changing one word.
                    Texels::Image(bake_sky(&SkyParams {
                        scale: BUILTIN_SKY_EXPOSURE,
                        ..SkyParams::default()
                    }))
                } else {
                    Texels::File(self.dir.join(name))
                };
                let spec = EnvMapSpec {
                    texels,
                    tint: radiance.unwrap_or(Rgb::ONE),
                    scale,
                    to_world,
                    filter,
                    rows: TexelRows::CellCentres,
                };
                let mut env = objects::envmap(&p, &NORI_ENVMAP_NAMES, spec, &mut self.warnings)?;
                env.visible = visible;
                p.finish(&mut self.warnings);
                return Ok(EmitterDesc::Free {
                    emitter: Emitter::Environment(Box::new(env)),
                    environment: true,
                });
            }
            "sky" => {
                let turbidity = p.get_float("turbidity", 3.0)?;
                if !(1.0..=10.0).contains(&turbidity) {
                    return Err(p.error(
                        "turbidity",
                        format!("'turbidity' must be between 1 and 10, found {turbidity}"),
                    ));
                }
                let elevation = p.get_float("sunElevation", 45.0)?;
                if !(-90.0..=90.0).contains(&elevation) {
                    return Err(p.error(
                        "sunElevation",
                        format!(
                            "'sunElevation' must be between -90 and 90 degrees, found {elevation}"
                        ),
                    ));
                }
                let azimuth = p.get_float("sunAzimuth", 0.0)?;
                let scale = non_negative(&mut p, "scale", 1.0)?;
                let resolution = int_in(&mut p, "resolution", 1024, 4, 16384)? as usize;
                if let Some(message) = crate::limits::check_image_size(
                    resolution as u64,
                    (resolution as u64 / 2).max(1),
                ) {
                    return Err(p.error("resolution", format!("the sky's table: {message}")));
                }
                let visible = p.get_bool("visible", true)?;
                let image = bake_sky(&SkyParams {
                    turbidity,
                    sun_elevation_deg: elevation,
                    sun_azimuth_deg: azimuth,
                    scale,
                    resolution,
                });
                let spec = EnvMapSpec {
                    texels: Texels::Image(image),
                    tint: Rgb::ONE,
                    scale: 1.0,
                    to_world: Transform::IDENTITY,
                    filter: EnvFilter::Bilinear,
                    rows: TexelRows::CellCentres,
                };
                let mut env = objects::envmap(&p, &NORI_ENVMAP_NAMES, spec, &mut self.warnings)?;
                env.visible = visible;
                p.finish(&mut self.warnings);
                return Ok(EmitterDesc::Free {
                    emitter: Emitter::Environment(Box::new(env)),
                    environment: true,
                });
            }
            _ => unreachable!(),
        };
        p.finish(&mut self.warnings);
        Ok(desc)
    }
}

/// Nori's names of an environment map's properties.
const NORI_ENVMAP_NAMES: EnvMapNames = EnvMapNames {
    filename: "filename",
    scale: "scale",
    to_world: "toWorld",
};

/// Nori's name of a BSDF parameter, for a BSDF of type `ty`.
fn nori_bsdf_name(ty: &str, param: BsdfParam) -> &'static str {
    match param {
        BsdfParam::Diffuse if ty == "diffuse" => "albedo",
        BsdfParam::Diffuse => "kd",
        BsdfParam::SpecularReflectance if ty == "roughconductor" => "R0",
        BsdfParam::IntIor => "intIOR",
        BsdfParam::ExtIor => "extIOR",
        BsdfParam::Alpha | BsdfParam::AlphaV => "alpha",
        // Not Nori parameters: no model of Nori's dialect reports them.
        BsdfParam::SpecularReflectance
        | BsdfParam::SpecularTransmittance
        | BsdfParam::Eta
        | BsdfParam::K
        | BsdfParam::Nested
        | BsdfParam::Opacity
        | BsdfParam::Weight
        | BsdfParam::NormalMap
        | BsdfParam::BumpScale => "",
    }
}

/// Nori's name of a camera parameter.
fn nori_camera_name(param: CameraParam) -> &'static str {
    match param {
        CameraParam::Width => "width",
        CameraParam::Height => "height",
        CameraParam::FieldOfView => "fov",
        CameraParam::NearClip => "nearClip",
        CameraParam::FarClip => "farClip",
        CameraParam::LensRadius => "lensRadius",
        CameraParam::FocalDistance => "focalDistance",
        CameraParam::ApertureBlades => "apertureBlades",
        CameraParam::ApertureRotation => "apertureRotation",
    }
}

/// A property another fork reads and lente does not: marks it as read and
/// warns with `message` (which names that fork's reading), instead of the
/// generic "unused property" warning.
fn fork_hint(p: &mut Props, name: &str, message: &str) -> Result<()> {
    let Some(kind) = p.kind_of(name) else {
        return Ok(());
    };
    match kind {
        Kind::Bool => {
            let _ = p.opt_bool(name)?;
        }
        Kind::Int => {
            let _ = p.opt_int(name)?;
        }
        Kind::Float => {
            let _ = p.opt_float_raw(name)?;
        }
        Kind::String => {
            let _ = p.opt_string(name)?;
        }
        Kind::Point => {
            let _ = p.opt_point_raw(name)?;
        }
        Kind::Vector => {
            let _ = p.opt_vector_raw(name)?;
        }
        Kind::Color | Kind::Spectrum => {
            let _ = p.opt_rgb_raw(name)?;
        }
        Kind::Transform => {
            let _ = p.opt_transform(name)?;
        }
        Kind::Texture => {
            let _ = p.opt_texture(name)?;
        }
        Kind::Pair => {
            let _ = p.get_pair(name, crate::math::Vec2::ZERO)?;
        }
    }
    p.warn(name, message);
    Ok(())
}

fn set_sampler(ctx: &Ctx, slot: &mut Option<(u32, Pos)>, spp: u32, pos: Pos) -> Result<()> {
    if let Some((_, first)) = slot {
        return Err(ctx.err(
            pos,
            format!("a scene can have only one <sampler> (the first is at {first})"),
        ));
    }
    *slot = Some((spp, pos));
    Ok(())
}

/// Nori's lookAt: columns (left, up, dir, origin).
fn look_at(origin: Vec3, target: Vec3, up: Option<Vec3>) -> std::result::Result<Mat4, LookAtError> {
    let up = up.expect("Nori's <lookat> requires 'up'");
    let to = target - origin;
    if !to.length().is_finite() || to.length() <= 0.0 {
        return Err(LookAtError::TargetAtOrigin);
    }
    let dir = to.normalize();
    if !up.length().is_finite() || up.length() <= 0.0 {
        return Err(LookAtError::ZeroUp);
    }
    let left = up.normalize().cross(dir);
    if !left.is_finite() || left.length() <= 1e-6 {
        return Err(LookAtError::ParallelUp);
    }
    let left = left.normalize();
    let new_up = dir.cross(left).normalize();
    Ok(Mat4::from_cols(
        left.extend(0.0),
        new_up.extend(0.0),
        dir.extend(0.0),
        origin.extend(1.0),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec4;

    #[test]
    fn look_at_builds_an_orthonormal_frame() {
        let m = look_at(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Some(Vec3::Y)).unwrap();
        assert!((m.transform_vector3(Vec3::Z) - Vec3::NEG_Z).length() < 1e-6);
        assert!((m.transform_vector3(Vec3::Y) - Vec3::Y).length() < 1e-6);
        // left = up x dir = Y x -Z = -X
        assert!((m.transform_vector3(Vec3::X) - Vec3::NEG_X).length() < 1e-6);
        assert!(look_at(Vec3::ZERO, Vec3::Y, Some(Vec3::Y)).is_err());
        assert!(look_at(Vec3::ZERO, Vec3::ZERO, Some(Vec3::Y)).is_err());
    }

    #[test]
    fn similarity_and_rotation_checks() {
        let rot = Transform::new(Mat4::from_axis_angle(
            Vec3::new(1.0, 2.0, 3.0).normalize(),
            0.7,
        ))
        .unwrap();
        assert!(rot.is_rotation(1e-4));
        assert!(rot.is_similarity());
        let sim = Transform::new(Mat4::from_scale(Vec3::splat(2.0)) * rot.m).unwrap();
        assert!(sim.is_similarity());
        assert!(!sim.is_rotation(1e-4));
        let shear = Transform::new(Mat4::from_cols(
            Vec4::new(1.0, 0.0, 0.0, 0.0),
            Vec4::new(0.6, 0.8, 0.0, 0.0),
            Vec4::new(0.0, 0.0, 1.0, 0.0),
            Vec4::W,
        ))
        .unwrap();
        assert!(!shear.is_similarity());
    }
}
