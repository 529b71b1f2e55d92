//! Fast approximations of libm functions for hot paths, each with an error
//! bound that its test checks.

use std::f32::consts::{FRAC_PI_2, PI};

use glam::Vec4;

/// Odd minimax-style polynomial for atan on [0, 1]: atan(t) ~ t P(t^2).
/// Fitted for this crate (iteratively reweighted least squares on
/// Chebyshev nodes), then rounded to f32.
const ATAN_COEFFS: [f32; 7] = [
    0.999_996_1,
    -0.333_173_7,
    0.198_078_16,
    -0.132_333_41,
    0.079_623_66,
    -0.033_604_21,
    0.006_811_791,
];

/// Largest absolute error of [`fast_atan2`] in radians, measured by its
/// test over 4 million directions (about 3.3e-7 from the polynomial plus
/// rounding of the quotient).
pub const FAST_ATAN2_MAX_ERROR: f32 = 6e-7;

/// atan2(y, x) to within [`FAST_ATAN2_MAX_ERROR`] radians, several times
/// faster than libm's `atan2f`. Unlike libm, atan2(+-0, -0) is +-0; NaN
/// input gives NaN, and two infinities give NaN.
#[inline]
pub fn fast_atan2(y: f32, x: f32) -> f32 {
    let (ax, ay) = (x.abs(), y.abs());
    let steep = ay > ax;
    let (num, den) = if steep { (ax, ay) } else { (ay, ax) };
    let t = if den > 0.0 { num / den } else { num };
    let t2 = t * t;
    let mut p = ATAN_COEFFS[6];
    for &c in ATAN_COEFFS[..6].iter().rev() {
        p = p * t2 + c;
    }
    let mut r = p * t;
    if steep {
        r = FRAC_PI_2 - r;
    }
    if x < 0.0 {
        r = PI - r;
    }
    if x.is_nan() {
        return f32::NAN;
    }
    r.copysign(y)
}

/// [`fast_atan2`] of four (y, x) pairs at once, one per SIMD lane: every
/// lane does the scalar routine's operations in its order (plain
/// multiplies and adds, correctly rounded divisions; the branches become
/// selects), so each lane is [`fast_atan2`] of its pair bit for bit
/// (tested), NaN included.
#[inline]
pub fn fast_atan2_lanes(y: Vec4, x: Vec4) -> Vec4 {
    let (ax, ay) = (x.abs(), y.abs());
    let steep = ay.cmpgt(ax);
    let num = Vec4::select(steep, ax, ay);
    let den = Vec4::select(steep, ay, ax);
    let t = Vec4::select(den.cmpgt(Vec4::ZERO), num / den, num);
    let t2 = t * t;
    let mut p = Vec4::splat(ATAN_COEFFS[6]);
    for &c in ATAN_COEFFS[..6].iter().rev() {
        p = p * t2 + Vec4::splat(c);
    }
    let mut r = p * t;
    r = Vec4::select(steep, Vec4::splat(FRAC_PI_2) - r, r);
    r = Vec4::select(x.cmplt(Vec4::ZERO), Vec4::splat(PI) - r, r);
    r = r.copysign(y);
    Vec4::select(x.is_nan_mask(), Vec4::NAN, r)
}

/// `f32::clamp(x, 0.0, 1.0)` in lanes, with its comparisons (NaN stays
/// NaN), so lane code that clamps is bit for bit its scalar twin.
#[inline]
pub fn clamp_unit_lanes(x: Vec4) -> Vec4 {
    let x = Vec4::select(x.cmplt(Vec4::ZERO), Vec4::ZERO, x);
    Vec4::select(x.cmpgt(Vec4::ONE), Vec4::ONE, x)
}

