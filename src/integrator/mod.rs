//! Integrators: estimate the radiance arriving along a camera ray.

mod path;
mod path_batch;
mod simple;
mod volpath;
mod whitted;

pub use path::PathConfig;
pub use path_batch::{PathBatch, BATCH_PATHS};

use crate::color::Rgb;
use crate::emitter::{ChoicePoint, LightPdf, LightSample};
use crate::math::{Ray, Vec2, Vec3};
use crate::sampling::Sampler;
use crate::scene::Scene;

/// Picks an emitter for the shading point `at` (see
/// [`crate::emitter::LightChoice`]) and samples incident light at `p` from
/// it with the density `which`. Returns the sample and the probability of
/// the choice.
fn sample_light(
    scene: &Scene,
    p: Vec3,
    at: &ChoicePoint,
    sampler: &mut Sampler,
    which: LightPdf,
) -> Option<(LightSample, f32)> {
    sample_light_with(scene, p, at, LightNumbers::draw(sampler), which)
}

/// [`sample_light`] with numbers drawn beforehand.
fn sample_light_with(
    scene: &Scene,
    p: Vec3,
    at: &ChoicePoint,
    numbers: LightNumbers,
    which: LightPdf,
) -> Option<(LightSample, f32)> {
    let choice = scene.light_choice.as_ref()?;
    let (i, pchoice, u1) = choice.sample(at, numbers.choice)?;
    let ls =
        scene.emitters[i].sample(&scene.emitter_context(), p, numbers.u, u1, which, at.facing)?;
    Some((ls, pchoice))
}

/// The uniform numbers of one next-event estimate, drawn before the ray to
/// its shading point is traced, so that the big tables an environment map
/// samples from are fetched from memory while the BVH is walked rather than
/// after (on env-lit scenes that wait was a tenth of the render).
#[derive(Clone, Copy, Debug)]
struct LightNumbers {
    /// Chooses the emitter.
    choice: f32,
    /// Samples it.
    u: Vec2,
}

impl LightNumbers {
    /// Draws the numbers, the choice first.
    #[inline]
    fn draw(sampler: &mut Sampler) -> LightNumbers {
        let choice = sampler.next_1d();
        LightNumbers {
            choice,
            u: sampler.next_2d(),
        }
    }

    /// Draws the numbers and prefetches what sampling an emitter at
    /// infinity with them reads (that choice does not depend on the
    /// shading point). Inlined: most scenes have nothing to prefetch, and the draws are
    /// a few instructions (the call and its spills cost as much).
    #[inline(always)]
    fn draw_ahead(scene: &Scene, sampler: &mut Sampler, which: LightPdf) -> LightNumbers {
        let numbers = LightNumbers::draw(sampler);
        if scene.has_environment_map {
            LightNumbers::prefetch(numbers.choice, numbers.u, scene, which);
        }
        numbers
    }

    /// Prefetches what sampling the emitter at infinity the numbers
    /// `choice` and `u` choose (if they choose one) reads. (The numbers
    /// one by one, in registers: a `LightNumbers` went to the stack for
    /// the call, and the path's copy of it was loaded back from there
    /// before those stores had landed.)
    #[inline(never)]
    fn prefetch(choice: f32, u: Vec2, scene: &Scene, which: LightPdf) {
        if let Some(c) = &scene.light_choice {
            if let Some(i) = c.choice_at_infinity(choice) {
                scene.emitters[i].prefetch_sample(u, which);
            }
        }
    }
}

/// Path-tracer parameters shared by the path integrators.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathParams {
    /// Longest path in segments (1 = emitters seen directly); `None` is unlimited.
    pub max_depth: Option<u32>,
    /// Path length from which Russian roulette starts.
    pub rr_depth: u32,
    /// Hide emitters seen directly by the camera.
    pub hide_emitters: bool,
}

impl Default for PathParams {
    fn default() -> Self {
        PathParams {
            max_depth: None,
            rr_depth: 3,
            hide_emitters: false,
        }
    }
}

