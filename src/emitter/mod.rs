//! Light sources. `sample` draws a direction towards the light from a
//! reference point; `pdf` is the solid-angle density of doing so.

mod area;
mod area_lanes;
mod constant;
mod directional;
mod envmap;
mod light_choice;
mod light_lanes;
mod light_triangle;
mod point;
mod projector;
pub mod sky;
mod spot;

pub use area::AreaLight;
pub use area_lanes::{sample_triangles_lanes, TriangleRequest};
pub use constant::ConstantLight;
pub use directional::DirectionalLight;
pub use envmap::{EnvFilter, EnvMap, EnvMapError, EnvMapParam, EnvPoint, LightPdf, TexelRows};
#[cfg(feature = "gpu")]
pub use envmap::{EnvGpuFacing, EnvGpuTables};
#[cfg(target_arch = "x86_64")]
pub use light_choice::PointWeights8;
pub use light_choice::{ChoicePoint, LightBounds, LightChoice, EXHAUSTIVE_MAX};
pub use point::PointLight;
pub use projector::{Projector, ProjectorError};
pub use spot::{SpotError, SpotLight};

use crate::color::Rgb;
use crate::geometry::Geometry;
use crate::math::{Vec2, Vec3, PI};

/// The closed set of emitters, one kind per file; each is built by its own
/// checked constructor.
#[derive(Clone, Debug)]
pub enum Emitter {
    Area(AreaLight),
    Point(PointLight),
    /// Mitsuba's `spot` (boxed: rare, and it may hold a texture).
    Spot(Box<SpotLight>),
    /// Mitsuba's `projector` (boxed: rare, and it holds a texture).
    Projector(Box<Projector>),
    Directional(DirectionalLight),
    Constant(ConstantLight),
    /// An image-based light at infinity.
    Environment(Box<EnvMap>),
}

/// Emitter parameters that describe no light. Each message completes a
/// sentence that starts with the parameter's name.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum EmitterError {
    #[error("must be finite and not negative, found {0}")]
    Radiance(Rgb),
    #[error("must be finite, found {0}")]
    Position(Vec3),
    #[error("must be finite and not zero, found {0}")]
    Direction(Vec3),
}

/// An emitted quantity (radiance, intensity, irradiance): finite, not
/// negative.
fn radiance(value: Rgb) -> Result<Rgb, EmitterError> {
    if value.is_finite() && value.min_element() >= 0.0 {
        Ok(value)
    } else {
        Err(EmitterError::Radiance(value))
    }
}

