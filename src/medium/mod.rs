//! Participating media: what fills the space between surfaces.
//!
//! A medium is entered and left through the surfaces that name it as
//! their `interior` or `exterior` (Mitsuba's convention), or is where the
//! camera sits. Inside one, a path either travels freely to the next
//! surface or scatters at a sampled distance ([`Medium::sample_distance`]);
//! shadow rays are attenuated by [`Medium::transmittance`].
//!
//! Free flights in a medium whose extinction differs per colour channel
//! are sampled with one channel's extinction, the channel chosen
//! uniformly, and weighted by the mean density over the three channels
//! (one-sample MIS with the balance heuristic): the weights stay bounded
//! where a single channel's would not (pbrt-v4's chromatic media do the
//! same; Mitsuba's `volpath` divides by the chosen channel's density
//! alone).

mod heterogeneous;
mod majorant;
mod phase;
mod vol_file;
mod volume;

pub use heterogeneous::{Heterogeneous, MAX_OPTICAL_EXTENT};
pub use phase::{Phase, PhaseSample};
pub use vol_file::{encode_vol, load_vol, parse_vol, VolError, VolumeGrid};
pub use volume::{GridLookup, Volume, VolumeData, VolumeFilter, WrapMode};

use crate::color::Rgb;
use crate::math::{Ray, Vec3};
use crate::sampling::Sampler;

/// A homogeneous medium: the same extinction everywhere. Its albedo may
/// still vary (Mitsuba evaluates a grid albedo at each scattering point).
#[derive(Clone, Debug, PartialEq)]
pub struct Homogeneous {
    /// Extinction coefficient per unit length (Mitsuba's `sigma_t`
    /// times `scale`).
    pub sigma_t: Rgb,
    /// Single-scattering albedo sigma_s / sigma_t.
    pub albedo: Volume,
}

/// The closed set of media.
#[derive(Clone, Debug, PartialEq)]
pub struct Medium {
    pub kind: MediumKind,
    pub phase: Phase,
    /// Whether paths sample emitters where they scatter in it (Mitsuba's
    /// `sample_emitters`; off, they find light by phase sampling alone).
    pub sample_emitters: bool,
}

#[derive(Clone, Debug, PartialEq)]
pub enum MediumKind {
    Homogeneous(Homogeneous),
    /// Boxed: its volumes and majorant grid are large, and media are few.
    Heterogeneous(Box<Heterogeneous>),
}

/// The media on either side of a surface: `interior` behind its
/// geometric normal, `exterior` in front of it. `None` is vacuum.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MediumInterface {
    pub interior: Option<u32>,
    pub exterior: Option<u32>,
}

impl MediumInterface {
    /// True if crossing the surface may change the medium.
    pub fn is_transition(&self) -> bool {
        self.interior.is_some() || self.exterior.is_some()
    }

    /// The medium a ray leaving the surface along `d` enters, given the
    /// surface's geometric normal `ng`.
    pub fn target(&self, ng: Vec3, d: Vec3) -> Option<u32> {
        if ng.dot(d) > 0.0 {
            self.exterior
        } else {
            self.interior
        }
    }
}

/// What happens to a path along a ray segment inside a medium.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FreeFlight {
    /// It scatters at distance `t`; the path's weight is multiplied by
    /// `weight` (transmittance times scattering coefficient over the
    /// density of `t`).
    Scatter { t: f32, weight: Rgb },
    /// It reaches the end of the segment; weight: transmittance over the
    /// probability of getting there.
    Pass { weight: Rgb },
}

impl Medium {
    /// Samples where a path travelling `ray` (unit direction) up to
    /// `t_max` (infinite if it escapes) interacts.
    pub fn sample_distance(&self, ray: &Ray, t_max: f32, sampler: &mut Sampler) -> FreeFlight {
        match &self.kind {
            MediumKind::Homogeneous(h) => {
                let u_channel = sampler.next_1d();
                h.sample_distance(ray, t_max, u_channel, sampler.next_1d())
            }
            MediumKind::Heterogeneous(h) => h.sample_distance(ray, t_max, sampler),
        }
    }

    /// Transmittance along `ray` up to `t` (may be infinite): exact in a
    /// homogeneous medium, an unbiased estimate in a heterogeneous one.
    pub fn transmittance(&self, ray: &Ray, t: f32, sampler: &mut Sampler) -> Rgb {
        match &self.kind {
            MediumKind::Homogeneous(h) => beer(h.sigma_t, t),
            MediumKind::Heterogeneous(h) => h.transmittance(ray, t, sampler),
        }
    }
}