/// `if cond { a } else { b }` by bit masks, for choices that depend on
/// random numbers: LLVM compiles an `if` between two floats into a jump
/// (x86 has no conditional move for SSE registers), which such data
/// mispredicts one time in two (about 15-20 cycles each); the masks cost
/// three integer operations. On x86_64 the masks are applied in an SSE
/// register: LLVM recognises the masks on the floats' bits as a select
/// and compiled some of them back into the jump (the concentric disk's
/// angle, once per cosine-weighted BSDF sample), but keeps vector masks.
#[inline(always)]
pub fn select_bits(cond: bool, a: f32, b: f32) -> f32 {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: SSE2 is part of the x86_64 baseline.
    unsafe {
        use std::arch::x86_64::*;
        let m = _mm_castsi128_ps(_mm_set1_epi32(-(cond as i32)));
        _mm_cvtss_f32(_mm_or_ps(
            _mm_and_ps(m, _mm_set_ss(a)),
            _mm_andnot_ps(m, _mm_set_ss(b)),
        ))
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let m = 0u32.wrapping_sub(cond as u32);
        f32::from_bits((a.to_bits() & m) | (b.to_bits() & !m))
    }
}

/// Below this libm's `expf` underflows to zero (glibc: -0x1.9fe368p6);
/// a little under it, so every argument it refuses is libm's too.
const EXP_UNDERFLOW: f32 = -104.0;

/// `x.exp()` bit for bit, without libm's underflow path: glibc's `expf`
/// sends arguments below -103.97 to an out-of-line routine that sets
/// `errno` before it returns zero, and Gaussian tails (Beckmann's D and
/// its slopes at near-normal incidence) land there often (two percent of
/// Veach's render). NaN still gives NaN.
#[inline]
pub fn exp_or_zero(x: f32) -> f32 {
    if x < EXP_UNDERFLOW {
        0.0
    } else {
        x.exp()
    }
}

/// Bound on the absolute error of [`sin_cos_turns`], checked by its test
/// over 4 million angles (it measures 1.04e-7: the polynomials plus the
/// rounding of the reduced angle).
pub const SIN_COS_TURNS_MAX_ERROR: f32 = 2e-7;

/// (sin, cos) of `2 pi t`: the angle in turns, as samplers have it (a
/// uniform number, an azimuth fraction), within
/// [`SIN_COS_TURNS_MAX_ERROR`] and without a libm call or a branch. The
/// reduction to the nearest quarter turn is exact in floating point, so
/// only the polynomials on [-pi/4, pi/4] err: Cephes' single-precision
/// minimax coefficients (S. Moshier).
/// NaN gives NaN; the angle must be under 2^20 turns.
#[inline]
pub fn sin_cos_turns(t: f32) -> (f32, f32) {
    // Nearest integer to 4 t (ties to even) by the 1.5 * 2^23 trick, exact
    // for |t| < 2^20 (`f32::round` is a libm call on x86_64's baseline).
    const ROUNDER: f32 = 12_582_912.0;
    let q = (4.0 * t + ROUNDER) - ROUNDER;
    // t - q / 4 is exact: the two are within a factor 2 of each other, or
    // q is 0.
    let a = (t - 0.25 * q) * (2.0 * PI);
    let a2 = a * a;
    let s = a + a * a2 * (-1.666_665_5e-1 + a2 * (8.332_161e-3 + a2 * -1.951_529_6e-4));
    let c =
        1.0 - 0.5 * a2 + a2 * a2 * (4.166_664_6e-2 + a2 * (-1.388_731_6e-3 + a2 * 2.443_315_7e-5));
    rotate_quarter_turn(q as i32, s, c)
}

/// (sin, cos) of the reduced angle, whose sin is `s` and cos `c`, rotated
/// by `qi` quarter turns without branches (random angles would mispredict
/// them): odd `qi` swaps sin and cos, and the two's complement bits of
/// `qi` give the signs, for negative `qi` too.
#[inline(always)]
fn rotate_quarter_turn(qi: i32, s: f32, c: f32) -> (f32, f32) {
    let swap = qi & 1 != 0;
    let (x, y) = (select_bits(swap, c, s), select_bits(swap, s, c));
    let sin = f32::from_bits(x.to_bits() ^ (((qi & 2) as u32) << 30));
    let cos = f32::from_bits(y.to_bits() ^ ((((qi + 1) & 2) as u32) << 30));
    (sin, cos)
}

