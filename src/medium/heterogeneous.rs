//! Mitsuba 3's `heterogeneous` medium: extinction and albedo read from
//! volumes, nonzero only inside the extinction volume's box.
//!
//! Free flights use delta tracking against a majorant the three channels
//! share: each cell's of a coarse grid ([`super::majorant`]), or `scale`
//! times the extinction's largest value for the whole box (Mitsuba's
//! choice) where the grid is rotated. Tentative collisions at that rate
//! are real with probability sigma_t / majorant, else null. Where sigma_t
//! differs per channel, the real-or-null choices follow one channel
//! picked per flight and the path is weighted by the mean of the three
//! channels' probabilities of the same choices (one-sample MIS, balance
//! heuristic, as pbrt-v4's chromatic media), so its weights stay below
//! three times the albedo, where a single channel's ratios would grow
//! without bound. Shadow rays use ratio tracking: the product of
//! sigma_n / majorant over the tentative collisions, with Russian
//! roulette once it is small.

use super::majorant::{MajorantGrid, Segment};
use super::volume::Volume;
use super::FreeFlight;
use crate::color::Rgb;
use crate::math::Ray;
use crate::sampling::Sampler;

/// Tentative collisions one flight or shadow ray may take before it is
/// given up as carrying nothing. The loader refuses media whose majorant
/// times box diagonal (the expected count across the box) is above
/// [`MAX_OPTICAL_EXTENT`], so this is reached only by rounding.
const MAX_COLLISIONS: u32 = 1 << 24;

/// The largest majorant times box diagonal the loader accepts.
pub const MAX_OPTICAL_EXTENT: f32 = 1e6;

/// Below this largest channel, a shadow ray's transmittance is subject to
/// Russian roulette.
const ROULETTE_BELOW: f32 = 0.05;

#[derive(Clone, Debug, PartialEq)]
pub struct Heterogeneous {
    /// Extinction before `scale`.
    pub sigma_t: Volume,
    pub scale: f32,
    pub albedo: Volume,
    /// `scale` times the extinction's largest value.
    pub majorant: f32,
    /// Majorants per cell of a coarse grid, where the volume allows one.
    pub majorants: Option<MajorantGrid>,
}

impl Heterogeneous {
    pub fn new(sigma_t: Volume, scale: f32, albedo: Volume) -> Heterogeneous {
        let majorant = scale * sigma_t.max();
        let majorants = MajorantGrid::new(&sigma_t, scale);
        Heterogeneous {
            sigma_t,
            scale,
            albedo,
            majorant,
            majorants,
        }
    }

    /// Majorant times the box's diagonal: how many tentative collisions a
    /// ray crossing the box expects.
    pub fn optical_extent(&self) -> f32 {
        self.majorant * self.sigma_t.bbox.diagonal().length()
    }

    /// Extinction at `p`, at most `maj` (trilinear rounding may exceed
    /// the grid's largest value by an ulp).
    #[inline]
    fn sigma_t_at(&self, p: crate::math::Vec3, maj: f32) -> Rgb {
        (self.sigma_t.eval(p) * self.scale).min(Rgb::splat(maj))
    }

    /// The part of `ray` up to `t_max` where collisions can happen.
    fn range(&self, ray: &Ray, t_max: f32) -> Option<(f32, f32)> {
        if self.majorant <= 0.0 {
            return None;
        }
        self.sigma_t.bbox.ray_range(ray.o, ray.d, t_max)
    }

