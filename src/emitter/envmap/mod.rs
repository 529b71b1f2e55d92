//! Image-based lighting from a lat-long HDR probe.
//!
//! # Convention
//!
//! For a unit direction `(x, y, z)` in the map's local frame (the world
//! direction taken through the inverse of `to_world`):
//!
//! ```text
//! theta = atan2(sqrt(x^2 + z^2), y),  phi = atan2(x, -z)
//! u = phi / 2pi wrapped into [0, 1) (rem_euclid),  v = theta / pi clamped to [0, 1]
//! ```
//!
//! so the left edge (u = 0) looks down -z, u = 0.25 down +x, the centre column
//! (u = 0.5) down +z, u = 0.75 down -x, and the top row (v = 0) is +y. The
//! inverse is `phi = 2 pi u`, `theta = pi v`,
//! `d = (sin theta sin phi, cos theta, -sin theta cos phi)`
//! ([`EnvMap::uv_to_dir`], [`EnvMap::dir_to_uv`], in `latlong.rs`; the
//! angles use [`fast_atan2`](crate::math::fast_atan2), within 6e-7 rad).
//!
//! `to_world` must be a rotation (reflections and uniform scale are harmless:
//! directions are renormalised). A shear or non-uniform scale would distort
//! solid angles and make `pdf` disagree with `sample`.
//!
//! # Lookup
//!
//! Radiance is `texel * scale`. Texel `i` of a row is centred at
//! `u = (i + 0.5) / W` and u wraps; where rows sit along v is the map's
//! [`TexelRows`]: cell centres `(j + 0.5) / H` with v clamped beyond the
//! first and last (lente, Nori), or `j / (H - 1)` from pole to pole
//! (Mitsuba). [`EnvFilter::Bilinear`] interpolates between those texel
//! positions, [`EnvFilter::Nearest`] returns the nearest texel (`grid.rs`
//! holds both rules). A map with texels that are negative or not finite is
//! refused when it is built (a light cannot emit negative or infinite
//! radiance); scene files' maps come through the image loader, which clamps
//! negative texels to zero with a warning.
//!
//! # Importance sampling
//!
//! The density over (u, v) follows luminance x sin(theta) the way the
//! lookup does (`warp.rs`): with the bilinear filter it is the bilinear
//! interpolant, inside each cell, of luminance x sin(theta) at the
//! interpolation vertices, so around a texel-sized sun the density falls
//! off exactly as the radiance does; with the nearest filter it is constant
//! per texel (luminance x sin of the texel's middle). The solid-angle
//! density is `pdf_uv / (2 pi^2 sin theta)`, theta of the direction itself.
//! Both vanish only where the lookup's luminance does (or on the poles, a
//! set of measure zero): `pdf > 0` wherever `eval > 0`.
//!
//! Two densities are built: the complete one, and for multiple importance
//! sampling ([`LightPdf::MisCompensated`]) one made from
//! `max(luminance - mean, 0)` (Karlik et al. 2019, "MIS compensation"),
//! which leaves the smooth part of the sky to BSDF sampling and spends the
//! light samples on what is brighter than average. That density is zero
//! where the map is dimmer than its mean, so it is only valid where BSDF
//! sampling covers those directions, which is what MIS guarantees. For
//! nearly constant maps (mean - minimum <= 1% of the mean) both are the
//! same.
//!
//! For a surface that only reflects, a third density per density above
//! ([`EnvMap::sample`] with `facing`): the same times a bound of the
//! cosine to the surface's normal per block of cells, so samples are not
//! spent behind the surface and follow radiance x cosine more closely
//! (`facing.rs`).
//!
//! Everything is built by [`EnvMap::new`] for the `image`, `filter` and
//! rows it is given; the fields are read-only, so they cannot drift apart.

mod facing;
#[cfg(feature = "gpu")]
mod gpu_tables;
mod grid;
mod latlong;
mod warp;

#[cfg(feature = "gpu")]
pub use gpu_tables::{EnvGpuFacing, EnvGpuTables};
pub use grid::TexelRows;

