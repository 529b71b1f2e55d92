//! Path tracing through participating media: Mitsuba 3's `volpath`.
//!
//! A path is always in one medium (or in vacuum): the camera's, then the
//! one behind the last surface it crossed that names media (its
//! `interior` behind the geometric normal, `exterior` in front). In a
//! medium, each segment either reaches the next surface or scatters at a
//! sampled distance ([`crate::medium::Medium::sample_distance`]); at a
//! scattering point the path samples an emitter (next-event estimation)
//! and its phase function, combined with the power heuristic, as at
//! surfaces. Shadow rays pass through surfaces with a null lobe (`null`,
//! a mask's holes, a polarizer, a thin dielectric's transmission), keeping
//! their null transmission and
//! changing medium as they cross, and are attenuated by every medium on
//! the way. As in Mitsuba, null crossings are not bounces: `max_depth`
//! counts scattering in media and at real surfaces.

use super::path::{
    add_area_emission, add_infinite_emission, power_heuristic, roulette, skip_area_emitters,
    PrevVertex,
};
use super::{sample_light, PathParams};
use crate::color::Rgb;
use crate::emitter::{ChoicePoint, LightPdf, LightSample};
use crate::math::{offset_ray_origin, Ray, Vec3};
use crate::medium::FreeFlight;
use crate::sampling::Sampler;
use crate::scene::Scene;

/// Surfaces a path or shadow ray may pass straight through in a row
/// before it is given up (coincident null surfaces would loop forever).
const MAX_NULL_CROSSINGS: u32 = 256;

pub fn li(scene: &Scene, camera_ray: &Ray, sampler: &mut Sampler, params: &PathParams) -> Rgb {
    let which = LightPdf::MisCompensated;
    let max_depth = params.max_depth.unwrap_or(u32::MAX);
    let mut l = Rgb::ZERO;
    let mut beta = Rgb::ONE;
    // Camera rays are unit length, as every later ray is: distances in
    // media are ray parameters.
    let mut ray = *camera_ray;
    let mut medium = scene.camera_medium;
    // Whether emission found by this ray counts in full (camera ray, or
    // the last real vertex was a delta lobe or a medium without NEE).
    let mut specular = true;
    // The last real vertex: the density of the direction it sampled, its
    // position and its light choice (for MIS weights).
    let mut prev_pdf = 0.0f32;
    let mut prev_p = ray.o;
    let mut prev_at = ChoicePoint::default();
    let mut eta_scale = 1.0f32;
    // Real scattering events so far (surfaces and media, not null crossings).
    let mut depth = 0u32;
    let mut nulls = 0u32;

    loop {
        let mut hit = scene.intersect(&ray);
        if depth == 0 && params.hide_emitters {
            hit = skip_area_emitters(scene, &ray, hit);
        }

        // The medium along the segment: scatter in it, or pass to its end.
        if let Some(m) = medium {
            let m = &scene.media[m as usize];
            let t_max = hit.as_ref().map_or(f32::INFINITY, |h| h.t);
            match m.sample_distance(&ray, t_max, sampler) {
                FreeFlight::Pass { weight } => {
                    beta *= weight;
                    if beta == Rgb::ZERO {
                        break;
                    }
                }
                FreeFlight::Scatter { t, weight } => {
                    beta *= weight;
                    depth += 1;
                    if depth >= max_depth || beta == Rgb::ZERO {
                        break;
                    }
                    let p = ray.at(t);
                    let d = ray.d;
                    if m.sample_emitters {
                        prev_at = scene.choice_point(p, Vec3::ZERO);
                        if let Some((ls, pchoice)) =
                            sample_light(scene, p, &prev_at, sampler, which)
                        {
                            let f = m.phase.eval(d, ls.wi);
                            if f > 0.0 && ls.weight != Rgb::ZERO {
                                let tr = shadow_transmittance(scene, p, medium, &ls, sampler);
                                if tr != Rgb::ZERO {
                                    let w = if ls.delta {
                                        1.0
                                    } else {
                                        power_heuristic(ls.pdf * pchoice, f)
                                    };
                                    l += beta * ls.weight * tr * (f * w / pchoice);
                                }
                            }
                        }
                    }
                    let ps = m.phase.sample(d, sampler.next_2d());
                    // Without NEE here, light found by the phase sample
                    // counts in full.
                    specular = !m.sample_emitters;
                    prev_pdf = ps.pdf;
                    prev_p = p;
                    if !roulette(&mut beta, eta_scale, depth, params, sampler) {
                        break;
                    }
                    nulls = 0;
                    ray = Ray::new(p, ps.wo);
                    continue;
                }
            }
        }

        let mis = (!specular).then_some(PrevVertex {
            pdf: prev_pdf,
            p: prev_p,
            at: &prev_at,
        });
        let Some(its) = hit else {
            if !(depth == 0 && params.hide_emitters) {
                add_infinite_emission(scene, ray.d, None, depth == 0, beta, mis, which, &mut l);
            }
            break;
        };

        let wi_world = -ray.d;
        let shape = its.shape as usize;
        if !(depth == 0 && params.hide_emitters) {
            add_area_emission(scene, &its, ray.d, beta, mis, which, &mut l);
        }

        let bsdf = &scene.bsdfs[shape];
        let interface = scene.shape_media[shape];
        let sp = scene.surface_point(&its);
        let frame = its.shading;
        let wi = frame.to_local(wi_world);

        // Next-event estimation, if a real bounce here may still see light.
        if !bsdf.is_specular() && depth + 1 < max_depth {
            prev_at = scene.choice_point(its.p, frame.n);
            if let Some((ls, pchoice)) = sample_light(scene, its.p, &prev_at, sampler, which) {
                let wo = frame.to_local(ls.wi);
                let (f, bsdf_pdf) = if ls.delta {
                    (bsdf.eval(sp, wi, wo), 0.0)
                } else {
                    bsdf.eval_pdf(sp, wi, wo)
                };
                if f != Rgb::ZERO && ls.weight != Rgb::ZERO {
                    let start = if interface.is_transition() {
                        interface.target(its.ng, ls.wi)
                    } else {
                        medium
                    };
                    let tr = shadow_transmittance(scene, its.spawn(ls.wi), start, &ls, sampler);
                    if tr != Rgb::ZERO {
                        let w = if ls.delta {
                            1.0
                        } else {
                            power_heuristic(ls.pdf * pchoice, bsdf_pdf)
                        };
                        l += beta * f * ls.weight * tr * (wo.z.abs() * w / pchoice);
                    }
                }
            }
        }

        let u = sampler.next_2d();
        let u_lobe = sampler.next_1d();
        let Some(bs) = bsdf.sample(sp, wi, u, u_lobe) else {
            break;
        };
        let wo_world = frame.to_world(bs.wo);
        beta *= bs.weight;
        if beta == Rgb::ZERO {
            break;
        }
        if interface.is_transition() {
            medium = interface.target(its.ng, wo_world);
        }
        if bs.null {
            // Straight on, as if the surface were not there.
            nulls += 1;
            if nulls > MAX_NULL_CROSSINGS {
                break;
            }
            ray = Ray::new(its.spawn(wo_world), wo_world);
            continue;
        }
        // Reject samples that cross the geometric surface against the
        // shading normal's verdict (light leaks through shading normals).
        if wo_world.dot(its.ng) * bs.wo.z <= 0.0 && wi_world.dot(its.ng) * wi.z > 0.0 {
            break;
        }
        depth += 1;
        if depth >= max_depth {
            break;
        }
        eta_scale *= bs.eta * bs.eta;
        specular = bs.specular;
        prev_pdf = if bs.specular { 0.0 } else { bs.pdf };
        prev_p = its.p;
        if !roulette(&mut beta, eta_scale, depth, params, sampler) {
            break;
        }
        nulls = 0;
        ray = Ray::new(its.spawn(wo_world), wo_world);
    }
    l
}

