//! Four light samples of emitting meshes at a time, in SIMD lanes: what
//! [`AreaLight::sample_into`] computes for a tabulated triangle of constant
//! radiance that it samples by area (the Cornell box's light, from almost
//! every point), each lane bit for bit the scalar routine's (the same
//! operations in the same order, its branches as masks; tested). The
//! scalar routine is a chain of square roots and divisions (the solid-angle
//! test's, the distance's, the direction's, the density's and the
//! weight's, one after the other) that four lanes run once; it was 14% of
//! the Cornell box's render. Lanes the routine would sample by solid
//! angle, or whose triangle has no fixed emitting side, are drawn by it.

use super::{AreaLight, EmitterContext, LightSample};
use crate::geometry::TriangleMesh;
use crate::math::{gamma, sqrt4, Lanes3, Vec2, Vec3, Vec4};
use crate::sampling::spherical_triangle::MIN_SOLID_ANGLE;

/// A light sample an [`AreaLight`] draws on its mesh: the light (one
/// that [`AreaLight::samples_in_lanes`]), its mesh, the shading point and
/// the numbers (`u` on the triangle, `u1` choosing it).
#[derive(Clone, Copy)]
pub struct TriangleRequest<'a> {
    pub light: &'a AreaLight,
    pub mesh: &'a TriangleMesh,
    pub p: Vec3,
    pub u: Vec2,
    pub u1: f32,
}

