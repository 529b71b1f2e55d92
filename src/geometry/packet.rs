//! Eight or sixteen rays at once in SIMD lanes ([`Lanes`]: AVX2's or
//! AVX-512VL's eight, AVX-512's sixteen), for
//! scenes small enough that rays which have nothing in
//! common still visit the same few nodes and leaves (issue 15: a Cornell
//! box's 31 primitives, a cube on a ground's 13). One primitive is tested
//! against all the packet's rays with one sequence of vector operations,
//! where a ray alone tests it with three lanes of four.
//!
//! Each shape's lane test ([`super::triangle::intersect_triangle_lanes`],
//! `Sphere::intersect_lanes`, `PlaneFrame::hit_lanes`) does its scalar
//! test's operations in the same order, so a lane's hit is the scalar
//! test's bit for bit (tested in `bvh.rs`, in every width).
//!
//! Everything here runs only inside functions compiled for the lanes'
//! instruction set, which are called only after the CPU was seen to
//! support it.

use super::lanes::{Lanes, MAX_LANES};
use crate::math::Ray;

/// Up to [`MAX_LANES`] rays, by coordinate (lane `i` of every register is
/// ray `i`), with what the slab and triangle tests precompute per ray.
/// Lanes beyond the rays given repeat the first ray and are left out of
/// `live`.
#[derive(Clone, Copy)]
pub struct RayPacket<'a, L: Lanes> {
    pub o: [L::F; 3],
    pub d: [L::F; 3],
    /// The reciprocal direction.
    pub inv: [L::F; 3],
    /// Set where the direction is negative along the axis (its sign bit,
    /// -0 included): the slab test meets the far plane first there.
    pub neg: [L::M; 3],
    pub tmin: L::F,
    pub tmax: L::F,
    /// The rows of each ray's triangle shear
    /// ([`RayShear::axes`](super::triangle::RayShear::axes) as a matrix,
    /// `RowShear`): row `3 r + c` is component `c` of row `r`.
    pub shear: [L::F; 9],
    /// The rays, for the primitives tested one ray at a time.
    pub rays: &'a [Ray],
    /// Bit `i` set: lane `i` carries a ray.
    pub live: u32,
    /// The width's token.
    pub l: L,
}

impl<'a, L: Lanes> RayPacket<'a, L> {
    /// The packet of `rays` (1 to [`MAX_LANES`] of them). The shears are
    /// [`RayShear::new`](super::triangle::RayShear::new)'s, computed in
    /// lanes (its axis choice by masks, not by the jumps that a ray's
    /// random direction mispredicts).
    #[inline(always)]
    pub fn new(l: L, rays: &'a [Ray]) -> RayPacket<'a, L> {
        assert!(!rays.is_empty() && rays.len() <= L::WIDTH && L::WIDTH <= MAX_LANES);
        // (No closures here or below: they would be compiled without the
        // width's instruction set, and its operations left as calls.)
        let f = l.rays(rays);
        let d = [f[3], f[4], f[5]];
        let one = l.splat(1.0);
        RayPacket {
            o: [f[0], f[1], f[2]],
            d,
            inv: [one / d[0], one / d[1], one / d[2]],
            neg: [l.sign(d[0]), l.sign(d[1]), l.sign(d[2])],
            tmin: f[6],
            tmax: f[7],
            shear: shear_lanes(l, d),
            rays,
            live: (1u32 << rays.len()) - 1,
            l,
        }
    }
}

/// [`RayShear::new`](super::triangle::RayShear::new)'s shear, as rows, for a
/// register of directions, by its operations: the dominant axis kz (ties
/// as its comparisons break them), kx and ky after it (swapped where
/// d[kz] < 0), then `e_kx - e_kz sx`, `e_ky - e_kz sy` and `e_kz sz` with
/// the unit vectors as 0/1 lanes.
#[inline(always)]
fn shear_lanes<L: Lanes>(l: L, d: [L::F; 3]) -> [L::F; 9] {
    let a = [l.abs(d[0]), l.abs(d[1]), l.abs(d[2])];
    let x_over_y = l.gt(a[0], a[1]);
    let k0 = l.m_and(x_over_y, l.gt(a[0], a[2]));
    let k1 = l.m_andnot(x_over_y, l.gt(a[1], a[2]));
    let k2 = l.m_andnot(l.m_or(k0, k1), l.m_all());
    let dz = l.blend(l.blend(d[2], d[1], k1), d[0], k0);
    let flip = l.lt(dz, l.zero());
    // `kept` where d[kz] >= 0, `swapped` where it is negative.
    #[inline(always)]
    fn sel<L: Lanes>(l: L, flip: L::M, kept: L::M, swapped: L::M) -> L::M {
        l.m_or(l.m_andnot(flip, kept), l.m_and(flip, swapped))
    }
    // kz = 0: (kx, ky) = (1, 2); kz = 1: (2, 0); kz = 2: (0, 1).
    let ex = [
        sel(l, flip, k2, k1),
        sel(l, flip, k0, k2),
        sel(l, flip, k1, k0),
    ];
    let ey = [
        sel(l, flip, k1, k2),
        sel(l, flip, k2, k0),
        sel(l, flip, k0, k1),
    ];
    let ez = [k0, k1, k2];
    // One of the three masks is set in each lane: its coordinate.
    #[inline(always)]
    fn pick<L: Lanes>(l: L, m: [L::M; 3], d: [L::F; 3]) -> L::F {
        l.blend(
            l.blend(l.blend(l.zero(), d[2], m[2]), d[1], m[1]),
            d[0],
            m[0],
        )
    }
    let sx = pick(l, ex, d) / dz;
    let sy = pick(l, ey, d) / dz;
    let sz = l.splat(1.0) / dz;
    let (zero, one) = (l.zero(), l.splat(1.0));
    let ux = [
        l.blend(zero, one, ex[0]),
        l.blend(zero, one, ex[1]),
        l.blend(zero, one, ex[2]),
    ];
    let uy = [
        l.blend(zero, one, ey[0]),
        l.blend(zero, one, ey[1]),
        l.blend(zero, one, ey[2]),
    ];
    let uz = [
        l.blend(zero, one, ez[0]),
        l.blend(zero, one, ez[1]),
        l.blend(zero, one, ez[2]),
    ];
    [
        ux[0] - uz[0] * sx,
        ux[1] - uz[1] * sx,
        ux[2] - uz[2] * sx,
        uy[0] - uz[0] * sy,
        uy[1] - uz[1] * sy,
        uy[2] - uz[2] * sy,
        uz[0] * sz,
        uz[1] * sz,
        uz[2] * sz,
    ]
}
