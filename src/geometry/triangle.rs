//! Watertight ray/triangle intersection (Woop, Benthin and Wald, JCGT 2013):
//! rays through shared edges or vertices hit exactly one of the triangles.

use glam::Vec3A;

#[cfg(target_arch = "x86_64")]
use super::lanes::Lanes;
use crate::math::{gamma, Vec3};

/// A triangle stored by coordinate: `xs` holds the three vertices' x, and
/// so on, so that one SIMD operation moves all three vertices into the
/// ray's frame (no per-coordinate permutation at run time).
#[derive(Clone, Copy, Debug)]
pub struct PackedTriangle {
    xs: Vec3A,
    ys: Vec3A,
    zs: Vec3A,
}

impl PackedTriangle {
    /// From the vertices' x, y and z coordinates, three to a vector.
    #[inline]
    pub fn from_lanes(xs: Vec3A, ys: Vec3A, zs: Vec3A) -> PackedTriangle {
        PackedTriangle { xs, ys, zs }
    }

    pub fn new(p0: Vec3, p1: Vec3, p2: Vec3) -> PackedTriangle {
        PackedTriangle {
            xs: Vec3A::new(p0.x, p1.x, p2.x),
            ys: Vec3A::new(p0.y, p1.y, p2.y),
            zs: Vec3A::new(p0.z, p1.z, p2.z),
        }
    }
}

/// Per-ray precomputation for the watertight test: the axis permutation
/// and shear that map the ray direction onto +z (Woop et al.'s kx, ky, kz
/// and sx, sy, sz), and the origin's coordinates in that axis order.
#[derive(Clone, Copy, Debug)]
pub struct RayShear {
    k: [u32; 3],
    s: [f32; 3],
    o_by_axes: [f32; 3],
}

impl RayShear {
    #[inline]
    pub fn new(o: Vec3, d: Vec3) -> RayShear {
        let a = d.abs();
        let kz = if a.x > a.y {
            if a.x > a.z {
                0
            } else {
                2
            }
        } else if a.y > a.z {
            1
        } else {
            2
        };
        let (kx, ky) = match kz {
            0 => (1, 2),
            1 => (2, 0),
            _ => (0, 1),
        };
        let (kx, ky) = if d[kz] < 0.0 { (ky, kx) } else { (kx, ky) };
        let dz = d[kz];
        RayShear {
            k: [kx as u32, ky as u32, kz as u32],
            s: [d[kx] / dz, d[ky] / dz, 1.0 / dz],
            o_by_axes: [o[kx], o[ky], o[kz]],
        }
    }

    /// The shear by axes: `([kx, ky, kz], [sx, sy, sz], [o[kx], o[ky],
    /// o[kz]])`: `x' = p[kx] - sx p[kz]`, `y' = p[ky] - sy p[kz]`,
    /// `z' = sz p[kz]` for `p` relative to the origin `o`.
    ///
    /// The same values, where they are not zero, as the matrix whose rows
    /// are `e_kx - e_kz sx`, `e_ky - e_kz sy` and `e_kz sz` (a packet's
    /// shear, `RowShear`): every term that form adds beside these is a
    /// coordinate times an exact zero, and each row entry is exact. A
    /// zero may differ in sign; no test's outcome depends on it.
    #[inline]
    pub fn axes(&self) -> ([usize; 3], [f32; 3], [f32; 3]) {
        // (No `map`: its closure stayed out of line in the AVX2 walks.)
        let [kx, ky, kz] = self.k;
        (
            [kx as usize, ky as usize, kz as usize],
            self.s,
            self.o_by_axes,
        )
    }
}

