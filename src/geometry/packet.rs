//! Eight rays at once in AVX2 lanes, for scenes small enough that rays
//! which have nothing in common still visit the same few nodes and leaves
//! (issue 15: a Cornell box's 31 primitives, a cube on a ground's 13).
//! One primitive is tested against all eight rays with one sequence of
//! vector operations, where a ray alone tests it with three lanes of four.
//!
//! Each shape's lane test ([`super::triangle::intersect_triangle_lanes`],
//! `Sphere::intersect_lanes`, `PlaneFrame::hit_lanes`) does its scalar
//! test's operations in the same order, so a lane's hit is the scalar
//! test's bit for bit (tested in `bvh.rs`).
//!
//! Everything here runs only inside functions compiled for AVX2, which are
//! called only after the CPU was seen to support it.

use std::arch::x86_64::*;

use crate::math::{Ray, Vec3};

/// Lanes in a packet.
pub const LANES: usize = super::bvh::PACKET_LANES;

/// Up to eight rays, by coordinate (lane `i` of every row is ray `i`), with
/// what the slab and triangle tests precompute per ray. Lanes beyond the
/// rays given repeat the first ray and are left out of `live`.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub struct RayPacket<'a> {
    pub o: [[f32; LANES]; 3],
    pub d: [[f32; LANES]; 3],
    /// The reciprocal direction.
    pub inv: [[f32; LANES]; 3],
    /// All ones where the direction is negative along the axis (its sign
    /// bit, -0 included): the slab test meets the far plane first there.
    pub neg: [[u32; LANES]; 3],
    pub tmin: [f32; LANES],
    pub tmax: [f32; LANES],
    /// The rows of each ray's triangle shear
    /// ([`RayShear::rows`](super::triangle::RayShear::rows)): row `3 r + c`
    /// is component `c` of row `r`.
    pub shear: [[f32; LANES]; 9],
    /// The rays, for the primitives tested one ray at a time.
    pub rays: &'a [Ray],
    /// Bit `i` set: lane `i` carries a ray.
    pub live: u32,
}

