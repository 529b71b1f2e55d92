//! Warps from the unit square to other domains, each with its pdf.
//! Names follow Nori's warp tester.

use crate::math::{
    select_bits, sin_cos_turns, sin_cos_turns_lanes, Vec2, Vec3, INV_FOUR_PI, INV_PI, INV_TWO_PI,
    PI,
};
use glam::Vec4;

pub fn square_to_uniform_square(s: Vec2) -> Vec2 {
    s
}

pub fn square_to_uniform_square_pdf(p: Vec2) -> f32 {
    if (0.0..=1.0).contains(&p.x) && (0.0..=1.0).contains(&p.y) {
        1.0
    } else {
        0.0
    }
}

/// 1D tent on [-1, 1] by inverting its CDF.
fn tent_1d(u: f32) -> f32 {
    if u < 0.5 {
        (2.0 * u).sqrt() - 1.0
    } else {
        1.0 - (2.0 - 2.0 * u).sqrt()
    }
}

pub fn square_to_tent(s: Vec2) -> Vec2 {
    Vec2::new(tent_1d(s.x), tent_1d(s.y))
}

pub fn square_to_tent_pdf(p: Vec2) -> f32 {
    let t = |x: f32| (1.0 - x.abs()).max(0.0);
    t(p.x) * t(p.y)
}

/// Shirley-Chiu concentric map onto the unit disk: preserves strata and
/// relative areas, the sampling pbrt and Mitsuba use for lenses.
pub fn square_to_uniform_disk(s: Vec2) -> Vec2 {
    let o = 2.0 * s - Vec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return Vec2::ZERO;
    }
    // The angle in turns: pi/4 (y/x), or pi/2 - pi/4 (x/y). Chosen by
    // masks, not jumps: the choice is random (`select_bits`).
    let flat = o.x.abs() > o.y.abs();
    let r = select_bits(flat, o.x, o.y);
    let q = select_bits(flat, o.y, o.x) / r;
    let turns = select_bits(flat, 0.125 * q, 0.25 - 0.125 * q);
    let (sin, cos) = sin_cos_turns(turns);
    r * Vec2::new(cos, sin)
}

pub fn square_to_uniform_disk_pdf(p: Vec2) -> f32 {
    if p.length_squared() <= 1.0 {
        INV_PI
    } else {
        0.0
    }
}

pub fn square_to_uniform_sphere(s: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * s.y;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (sin_phi, cos_phi) = sin_cos_turns(s.x);
    Vec3::new(r * cos_phi, r * sin_phi, z)
}

/// [`square_to_uniform_sphere`] of four points in SIMD lanes, each lane
/// the scalar routine's bits (tested): a constant sky's light samples
/// drawn four at a time by a batch of paths, whose angle polynomials and
/// square roots would otherwise run as one dependent chain per path.
pub fn square_to_uniform_sphere_lanes(s: &[Vec2; 4]) -> [Vec3; 4] {
    let sx = Vec4::from_array(s.map(|s| s.x));
    let sy = Vec4::from_array(s.map(|s| s.y));
    let z = Vec4::ONE - 2.0 * sy;
    let r = (Vec4::ONE - z * z).max(Vec4::ZERO);
    let r = Vec4::from_array(r.to_array().map(f32::sqrt));
    let (sin, cos) = sin_cos_turns_lanes(sx);
    let (x, y, z) = ((r * cos).to_array(), (r * sin).to_array(), z.to_array());
    std::array::from_fn(|k| Vec3::new(x[k], y[k], z[k]))
}

pub fn square_to_uniform_sphere_pdf(_v: Vec3) -> f32 {
    INV_FOUR_PI
}

pub fn square_to_uniform_hemisphere(s: Vec2) -> Vec3 {
    let z = s.y;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (sin_phi, cos_phi) = sin_cos_turns(s.x);
    Vec3::new(r * cos_phi, r * sin_phi, z)
}

pub fn square_to_uniform_hemisphere_pdf(v: Vec3) -> f32 {
    if v.z >= 0.0 {
        INV_TWO_PI
    } else {
        0.0
    }
}

