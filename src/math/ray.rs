//! Rays and robust ray origins.

use super::Vec3;

/// A ray `o + t d` valid for `t` in `[tmin, tmax]`. Laid out as eight
/// floats in this order (`o`, `d`, `tmin`, `tmax`), so eight rays are an
/// 8 x 8 matrix that `RayPacket::new` transposes in AVX2 registers.
#[derive(Clone, Copy, Debug)]
#[repr(C)]
pub struct Ray {
    pub o: Vec3,
    pub d: Vec3,
    pub tmin: f32,
    pub tmax: f32,
}

impl Ray {
    pub fn new(o: Vec3, d: Vec3) -> Ray {
        Ray {
            o,
            d,
            tmin: 0.0,
            tmax: f32::INFINITY,
        }
    }

    pub fn with_range(o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> Ray {
        Ray { o, d, tmin, tmax }
    }

    pub fn at(&self, t: f32) -> Vec3 {
        self.o + t * self.d
    }
}

/// gamma(n) of Higham's floating-point error analysis: a bound on the
/// relative error of n chained f32 operations.
pub const fn gamma(n: i32) -> f32 {
    let e = f32::EPSILON * 0.5 * n as f32;
    e / (1.0 - e)
}

/// Moves a surface point off its surface, towards the side `w` points to,
/// by just more than its floating-point error bound `err` projected on the
/// normal `n`, then one ulp further away (pbrt's spawned-ray origins). No
/// scene-dependent epsilon: points far from the origin or on huge
/// triangles get proportionally larger offsets, tiny ones tiny offsets.
pub fn offset_ray_origin(p: Vec3, err: Vec3, n: Vec3, w: Vec3) -> Vec3 {
    #[cfg(target_arch = "x86_64")]
    {
        // SAFETY: SSE2 is part of x86-64.
        unsafe { offset_ray_origin_sse2(p, err, n, w) }
    }
    #[cfg(not(target_arch = "x86_64"))]
    offset_ray_origin_scalar(p, err, n, w)
}

/// [`offset_ray_origin`] a component at a time (the reference the SSE2
/// version is tested against).
#[cfg_attr(target_arch = "x86_64", allow(dead_code))]
fn offset_ray_origin_scalar(p: Vec3, err: Vec3, n: Vec3, w: Vec3) -> Vec3 {
    let d = n.abs().dot(err);
    let mut offset = d * n;
    if w.dot(n) < 0.0 {
        offset = -offset;
    }
    step_away_scalar(p + offset, offset)
}

/// [`offset_ray_origin`] in four SSE2 lanes, its vectors loaded once and
/// kept in registers to the end: the same operations in the same order as
/// the scalar form (the dot products summed x + y, then + z, as glam's),
/// so the same bits (tested). Every spawned ray runs it, and every light
/// sample's far end: the scalar form (about 65 instructions) moved each
/// vector between scalar and vector registers three times; this one takes
/// 0.2% to 0.9% off the speed suite's instructions (callgrind).
#[cfg(target_arch = "x86_64")]
#[inline]
unsafe fn offset_ray_origin_sse2(p: Vec3, err: Vec3, n: Vec3, w: Vec3) -> Vec3 {
    use std::arch::x86_64::*;
    // (glam's `Vec3A` is an `__m128`; its fourth lane, which no result
    // reads, repeats z.)
    let lanes = |v: Vec3| __m128::from(glam::Vec3A::from(v));
    let (p4, err4, n4, w4) = (lanes(p), lanes(err), lanes(n), lanes(w));
    // x + y, then + z, in lane 0.
    let sum3 = |a: __m128| {
        let xy = _mm_add_ss(a, _mm_shuffle_ps::<0b01>(a, a));
        _mm_add_ss(xy, _mm_movehl_ps(a, a))
    };
    let abs = _mm_castsi128_ps(_mm_set1_epi32(0x7fff_ffff));
    let d = sum3(_mm_mul_ps(_mm_and_ps(n4, abs), err4));
    let toward = sum3(_mm_mul_ps(w4, n4));
    // -0.0 in every lane where `w` is on the other side (not for NaN).
    let behind = _mm_and_ps(_mm_cmplt_ss(toward, _mm_setzero_ps()), _mm_set_ss(-0.0));
    let offset = _mm_xor_ps(
        _mm_mul_ps(_mm_shuffle_ps::<0>(d, d), n4),
        _mm_shuffle_ps::<0>(behind, behind),
    );
    let r = step_away_lanes(_mm_add_ps(p4, offset), offset);
    Vec3::from(glam::Vec3A::from(r))
}

/// [`step_away_lanes`] on vectors (what the tests compare with
/// [`step_away_scalar`]).
#[cfg(test)]
fn step_away(v: Vec3, o: Vec3) -> Vec3 {
    #[cfg(target_arch = "x86_64")]
    {
        let lanes = |v: Vec3| glam::Vec3A::from(v).into();
        // SAFETY: SSE2 is part of x86-64.
        let r = unsafe { step_away_lanes(lanes(v), lanes(o)) };
        Vec3::from(glam::Vec3A::from(r))
    }
    #[cfg(not(target_arch = "x86_64"))]
    step_away_scalar(v, o)
}

/// Each component of `v` one ulp further in the direction of the sign of
/// the same component of `o` (unchanged where it is zero), with std's
/// `next_up` and `next_down` (the reference the SIMD version is tested
/// against).
fn step_away_scalar(v: Vec3, o: Vec3) -> Vec3 {
    let away = |v: f32, o: f32| {
        if o > 0.0 {
            v.next_up()
        } else if o < 0.0 {
            v.next_down()
        } else {
            v
        }
    };
    Vec3::new(away(v.x, o.x), away(v.y, o.y), away(v.z, o.z))
}

/// [`step_away_scalar`] in four SSE2 lanes, without branches (which way each
/// axis steps is random): `next_down(v) = -next_up(-v)`, and `next_up`
/// of a finite or -inf `w` is its bit pattern plus one (w >= 0, -0 taken
/// as +0) or minus one (w < 0). +inf and NaN stay as they are, as in std.
/// Bit for bit std's result (tested), at a third of the instructions of
/// three scalar `next_up`/`next_down` calls with their branches.
#[cfg(target_arch = "x86_64")]
#[inline]
unsafe fn step_away_lanes(
    v4: std::arch::x86_64::__m128,
    o4: std::arch::x86_64::__m128,
) -> std::arch::x86_64::__m128 {
    use std::arch::x86_64::*;
    let zero = _mm_setzero_ps();
    let down = _mm_cmplt_ps(o4, zero);
    let still = _mm_cmpeq_ps(o4, zero);
    // Negated where stepping down; -0 + 0 is +0 (round to nearest).
    let flip = _mm_and_ps(down, _mm_set1_ps(-0.0));
    let w = _mm_add_ps(_mm_xor_ps(v4, flip), zero);
    let negative = _mm_castps_si128(_mm_cmplt_ps(w, zero));
    let step = _mm_or_si128(negative, _mm_set1_epi32(1));
    let stepped = _mm_xor_ps(
        _mm_castsi128_ps(_mm_add_epi32(_mm_castps_si128(w), step)),
        flip,
    );
    // Lanes that keep v: no step (o is 0 or NaN: neither above nor below
    // zero), or w is +inf or NaN.
    let unordered_o = _mm_cmpunord_ps(o4, o4);
    let top = _mm_or_ps(
        _mm_cmpeq_ps(w, _mm_set1_ps(f32::INFINITY)),
        _mm_cmpunord_ps(w, w),
    );
    let keep = _mm_or_ps(_mm_or_ps(still, unordered_o), top);
    _mm_or_ps(_mm_and_ps(keep, v4), _mm_andnot_ps(keep, stepped))
}

/// Error bound of a point computed as b0 p0 + b1 p1 + b2 p2.
pub fn barycentric_error(b0: f32, b1: f32, b2: f32, p0: Vec3, p1: Vec3, p2: Vec3) -> Vec3 {
    ((b0 * p0).abs() + (b1 * p1).abs() + (b2 * p2).abs()) * gamma(7)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The SIMD step equals std's `next_up`/`next_down` bit for bit on
    /// zeros of both signs, subnormals, the largest finite values,
    /// infinities, NaN and a spread of ordinary values, for every sign of
    /// the step (NaN steps included).
    #[test]
    fn step_away_is_next_up_and_next_down() {
        let mut values = vec![
            0.0,
            -0.0,
            f32::from_bits(1),
            -f32::from_bits(1),
            f32::MIN_POSITIVE,
            -f32::MIN_POSITIVE,
            f32::MAX,
            f32::MIN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            1.0,
            -1.0,
        ];
        // Random bit patterns (every exponent, both signs, NaNs among them).
        values.extend((0..20_000u64).map(|i| f32::from_bits(crate::sampling::mix64(i) as u32)));
        let steps = [1.0, -1.0, 0.0, -0.0, 1e-30, -1e-30, f32::NAN];
        let mut compared = 0;
        for chunk in values.chunks(3) {
            if chunk.len() < 3 {
                continue;
            }
            let v = Vec3::new(chunk[0], chunk[1], chunk[2]);
            for (i, &a) in steps.iter().enumerate() {
                let b = steps[(i + 3) % steps.len()];
                let c = steps[(i + 5) % steps.len()];
                let o = Vec3::new(a, b, c);
                let (got, want) = (step_away(v, o), step_away_scalar(v, o));
                assert_eq!(
                    got.to_array().map(f32::to_bits),
                    want.to_array().map(f32::to_bits),
                    "{v:?} stepped by {o:?}"
                );
                compared += 1;
            }
        }
        assert!(compared > 40_000);
    }

    /// The SSE2 offset equals the scalar one bit for bit (NaN for NaN) on
    /// random points, error bounds, normals and directions, special values
    /// among them: every sign of `w . n`, zero and infinite components.
    #[test]
    fn offset_ray_origin_is_the_scalar_offset() {
        let specials = [
            0.0,
            -0.0,
            f32::INFINITY,
            -f32::INFINITY,
            f32::NAN,
            1e-30,
            -1e-30,
        ];
        let pick = |i: u64, k: u64| {
            let r = crate::sampling::mix64(i * 16 + k);
            match r % 8 {
                0 => specials[(r >> 8) as usize % specials.len()],
                1 => f32::from_bits((r >> 16) as u32),
                _ => ((r >> 11) as f64 / (1u64 << 53) as f64 * 20.0 - 10.0) as f32,
            }
        };
        let mut compared = 0;
        for i in 0..50_000u64 {
            let v = |k: u64| Vec3::new(pick(i, k), pick(i, k + 1), pick(i, k + 2));
            let (p, err, n, w) = (v(0), v(3).abs() * 1e-4, v(6), v(9));
            let got = offset_ray_origin(p, err, n, w).to_array();
            let want = offset_ray_origin_scalar(p, err, n, w).to_array();
            for (g, e) in got.iter().zip(&want) {
                assert!(
                    g.to_bits() == e.to_bits() || (g.is_nan() && e.is_nan()),
                    "{p:?} {err:?} {n:?} {w:?}: {got:?} against {want:?}"
                );
            }
            compared += usize::from(got.iter().all(|c| c.is_finite()));
        }
        assert!(compared > 10_000, "{compared} finite offsets");
    }
}