/// Returns (t, b1, b2) for a hit with t in (tmin, tmax); b1, b2 weight
/// vertices 1 and 2.
#[inline(always)]
pub fn intersect_triangle(
    shear: &RayShear,
    tri: &PackedTriangle,
    tmin: f32,
    tmax: f32,
) -> Option<(f32, f32, f32)> {
    let ([kx, ky, kz], [sx, sy, sz], [ox, oy, oz]) = shear.axes();
    // The vertices' coordinates in the ray's axis order, three vertices at
    // a time, sheared as a leaf's lanes shear them (`AxisShear`): xt =
    // (ax, bx, cx), yt = (ay, by, cy), zt = (az, bz, cz).
    let coords = [tri.xs, tri.ys, tri.zs];
    let shear = AxisShear {
        o: [ox, oy, oz].map(Vec3A::splat),
        s: [sx, sy, sz].map(Vec3A::splat),
    };
    let (xt, yt, z) = shear.xy([coords[kx], coords[ky], coords[kz]]);
    let zt = shear.z(z);
    // Edge functions (u, v, w) = (cx by - cy bx, ax cy - ay cx, bx ay - by ax).
    let e = yt.cross(xt);
    let (mut u, mut v, mut w) = (e.x, e.y, e.z);
    if u == 0.0 || v == 0.0 || w == 0.0 {
        // Edge case: redo in double precision so shared edges stay watertight.
        let (ax, bx, cx) = (xt.x as f64, xt.y as f64, xt.z as f64);
        let (ay, by, cy) = (yt.x as f64, yt.y as f64, yt.z as f64);
        u = (cx * by - cy * bx) as f32;
        v = (ax * cy - ay * cx) as f32;
        w = (bx * ay - by * ax) as f32;
    }
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return None;
    }
    let det = u + v + w;
    if det == 0.0 {
        return None;
    }
    let (az, bz, cz) = (zt.x, zt.y, zt.z);
    let t_scaled = u * az + v * bz + w * cz;
    let inv_det = 1.0 / det;
    let t = t_scaled * inv_det;
    if !(t > tmin && t < tmax) {
        return None;
    }
    // Reject hits whose t is within its own rounding error of zero (pbrt's
    // conservative bound): a ray spawned on this very triangle.
    {
        let max_zt = zt.abs().max_element();
        let max_xt = xt.abs().max_element();
        let max_yt = yt.abs().max_element();
        let delta_z = gamma(3) * max_zt;
        let delta_x = gamma(5) * (max_xt + max_zt);
        let delta_y = gamma(5) * (max_yt + max_zt);
        let delta_e = 2.0 * (gamma(2) * max_xt * max_yt + delta_y * max_xt + delta_x * max_yt);
        let max_e = u.abs().max(v.abs()).max(w.abs());
        let delta_t =
            3.0 * (gamma(3) * max_e * max_zt + delta_e * max_zt + delta_z * max_e) * inv_det.abs();
        if t <= delta_t {
            return None;
        }
    }
    Some((t, v * inv_det, w * inv_det))
}

