//! The SIMD registers the packet tests run in, as one interface over
//! three: AVX2 ([`Avx2Lanes`]) and AVX-512VL ([`Avx512VlLanes`]), eight
//! float lanes each, and AVX-512F's sixteen ([`Avx512Lanes`]). The packet walks and every
//! shape's lane test are written once, generic over [`Lanes`], and
//! compiled into one copy per instruction set inside a function built for
//! it, chosen at run time ([`PacketIsa::detect`]).
//!
//! AVX-512VL keeps AVX2's 256-bit registers but adds sixteen more of them
//! and mask registers: comparisons set a mask, blends read one, and the
//! walk's rays stay in registers instead of being reloaded from the stack
//! (issue 15: the Cornell box, the constant cube and the mirror on a stand
//! 3-4% faster, same images). Packets of sixteen rays in 512-bit
//! registers ([`Avx512Lanes`]) pay where the CPU runs 512-bit operations
//! at full rate (AMD Zen 5: the Cornell box 8-11% faster, see
//! [`PacketIsa::detect`]); on an Intel Xeon VM, with older walks, the
//! same eight rays ran 10% slower in 512-bit code, and sixteen rays
//! gained 3% on the Cornell box but lost 2-5% on the other scenes, so it
//! keeps eight.
//!
//! A lane does the scalar code's operations in its order (no fused
//! multiply-adds), so both instruction sets find the same bits.
//!
//! The operations are `#[inline(always)]` plain functions, only ever
//! inlined into a function compiled for their instruction set. Lane code
//! avoids closures, or marks them `#[inline(always)]` as the walks'
//! primitive tests are: a closure LLVM does not inline is compiled
//! without the instruction set, and its operations stay calls (the
//! Cornell box ran four times slower). Their registers can only be made
//! through a token ([`Avx2Lanes::new`], [`Avx512VlLanes::new`]), which
//! exists only where the CPU has the instructions.

use std::arch::x86_64::*;
use std::ops::{Add, Div, Mul, Sub};

use crate::math::Ray;

/// Lanes in the widest register: the size of the arrays a register is
/// read into and written from (eight-lane registers use the first half).
pub const MAX_LANES: usize = 16;

/// One instruction set's SIMD registers: float vectors `F`, their
/// comparison masks `M`, and the operations the packet tests use. `self` is the token that
/// proves the CPU has the instructions.
pub trait Lanes: Copy {
    type F: Copy
        + Add<Output = Self::F>
        + Sub<Output = Self::F>
        + Mul<Output = Self::F>
        + Div<Output = Self::F>;
    type M: Copy;
    /// Lanes in a register.
    const WIDTH: usize;
    fn splat(self, x: f32) -> Self::F;
    /// `x`'s bits in every lane.
    fn splat_bits(self, x: u32) -> Self::F;
    fn zero(self) -> Self::F;
    /// The lanes from an array.
    fn load(self, a: &[f32; MAX_LANES]) -> Self::F;
    /// The lanes as an array.
    fn store(self, v: Self::F) -> [f32; MAX_LANES];
    /// `minps`: `b` where either is NaN.
    fn min(self, a: Self::F, b: Self::F) -> Self::F;
    /// `maxps`: `b` where either is NaN.
    fn max(self, a: Self::F, b: Self::F) -> Self::F;
    fn sqrt(self, a: Self::F) -> Self::F;
    fn and(self, a: Self::F, b: Self::F) -> Self::F;
    fn or(self, a: Self::F, b: Self::F) -> Self::F;
    fn xor(self, a: Self::F, b: Self::F) -> Self::F;
    /// `!a & b`, bit by bit.
    fn andnot(self, a: Self::F, b: Self::F) -> Self::F;
    fn lt(self, a: Self::F, b: Self::F) -> Self::M;
    fn le(self, a: Self::F, b: Self::F) -> Self::M;
    fn gt(self, a: Self::F, b: Self::F) -> Self::M;
    fn eq(self, a: Self::F, b: Self::F) -> Self::M;
    /// Where `a` or `b` is NaN.
    fn unord(self, a: Self::F, b: Self::F) -> Self::M;
    fn m_and(self, a: Self::M, b: Self::M) -> Self::M;
    fn m_or(self, a: Self::M, b: Self::M) -> Self::M;
    /// `!a & b`.
    fn m_andnot(self, a: Self::M, b: Self::M) -> Self::M;
    /// Every lane set.
    fn m_all(self) -> Self::M;
    /// The mask as bits (lane `i`: bit `i`).
    fn bits(self, m: Self::M) -> u32;
    /// The lanes set in `bits` as a mask.
    fn mask(self, bits: u32) -> Self::M;
    /// `b` where `m` is set, `a` elsewhere.
    fn blend(self, a: Self::F, b: Self::F, m: Self::M) -> Self::F;
    /// Where the sign bit is set (-0 and NaNs with it included).
    fn sign(self, v: Self::F) -> Self::M;
    /// The rays' eight floats (o, d, tmin, tmax: `Ray` is repr(C)) by
    /// field: row `j` holds field `j` of every ray. Lanes beyond the rays
    /// (1 to [`MAX_LANES`] of them) repeat the first.
    fn rays(self, rays: &[Ray]) -> [Self::F; 8];
    /// The inverse of [`Lanes::rays`]: rays from their eight fields' rows,
    /// lane `k` into `rays[k]` for each of `rays` (at most eight).
    fn store_rays(self, fields: [Self::F; 8], rays: &mut [Ray]);

