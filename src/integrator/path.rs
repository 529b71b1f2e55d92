//! The unidirectional path tracer with three ways of finding light:
//! BSDF sampling (mats), emitter sampling (ems), and both with MIS.

use super::{sample_light_with, LightNumbers, PathParams, Strategy};
use crate::color::{max_component, Rgb};
use crate::emitter::{ChoicePoint, Emitter, EnvPoint, LightHit, LightPdf};
use crate::geometry::Intersection;
use crate::math::{Ray, Vec3};
use crate::sampling::Sampler;
use crate::scene::Scene;

/// Power heuristic (beta = 2) weight of strategy `a` against `b`.
#[inline]
pub(super) fn power_heuristic(a: f32, b: f32) -> f32 {
    let (a2, b2) = (a * a, b * b);
    if a2 + b2 == 0.0 || !a2.is_finite() {
        if a2.is_infinite() {
            1.0
        } else {
            0.0
        }
    } else {
        a2 / (a2 + b2)
    }
}

/// Probability that emitter sampling at the shading point `at` picks
/// emitter `i`.
#[inline]
pub(super) fn choice_pdf(scene: &Scene, i: usize, at: &ChoicePoint) -> f32 {
    scene.light_choice.as_ref().map_or(0.0, |c| c.pdf(at, i))
}

/// Area emitters a camera ray passes through before its first hit, at most.
const MAX_EMITTER_SKIPS: usize = 64;

/// Mitsuba's `hide_emitters`: camera rays pass through area emitters (up
/// to [`MAX_EMITTER_SKIPS`] of them) to the surface behind.
pub(super) fn skip_area_emitters(
    scene: &Scene,
    ray: &Ray,
    mut hit: Option<Intersection>,
) -> Option<Intersection> {
    for _ in 0..MAX_EMITTER_SKIPS {
        match &hit {
            Some(its) if scene.shape_emitter[its.shape as usize].is_some() => {
                let o = its.spawn(ray.d);
                hit = scene.intersect(&Ray::new(o, ray.d));
            }
            _ => break,
        }
    }
    hit
}

/// The last real vertex of a path, against whose sampling density
/// emission found by the path is weighed (MIS with next-event estimation).
#[derive(Clone, Copy)]
pub(super) struct PrevVertex<'a> {
    /// Solid-angle density of the direction it sampled.
    pub pdf: f32,
    pub p: Vec3,
    /// Its light choice.
    pub at: &'a ChoicePoint,
}

/// Adds to `l` the emission at infinity seen along the escaping direction
/// `d`, times `beta`: weighed against NEE at `mis` if given, in full
/// otherwise. `camera_ray`: only emitters visible to the camera count.
/// `escape`: `d` located on an environment map before the ray was traced
/// ([`Scene::locate_escape`]), if it was.
#[allow(clippy::too_many_arguments)]
pub(super) fn add_infinite_emission(
    scene: &Scene,
    d: Vec3,
    escape: Option<(u32, EnvPoint)>,
    camera_ray: bool,
    beta: Rgb,
    mis: Option<PrevVertex>,
    which: LightPdf,
    l: &mut Rgb,
) {
    for &i in &scene.infinite {
        let e = &scene.emitters[i as usize];
        if camera_ray && !e.visible_to_camera() {
            continue;
        }
        let at = escape.filter(|&(j, _)| j == i).map(|(_, at)| at);
        let (le, w) = match mis {
            Some(prev) => {
                let (le, pdf) = e.eval_infinite_pdf(d, at, which, prev.at.facing);
                let pl = choice_pdf(scene, i as usize, prev.at) * pdf;
                (le, power_heuristic(prev.pdf, pl))
            }
            None => (e.eval_infinite_at(d, at), 1.0),
        };
        *l += beta * le * w;
    }
}

/// Adds to `l` the emission of the area light hit at `its` by a ray along
/// `d` (if it is one, seen from its front), times `beta`: weighed against
/// NEE at `mis` if given, in full otherwise.
pub(super) fn add_area_emission(
    scene: &Scene,
    its: &Intersection,
    d: Vec3,
    beta: Rgb,
    mis: Option<PrevVertex>,
    which: LightPdf,
    l: &mut Rgb,
) {
    let Some(ei) = scene.shape_emitter[its.shape as usize] else {
        return;
    };
    let e = &scene.emitters[ei as usize];
    let Emitter::Area(light) = e else {
        return;
    };
    if its.ng.dot(-d) <= 0.0 {
        return;
    }
    let w = match mis {
        Some(prev) => {
            let hit = LightHit {
                p: its.p,
                n: its.ng,
                prim: its.prim,
            };
            let pl = choice_pdf(scene, ei as usize, prev.at)
                * e.pdf(
                    &scene.emitter_context(),
                    prev.p,
                    d,
                    &hit,
                    which,
                    prev.at.facing,
                );
            power_heuristic(prev.pdf, pl)
        }
        None => 1.0,
    };
    *l += beta * light.radiance_at(its.surface_point()) * w;
}

/// Russian roulette from `rr_depth` on (survival probability the
/// throughput's largest channel times `eta_scale`, at most 0.99); false
/// if the path ends.
#[inline]
pub(super) fn roulette(
    beta: &mut Rgb,
    eta_scale: f32,
    depth: u32,
    params: &PathParams,
    sampler: &mut Sampler,
) -> bool {
    if depth < params.rr_depth {
        return true;
    }
    let q = (max_component(*beta) * eta_scale).min(0.99);
    if sampler.next_1d() >= q {
        return false;
    }
    *beta /= q;
    true
}

