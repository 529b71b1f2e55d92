//! Four spheres' cone samples in SIMD lanes: [`Sphere::visible_cone`],
//! [`Sphere::sample_cone`] and the direction and distance to the point,
//! each lane bit for bit the scalar routines' (the same operations in the
//! same order, their branches as masks; tested). A batch of paths draws
//! its sphere lights' samples with it (Veach's scene has five): the
//! scalar routine is one chain of dependent divisions, square roots and
//! sine and cosine polynomials, which four lanes run once.

use crate::math::{gamma, sin_cos_turns_lanes, sqrt4 as sqrt, Lanes3, Vec2, Vec3, Vec4, PI};

use super::{Sphere, SurfaceSample};

/// A point drawn on the cap of a sphere visible from a point `p_ref`: the
/// surface sample, its solid-angle density, and the unit direction and
/// distance from `p_ref` to it.
#[derive(Clone, Copy, Debug)]
pub struct ConeSample {
    pub s: SurfaceSample,
    pub pdf: f32,
    pub wi: Vec3,
    pub dist: f32,
}

/// For each lane `k`: the cone sample of `spheres[k]` seen from `p[k]`
/// with numbers `u[k]`, as [`Sphere::visible_cone`] then
/// [`Sphere::sample_cone`] give it, with `to / |to|` and `|to|` for
/// `to = s.p - p[k]` (what an area light's sample computes from it); None
/// where the point is inside or on the sphere (no cone: the caller draws
/// those by area, as the scalar routine does).
pub fn sample_cones_lanes(spheres: [&Sphere; 4], p: [&Vec3; 4], u: [Vec2; 4]) -> ConeLanes {
    let centre = Lanes3::gather(spheres.map(|s| &s.center));
    let radius = Vec4::from_array(spheres.map(|s| s.radius));
    let at = Lanes3::gather(p);
    // `visible_cone`.
    let to = Lanes3 {
        x: centre.x - at.x,
        y: centre.y - at.y,
        z: centre.z - at.z,
    };
    let d2 = to.length_squared();
    let r2 = radius * radius;
    // The scalar test `d2 <= r2 * 1.0001` (false for NaN: such a lane has
    // a cone, of NaNs, in both).
    let inside = d2.cmple(r2 * 1.0001).bitmask();
    let sin2 = r2 / d2;
    let cos_max = sqrt((Vec4::ONE - sin2).max(Vec4::ZERO));
    let len = sqrt(d2);
    let axis = to.map(|c| c / len);
    let one_minus_cos = sin2 / (Vec4::ONE + cos_max);
    // `sample_cone`.
    let ux = Vec4::from_array(u.map(|u| u.x));
    let uy = Vec4::from_array(u.map(|u| u.y));
    let t = uy * one_minus_cos;
    let cos_theta = Vec4::ONE - t;
    let sin2_theta = t * (Vec4::splat(2.0) - t);
    let ratio = (sin2_theta / sin2).min(Vec4::ONE);
    let cos_alpha = (sin2_theta / sqrt(sin2)
        + cos_theta * sqrt((Vec4::ONE - ratio).max(Vec4::ZERO)))
    .min(Vec4::ONE);
    let sin_alpha = sqrt((Vec4::ONE - cos_alpha * cos_alpha).max(Vec4::ZERO));
    let (sin_phi, cos_phi) = sin_cos_turns_lanes(ux);
    let (lx, ly, lz) = (sin_alpha * cos_phi, sin_alpha * sin_phi, cos_alpha);
    // `Frame::from_normal(axis)`: sign = 1 with the sign of axis.z.
    let sign = Vec4::ONE.copysign(axis.z);
    let a = Vec4::splat(-1.0) / (sign + axis.z);
    let b = axis.x * axis.y * a;
    let s = Lanes3 {
        x: Vec4::ONE + sign * axis.x * axis.x * a,
        y: sign * b,
        z: -sign * axis.x,
    };
    let tt = Lanes3 {
        x: b,
        y: sign + axis.y * axis.y * a,
        z: -axis.y,
    };
    // `-frame.to_world(local)`: -((s lx + t ly) + n lz).
    let n = Lanes3 {
        x: -(s.x * lx + tt.x * ly + axis.x * lz),
        y: -(s.y * lx + tt.y * ly + axis.y * lz),
        z: -(s.z * lx + tt.z * ly + axis.z * lz),
    };
    let rn = n.map(|c| radius * c);
    let point = Lanes3 {
        x: centre.x + rn.x,
        y: centre.y + rn.y,
        z: centre.z + rn.z,
    };
    let g6 = Vec4::splat(gamma(6));
    let err = Lanes3 {
        x: (centre.x.abs() + rn.x.abs()) * g6,
        y: (centre.y.abs() + rn.y.abs()) * g6,
        z: (centre.z.abs() + rn.z.abs()) * g6,
    };
    let pdf = Vec4::ONE / (Vec4::splat(2.0 * PI) * one_minus_cos);
    // The area light's direction and distance to the point.
    let to_point = Lanes3 {
        x: point.x - at.x,
        y: point.y - at.y,
        z: point.z - at.z,
    };
    let dist = sqrt(to_point.length_squared());
    let wi = to_point.map(|c| c / dist);
    ConeLanes {
        inside,
        point,
        err,
        n,
        pdf,
        wi,
        dist,
    }
}