    /// |x|.
    #[inline(always)]
    fn abs(self, x: Self::F) -> Self::F {
        self.andnot(self.splat(-0.0), x)
    }
}

/// `+ - * /` for a register type wrapping one intrinsic type, by the
/// intrinsics named.
macro_rules! arithmetic {
    ($t:ident, $add:ident, $sub:ident, $mul:ident, $div:ident) => {
        impl Add for $t {
            type Output = $t;
            #[inline(always)]
            fn add(self, b: $t) -> $t {
                $t(unsafe { $add(self.0, b.0) })
            }
        }

        impl Sub for $t {
            type Output = $t;
            #[inline(always)]
            fn sub(self, b: $t) -> $t {
                $t(unsafe { $sub(self.0, b.0) })
            }
        }

        impl Mul for $t {
            type Output = $t;
            #[inline(always)]
            fn mul(self, b: $t) -> $t {
                $t(unsafe { $mul(self.0, b.0) })
            }
        }

        impl Div for $t {
            type Output = $t;
            #[inline(always)]
            fn div(self, b: $t) -> $t {
                $t(unsafe { $div(self.0, b.0) })
            }
        }
    };
}

/// AVX2's eight lanes.
#[derive(Clone, Copy, Debug)]
pub struct Avx2Lanes(());

/// AVX-512VL's eight lanes: AVX2's registers, AVX-512's mask registers
/// and its thirty-two vector registers.
#[derive(Clone, Copy, Debug)]
pub struct Avx512VlLanes(());

impl Avx2Lanes {
    /// The token, where the CPU has AVX2.
    pub fn new() -> Option<Avx2Lanes> {
        std::arch::is_x86_feature_detected!("avx2").then_some(Avx2Lanes(()))
    }

    /// The token, unchecked.
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[inline(always)]
    pub unsafe fn new_unchecked() -> Avx2Lanes {
        Avx2Lanes(())
    }

    /// A register made with AVX2's own intrinsics.
    #[inline(always)]
    pub fn wrap(self, x: __m256) -> F8 {
        F8(x)
    }
}

impl Avx512VlLanes {
    /// The token, where the CPU has AVX-512F, AVX-512VL and AVX2.
    pub fn new() -> Option<Avx512VlLanes> {
        (std::arch::is_x86_feature_detected!("avx512f")
            && std::arch::is_x86_feature_detected!("avx512vl")
            && std::arch::is_x86_feature_detected!("avx2"))
        .then_some(Avx512VlLanes(()))
    }

    /// The token, unchecked.
    ///
    /// # Safety
    /// The CPU must have AVX-512F, AVX-512VL and AVX2.
    #[inline(always)]
    pub unsafe fn new_unchecked() -> Avx512VlLanes {
        Avx512VlLanes(())
    }
}

/// AVX-512F's sixteen lanes: 512-bit registers and 16-bit masks, for
/// packets of up to sixteen rays.
#[derive(Clone, Copy, Debug)]
pub struct Avx512Lanes(());

impl Avx512Lanes {
    /// The token, unchecked.
    ///
    /// # Safety
    /// The CPU must have AVX-512F, AVX-512VL and AVX2.
    #[inline(always)]
    pub unsafe fn new_unchecked() -> Avx512Lanes {
        Avx512Lanes(())
    }
}