    /// The stretches of `ray` between `t0` and `t1` and their majorants:
    /// the grid's cells, or the whole range under the one majorant.
    fn segments<'a>(
        &'a self,
        ray: &'a Ray,
        t0: f32,
        t1: f32,
    ) -> impl Iterator<Item = Segment> + 'a {
        let (grid, whole) = match &self.majorants {
            Some(g) => (Some(g.walk(&self.sigma_t.to_local, ray, t0, t1)), None),
            None => (
                None,
                Some(Segment {
                    t0,
                    t1,
                    majorant: self.majorant,
                }),
            ),
        };
        grid.into_iter().flatten().chain(whole)
    }

    /// Takes the tentative collisions along `ray` from `t0` to `t1`, cell
    /// by cell (exponential steps are memoryless: each cell starts
    /// afresh), and calls `at` with each one's distance and majorant until
    /// it returns a result.
    fn walk_collisions<R>(
        &self,
        ray: &Ray,
        t0: f32,
        t1: f32,
        sampler: &mut Sampler,
        mut at: impl FnMut(f32, f32, &mut Sampler) -> Option<R>,
    ) -> Walked<R> {
        let mut collisions = 0u32;
        for seg in self.segments(ray, t0, t1) {
            let maj = seg.majorant;
            if maj <= 0.0 {
                continue;
            }
            let mut t = seg.t0;
            loop {
                t -= (1.0 - sampler.next_1d()).ln() / maj;
                if t >= seg.t1 {
                    break;
                }
                collisions += 1;
                if collisions > MAX_COLLISIONS {
                    return Walked::GaveUp;
                }
                if let Some(r) = at(t, maj, sampler) {
                    return Walked::Stopped(r);
                }
            }
        }
        Walked::Passed
    }

    pub(super) fn sample_distance(
        &self,
        ray: &Ray,
        t_max: f32,
        sampler: &mut Sampler,
    ) -> FreeFlight {
        let Some((t0, t1)) = self.range(ray, t_max) else {
            return FreeFlight::Pass { weight: Rgb::ONE };
        };
        let c = ((sampler.next_1d() * 3.0) as usize).min(2);
        // The path's weight and the three channels' probabilities of its
        // choices so far, both divided by the probabilities' mean (which
        // keeps them from underflowing on long flights).
        let mut weight = Rgb::ONE;
        let mut probs = Rgb::ONE;
        let walked = self.walk_collisions(ray, t0, t1, sampler, |t, maj, sampler| {
            let p = ray.at(t);
            let sigma_t = self.sigma_t_at(p, maj);
            let p_real = sigma_t / maj;
            if sampler.next_1d() < p_real[c] {
                let sigma_s = sigma_t * self.albedo.eval(p);
                let mean = (probs * p_real).dot(Rgb::splat(1.0 / 3.0));
                return Some(FreeFlight::Scatter {
                    t,
                    weight: weight * sigma_s / (maj * mean),
                });
            }
            let p_null = Rgb::ONE - p_real;
            let mean = (probs * p_null).dot(Rgb::splat(1.0 / 3.0));
            if mean <= 0.0 {
                return Some(FreeFlight::Pass { weight: Rgb::ZERO });
            }
            // sigma_n / maj is p_null: the weight's factor and the
            // probabilities' factor are the same vector.
            weight *= p_null / mean;
            probs *= p_null / mean;
            None
        });
        match walked {
            Walked::Stopped(flight) => flight,
            Walked::Passed => FreeFlight::Pass { weight },
            Walked::GaveUp => FreeFlight::Pass { weight: Rgb::ZERO },
        }
    }

    pub(super) fn transmittance(&self, ray: &Ray, t_end: f32, sampler: &mut Sampler) -> Rgb {
        let Some((t0, t1)) = self.range(ray, t_end) else {
            return Rgb::ONE;
        };
        let mut tr = Rgb::ONE;
        let walked = self.walk_collisions(ray, t0, t1, sampler, |t, maj, sampler| {
            tr *= Rgb::ONE - self.sigma_t_at(ray.at(t), maj) / maj;
            let m = tr.max_element();
            if m < ROULETTE_BELOW {
                // Survive with probability 1/4, weighted by 4.
                if m <= 0.0 || sampler.next_1d() >= 0.25 {
                    return Some(());
                }
                tr *= 4.0;
            }
            None
        });
        match walked {
            Walked::Passed => tr,
            // Killed by roulette, or given up.
            Walked::Stopped(()) | Walked::GaveUp => Rgb::ZERO,
        }
    }
}

/// How [`Heterogeneous::walk_collisions`] ended.
enum Walked<R> {
    /// Past the last collision: the segment's end was reached.
    Passed,
    /// The callback returned this.
    Stopped(R),
    /// More than [`MAX_COLLISIONS`] collisions.
    GaveUp,
}

#[cfg(test)]
mod tests {
    use super::super::vol_file::VolumeGrid;
    use super::super::volume::{GridLookup, VolumeData, VolumeFilter, WrapMode};
    use super::*;
    use crate::math::{Aabb, Transform, Vec3};
    use std::sync::Arc;

    /// A 4 x 1 x 1 grid along x over the unit cube: extinction rising
    /// per channel at different rates, so the flight's channel mixture and
    /// null weights are exercised.
    fn medium() -> Heterogeneous {
        let data = vec![
            0.5, 0.1, 2.0, //
            1.0, 0.2, 1.5, //
            2.0, 0.4, 1.0, //
            3.0, 0.8, 0.5,
        ];
        let grid = VolumeGrid {
            res: [4, 1, 1],
            channels: 3,
            bbox: Aabb {
                min: Vec3::ZERO,
                max: Vec3::ONE,
            },
            data,
        };
        let sigma_t = Volume::new(
            VolumeData::Grid(GridLookup {
                grid: Arc::new(grid),
                filter: VolumeFilter::Trilinear,
                wrap: WrapMode::Clamp,
            }),
            Transform::IDENTITY,
        );
        Heterogeneous::new(sigma_t, 1.5, Volume::constant(Rgb::new(0.9, 0.6, 1.0)))
    }