use crate::color::{luminance, Rgb};
use crate::image::Bitmap;
use crate::math::{Transform, Vec2, Vec3, Vec4, PI};
use facing::{FacingBounds, FacingWarp};
use grid::{CellLanes, CellPoint, TexelGrid};
use latlong::{
    dir_to_uv_sin, normalize_robust, unit_dir_to_uv_sin, unit_dir_to_uv_sin_lanes, uv_to_dir_sin,
    uv_to_dir_sin_lanes,
};
use warp::EnvWarp;

/// 2 pi^2: the Jacobian |d omega / (du dv)| = 2 pi^2 sin(theta).
const TWO_PI_SQ: f32 = 2.0 * PI * PI;

/// Which light-sampling density a caller wants (see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LightPdf {
    /// A density that is positive wherever the light shines: for
    /// estimators that rely on light sampling alone.
    #[default]
    Complete,
    /// A density that may leave dim regions to BSDF sampling: only for
    /// combining with BSDF sampling by MIS, with the same choice in `pdf`.
    MisCompensated,
}

/// How texels are looked up.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum EnvFilter {
    /// Bilinear interpolation between texel centres (u wraps, v clamps).
    #[default]
    Bilinear,
    /// The texel containing (u, v).
    Nearest,
}

/// A lat-long environment map, importance-sampled by luminance x sin(theta).
/// Built only through [`EnvMap::new`], which checks it.
#[derive(Clone, Debug)]
pub struct EnvMap {
    image: Bitmap,
    scale: f32,
    to_world: Transform,
    rows: TexelRows,
    /// Seen by camera rays (it lights the scene either way).
    pub visible: bool,
    /// Cells of the lookup and of the densities.
    grid: TexelGrid,
    /// The complete density; `None` if the map is black.
    warp: Option<Density>,
    /// The MIS-compensated density; `None` where it would equal `warp`.
    mis_warp: Option<Density>,
    /// Mean luminance over the sphere of the unscaled map.
    mean_lum: f32,
}

/// A sampling density over the map, and the same restricted to surfaces
/// facing one way (`facing.rs`).
#[derive(Clone, Debug)]
struct Density {
    map: EnvWarp,
    /// `None` where it would not pay (`facing.rs`).
    facing: Option<FacingWarp>,
}

impl Density {
    fn new(
        grid: &TexelGrid,
        bounds: &FacingBounds,
        weight: &[f32],
        worth_it: f64,
    ) -> Option<Density> {
        let map = EnvWarp::new(grid, weight)?;
        let facing = FacingWarp::new(&map, grid, bounds, worth_it);
        Some(Density { map, facing })
    }
}

/// How far from orthonormal `to_world` may be (on M M^T; Mitsuba's
/// `has_scale` tolerance).
pub const ROTATION_TOLERANCE: f32 = 1e-3;

/// The parameter of an environment map an [`EnvMapError`] is about.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EnvMapParam {
    Image,
    Scale,
    ToWorld,
}

/// An environment map that cannot be built. Each message completes a
/// sentence that starts with the parameter's name.
#[derive(Debug, thiserror::Error)]
pub enum EnvMapError {
    #[error("is empty ({width} x {height} texels)")]
    Empty { width: usize, height: usize },
    #[error("has texel ({x}, {y}) = {value}: radiance must be finite and not negative")]
    Texel { x: usize, y: usize, value: Rgb },
    #[error("must be finite and not negative, found {0}")]
    Scale(f32),
    #[error("must be a rotation (an orthogonal matrix)")]
    ToWorld,
    #[error("has {height} row: rows from pole to pole (Mitsuba's convention) need at least 2")]
    TooFewRows { height: usize },
}

impl EnvMapError {
    /// The parameter that is wrong.
    pub fn param(&self) -> EnvMapParam {
        match self {
            EnvMapError::Empty { .. }
            | EnvMapError::Texel { .. }
            | EnvMapError::TooFewRows { .. } => EnvMapParam::Image,
            EnvMapError::Scale(_) => EnvMapParam::Scale,
            EnvMapError::ToWorld => EnvMapParam::ToWorld,
        }
    }
}