/// [`sin_cos_turns`] of four angles in lanes, each lane bit for bit the
/// scalar routine's (tested): the same operations in the same order, the
/// quarter-turn rotation by integer masks.
#[inline]
pub fn sin_cos_turns_lanes(t: Vec4) -> (Vec4, Vec4) {
    const ROUNDER: f32 = 12_582_912.0;
    let q = (t * 4.0 + Vec4::splat(ROUNDER)) - Vec4::splat(ROUNDER);
    let a = (t - q * 0.25) * (2.0 * PI);
    let a2 = a * a;
    let s = a + a
        * a2
        * (Vec4::splat(-1.666_665_5e-1) + a2 * (Vec4::splat(8.332_161e-3) + a2 * -1.951_529_6e-4));
    let c = Vec4::ONE - a2 * 0.5
        + a2 * a2
            * (Vec4::splat(4.166_664_6e-2)
                + a2 * (Vec4::splat(-1.388_731_6e-3) + a2 * 2.443_315_7e-5));
    rotate_quarter_turns(q, s, c)
}

/// [`rotate_quarter_turn`] in lanes: `q` holds whole numbers, |q| < 2^22.
#[inline(always)]
fn rotate_quarter_turns(q: Vec4, s: Vec4, c: Vec4) -> (Vec4, Vec4) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: SSE2 is part of the x86_64 baseline.
    unsafe {
        use std::arch::x86_64::*;
        // Truncation is exact on whole numbers; NaN gives i32::MIN, whose
        // low two bits are those of the scalar routine's 0.
        let qi = _mm_cvttps_epi32(q.into());
        let one = _mm_set1_epi32(1);
        let two = _mm_set1_epi32(2);
        let swap = _mm_castsi128_ps(_mm_cmpeq_epi32(_mm_and_si128(qi, one), one));
        let (s, c): (__m128, __m128) = (s.into(), c.into());
        let x = _mm_or_ps(_mm_and_ps(swap, c), _mm_andnot_ps(swap, s));
        let y = _mm_or_ps(_mm_and_ps(swap, s), _mm_andnot_ps(swap, c));
        let sin_sign = _mm_slli_epi32::<30>(_mm_and_si128(qi, two));
        let cos_sign = _mm_slli_epi32::<30>(_mm_and_si128(_mm_add_epi32(qi, one), two));
        (
            _mm_xor_ps(x, _mm_castsi128_ps(sin_sign)).into(),
            _mm_xor_ps(y, _mm_castsi128_ps(cos_sign)).into(),
        )
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let r: [(f32, f32); 4] =
            std::array::from_fn(|k| rotate_quarter_turn(q[k] as i32, s[k], c[k]));
        (
            Vec4::from_array(r.map(|r| r.0)),
            Vec4::from_array(r.map(|r| r.1)),
        )
    }
}

/// Largest relative error of [`exp4`] on [-87, 88], measured by its test
/// against f64 `exp` (Cephes' polynomial: about 1.5 ulp).
pub const EXP4_MAX_RELATIVE_ERROR: f32 = 2.5e-7;

