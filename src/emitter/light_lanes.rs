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
    /// The importance at a point inside the light's sphere, which does
    /// not depend on the point.
    inside_value: Vec4,
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
            sin_o: lane(&LightBounds::sin_theta_o, 0.0),
            cone: cos_o.cmpgt(Vec4::splat(-1.0)),
            inside_value: lane(&LightBounds::inside_importance, 0.0),
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
        let inside = d2.cmple(self.radius * self.radius);
        let inv_dist = Vec4::ONE / d2.sqrt();
        let (wx, wy, wz) = (tx * inv_dist, ty * inv_dist, tz * inv_dist);
        let sin_b = self.radius * inv_dist;
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
        let value = Vec4::select(inside, self.inside_value, outside_value);
        Vec4::select(self.power.cmple(zero), zero, value)
    }
}

/// Up to eight lights' bounds for [`BoundsLanes8::importance`]: the fields
/// of [`BoundsLanes`], eight lanes to a row (unused lanes padded alike).
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub(super) struct BoundsLanes8 {
    /// cx, cy, cz, radius, power, ax, ay, az, cos_o, sin_o, inside_value.
    rows: [[f32; 8]; 11],
    /// All ones where the light emits within a cone.
    cone: [u32; 8],
}

#[cfg(target_arch = "x86_64")]
impl BoundsLanes8 {
    /// The groups of four `fours` ([`BoundsLanes::group`]) two by two side
    /// by side, the last padded.
    pub fn pairs(fours: &[BoundsLanes]) -> Vec<BoundsLanes8> {
        let padding = BoundsLanes::new(&[]);
        fours
            .chunks(2)
            .map(|pair| {
                let (lo, hi) = (pair[0], *pair.get(1).unwrap_or(&padding));
                let row = |f: &dyn Fn(&BoundsLanes) -> Vec4| {
                    let (a, b) = (f(&lo).to_array(), f(&hi).to_array());
                    std::array::from_fn(|k| if k < 4 { a[k] } else { b[k - 4] })
                };
                let cone = |b: &BoundsLanes| b.cone.bitmask();
                let (cl, ch) = (cone(&lo), cone(&hi));
                BoundsLanes8 {
                    rows: [
                        row(&|b| b.cx),
                        row(&|b| b.cy),
                        row(&|b| b.cz),
                        row(&|b| b.radius),
                        row(&|b| b.power),
                        row(&|b| b.ax),
                        row(&|b| b.ay),
                        row(&|b| b.az),
                        row(&|b| b.cos_o),
                        row(&|b| b.sin_o),
                        row(&|b| b.inside_value),
                    ],
                    cone: std::array::from_fn(|k| {
                        let bit = if k < 4 { cl >> k } else { ch >> (k - 4) };
                        if bit & 1 == 1 {
                            u32::MAX
                        } else {
                            0
                        }
                    }),
                }
            })
            .collect()
    }

