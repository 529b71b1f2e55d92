//! Phase functions: how light scatters at a point inside a medium.
//!
//! Directions follow the path: `d` is the direction the path arrives
//! along (propagation), `wo` the one it leaves along. The Henyey-Greenstein
//! angle is the one between them, so g > 0 scatters forward, as in
//! Mitsuba 3 and pbrt.

use crate::math::{Frame, Vec2, Vec3, INV_FOUR_PI, PI};
use crate::sampling::warp::square_to_uniform_sphere;

/// The closed set of phase functions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Phase {
    /// The same in every direction (Mitsuba's `isotropic`).
    Isotropic,
    /// Henyey-Greenstein with mean cosine `g` in (-1, 1) (Mitsuba's `hg`).
    HenyeyGreenstein { g: f32 },
    /// Rayleigh scattering by particles much smaller than the wavelength,
    /// 3 / (16 pi) (1 + cos^2), unpolarised (Mitsuba's `rayleigh`).
    Rayleigh,
}

/// A sampled direction: its density, which for these phase functions is
/// also their value (the weight is 1).
#[derive(Clone, Copy, Debug)]
pub struct PhaseSample {
    pub wo: Vec3,
    pub pdf: f32,
}

impl Phase {
    /// Density (and value) of leaving along `wo` after arriving along `d`.
    pub fn eval(&self, d: Vec3, wo: Vec3) -> f32 {
        match *self {
            Phase::Isotropic => INV_FOUR_PI,
            Phase::HenyeyGreenstein { g } => hg(g, d.dot(wo)),
            Phase::Rayleigh => rayleigh(d.dot(wo)),
        }
    }

    /// Samples a direction to leave along after arriving along the unit `d`.
    pub fn sample(&self, d: Vec3, u: Vec2) -> PhaseSample {
        match *self {
            Phase::Isotropic => PhaseSample {
                wo: square_to_uniform_sphere(u),
                pdf: INV_FOUR_PI,
            },
            Phase::HenyeyGreenstein { g } => {
                let cos_t = if g.abs() < 1e-3 {
                    1.0 - 2.0 * u.x
                } else {
                    let s = (1.0 - g * g) / (1.0 + g - 2.0 * g * u.x);
                    ((1.0 + g * g - s * s) / (2.0 * g)).clamp(-1.0, 1.0)
                };
                PhaseSample {
                    wo: around(d, cos_t, u.y),
                    pdf: hg(g, cos_t),
                }
            }
            Phase::Rayleigh => {
                // The cosine's CDF (cos^3 + 3 cos + 4) / 8 inverted in
                // closed form (Cardano: one real root).
                let z = 4.0 * u.x - 2.0;
                let r = (z * z + 1.0).sqrt();
                let cos_t = ((z + r).cbrt() + (z - r).cbrt()).clamp(-1.0, 1.0);
                PhaseSample {
                    wo: around(d, cos_t, u.y),
                    pdf: rayleigh(cos_t),
                }
            }
        }
    }
}

/// The unit direction at cosine `cos_t` to `d`, turned about it by the
/// angle 2 pi `u`.
#[inline]
fn around(d: Vec3, cos_t: f32, u: f32) -> Vec3 {
    let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
    let (s, c) = (2.0 * PI * u).sin_cos();
    let local = Vec3::new(sin_t * c, sin_t * s, cos_t);
    Frame::from_normal(d).to_world(local).normalize()
}

/// The Henyey-Greenstein density at the cosine `cos_t` between the
/// arriving and leaving directions.
#[inline]
fn hg(g: f32, cos_t: f32) -> f32 {
    let denom = 1.0 + g * g - 2.0 * g * cos_t;
    INV_FOUR_PI * (1.0 - g * g) / (denom * denom.max(1e-12).sqrt())
}

/// The Rayleigh density at the cosine `cos_t` between the two directions.
#[inline]
fn rayleigh(cos_t: f32) -> f32 {
    3.0 / (16.0 * PI) * (1.0 + cos_t * cos_t)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Both densities integrate to one over the sphere, and HG's mean
    /// cosine is g (midpoint rule over cos theta).
    #[test]
    fn normalised_with_mean_cosine_g() {
        let d = Vec3::new(0.0, 0.6, 0.8);
        for phase in [
            Phase::Isotropic,
            Phase::HenyeyGreenstein { g: 0.7 },
            Phase::HenyeyGreenstein { g: -0.4 },
            Phase::Rayleigh,
        ] {
            let n = 200_000;
            let (mut total, mut mean) = (0.0f64, 0.0f64);
            for i in 0..n {
                let c = -1.0 + 2.0 * (i as f64 + 0.5) / n as f64;
                let s = (1.0 - c * c).sqrt();
                let wo = Frame::from_normal(d).to_world(Vec3::new(s as f32, 0.0, c as f32));
                let p = phase.eval(d, wo) as f64 * 2.0 * std::f64::consts::PI * 2.0 / n as f64;
                total += p;
                mean += p * c;
            }
            let g = match phase {
                Phase::Isotropic | Phase::Rayleigh => 0.0,
                Phase::HenyeyGreenstein { g } => g as f64,
            };
            assert!((total - 1.0).abs() < 1e-3, "{phase:?}: {total}");
            assert!((mean - g).abs() < 1e-3, "{phase:?}: {mean}");
        }
    }

    /// Samples carry the density `eval` gives, and are unit vectors.
    #[test]
    fn sample_pdf_matches_eval() {
        let d = Vec3::new(0.48, -0.6, 0.64);
        for phase in [Phase::HenyeyGreenstein { g: 0.8 }, Phase::Rayleigh] {
            for i in 0..1000 {
                let u = Vec2::new(
                    (i as f32 * 0.618_034).fract(),
                    (i as f32 * 0.414_213).fract(),
                );
                let s = phase.sample(d, u);
                assert!((s.wo.length() - 1.0).abs() < 1e-4);
                let e = phase.eval(d, s.wo);
                assert!((s.pdf - e).abs() <= 2e-3 * e, "{} vs {}", s.pdf, e);
            }
        }
    }
}
