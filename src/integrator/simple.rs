//! Small integrators: normals, ambient occlusion, average visibility and
//! Nori's `simple` point-light shader.

use crate::color::Rgb;
use crate::math::{Ray, Vec3, PI};
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
    let o = its.spawn(d);
    let shadow = Ray::with_range(o, d, 0.0, length);
    if scene.bvh.occluded(&shadow) {
        Rgb::ZERO
    } else {
        Rgb::ONE
    }
}

/// Average visibility: 1 if a uniformly sampled hemisphere direction around
/// the shading normal is unoccluded within `length`, 1 for rays that miss.
pub fn average_visibility(scene: &Scene, ray: &Ray, sampler: &mut Sampler, length: f32) -> Rgb {
    let Some(its) = scene.intersect(ray) else {
        return Rgb::ONE;
    };
    let local = warp::square_to_uniform_hemisphere(sampler.next_2d());
    let d = its.shading.to_world(local);
    let o = its.spawn(d);
    if scene.bvh.occluded(&Ray::with_range(o, d, 0.0, length)) {
        Rgb::ZERO
    } else {
        Rgb::ONE
    }
}

/// Nori's `simple` integrator: a point light of power `energy` at
/// `position` shading every surface as white diffuse (albedo 1), with a
/// shadow ray.
pub fn simple_point(scene: &Scene, ray: &Ray, position: Vec3, energy: Rgb) -> Rgb {
    let Some(its) = scene.intersect(ray) else {
        return Rgb::ZERO;
    };
    let to = position - its.p;
    let d2 = to.length_squared();
    if d2 <= 0.0 {
        return Rgb::ZERO;
    }
    let wi = to / d2.sqrt();
    let cos = its.shading.n.dot(wi);
    if cos <= 0.0 {
        return Rgb::ZERO;
    }
    let o = its.spawn(wi);
    if scene.occluded_segment(o, position) {
        return Rgb::ZERO;
    }
    energy * (cos / (4.0 * PI * PI * d2))
}
