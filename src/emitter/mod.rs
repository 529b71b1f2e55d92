//! Light sources. `sample` draws a direction towards the light from a
//! reference point; `pdf` is the solid-angle density of doing so.

mod envmap;
pub mod sky;

pub use envmap::{EnvFilter, EnvMap, EnvMapError, EnvMapParam};

use crate::color::{luminance, Rgb};
use crate::geometry::Geometry;
use crate::math::{Vec2, Vec3, PI};

/// The closed set of emitters.
#[derive(Clone, Debug)]
pub enum Emitter {
    /// Uniform emission from the front side of a shape.
    Area { shape: u32, radiance: Rgb },
    /// Isotropic point light with radiant intensity `intensity` (W/sr).
    Point { position: Vec3, intensity: Rgb },
    /// Parallel light arriving along `direction` (unit, the way the light
    /// travels) with `irradiance` on a surface facing it.
    Directional { direction: Vec3, irradiance: Rgb },
    /// Uniform radiance from every direction at infinity.
    Constant { radiance: Rgb },
    /// An image-based light at infinity.
    Environment(Box<EnvMap>),
}

/// A light sample as seen from a reference point.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// Unit direction from the reference point towards the light.
    pub wi: Vec3,
    /// Point on the light (far away for infinite lights).
    pub p: Vec3,
    /// Floating-point error bound of `p` (zero where `p` is exact).
    pub err: Vec3,
    /// Normal at the light point (zero for points and infinite lights).
    pub n: Vec3,
    /// Distance to the light point (infinity for infinite lights).
    pub dist: f32,
    /// Incident radiance divided by the solid-angle pdf (for delta lights:
    /// intensity / dist^2).
    pub weight: Rgb,
    /// Solid-angle pdf (0 for delta lights, which MIS must not weight).
    pub pdf: f32,
    pub delta: bool,
}

impl LightSample {
    /// A sample of a light at infinity in direction `wi` (the point is put
    /// beyond the scene's bounding sphere, for shadow rays).
    fn at_infinity(ctx: &EmitterContext, p_ref: Vec3, wi: Vec3, weight: Rgb, pdf: f32) -> Self {
        LightSample {
            wi,
            p: p_ref + wi * (2.0 * ctx.scene_radius),
            err: Vec3::ZERO,
            n: Vec3::ZERO,
            dist: f32::INFINITY,
            weight,
            pdf,
            delta: pdf == 0.0,
        }
    }
}

/// Geometry of the scene the emitters need (area lights live on shapes;
/// infinite lights need the scene's bounding sphere for power estimates).
pub struct EmitterContext<'a> {
    pub shapes: &'a [Geometry],
    pub scene_radius: f32,
}