/// [`intersect_triangle`] of the rays of a packet: the lanes that hit the
/// triangle within (tmin, tmax) as bits, and their t, b1 and b2. Each
/// lane does the scalar test's operations in its order, so it finds the
/// same hit bit for bit; a lane whose edge function comes out exactly zero
/// (a ray through an edge or vertex) is redone by the scalar test, which
/// recomputes it in double precision.
///
/// `ANY_HIT` (the any-hit walk's copy or the closest-hit walk's) only
/// gives each walk a copy of its own, which LLVM inlines (one called
/// from both stayed out of line: +13% instructions for the walk).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub fn intersect_triangle_lanes<L: Lanes, const ANY_HIT: bool>(
    p: &super::packet::RayPacket<L>,
    tri: &PackedTriangle,
    lanes: u32,
    tmax: L::F,
) -> (u32, L::F, L::F, L::F) {
    let l = p.l;
    // (No closures in lane code: they would be compiled without the
    // width's instruction set, and its operations left as calls.)
    let (xs, ys, zs) = (tri.xs, tri.ys, tri.zs);
    let vertices = [
        [l.splat(xs.x), l.splat(ys.x), l.splat(zs.x)],
        [l.splat(xs.y), l.splat(ys.y), l.splat(zs.y)],
        [l.splat(xs.z), l.splat(ys.z), l.splat(zs.z)],
    ];
    let zero = l.zero();
    let Some(WatertightLanes {
        hits,
        zero_edge,
        t,
        b1,
        b2,
    }) = watertight_lanes(
        l,
        &RowShear { o: p.o, r: p.shear },
        vertices,
        p.tmin,
        tmax,
        lanes,
    )
    else {
        return (0, zero, zero, zero);
    };
    let mut bits = hits;
    let (mut t, mut b1, mut b2) = (t, b1, b2);
    if zero_edge != 0 {
        // The scalar test, in double precision where it needs it.
        let (mut ts, mut b1s, mut b2s) = (l.store(t), l.store(b1), l.store(b2));
        let tmaxs = l.store(tmax);
        let mut edge = zero_edge;
        while edge != 0 {
            let lane = edge.trailing_zeros() as usize;
            edge &= edge - 1;
            let ray = &p.rays[lane];
            let shear = RayShear::new(ray.o, ray.d);
            if let Some((tl, u1, u2)) = intersect_triangle(&shear, tri, ray.tmin, tmaxs[lane]) {
                (ts[lane], b1s[lane], b2s[lane]) = (tl, u1, u2);
                bits |= 1 << lane;
            }
        }
        (t, b1, b2) = (l.load(&ts), l.load(&b1s), l.load(&b2s));
    }
    (bits, t, b1, b2)
}

/// What [`watertight_lanes`] finds: the lanes hit (those with a zero edge
/// function left out), the lanes whose edge function is exactly zero
/// (the scalar test redoes them in double precision), and each lane's t,
/// b1 and b2.
#[cfg(target_arch = "x86_64")]
pub struct WatertightLanes<F> {
    pub hits: u32,
    pub zero_edge: u32,
    pub t: F,
    pub b1: F,
    pub b2: F,
}

/// How [`watertight_lanes`] takes a triangle's vertices into its ray's
/// sheared frame: x' and y' first, for the edge functions, and what z'
/// needs kept until then (the test computes z' only for lanes still in the
/// running).
pub trait ShearLanes<F> {
    type Kept: Copy;
    /// x' and y' of the vertex `v`, and what z' needs of it.
    fn xy(&self, v: [F; 3]) -> (F, F, Self::Kept);
    /// z' of a vertex, from what [`ShearLanes::xy`] kept of it.
    fn z(&self, kept: Self::Kept) -> F;
}

/// Each lane its own ray: the lanes' origins `o` and the rows `r` of their
/// shears (a packet's rays, whose axis orders differ from lane to lane),
/// `e_kx - e_kz sx`, `e_ky - e_kz sy` and `e_kz sz` applied with every
/// product: [`RayShear::axes`]'s values wherever they are not zero.
#[cfg(target_arch = "x86_64")]
pub struct RowShear<F> {
    pub o: [F; 3],
    pub r: [F; 9],
}

#[cfg(target_arch = "x86_64")]
impl<
        F: Copy + std::ops::Add<Output = F> + std::ops::Sub<Output = F> + std::ops::Mul<Output = F>,
    > RowShear<F>
{
    #[inline(always)]
    fn row(&self, [x, y, z]: [F; 3], k: usize) -> F {
        x * self.r[k] + y * self.r[k + 1] + z * self.r[k + 2]
    }
}

#[cfg(target_arch = "x86_64")]
impl<
        F: Copy + std::ops::Add<Output = F> + std::ops::Sub<Output = F> + std::ops::Mul<Output = F>,
    > ShearLanes<F> for RowShear<F>
{
    /// The vertex relative to the origin.
    type Kept = [F; 3];

    #[inline(always)]
    fn xy(&self, [vx, vy, vz]: [F; 3]) -> (F, F, [F; 3]) {
        let rel = [vx - self.o[0], vy - self.o[1], vz - self.o[2]];
        (self.row(rel, 0), self.row(rel, 3), rel)
    }

    #[inline(always)]
    fn z(&self, rel: [F; 3]) -> F {
        self.row(rel, 6)
    }
}