impl EnvMap {
    /// A map of `image` (W x H > 0 texels of finite, non-negative
    /// radiance; H >= 2 with [`TexelRows::PoleToPole`]) times `scale`
    /// (finite, >= 0), turned by `to_world` (a rotation, possibly with a
    /// mirror), looked up with `filter` at texel positions given by `rows`.
    pub fn new(
        image: Bitmap,
        scale: f32,
        to_world: Transform,
        filter: EnvFilter,
        rows: TexelRows,
    ) -> Result<EnvMap, EnvMapError> {
        EnvMap::build(image, scale, to_world, filter, rows, facing::WORTH_IT)
    }

    /// [`EnvMap::new`] with facing densities built where their predicted
    /// variance ratio is below `worth_it` (tests force them with infinity).
    fn build(
        image: Bitmap,
        scale: f32,
        to_world: Transform,
        filter: EnvFilter,
        rows: TexelRows,
        worth_it: f64,
    ) -> Result<EnvMap, EnvMapError> {
        let (w, h) = (image.width, image.height);
        if w == 0 || h == 0 || image.pixels.len() != w * h {
            return Err(EnvMapError::Empty {
                width: w,
                height: h,
            });
        }
        if rows == TexelRows::PoleToPole && h < 2 {
            return Err(EnvMapError::TooFewRows { height: h });
        }
        if let Some(i) = image
            .pixels
            .iter()
            .position(|p| !p.is_finite() || p.min_element() < 0.0)
        {
            return Err(EnvMapError::Texel {
                x: i % w,
                y: i / w,
                value: image.pixels[i],
            });
        }
        if !(scale >= 0.0 && scale.is_finite()) {
            return Err(EnvMapError::Scale(scale));
        }
        if !to_world.is_rotation(ROTATION_TOLERANCE) {
            return Err(EnvMapError::ToWorld);
        }
        let grid = TexelGrid::new(w, h, filter, rows);
        let lum: Vec<f32> = image
            .pixels
            .iter()
            .map(|&p| luminance(p).max(0.0))
            .collect();
        let mean_lum = grid.sphere_mean(&lum) as f32;
        let bounds = FacingBounds::new(&grid);
        let warp = Density::new(&grid, &bounds, &lum, worth_it);
        let min_lum = lum.iter().copied().fold(f32::INFINITY, f32::min);
        let mis_warp = if warp.is_some() && mean_lum - min_lum > 0.01 * mean_lum {
            let compensated: Vec<f32> = lum.iter().map(|&l| (l - mean_lum).max(0.0)).collect();
            Density::new(&grid, &bounds, &compensated, worth_it)
        } else {
            None
        };
        Ok(EnvMap {
            image,
            scale,
            to_world,
            rows,
            visible: true,
            grid,
            warp,
            mis_warp,
            mean_lum,
        })
    }

    /// The texels (unscaled).
    pub fn image(&self) -> &Bitmap {
        &self.image
    }

    pub fn scale(&self) -> f32 {
        self.scale
    }

    pub fn to_world(&self) -> &Transform {
        &self.to_world
    }

    pub fn filter(&self) -> EnvFilter {
        self.grid.filter
    }

    pub fn rows(&self) -> TexelRows {
        self.rows
    }

    /// Local direction (need not be normalised) to (u, v) in `[0, 1) x [0, 1]`.
    pub fn dir_to_uv(d: Vec3) -> Vec2 {
        dir_to_uv_sin(d).0
    }

    /// (u, v) to the local unit direction.
    pub fn uv_to_dir(uv: Vec2) -> Vec3 {
        latlong::uv_to_dir(uv)
    }

    /// Radiance seen in world direction `d`.
    pub fn eval(&self, d: Vec3) -> Rgb {
        self.locate(d).map_or(Rgb::ZERO, |at| self.eval_at(at))
    }

    /// [`EnvMap::eval`] of the direction `at` was located from.
    #[inline]
    pub fn eval_at(&self, at: EnvPoint) -> Rgb {
        if !self.emits() {
            return Rgb::ZERO;
        }
        self.grid.lookup(&self.image.pixels, at.p) * self.scale
    }