pub fn li(
    scene: &Scene,
    camera_ray: &Ray,
    sampler: &mut Sampler,
    strategy: Strategy,
    params: &PathParams,
) -> Rgb {
    let which = strategy.light_pdf();
    let max_depth = params.max_depth.unwrap_or(u32::MAX);
    let mut l = Rgb::ZERO;
    let mut beta = Rgb::ONE;
    let mut ray = *camera_ray;
    // Whether the last bounce was specular (or this is the camera ray).
    let mut specular = true;
    // Solid-angle pdf of the BSDF sample that produced `ray`, and its origin.
    let mut prev_pdf = 0.0f32;
    let mut prev_p = ray.o;
    // The light choice at the vertex that sampled `ray` (for MIS weights).
    let mut prev_at = ChoicePoint::default();
    let mut eta_scale = 1.0f32;
    let mut depth = 0u32;
    // The next vertex's light-sample numbers, drawn ahead (LightNumbers).
    let nee = strategy != Strategy::Mats;
    let mut light_numbers = nee.then(|| LightNumbers::draw_ahead(scene, sampler, which));
    // Where `ray` meets the environment map, found (and its texels
    // prefetched) before it is traced: bounce rays escape to random parts
    // of the map, whose texels are rarely in the cache.
    let mut escape = None;

    loop {
        let mut hit = scene.intersect(&ray);
        if depth == 0 && params.hide_emitters {
            hit = skip_area_emitters(scene, &ray, hit);
        }
        // Emission found by following the path.
        let count_emission = |specular: bool| -> bool {
            match strategy {
                Strategy::Mats | Strategy::Mis => true,
                Strategy::Ems => specular,
            }
        };
        let mis = (strategy == Strategy::Mis && !specular).then_some(PrevVertex {
            pdf: prev_pdf,
            p: prev_p,
            at: &prev_at,
        });
        let Some(its) = hit else {
            if depth == 0 && params.hide_emitters {
                break;
            }
            if count_emission(specular) {
                add_infinite_emission(scene, ray.d, escape, depth == 0, beta, mis, which, &mut l);
            }
            break;
        };

        let wi_world = -ray.d;
        if count_emission(specular) && !(depth == 0 && params.hide_emitters) {
            add_area_emission(scene, &its, ray.d, beta, mis, which, &mut l);
        }

        depth += 1;
        if depth >= max_depth {
            break;
        }

        let bsdf = &scene.bsdfs[its.shape as usize];
        let sp = scene.surface_point(&its);
        let frame = its.shading;
        let wi = frame.to_local(wi_world);

        // Next-event estimation.
        if let (Some(numbers), false) = (light_numbers, bsdf.is_specular()) {
            // A surface that only reflects receives light from the side of
            // its shading normal that `wi` is on (the BSDF is zero across):
            // an environment map then samples for that side (`facing.rs`).
            // Only at the first vertex: its light reaches the pixel
            // unattenuated and brings most of the variance (studio probe:
            // MSE 0.52x with it there, 0.49x at every vertex), while each
            // facing sample costs about a fifth more than the map's own
            // (maps where it would not pay have no facing density at all).
            let facing = (depth == 1 && bsdf.favours_facing_light()).then(|| {
                if wi.z < 0.0 {
                    -frame.n
                } else {
                    frame.n
                }
            });
            prev_at = scene.choice_point(its.p, frame.n).facing(facing);
            if let Some((ls, pchoice)) = sample_light_with(scene, its.p, &prev_at, numbers, which) {
                let wo = frame.to_local(ls.wi);
                // The BSDF's density only where MIS weighs with it, and
                // then with its value in one call (they share work).
                let mis = strategy == Strategy::Mis && !ls.delta;
                let (f, bsdf_pdf) = if mis {
                    bsdf.eval_pdf(sp, wi, wo)
                } else {
                    (bsdf.eval(sp, wi, wo), 0.0)
                };
                if f != Rgb::ZERO && ls.weight != Rgb::ZERO && scene.unoccluded(&its, &ls) {
                    let w = if mis {
                        power_heuristic(ls.pdf * pchoice, bsdf_pdf)
                    } else {
                        1.0
                    };
                    l += beta * f * wo.z.abs() * ls.weight * (w / pchoice);
                }
            }
        }

        // Continue the path by sampling the BSDF.
        let u = sampler.next_2d();
        let u_lobe = sampler.next_1d();
        let Some(bs) = bsdf.sample(sp, wi, u, u_lobe) else {
            break;
        };
        let wo_world = frame.to_world(bs.wo);
        // Reject samples that cross the geometric surface against the
        // shading normal's verdict (light leaks through shading normals).
        if wo_world.dot(its.ng) * bs.wo.z <= 0.0 && wi_world.dot(its.ng) * wi.z > 0.0 {
            break;
        }
        beta *= bs.weight;
        eta_scale *= bs.eta * bs.eta;
        specular = bs.specular;
        prev_pdf = if bs.specular { 0.0 } else { bs.pdf };
        prev_p = its.p;
        if beta == Rgb::ZERO {
            break;
        }

        if !roulette(&mut beta, eta_scale, depth, params, sampler) {
            break;
        }

        let o = its.spawn(wo_world);
        ray = Ray::new(o, wo_world);
        // Only where the path would count what it finds there (not
        // behind a diffuse bounce under `path_ems`).
        escape = if count_emission(specular) {
            scene.locate_escape(wo_world, which)
        } else {
            None
        };
        if nee {
            light_numbers = Some(LightNumbers::draw_ahead(scene, sampler, which));
        }
    }
    l
}