/// One ray in every lane ([`RayShear::axes`]; [`intersect_triangle`]
/// shears with it too, a triangle's three vertices to a `Vec3A`): the
/// vertices come with their coordinates in the ray's axis order (kx, ky,
/// kz), as do the origin `o`, and `s` is (sx, sy, sz). x' = x - sx z,
/// y' = y - sy z, z' = sz z: [`RowShear`]'s products and sums without the
/// terms whose row entry is zero, each left out term a zero added to the
/// rest, so every value is the same wherever it is not zero, and a zero's
/// sign changes nothing the test finds: an edge function of either zero
/// sends its lane to the scalar test, and a depth of either zero is no
/// hit. Eight operations a vertex instead of eighteen, and one vector
/// kept for z' instead of three.
pub struct AxisShear<F> {
    pub o: [F; 3],
    pub s: [F; 3],
}

impl<F: Copy + std::ops::Sub<Output = F> + std::ops::Mul<Output = F>> ShearLanes<F>
    for AxisShear<F>
{
    /// The vertex's z relative to the origin.
    type Kept = F;

    #[inline(always)]
    fn xy(&self, [vx, vy, vz]: [F; 3]) -> (F, F, F) {
        let z = vz - self.o[2];
        let [sx, sy, _] = self.s;
        ((vx - self.o[0]) - sx * z, (vy - self.o[1]) - sy * z, z)
    }

    #[inline(always)]
    fn z(&self, z: F) -> F {
        self.s[2] * z
    }
}