    /// The density `which` selects (the complete one where the compensated
    /// one is not built); `None` if the map emits nothing.
    fn warp(&self, which: LightPdf) -> Option<&Density> {
        if !self.emits() {
            return None;
        }
        match which {
            LightPdf::MisCompensated => self.mis_warp.as_ref().or(self.warp.as_ref()),
            LightPdf::Complete => self.warp.as_ref(),
        }
    }

    /// The facing version of `density` and the bin of a world-space
    /// `facing` normal, where the density has one (else the map's own
    /// density serves every surface).
    #[inline]
    fn side<'a>(
        &self,
        density: &'a Density,
        facing: Option<Vec3>,
    ) -> Option<(&'a FacingWarp, usize)> {
        let warp = density.facing.as_ref()?;
        let bin = facing::bin_of(self.to_world.inv.transform_vector3(facing?))?;
        Some((warp, bin))
    }

    /// (direction, radiance / pdf, solid-angle pdf) drawn from the density
    /// `which`, restricted to a surface facing `facing` if given (see
    /// [`EnvMap::pdf`]). `None` if the map emits nothing, if such a surface
    /// sees none of it, or (with vanishing probability) if the sample lands
    /// on a pole.
    ///
    /// The radiance and pdf are those of the sampled point itself, as
    /// Mitsuba and pbrt return them: `pdf(d)` and `eval(d)` of the returned
    /// direction agree with them up to the rounding of the trip through
    /// the direction (bilinear: ~1e-6 relative; nearest: the same, except
    /// within rounding of a texel's edge, where they may give the
    /// neighbour's value).
    #[inline]
    pub fn sample(
        &self,
        u: Vec2,
        which: LightPdf,
        facing: Option<Vec3>,
    ) -> Option<(Vec3, Rgb, f32)> {
        let density = self.warp(which)?;
        let warp = &density.map;
        let side = self.side(density, facing);
        let pixels = &self.image.pixels;
        let p = match side {
            Some((facing, bin)) => facing.sample(warp, bin, u, |cols, band| {
                self.grid.prefetch_span(pixels, cols, band)
            })?,
            None => warp.place(warp.pick(u)),
        };
        // A point on an edge where the density vanishes (a pole, or the
        // border of a compensated density's support) is pulled towards its
        // cell's centre: this moves a vanishing fraction of samples by a
        // sliver of a texel.
        for shrink in [1.0, 0.999, 0.99, 0.5, 0.0] {
            let p = CellPoint {
                fx: 0.5 + (p.fx - 0.5) * shrink,
                fy: 0.5 + (p.fy - 0.5) * shrink,
                ..p
            };
            let uv = self.grid.to_uv(p);
            let (local, sin_theta) = uv_to_dir_sin(uv);
            let world = self.to_world.vector(local).normalize_or_zero();
            let pdf = pdf_at(density, side, p, sin_theta);
            if pdf > 0.0 && world != Vec3::ZERO {
                let radiance = self.grid.lookup(&self.image.pixels, p) * self.scale;
                return Some((world, radiance / pdf, pdf));
            }
        }
        None
    }

    /// [`EnvMap::sample`] of four uniform pairs, each with its `facing`,
    /// every lane bit for bit the scalar routine's (tested): the position
    /// in the cell (unless a facing density picks the cell), the direction,
    /// the density and the lookup run in SIMD lanes (the scalar routine's
    /// operations in its order), where four dependent chains of square
    /// roots and divisions would otherwise run one after another. Lanes
    /// that the lane code does not cover (the nearest filter, a first try
    /// that lands where the density vanishes) take the scalar routine.
    #[inline]
    pub fn sample_lanes(
        &self,
        u: &[Vec2; 4],
        which: LightPdf,
        facing: &[Option<Vec3>; 4],
    ) -> [Option<(Vec3, Rgb, f32)>; 4] {
        let scalar = |k: usize| self.sample(u[k], which, facing[k]);
        let Some(density) = self.warp(which) else {
            return [None; 4];
        };
        let warp = &density.map;
        if !warp.is_bilinear() {
            return std::array::from_fn(scalar);
        }
        let sides = facing.map(|f| self.side(density, f));
        // Lanes whose facing density leaves nothing to sample.
        let mut nothing = [false; 4];
        let (p, corners) = if sides.iter().all(Option::is_none) {
            warp.place_lanes(&u.map(|u| warp.pick(u)))
        } else {
            let pixels = &self.image.pixels;
            let points: [CellPoint; 4] = std::array::from_fn(|k| match sides[k] {
                Some((f, bin)) => f
                    .sample(warp, bin, u[k], |cols, band| {
                        self.grid.prefetch_span(pixels, cols, band)
                    })
                    .unwrap_or_else(|| {
                        nothing[k] = true;
                        CellPoint::default()
                    }),
                None => warp.place(warp.pick(u[k])),
            });
            let p = CellLanes::from_points(&points);
            (p, warp.corner_lanes(&p))
        };
        // The scalar loop's first try (a shrink of 1).
        let half = Vec4::splat(0.5);
        let p = CellLanes {
            fx: half + (p.fx - half) * 1.0,
            fy: half + (p.fy - half) * 1.0,
            ..p
        };
        let (pu, pv) = self.grid.to_uv_lanes(&p);
        let ([lx, ly, lz], sin_theta) = uv_to_dir_sin_lanes(pu, pv);
        // `Transform::vector` (glam's `transform_vector3`, in its order),
        // then `normalize_or_zero`.
        let m = &self.to_world.m;
        let row = |k: usize| m.z_axis[k] * lz + (m.y_axis[k] * ly + m.x_axis[k] * lx);
        let (wx, wy, wz) = (row(0), row(1), row(2));
        let rcp = Vec4::ONE / (wx * wx + wy * wy + wz * wz).sqrt();
        let unit = rcp.cmplt(Vec4::splat(f32::INFINITY)) & rcp.cmpgt(Vec4::ZERO);
        let [wx, wy, wz] = [wx, wy, wz].map(|c| Vec4::select(unit, c * rcp, Vec4::ZERO));
        let nonzero = wx.cmpne(Vec4::ZERO) | wy.cmpne(Vec4::ZERO) | wz.cmpne(Vec4::ZERO);
        let ratio = Vec4::from_array(std::array::from_fn(|k| {
            sides[k].map_or(1.0, |(f, bin)| f.ratio(bin, p.point(k)))
        }));
        let pdf = pdf_at_lanes(warp.pdf_lanes(&p, &corners), ratio, sin_theta);
        let found = (pdf.cmpgt(Vec4::ZERO) & nonzero).bitmask();
        let [r, g, b] = self
            .grid
            .lookup_lanes_bilinear(&self.image.pixels, &p)
            .map(|c| c * self.scale / pdf);
        std::array::from_fn(|k| {
            if nothing[k] {
                return None;
            }
            if found & (1 << k) == 0 {
                return scalar(k);
            }
            Some((
                Vec3::new(wx[k], wy[k], wz[k]),
                Rgb::new(r[k], g[k], b[k]),
                pdf[k],
            ))
        })
    }

    /// Prefetches the tables and texels that `sample(u, which, None)`
    /// reads, for a caller that knows `u` before it needs the sample (the
    /// path tracer draws it before tracing the ray to the point that
    /// samples).
    #[inline]
    pub fn prefetch_sample(&self, u: Vec2, which: LightPdf) {
        if let Some(density) = self.warp(which) {
            let pixels = &self.image.pixels;
            (density.map).prefetch_pick(u, |col, band| self.grid.prefetch(pixels, col, band));
        }
    }

    /// `(eval(d), pdf(d, which, facing))` with one trip from direction to
    /// texels: what a path needs when a BSDF-sampled ray escapes to the map.
    #[inline]
    pub fn eval_pdf(&self, d: Vec3, which: LightPdf, facing: Option<Vec3>) -> (Rgb, f32) {
        match self.locate(d) {
            Some(at) => self.eval_pdf_at(at, which, facing),
            None => (Rgb::ZERO, 0.0),
        }
    }

    /// Where world direction `d` meets the map; `None` for zero, NaN or
    /// infinite input.
    #[inline]
    pub fn locate(&self, d: Vec3) -> Option<EnvPoint> {
        let (uv, sin_theta) = unit_dir_to_uv_sin(self.to_local(d)?);
        Some(EnvPoint {
            p: self.grid.locate(uv),
            sin_theta,
        })
    }

    /// [`EnvMap::locate`] of four directions in SIMD lanes: the same
    /// points bit for bit (tested).
    #[inline]
    pub fn locate_lanes(&self, d: [&Vec3; 4]) -> [Option<EnvPoint>; 4] {
        let (dx, dy, dz) = (
            Vec4::from_array(d.map(|d| d.x)),
            Vec4::from_array(d.map(|d| d.y)),
            Vec4::from_array(d.map(|d| d.z)),
        );
        // `to_local`: `Mat4::transform_vector3`'s operations in its order,
        // then its common case; any lane outside it takes the scalar path.
        let m = &self.to_world.inv;
        let row = |k: usize| m.z_axis[k] * dz + (m.y_axis[k] * dy + m.x_axis[k] * dx);
        let (lx, ly, lz) = (row(0), row(1), row(2));
        let len2 = lx * lx + ly * ly + lz * lz;
        let common = len2.cmpgt(Vec4::splat(1e-20)) & len2.cmplt(Vec4::splat(1e20));
        if !common.all() {
            return d.map(|d| self.locate(*d));
        }
        let len = len2.sqrt();
        let (u, v, sin_theta) = unit_dir_to_uv_sin_lanes(lx / len, ly / len, lz / len);
        let cells = self.grid.locate_lanes(u, v);
        std::array::from_fn(|k| {
            Some(EnvPoint {
                p: cells[k],
                sin_theta: sin_theta[k],
            })
        })
    }

    /// Prefetches what [`EnvMap::eval_pdf_at`] reads at `at` with `which`
    /// (texels and density values; not the facing tables), for a caller
    /// that has a ray to trace before it knows whether it escapes.
    #[inline]
    pub fn prefetch_point(&self, at: EnvPoint, which: LightPdf) {
        let CellPoint { col, band, .. } = at.p;
        self.grid.prefetch(&self.image.pixels, col, band);
        if let Some(density) = self.warp(which) {
            density.map.prefetch_cell(col, band);
        }
    }

    /// [`EnvMap::eval_pdf`] of the direction `at` was located from.
    #[inline]
    pub fn eval_pdf_at(&self, at: EnvPoint, which: LightPdf, facing: Option<Vec3>) -> (Rgb, f32) {
        let Some(density) = self.warp(which) else {
            return (Rgb::ZERO, 0.0);
        };
        let radiance = self.grid.lookup(&self.image.pixels, at.p) * self.scale;
        let pdf = pdf_at(density, self.side(density, facing), at.p, at.sin_theta);
        (radiance, pdf)
    }

    /// [`EnvMap::eval_pdf_at`] of four located points, each with its
    /// `facing`, every lane bit for bit the scalar routine's (tested): the
    /// lookup and the density in SIMD lanes. Lanes with a facing density,
    /// and maps with the nearest filter, take the scalar routine.
    #[inline]
    pub fn eval_pdf_at_lanes(
        &self,
        at: &[EnvPoint; 4],
        which: LightPdf,
        facing: &[Option<Vec3>; 4],
    ) -> [(Rgb, f32); 4] {
        let scalar = |k: usize| self.eval_pdf_at(at[k], which, facing[k]);
        let Some(density) = self.warp(which) else {
            return [(Rgb::ZERO, 0.0); 4];
        };
        let warp = &density.map;
        if !warp.is_bilinear() {
            return std::array::from_fn(scalar);
        }
        let p = CellLanes::from_points(&at.map(|a| a.p));
        let sin_theta = Vec4::from_array(at.map(|a| a.sin_theta));
        // Lanes with a facing density are replaced below (ratio 1 here).
        let pdf = pdf_at_lanes(
            warp.pdf_lanes(&p, &warp.corner_lanes(&p)),
            Vec4::ONE,
            sin_theta,
        );
        let [r, g, b] = self
            .grid
            .lookup_lanes_bilinear(&self.image.pixels, &p)
            .map(|c| c * self.scale);
        std::array::from_fn(|k| {
            if self.side(density, facing[k]).is_some() {
                return scalar(k);
            }
            (Rgb::new(r[k], g[k], b[k]), pdf[k])
        })
    }

    /// Whether the map has a density for `which` (it emits): then
    /// [`EnvMap::eval_pdf_at`]'s radiance is [`EnvMap::eval_at`]'s.
    pub fn has_density(&self, which: LightPdf) -> bool {
        self.warp(which).is_some()
    }

    /// Solid-angle pdf that `sample(_, which, facing)` draws world direction
    /// `d`. With `facing` (a normal, need not be unit), the density is for a
    /// surface that only receives light from the side `facing` points to:
    /// it may vanish behind it, and is the map's density times a bound of
    /// the cosine to `facing`, renormalised (`facing.rs`).
    pub fn pdf(&self, d: Vec3, which: LightPdf, facing: Option<Vec3>) -> f32 {
        let Some(density) = self.warp(which) else {
            return 0.0;
        };
        match self.to_local(d) {
            Some(l) => {
                let (uv, sin_theta) = unit_dir_to_uv_sin(l);
                let side = self.side(density, facing);
                pdf_at(density, side, self.grid.locate(uv), sin_theta)
            }
            None => 0.0,
        }
    }

    /// Mean luminance over the sphere (for choosing between lights).
    pub fn mean_luminance(&self) -> f32 {
        if self.emits() {
            self.mean_lum * self.scale
        } else {
            0.0
        }
    }

    /// True if the map emits any light (so `sample` can succeed).
    pub fn has_light(&self) -> bool {
        self.warp(LightPdf::Complete).is_some()
    }

    fn emits(&self) -> bool {
        self.scale > 0.0
    }

    /// World direction to a unit local direction; `None` for zero, NaN or
    /// infinite input.
    #[inline]
    fn to_local(&self, d: Vec3) -> Option<Vec3> {
        let l = self.to_world.inv.transform_vector3(d);
        let len2 = l.length_squared();
        // The common case in one square root; tiny, huge and bad input
        // take the careful path.
        if len2 > 1e-20 && len2 < 1e20 {
            Some(l / len2.sqrt())
        } else if d.is_finite() {
            normalize_robust(l)
        } else {
            None
        }
    }
}