/// Sixteen float lanes (only made by the token).
#[derive(Clone, Copy, Debug)]
pub struct F16(__m512);

// SAFETY (each operator): an `F16` exists only where the CPU has
// AVX-512F, and the operators are inlined into functions built for it.
arithmetic!(
    F16,
    _mm512_add_ps,
    _mm512_sub_ps,
    _mm512_mul_ps,
    _mm512_div_ps
);

/// Two eight-lane registers as one of sixteen (`lo` in lanes 0-7).
///
/// # Safety
/// Only inlined into functions compiled for AVX-512F.
#[inline(always)]
unsafe fn join16(lo: __m256, hi: __m256) -> __m512 {
    unsafe {
        _mm512_castpd_ps(_mm512_insertf64x4::<1>(
            _mm512_castpd256_pd512(_mm256_castps_pd(lo)),
            _mm256_castps_pd(hi),
        ))
    }
}

/// A sixteen-lane register's halves (lanes 0-7, lanes 8-15).
///
/// # Safety
/// Only inlined into functions compiled for AVX-512F.
#[inline(always)]
unsafe fn halves16(v: __m512) -> (__m256, __m256) {
    unsafe {
        let v = _mm512_castps_pd(v);
        (
            _mm256_castpd_ps(_mm512_castpd512_pd256(v)),
            _mm256_castpd_ps(_mm512_extractf64x4_pd::<1>(v)),
        )
    }
}

impl Lanes for Avx512Lanes {
    type F = F16;
    type M = __mmask16;
    const WIDTH: usize = 16;