impl Emitter {
    /// Short name for reports.
    pub fn name(&self) -> &'static str {
        match self {
            Emitter::Area { .. } => "area",
            Emitter::Point { .. } => "point",
            Emitter::Directional { .. } => "directional",
            Emitter::Constant { .. } => "constant",
            Emitter::Environment(_) => "environment",
        }
    }

    pub fn is_infinite(&self) -> bool {
        matches!(self, Emitter::Constant { .. } | Emitter::Environment(_))
    }

    /// False for an environment map marked invisible to camera rays.
    pub fn visible_to_camera(&self) -> bool {
        match self {
            Emitter::Environment(env) => env.visible,
            _ => true,
        }
    }

    pub fn is_delta(&self) -> bool {
        matches!(self, Emitter::Point { .. } | Emitter::Directional { .. })
    }

    /// Estimated emitted power (luminance), for choosing lights.
    pub fn power(&self, ctx: &EmitterContext) -> f32 {
        match self {
            Emitter::Area { shape, radiance } => {
                PI * ctx.shapes[*shape as usize].area() * luminance(*radiance)
            }
            Emitter::Point { intensity, .. } => 4.0 * PI * luminance(*intensity),
            Emitter::Directional { irradiance, .. } => {
                PI * ctx.scene_radius * ctx.scene_radius * luminance(*irradiance)
            }
            Emitter::Constant { radiance } => {
                PI * ctx.scene_radius * ctx.scene_radius * PI * luminance(*radiance)
            }
            Emitter::Environment(env) => {
                PI * ctx.scene_radius * ctx.scene_radius * PI * env.mean_luminance()
            }
        }
    }

    /// Radiance arriving along a ray that escapes the scene in direction `d`
    /// (zero for lights that are not at infinity).
    pub fn eval_infinite(&self, d: Vec3) -> Rgb {
        match self {
            Emitter::Constant { radiance } => *radiance,
            Emitter::Environment(env) => env.eval(d),
            _ => Rgb::ZERO,
        }
    }

    /// Samples incident illumination at `p_ref`.
    pub fn sample(
        &self,
        ctx: &EmitterContext,
        p_ref: Vec3,
        u: Vec2,
        u1: f32,
    ) -> Option<LightSample> {
        match self {
            Emitter::Area { shape, radiance } => {
                let s = match &ctx.shapes[*shape as usize] {
                    Geometry::Mesh(m) => m.sample_area(u1, u),
                    Geometry::Sphere(sp) => match sp.visible_cone(p_ref) {
                        // Outside the sphere: sample the cone it subtends.
                        Some(cone) => {
                            let (s, pdf) = sp.sample_cone(p_ref, &cone, u);
                            return Some(LightSample {
                                wi: (s.p - p_ref).normalize(),
                                p: s.p,
                                err: s.err,
                                n: s.n,
                                dist: (s.p - p_ref).length(),
                                weight: *radiance / pdf,
                                pdf,
                                delta: false,
                            });
                        }
                        None => sp.sample_area(u),
                    },
                };
                let to = s.p - p_ref;
                let d2 = to.length_squared();
                if d2 <= 0.0 {
                    return None;
                }
                let dist = d2.sqrt();
                let wi = to / dist;
                let cos_l = -wi.dot(s.n);
                if cos_l <= 0.0 {
                    return None;
                }
                let pdf = s.pdf_area * d2 / cos_l;
                Some(LightSample {
                    wi,
                    p: s.p,
                    err: s.err,
                    n: s.n,
                    dist,
                    weight: *radiance / pdf,
                    pdf,
                    delta: false,
                })
            }
            Emitter::Point {
                position,
                intensity,
            } => {
                let to = *position - p_ref;
                let d2 = to.length_squared();
                if d2 <= 0.0 {
                    return None;
                }
                let dist = d2.sqrt();
                Some(LightSample {
                    wi: to / dist,
                    p: *position,
                    err: Vec3::ZERO,
                    n: Vec3::ZERO,
                    dist,
                    weight: *intensity / d2,
                    pdf: 0.0,
                    delta: true,
                })
            }
            Emitter::Directional {
                direction,
                irradiance,
            } => Some(LightSample::at_infinity(
                ctx,
                p_ref,
                -*direction,
                *irradiance,
                0.0,
            )),
            Emitter::Constant { radiance } => {
                let wi = crate::sampling::warp::square_to_uniform_sphere(u);
                let pdf = crate::sampling::warp::square_to_uniform_sphere_pdf(wi);
                Some(LightSample::at_infinity(
                    ctx,
                    p_ref,
                    wi,
                    *radiance / pdf,
                    pdf,
                ))
            }
            Emitter::Environment(env) => {
                let (wi, weight, pdf) = env.sample(u)?;
                Some(LightSample::at_infinity(ctx, p_ref, wi, weight, pdf))
            }
        }
    }

    /// Solid-angle pdf that `sample` from `p_ref` produces the point `p_light`
    /// with normal `n_light` (area lights) or the direction `wi` (infinite).
    pub fn pdf(
        &self,
        ctx: &EmitterContext,
        p_ref: Vec3,
        wi: Vec3,
        p_light: Vec3,
        n_light: Vec3,
    ) -> f32 {
        match self {
            Emitter::Area { shape, .. } => {
                let g = &ctx.shapes[*shape as usize];
                if let Geometry::Sphere(sp) = g {
                    if let Some(cone) = sp.visible_cone(p_ref) {
                        return cone.pdf();
                    }
                }
                let area = g.area();
                let d2 = (p_light - p_ref).length_squared();
                let cos_l = (-wi).dot(n_light);
                if cos_l <= 0.0 || area <= 0.0 {
                    return 0.0;
                }
                d2 / (cos_l * area)
            }
            Emitter::Point { .. } | Emitter::Directional { .. } => 0.0,
            Emitter::Constant { .. } => crate::sampling::warp::square_to_uniform_sphere_pdf(wi),
            Emitter::Environment(env) => env.pdf(wi),
        }
    }
}
