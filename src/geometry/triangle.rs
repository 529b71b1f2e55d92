//! Watertight ray/triangle intersection (Woop, Benthin and Wald, JCGT 2013):
//! rays through shared edges or vertices hit exactly one of the triangles.

use crate::math::{gamma, Vec3};

/// Per-ray precomputation for the watertight test: the axis permutation and
/// shear that map the ray direction onto +z.
#[derive(Clone, Copy, Debug)]
pub struct RayShear {
    kx: usize,
    ky: usize,
    kz: usize,
    sx: f32,
    sy: f32,
    sz: f32,
}

impl RayShear {
    pub fn new(d: Vec3) -> RayShear {
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
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        RayShear {
            kx,
            ky,
            kz,
            sx: d[kx] / d[kz],
            sy: d[ky] / d[kz],
            sz: 1.0 / d[kz],
        }
    }
}

/// Returns (t, b1, b2) for a hit with t in (tmin, tmax); b1, b2 weight
/// vertices 1 and 2.
#[inline]
pub fn intersect_triangle(
    o: Vec3,
    shear: &RayShear,
    p0: Vec3,
    p1: Vec3,
    p2: Vec3,
    tmin: f32,
    tmax: f32,
) -> Option<(f32, f32, f32)> {
    let RayShear {
        kx,
        ky,
        kz,
        sx,
        sy,
        sz,
    } = *shear;
    let a = p0 - o;
    let b = p1 - o;
    let c = p2 - o;
    let ax = a[kx] - sx * a[kz];
    let ay = a[ky] - sy * a[kz];
    let bx = b[kx] - sx * b[kz];
    let by = b[ky] - sy * b[kz];
    let cx = c[kx] - sx * c[kz];
    let cy = c[ky] - sy * c[kz];
    let mut u = cx * by - cy * bx;
    let mut v = ax * cy - ay * cx;
    let mut w = bx * ay - by * ax;
    if u == 0.0 || v == 0.0 || w == 0.0 {
        // Edge case: redo in double precision so shared edges stay watertight.
        let (ax, ay, bx, by, cx, cy) = (
            ax as f64, ay as f64, bx as f64, by as f64, cx as f64, cy as f64,
        );
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
    let az = sz * a[kz];
    let bz = sz * b[kz];
    let cz = sz * c[kz];
    let t_scaled = u * az + v * bz + w * cz;
    let inv_det = 1.0 / det;
    let t = t_scaled * inv_det;
    if !(t > tmin && t < tmax) {
        return None;
    }
    // Reject hits whose t is within its own rounding error of zero (pbrt's
    // conservative bound): a ray spawned on this very triangle.
    {
        let max_zt = az.abs().max(bz.abs()).max(cz.abs());
        let max_xt = ax.abs().max(bx.abs()).max(cx.abs());
        let max_yt = ay.abs().max(by.abs()).max(cy.abs());
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
        let o = Vec3::new(0.25, 0.25, 0.0);
        let d = Vec3::Z;
        let (t, b1, b2) =
            intersect_triangle(o, &RayShear::new(d), p0, p1, p2, 0.0, f32::INFINITY).unwrap();
        assert!((t - 1.0).abs() < 1e-6);
        assert!((b1 - 0.25).abs() < 1e-6 && (b2 - 0.25).abs() < 1e-6);
        let miss = Vec3::new(0.8, 0.8, 0.0);
        assert!(intersect_triangle(miss, &RayShear::new(d), p0, p1, p2, 0.0, 9.0).is_none());
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
        for i in 0..1000 {
            let s = i as f32 / 999.0;
            let o = Vec3::new(s, s, -3.0);
            let d = Vec3::new(0.1 * s - 0.05, 0.013, 1.0).normalize();
            let o = o - d * (4.0 / d.z) + d * (4.0 / d.z); // keep on diagonal at z=1 approx
            let sh = RayShear::new(d);
            let h1 = intersect_triangle(o, &sh, q[0], q[1], q[2], 0.0, 1e9).is_some();
            let h2 = intersect_triangle(o, &sh, q[0], q[2], q[3], 0.0, 1e9).is_some();
            let target = o + d * ((1.0 - o.z) / d.z);
            let inside = (0.0..=1.0).contains(&target.x) && (0.0..=1.0).contains(&target.y);
            if inside {
                assert!(h1 || h2, "ray {i} slipped through the shared edge");
            }
        }
    }
}