    // SAFETY (every operation): the token exists only where the CPU has
    // AVX-512F, AVX-512VL and AVX2, and the operations are inlined into
    // functions built for them.
    #[inline(always)]
    fn splat(self, x: f32) -> F16 {
        F16(unsafe { _mm512_set1_ps(x) })
    }
    #[inline(always)]
    fn splat_bits(self, x: u32) -> F16 {
        F16(unsafe { _mm512_castsi512_ps(_mm512_set1_epi32(x as i32)) })
    }
    #[inline(always)]
    fn zero(self) -> F16 {
        F16(unsafe { _mm512_setzero_ps() })
    }
    #[inline(always)]
    fn load(self, a: &[f32; MAX_LANES]) -> F16 {
        F16(unsafe { _mm512_loadu_ps(a.as_ptr()) })
    }
    #[inline(always)]
    fn store(self, v: F16) -> [f32; MAX_LANES] {
        let mut a = [0.0; MAX_LANES];
        unsafe { _mm512_storeu_ps(a.as_mut_ptr(), v.0) };
        a
    }
    #[inline(always)]
    fn min(self, a: F16, b: F16) -> F16 {
        F16(unsafe { _mm512_min_ps(a.0, b.0) })
    }
    #[inline(always)]
    fn max(self, a: F16, b: F16) -> F16 {
        F16(unsafe { _mm512_max_ps(a.0, b.0) })
    }
    #[inline(always)]
    fn sqrt(self, a: F16) -> F16 {
        F16(unsafe { _mm512_sqrt_ps(a.0) })
    }
    // The bit operations in integer lanes (the float ones are AVX-512DQ).
    #[inline(always)]
    fn and(self, a: F16, b: F16) -> F16 {
        F16(unsafe {
            _mm512_castsi512_ps(_mm512_and_si512(
                _mm512_castps_si512(a.0),
                _mm512_castps_si512(b.0),
            ))
        })
    }
    #[inline(always)]
    fn or(self, a: F16, b: F16) -> F16 {
        F16(unsafe {
            _mm512_castsi512_ps(_mm512_or_si512(
                _mm512_castps_si512(a.0),
                _mm512_castps_si512(b.0),
            ))
        })
    }
    #[inline(always)]
    fn xor(self, a: F16, b: F16) -> F16 {
        F16(unsafe {
            _mm512_castsi512_ps(_mm512_xor_si512(
                _mm512_castps_si512(a.0),
                _mm512_castps_si512(b.0),
            ))
        })
    }
    #[inline(always)]
    fn andnot(self, a: F16, b: F16) -> F16 {
        F16(unsafe {
            _mm512_castsi512_ps(_mm512_andnot_si512(
                _mm512_castps_si512(a.0),
                _mm512_castps_si512(b.0),
            ))
        })
    }
    #[inline(always)]
    fn lt(self, a: F16, b: F16) -> __mmask16 {
        unsafe { _mm512_cmp_ps_mask::<_CMP_LT_OQ>(a.0, b.0) }
    }
    #[inline(always)]
    fn le(self, a: F16, b: F16) -> __mmask16 {
        unsafe { _mm512_cmp_ps_mask::<_CMP_LE_OQ>(a.0, b.0) }
    }
    #[inline(always)]
    fn gt(self, a: F16, b: F16) -> __mmask16 {
        unsafe { _mm512_cmp_ps_mask::<_CMP_GT_OQ>(a.0, b.0) }
    }
    #[inline(always)]
    fn eq(self, a: F16, b: F16) -> __mmask16 {
        unsafe { _mm512_cmp_ps_mask::<_CMP_EQ_OQ>(a.0, b.0) }
    }
    #[inline(always)]
    fn unord(self, a: F16, b: F16) -> __mmask16 {
        unsafe { _mm512_cmp_ps_mask::<_CMP_UNORD_Q>(a.0, b.0) }
    }
    #[inline(always)]
    fn m_and(self, a: __mmask16, b: __mmask16) -> __mmask16 {
        a & b
    }
    #[inline(always)]
    fn m_or(self, a: __mmask16, b: __mmask16) -> __mmask16 {
        a | b
    }
    #[inline(always)]
    fn m_andnot(self, a: __mmask16, b: __mmask16) -> __mmask16 {
        !a & b
    }
    #[inline(always)]
    fn m_all(self) -> __mmask16 {
        0xffff
    }
    #[inline(always)]
    fn bits(self, m: __mmask16) -> u32 {
        u32::from(m)
    }
    #[inline(always)]
    fn mask(self, bits: u32) -> __mmask16 {
        bits as __mmask16
    }
    #[inline(always)]
    fn blend(self, a: F16, b: F16, m: __mmask16) -> F16 {
        F16(unsafe { _mm512_mask_blend_ps(m, a.0, b.0) })
    }
    #[inline(always)]
    fn sign(self, v: F16) -> __mmask16 {
        unsafe { _mm512_cmplt_epi32_mask(_mm512_castps_si512(v.0), _mm512_setzero_si512()) }
    }
    #[inline(always)]
    fn rays(self, rays: &[Ray]) -> [F16; 8] {
        // Rays 0-7 and 8-15 transposed apart (lanes beyond the rays
        // repeat ray 0), then joined.
        unsafe {
            let lo = ray_fields8(rays, 0);
            let hi = ray_fields8(rays, 8);
            [
                F16(join16(lo[0], hi[0])),
                F16(join16(lo[1], hi[1])),
                F16(join16(lo[2], hi[2])),
                F16(join16(lo[3], hi[3])),
                F16(join16(lo[4], hi[4])),
                F16(join16(lo[5], hi[5])),
                F16(join16(lo[6], hi[6])),
                F16(join16(lo[7], hi[7])),
            ]
        }
    }
    #[inline(always)]
    fn store_rays(self, fields: [F16; 8], rays: &mut [Ray]) {
        unsafe {
            let h = [
                halves16(fields[0].0),
                halves16(fields[1].0),
                halves16(fields[2].0),
                halves16(fields[3].0),
                halves16(fields[4].0),
                halves16(fields[5].0),
                halves16(fields[6].0),
                halves16(fields[7].0),
            ];
            let lo = transpose8([
                h[0].0, h[1].0, h[2].0, h[3].0, h[4].0, h[5].0, h[6].0, h[7].0,
            ]);
            let hi = transpose8([
                h[0].1, h[1].1, h[2].1, h[3].1, h[4].1, h[5].1, h[6].1, h[7].1,
            ]);
            for (ray, v) in rays.iter_mut().zip(lo.into_iter().chain(hi)) {
                // SAFETY: a `Ray` is eight contiguous floats.
                _mm256_storeu_ps((ray as *mut Ray).cast(), v);
            }
        }
    }
}

/// Which instruction set the packet walks run in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PacketIsa {
    Avx2,
    /// AVX-512VL's eight lanes.
    Avx512Vl,
    /// AVX-512VL's eight lanes for packets of up to eight rays (and the
    /// one-ray walks' leaves), AVX-512F's sixteen (`Avx512Lanes`) for
    /// packets of more.
    Avx512,
}