/// Four lanes of [`sample_cones_lanes`]: each lane's cone sample, as
/// vectors (read lane by lane where they are used: a `ConeSample` array
/// written lane by lane and copied out in 16-byte pieces waited for the
/// narrower stores, which cannot be forwarded to them: half of the
/// sphere lights' group in `perf`).
pub struct ConeLanes {
    /// Lanes (as bits) whose point is inside or on its sphere: no cone.
    pub inside: u32,
    pub point: Lanes3,
    pub err: Lanes3,
    pub n: Lanes3,
    pub pdf: Vec4,
    pub wi: Lanes3,
    pub dist: Vec4,
}

impl ConeLanes {
    /// Lane `k`'s sample, None where it has no cone.
    pub fn lane(&self, k: usize) -> Option<ConeSample> {
        (self.inside & (1 << k) == 0).then(|| ConeSample {
            s: SurfaceSample {
                p: self.point.lane(k),
                err: self.err.lane(k),
                n: self.n.lane(k),
                pdf_area: 0.0,
                prim: 0,
                bary: Vec2::ZERO,
            },
            pdf: self.pdf[k],
            wi: self.wi.lane(k),
            dist: self.dist[k],
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Sampler;

    /// The scalar routines' sample, as an area light computes it.
    fn scalar(sphere: &Sphere, p: Vec3, u: Vec2) -> Option<ConeSample> {
        let cone = sphere.visible_cone(p)?;
        let (s, pdf) = sphere.sample_cone(&cone, u);
        let to = s.p - p;
        let dist = to.length();
        Some(ConeSample {
            s,
            pdf,
            wi: to / dist,
            dist,
        })
    }

    fn bits(c: &Option<ConeSample>) -> Option<Vec<u32>> {
        c.map(|c| {
            [c.s.p, c.s.err, c.s.n, c.wi]
                .iter()
                .flat_map(|v| v.to_array())
                .chain([c.pdf, c.dist, c.s.pdf_area])
                .map(f32::to_bits)
                .collect()
        })
    }

    /// Random spheres seen from points far, near, on and inside them, with
    /// numbers on the square's edges too: every lane is the scalar
    /// sample, bit for bit, and None exactly where the scalar has no cone.
    #[test]
    fn lanes_are_the_scalar_cone_samples_bit_for_bit() {
        let mut rng = Sampler::new(5, 1);
        let mut next = || rng.next_1d();
        let edges = [0.0, 0.5, 1.0 - f32::EPSILON, 0.25, 0.75];
        let (mut compared, mut inside) = (0, 0);
        for round in 0..20_000 {
            let spheres: Vec<Sphere> = (0..4)
                .map(|_| {
                    let c = Vec3::new(next() * 20.0 - 10.0, next() * 4.0, next() * 9.0 - 3.0);
                    Sphere::new(c, 0.01 + next() * 3.0).unwrap()
                })
                .collect();
            let p: [Vec3; 4] = std::array::from_fn(|k| {
                let s = &spheres[k];
                let dir =
                    crate::sampling::warp::square_to_uniform_sphere(Vec2::new(next(), next()));
                // Inside, on, just outside, near and far.
                let scale = [0.5, 1.0, 1.0001, 1.5, 40.0][(round + k) % 5];
                s.center + dir * s.radius * scale
            });
            let u: [Vec2; 4] = std::array::from_fn(|k| {
                if round % 7 == 0 {
                    Vec2::new(edges[(round / 7 + k) % 5], edges[(round / 7 + 2 * k) % 5])
                } else {
                    Vec2::new(next(), next())
                }
            });
            let refs = [&spheres[0], &spheres[1], &spheres[2], &spheres[3]];
            let lanes = sample_cones_lanes(refs, p.each_ref(), u);
            for k in 0..4 {
                let want = scalar(&spheres[k], p[k], u[k]);
                assert_eq!(bits(&lanes.lane(k)), bits(&want), "round {round}, lane {k}");
                compared += 1;
                inside += usize::from(want.is_none());
            }
        }
        // Both kinds of lanes were met.
        assert!(
            inside > 1000 && inside < compared - 1000,
            "{inside} of {compared}"
        );
    }
}