    /// [`BoundsLanes::importance`] of the eight lanes in AVX lanes: the
    /// same operations in the same order, so the same bits (tested).
    ///
    /// # Safety
    /// Call only where the CPU has AVX2.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub fn importance(&self, p: Vec3, n: Vec3) -> [f32; 8] {
        use avx::{cone_cos, cos_less, dot, le, select, sqrt1m};
        use std::arch::x86_64::*;
        let (sub, mul, div) = (_mm256_sub_ps, _mm256_mul_ps, _mm256_div_ps);
        // SAFETY: the rows are eight aligned floats each.
        let row = |k: usize| unsafe { _mm256_load_ps(self.rows[k].as_ptr()) };
        let (cx, cy, cz, radius, power) = (row(0), row(1), row(2), row(3), row(4));
        let (ax, ay, az, cos_o, sin_o) = (row(5), row(6), row(7), row(8), row(9));
        // SAFETY: eight aligned integers.
        let cone = _mm256_castsi256_ps(unsafe { _mm256_load_si256(self.cone.as_ptr().cast()) });
        let (zero, one) = (_mm256_setzero_ps(), _mm256_set1_ps(1.0));
        let (tx, ty, tz) = (
            sub(_mm256_set1_ps(p.x), cx),
            sub(_mm256_set1_ps(p.y), cy),
            sub(_mm256_set1_ps(p.z), cz),
        );
        let d2 = dot(tx, ty, tz, tx, ty, tz);
        let inside = le(d2, mul(radius, radius));
        let inside_value = row(10);
        let inv_dist = div(one, _mm256_sqrt_ps(d2));
        let (wx, wy, wz) = (mul(tx, inv_dist), mul(ty, inv_dist), mul(tz, inv_dist));
        let sin_b = mul(radius, inv_dist);
        let cos_b = sqrt1m(sin_b);
        let c = cone_cos([ax, ay, az], cos_o, sin_o, [wx, wy, wz], cos_b, sin_b);
        let culled = _mm256_and_ps(cone, le(c, _mm256_set1_ps(-1e-4)));
        let mut factor = select(cone, _mm256_max_ps(c, _mm256_set1_ps(MIN_FACTOR)), one);
        if n != Vec3::ZERO {
            let (nx, ny, nz) = (
                _mm256_set1_ps(n.x),
                _mm256_set1_ps(n.y),
                _mm256_set1_ps(n.z),
            );
            let magnitude = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fff_ffff));
            let cos_i = _mm256_min_ps(_mm256_and_ps(dot(nx, ny, nz, wx, wy, wz), magnitude), one);
            let c = cos_less(cos_i, sqrt1m(cos_i), cos_b, sin_b);
            factor = mul(factor, _mm256_max_ps(c, _mm256_set1_ps(MIN_FACTOR)));
        }
        let outside_value = select(culled, zero, div(mul(power, factor), d2));
        let value = select(inside, inside_value, outside_value);
        let value = select(le(power, zero), zero, value);
        let mut out = [0.0f32; 8];
        // SAFETY: `out` holds eight floats.
        unsafe { _mm256_storeu_ps(out.as_mut_ptr(), value) };
        out
    }

    /// [`LightBounds::importance`] of the light in lane `lane` at each of
    /// eight points, one per lane: the scalar routine's operations in its
    /// order (its branches on the light taken here, those on the point
    /// made selects), so the same bits (tested). Weighing many points a
    /// light at a time fills every lane and runs the points' chains of
    /// square roots and divisions side by side, where weighing a point's
    /// few lights at a time left lanes empty and waited on each chain.
    ///
    /// # Safety
    /// Call only where the CPU has AVX2.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub fn importance_at_points(&self, lane: usize, at: &PointLanes8) -> std::arch::x86_64::__m256 {
        use avx::{cone_cos, cos_less, dot, le, select, sqrt1m};
        use std::arch::x86_64::*;
        let (sub, mul, div) = (_mm256_sub_ps, _mm256_mul_ps, _mm256_div_ps);
        let field = |k: usize| self.rows[k][lane];
        let power = field(4);
        if power <= 0.0 {
            return _mm256_setzero_ps();
        }
        let splat = _mm256_set1_ps;
        let (zero, one) = (_mm256_setzero_ps(), splat(1.0));
        let radius = splat(field(3));
        let (tx, ty, tz) = (
            sub(at.x, splat(field(0))),
            sub(at.y, splat(field(1))),
            sub(at.z, splat(field(2))),
        );
        let d2 = dot(tx, ty, tz, tx, ty, tz);
        let inside = le(d2, mul(radius, radius));
        let inv_dist = div(one, _mm256_sqrt_ps(d2));
        let (wx, wy, wz) = (mul(tx, inv_dist), mul(ty, inv_dist), mul(tz, inv_dist));
        let sin_b = mul(radius, inv_dist);
        let cos_b = sqrt1m(sin_b);
        let mut factor = one;
        let mut culled = zero;
        if self.cone[lane] != 0 {
            let (cos_o, sin_o) = (splat(field(8)), splat(field(9)));
            let axis = [splat(field(5)), splat(field(6)), splat(field(7))];
            let c = cone_cos(axis, cos_o, sin_o, [wx, wy, wz], cos_b, sin_b);
            culled = le(c, splat(-1e-4));
            factor = _mm256_max_ps(c, splat(MIN_FACTOR));
        }
        let magnitude = _mm256_castsi256_ps(_mm256_set1_epi32(0x7fff_ffff));
        let cos_i = _mm256_min_ps(
            _mm256_and_ps(dot(at.nx, at.ny, at.nz, wx, wy, wz), magnitude),
            one,
        );
        let c = cos_less(cos_i, sqrt1m(cos_i), cos_b, sin_b);
        let with_normal = mul(factor, _mm256_max_ps(c, splat(MIN_FACTOR)));
        let factor = select(at.has_normal, with_normal, factor);
        let outside_value = select(culled, zero, div(mul(splat(power), factor), d2));
        select(inside, splat(field(10)), outside_value)
    }
}

