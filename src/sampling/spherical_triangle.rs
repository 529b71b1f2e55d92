//! Uniform sampling of the solid angle a triangle subtends (Arvo, "Stratified
//! sampling of spherical triangles", SIGGRAPH 1995). Light sampled this way
//! carries no 1/d^2 or emitter-cosine variation, which area sampling has
//! near a light. Computed in f64: the spherical excess of a small triangle
//! is a difference of nearly equal angles.

use crate::math::Vec3;
use glam::DVec3;

/// Solid angles below this are sampled by area by the callers: there
/// area sampling is nearly as good and costs less (measured: the Cornell
/// box's light, 0.02-0.04 sr from most points, gains nothing from solid-
/// angle sampling; a big light near a floor, 0.1-2 sr, has 2.3x less
/// error with it, and keeps that with this threshold).
pub const MIN_SOLID_ANGLE: f32 = 0.15;

/// Solid angles above this (close to a hemisphere, 2 pi) are sampled by
/// area too: the triangle's edges there lie on near-great circles through
/// the reference point.
pub const MAX_SOLID_ANGLE: f32 = 6.0;

/// Solid angle of the spherical triangle with unit vertices `a`, `b`, `c`
/// (Van Oosterom and Strackee).
pub fn solid_angle(a: Vec3, b: Vec3, c: Vec3) -> f32 {
    let (a, b, c) = (a.as_dvec3(), b.as_dvec3(), c.as_dvec3());
    let num = a.dot(b.cross(c)).abs();
    let den = 1.0 + a.dot(b) + b.dot(c) + c.dot(a);
    (2.0 * num.atan2(den)) as f32
}

/// The part of `v` orthogonal to the unit vector `n`, normalized.
fn orthonormal(v: DVec3, n: DVec3) -> DVec3 {
    (v - n * v.dot(n)).normalize_or_zero()
}

/// A direction uniformly distributed over the spherical triangle with unit
/// vertices `a`, `b`, `c` (density 1 / solid angle), or `None` for a
/// degenerate triangle.
pub fn sample(a: Vec3, b: Vec3, c: Vec3, u: crate::math::Vec2) -> Option<Vec3> {
    let (a, b, c) = (a.as_dvec3(), b.as_dvec3(), c.as_dvec3());
    // Interior angles from the normals of the great circles through the
    // edges; the area is their excess over pi.
    let n_ab = a.cross(b).normalize_or_zero();
    let n_bc = b.cross(c).normalize_or_zero();
    let n_ca = c.cross(a).normalize_or_zero();
    if n_ab == DVec3::ZERO || n_bc == DVec3::ZERO || n_ca == DVec3::ZERO {
        return None;
    }
    let angle = |n1: DVec3, n2: DVec3| (-n1.dot(n2)).clamp(-1.0, 1.0).acos();
    let alpha = angle(n_ab, n_ca);
    let beta = angle(n_bc, n_ab);
    let gamma = angle(n_ca, n_bc);
    let area = alpha + beta + gamma - std::f64::consts::PI;
    if area.is_nan() || area <= 0.0 {
        return None;
    }
    // The sub-triangle A B C' with area u0 * area fixes C' on the arc AC.
    let area_sub = u.x as f64 * area;
    let (s, t) = (area_sub - alpha).sin_cos();
    let (sin_alpha, cos_alpha) = alpha.sin_cos();
    let cos_c = a.dot(b);
    let uu = t - cos_alpha;
    let vv = s + sin_alpha * cos_c;
    let den = (vv * s + uu * t) * sin_alpha;
    let q = if den != 0.0 {
        (((vv * t - uu * s) * cos_alpha - vv) / den).clamp(-1.0, 1.0)
    } else {
        1.0
    };
    let c_sub = q * a + (1.0 - q * q).max(0.0).sqrt() * orthonormal(c, a);
    // Then a point on the arc from B to C', uniform in the sub-triangle.
    let z = 1.0 - u.y as f64 * (1.0 - c_sub.dot(b));
    let d = z * b + (1.0 - z * z).max(0.0).sqrt() * orthonormal(c_sub, b);
    let d = d.normalize_or_zero();
    (d != DVec3::ZERO).then(|| d.as_vec3())
}

