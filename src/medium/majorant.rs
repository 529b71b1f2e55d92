//! Majorants that follow the density: a coarse grid over a heterogeneous
//! medium's extinction volume, each cell holding the largest extinction
//! any lookup inside it can return, walked cell by cell along a ray
//! (Amanatides-Woo). Delta and ratio tracking then take tentative
//! collisions at each cell's own rate, so the empty parts of a sparse
//! medium cost nothing and its thin parts little, where one majorant for
//! the whole box (Mitsuba's) spends most collisions on null ones.
//!
//! Built only for grids placed by an axis-aligned scale and translation
//! (the usual `to_world`, and `use_grid_bbox`), whose unit cube is then
//! exactly the medium's box; other placements use the single majorant.

use super::volume::{Volume, VolumeData};
use crate::math::{Ray, Transform};

/// Cells per axis at most (a cell per voxel below that).
const MAX_CELLS: usize = 32;

#[derive(Clone, Debug, PartialEq)]
pub struct MajorantGrid {
    /// Cells along x, y and z.
    n: [usize; 3],
    /// Each cell's majorant (`scale` applied), x fastest.
    max: Vec<f32>,
}

/// One stretch of a ray inside one cell: `[t0, t1)` and its majorant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Segment {
    pub t0: f32,
    pub t1: f32,
    pub majorant: f32,
}

impl MajorantGrid {
    /// The grid for `sigma_t` scaled by `scale`, if the volume is a grid
    /// placed without rotation, shear or projection.
    pub fn new(sigma_t: &Volume, scale: f32) -> Option<MajorantGrid> {
        let VolumeData::Grid(lookup) = &sigma_t.data else {
            return None;
        };
        let m = sigma_t.to_local.m;
        let off_diagonal = [
            m.x_axis.y, m.x_axis.z, m.y_axis.x, m.y_axis.z, m.z_axis.x, m.z_axis.y,
        ];
        if off_diagonal.iter().any(|&v| v != 0.0)
            || m.x_axis.w != 0.0
            || m.y_axis.w != 0.0
            || m.z_axis.w != 0.0
            || m.w_axis.w != 1.0
        {
            return None;
        }
        let g = &*lookup.grid;
        let n = g.res.map(|r| r.min(MAX_CELLS));
        // The voxel indices a lookup in cell i (of n) along an axis of res
        // voxels may read, for either filter: trilinear reads the voxels
        // around q res - 1/2, nearest the one at q res; one more each side
        // covers both and rounding. Wrapped as the lookups wrap them.
        let reach = |i: usize, n: usize, res: usize| {
            let lo = (i * res / n) as i64 - 1;
            let hi = ((i + 1) * res).div_ceil(n) as i64 + 1;
            let mut idx: Vec<usize> = (lo..=hi).map(|j| lookup.wrap.wrap(j, res)).collect();
            idx.sort_unstable();
            idx.dedup();
            idx
        };
        let per_axis: Vec<Vec<Vec<usize>>> = (0..3)
            .map(|a| (0..n[a]).map(|i| reach(i, n[a], g.res[a])).collect())
            .collect();
        let voxel_max = |x: usize, y: usize, z: usize| {
            let i = ((z * g.res[1] + y) * g.res[0] + x) * g.channels;
            let c = g.channels.min(3);
            g.data[i..i + c].iter().fold(0.0f32, |m, &v| m.max(v))
        };
        let mut max = Vec::with_capacity(n[0] * n[1] * n[2]);
        for cz in 0..n[2] {
            for cy in 0..n[1] {
                for cx in 0..n[0] {
                    let mut m = 0.0f32;
                    for &z in &per_axis[2][cz] {
                        for &y in &per_axis[1][cy] {
                            for &x in &per_axis[0][cx] {
                                m = m.max(voxel_max(x, y, z));
                            }
                        }
                    }
                    max.push(m * scale);
                }
            }
        }
        Some(MajorantGrid { n, max })
    }

    /// The largest cell majorant.
    pub fn max(&self) -> f32 {
        self.max.iter().fold(0.0f32, |m, &v| m.max(v))
    }

    /// The cells `ray` crosses between `t0` and `t1` (inside the box),
    /// in order, with `to_local` mapping the world to the unit cube.
    pub fn walk(&self, to_local: &Transform, ray: &Ray, t0: f32, t1: f32) -> Walk<'_> {
        let o = to_local.point(ray.o);
        let d = to_local.vector(ray.d);
        let n = self.n.map(|v| v as f32);
        let start = o + d * t0;
        let mut cell = [0i64; 3];
        let mut next = [f32::INFINITY; 3];
        let mut delta = [f32::INFINITY; 3];
        let mut step = [0i64; 3];
        for a in 0..3 {
            let c = ((start[a] * n[a]).floor() as i64).clamp(0, self.n[a] as i64 - 1);
            cell[a] = c;
            if d[a] > 0.0 {
                step[a] = 1;
                next[a] = ((c + 1) as f32 / n[a] - o[a]) / d[a];
                delta[a] = 1.0 / (n[a] * d[a]);
            } else if d[a] < 0.0 {
                step[a] = -1;
                next[a] = (c as f32 / n[a] - o[a]) / d[a];
                delta[a] = -1.0 / (n[a] * d[a]);
            }
        }
        Walk {
            grid: self,
            cell,
            next,
            delta,
            step,
            t: t0,
            t_end: t1,
            left: self.n.iter().sum::<usize>() + 3,
        }
    }
}