impl PacketIsa {
    /// The best the CPU has, None without AVX2: with AVX-512, packets of
    /// sixteen where the CPU runs 512-bit operations at the rate of
    /// 256-bit ones (AMD Zen 5 and later), eight elsewhere. `LENTE_SIMD`
    /// names one instead (`avx2`, `avx512vl` or `avx512`; to compare
    /// them, the images are the same), where the CPU has it.
    pub fn detect() -> Option<PacketIsa> {
        static ISA: std::sync::OnceLock<Option<PacketIsa>> = std::sync::OnceLock::new();
        *ISA.get_or_init(|| {
            let named = std::env::var("LENTE_SIMD").ok();
            let named = named.as_deref().map(str::trim);
            if Avx512VlLanes::new().is_none() || named == Some("avx2") {
                return Avx2Lanes::new().map(|_| PacketIsa::Avx2);
            }
            Some(match named {
                Some("avx512vl") => PacketIsa::Avx512Vl,
                Some("avx512") => PacketIsa::Avx512,
                _ if full_rate_512() => PacketIsa::Avx512,
                _ => PacketIsa::Avx512Vl,
            })
        })
    }

    /// Whether the CPU has it (the walks check before they run, since
    /// anyone can name one).
    #[inline]
    pub fn available(self) -> bool {
        match self {
            PacketIsa::Avx2 => Avx2Lanes::new().is_some(),
            PacketIsa::Avx512Vl | PacketIsa::Avx512 => Avx512VlLanes::new().is_some(),
        }
    }

    /// Whether the one-ray walks and packets of up to eight rays run in
    /// AVX-512VL's form (rather than AVX2's).
    #[inline]
    pub fn has_avx512vl(self) -> bool {
        self != PacketIsa::Avx2
    }
}

/// Whether this CPU's 512-bit operations cost what 256-bit ones do, so
/// that a packet of sixteen rays costs about what one of eight does: AMD
/// Zen 5 (family 1Ah) and later, whose vector units are 512 bits wide.
/// Measured on a Zen 5 VM (issue 15, three alternating runs: Cornell box
/// 1.95 -> 2.12-2.19 M samples/s, the constant cube +2-4%, the other
/// packet scenes within noise; the same images). Elsewhere eight: Zen 4
/// splits 512-bit operations in two (not measured), and on an Intel Xeon
/// VM, with older walks, sixteen rays gained 3% on the Cornell box but
/// lost 2-5% on the other scenes (the clock 512-bit code runs at).
fn full_rate_512() -> bool {
    // SAFETY: CPUID leaves 0 and 1 exist on every x86_64 CPU. (Newer Rust
    // calls it safe, older unsafe.)
    #[allow(unused_unsafe)]
    let (vendor, signature) = unsafe { (__cpuid(0), __cpuid(1)) };
    let amd = [vendor.ebx, vendor.edx, vendor.ecx] == [0x6874_7541, 0x6974_6e65, 0x444d_4163];
    let base = (signature.eax >> 8) & 0xf;
    let family = if base == 0xf {
        base + ((signature.eax >> 20) & 0xff)
    } else {
        base
    };
    amd && family >= 0x1a
}

/// Eight float lanes (only made by the tokens).
#[derive(Clone, Copy, Debug)]
pub struct F8(__m256);

// SAFETY (each operator): an `F8` exists only where the CPU has AVX2,
// and the operators are inlined into functions built for it.
arithmetic!(
    F8,
    _mm256_add_ps,
    _mm256_sub_ps,
    _mm256_mul_ps,
    _mm256_div_ps
);