/// Sub-triangles of a triangle, `n` x `n` in barycentric space, each as
/// its three (b1, b2) corners: the bins of the chi-square tests of
/// triangle sampling.
#[cfg(test)]
pub(crate) fn subdivide(n: usize) -> Vec<[(f32, f32); 3]> {
    let v = |i: usize, j: usize| (i as f32 / n as f32, j as f32 / n as f32);
    let mut out = Vec::new();
    for i in 0..n {
        for j in 0..n - i {
            out.push([v(i, j), v(i + 1, j), v(i, j + 1)]);
            if i + j + 1 < n {
                out.push([v(i + 1, j), v(i + 1, j + 1), v(i, j + 1)]);
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec2;
    use crate::sampling::Sampler;
    use crate::stats::{chi2_test, sidak};

    fn tri(p: Vec3, v: [Vec3; 3]) -> [Vec3; 3] {
        v.map(|x| (x - p).normalize())
    }

    /// Whether the ray from the origin along `d` passes through the
    /// spherical triangle: on the inner side of all three edge planes, up
    /// to f32 rounding of `d` (1e-6 rad).
    fn inside(t: &[Vec3; 3], d: Vec3) -> bool {
        let t = t.map(|x| x.as_dvec3());
        let d = d.as_dvec3();
        let orient = t[0].cross(t[1]).dot(t[2]).signum();
        let side = |x: DVec3, y: DVec3| x.cross(y).normalize().dot(d) * orient >= -1e-6;
        side(t[0], t[1]) && side(t[1], t[2]) && side(t[2], t[0])
    }

    #[test]
    fn solid_angle_of_an_octant() {
        let o = solid_angle(Vec3::X, Vec3::Y, Vec3::Z);
        assert!((o - std::f32::consts::FRAC_PI_2).abs() < 1e-6, "{o}");
    }

    /// Samples lie inside the triangle, and a chi-square test over a grid
    /// of its barycentric-like coordinates against the uniform solid-angle
    /// density: the fraction of samples falling into a sub-triangle equals
    /// its solid angle over the whole.
    #[test]
    fn uniform_over_the_solid_angle() {
        let cases = [
            // Big and close, seen obliquely.
            tri(
                Vec3::new(0.1, 0.2, 0.05),
                [
                    Vec3::new(-1.0, -1.0, 0.3),
                    Vec3::new(2.0, -0.5, 0.1),
                    Vec3::new(0.0, 1.5, 0.4),
                ],
            ),
            // Small and far.
            tri(
                Vec3::ZERO,
                [
                    Vec3::new(0.0, 0.0, 10.0),
                    Vec3::new(0.3, 0.0, 10.0),
                    Vec3::new(0.0, 0.2, 10.2),
                ],
            ),
            // A long sliver.
            tri(
                Vec3::ZERO,
                [
                    Vec3::new(-3.0, 0.0, 1.0),
                    Vec3::new(3.0, 0.05, 1.0),
                    Vec3::new(0.0, 0.2, 1.0),
                ],
            ),
        ];
        let alpha = sidak(0.01, cases.len());
        let mut sampler = Sampler::new(11, 3);
        for t in cases {
            let total = solid_angle(t[0], t[1], t[2]);
            // Split the triangle into a grid of sub-triangles by
            // subdividing its edges (n x n cells, n^2 triangles).
            let n = 6;
            let subs: Vec<[Vec3; 3]> = subdivide(n)
                .into_iter()
                .map(|s| {
                    s.map(|(b1, b2)| (t[0] * (1.0 - b1 - b2) + t[1] * b1 + t[2] * b2).normalize())
                })
                .collect();
            let expected_frac: Vec<f64> = subs
                .iter()
                .map(|s| (solid_angle(s[0], s[1], s[2]) / total) as f64)
                .collect();
            let sum: f64 = expected_frac.iter().sum();
            assert!((sum - 1.0).abs() < 1e-3, "sub-triangles cover it: {sum}");
            let samples = 200_000;
            let mut counts = vec![0.0f64; subs.len()];
            for _ in 0..samples {
                let d = sample(t[0], t[1], t[2], sampler.next_2d()).unwrap();
                assert!((d.length() - 1.0).abs() < 1e-5);
                assert!(inside(&t, d), "{d} outside");
                if let Some(k) = subs.iter().position(|s| inside(s, d)) {
                    counts[k] += 1.0;
                }
            }
            let placed: f64 = counts.iter().sum();
            assert!(placed > 0.999 * samples as f64, "{placed}");
            let expected: Vec<f64> = expected_frac.iter().map(|f| f * placed).collect();
            let r = chi2_test(&counts, &expected, 5.0);
            assert!(r.passes(alpha), "{r:?}");
        }
    }

    #[test]
    fn degenerate_triangles_give_none() {
        let u = Vec2::new(0.3, 0.7);
        assert!(sample(Vec3::X, Vec3::X, Vec3::Y, u).is_none());
        let d = Vec3::new(1.0, 1.0, 0.0).normalize();
        assert!(sample(Vec3::X, d, Vec3::Y, u).is_none());
    }
}