/// Where a direction meets an environment map ([`EnvMap::locate`]): found
/// once, to prefetch its texels while a ray that may escape is traced and
/// then to look them up if it does.
#[derive(Clone, Copy, Debug, Default)]
pub struct EnvPoint {
    p: CellPoint,
    sin_theta: f32,
}

/// Solid-angle density of `density` at a point with the given sin(theta),
/// or of its facing version for a normal bin (`side`) if given.
#[inline]
fn pdf_at(
    density: &Density,
    side: Option<(&FacingWarp, usize)>,
    p: CellPoint,
    sin_theta: f32,
) -> f32 {
    if sin_theta.is_nan() || sin_theta <= 0.0 {
        return 0.0;
    }
    let ratio = side.map_or(1.0, |(f, bin)| f.ratio(bin, p));
    let pdf = density.map.pdf(p) * ratio / (TWO_PI_SQ * sin_theta);
    if pdf.is_finite() {
        pdf
    } else {
        0.0
    }
}

/// [`pdf_at`] of four points in lanes, bit for bit: their densities over
/// (u, v) `pdf_uv`, the facing ratios (1 without a facing density) and
/// sin(theta).
#[inline]
fn pdf_at_lanes(pdf_uv: Vec4, ratio: Vec4, sin_theta: Vec4) -> Vec4 {
    let pdf = pdf_uv * ratio / (sin_theta * TWO_PI_SQ);
    let valid = sin_theta.cmpgt(Vec4::ZERO) & pdf.abs().cmplt(Vec4::splat(f32::INFINITY));
    Vec4::select(valid, pdf, Vec4::ZERO)
}

#[cfg(test)]
mod tests;
