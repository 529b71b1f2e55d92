//! Nori's Whitted-style integrator: emitter sampling on non-specular
//! surfaces, recursion through specular ones with Russian roulette
//! (continuing with probability 0.95).

use crate::color::Rgb;
use crate::emitter::Emitter;
use crate::math::{offset_ray_origin, Ray, Vec3};
use crate::sampling::Sampler;
use crate::scene::Scene;

/// Survival probability at each specular bounce.
const CONTINUE: f32 = 0.95;

pub fn li(scene: &Scene, camera_ray: &Ray, sampler: &mut Sampler) -> Rgb {
    let ctx = scene.emitter_context();
    let mut ray = *camera_ray;
    let mut beta = Rgb::ONE;
    let mut l = Rgb::ZERO;
    loop {
        let Some(its) = scene.intersect(&ray) else {
            l += beta * scene.eval_infinite(ray.d);
            return l;
        };
        let wi_world = -ray.d;
        if let Some(ei) = scene.shape_emitter[its.shape as usize] {
            if let Emitter::Area { radiance, .. } = &scene.emitters[ei as usize] {
                if its.ng.dot(wi_world) > 0.0 {
                    l += beta * *radiance;
                }
            }
        }
        let bsdf = &scene.bsdfs[its.shape as usize];
        let wi = its.shading.to_local(wi_world);
        if !bsdf.is_specular() {
            // One emitter sample, chosen in proportion to power.
            if let Some(choice) = scene.light_choice.as_ref() {
                let (i, p, u1) = choice.sample_discrete(sampler.next_1d());
                let u = sampler.next_2d();
                if let Some(ls) = scene.emitters[i].sample(&ctx, its.p, u, u1) {
                    let wo = its.shading.to_local(ls.wi);
                    let f = bsdf.eval(wi, wo);
                    if f != Rgb::ZERO {
                        let from = its.spawn(ls.wi);
                        let blocked = if ls.dist.is_infinite() {
                            scene.occluded_ray(from, ls.wi)
                        } else if ls.n == Vec3::ZERO {
                            scene.occluded_segment(from, ls.p)
                        } else {
                            scene.occluded_segment(
                                from,
                                offset_ray_origin(ls.p, ls.err, ls.n, -ls.wi),
                            )
                        };
                        if !blocked {
                            l += beta * f * wo.z.abs() * ls.weight / p;
                        }
                    }
                }
            }
            return l;
        }
        if sampler.next_1d() >= CONTINUE {
            return l;
        }
        let Some(bs) = bsdf.sample(wi, sampler.next_2d(), sampler.next_1d()) else {
            return l;
        };
        beta *= bs.weight / CONTINUE;
        let d = its.shading.to_world(bs.wo);
        ray = Ray::new(its.spawn(d), d);
    }
}