/// The iterator [`MajorantGrid::walk`] returns.
pub struct Walk<'g> {
    grid: &'g MajorantGrid,
    cell: [i64; 3],
    next: [f32; 3],
    delta: [f32; 3],
    step: [i64; 3],
    t: f32,
    t_end: f32,
    /// Cells it may still visit (a ray crosses at most the sum of the
    /// axes' counts; this bounds the walk whatever the rounding).
    left: usize,
}

impl Iterator for Walk<'_> {
    type Item = Segment;

    fn next(&mut self) -> Option<Segment> {
        if self.t >= self.t_end || self.left == 0 {
            return None;
        }
        self.left -= 1;
        let n = self.grid.n;
        let inside = (0..3).all(|a| (0..n[a] as i64).contains(&self.cell[a]));
        if !inside {
            return None;
        }
        let a = if self.next[0] <= self.next[1] && self.next[0] <= self.next[2] {
            0
        } else if self.next[1] <= self.next[2] {
            1
        } else {
            2
        };
        let t1 = self.next[a].min(self.t_end).max(self.t);
        let [x, y, z] = self.cell.map(|c| c as usize);
        let majorant = self.grid.max[(z * n[1] + y) * n[0] + x];
        let seg = Segment {
            t0: self.t,
            t1,
            majorant,
        };
        self.t = t1;
        self.cell[a] += self.step[a];
        self.next[a] += self.delta[a];
        Some(seg)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{Mat4, Vec3};
    use crate::medium::volume::{GridLookup, VolumeFilter, WrapMode};
    use crate::medium::VolumeGrid;
    use crate::sampling::Sampler;
    use std::sync::Arc;

    /// A 9 x 5 x 3 one-channel grid of mostly zeros with a few hot voxels
    /// (one at a corner, for the wrap modes), placed by `to_world`.
    fn volume(filter: VolumeFilter, wrap: WrapMode, to_world: Transform) -> Volume {
        let res = [9, 5, 3];
        let mut data = vec![0.0f32; 9 * 5 * 3];
        for (x, y, z, v) in [
            (4, 2, 1, 3.0),
            (0, 0, 0, 2.0),
            (8, 4, 2, 1.0),
            (6, 1, 0, 0.5),
        ] {
            data[(z * 5 + y) * 9 + x] = v;
        }
        let grid = VolumeGrid {
            res,
            channels: 1,
            bbox: crate::math::Aabb {
                min: Vec3::ZERO,
                max: Vec3::ONE,
            },
            data,
        };
        Volume::new(
            VolumeData::Grid(GridLookup {
                grid: Arc::new(grid),
                filter,
                wrap,
            }),
            to_world,
        )
    }

    fn placed() -> Transform {
        Transform::new(
            Mat4::from_translation(Vec3::new(-1.0, 0.5, 2.0))
                * Mat4::from_scale(Vec3::new(2.0, -1.0, 0.5)),
        )
        .unwrap()
    }

    /// Along random rays through the box, the segments tile the range
    /// exactly, and every lookup inside a segment is at most its
    /// majorant, for both filters and every wrap mode (the cells' voxel
    /// reach is right); the empty cells have majorant zero.
    #[test]
    fn cells_bound_every_lookup_and_tile_the_ray() {
        let mut s = Sampler::new(5, 6);
        for filter in [VolumeFilter::Trilinear, VolumeFilter::Nearest] {
            for wrap in [WrapMode::Clamp, WrapMode::Repeat, WrapMode::Mirror] {
                let v = volume(filter, wrap, placed());
                let g = MajorantGrid::new(&v, 1.5).expect("axis-aligned placement");
                assert!(g.max.contains(&0.0), "{filter:?} {wrap:?}: no empty cell");
                for _ in 0..400 {
                    let o = v.bbox.min - Vec3::ONE
                        + 3.0 * (v.bbox.max - v.bbox.min) * s.next_2d().extend(s.next_1d());
                    let target =
                        v.bbox.min + (v.bbox.max - v.bbox.min) * s.next_2d().extend(s.next_1d());
                    let ray = Ray::new(o, (target - o).normalize());
                    let Some((t0, t1)) = v.bbox.ray_range(ray.o, ray.d, f32::INFINITY) else {
                        continue;
                    };
                    let segs: Vec<Segment> = g.walk(&v.to_local, &ray, t0, t1).collect();
                    assert!(!segs.is_empty());
                    assert_eq!(segs[0].t0, t0);
                    let end = segs.last().unwrap().t1;
                    assert!((end - t1).abs() <= 1e-4 * t1.max(1.0), "{end} vs {t1}");
                    for w in segs.windows(2) {
                        assert_eq!(w[0].t1, w[1].t0);
                    }
                    for seg in &segs {
                        for k in 0..8 {
                            let t = seg.t0 + (seg.t1 - seg.t0) * (k as f32 + 0.5) / 8.0;
                            let sigma = v.eval(ray.at(t)).max_element() * 1.5;
                            assert!(
                                sigma <= seg.majorant * (1.0 + 1e-5) + 1e-6,
                                "{filter:?} {wrap:?}: {sigma} above {}",
                                seg.majorant
                            );
                        }
                    }
                }
            }
        }
    }

    /// Rotated placements have no grid (the unit cube is not the box).
    #[test]
    fn rotated_volumes_use_the_single_majorant() {
        let r = Transform::new(Mat4::from_rotation_y(0.3)).unwrap();
        assert!(
            MajorantGrid::new(&volume(VolumeFilter::Trilinear, WrapMode::Clamp, r), 1.0).is_none()
        );
        assert!(MajorantGrid::new(&Volume::constant(crate::color::Rgb::ONE), 1.0).is_none());
    }
}
