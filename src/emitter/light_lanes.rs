//! [`LightBounds::importance`] for four lights at once, one per SIMD lane.
//!
//! The light choice weighs every bounded light at every shading point; on
//! Veach's MIS scene (four spheres) that was 7.6% of a render, most of it
//! the latency of each light's chain of square roots and divisions. Four
//! lanes run the four chains side by side. Every lane does the scalar
//! routine's operations in its order, with its rounding (plain multiplies
//! and adds, correctly rounded square roots and divisions; the branches
//! become selects), so the results are the scalar ones bit for bit (tested)
//! and renders do not change.

use super::LightBounds;
use crate::math::{Vec3, Vec4};
use glam::BVec4A;

use super::light_choice::MIN_FACTOR;

/// Up to four lights' bounds, field by field in lanes. Unused lanes have no
/// power, which gives them zero importance.
#[derive(Clone, Copy, Debug)]
pub(super) struct BoundsLanes {
    cx: Vec4,
    cy: Vec4,
    cz: Vec4,
    radius: Vec4,
    power: Vec4,
    ax: Vec4,
    ay: Vec4,
    az: Vec4,
    cos_o: Vec4,
    /// sin(theta_o), as the scalar routine computes it from `cos_o`.
    sin_o: Vec4,
    /// Lanes whose light emits within a cone (`cos_theta_o > -1`).
    cone: BVec4A,
}

impl BoundsLanes {
    /// The lanes of `lights` in groups of four, the last padded.
    pub fn group(lights: &[LightBounds]) -> Vec<BoundsLanes> {
        lights.chunks(4).map(BoundsLanes::new).collect()
    }

    fn new(four: &[LightBounds]) -> BoundsLanes {
        let lane = |f: &dyn Fn(&LightBounds) -> f32, pad: f32| {
            Vec4::from_array(std::array::from_fn(|i| four.get(i).map_or(pad, f)))
        };
        let cos_o = lane(&|b| b.cos_theta_o, -1.0);
        BoundsLanes {
            cx: lane(&|b| b.centre.x, 0.0),
            cy: lane(&|b| b.centre.y, 0.0),
            cz: lane(&|b| b.centre.z, 0.0),
            radius: lane(&|b| b.radius, 0.0),
            power: lane(&|b| b.power, 0.0),
            ax: lane(&|b| b.axis.x, 0.0),
            ay: lane(&|b| b.axis.y, 0.0),
            az: lane(&|b| b.axis.z, 1.0),
            cos_o,
            // As `LightBounds::importance` computes it.
            sin_o: lane(
                &|b| (1.0 - b.cos_theta_o * b.cos_theta_o).max(0.0).sqrt(),
                0.0,
            ),
            cone: cos_o.cmpgt(Vec4::splat(-1.0)),
        }
    }

    /// [`LightBounds::importance`] of the four lanes at `p` with normal
    /// `n` (zero for none).
    #[inline]
    pub fn importance(&self, p: Vec3, n: Vec3) -> Vec4 {
        let zero = Vec4::ZERO;
        let one = Vec4::ONE;
        let (tx, ty, tz) = (
            Vec4::splat(p.x) - self.cx,
            Vec4::splat(p.y) - self.cy,
            Vec4::splat(p.z) - self.cz,
        );
        let d2 = dot(tx, ty, tz, tx, ty, tz);
        let r2 = self.radius * self.radius;
        let inside = d2.cmple(r2);
        let inside_value = self.power / r2.max(Vec4::splat(f32::MIN_POSITIVE));
        let dist = d2.sqrt();
        let (wx, wy, wz) = (tx / dist, ty / dist, tz / dist);
        let sin_b = self.radius / dist;
        let cos_b = sqrt_of_one_minus_square(sin_b);
        // The emission cone, where the light has one.
        let cos_w = dot(self.ax, self.ay, self.az, wx, wy, wz).clamp(-one, one);
        let sin_w = sqrt_of_one_minus_square(cos_w);
        let within = cos_w.cmpge(self.cos_o);
        let cos_x = Vec4::select(within, one, cos_w * self.cos_o + sin_w * self.sin_o);
        let sin_x = Vec4::select(within, zero, sin_w * self.cos_o - cos_w * self.sin_o);
        let c = Vec4::select(cos_x.cmpge(cos_b), one, cos_x * cos_b + sin_x * sin_b);
        let culled = self.cone & c.cmple(Vec4::splat(-1e-4));
        let mut factor = Vec4::select(self.cone, c.max(Vec4::splat(MIN_FACTOR)), one);
        if n != Vec3::ZERO {
            let (nx, ny, nz) = (Vec4::splat(n.x), Vec4::splat(n.y), Vec4::splat(n.z));
            let cos_i = dot(nx, ny, nz, wx, wy, wz).abs().min(one);
            let sin_i = sqrt_of_one_minus_square(cos_i);
            let c = Vec4::select(cos_i.cmpge(cos_b), one, cos_i * cos_b + sin_i * sin_b);
            factor *= c.max(Vec4::splat(MIN_FACTOR));
        }
        let outside_value = Vec4::select(culled, zero, self.power * factor / d2);
        let value = Vec4::select(inside, inside_value, outside_value);
        Vec4::select(self.power.cmple(zero), zero, value)
    }
}