/// The transpose of an 8 x 8 matrix of floats held by rows: unpacks
/// within 128-bit halves, then across them.
///
/// # Safety
/// Only inlined into functions compiled for AVX2.
#[inline(always)]
unsafe fn transpose8(r: [__m256; 8]) -> [__m256; 8] {
    unsafe {
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
}

/// Rays `first..first + 8` of `rays` (lanes beyond them repeat ray 0) as
/// the rows of an 8 x 8 matrix, transposed to fields.
///
/// # Safety
/// Only inlined into functions compiled for AVX2.
#[inline(always)]
unsafe fn ray_fields8(rays: &[Ray], first: usize) -> [__m256; 8] {
    const _: () = assert!(std::mem::size_of::<Ray>() == 32);
    #[inline(always)]
    unsafe fn load(rays: &[Ray], k: usize) -> __m256 {
        let ray = rays.get(k).unwrap_or(&rays[0]);
        // SAFETY: a `Ray` is eight contiguous floats.
        unsafe { _mm256_loadu_ps((ray as *const Ray).cast()) }
    }
    unsafe {
        transpose8([
            load(rays, first),
            load(rays, first + 1),
            load(rays, first + 2),
            load(rays, first + 3),
            load(rays, first + 4),
            load(rays, first + 5),
            load(rays, first + 6),
            load(rays, first + 7),
        ])
    }
}

/// The operations on float registers, the same for both instruction sets
/// (their registers are AVX2's); pasted into each `impl Lanes`.
macro_rules! float_ops {
    () => {
        #[inline(always)]
        fn splat(self, x: f32) -> F8 {
            F8(unsafe { _mm256_set1_ps(x) })
        }
        #[inline(always)]
        fn splat_bits(self, x: u32) -> F8 {
            F8(unsafe { _mm256_castsi256_ps(_mm256_set1_epi32(x as i32)) })
        }
        #[inline(always)]
        fn zero(self) -> F8 {
            F8(unsafe { _mm256_setzero_ps() })
        }
        #[inline(always)]
        fn load(self, a: &[f32; MAX_LANES]) -> F8 {
            F8(unsafe { _mm256_loadu_ps(a.as_ptr()) })
        }
        #[inline(always)]
        fn store(self, v: F8) -> [f32; MAX_LANES] {
            let mut a = [0.0; MAX_LANES];
            unsafe { _mm256_storeu_ps(a.as_mut_ptr(), v.0) };
            a
        }
        #[inline(always)]
        fn min(self, a: F8, b: F8) -> F8 {
            F8(unsafe { _mm256_min_ps(a.0, b.0) })
        }
        #[inline(always)]
        fn max(self, a: F8, b: F8) -> F8 {
            F8(unsafe { _mm256_max_ps(a.0, b.0) })
        }
        #[inline(always)]
        fn sqrt(self, a: F8) -> F8 {
            F8(unsafe { _mm256_sqrt_ps(a.0) })
        }
        #[inline(always)]
        fn and(self, a: F8, b: F8) -> F8 {
            F8(unsafe { _mm256_and_ps(a.0, b.0) })
        }
        #[inline(always)]
        fn or(self, a: F8, b: F8) -> F8 {
            F8(unsafe { _mm256_or_ps(a.0, b.0) })
        }
        #[inline(always)]
        fn xor(self, a: F8, b: F8) -> F8 {
            F8(unsafe { _mm256_xor_ps(a.0, b.0) })
        }
        #[inline(always)]
        fn andnot(self, a: F8, b: F8) -> F8 {
            F8(unsafe { _mm256_andnot_ps(a.0, b.0) })
        }
        #[inline(always)]
        fn rays(self, rays: &[Ray]) -> [F8; 8] {
            unsafe { ray_fields8(rays, 0) }.map(F8)
        }
        #[inline(always)]
        fn store_rays(self, fields: [F8; 8], rays: &mut [Ray]) {
            let [a, b, c, d, e, f, g, h] = fields;
            let each = unsafe { transpose8([a.0, b.0, c.0, d.0, e.0, f.0, g.0, h.0]) };
            for (ray, v) in rays.iter_mut().zip(each) {
                // SAFETY: a `Ray` is eight contiguous floats.
                unsafe { _mm256_storeu_ps((ray as *mut Ray).cast(), v) };
            }
        }
    };
}

impl Lanes for Avx2Lanes {
    type F = F8;
    type M = __m256;
    const WIDTH: usize = 8;

    // SAFETY (every operation): the token exists only where the CPU has
    // AVX2, and the operations are inlined into functions built for it.
    float_ops!();

    #[inline(always)]
    fn lt(self, a: F8, b: F8) -> __m256 {
        unsafe { _mm256_cmp_ps::<_CMP_LT_OQ>(a.0, b.0) }
    }
    #[inline(always)]
    fn le(self, a: F8, b: F8) -> __m256 {
        unsafe { _mm256_cmp_ps::<_CMP_LE_OQ>(a.0, b.0) }
    }
    #[inline(always)]
    fn gt(self, a: F8, b: F8) -> __m256 {
        unsafe { _mm256_cmp_ps::<_CMP_GT_OQ>(a.0, b.0) }
    }
    #[inline(always)]
    fn eq(self, a: F8, b: F8) -> __m256 {
        unsafe { _mm256_cmp_ps::<_CMP_EQ_OQ>(a.0, b.0) }
    }
    #[inline(always)]
    fn unord(self, a: F8, b: F8) -> __m256 {
        unsafe { _mm256_cmp_ps::<_CMP_UNORD_Q>(a.0, b.0) }
    }
    #[inline(always)]
    fn m_and(self, a: __m256, b: __m256) -> __m256 {
        unsafe { _mm256_and_ps(a, b) }
    }
    #[inline(always)]
    fn m_or(self, a: __m256, b: __m256) -> __m256 {
        unsafe { _mm256_or_ps(a, b) }
    }
    #[inline(always)]
    fn m_andnot(self, a: __m256, b: __m256) -> __m256 {
        unsafe { _mm256_andnot_ps(a, b) }
    }
    #[inline(always)]
    fn m_all(self) -> __m256 {
        unsafe { _mm256_castsi256_ps(_mm256_set1_epi32(-1)) }
    }
    #[inline(always)]
    fn bits(self, m: __m256) -> u32 {
        unsafe { _mm256_movemask_ps(m) as u32 }
    }
    #[inline(always)]
    fn mask(self, bits: u32) -> __m256 {
        unsafe {
            let lane_bits = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
            let set = _mm256_and_si256(_mm256_set1_epi32(bits as i32), lane_bits);
            _mm256_castsi256_ps(_mm256_cmpeq_epi32(set, lane_bits))
        }
    }
    #[inline(always)]
    fn blend(self, a: F8, b: F8, m: __m256) -> F8 {
        F8(unsafe { _mm256_blendv_ps(a.0, b.0, m) })
    }
    #[inline(always)]
    fn sign(self, v: F8) -> __m256 {
        unsafe { _mm256_castsi256_ps(_mm256_srai_epi32::<31>(_mm256_castps_si256(v.0))) }
    }
}

impl Lanes for Avx512VlLanes {
    type F = F8;
    type M = __mmask8;
    const WIDTH: usize = 8;

    // SAFETY (every operation): the token exists only where the CPU has
    // AVX-512F, AVX-512VL and AVX2, and the operations are inlined into
    // functions built for them.
    float_ops!();

    #[inline(always)]
    fn lt(self, a: F8, b: F8) -> __mmask8 {
        unsafe { _mm256_cmp_ps_mask::<_CMP_LT_OQ>(a.0, b.0) }
    }
    #[inline(always)]
    fn le(self, a: F8, b: F8) -> __mmask8 {
        unsafe { _mm256_cmp_ps_mask::<_CMP_LE_OQ>(a.0, b.0) }
    }
    #[inline(always)]
    fn gt(self, a: F8, b: F8) -> __mmask8 {
        unsafe { _mm256_cmp_ps_mask::<_CMP_GT_OQ>(a.0, b.0) }
    }
    #[inline(always)]
    fn eq(self, a: F8, b: F8) -> __mmask8 {
        unsafe { _mm256_cmp_ps_mask::<_CMP_EQ_OQ>(a.0, b.0) }
    }
    #[inline(always)]
    fn unord(self, a: F8, b: F8) -> __mmask8 {
        unsafe { _mm256_cmp_ps_mask::<_CMP_UNORD_Q>(a.0, b.0) }
    }
    #[inline(always)]
    fn m_and(self, a: __mmask8, b: __mmask8) -> __mmask8 {
        a & b
    }
    #[inline(always)]
    fn m_or(self, a: __mmask8, b: __mmask8) -> __mmask8 {
        a | b
    }
    #[inline(always)]
    fn m_andnot(self, a: __mmask8, b: __mmask8) -> __mmask8 {
        !a & b
    }
    #[inline(always)]
    fn m_all(self) -> __mmask8 {
        0xff
    }
    #[inline(always)]
    fn bits(self, m: __mmask8) -> u32 {
        u32::from(m)
    }
    #[inline(always)]
    fn mask(self, bits: u32) -> __mmask8 {
        bits as __mmask8
    }
    #[inline(always)]
    fn blend(self, a: F8, b: F8, m: __mmask8) -> F8 {
        F8(unsafe { _mm256_mask_blend_ps(m, a.0, b.0) })
    }
    #[inline(always)]
    fn sign(self, v: F8) -> __mmask8 {
        unsafe { _mm256_cmplt_epi32_mask(_mm256_castps_si256(v.0), _mm256_setzero_si256()) }
    }
}

/// `v` in every lane, by coordinate.
#[inline(always)]
pub fn splat3<L: Lanes>(l: L, v: crate::math::Vec3) -> [L::F; 3] {
    [l.splat(v.x), l.splat(v.y), l.splat(v.z)]
}

/// `a - b` by coordinate.
#[inline(always)]
pub fn sub3<F: Copy + Sub<Output = F>>(a: [F; 3], b: [F; 3]) -> [F; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// `a . b` in every lane, in `Vec3::dot`'s order ((x + y) + z).
#[inline(always)]
pub fn dot3<F: Copy + Add<Output = F> + Mul<Output = F>>(a: [F; 3], b: [F; 3]) -> F {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// `t a - b` by coordinate (`f32 * Vec3 - Vec3`).
#[inline(always)]
pub fn scaled_sub3<F: Copy + Sub<Output = F> + Mul<Output = F>>(
    t: F,
    a: [F; 3],
    b: [F; 3],
) -> [F; 3] {
    [t * a[0] - b[0], t * a[1] - b[1], t * a[2] - b[2]]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Rays `0..n` by field and back: every lane of a field holds its
    /// ray's value (lanes beyond the rays the first ray's), and storing
    /// the fields writes the rays as they were, and nothing beyond them.
    #[inline(always)]
    fn fields_round_trip<L: Lanes>(l: L, n: usize) {
        let ray = |k: usize| {
            let f = |j: usize| (8 * k + j) as f32 + 0.25;
            Ray::with_range(
                crate::math::Vec3::new(f(0), f(1), f(2)),
                crate::math::Vec3::new(f(3), f(4), f(5)),
                f(6),
                f(7),
            )
        };
        let rays: Vec<Ray> = (0..n).map(ray).collect();
        let fields = l.rays(&rays);
        for (j, field) in fields.iter().enumerate() {
            let lanes = l.store(*field);
            for (k, &v) in lanes.iter().enumerate().take(L::WIDTH) {
                let of = if k < n { k } else { 0 };
                assert_eq!(v, (8 * of + j) as f32 + 0.25, "field {j}, lane {k} of {n}");
            }
        }
        let blank = Ray::with_range(crate::math::Vec3::ZERO, crate::math::Vec3::Z, 0.0, 0.0);
        let mut back = vec![blank; L::WIDTH + 1];
        l.store_rays(fields, &mut back[..n]);
        for (k, r) in back.iter().enumerate() {
            let want = if k < n { rays[k] } else { blank };
            assert_eq!(format!("{r:?}"), format!("{want:?}"), "ray {k} of {n}");
        }
    }

    #[target_feature(enable = "avx2")]
    fn avx2_round_trips() {
        // SAFETY: built for AVX2, run where the CPU has it.
        let l = unsafe { Avx2Lanes::new_unchecked() };
        for n in 1..=Avx2Lanes::WIDTH {
            fields_round_trip(l, n);
        }
    }

    #[target_feature(enable = "avx2,avx512f,avx512vl")]
    fn avx512_round_trips() {
        // SAFETY: built for AVX-512, run where the CPU has it.
        let (vl, l) = unsafe { (Avx512VlLanes::new_unchecked(), Avx512Lanes::new_unchecked()) };
        for n in 1..=Avx512VlLanes::WIDTH {
            fields_round_trip(vl, n);
        }
        for n in 1..=Avx512Lanes::WIDTH {
            fields_round_trip(l, n);
        }
    }

    #[test]
    fn rays_by_field_and_back_in_every_width() {
        if Avx2Lanes::new().is_some() {
            // SAFETY: the CPU has AVX2.
            unsafe { avx2_round_trips() };
        }
        if Avx512VlLanes::new().is_some() {
            // SAFETY: the CPU has AVX-512F, AVX-512VL and AVX2.
            unsafe { avx512_round_trips() };
        }
    }
}
