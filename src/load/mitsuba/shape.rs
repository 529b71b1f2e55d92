//! Shapes: obj, ply, sphere, rectangle, cube, disk and cylinder, with
//! their BSDF and area emitter.

use super::emitter::EmitterDesc;
use super::{BsdfSpec, Ctx};
use crate::bsdf::Bsdf;
use crate::color::Rgb;
use crate::geometry::{self, Geometry, Sphere, TriangleMesh};
use crate::load::props::positive;
use crate::load::xml::{Pos, SceneNode};
use crate::load::SceneError;
use crate::math::{Transform, Vec3};
use crate::scene::ShapeDesc;

type Result<T> = std::result::Result<T, SceneError>;

impl<'d> Ctx<'d> {
    /// Shapes (Mitsuba's `shapes/`): obj, ply, sphere, rectangle, cube,
    /// disk, cylinder; `to_world`, `flip_normals`, `face_normals` (meshes).
    pub(super) fn shape(&mut self, node: &'d SceneNode) -> Result<ShapeDesc> {
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
}