/// The path tracer's parameters for `direct`: paths of two segments.
const DIRECT_PARAMS: PathParams = PathParams {
    max_depth: Some(2),
    rr_depth: u32::MAX,
    hide_emitters: false,
};

/// How the emitted light of the scene is gathered along paths.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Strategy {
    /// BSDF sampling only: emission is counted where a path hits it.
    Mats,
    /// Emitter sampling (next-event estimation) at every non-specular vertex.
    Ems,
    /// Both, combined with the power heuristic.
    Mis,
}

impl Strategy {
    /// The light-sampling density this strategy may use: MIS can leave the
    /// dim parts of an environment map to BSDF sampling.
    pub fn light_pdf(self) -> LightPdf {
        match self {
            Strategy::Mis => LightPdf::MisCompensated,
            Strategy::Mats | Strategy::Ems => LightPdf::Complete,
        }
    }
}

/// The closed set of integrators.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Integrator {
    /// Absolute value of the shading normal as a colour.
    Normals,
    /// Ambient occlusion: fraction of the cosine-weighted hemisphere that is
    /// unoccluded within `length`.
    Ao { length: f32 },
    /// Average visibility of the uniform hemisphere within `length`.
    AverageVisibility { length: f32 },
    /// Nori's `simple`: one point light, white diffuse shading, shadows.
    Simple {
        position: crate::math::Vec3,
        energy: Rgb,
    },
    /// Emitter sampling on diffuse surfaces, recursion through specular ones.
    Whitted,
    /// Unidirectional path tracing.
    Path {
        strategy: Strategy,
        params: PathParams,
    },
    /// Direct illumination only (paths of two segments) with one strategy.
    Direct { strategy: Strategy },
    /// Path tracing through participating media (Mitsuba's `volpath`):
    /// free flights, phase functions, shadow rays through null surfaces.
    VolPath { params: PathParams },
}

impl Integrator {
    /// Estimates incident radiance along `ray` (one sample).
    pub fn li(&self, scene: &Scene, ray: &Ray, sampler: &mut Sampler) -> Rgb {
        match self {
            Integrator::Normals => simple::normals(scene, ray),
            Integrator::Ao { length } => simple::ao(scene, ray, sampler, *length),
            Integrator::AverageVisibility { length } => {
                simple::average_visibility(scene, ray, sampler, *length)
            }
            Integrator::Simple { position, energy } => {
                simple::simple_point(scene, ray, *position, *energy)
            }
            Integrator::Whitted => whitted::li(scene, ray, sampler),
            Integrator::Path { strategy, params } => {
                path::li(scene, ray, sampler, *strategy, params)
            }
            Integrator::VolPath { params } => volpath::li(scene, ray, sampler, params),
            Integrator::Direct { strategy } => {
                path::li(scene, ray, sampler, *strategy, &DIRECT_PARAMS)
            }
        }
    }

    /// The path tracer's configuration, for the integrators that are the
    /// path tracer (`path`, `direct`): their samples can be traced as a
    /// batch ([`PathBatch`]).
    pub fn path_config(&self) -> Option<PathConfig> {
        match self {
            Integrator::Path { strategy, params } => Some(PathConfig::new(*strategy, params)),
            Integrator::Direct { strategy } => Some(PathConfig::new(*strategy, &DIRECT_PARAMS)),
            _ => None,
        }
    }

    /// Name as a Nori scene would spell it.
    pub fn name(&self) -> &'static str {
        match self {
            Integrator::Normals => "normals",
            Integrator::Ao { .. } => "ao",
            Integrator::AverageVisibility { .. } => "av",
            Integrator::Simple { .. } => "simple",
            Integrator::Whitted => "whitted",
            Integrator::VolPath { .. } => "volpath",
            Integrator::Direct { strategy } => match strategy {
                Strategy::Mats => "direct_mats",
                Strategy::Ems => "direct_ems",
                Strategy::Mis => "direct_mis",
            },
            Integrator::Path { strategy, .. } => match strategy {
                Strategy::Mats => "path_mats",
                Strategy::Ems => "path_ems",
                Strategy::Mis => "path_mis",
            },
        }
    }
}