/// e^x in four lanes at once, within [`EXP4_MAX_RELATIVE_ERROR`] on [-87,
/// 88]; 0 below -87 (where libm's `expf` gives subnormals), e^88 above 88.
/// Plain multiplies and adds (no fused multiply-add, SSE2 through glam), so
/// every lane and every CPU rounds alike: a scalar caller takes one lane
/// and gets the bits a four-lane caller gets (the film's Gaussian weights
/// rely on it). Cody and Waite's reduction by ln 2 in two parts, then
/// Cephes' `expf` polynomial on [-ln 2 / 2, ln 2 / 2].
#[inline(always)]
pub fn exp4(x: glam::Vec4) -> glam::Vec4 {
    use glam::Vec4;
    const LN2_HI: f32 = 0.693_359_4;
    const LN2_LO: f32 = -2.121_944_4e-4;
    let below = x.cmplt(Vec4::splat(-87.0));
    let x = x.clamp(Vec4::splat(-87.0), Vec4::splat(88.0));
    let (n, two_to_n) = floor_and_pow2(x * std::f32::consts::LOG2_E + 0.5);
    let r = x - n * LN2_HI - n * LN2_LO;
    let p = ((((1.987_569_1e-4 * r + 1.398_199_9e-3) * r + 8.333_452e-3) * r + 4.166_579_6e-2) * r
        + 0.166_666_65)
        * r
        + 0.5;
    let y = p * (r * r) + r + 1.0;
    Vec4::select(below, Vec4::ZERO, y * two_to_n)
}

/// [`exp4`] in eight AVX lanes: the same operations in the same order
/// (no fused multiply-add), so every lane has the bits `exp4` gives it
/// (tested). The film's Gaussian splat takes its x and y weights from one
/// call.
///
/// # Safety
/// Call only where the CPU has AVX2.
#[cfg(target_arch = "x86_64")]
#[inline]
#[target_feature(enable = "avx2")]
pub fn exp8(x: std::arch::x86_64::__m256) -> std::arch::x86_64::__m256 {
    use std::arch::x86_64::*;
    const LN2_HI: f32 = 0.693_359_4;
    const LN2_LO: f32 = -2.121_944_4e-4;
    let (add, sub, mul, c) = (_mm256_add_ps, _mm256_sub_ps, _mm256_mul_ps, _mm256_set1_ps);
    let below = _mm256_cmp_ps::<_CMP_LT_OQ>(x, c(-87.0));
    // glam's clamp: max with the low end, then min with the high end.
    let x = _mm256_min_ps(_mm256_max_ps(x, c(-87.0)), c(88.0));
    let v = add(mul(x, c(std::f32::consts::LOG2_E)), c(0.5));
    // floor_and_pow2, in eight lanes.
    let t = _mm256_cvttps_epi32(v);
    let rounded_up = _mm256_castps_si256(_mm256_cmp_ps::<_CMP_GT_OQ>(_mm256_cvtepi32_ps(t), v));
    let i = _mm256_add_epi32(t, rounded_up);
    let two_to_n = _mm256_castsi256_ps(_mm256_slli_epi32::<23>(_mm256_add_epi32(
        i,
        _mm256_set1_epi32(127),
    )));
    let n = _mm256_cvtepi32_ps(i);
    let r = sub(sub(x, mul(n, c(LN2_HI))), mul(n, c(LN2_LO)));
    let mut p = add(mul(c(1.987_569_1e-4), r), c(1.398_199_9e-3));
    p = add(mul(p, r), c(8.333_452e-3));
    p = add(mul(p, r), c(4.166_579_6e-2));
    p = add(mul(p, r), c(0.166_666_65));
    p = add(mul(p, r), c(0.5));
    let y = add(add(mul(p, mul(r, r)), r), c(1.0));
    _mm256_blendv_ps(mul(y, two_to_n), _mm256_setzero_ps(), below)
}

