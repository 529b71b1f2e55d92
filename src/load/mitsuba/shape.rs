//! Shapes: obj, ply, serialized, sphere, rectangle, cube, disk, cylinder,
//! linearcurve and bsplinecurve, with their BSDF and area emitter.

use super::emitter::EmitterDesc;
use super::Ctx;
use crate::bsdf::{Bsdf, Diffuse};
use crate::color::Rgb;
use crate::geometry::{
    self, CurveBasis, Geometry, MeshAttribute, ShapeError, Sphere, SphereError, TriangleMesh,
};
use crate::load::objects;
use crate::load::props::positive;
use crate::load::xml::{Pos, SceneNode};
use crate::load::SceneError;
use crate::math::{Transform, Vec3};
use crate::scene::ShapeDesc;
use crate::texture::Texture;

type Result<T> = std::result::Result<T, SceneError>;

impl<'d> Ctx<'d> {
    /// Shapes (Mitsuba's `shapes/`): obj, ply, serialized (`shape_index`),
    /// sphere, rectangle, cube, disk, cylinder, linearcurve, bsplinecurve;
    /// `to_world`, `flip_normals`, `face_normals` (meshes).
    pub(super) fn shape(&mut self, node: &'d SceneNode) -> Result<ShapeDesc> {
        let ty = self.object_type(
            node,
            &[
                "obj",
                "ply",
                "serialized",
                "sphere",
                "rectangle",
                "cube",
                "disk",
                "cylinder",
                "linearcurve",
                "bsplinecurve",
            ],
            &["sdfgrid", "ellipsoids", "ellipsoidsmesh", "merge"],
        )?;
        let owner = format!("<shape type=\"{ty}\">");
        let (mut p, children) = self.read_object(node, &owner)?;
        let to_world = p.get_transform("to_world", Transform::IDENTITY)?;
        let to_world_pos = p.value_pos("to_world");
        let flip_normals = p.get_bool("flip_normals", false)?;

        enum Source {
            Mesh {
                mesh: TriangleMesh,
                /// Per-vertex and per-face data (PLY files).
                attributes: Vec<MeshAttribute>,
                /// Normals to compute after the transform (Mitsuba does so
                /// for meshes without them unless face_normals is set).
                smooth: bool,
            },
            Sphere(Sphere),
            /// Analytic, or triangles when they emit (see below).
            Disk,
            Rectangle,
            /// Placed when read (its radii do not follow `to_world`).
            Curve(geometry::Curve),
        }
        let source = match ty {
            "obj" | "ply" | "serialized" => {
                let name = p.require_string("filename")?;
                if name.trim().is_empty() {
                    return Err(p.error("filename", "'filename' is empty"));
                }
                let face_normals = p.get_bool("face_normals", false)?;
                let flip_tex = ty == "obj" && p.get_bool("flip_tex_coords", true)?;
                let path = self.resolve(&name);
                let mut attributes = Vec::new();
                let mut mesh = match ty {
                    "obj" => geometry::load_obj(&path),
                    "ply" => geometry::load_ply_full(&path).map(|(m, a)| {
                        attributes = a;
                        m
                    }),
                    _ => {
                        let index = p.get_int("shape_index", 0)?;
                        let index = u32::try_from(index).map_err(|_| {
                            p.error(
                                "shape_index",
                                format!("'shape_index' must not be negative, found {index}"),
                            )
                        })?;
                        geometry::load_serialized_full(&path, index).map(|(m, a)| {
                            attributes = a;
                            m
                        })
                    }
                }
                .map_err(|e| p.error("filename", "cannot load the mesh").caused_by(e))?;
                if flip_tex {
                    mesh.flip_v();
                }
                if face_normals {
                    mesh.clear_normals();
                }
                let smooth = !face_normals && mesh.normals().is_empty();
                Source::Mesh {
                    mesh,
                    attributes,
                    smooth,
                }
            }
            "rectangle" => Source::Rectangle,
            "cube" => Source::Mesh {
                mesh: geometry::cube_mesh(),
                attributes: Vec::new(),
                smooth: false,
            },
            "disk" => Source::Disk,
            "cylinder" => {
                let p0 = p.get_point("p0", Vec3::ZERO)?;
                let p1 = p.get_point("p1", Vec3::Z)?;
                let radius = positive(&mut p, "radius", 1.0)?;
                if p0 == p1 {
                    return Err(p.error("p1", "the cylinder's 'p0' and 'p1' must differ"));
                }
                let mesh = geometry::cylinder_mesh(p0, p1, radius, geometry::ROUND_SEGMENTS)
                    .map_err(|e| p.object_error(format!("{owner}: the mesh {e}")))?;
                Source::Mesh {
                    mesh,
                    attributes: Vec::new(),
                    smooth: false,
                }
            }
            "linearcurve" | "bsplinecurve" => {
                let basis = if ty == "linearcurve" {
                    CurveBasis::Linear
                } else {
                    CurveBasis::BSpline
                };
                let path = self.resolve(&p.require_string("filename")?);
                let curve = geometry::load_curve(&path, basis, &to_world)
                    .map_err(|e| p.error("filename", "cannot load the curves").caused_by(e))?;
                if flip_normals {
                    return Err(p.error(
                        "flip_normals",
                        "curves are seen from outside only; flip_normals does not apply to them",
                    ));
                }
                Source::Curve(curve)
            }
            _ => Source::Sphere(objects::sphere(&mut p)?),
        };
        p.finish(&mut self.warnings);

        let mut bsdf: Option<(Bsdf, Pos)> = None;
        let mut area: Option<(Texture, Pos)> = None;
        let mut media = crate::medium::MediumInterface::default();
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
                    let slot = match c.name {
                        Some("interior") => &mut media.interior,
                        Some("exterior") => &mut media.exterior,
                        other => {
                            return Err(self.err(
                                c.at,
                                format!(
                                    "a <medium> inside a shape is its 'interior' or 'exterior' \
                                     (the name attribute), not {}",
                                    other.map_or("unnamed".to_string(), |n| format!("'{n}'"))
                                ),
                            ))
                        }
                    };
                    if slot.is_some() {
                        return Err(self.err(
                            c.at,
                            format!(
                                "a shape can have only one {} medium",
                                c.name.unwrap_or_default()
                            ),
                        ));
                    }
                    *slot = Some(self.medium_index(&c)?);
                }
                _ => return Err(self.misplaced(&c, &owner)),
            }
        }

        // A transform that overflows the float range breaks the shape.
        let file = self.file();
        let overflow = |e: &dyn std::fmt::Display| {
            SceneError::new(
                file,
                to_world_pos,
                format!("{owner} is not valid after its to_world: {e}"),
            )
        };
        let mut attributes = Vec::new();
        // A disk or rectangle that emits stays triangles (a fan, a pair):
        // its light samples then cover the solid angle of each triangle
        // (spherical-triangle sampling), which near the light beats the
        // uniform area sampling an analytic shape (like Mitsuba's) gets.
        let triangles = |mesh| Source::Mesh {
            mesh,
            attributes: Vec::new(),
            smooth: false,
        };
        let source = match source {
            Source::Disk if area.is_some() => {
                triangles(geometry::disk_mesh(geometry::ROUND_SEGMENTS))
            }
            Source::Rectangle if area.is_some() => triangles(geometry::rectangle_mesh()),
            other => other,
        };
        let geometry = match source {
            Source::Mesh {
                mut mesh,
                attributes: a,
                smooth,
            } => {
                attributes = a;
                mesh.transform_keep_winding(&to_world)
                    .map_err(|e| overflow(&ShapeError::Mesh(e)))?;
                if smooth {
                    mesh.compute_vertex_normals();
                }
                if flip_normals {
                    mesh.flip_normals();
                }
                Geometry::Mesh(mesh)
            }
            Source::Sphere(mut s) => {
                s.transform(&to_world).map_err(|e| match e {
                    SphereError::NotSimilarity => {
                        SceneError::new(file, to_world_pos, format!("a sphere's 'to_world' {e}"))
                    }
                    _ => overflow(&ShapeError::Sphere(e)),
                })?;
                if flip_normals {
                    self.warn(
                        node.pos,
                        "a sphere with flip_normals is rendered as a fine mesh (normals inward)",
                    );
                    let mut m = geometry::sphere_mesh(s.center, s.radius, 256, 128)
                        .map_err(|e| overflow(&ShapeError::Mesh(e)))?;
                    m.flip_normals();
                    Geometry::Mesh(m)
                } else {
                    Geometry::Sphere(s)
                }
            }
            Source::Disk => {
                let mut d =
                    geometry::Disk::new(&to_world).map_err(|e| overflow(&ShapeError::Disk(e)))?;
                if flip_normals {
                    d.flip_normals();
                }
                Geometry::Disk(d)
            }
            Source::Rectangle => {
                let mut r = geometry::Rectangle::new(&to_world)
                    .map_err(|e| overflow(&ShapeError::Rectangle(e)))?;
                if flip_normals {
                    r.flip_normals();
                }
                Geometry::Rectangle(r)
            }
            Source::Curve(c) => {
                if let Some((_, at)) = &area {
                    return Err(self.err(
                        *at,
                        format!(
                            "{owner} cannot be an area emitter (Mitsuba's curves have no \
                             surface sampling either); use a mesh or a sphere"
                        ),
                    ));
                }
                if media.interior.is_some() || media.exterior.is_some() {
                    return Err(self.err(
                        node.pos,
                        format!("{owner} cannot bound a medium: it is seen from outside only"),
                    ));
                }
                Geometry::Curve(c)
            }
        };
        let bsdf_at = bsdf.as_ref().map_or(node.pos, |b| b.1);
        let mut bsdf = match bsdf {
            Some((b, _)) => b,
            // Mitsuba's default (`render/shape.cpp`): diffuse 0.5, but
            // black for an emitter, so lights do not reflect.
            None if area.is_some() => Bsdf::Diffuse(Diffuse { albedo: Rgb::ZERO }),
            None => Bsdf::default(),
        };
        // Mesh attribute textures (of the BSDF and of an area emitter's
        // radiance) read this shape's data.
        let indices = match &geometry {
            Geometry::Mesh(m) => m.indices(),
            Geometry::Sphere(_)
            | Geometry::Disk(_)
            | Geometry::Rectangle(_)
            | Geometry::Curve(_) => &[],
        };
        let bind = |t: &mut Texture| match t.mesh_attribute_mut() {
            Some(a) => a.bind(&attributes, indices),
            None => Ok(()),
        };
        let hint = if matches!(geometry, Geometry::Mesh(_)) && !matches!(ty, "ply" | "serialized") {
            " (lente reads mesh attributes from PLY and serialized files)"
        } else {
            ""
        };
        let mut unbound = None;
        bsdf.for_each_texture_mut(&mut |t| {
            if let Err(e) = bind(t) {
                unbound.get_or_insert(e);
            }
        });
        if let Some(e) = unbound {
            return Err(self.err(
                bsdf_at,
                format!(
                    "a mesh_attribute texture of this BSDF cannot be read on {owner}: {e}{hint}"
                ),
            ));
        }
        let (area_radiance, area_texture) = match area {
            None => (None, None),
            Some((Texture::Constant(c), _)) => (Some(c), None),
            Some((mut t, at)) => {
                bind(&mut t).map_err(|e| {
                    self.err(
                        at,
                        format!(
                            "the area emitter's mesh_attribute radiance cannot be read on {owner}: {e}{hint}"
                        ),
                    )
                })?;
                (Some(t.mean()), Some(t))
            }
        };
        Ok(ShapeDesc {
            geometry,
            bsdf,
            area_radiance,
            area_texture,
            media,
        })
    }
}