/// Eight shading points (positions and normals) in AVX lanes, one point
/// per lane, for weighing one light at all of them at once
/// ([`BoundsLanes8::importance_at_points`]).
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
pub(super) struct PointLanes8 {
    x: std::arch::x86_64::__m256,
    y: std::arch::x86_64::__m256,
    z: std::arch::x86_64::__m256,
    nx: std::arch::x86_64::__m256,
    ny: std::arch::x86_64::__m256,
    nz: std::arch::x86_64::__m256,
    /// All ones where the point has a normal (`n != Vec3::ZERO`).
    has_normal: std::arch::x86_64::__m256,
}

#[cfg(target_arch = "x86_64")]
impl PointLanes8 {
    /// The points `p` with normals `n` (zero for none).
    ///
    /// # Safety
    /// Call only where the CPU has AVX2.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub fn new(p: &[Vec3; 8], n: &[Vec3; 8]) -> PointLanes8 {
        use std::arch::x86_64::*;
        let lanes = |f: &dyn Fn(usize) -> f32| {
            let a: [f32; 8] = std::array::from_fn(f);
            // SAFETY: eight floats.
            unsafe { _mm256_loadu_ps(a.as_ptr()) }
        };
        let (nx, ny, nz) = (lanes(&|k| n[k].x), lanes(&|k| n[k].y), lanes(&|k| n[k].z));
        // `!=` on each component: true where unordered, as Rust's is.
        let ne = |a| _mm256_cmp_ps::<_CMP_NEQ_UQ>(a, _mm256_setzero_ps());
        PointLanes8 {
            x: lanes(&|k| p[k].x),
            y: lanes(&|k| p[k].y),
            z: lanes(&|k| p[k].z),
            nx,
            ny,
            nz,
            has_normal: _mm256_or_ps(_mm256_or_ps(ne(nx), ne(ny)), ne(nz)),
        }
    }
}

/// The eight-lane routines' steps, each as the four-lane code does it.
#[cfg(target_arch = "x86_64")]
mod avx {
    use std::arch::x86_64::*;