impl Homogeneous {
    fn sample_distance(&self, ray: &Ray, t_max: f32, u_channel: f32, u: f32) -> FreeFlight {
        let s = self.sigma_t;
        if self.albedo.as_constant() == Some(Rgb::ZERO) {
            // Nothing scatters: the transmittance itself, without noise
            // (coloured glass; Mitsuba samples collisions that end paths).
            return FreeFlight::Pass {
                weight: beer(s, t_max),
            };
        }
        let c = ((u_channel * 3.0) as usize).min(2);
        let t = if s[c] > 0.0 {
            -(1.0 - u).ln() / s[c]
        } else {
            f32::INFINITY
        };
        if t < t_max {
            let tr = beer(s, t);
            // Density of t under the three channels' exponentials, mixed.
            let pdf = (s * tr).dot(Rgb::splat(1.0 / 3.0));
            if pdf > 0.0 {
                return FreeFlight::Scatter {
                    t,
                    weight: tr * s * self.albedo.eval(ray.at(t)) / pdf,
                };
            }
        }
        let tr = beer(s, t_max);
        let p_pass = tr.dot(Rgb::splat(1.0 / 3.0));
        FreeFlight::Pass {
            weight: if p_pass > 0.0 { tr / p_pass } else { Rgb::ZERO },
        }
    }
}

/// Beer-Lambert transmittance exp(-sigma t), 0 for an infinite path
/// through an absorbing channel and 1 through an empty one.
#[inline]
fn beer(sigma: Rgb, t: f32) -> Rgb {
    let f = |s: f32| if s == 0.0 { 1.0 } else { (-s * t).exp() };
    Rgb::new(f(sigma.x), f(sigma.y), f(sigma.z))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn medium(sigma_t: Rgb, albedo: Rgb) -> Medium {
        Medium {
            kind: MediumKind::Homogeneous(Homogeneous {
                sigma_t,
                albedo: Volume::constant(albedo),
            }),
            phase: Phase::Isotropic,
            sample_emitters: true,
        }
    }

    /// The free-flight estimator is unbiased: averaged over many flights,
    /// the Pass weights give the transmittance to the end of the segment,
    /// and the Scatter weights integrate sigma_s * T over the segment
    /// (here, with a test function f(t) = t, the exact integral of
    /// sigma_s t exp(-sigma_t t)). A chromatic extinction checks the
    /// channel mixture's weights.
    #[test]
    fn free_flight_is_unbiased() {
        let sigma = Rgb::new(2.0, 0.3, 0.9);
        let albedo = Rgb::new(0.8, 0.5, 1.0);
        let m = medium(sigma, albedo);
        let t_max = 1.3f32;
        let n = 400_000;
        let (mut pass, mut scat) = (Rgb::ZERO, Rgb::ZERO);
        let mut sampler = Sampler::new(0x1234, 5678);
        let ray = Ray::new(Vec3::ZERO, Vec3::X);
        for _ in 0..n {
            match m.sample_distance(&ray, t_max, &mut sampler) {
                FreeFlight::Pass { weight } => pass += weight,
                FreeFlight::Scatter { t, weight } => {
                    assert!(t < t_max);
                    scat += weight * t
                }
            }
        }
        pass /= n as f32;
        scat /= n as f32;
        for c in 0..3 {
            let (s, a) = (sigma[c] as f64, albedo[c] as f64);
            let tm = t_max as f64;
            let want_pass = (-s * tm).exp();
            // Integral of a s t exp(-s t) dt over [0, tm].
            let want_scat = a * (1.0 - (-s * tm).exp() * (1.0 + s * tm)) / s;
            assert!(
                (pass[c] as f64 - want_pass).abs() < 0.01 * want_pass.max(0.1),
                "channel {c}: pass {} vs {want_pass}",
                pass[c]
            );
            assert!(
                (scat[c] as f64 - want_scat).abs() < 0.01 * want_scat,
                "channel {c}: scatter {} vs {want_scat}",
                scat[c]
            );
        }
    }

    /// An empty channel passes everything; an infinite segment through an
    /// absorbing one passes nothing.
    #[test]
    fn transmittance_limits() {
        let m = medium(Rgb::new(0.0, 1.0, 2.0), Rgb::ONE);
        let mut s = Sampler::new(1, 1);
        let ray = Ray::new(Vec3::ZERO, Vec3::X);
        assert_eq!(
            m.transmittance(&ray, f32::INFINITY, &mut s),
            Rgb::new(1.0, 0.0, 0.0)
        );
        let t = m.transmittance(&ray, 0.5, &mut s);
        assert!((t.y - (-0.5f32).exp()).abs() < 1e-6);
    }

    #[test]
    fn interface_targets_by_side() {
        let i = MediumInterface {
            interior: Some(3),
            exterior: None,
        };
        let n = Vec3::Z;
        assert_eq!(i.target(n, -Vec3::Z), Some(3));
        assert_eq!(i.target(n, Vec3::Z), None);
        assert!(i.is_transition());
        assert!(!MediumInterface::default().is_transition());
    }
}