/// [`AreaLight::sample_into`] of each of the first `n` of `requests` (1 to
/// 4, each `Some`; lanes beyond them repeat the last and are dropped) into
/// `lights[slots[k]]`.
pub fn sample_triangles_lanes(
    ctx: &EmitterContext,
    requests: &[Option<TriangleRequest>; 4],
    n: usize,
    slots: &[usize; 4],
    lights: &mut [Option<LightSample>],
) {
    let r: [&TriangleRequest; 4] = std::array::from_fn(|k| {
        requests[k.min(n - 1)]
            .as_ref()
            .expect("the first n requests are filled")
    });
    // The triangles, chosen one lane at a time.
    let tri = r.map(|r| r.mesh.choose_triangle(r.u1).0);
    let t = std::array::from_fn::<_, 4, _>(|k| {
        r[k].light
            .constant_table_triangle(tri[k])
            .expect("a request's light samples in lanes")
    });
    let p = Lanes3::gather(r.map(|r| &r.p));
    // `spherical`'s first test: true where it samples by area.
    let to_c = Lanes3::gather(t.map(|t| &t.centroid)).sub(&p);
    let d2c = to_c.length_squared();
    let projected = Vec4::splat(0.5) * Lanes3::gather(t.map(|t| &t.cross)).dot(&to_c).abs();
    let limit = Vec4::splat(0.25 * MIN_SOLID_ANGLE) * d2c * sqrt4(d2c);
    let by_area = projected.cmplt(limit).bitmask();
    // `square_to_uniform_triangle`, then `LightTriangle::surface_point`
    // (`TriangleMesh::barycentric_point`: the point b0 v0 + b1 v1 + b2 v2
    // and its error bound).
    let su = sqrt4(Vec4::from_array(r.map(|r| r.u.x)));
    let (b1, b2) = (Vec4::ONE - su, Vec4::from_array(r.map(|r| r.u.y)) * su);
    let b0 = Vec4::ONE - b1 - b2;
    let v = [0, 1, 2].map(|i| Lanes3::gather(t.map(|t| &t.v[i])));
    let [w0, w1, w2] = [(b0, &v[0]), (b1, &v[1]), (b2, &v[2])].map(|(b, v)| v.map(|c| b * c));
    let point = Lanes3 {
        x: w0.x + w1.x + w2.x,
        y: w0.y + w1.y + w2.y,
        z: w0.z + w1.z + w2.z,
    };
    let g7 = Vec4::splat(gamma(7));
    let err = Lanes3 {
        x: (w0.x.abs() + w1.x.abs() + w2.x.abs()) * g7,
        y: (w0.y.abs() + w1.y.abs() + w2.y.abs()) * g7,
        z: (w0.z.abs() + w1.z.abs() + w2.z.abs()) * g7,
    };
    let normal = Lanes3::gather(t.map(|t| t.front_ref().unwrap_or(&Vec3::ZERO)));
    let pdf_area = Vec4::ONE / Vec4::from_array(r.map(|r| r.mesh.area()));
    // The direction, distance, density and weight.
    let to = point.sub(&p);
    let d2 = to.length_squared();
    let dist = sqrt4(d2);
    let wi = to.map(|c| c / dist);
    let cos_l = -wi.dot(&normal);
    let pdf = pdf_area * d2 / cos_l;
    let radiance = Lanes3::gather(r.map(|r| &r.light.radiance));
    let weight = radiance.map(|c| c / pdf);
    // `d2 <= 0` and `cos_l <= 0` give no sample (NaNs go on, as there).
    let none = d2.cmple(Vec4::ZERO).bitmask() | cos_l.cmple(Vec4::ZERO).bitmask();
    for (k, &slot) in slots.iter().enumerate().take(n) {
        let out = &mut lights[slot];
        if by_area & (1 << k) == 0 || t[k].front_ref().is_none() {
            let r = r[k];
            r.light.sample_into(ctx, r.p, r.u, r.u1, out);
            continue;
        }
        *out = (none & (1 << k) == 0).then(|| LightSample {
            wi: wi.lane(k),
            p: point.lane(k),
            err: err.lane(k),
            n: normal.lane(k),
            dist: dist[k],
            weight: weight.lane(k),
            pdf: pdf[k],
            delta: false,
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Geometry;
    use crate::sampling::Sampler;

    fn bits(s: &Option<LightSample>) -> Option<Vec<u32>> {
        s.map(|s| {
            [s.wi, s.p, s.err, s.n, s.weight]
                .iter()
                .flat_map(|v| v.to_array())
                .chain([s.dist, s.pdf, f32::from(u8::from(s.delta))])
                .map(f32::to_bits)
                .collect()
        })
    }

    /// Lights of two triangles (a Cornell-box-like square, and one whose
    /// vertex normals disagree, so it has no fixed side), seen from points
    /// far, near, behind and on their plane: every lane is
    /// `sample_into`'s sample bit for bit, for groups of one to four, and
    /// both the lanes' and the scalar routine's draws occur.
    #[test]
    fn lanes_draw_what_sample_into_draws() {
        let square = TriangleMesh::new(
            vec![
                Vec3::new(-0.25, 1.98, -0.2),
                Vec3::new(0.25, 1.98, -0.2),
                Vec3::new(0.25, 1.98, 0.3),
                Vec3::new(-0.25, 1.98, 0.3),
            ],
            vec![],
            vec![],
            vec![[0, 2, 1], [0, 3, 2]],
        )
        .unwrap();
        let twisted = TriangleMesh::new(
            vec![
                Vec3::new(0.0, 0.0, 0.0),
                Vec3::new(1.0, 0.0, 0.0),
                Vec3::new(0.0, 1.0, 0.2),
            ],
            vec![Vec3::Z, -Vec3::Z, Vec3::Z],
            vec![],
            vec![[0, 1, 2]],
        )
        .unwrap();
        let shapes = [Geometry::Mesh(square), Geometry::Mesh(twisted)];
        let ctx = EmitterContext {
            shapes: &shapes,
            scene_radius: 10.0,
        };
        let lights: Vec<AreaLight> = (0..2)
            .map(|i| {
                AreaLight::new(i, Vec3::new(17.0, 12.0, 4.0))
                    .unwrap()
                    .with_triangles(&shapes[i as usize])
            })
            .collect();
        assert!(lights.iter().all(AreaLight::samples_in_lanes));
        let mut s = Sampler::new(3, 9);
        let (mut in_lanes, mut scalar) = (0, 0);
        for round in 0..3000 {
            let n = 1 + round % 4;
            let requests: [TriangleRequest; 4] = std::array::from_fn(|_| {
                let i = (s.next_1d() * 2.0) as usize;
                let Geometry::Mesh(mesh) = &shapes[i] else {
                    unreachable!()
                };
                // Points anywhere in a box around the lights, some close
                // to them, some on the square's plane.
                let mut p = Vec3::new(
                    4.0 * s.next_1d() - 2.0,
                    4.0 * s.next_1d() - 1.0,
                    4.0 * s.next_1d() - 2.0,
                );
                match round % 7 {
                    0 => p = p * 0.05 + Vec3::new(0.0, 1.9, 0.0),
                    1 => p.y = 1.98,
                    _ => {}
                }
                TriangleRequest {
                    light: &lights[i],
                    mesh,
                    p,
                    u: s.next_2d(),
                    u1: s.next_1d(),
                }
            });
            let mut got = [None; 4];
            sample_triangles_lanes(&ctx, &requests.map(Some), n, &[0, 1, 2, 3], &mut got);
            for (k, r) in requests.iter().enumerate().take(n) {
                let mut want = None;
                r.light.sample_into(&ctx, r.p, r.u, r.u1, &mut want);
                assert_eq!(bits(&got[k]), bits(&want), "round {round} lane {k}");
                let t = r.mesh.choose_triangle(r.u1).0;
                let tri = r.light.constant_table_triangle(t).unwrap();
                let to_c = tri.centroid - r.p;
                let d2 = to_c.length_squared();
                let far = 0.5 * tri.cross.dot(to_c).abs() < 0.25 * MIN_SOLID_ANGLE * d2 * d2.sqrt();
                if far && tri.front_ref().is_some() {
                    in_lanes += 1;
                } else {
                    scalar += 1;
                }
            }
        }
        assert!(in_lanes > 1000 && scalar > 1000, "{in_lanes} {scalar}");
    }
}
