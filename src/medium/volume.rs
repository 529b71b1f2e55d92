//! Volumes: values that vary through space (Mitsuba 3's `constvolume`
//! and `gridvolume`), read by media for their extinction and albedo.
//!
//! A volume lives in the unit cube of its own coordinates, placed in the
//! world by `to_world`; Mitsuba bounds heterogeneous media by that cube
//! (a constant volume included). Grids are looked up the way Dr.Jit's
//! `Texture3f` does: trilinear between voxel centres (voxel i's centre at
//! (i + 1/2) / res), or the voxel holding the point; coordinates outside
//! [0, 1] wrap by `wrap_mode` (clamp, repeat, mirror).

use std::sync::Arc;

use super::vol_file::VolumeGrid;
use crate::color::Rgb;
use crate::math::{Aabb, Transform, Vec3};
use crate::texture::bounded;
pub use crate::texture::WrapMode;

/// Mitsuba's grid `filter_type`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VolumeFilter {
    Trilinear,
    Nearest,
}

/// A grid of 1- or 3-channel values and how it is looked up.
#[derive(Clone, Debug, PartialEq)]
pub struct GridLookup {
    pub grid: Arc<VolumeGrid>,
    pub filter: VolumeFilter,
    pub wrap: WrapMode,
}

#[derive(Clone, Debug, PartialEq)]
pub enum VolumeData {
    Constant(Rgb),
    Grid(GridLookup),
}

/// A volume placed in the world.
#[derive(Clone, Debug, PartialEq)]
pub struct Volume {
    pub data: VolumeData,
    /// World to the volume's unit cube.
    pub to_local: Transform,
    /// The unit cube's bounds in the world.
    pub bbox: Aabb,
}

impl Volume {
    /// A volume with `data` whose unit cube `to_world` places.
    pub fn new(data: VolumeData, to_world: Transform) -> Volume {
        let mut bbox = Aabb::EMPTY;
        for i in 0..8 {
            let corner = Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, (i >> 2) as f32);
            bbox = bbox.extend(to_world.point(corner));
        }
        Volume {
            data,
            to_local: to_world.inverse(),
            bbox,
        }
    }

    /// The same value everywhere (the unit cube at the origin bounds it).
    pub fn constant(value: Rgb) -> Volume {
        Volume::new(VolumeData::Constant(value), Transform::IDENTITY)
    }

    /// The constant, if the volume is one.
    pub fn as_constant(&self) -> Option<Rgb> {
        match self.data {
            VolumeData::Constant(c) => Some(c),
            VolumeData::Grid(_) => None,
        }
    }

    /// The value at world point `p`.
    #[inline]
    pub fn eval(&self, p: Vec3) -> Rgb {
        match &self.data {
            VolumeData::Constant(c) => *c,
            VolumeData::Grid(g) => g.eval(self.to_local.point(p)),
        }
    }

    /// The largest value of any channel anywhere (Mitsuba's `max()`).
    pub fn max(&self) -> f32 {
        match &self.data {
            VolumeData::Constant(c) => c.max_element(),
            VolumeData::Grid(g) => g.grid.max(),
        }
    }

    /// The smallest value of any channel anywhere.
    pub fn min(&self) -> f32 {
        match &self.data {
            VolumeData::Constant(c) => c.min_element(),
            VolumeData::Grid(g) => g.grid.min(),
        }
    }
}

impl GridLookup {
    /// The value at `q`, in the grid's unit-cube coordinates.
    #[inline]
    pub fn eval(&self, q: Vec3) -> Rgb {
        let g = &*self.grid;
        let [nx, ny, nz] = g.res;
        match self.filter {
            VolumeFilter::Nearest => {
                let ix = self.wrap.wrap(bounded(q.x * nx as f32).floor() as i64, nx);
                let iy = self.wrap.wrap(bounded(q.y * ny as f32).floor() as i64, ny);
                let iz = self.wrap.wrap(bounded(q.z * nz as f32).floor() as i64, nz);
                self.voxel(ix, iy, iz)
            }
            VolumeFilter::Trilinear => {
                let axis = |x: f32, n: usize| {
                    let p = bounded(x * n as f32 - 0.5);
                    let f = p.floor();
                    let i = f as i64;
                    (
                        self.wrap.wrap(i, n),
                        self.wrap.wrap(i.saturating_add(1), n),
                        p - f,
                    )
                };
                let (x0, x1, tx) = axis(q.x, nx);
                let (y0, y1, ty) = axis(q.y, ny);
                let (z0, z1, tz) = axis(q.z, nz);
                let lerp = |a: Rgb, b: Rgb, t: f32| a * (1.0 - t) + b * t;
                let plane = |z| {
                    let a = lerp(self.voxel(x0, y0, z), self.voxel(x1, y0, z), tx);
                    let b = lerp(self.voxel(x0, y1, z), self.voxel(x1, y1, z), tx);
                    lerp(a, b, ty)
                };
                lerp(plane(z0), plane(z1), tz)
            }
        }
    }

