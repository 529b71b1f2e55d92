//! Nori's Whitted-style integrator: emitter sampling on non-specular
//! surfaces, recursion through specular ones with Russian roulette
//! (continuing with probability 0.95).

use crate::color::Rgb;
use crate::emitter::{Emitter, LightPdf};
use crate::math::Ray;
use crate::sampling::Sampler;
use crate::scene::Scene;

/// Survival probability at each specular bounce.
const CONTINUE: f32 = 0.95;

pub fn li(scene: &Scene, camera_ray: &Ray, sampler: &mut Sampler) -> Rgb {
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
            if let Emitter::Area(light) = &scene.emitters[ei as usize] {
                if its.ng.dot(wi_world) > 0.0 {
                    l += beta * light.radiance_at(its.surface_point());
                }
            }
        }
        let bsdf = &scene.bsdfs[its.shape as usize];
        let sp = scene.surface_point(&its);
        let wi = its.shading.to_local(wi_world);
        if !bsdf.is_specular() {
            // One emitter sample, chosen by what it can deliver here.
            let at = scene.choice_point(its.p, its.shading.n);
            if let Some((ls, p)) =
                super::sample_light(scene, its.p, &at, sampler, LightPdf::Complete)
            {
                let wo = its.shading.to_local(ls.wi);
                let f = bsdf.eval(sp, wi, wo);
                if f != Rgb::ZERO && scene.unoccluded(&its, &ls) {
                    l += beta * f * wo.z.abs() * ls.weight / p;
                }
            }
            return l;
        }
        if sampler.next_1d() >= CONTINUE {
            return l;
        }
        let Some(bs) = bsdf.sample(sp, wi, sampler.next_2d(), sampler.next_1d()) else {
            return l;
        };
        beta *= bs.weight / CONTINUE;
        let d = its.shading.to_world(bs.wo);
        ray = Ray::new(its.spawn(d), d);
    }
}