impl<'a> RayPacket<'a> {
    /// The packet of `rays` (1 to [`LANES`] of them). The shears are
    /// [`RayShear::new`](super::triangle::RayShear::new)'s, computed in
    /// lanes (its axis choice by masks, not by the jumps that a ray's
    /// random direction mispredicts).
    #[inline]
    #[target_feature(enable = "avx2")]
    pub fn new(rays: &'a [Ray]) -> RayPacket<'a> {
        assert!(!rays.is_empty() && rays.len() <= LANES);
        // Ray k's eight floats (o, d, tmin, tmax: `Ray` is repr(C)) as row
        // k of a matrix, transposed so that row j holds field j of every
        // ray.
        const _: () = assert!(std::mem::size_of::<Ray>() == 32);
        let load = |lane: usize| {
            let ray = rays.get(lane).unwrap_or(&rays[0]);
            // SAFETY: a `Ray` is eight contiguous floats.
            unsafe { _mm256_loadu_ps((ray as *const Ray).cast()) }
        };
        let r: [__m256; LANES] = std::array::from_fn(load);
        let cols = transpose8(r);
        let store = |x: __m256| {
            let mut row = [0.0f32; LANES];
            // SAFETY: `row` holds eight floats.
            unsafe { _mm256_storeu_ps(row.as_mut_ptr(), x) };
            row
        };
        let rows = cols.map(store);
        let d = [cols[3], cols[4], cols[5]];
        let one = _mm256_set1_ps(1.0);
        let inv = d.map(|c| store(_mm256_div_ps(one, c)));
        let neg = d.map(|c| {
            let sign = _mm256_srai_epi32::<31>(_mm256_castps_si256(c));
            let mut row = [0u32; LANES];
            // SAFETY: `row` holds eight integers.
            unsafe { _mm256_storeu_si256(row.as_mut_ptr().cast(), sign) };
            row
        });
        let shear = shear_lanes(d).map(store);
        RayPacket {
            o: [rows[0], rows[1], rows[2]],
            d: [rows[3], rows[4], rows[5]],
            inv,
            neg,
            tmin: rows[6],
            tmax: rows[7],
            shear,
            rays,
            live: (1u32 << rays.len()) - 1,
        }
    }
}

/// The transpose of an 8 x 8 matrix of floats held by rows: unpacks
/// within 128-bit halves, then across them.
#[inline]
#[target_feature(enable = "avx2")]
fn transpose8(r: [__m256; LANES]) -> [__m256; LANES] {
    let t = [
        _mm256_unpacklo_ps(r[0], r[1]),
        _mm256_unpackhi_ps(r[0], r[1]),
        _mm256_unpacklo_ps(r[2], r[3]),
        _mm256_unpackhi_ps(r[2], r[3]),
        _mm256_unpacklo_ps(r[4], r[5]),
        _mm256_unpackhi_ps(r[4], r[5]),
        _mm256_unpacklo_ps(r[6], r[7]),
        _mm256_unpackhi_ps(r[6], r[7]),
    ];
    let q = [
        _mm256_shuffle_ps::<0x44>(t[0], t[2]),
        _mm256_shuffle_ps::<0xEE>(t[0], t[2]),
        _mm256_shuffle_ps::<0x44>(t[1], t[3]),
        _mm256_shuffle_ps::<0xEE>(t[1], t[3]),
        _mm256_shuffle_ps::<0x44>(t[4], t[6]),
        _mm256_shuffle_ps::<0xEE>(t[4], t[6]),
        _mm256_shuffle_ps::<0x44>(t[5], t[7]),
        _mm256_shuffle_ps::<0xEE>(t[5], t[7]),
    ];
    [
        _mm256_permute2f128_ps::<0x20>(q[0], q[4]),
        _mm256_permute2f128_ps::<0x20>(q[1], q[5]),
        _mm256_permute2f128_ps::<0x20>(q[2], q[6]),
        _mm256_permute2f128_ps::<0x20>(q[3], q[7]),
        _mm256_permute2f128_ps::<0x31>(q[0], q[4]),
        _mm256_permute2f128_ps::<0x31>(q[1], q[5]),
        _mm256_permute2f128_ps::<0x31>(q[2], q[6]),
        _mm256_permute2f128_ps::<0x31>(q[3], q[7]),
    ]
}

/// [`RayShear::new`](super::triangle::RayShear::new)'s rows for eight
/// directions, by its operations: the dominant axis kz (ties as its
/// comparisons break them), kx and ky after it (swapped where d[kz] < 0),
/// then `e_kx - e_kz sx`, `e_ky - e_kz sy` and `e_kz sz` with the unit
/// vectors as 0/1 lanes.
#[inline]
#[target_feature(enable = "avx2")]
fn shear_lanes(d: [__m256; 3]) -> [__m256; 9] {
    let (and, or, andnot) = (_mm256_and_ps, _mm256_or_ps, _mm256_andnot_ps);
    let a = d.map(|c| abs(c));
    let x_over_y = _mm256_cmp_ps::<_CMP_GT_OQ>(a[0], a[1]);
    let k0 = and(x_over_y, _mm256_cmp_ps::<_CMP_GT_OQ>(a[0], a[2]));
    let k1 = andnot(x_over_y, _mm256_cmp_ps::<_CMP_GT_OQ>(a[1], a[2]));
    let k2 = andnot(or(k0, k1), _mm256_castsi256_ps(_mm256_set1_epi32(-1)));
    let dz = _mm256_blendv_ps(_mm256_blendv_ps(d[2], d[1], k1), d[0], k0);
    let flip = _mm256_cmp_ps::<_CMP_LT_OQ>(dz, _mm256_setzero_ps());
    let sel = |kept, swapped| or(andnot(flip, kept), and(flip, swapped));
    // kz = 0: (kx, ky) = (1, 2); kz = 1: (2, 0); kz = 2: (0, 1).
    let ex = [sel(k2, k1), sel(k0, k2), sel(k1, k0)];
    let ey = [sel(k1, k2), sel(k2, k0), sel(k0, k1)];
    let ez = [k0, k1, k2];
    let pick = |m: [__m256; 3]| or(or(and(m[0], d[0]), and(m[1], d[1])), and(m[2], d[2]));
    let sx = _mm256_div_ps(pick(ex), dz);
    let sy = _mm256_div_ps(pick(ey), dz);
    let sz = _mm256_div_ps(_mm256_set1_ps(1.0), dz);
    let unit = |m| and(m, _mm256_set1_ps(1.0));
    let (mul, sub) = (_mm256_mul_ps, _mm256_sub_ps);
    let rx = |c: usize| sub(unit(ex[c]), mul(unit(ez[c]), sx));
    let ry = |c: usize| sub(unit(ey[c]), mul(unit(ez[c]), sy));
    let rz = |c: usize| mul(unit(ez[c]), sz);
    [
        rx(0),
        rx(1),
        rx(2),
        ry(0),
        ry(1),
        ry(2),
        rz(0),
        rz(1),
        rz(2),
    ]
}

/// The packet's origins, directions and `tmin`, in registers.
#[inline]
#[target_feature(enable = "avx2")]
pub fn rays_lanes(p: &RayPacket) -> ([__m256; 3], [__m256; 3], __m256) {
    // SAFETY: loads of the packet's aligned rows.
    unsafe {
        (
            [load(&p.o[0]), load(&p.o[1]), load(&p.o[2])],
            [load(&p.d[0]), load(&p.d[1]), load(&p.d[2])],
            load(&p.tmin),
        )
    }
}

/// `v` in every lane, by coordinate.
#[inline]
#[target_feature(enable = "avx2")]
pub fn splat3(v: Vec3) -> [__m256; 3] {
    [
        _mm256_set1_ps(v.x),
        _mm256_set1_ps(v.y),
        _mm256_set1_ps(v.z),
    ]
}

/// `a - b` by coordinate.
#[inline]
#[target_feature(enable = "avx2")]
pub fn sub3(a: [__m256; 3], b: [__m256; 3]) -> [__m256; 3] {
    [
        _mm256_sub_ps(a[0], b[0]),
        _mm256_sub_ps(a[1], b[1]),
        _mm256_sub_ps(a[2], b[2]),
    ]
}

/// `a . b` in every lane, in `Vec3::dot`'s order ((x + y) + z).
#[inline]
#[target_feature(enable = "avx2")]
pub fn dot3(a: [__m256; 3], b: [__m256; 3]) -> __m256 {
    let (mul, add) = (_mm256_mul_ps, _mm256_add_ps);
    add(add(mul(a[0], b[0]), mul(a[1], b[1])), mul(a[2], b[2]))
}

/// `t a - b` by coordinate (`f32 * Vec3 - Vec3`).
#[inline]
#[target_feature(enable = "avx2")]
pub fn scaled_sub3(t: __m256, a: [__m256; 3], b: [__m256; 3]) -> [__m256; 3] {
    [
        _mm256_sub_ps(_mm256_mul_ps(t, a[0]), b[0]),
        _mm256_sub_ps(_mm256_mul_ps(t, a[1]), b[1]),
        _mm256_sub_ps(_mm256_mul_ps(t, a[2]), b[2]),
    ]
}

/// A row of the packet in a register.
#[inline]
#[target_feature(enable = "avx2")]
pub unsafe fn load(row: &[f32; LANES]) -> __m256 {
    // SAFETY: the packet is 32-byte aligned and every row is 32 bytes.
    unsafe { _mm256_load_ps(row.as_ptr()) }
}

/// A mask row of the packet in a register.
#[inline]
#[target_feature(enable = "avx2")]
pub unsafe fn load_mask(row: &[u32; LANES]) -> __m256 {
    // SAFETY: as `load`.
    unsafe { _mm256_load_ps(row.as_ptr().cast()) }
}

/// |x| in every lane.
#[inline]
#[target_feature(enable = "avx2")]
pub fn abs(x: __m256) -> __m256 {
    _mm256_andnot_ps(_mm256_set1_ps(-0.0), x)
}

/// `f32::max(a, b)` in every lane where neither is NaN (what the scalar
/// tests' maxima of absolute values see).
#[inline]
#[target_feature(enable = "avx2")]
pub fn max(a: __m256, b: __m256) -> __m256 {
    _mm256_max_ps(a, b)
}

/// The lanes set in `bits` as a vector mask.
#[inline]
#[target_feature(enable = "avx2")]
pub fn mask_of(bits: u32) -> __m256 {
    let lane_bits = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
    let set = _mm256_and_si256(_mm256_set1_epi32(bits as i32), lane_bits);
    _mm256_castsi256_ps(_mm256_cmpeq_epi32(set, lane_bits))
}

/// The vector mask as bits.
#[inline]
#[target_feature(enable = "avx2")]
pub fn bits_of(mask: __m256) -> u32 {
    _mm256_movemask_ps(mask) as u32
}

/// The lanes of a register as an array (a plain function: also called
/// from code not compiled for AVX2 that runs only where the CPU has it,
/// the one-ray walks' leaf test).
#[inline(always)]
pub fn to_array(x: __m256) -> [f32; LANES] {
    // SAFETY: an __m256 is eight floats.
    unsafe { std::mem::transmute::<__m256, [f32; LANES]>(x) }
}