/// [`intersect_triangle`]'s operations in SIMD lanes, each lane a ray
/// (its shear `shear`, range `tmin`..`tmax`) and a triangle (vertices
/// `v`): a packet's rays against one triangle splat in every lane
/// ([`RowShear`]), or one ray splat against a leaf's triangles
/// ([`AxisShear`]). `None` where every lane of `lanes` passes the
/// triangle by (the scalar test's first early `None`, as a mask).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub fn watertight_lanes<L: Lanes, S: ShearLanes<L::F>>(
    l: L,
    shear: &S,
    v: [[L::F; 3]; 3],
    tmin: L::F,
    tmax: L::F,
    lanes: u32,
) -> Option<WatertightLanes<L::F>> {
    let (xa, ya, ka) = shear.xy(v[0]);
    let (xb, yb, kb) = shear.xy(v[1]);
    let (xc, yc, kc) = shear.xy(v[2]);
    // `yt.cross(xt)`'s products and differences.
    let u = yb * xc - xb * yc;
    let v = yc * xa - xc * ya;
    let w = ya * xb - xa * yb;
    let zero = l.zero();
    let zero_edge = l.bits(l.m_or(l.m_or(l.eq(u, zero), l.eq(v, zero)), l.eq(w, zero))) & lanes;
    let below = l.m_or(l.m_or(l.lt(u, zero), l.lt(v, zero)), l.lt(w, zero));
    let above = l.m_or(l.m_or(l.gt(u, zero), l.gt(v, zero)), l.gt(w, zero));
    let outside = l.m_and(below, above);
    // Every live lane passes the triangle by (the scalar test's first
    // `None`), and none needs the scalar test: no hit, and the rest
    // (depths, division, error bounds) is skipped. Most tests of a packet
    // end here.
    if !l.bits(outside) & lanes == 0 && zero_edge == 0 {
        return None;
    }
    let (za, zb, zc) = (shear.z(ka), shear.z(kb), shear.z(kc));
    let det = u + v + w;
    let t_scaled = u * za + v * zb + w * zc;
    let inv_det = l.splat(1.0) / det;
    let t = t_scaled * inv_det;
    let in_range = l.m_and(l.gt(t, tmin), l.lt(t, tmax));
    // The scalar test's second and third `None` (no lane in range) are
    // left to the masks: on the Cornell box their branch mispredicted
    // more than the error bounds cost (valgrind's branch model: 3% fewer
    // mispredicts, 0.3% fewer instructions).
    let candidate = l.m_andnot(l.m_or(outside, l.eq(det, zero)), in_range);
    #[inline(always)]
    fn max3<L: Lanes>(l: L, a: L::F, b: L::F, c: L::F) -> L::F {
        l.max(l.max(l.abs(a), l.abs(b)), l.abs(c))
    }
    let (max_xt, max_yt, max_zt) = (
        max3(l, xa, xb, xc),
        max3(l, ya, yb, yc),
        max3(l, za, zb, zc),
    );
    let (g2, g3, g5) = (l.splat(gamma(2)), l.splat(gamma(3)), l.splat(gamma(5)));
    let delta_z = g3 * max_zt;
    let delta_x = g5 * (max_xt + max_zt);
    let delta_y = g5 * (max_yt + max_zt);
    let delta_e = l.splat(2.0) * (g2 * max_xt * max_yt + delta_y * max_xt + delta_x * max_yt);
    let max_e = max3(l, u, v, w);
    let delta_t =
        l.splat(3.0) * (g3 * max_e * max_zt + delta_e * max_zt + delta_z * max_e) * l.abs(inv_det);
    let hit = l.m_and(candidate, l.gt(t, delta_t));
    Some(WatertightLanes {
        hits: l.bits(hit) & lanes & !zero_edge,
        zero_edge,
        t,
        b1: v * inv_det,
        b2: w * inv_det,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hit_and_barycentrics() {
        let (p0, p1, p2) = (
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(1.0, 0.0, 1.0),
            Vec3::new(0.0, 1.0, 1.0),
        );
        let tri = PackedTriangle::new(p0, p1, p2);
        let o = Vec3::new(0.25, 0.25, 0.0);
        let d = Vec3::Z;
        let (t, b1, b2) =
            intersect_triangle(&RayShear::new(o, d), &tri, 0.0, f32::INFINITY).unwrap();
        assert!((t - 1.0).abs() < 1e-6);
        assert!((b1 - 0.25).abs() < 1e-6 && (b2 - 0.25).abs() < 1e-6);
        let miss = Vec3::new(0.8, 0.8, 0.0);
        assert!(intersect_triangle(&RayShear::new(miss, d), &tri, 0.0, 9.0).is_none());
    }

    #[test]
    fn shared_edge_is_hit_once_or_more_never_missed() {
        // Two triangles sharing the diagonal of a unit square; rays along it.
        let q = [
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(1.0, 0.0, 1.0),
            Vec3::new(1.0, 1.0, 1.0),
            Vec3::new(0.0, 1.0, 1.0),
        ];
        let t1 = PackedTriangle::new(q[0], q[1], q[2]);
        let t2 = PackedTriangle::new(q[0], q[2], q[3]);
        for i in 0..1000 {
            let s = i as f32 / 999.0;
            let o = Vec3::new(s, s, -3.0);
            let d = Vec3::new(0.1 * s - 0.05, 0.013, 1.0).normalize();
            let o = o - d * (4.0 / d.z) + d * (4.0 / d.z); // keep on diagonal at z=1 approx
            let sh = RayShear::new(o, d);
            let h1 = intersect_triangle(&sh, &t1, 0.0, 1e9).is_some();
            let h2 = intersect_triangle(&sh, &t2, 0.0, 1e9).is_some();
            let target = o + d * ((1.0 - o.z) / d.z);
            let inside = (0.0..=1.0).contains(&target.x) && (0.0..=1.0).contains(&target.y);
            if inside {
                assert!(h1 || h2, "ray {i} slipped through the shared edge");
            }
        }
    }
}