/// Cosine-weighted hemisphere by Malley's method over the concentric disk.
pub fn square_to_cosine_hemisphere(s: Vec2) -> Vec3 {
    let d = square_to_uniform_disk(s);
    let z = (1.0 - d.length_squared()).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

/// [`square_to_cosine_hemisphere`] of four points in SIMD lanes, each
/// lane the scalar routine's bits (tested): the same operations in the
/// same order, its branches as masks. A batch of paths samples its
/// diffuse bounces with it: the scalar map is one long chain of
/// dependent operations (a division, the sine and cosine polynomials, a
/// square root) that four lanes run once.
pub fn square_to_cosine_hemisphere_lanes(s: &[Vec2; 4]) -> [Vec3; 4] {
    let sx = Vec4::from_array(s.map(|s| s.x));
    let sy = Vec4::from_array(s.map(|s| s.y));
    let (ox, oy) = (2.0 * sx - Vec4::ONE, 2.0 * sy - Vec4::ONE);
    let centre = ox.cmpeq(Vec4::ZERO) & oy.cmpeq(Vec4::ZERO);
    let flat = ox.abs().cmpgt(oy.abs());
    let r = Vec4::select(flat, ox, oy);
    let q = Vec4::select(flat, oy, ox) / r;
    let turns = Vec4::select(flat, 0.125 * q, Vec4::splat(0.25) - 0.125 * q);
    let (sin, cos) = sin_cos_turns_lanes(turns);
    let dx = Vec4::select(centre, Vec4::ZERO, r * cos);
    let dy = Vec4::select(centre, Vec4::ZERO, r * sin);
    let z = (Vec4::ONE - (dx * dx + dy * dy)).max(Vec4::ZERO);
    let z = Vec4::from_array(z.to_array().map(f32::sqrt));
    let (dx, dy, z) = (dx.to_array(), dy.to_array(), z.to_array());
    std::array::from_fn(|k| Vec3::new(dx[k], dy[k], z[k]))
}

pub fn square_to_cosine_hemisphere_pdf(v: Vec3) -> f32 {
    if v.z >= 0.0 {
        v.z * INV_PI
    } else {
        0.0
    }
}

/// Uniform cone around +z with the given cosine of its half-angle.
pub fn square_to_uniform_cone(s: Vec2, cos_max: f32) -> Vec3 {
    let z = 1.0 - s.y * (1.0 - cos_max);
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (sin_phi, cos_phi) = sin_cos_turns(s.x);
    Vec3::new(r * cos_phi, r * sin_phi, z)
}

pub fn square_to_uniform_cone_pdf(v: Vec3, cos_max: f32) -> f32 {
    if v.z >= cos_max {
        1.0 / (2.0 * PI * (1.0 - cos_max))
    } else {
        0.0
    }
}

/// Barycentrics uniform over a triangle.
pub fn square_to_uniform_triangle(s: Vec2) -> Vec2 {
    let su = s.x.sqrt();
    Vec2::new(1.0 - su, s.y * su)
}

/// Beckmann normal distribution D(m) cos(theta_m): samples microfacet normals.
pub fn square_to_beckmann(s: Vec2, alpha: f32) -> Vec3 {
    let tan2 = -alpha * alpha * (1.0 - s.x).ln();
    let cos_theta = 1.0 / (1.0 + tan2).sqrt();
    // sin = tan cos: exact near the pole, where 1 - cos^2 cancels.
    let sin_theta = tan2.sqrt() * cos_theta;
    let (sin_phi, cos_phi) = sin_cos_turns(s.y);
    Vec3::new(sin_theta * cos_phi, sin_theta * sin_phi, cos_theta)
}

/// The Beckmann distribution D(m) (not yet multiplied by cos theta).
pub fn beckmann_d(m: Vec3, alpha: f32) -> f32 {
    if m.z <= 0.0 {
        return 0.0;
    }
    let cos2 = m.z * m.z;
    let tan2 = (1.0 - cos2) / cos2;
    let a2 = alpha * alpha;
    (-tan2 / a2).exp() / (PI * a2 * cos2 * cos2)
}

pub fn square_to_beckmann_pdf(m: Vec3, alpha: f32) -> f32 {
    beckmann_d(m, alpha) * m.z.max(0.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The uniform sphere's lanes give the scalar map's bits, on a grid
    /// over the square with its edges and next to them.
    #[test]
    fn uniform_sphere_lanes_are_the_scalar_bit_for_bit() {
        let mut points: Vec<Vec2> = Vec::new();
        for i in 0..=300 {
            for j in 0..=300 {
                let (x, y) = (i as f32 / 300.0, j as f32 / 300.0);
                points.extend([Vec2::new(x, y), Vec2::new(x.next_up(), y.next_down())]);
            }
        }
        points.push(Vec2::splat(1.0f32.next_down()));
        while !points.len().is_multiple_of(4) {
            points.push(Vec2::splat(0.5));
        }
        let bits = |v: Vec3| v.to_array().map(f32::to_bits);
        for chunk in points.chunks(4) {
            let s: [Vec2; 4] = chunk.try_into().unwrap();
            let lanes = square_to_uniform_sphere_lanes(&s);
            for (p, lane) in s.iter().zip(lanes) {
                let scalar = square_to_uniform_sphere(*p);
                assert_eq!(bits(lane), bits(scalar), "{p}: {lane} != {scalar}");
            }
        }
    }

    /// The lanes give the scalar map's bits: on a grid over the square
    /// with its edges, at the centre (the scalar map's own case, which
    /// the lanes' division turns into NaN before their mask), on the
    /// diagonals (where the two halves of the map meet) and next to them.
    #[test]
    fn cosine_hemisphere_lanes_are_the_scalar_bit_for_bit() {
        let mut points: Vec<Vec2> = Vec::new();
        for i in 0..=200 {
            for j in 0..=200 {
                points.push(Vec2::new(i as f32 / 200.0, j as f32 / 200.0));
            }
        }
        for k in 0..=1000 {
            let t = k as f32 / 1000.0;
            points.extend([
                Vec2::new(t, t),
                Vec2::new(t, 1.0 - t),
                Vec2::new(t.next_up(), t),
                Vec2::new(t, t.next_down()),
            ]);
        }
        let below_one = 1.0f32.next_down();
        points.extend([Vec2::splat(0.5), Vec2::new(0.5, below_one), Vec2::ZERO]);
        while !points.len().is_multiple_of(4) {
            points.push(Vec2::splat(0.5));
        }
        let bits = |v: Vec3| v.to_array().map(f32::to_bits);
        for chunk in points.chunks(4) {
            let s: [Vec2; 4] = chunk.try_into().unwrap();
            let lanes = square_to_cosine_hemisphere_lanes(&s);
            for (p, lane) in s.iter().zip(lanes) {
                let scalar = square_to_cosine_hemisphere(*p);
                assert_eq!(bits(lane), bits(scalar), "{p}: {lane} != {scalar}");
            }
        }
    }
}