/// floor(v) and 2^floor(v) for v in [-126, 128) (what `exp4`'s clamp
/// leaves), from the exponent bits. On x86_64 the floor and the exponent
/// come from one conversion of the four lanes, where glam's floor (SSE2
/// has no rounding instruction) and `as i32` lane by lane with its
/// saturation checks were a fifth of the film's Gaussian splat; the same
/// bits (tested).
#[inline(always)]
fn floor_and_pow2(v: glam::Vec4) -> (glam::Vec4, glam::Vec4) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: SSE2 is part of the x86_64 baseline.
    unsafe {
        use std::arch::x86_64::*;
        let v: __m128 = v.into();
        // Truncation, then one less where it rounded up (negative v).
        let t = _mm_cvttps_epi32(v);
        let rounded_up = _mm_castps_si128(_mm_cmpgt_ps(_mm_cvtepi32_ps(t), v));
        let i = _mm_add_epi32(t, rounded_up);
        let bits = _mm_slli_epi32::<23>(_mm_add_epi32(i, _mm_set1_epi32(127)));
        (_mm_cvtepi32_ps(i).into(), _mm_castsi128_ps(bits).into())
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let n = v.floor();
        let pow2 = n
            .to_array()
            .map(|n| f32::from_bits(((n as i32 + 127) as u32) << 23));
        (n, glam::Vec4::from_array(pow2))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exp_or_zero_is_exp_bit_for_bit() {
        // Every float from -120 to 0 in steps of a few ulps, the threshold's
        // neighbours, and the special values.
        let mut x = -120.0f32;
        let mut tested = 0;
        while x < 0.0 {
            assert_eq!(exp_or_zero(x).to_bits(), x.exp().to_bits(), "{x}");
            x = f32::from_bits(x.to_bits() - 997);
            tested += 1;
        }
        assert!(tested > 1_000_000, "{tested}");
        let edge = EXP_UNDERFLOW;
        for y in [
            f32::from_bits(edge.to_bits() + 1),
            edge,
            f32::from_bits(edge.to_bits() - 1),
        ] {
            assert_eq!(exp_or_zero(y).to_bits(), y.exp().to_bits(), "{y}");
        }
        for y in [f32::NEG_INFINITY, f32::INFINITY, -1e30, 80.0, 100.0, -0.0] {
            assert_eq!(exp_or_zero(y).to_bits(), y.exp().to_bits(), "{y}");
        }
        assert!(exp_or_zero(f32::NAN).is_nan());
    }

    #[test]
    fn atan2_lanes_are_the_scalar_atan2_bit_for_bit() {
        let special = [
            0.0f32,
            -0.0,
            1.0,
            -1.0,
            1e-30,
            -3e-39,
            7e25,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            f32::MIN_POSITIVE,
        ];
        let mut pairs: Vec<(f32, f32)> = special
            .iter()
            .flat_map(|&y| special.iter().map(move |&x| (y, x)))
            .collect();
        let mut s = crate::sampling::Sampler::new(7, 3);
        for _ in 0..100_000 {
            let (a, b) = (s.next_1d() * 4.0 - 2.0, s.next_1d() * 4.0 - 2.0);
            // Equal magnitudes too (the steep / flat boundary).
            pairs.push((a, b));
            pairs.push((a, if b < 0.0 { -a.abs() } else { a.abs() }));
        }
        for four in pairs.chunks_exact(4) {
            let y = Vec4::from_array(std::array::from_fn(|k| four[k].0));
            let x = Vec4::from_array(std::array::from_fn(|k| four[k].1));
            let lanes = fast_atan2_lanes(y, x).to_array();
            for (k, &(y, x)) in four.iter().enumerate() {
                let scalar = fast_atan2(y, x);
                assert_eq!(lanes[k].to_bits(), scalar.to_bits(), "atan2({y}, {x})");
            }
        }
    }

    #[test]
    fn atan2_within_its_bound_everywhere() {
        let n = 4_000_000u32;
        let mut worst = 0.0f64;
        for k in 0..n {
            let a = (k as f64 + 0.5) / n as f64 * 2.0 * std::f64::consts::PI;
            let (y, x) = (a.sin() as f32, a.cos() as f32);
            let err = (fast_atan2(y, x) as f64 - (y as f64).atan2(x as f64)).abs();
            worst = worst.max(err);
            // Scale does not matter.
            let e2 = (fast_atan2(y * 1e-20, x * 1e-20) as f64 - (y as f64).atan2(x as f64)).abs();
            worst = worst.max(e2);
        }
        eprintln!("fast_atan2 worst error {worst:e} rad");
        assert!(worst < FAST_ATAN2_MAX_ERROR as f64, "{worst}");
        // And the bound is not slack by orders of magnitude (a test that
        // could not fail): the polynomial's own error shows.
        assert!(worst > 1e-7, "{worst}");
    }

    #[test]
    fn atan2_axes_zeros_and_nan() {
        assert_eq!(fast_atan2(0.0, 1.0), 0.0);
        assert!((fast_atan2(1.0, 0.0) - FRAC_PI_2).abs() < 1e-7);
        assert!((fast_atan2(-1.0, 0.0) + FRAC_PI_2).abs() < 1e-7);
        assert!((fast_atan2(0.0, -1.0) - PI).abs() < 1e-7);
        assert!((fast_atan2(-0.0, -1.0) + PI).abs() < 1e-7);
        assert_eq!(fast_atan2(0.0, 0.0), 0.0);
        assert!(fast_atan2(f32::NAN, 1.0).is_nan());
        assert!(fast_atan2(1.0, f32::NAN).is_nan());
        assert!((fast_atan2(1e30, 1e30) - PI / 4.0).abs() < 1e-6);
        assert!((fast_atan2(f32::INFINITY, 1.0) - FRAC_PI_2).abs() < 1e-6);
        assert!(fast_atan2(f32::INFINITY, f32::INFINITY).is_nan());
    }

    /// The lanes give the scalar bits on a grid over [-2, 2] turns, the
    /// quarter-turn boundaries and their neighbours, zeros and NaN.
    #[test]
    fn sin_cos_turns_lanes_are_the_scalar_bit_for_bit() {
        let mut ts: Vec<f32> = (-80_000..=80_000).map(|i| i as f32 / 40_000.0).collect();
        for k in -8..=8 {
            let b = k as f32 * 0.125;
            ts.extend([b, b.next_up(), b.next_down()]);
        }
        ts.extend([0.0, -0.0, f32::NAN, 1.0 - f32::EPSILON, 0.5 - 1e-9]);
        while !ts.len().is_multiple_of(4) {
            ts.push(0.3);
        }
        for four in ts.chunks_exact(4) {
            let (s, c) = sin_cos_turns_lanes(Vec4::from_slice(four));
            for (k, &t) in four.iter().enumerate() {
                let (ws, wc) = sin_cos_turns(t);
                assert_eq!(s[k].to_bits(), ws.to_bits(), "sin of {t} turns");
                assert_eq!(c[k].to_bits(), wc.to_bits(), "cos of {t} turns");
            }
        }
    }

    #[test]
    fn sin_cos_turns_within_its_bound() {
        let n = 4_000_000u32;
        let mut worst = 0.0f64;
        for k in 0..=n {
            // Turns over [-1.5, 2.5]: negative angles, several quadrants of
            // each sign, and the ends of [0, 1] where samplers work.
            let t = (-1.5 + 4.0 * k as f64 / n as f64) as f32;
            let (s, c) = sin_cos_turns(t);
            let a = 2.0 * std::f64::consts::PI * t as f64;
            worst = worst.max((s as f64 - a.sin()).abs());
            worst = worst.max((c as f64 - a.cos()).abs());
        }
        eprintln!("sin_cos_turns worst error {worst:e}");
        assert!(worst < SIN_COS_TURNS_MAX_ERROR as f64, "{worst}");
        assert!(worst > 1e-8, "the bound is slack: {worst}");
        // Quarter turns are exact; NaN propagates.
        assert_eq!(sin_cos_turns(0.0), (0.0, 1.0));
        assert_eq!(sin_cos_turns(0.25), (1.0, 0.0));
        assert_eq!(sin_cos_turns(0.5), (-0.0, -1.0));
        assert_eq!(sin_cos_turns(-0.25), (-1.0, 0.0));
        let (s, c) = sin_cos_turns(f32::NAN);
        assert!(s.is_nan() && c.is_nan());
    }

    /// The four-lane floor and 2^floor are `f32::floor` and the
    /// lane-by-lane exponent bit for bit, over [-126, 128) in steps of
    /// 1/64 (whole numbers, halves and their neighbours included).
    #[test]
    fn floor_and_pow2_are_floor_and_the_lane_by_lane_exponent() {
        let mut values = Vec::new();
        for k in -126 * 64..128 * 64 {
            let v = k as f32 / 64.0;
            values.extend([v, v.next_up(), v.next_down()]);
        }
        values.retain(|v| (-126.0..128.0).contains(v));
        for chunk in values.chunks(4) {
            let mut a = [0.5f32; 4];
            a[..chunk.len()].copy_from_slice(chunk);
            let (n, p) = super::floor_and_pow2(glam::Vec4::from_array(a));
            for k in 0..4 {
                let want = a[k].floor();
                let pow = f32::from_bits(((want as i32 + 127) as u32) << 23);
                assert_eq!(n[k].to_bits(), want.to_bits(), "floor({})", a[k]);
                assert_eq!(p[k].to_bits(), pow.to_bits(), "2^floor({})", a[k]);
            }
        }
    }

    /// exp8's lanes against exp4's, bit for bit, over the range and past
    /// both ends (infinities and NaN included).
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn exp8_lanes_are_exp4_bit_for_bit() {
        if !std::arch::is_x86_feature_detected!("avx2") {
            return;
        }
        let special = [
            -1e30f32,
            -87.01,
            -87.0,
            88.0,
            88.5,
            1e30,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            0.0,
            -0.0,
        ];
        let n = 400_000;
        let xs: Vec<f32> = (0..=n)
            .map(|i| -100.0 + 200.0 * i as f32 / n as f32)
            .chain(special)
            .collect();
        for chunk in xs.chunks(8) {
            let mut lanes = [0.0f32; 8];
            lanes[..chunk.len()].copy_from_slice(chunk);
            // SAFETY: AVX2 was detected above; the loads and stores are of
            // 8-float arrays.
            let got: [f32; 8] = unsafe {
                use std::arch::x86_64::*;
                let mut out = [0.0f32; 8];
                _mm256_storeu_ps(
                    out.as_mut_ptr(),
                    super::exp8(_mm256_loadu_ps(lanes.as_ptr())),
                );
                out
            };
            for (k, &x) in lanes.iter().enumerate() {
                let want = super::exp4(glam::Vec4::splat(x)).x;
                assert_eq!(got[k].to_bits(), want.to_bits(), "exp8({x})");
            }
        }
    }

    /// exp4 against f64 exp: relative error within its bound on [-87, 88]
    /// (a million points, and the ends), 0 below -87, and the four lanes
    /// of one call equal to four one-lane calls.
    #[test]
    fn exp4_is_within_its_bound() {
        let mut worst = 0.0f64;
        let n = 1_000_000;
        for i in 0..=n {
            let x = -87.0 + 175.0 * i as f32 / n as f32;
            let x = x.min(88.0);
            let got = super::exp4(glam::Vec4::splat(x)).x as f64;
            let want = (x as f64).exp();
            worst = worst.max(((got - want) / want).abs());
        }
        assert!(worst <= super::EXP4_MAX_RELATIVE_ERROR as f64, "{worst}");
        assert!(
            worst > 0.25 * super::EXP4_MAX_RELATIVE_ERROR as f64,
            "bound loose: {worst}"
        );
        for x in [-87.01f32, -100.0, -1e30, f32::NEG_INFINITY] {
            assert_eq!(super::exp4(glam::Vec4::splat(x)).x, 0.0, "{x}");
        }
        assert_eq!(super::exp4(glam::Vec4::ZERO).x, 1.0);
        let xs = glam::Vec4::new(-0.3, -7.9, -2.0, -0.01);
        let four = super::exp4(xs).to_array();
        for (k, &x) in xs.to_array().iter().enumerate() {
            assert_eq!(
                four[k].to_bits(),
                super::exp4(glam::Vec4::splat(x)).x.to_bits()
            );
        }
    }
}