    /// glam's select: `b` where the mask `m` is clear, `a` where it is set.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub fn select(m: __m256, a: __m256, b: __m256) -> __m256 {
        _mm256_blendv_ps(b, a, m)
    }

    /// a >= b (false where unordered).
    #[inline]
    #[target_feature(enable = "avx2")]
    pub fn ge(a: __m256, b: __m256) -> __m256 {
        _mm256_cmp_ps::<_CMP_GE_OQ>(a, b)
    }

    /// a <= b (false where unordered).
    #[inline]
    #[target_feature(enable = "avx2")]
    pub fn le(a: __m256, b: __m256) -> __m256 {
        _mm256_cmp_ps::<_CMP_LE_OQ>(a, b)
    }

    /// x1 x2 + y1 y2 + z1 z2, added in glam's `Vec3::dot` order.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub fn dot(x1: __m256, y1: __m256, z1: __m256, x2: __m256, y2: __m256, z2: __m256) -> __m256 {
        let (add, mul) = (_mm256_add_ps, _mm256_mul_ps);
        add(add(mul(x1, x2), mul(y1, y2)), mul(z1, z2))
    }

    /// cos(max(0, x - b)) from the cosines and sines of angles x and b.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub fn cos_less(cos_x: __m256, sin_x: __m256, cos_b: __m256, sin_b: __m256) -> __m256 {
        let (add, mul) = (_mm256_add_ps, _mm256_mul_ps);
        let one = _mm256_set1_ps(1.0);
        select(
            ge(cos_x, cos_b),
            one,
            add(mul(cos_x, cos_b), mul(sin_x, sin_b)),
        )
    }

    /// The cosine of the angle between an emission cone (`axis`, half-angle
    /// o) and the unit direction `w`, less the light's extent b:
    /// `LightBounds::importance`'s theta', one inside the cone.
    #[inline]
    #[target_feature(enable = "avx2")]
    pub fn cone_cos(
        axis: [__m256; 3],
        cos_o: __m256,
        sin_o: __m256,
        w: [__m256; 3],
        cos_b: __m256,
        sin_b: __m256,
    ) -> __m256 {
        let (add, sub, mul) = (_mm256_add_ps, _mm256_sub_ps, _mm256_mul_ps);
        let (zero, one) = (_mm256_setzero_ps(), _mm256_set1_ps(1.0));
        let [ax, ay, az] = axis;
        let [wx, wy, wz] = w;
        // glam's clamp: max with the low end, then min with the high end.
        let cos_w = _mm256_min_ps(
            _mm256_max_ps(dot(ax, ay, az, wx, wy, wz), _mm256_set1_ps(-1.0)),
            one,
        );
        let sin_w = sqrt1m(cos_w);
        let within = ge(cos_w, cos_o);
        let cos_x = select(within, one, add(mul(cos_w, cos_o), mul(sin_w, sin_o)));
        let sin_x = select(within, zero, sub(mul(sin_w, cos_o), mul(cos_w, sin_o)));
        cos_less(cos_x, sin_x, cos_b, sin_b)
    }

    /// sqrt(max(1 - x^2, 0)).
    #[inline]
    #[target_feature(enable = "avx2")]
    pub fn sqrt1m(x: __m256) -> __m256 {
        let one_minus = _mm256_sub_ps(_mm256_set1_ps(1.0), _mm256_mul_ps(x, x));
        _mm256_sqrt_ps(_mm256_max_ps(one_minus, _mm256_setzero_ps()))
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

    /// The eight-lane routine equals the four-lane one (so the scalar one)
    /// bit for bit, for groups of 1 to 8 lights, padding lanes included.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn eight_lanes_equal_four_lanes_bit_for_bit() {
        if !std::arch::is_x86_feature_detected!("avx2") {
            return;
        }
        let mut s = Sampler::new(17, 5);
        let mut nonzero = 0;
        for round in 0..3000 {
            let count = 1 + round % 8;
            let lights: Vec<LightBounds> = (0..count).map(|_| random_bounds(&mut s)).collect();
            let four = BoundsLanes::group(&lights);
            let eight = BoundsLanes8::pairs(&four);
            assert_eq!(eight.len(), 1);
            let p = Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) * 6.0 - 3.0;
            let n = (Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) - 0.5).normalize();
            for normal in [n, Vec3::ZERO] {
                // SAFETY: AVX2 was detected above.
                let got = unsafe { eight[0].importance(p, normal) };
                let want: Vec<f32> = four
                    .iter()
                    .flat_map(|g| g.importance(p, normal).to_array())
                    .chain(std::iter::repeat(0.0))
                    .take(8)
                    .collect();
                for k in 0..8 {
                    assert_eq!(got[k].to_bits(), want[k].to_bits(), "lane {k} of {count}");
                    nonzero += usize::from(got[k] > 0.0);
                }
            }
        }
        assert!(nonzero > 10_000, "only {nonzero} lights with importance");
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