/// Where a light that shines along its local +z stands (spot,
/// projector): its `to_world`'s origin, its unit +z in the world, and the
/// inverse of its linear part (directions into the light's frame).
/// `Err(Some(origin))` for an origin that is not finite, `Err(None)` for a
/// degenerate transform.
fn placement(
    to_world: &crate::math::Transform,
) -> Result<(Vec3, Vec3, crate::math::Mat3), Option<Vec3>> {
    let position = to_world.point(Vec3::ZERO);
    if !position.is_finite() {
        return Err(Some(position));
    }
    let axis = to_world.vector(Vec3::Z).normalize_or_zero();
    let to_local = to_world.inverse().linear();
    if axis == Vec3::ZERO || !to_local.is_finite() {
        return Err(None);
    }
    Ok((position, axis, to_local))
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
    /// A sample of a light at the point `p` (a delta in position: point,
    /// spot, projector), reached along the unit `wi` at `dist`, with
    /// `weight` = its intensity towards the reference point / dist².
    fn at_point(p: Vec3, wi: Vec3, dist: f32, weight: Rgb) -> Self {
        LightSample {
            wi,
            p,
            err: Vec3::ZERO,
            n: Vec3::ZERO,
            dist,
            weight,
            pdf: 0.0,
            delta: true,
        }
    }

    /// The sample of a light at the point `p` seen from `p_ref`, with the
    /// intensity `intensity(wi)` gives towards it (None: nothing arrives);
    /// None at `p_ref` itself.
    #[inline]
    fn from_point(
        p: Vec3,
        p_ref: Vec3,
        intensity: impl FnOnce(Vec3) -> Option<Rgb>,
    ) -> Option<Self> {
        let to = p - p_ref;
        let d2 = to.length_squared();
        if d2 <= 0.0 {
            return None;
        }
        let dist = d2.sqrt();
        let wi = to / dist;
        Some(LightSample::at_point(p, wi, dist, intensity(wi)? / d2))
    }

    /// A sample of a light at infinity in direction `wi` (the point is put
    /// beyond the scene's bounding sphere, for shadow rays).
    pub(crate) fn at_infinity(
        ctx: &EmitterContext,
        p_ref: Vec3,
        wi: Vec3,
        weight: Rgb,
        pdf: f32,
    ) -> Self {
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

/// Where a ray met an area light: the point, the normal of the side that
/// emits, and the triangle (0 on spheres).
#[derive(Clone, Copy, Debug)]
pub struct LightHit {
    pub p: Vec3,
    pub n: Vec3,
    pub prim: u32,
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
            Emitter::Area(_) => "area",
            Emitter::Point(_) => "point",
            Emitter::Spot(_) => "spot",
            Emitter::Projector(_) => "projector",
            Emitter::Directional(_) => "directional",
            Emitter::Constant(_) => "constant",
            Emitter::Environment(_) => "environment",
        }
    }

    pub fn is_infinite(&self) -> bool {
        matches!(self, Emitter::Constant(_) | Emitter::Environment(_))
    }

    /// False for an environment map marked invisible to camera rays.
    pub fn visible_to_camera(&self) -> bool {
        match self {
            Emitter::Environment(env) => env.visible,
            _ => true,
        }
    }

    pub fn is_delta(&self) -> bool {
        matches!(
            self,
            Emitter::Point(_) | Emitter::Spot(_) | Emitter::Projector(_) | Emitter::Directional(_)
        )
    }

    /// Estimated emitted power (luminance), for choosing lights.
    pub fn power(&self, ctx: &EmitterContext) -> f32 {
        match self {
            Emitter::Area(e) => e.power(ctx),
            Emitter::Point(e) => e.power(),
            Emitter::Spot(e) => e.power(),
            Emitter::Projector(e) => e.power(),
            Emitter::Directional(e) => e.power(ctx),
            Emitter::Constant(e) => e.power(ctx),
            Emitter::Environment(e) => {
                PI * ctx.scene_radius * ctx.scene_radius * PI * e.mean_luminance()
            }
        }
    }

    /// Radiance arriving along a ray that escapes the scene in direction `d`
    /// (zero for lights that are not at infinity).
    pub fn eval_infinite(&self, d: Vec3) -> Rgb {
        self.eval_infinite_at(d, None)
    }

    /// [`Emitter::eval_infinite`], with `d` already located on this
    /// emitter's map if it has one ([`Emitter::locate_escape`]).
    #[inline]
    pub fn eval_infinite_at(&self, d: Vec3, at: Option<EnvPoint>) -> Rgb {
        match self {
            Emitter::Constant(e) => e.radiance,
            Emitter::Environment(e) => at.map_or_else(|| e.eval(d), |at| e.eval_at(at)),
            _ => Rgb::ZERO,
        }
    }

    /// `(eval_infinite(d), pdf(.., d, .., which, facing))` in one go (an
    /// environment map finds its texels once), with `d` already located on
    /// this emitter's map if `at` is given.
    pub fn eval_infinite_pdf(
        &self,
        d: Vec3,
        at: Option<EnvPoint>,
        which: LightPdf,
        facing: Option<Vec3>,
    ) -> (Rgb, f32) {
        match self {
            Emitter::Constant(e) => (e.radiance, e.pdf(d)),
            Emitter::Environment(e) => match at {
                Some(at) => e.eval_pdf_at(at, which, facing),
                None => e.eval_pdf(d, which, facing),
            },
            _ => (Rgb::ZERO, 0.0),
        }
    }

    /// Where `d` meets this emitter's environment map (`None` for other
    /// emitters), with what looking it up with `which` reads prefetched:
    /// for a path that is about to trace a ray along `d` and will need
    /// them if it escapes.
    #[inline]
    pub fn locate_escape(&self, d: Vec3, which: LightPdf) -> Option<EnvPoint> {
        let Emitter::Environment(e) = self else {
            return None;
        };
        let at = e.locate(d)?;
        e.prefetch_point(at, which);
        Some(at)
    }

    /// Prefetches what `sample(.., u, .., which)` reads (environment maps
    /// only), for a caller that draws `u` before it samples.
    #[inline]
    pub fn prefetch_sample(&self, u: Vec2, which: LightPdf) {
        if let Emitter::Environment(e) = self {
            e.prefetch_sample(u, which);
        }
    }

    /// Samples incident illumination at `p_ref` with the density `which`
    /// (only environment maps have more than one), for a surface that only
    /// receives light from the side its normal `facing` points to, if given
    /// (environment maps then sample less of what is behind it).
    pub fn sample(
        &self,
        ctx: &EmitterContext,
        p_ref: Vec3,
        u: Vec2,
        u1: f32,
        which: LightPdf,
        facing: Option<Vec3>,
    ) -> Option<LightSample> {
        match self {
            Emitter::Area(e) => e.sample(ctx, p_ref, u, u1),
            Emitter::Point(e) => e.sample(p_ref),
            Emitter::Spot(e) => e.sample(p_ref),
            Emitter::Projector(e) => e.sample(p_ref),
            Emitter::Directional(e) => e.sample(ctx, p_ref),
            Emitter::Constant(e) => e.sample(ctx, p_ref, u),
            Emitter::Environment(e) => {
                let (wi, weight, pdf) = e.sample(u, which, facing)?;
                Some(LightSample::at_infinity(ctx, p_ref, wi, weight, pdf))
            }
        }
    }

    /// Solid-angle pdf that `sample` from `p_ref` with the density `which`
    /// and `facing` produces the point `at` (area lights) or the direction
    /// `wi` (infinite).
    pub fn pdf(
        &self,
        ctx: &EmitterContext,
        p_ref: Vec3,
        wi: Vec3,
        at: &LightHit,
        which: LightPdf,
        facing: Option<Vec3>,
    ) -> f32 {
        match self {
            Emitter::Area(e) => e.pdf(ctx, p_ref, wi, at),
            Emitter::Point(_)
            | Emitter::Spot(_)
            | Emitter::Projector(_)
            | Emitter::Directional(_) => 0.0,
            Emitter::Constant(e) => e.pdf(wi),
            Emitter::Environment(e) => e.pdf(wi, which, facing),
        }
    }
}