    #[inline]
    fn voxel(&self, x: usize, y: usize, z: usize) -> Rgb {
        let g = &*self.grid;
        let i = ((z * g.res[1] + y) * g.res[0] + x) * g.channels;
        if g.channels == 1 {
            Rgb::splat(g.data[i])
        } else {
            Rgb::new(g.data[i], g.data[i + 1], g.data[i + 2])
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Mat4;

    /// A 2 x 1 x 1 grid: 0 in the left voxel, 1 in the right one.
    fn ramp(filter: VolumeFilter, wrap: WrapMode) -> GridLookup {
        GridLookup {
            grid: Arc::new(VolumeGrid {
                res: [2, 1, 1],
                channels: 1,
                bbox: Aabb {
                    min: Vec3::ZERO,
                    max: Vec3::ONE,
                },
                data: vec![0.0, 1.0],
            }),
            filter,
            wrap,
        }
    }

    /// Trilinear lookups interpolate between voxel centres (x = 1/4 and
    /// 3/4 here) and hold the edge value beyond them under clamp.
    #[test]
    fn trilinear_interpolates_between_voxel_centres() {
        let g = ramp(VolumeFilter::Trilinear, WrapMode::Clamp);
        let at = |x: f32| g.eval(Vec3::new(x, 0.5, 0.5)).x;
        assert_eq!(at(0.25), 0.0);
        assert_eq!(at(0.75), 1.0);
        assert!((at(0.5) - 0.5).abs() < 1e-6);
        assert!((at(0.375) - 0.25).abs() < 1e-6);
        assert_eq!(at(0.0), 0.0);
        assert_eq!(at(1.5), 1.0);
        assert_eq!(at(f32::NAN), 0.0);
        // Repeat: beyond the right centre the left voxel follows.
        let r = ramp(VolumeFilter::Trilinear, WrapMode::Repeat);
        assert!((r.eval(Vec3::new(1.0, 0.5, 0.5)).x - 0.5).abs() < 1e-6);
    }

    #[test]
    fn nearest_reads_the_voxel_holding_the_point() {
        let g = ramp(VolumeFilter::Nearest, WrapMode::Mirror);
        let at = |x: f32| g.eval(Vec3::new(x, 0.5, 0.5)).x;
        assert_eq!(at(0.49), 0.0);
        assert_eq!(at(0.51), 1.0);
        // Mirrored: [1, 1.5) reads the right voxel again.
        assert_eq!(at(1.2), 1.0);
        assert_eq!(at(1.7), 0.0);
    }

    /// `to_world` places the unit cube; lookups go through its inverse.
    #[test]
    fn to_world_places_the_cube() {
        let to_world = Transform::new(
            Mat4::from_translation(Vec3::new(-0.5, -0.5, -0.5))
                * Mat4::from_scale(Vec3::splat(1.5)),
        )
        .unwrap();
        let v = Volume::new(
            VolumeData::Grid(ramp(VolumeFilter::Nearest, WrapMode::Clamp)),
            to_world,
        );
        assert!((v.bbox.min - Vec3::splat(-0.5)).abs().max_element() < 1e-6);
        assert!((v.bbox.max - Vec3::splat(1.0)).abs().max_element() < 1e-6);
        assert_eq!(v.eval(Vec3::new(-0.4, 0.0, 0.0)).x, 0.0);
        assert_eq!(v.eval(Vec3::new(0.9, 0.0, 0.0)).x, 1.0);
        assert_eq!(v.max(), 1.0);
        assert_eq!(Volume::constant(Rgb::splat(2.0)).bbox.max, Vec3::ONE);
    }
}