    /// Optical depth along the x axis from x = 0 to `x`, by the midpoint
    /// rule on a fine grid (the reference the estimators must match).
    fn optical_depth(m: &Heterogeneous, x: f32) -> Rgb {
        let n = 20_000;
        let h = x / n as f32;
        (0..n)
            .map(|i| m.sigma_t_at(Vec3::new((i as f32 + 0.5) * h, 0.5, 0.5), m.majorant) * h)
            .fold(Rgb::ZERO, |a, b| a + b)
    }

    /// t-tests per channel, each against a reference computed by
    /// quadrature: over many flights along x from outside the box, Pass
    /// weights average to the transmittance through it, Scatter weights
    /// times the test function t integrate sigma_s T t over it, and ratio
    /// tracking averages to the same transmittance. A 2% change of any
    /// reference is rejected (the tests have power).
    #[test]
    fn delta_and_ratio_tracking_are_unbiased() {
        let m = medium();
        assert!(m.majorants.is_some());
        tracking_is_unbiased(&m, 11);
        // And under the one majorant for the whole box.
        let single = Heterogeneous {
            majorants: None,
            ..m
        };
        tracking_is_unbiased(&single, 12);
    }

    fn tracking_is_unbiased(m: &Heterogeneous, seed: u64) {
        use crate::stats::{sidak, t_test, MeanVar};
        let albedo = Rgb::new(0.9, 0.6, 1.0);
        let ray = Ray::new(Vec3::new(-1.0, 0.5, 0.5), Vec3::X);
        let t_max = 1.8f32;
        let n = 200_000;
        let mut s = Sampler::new(7, seed);
        let mut pass = [MeanVar::default(), MeanVar::default(), MeanVar::default()];
        let (mut scat, mut ratio) = (pass, pass);
        for _ in 0..n {
            let (p, sc) = match m.sample_distance(&ray, t_max, &mut s) {
                FreeFlight::Pass { weight } => (weight, Rgb::ZERO),
                FreeFlight::Scatter { t, weight } => {
                    assert!((1.0..=t_max).contains(&t), "{t}");
                    (Rgb::ZERO, weight * t)
                }
            };
            let r = m.transmittance(&ray, t_max, &mut s);
            for c in 0..3 {
                pass[c].push(p[c] as f64);
                scat[c].push(sc[c] as f64);
                ratio[c].push(r[c] as f64);
            }
        }
        // The references: T through the box, and the integral over x in
        // [0, 0.8] of albedo sigma_t(x) T(x) (x + 1), by the midpoint rule.
        let want_pass = (-optical_depth(m, 0.8)).exp();
        let k = 4000;
        let h = 0.8 / k as f32;
        let mut want_scat = Rgb::ZERO;
        let mut depth = Rgb::ZERO;
        for i in 0..k {
            let x = (i as f32 + 0.5) * h;
            let st = m.sigma_t_at(Vec3::new(x, 0.5, 0.5), m.majorant);
            let tr = (-(depth + st * h * 0.5)).exp();
            want_scat += st * albedo * tr * (x + 1.0) * h;
            depth += st * h;
        }
        let alpha = sidak(0.01, 18);
        for c in 0..3 {
            for (what, mv, want) in [
                ("pass", &pass[c], want_pass[c]),
                ("ratio", &ratio[c], want_pass[c]),
                ("scatter", &scat[c], want_scat[c]),
            ] {
                let want = want as f64;
                let r = t_test(mv, want);
                assert!(
                    r.passes(alpha),
                    "{what} {c}: {} vs {want}, p {}",
                    mv.mean(),
                    r.p_value
                );
                assert!(
                    !t_test(mv, want * 1.02).passes(0.01),
                    "{what} {c}: no power"
                );
            }
        }
    }

    /// Rays that miss the box, or a medium with nothing in it, pass
    /// without drawing a collision.
    #[test]
    fn outside_the_box_nothing_happens() {
        let m = medium();
        let mut s = Sampler::new(1, 2);
        let miss = Ray::new(Vec3::new(-1.0, 2.0, 0.5), Vec3::X);
        assert_eq!(
            m.sample_distance(&miss, 10.0, &mut s),
            FreeFlight::Pass { weight: Rgb::ONE }
        );
        assert_eq!(m.transmittance(&miss, 10.0, &mut s), Rgb::ONE);
        // Stopping short of the box.
        let short = Ray::new(Vec3::new(-1.0, 0.5, 0.5), Vec3::X);
        assert_eq!(m.transmittance(&short, 0.99, &mut s), Rgb::ONE);
        let empty =
            Heterogeneous::new(Volume::constant(Rgb::ZERO), 1.0, Volume::constant(Rgb::ONE));
        assert_eq!(empty.transmittance(&short, 5.0, &mut s), Rgb::ONE);
        assert!((m.optical_extent() - 4.5 * 3f32.sqrt()).abs() < 1e-4);
    }
}
