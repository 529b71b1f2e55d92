//! Nori's `microfacet` BSDF: a Beckmann specular lobe with exact dielectric
//! Fresnel over a Lambertian base. The specular weight is 1 - max(kd), and
//! sampling picks a lobe in proportion to the weights.

use super::{fresnel_dielectric, BsdfSample};
use crate::color::Rgb;
use crate::math::{reflect, Vec2, Vec3, INV_PI};
use crate::sampling::warp;

/// Smith's shadowing for the Beckmann distribution (Walter et al. 2007's
/// rational approximation), with the sidedness check.
fn smith_g1(v: Vec3, m: Vec3, alpha: f32) -> f32 {
    if v.dot(m) * v.z <= 0.0 {
        return 0.0;
    }
    let cos = v.z;
    let sin = (1.0 - cos * cos).max(0.0).sqrt();
    if sin == 0.0 {
        return 1.0;
    }
    let b = cos / (alpha * sin);
    if b >= 1.6 {
        1.0
    } else {
        let b2 = b * b;
        (3.535 * b + 2.181 * b2) / (1.0 + 2.276 * b + 2.577 * b2)
    }
}

pub fn eval(alpha: f32, eta: f32, kd: Rgb, ks: f32, wi: Vec3, wo: Vec3) -> Rgb {
    if wi.z <= 0.0 || wo.z <= 0.0 {
        return Rgb::ZERO;
    }
    let wh = (wi + wo).normalize();
    let d = warp::beckmann_d(wh, alpha);
    let (f, _, _) = fresnel_dielectric(wh.dot(wi), eta);
    let g = smith_g1(wi, wh, alpha) * smith_g1(wo, wh, alpha);
    kd * INV_PI + Rgb::splat(ks * d * f * g / (4.0 * wi.z * wo.z))
}

pub fn pdf(alpha: f32, ks: f32, wi: Vec3, wo: Vec3) -> f32 {
    if wi.z <= 0.0 || wo.z <= 0.0 {
        return 0.0;
    }
    let wh = (wi + wo).normalize();
    let spec = warp::square_to_beckmann_pdf(wh, alpha) / (4.0 * wh.dot(wo).abs());
    ks * spec + (1.0 - ks) * wo.z * INV_PI
}

pub fn sample(
    alpha: f32,
    eta: f32,
    kd: Rgb,
    ks: f32,
    wi: Vec3,
    u: Vec2,
    u_lobe: f32,
) -> Option<BsdfSample> {
    if wi.z <= 0.0 {
        return None;
    }
    let wo = if u_lobe < ks {
        let wh = warp::square_to_beckmann(u, alpha);
        reflect(wi, wh)
    } else {
        warp::square_to_cosine_hemisphere(u)
    };
    if wo.z <= 0.0 {
        return None;
    }
    let p = pdf(alpha, ks, wi, wo);
    if p <= 0.0 {
        return None;
    }
    let weight = eval(alpha, eta, kd, ks, wi, wo) * wo.z / p;
    Some(BsdfSample {
        wo,
        weight,
        pdf: p,
        specular: false,
        eta: 1.0,
    })
}
