//! Visualisation integrators: normals and ambient occlusion.

use crate::color::Rgb;
use crate::math::{offset_ray_origin, Ray};
use crate::sampling::{warp, Sampler};
use crate::scene::Scene;

pub fn normals(scene: &Scene, ray: &Ray) -> Rgb {
    match scene.intersect(ray) {
        Some(its) => its.shading.n.abs(),
        None => Rgb::ZERO,
    }
}

/// One cosine-weighted visibility sample: an unbiased estimate of the
/// cosine-weighted unoccluded fraction of the hemisphere.
pub fn ao(scene: &Scene, ray: &Ray, sampler: &mut Sampler, length: f32) -> Rgb {
    let Some(its) = scene.intersect(ray) else {
        return Rgb::ZERO;
    };
    let local = warp::square_to_cosine_hemisphere(sampler.next_2d());
    let d = its.shading.to_world(local);
    let o = offset_ray_origin(its.p, its.ng, d);
    let shadow = Ray::with_range(o, d, 0.0, length);
    if scene.bvh.occluded(&shadow) {
        Rgb::ZERO
    } else {
        Rgb::ONE
    }
}