/// x1 x2 + y1 y2 + z1 z2, added in glam's `Vec3::dot` order.
#[inline(always)]
fn dot(x1: Vec4, y1: Vec4, z1: Vec4, x2: Vec4, y2: Vec4, z2: Vec4) -> Vec4 {
    x1 * x2 + y1 * y2 + z1 * z2
}

/// sqrt(max(1 - x^2, 0)).
#[inline(always)]
fn sqrt_of_one_minus_square(x: Vec4) -> Vec4 {
    (Vec4::ONE - x * x).max(Vec4::ZERO).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampling::Sampler;

    /// Random bounds of every kind: points, spheres, cones narrow and wide,
    /// powerless, and shading points inside, near and far.
    fn random_bounds(s: &mut Sampler) -> LightBounds {
        let mut v = |scale: f32| {
            Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) * 2.0 * scale - Vec3::splat(scale)
        };
        let centre = v(3.0);
        let axis = v(1.0).normalize_or(Vec3::Z);
        let k = v(1.0);
        LightBounds {
            centre,
            radius: if k.x < 0.0 { 0.0 } else { k.x.abs() * 2.0 },
            power: if k.y < -0.8 { 0.0 } else { 10.0 * (k.y + 1.0) },
            axis,
            cos_theta_o: if k.z < -0.3 { -1.0 } else { k.z },
        }
    }

    /// Each lane equals the scalar routine bit for bit, with and without a
    /// normal, over 20,000 random lights and points (many inside a light's
    /// sphere, behind a cone, or at grazing angles). Control: the lanes
    /// differ from the scalar routine once the normal term is left out.
    #[test]
    fn lanes_equal_the_scalar_importance_bit_for_bit() {
        let mut s = Sampler::new(11, 4);
        let mut nonzero = 0;
        let mut differs_without_normal = 0;
        for _ in 0..5000 {
            let lights: Vec<LightBounds> = (0..4).map(|_| random_bounds(&mut s)).collect();
            let lanes = BoundsLanes::group(&lights)[0];
            let p = Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) * 6.0 - 3.0;
            let n = (Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) - 0.5).normalize();
            for normal in [n, Vec3::ZERO] {
                let got = lanes.importance(p, normal).to_array();
                for (k, b) in lights.iter().enumerate() {
                    let want = b.importance(p, normal);
                    assert_eq!(got[k].to_bits(), want.to_bits(), "{b:?} at {p} n {normal}");
                    nonzero += usize::from(want > 0.0);
                }
            }
            let no_normal = lanes.importance(p, Vec3::ZERO).to_array();
            differs_without_normal += (0..4)
                .filter(|&k| no_normal[k] != lights[k].importance(p, n))
                .count();
        }
        assert!(nonzero > 20_000, "only {nonzero} lights with importance");
        assert!(differs_without_normal > 1000, "{differs_without_normal}");
    }

    /// Padding lanes weigh nothing.
    #[test]
    fn padding_lanes_are_zero() {
        let mut s = Sampler::new(2, 9);
        let light = random_bounds(&mut s);
        let lanes = BoundsLanes::group(&[light])[0].importance(Vec3::ONE, Vec3::Y);
        assert_eq!(&lanes.to_array()[1..], &[0.0; 3]);
    }
}