/// The fraction of the light sample `ls` that reaches `from` (a point off
/// any surface, in `medium`): the transmittance of the media on the way
/// (estimated by ratio tracking in heterogeneous ones) times the null
/// transmission of the surfaces crossed; zero if a surface blocks it.
fn shadow_transmittance(
    scene: &Scene,
    from: Vec3,
    mut medium: Option<u32>,
    ls: &LightSample,
    sampler: &mut Sampler,
) -> Rgb {
    let d = ls.wi;
    let target = if ls.dist.is_infinite() {
        None
    } else if ls.n == Vec3::ZERO {
        Some(ls.p)
    } else {
        Some(offset_ray_origin(ls.p, ls.err, ls.n, -d))
    };
    let mut tr = Rgb::ONE;
    let mut o = from;
    for _ in 0..=MAX_NULL_CROSSINGS {
        let remaining = target.map_or(f32::INFINITY, |q| (q - o).length());
        let ray = Ray::with_range(o, d, 0.0, remaining * (1.0 - 1e-4));
        let hit = scene.intersect(&ray);
        if let Some(m) = medium {
            let seg = hit.as_ref().map_or(remaining, |h| h.t);
            tr *= scene.media[m as usize].transmittance(&ray, seg, sampler);
        }
        let Some(its) = hit else {
            return tr;
        };
        let cos_i = its.shading.n.dot(d);
        tr *= scene.bsdfs[its.shape as usize].null_transmission(scene.surface_point(&its), cos_i);
        if tr == Rgb::ZERO {
            return tr;
        }
        let interface = scene.shape_media[its.shape as usize];
        if interface.is_transition() {
            medium = interface.target(its.ng, d);
        }
        o = its.spawn(d);
    }
    Rgb::ZERO
}
