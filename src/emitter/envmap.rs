//! Image-based lighting from a lat-long HDR probe.
//!
//! # Convention
//!
//! For a unit direction `(x, y, z)` in the map's local frame (the world
//! direction taken through the inverse of `to_world`):
//!
//! ```text
//! theta = acos(y),  phi = atan2(x, -z)
//! u = phi / 2pi wrapped into [0, 1) (rem_euclid),  v = theta / pi clamped to [0, 1]
//! ```
//!
//! so the left edge (u = 0) looks down -z, u = 0.25 down +x, the centre column
//! (u = 0.5) down +z, u = 0.75 down -x, and the top row (v = 0) is +y. The
//! inverse is `phi = 2 pi u`, `theta = pi v`,
//! `d = (sin theta sin phi, cos theta, -sin theta cos phi)`
//! ([`EnvMap::uv_to_dir`], [`EnvMap::dir_to_uv`]).
//!
//! `to_world` must be a rotation (reflections and uniform scale are harmless:
//! directions are renormalised). A shear or non-uniform scale would distort
//! solid angles and make `pdf` disagree with `sample`.
//!
//! # Lookup
//!
//! Radiance is `texel * scale`. [`EnvFilter::Bilinear`] places texel centres
//! at `((i + 0.5) / W, (j + 0.5) / H)`, wraps horizontally and clamps
//! vertically; [`EnvFilter::Nearest`] returns the texel containing `(u, v)`.
//! A map with texels that are negative or not finite is refused when it is
//! built (a light cannot emit negative or infinite radiance); scene files'
//! maps come through the image loader, which clamps negative texels to zero
//! with a warning.
//!
//! # Importance sampling
//!
//! A piecewise-constant distribution over the W x H texel cells in (u, v)
//! (a marginal over rows and a conditional per row), with per-cell weight `lum(cell) * sin(theta_centre)` and
//! solid-angle density `pdf_uv / (2 pi^2 sin theta)` (theta of the direction,
//! not of the cell centre). With the nearest filter `lum(cell)` is the texel's
//! luminance: the pdf is then exactly proportional to the luminance of `eval`
//! times the `sin theta` of the cell centre. Bilinear filtering spreads each
//! texel half a texel into its neighbours, so there `lum(cell)` is the exact
//! mean over the cell of the bilinearly interpolated luminance: a separable
//! `[1, 6, 1] / 8` blur of the luminance (horizontal wrap, vertical clamp, the
//! same boundary rules as the lookup). Every kernel entry is positive, so a
//! cell gets a positive weight exactly when one of the texels its lookups
//! touch is nonzero: `pdf > 0` wherever `eval > 0` (except at the two exact
//! poles, a set of measure zero where the pdf is reported as 0).
//!
//! The distribution is built by [`EnvMap::new`] for the `image` and `filter`
//! it is given; the fields are read-only, so they cannot drift apart.

use crate::color::{luminance, Rgb};
use crate::image::Bitmap;
use crate::math::{Transform, Vec2, Vec3, INV_PI, INV_TWO_PI, PI};
use crate::sampling::Distribution2D;

/// 2 pi^2: the Jacobian |d omega / (du dv)| = 2 pi^2 sin(theta).
const TWO_PI_SQ: f32 = 2.0 * PI * PI;

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
    filter: EnvFilter,
    /// Seen by camera rays (it lights the scene either way).
    pub visible: bool,
    /// Sampling table over texel cells (see the module docs).
    dist: Distribution2D,
    /// Mean luminance over the sphere of the unscaled map.
    mean_lum: f32,
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
}

impl EnvMapError {
    /// The parameter that is wrong.
    pub fn param(&self) -> EnvMapParam {
        match self {
            EnvMapError::Empty { .. } | EnvMapError::Texel { .. } => EnvMapParam::Image,
            EnvMapError::Scale(_) => EnvMapParam::Scale,
            EnvMapError::ToWorld => EnvMapParam::ToWorld,
        }
    }
}

impl EnvMap {
    /// A map of `image` (W x H > 0 texels of finite, non-negative
    /// radiance) times `scale` (finite, >= 0), turned by `to_world` (a
    /// rotation, possibly with a mirror), looked up with `filter`.
    pub fn new(
        image: Bitmap,
        scale: f32,
        to_world: Transform,
        filter: EnvFilter,
    ) -> Result<EnvMap, EnvMapError> {
        let (w, h) = (image.width, image.height);
        if w == 0 || h == 0 || image.pixels.len() != w * h {
            return Err(EnvMapError::Empty {
                width: w,
                height: h,
            });
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
        let weights = sampling_weights(&image, filter);
        let dist = Distribution2D::new(&weights, w, h);
        // mean over the sphere = (1 / 4 pi) sum lum * 2 pi^2 sin / (W H)
        //                      = (pi / 2) * mean(weights).
        let mean_lum = 0.5 * PI * dist.integral();
        Ok(EnvMap {
            image,
            scale,
            to_world,
            filter,
            visible: true,
            dist,
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
        self.filter
    }

    /// Local direction (need not be normalised) to (u, v) in `[0, 1) x [0, 1]`.
    pub fn dir_to_uv(d: Vec3) -> Vec2 {
        dir_to_uv_sin(d).0
    }

    /// (u, v) to the local unit direction.
    pub fn uv_to_dir(uv: Vec2) -> Vec3 {
        let (sin_phi, cos_phi) = (2.0 * PI * uv.x).sin_cos();
        let (sin_theta, cos_theta) = (PI * uv.y).sin_cos();
        Vec3::new(sin_theta * sin_phi, cos_theta, -sin_theta * cos_phi)
    }

    /// Radiance seen in world direction `d`.
    pub fn eval(&self, d: Vec3) -> Rgb {
        if !self.emits() {
            return Rgb::ZERO;
        }
        match self.to_local(d) {
            Some(l) => self.lookup(dir_to_uv_sin(l).0) * self.scale,
            None => Rgb::ZERO,
        }
    }

    /// (direction, radiance / pdf, solid-angle pdf). `None` if the map emits
    /// nothing (or, with vanishing probability, if the sample lands on a pole).
    pub fn sample(&self, u: Vec2) -> Option<(Vec3, Rgb, f32)> {
        if !self.has_light() {
            return None;
        }
        let (i, j, duv) = self.dist.sample_cell(u);
        let cell = (i, j);
        let n = self.cell_count();
        let corner = Vec2::new(i as f32, j as f32);
        let centre = (corner + 0.5) / n;
        let uv = (corner + duv) / n;
        // Round-off (in the line above and in uv -> direction -> uv) can move
        // a point near a cell's edge into the neighbouring cell, whose pdf may
        // differ or be zero. Then pull it towards its cell's centre and try
        // again: this moves a vanishing fraction of samples by a sliver of a
        // texel, and keeps `pdf(d)` equal to the density of the cell sampled.
        for shrink in [1.0, 0.999, 0.99, 0.9, 0.5, 0.0] {
            let uv_s = centre + (uv - centre) * shrink;
            let world = normalize_robust(self.to_world.vector(Self::uv_to_dir(uv_s)))?;
            // Evaluate exactly as `pdf(world)` and `eval(world)` do, so the
            // three agree bit for bit on the returned direction.
            let local = self.to_local(world)?;
            let (uv_w, sin_theta) = dir_to_uv_sin(local);
            if self.cell_of(uv_w) != cell {
                continue;
            }
            let pdf = self.pdf_uv_sin(uv_w, sin_theta);
            if pdf <= 0.0 {
                continue; // on a pole
            }
            let radiance = self.lookup(uv_w) * self.scale;
            return Some((world, radiance / pdf, pdf));
        }
        None
    }

    /// Solid-angle pdf of sampling world direction `d`.
    pub fn pdf(&self, d: Vec3) -> f32 {
        if !self.has_light() {
            return 0.0;
        }
        match self.to_local(d) {
            Some(l) => {
                let (uv, sin_theta) = dir_to_uv_sin(l);
                self.pdf_uv_sin(uv, sin_theta)
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
        self.emits() && self.dist.integral() > 0.0
    }

    /// Number of texel cells along u and v.
    fn cell_count(&self) -> Vec2 {
        Vec2::new(self.image.width as f32, self.image.height as f32)
    }

    /// The texel cell containing (u, v), as the pdf and lookups index it.
    fn cell_of(&self, uv: Vec2) -> (usize, usize) {
        let (w, h) = (self.image.width, self.image.height);
        (
            ((uv.x * w as f32) as usize).min(w - 1),
            ((uv.y * h as f32) as usize).min(h - 1),
        )
    }

    fn emits(&self) -> bool {
        self.scale > 0.0
    }

    fn pdf_uv_sin(&self, uv: Vec2, sin_theta: f32) -> f32 {
        if sin_theta.is_nan() || sin_theta <= 0.0 {
            return 0.0;
        }
        let (i, j) = self.cell_of(uv);
        let pdf = self.dist.pdf_cell(i, j) / (TWO_PI_SQ * sin_theta);
        if pdf.is_finite() {
            pdf
        } else {
            0.0
        }
    }

    /// World direction to a unit local direction; `None` for zero, NaN or
    /// infinite input.
    fn to_local(&self, d: Vec3) -> Option<Vec3> {
        if !d.is_finite() {
            return None;
        }
        normalize_robust(self.to_world.inv.transform_vector3(d))
    }

    /// Unscaled filtered texel value at (u, v), u in [0,1), v in [0,1].
    fn lookup(&self, uv: Vec2) -> Rgb {
        let (w, h) = (self.image.width, self.image.height);
        match self.filter {
            EnvFilter::Nearest => {
                let i = ((uv.x * w as f32) as usize).min(w - 1);
                let j = ((uv.y * h as f32) as usize).min(h - 1);
                self.image.pixels[j * w + i]
            }
            EnvFilter::Bilinear => {
                let x = uv.x * w as f32 - 0.5;
                let y = uv.y * h as f32 - 0.5;
                let (x0, y0) = (x.floor(), y.floor());
                let (fx, fy) = (x - x0, y - y0);
                let (ix, iy) = (x0 as i64, y0 as i64);
                let i0 = ix.rem_euclid(w as i64) as usize;
                let i1 = (ix + 1).rem_euclid(w as i64) as usize;
                let j0 = iy.clamp(0, h as i64 - 1) as usize;
                let j1 = (iy + 1).clamp(0, h as i64 - 1) as usize;
                let px = &self.image.pixels;
                let top = px[j0 * w + i0].lerp(px[j0 * w + i1], fx);
                let bottom = px[j1 * w + i0].lerp(px[j1 * w + i1], fx);
                top.lerp(bottom, fy)
            }
        }
    }
}

/// (u, v) and sin(theta) of a local direction (normalised or not; zero and
/// non-finite input give the top-left corner and sin(theta) = 0).
fn dir_to_uv_sin(d: Vec3) -> (Vec2, f32) {
    let len = d.length();
    let d = if len > 0.0 && len.is_finite() {
        d / len
    } else {
        return (Vec2::ZERO, 0.0);
    };
    let sin_theta = (d.x * d.x + d.z * d.z).sqrt();
    // atan2 is accurate near the poles, where acos(y) is not.
    let theta = sin_theta.atan2(d.y);
    let phi = d.x.atan2(-d.z);
    let mut u = (phi * INV_TWO_PI).rem_euclid(1.0);
    if u >= 1.0 {
        // rem_euclid can round up to the modulus for tiny negative input.
        u = 0.0;
    }
    let v = (theta * INV_PI).clamp(0.0, 1.0);
    (Vec2::new(u, v), sin_theta)
}

/// Unit vector in the direction of `v`, robust to tiny and huge lengths.
fn normalize_robust(v: Vec3) -> Option<Vec3> {
    let m = v.abs().max_element();
    if !(m > 0.0 && m.is_finite()) {
        return None;
    }
    let v = v / m;
    let n = v / v.length();
    n.is_finite().then_some(n)
}

/// Per-cell sampling weights (row-major): filtered luminance x sin(theta) of
/// the cell centre. See the module docs.
fn sampling_weights(image: &Bitmap, filter: EnvFilter) -> Vec<f32> {
    let (w, h) = (image.width, image.height);
    let lum: Vec<f32> = image.pixels.iter().map(|&p| luminance(p)).collect();
    let mut weights = match filter {
        EnvFilter::Nearest => lum,
        EnvFilter::Bilinear => {
            // Mean of the bilinear interpolant over a cell, separably:
            // 1/8 of each neighbour and 6/8 of the texel itself.
            let mut tmp = vec![0.0f32; w * h];
            for j in 0..h {
                let row = &lum[j * w..(j + 1) * w];
                for i in 0..w {
                    let l = row[(i + w - 1) % w];
                    let r = row[(i + 1) % w];
                    tmp[j * w + i] = (l + 6.0 * row[i] + r) * 0.125;
                }
            }
            let mut out = vec![0.0f32; w * h];
            for j in 0..h {
                let up = j.saturating_sub(1);
                let down = (j + 1).min(h - 1);
                for i in 0..w {
                    out[j * w + i] =
                        (tmp[up * w + i] + 6.0 * tmp[j * w + i] + tmp[down * w + i]) * 0.125;
                }
            }
            out
        }
    };
    for j in 0..h {
        let sin_theta = (PI * (j as f32 + 0.5) / h as f32).sin();
        for x in &mut weights[j * w..(j + 1) * w] {
            *x *= sin_theta;
        }
    }
    weights
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Mat4;
    use crate::sampling::Sampler;
    use crate::stats::{chi2_test, sidak};

    /// Number of chi-square tests in this module that must pass; Sidak
    /// splits the family-wise alpha = 0.01 between them.
    const N_CHI2_TESTS: usize = 9;
    /// Bins in cos(theta) and in phi.
    const NC: usize = 40;
    const NP: usize = 80;
    const N_SAMPLES: usize = 1_000_000;

    fn alpha() -> f64 {
        sidak(0.01, N_CHI2_TESTS)
    }

    fn constant(w: usize, h: usize, c: Rgb) -> Bitmap {
        let mut b = Bitmap::new(w, h);
        b.pixels.iter_mut().for_each(|p| *p = c);
        b
    }

    fn one_hot(w: usize, h: usize, texels: &[(usize, usize)]) -> Bitmap {
        let mut b = Bitmap::new(w, h);
        for &(i, j) in texels {
            b.set(i, j, Rgb::new(3.0, 1.0, 0.5));
        }
        b
    }

    fn gradient(w: usize, h: usize) -> Bitmap {
        let mut b = Bitmap::new(w, h);
        for j in 0..h {
            for i in 0..w {
                let (u, v) = ((i as f32 + 0.5) / w as f32, (j as f32 + 0.5) / h as f32);
                b.set(
                    i,
                    j,
                    Rgb::new(0.2 + u, 0.1 + 2.0 * v * v, 0.5 + (6.0 * u).sin().abs()),
                );
            }
        }
        b
    }

    /// Unit sky with a 2x1-texel sun 10^4 times brighter.
    fn sun_map(w: usize, h: usize) -> Bitmap {
        let mut b = constant(w, h, Rgb::new(0.3, 0.5, 1.0));
        let sun = Rgb::new(1.0, 0.9, 0.8) * 1.0e4;
        b.set(w / 3, h / 3, sun);
        b.set(w / 3 + 1, h / 3, sun);
        b
    }

    fn rot_a() -> Transform {
        let axis = Vec3::new(1.0, 2.0, 3.0).normalize();
        Transform::new(Mat4::from_axis_angle(axis, 0.9)).unwrap()
    }

    /// A rotation combined with a mirror (Nori cameras and scenes use these).
    fn rot_mirror() -> Transform {
        let m = Mat4::from_axis_angle(Vec3::new(-2.0, 0.5, 1.0).normalize(), 2.1)
            * Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0));
        Transform::new(m).unwrap()
    }

    fn bin_of(d: Vec3) -> usize {
        let d = d.normalize();
        let c = (((1.0 - d.y) * 0.5 * NC as f32) as usize).min(NC - 1);
        let p = ((EnvMap::dir_to_uv(d).x * NP as f32) as usize).min(NP - 1);
        c * NP + p
    }

    /// Histogram of `n` samples binned on a (cos theta, phi) grid of the
    /// frame `frame` (world directions are taken through `frame.inv`).
    fn histogram(env: &EnvMap, frame: &Transform, n: usize, seed: u64) -> Vec<f64> {
        let mut s = Sampler::new(seed, 7);
        let mut obs = vec![0.0; NC * NP];
        let mut failed = 0;
        for _ in 0..n {
            match env.sample(s.next_2d()) {
                Some((d, _, _)) => obs[bin_of(frame.inv.transform_vector3(d))] += 1.0,
                None => failed += 1,
            }
        }
        assert_eq!(failed, 0, "samples failed");
        obs
    }

    /// Expected counts on the (cos theta, phi) grid of the map's own frame.
    /// Each bin is a rectangle in (u, v) and the pdf is piecewise constant
    /// in (u, v) per texel cell, so each bin is integrated exactly as a sum
    /// over its intersections with the cells: there the probability is
    /// pdf(d) * 2 pi^2 sin(theta) * area, with `pdf(d)` the public world
    /// space pdf at the intersection's midpoint. `jacobian` = false drops the
    /// sin(theta) (a deliberately wrong pdf).
    fn expected_local(env: &EnvMap, n: usize, jacobian: bool) -> Vec<f64> {
        let (w, h) = (env.image.width as f64, env.image.height as f64);
        let mut exp = vec![0.0; NC * NP];
        let pi = std::f64::consts::PI;
        for c in 0..NC {
            let cos_hi = 1.0 - 2.0 * c as f64 / NC as f64;
            let cos_lo = 1.0 - 2.0 * (c + 1) as f64 / NC as f64;
            let (v0, v1) = (cos_hi.acos() / pi, cos_lo.acos() / pi);
            for p in 0..NP {
                let (u0, u1) = (p as f64 / NP as f64, (p + 1) as f64 / NP as f64);
                let mut prob = 0.0;
                let (i0, i1) = (
                    (u0 * w).floor() as usize,
                    ((u1 * w).ceil() as usize).min(w as usize),
                );
                let (j0, j1) = (
                    (v0 * h).floor() as usize,
                    ((v1 * h).ceil() as usize).min(h as usize),
                );
                for j in j0..j1 {
                    let (a, b) = ((j as f64 / h).max(v0), ((j + 1) as f64 / h).min(v1));
                    if b <= a {
                        continue;
                    }
                    for i in i0..i1 {
                        let (l, r) = ((i as f64 / w).max(u0), ((i + 1) as f64 / w).min(u1));
                        if r <= l {
                            continue;
                        }
                        let mid = Vec2::new((0.5 * (l + r)) as f32, (0.5 * (a + b)) as f32);
                        let world = env.to_world.vector(EnvMap::uv_to_dir(mid));
                        let sin = if jacobian {
                            (pi * 0.5 * (a + b)).sin()
                        } else {
                            1.0
                        };
                        prob += env.pdf(world) as f64 * 2.0 * pi * pi * sin * (r - l) * (b - a);
                    }
                }
                exp[c * NP + p] = prob;
            }
        }
        let total: f64 = exp.iter().sum();
        if !jacobian {
            exp.iter_mut().for_each(|e| *e /= total);
        } else {
            assert!((total - 1.0).abs() < 1e-3, "pdf integrates to {total}");
        }
        exp.iter().map(|&e| e * n as f64).collect()
    }

    /// Expected counts on the world (cos theta, phi) grid by numerically
    /// integrating the public pdf on a `sub` x `sub` midpoint grid per bin
    /// (d omega = d cos(theta) d phi).
    fn expected_world_numeric(env: &EnvMap, n: usize, sub: usize) -> Vec<f64> {
        let mut exp = vec![0.0; NC * NP];
        let pi = std::f64::consts::PI;
        let (dc, dp) = (2.0 / (NC * sub) as f64, 2.0 * pi / (NP * sub) as f64);
        for c in 0..NC * sub {
            let cos_t = 1.0 - (c as f64 + 0.5) * dc;
            let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
            for p in 0..NP * sub {
                let phi = (p as f64 + 0.5) * dp;
                let d = Vec3::new(
                    (sin_t * phi.sin()) as f32,
                    cos_t as f32,
                    (-sin_t * phi.cos()) as f32,
                );
                exp[(c / sub) * NP + p / sub] += env.pdf(d) as f64 * dc * dp;
            }
        }
        exp.iter().map(|&e| e * n as f64).collect()
    }

    fn chi2_local(env: &EnvMap, seed: u64) -> crate::stats::TestResult {
        let obs = histogram(env, &env.to_world, N_SAMPLES, seed);
        let exp = expected_local(env, N_SAMPLES, true);
        chi2_test(&obs, &exp, 5.0)
    }

    fn assert_passes(r: crate::stats::TestResult, what: &str) {
        eprintln!("{what}: {r:?}");
        assert!(r.passes(alpha()), "{what}: {r:?} (alpha {})", alpha());
    }

    #[test]
    fn landmark_directions_and_round_trip() {
        let cases = [
            (Vec3::new(0.0, 0.0, -1.0), 0.0),
            (Vec3::new(1.0, 0.0, 0.0), 0.25),
            (Vec3::new(0.0, 0.0, 1.0), 0.5),
            (Vec3::new(-1.0, 0.0, 0.0), 0.75),
        ];
        for (d, u) in cases {
            let uv = EnvMap::dir_to_uv(d);
            assert!(
                (uv.x - u).abs() < 1e-6 && (uv.y - 0.5).abs() < 1e-6,
                "{d} -> {uv}"
            );
            assert!((EnvMap::uv_to_dir(Vec2::new(u, 0.5)) - d).length() < 1e-6);
        }
        assert_eq!(EnvMap::dir_to_uv(Vec3::Y).y, 0.0);
        assert_eq!(EnvMap::dir_to_uv(-Vec3::Y).y, 1.0);
        // Just left of the -z seam wraps to u near 1, never to 1 itself.
        let uv = EnvMap::dir_to_uv(Vec3::new(-1e-9, 0.0, -1.0));
        assert!((0.0..1.0).contains(&uv.x));
        let mut s = Sampler::new(1, 1);
        for _ in 0..10_000 {
            let uv = s.next_2d();
            let d = EnvMap::uv_to_dir(uv);
            assert!((d.length() - 1.0).abs() < 1e-5);
            let back = EnvMap::dir_to_uv(d);
            let du = (back.x - uv.x).abs();
            assert!(
                du.min(1.0 - du) < 1e-4 && (back.y - uv.y).abs() < 1e-4,
                "{uv} {back}"
            );
            // And direction -> uv -> direction.
            assert!((EnvMap::uv_to_dir(back) - d).length() < 1e-4);
        }
    }

    #[test]
    fn lookup_filters_wrap_and_clamp() {
        let (w, h) = (8, 4);
        let mut b = Bitmap::new(w, h);
        for j in 0..h {
            for i in 0..w {
                b.set(i, j, Rgb::new(i as f32, j as f32, 1.0));
            }
        }
        let bil = EnvMap::new(b.clone(), 2.0, Transform::IDENTITY, EnvFilter::Bilinear).unwrap();
        let near = EnvMap::new(b, 2.0, Transform::IDENTITY, EnvFilter::Nearest).unwrap();
        let at = |u: f32, v: f32| EnvMap::uv_to_dir(Vec2::new(u, v));
        for j in 0..h {
            for i in 0..w {
                let (u, v) = ((i as f32 + 0.5) / w as f32, (j as f32 + 0.5) / h as f32);
                let want = Rgb::new(i as f32, j as f32, 1.0) * 2.0;
                assert!((bil.eval(at(u, v)) - want).length() < 1e-4);
                assert!(
                    (near.eval(at(u + 0.3 / w as f32, v - 0.3 / h as f32)) - want).length() < 1e-4
                );
            }
        }
        // The u = 0 seam averages the last and the first column.
        let seam = bil.eval(at(0.0, 1.5 / h as f32));
        assert!(
            (seam - Rgb::new(3.5, 1.0, 1.0) * 2.0).length() < 1e-3,
            "{seam}"
        );
        // Above the first row's centres v clamps: no blending with the bottom.
        let top = bil.eval(at(0.5 / w as f32, 0.1 / h as f32));
        assert!(
            (top - Rgb::new(0.0, 0.0, 1.0) * 2.0).length() < 1e-3,
            "{top}"
        );
    }

    #[test]
    fn to_world_rotates_the_map() {
        let b = gradient(32, 16);
        let r = Transform::new(Mat4::from_rotation_y(0.5 * PI)).unwrap();
        let plain = EnvMap::new(b.clone(), 1.0, Transform::IDENTITY, EnvFilter::Bilinear).unwrap();
        let rot = EnvMap::new(b, 1.0, r, EnvFilter::Bilinear).unwrap();
        let mut s = Sampler::new(5, 5);
        for _ in 0..1000 {
            let d = crate::sampling::warp::square_to_uniform_sphere(s.next_2d());
            let (a, b) = (plain.eval(d), rot.eval(r.vector(d)));
            assert!((a - b).length() < 1e-4 * a.length(), "{a} {b}");
            assert!((plain.pdf(d) - rot.pdf(r.vector(d))).abs() < 1e-4 * plain.pdf(d));
        }
        // Rotating +90 degrees about y takes local -z (u = 0) to world -x.
        let want = plain.eval(-Vec3::Z);
        assert!((rot.eval(-Vec3::X) - want).length() < 1e-5);
    }

    #[test]
    fn chi2_one_hot_bilinear() {
        let env = EnvMap::new(
            one_hot(24, 12, &[(7, 3)]),
            1.0,
            Transform::IDENTITY,
            EnvFilter::Bilinear,
        )
        .unwrap();
        assert_passes(chi2_local(&env, 11), "one-hot bilinear");
    }

    #[test]
    fn chi2_one_hot_nearest() {
        let env = EnvMap::new(
            one_hot(24, 12, &[(7, 3)]),
            1.0,
            Transform::IDENTITY,
            EnvFilter::Nearest,
        )
        .unwrap();
        assert_passes(chi2_local(&env, 12), "one-hot nearest");
    }

    #[test]
    fn chi2_one_hot_at_seam_and_poles() {
        let img = one_hot(24, 12, &[(0, 0), (23, 11), (23, 4)]);
        let env = EnvMap::new(img, 1.0, Transform::IDENTITY, EnvFilter::Bilinear).unwrap();
        assert_passes(chi2_local(&env, 13), "one-hot at seam and poles");
    }

    #[test]
    fn chi2_one_hot_rotated() {
        let env = EnvMap::new(
            one_hot(24, 12, &[(7, 3)]),
            1.0,
            rot_a(),
            EnvFilter::Bilinear,
        )
        .unwrap();
        assert_passes(chi2_local(&env, 14), "one-hot rotated");
    }

    #[test]
    fn chi2_gradient() {
        let env = EnvMap::new(
            gradient(96, 48),
            1.0,
            Transform::IDENTITY,
            EnvFilter::Bilinear,
        )
        .unwrap();
        assert_passes(chi2_local(&env, 15), "gradient");
    }

    #[test]
    fn chi2_gradient_rotated_world_bins() {
        let env = EnvMap::new(gradient(96, 48), 1.0, rot_a(), EnvFilter::Bilinear).unwrap();
        let n = 300_000;
        let obs = histogram(&env, &Transform::IDENTITY, n, 16);
        let exp = expected_world_numeric(&env, n, 24);
        let total: f64 = exp.iter().sum::<f64>() / n as f64;
        assert!((total - 1.0).abs() < 2e-3, "pdf integrates to {total}");
        assert_passes(chi2_test(&obs, &exp, 5.0), "gradient rotated, world bins");
    }

    #[test]
    fn chi2_sun() {
        let env = EnvMap::new(
            sun_map(128, 64),
            1.0,
            Transform::IDENTITY,
            EnvFilter::Bilinear,
        )
        .unwrap();
        assert_passes(chi2_local(&env, 17), "sun");
    }

    #[test]
    fn chi2_sun_rotated_mirrored() {
        let env = EnvMap::new(sun_map(128, 64), 1.0, rot_mirror(), EnvFilter::Bilinear).unwrap();
        assert_passes(chi2_local(&env, 18), "sun rotated");
    }

    #[test]
    fn chi2_baked_sky() {
        let p = crate::emitter::sky::SkyParams {
            resolution: 128,
            sun_elevation_deg: 30.0,
            sun_azimuth_deg: 60.0,
            ..Default::default()
        };
        let env = EnvMap::new(
            crate::emitter::sky::bake_sky(&p),
            1.0,
            rot_a(),
            EnvFilter::Bilinear,
        )
        .unwrap();
        assert_passes(chi2_local(&env, 19), "baked sky");
    }

    /// The chi-square machinery must be able to fail.
    #[test]
    fn chi2_rejects_wrong_pdfs() {
        let env = EnvMap::new(
            sun_map(128, 64),
            1.0,
            Transform::IDENTITY,
            EnvFilter::Bilinear,
        )
        .unwrap();
        let n = 100_000;
        let obs = histogram(&env, &env.to_world, n, 21);
        // Uniform sphere: each bin has the same solid angle.
        let uniform = vec![n as f64 / (NC * NP) as f64; NC * NP];
        let r = chi2_test(&obs, &uniform, 5.0);
        assert!(!r.passes(alpha()), "uniform pdf accepted: {r:?}");
        // The same pdf without the sin(theta) Jacobian.
        let grad = EnvMap::new(
            gradient(96, 48),
            1.0,
            Transform::IDENTITY,
            EnvFilter::Bilinear,
        )
        .unwrap();
        let obs_g = histogram(&grad, &grad.to_world, n, 22);
        let r = chi2_test(&obs_g, &expected_local(&grad, n, false), 5.0);
        assert!(!r.passes(alpha()), "pdf without Jacobian accepted: {r:?}");
        // The sun one texel to the right.
        let mut shifted = sun_map(128, 64);
        shifted.set(128 / 3, 64 / 3, shifted.get(0, 0));
        shifted.set(128 / 3 + 2, 64 / 3, sun_map(128, 64).get(128 / 3, 64 / 3));
        let shifted = EnvMap::new(shifted, 1.0, Transform::IDENTITY, EnvFilter::Bilinear).unwrap();
        let r = chi2_test(&obs, &expected_local(&shifted, n, true), 5.0);
        assert!(
            !r.passes(alpha()),
            "sun shifted by one texel accepted: {r:?}"
        );
        // Samples with the mirror the pdf does not know about.
        let mirrored =
            EnvMap::new(sun_map(128, 64), 1.0, rot_mirror(), EnvFilter::Bilinear).unwrap();
        let unmirrored = EnvMap {
            to_world: Transform::new(Mat4::from_axis_angle(
                Vec3::new(-2.0, 0.5, 1.0).normalize(),
                2.1,
            ))
            .unwrap(),
            ..mirrored.clone()
        };
        let obs_m = histogram(&mirrored, &Transform::IDENTITY, n, 23);
        let r = chi2_test(&obs_m, &expected_world_numeric(&unmirrored, n, 8), 5.0);
        assert!(!r.passes(alpha()), "missing mirror accepted: {r:?}");
    }

    #[test]
    fn weight_is_eval_over_pdf() {
        for (img, t) in [
            (sun_map(128, 64), rot_mirror()),
            (gradient(50, 25), rot_a()),
            (one_hot(16, 8, &[(3, 0)]), Transform::IDENTITY),
        ] {
            for filter in [EnvFilter::Bilinear, EnvFilter::Nearest] {
                let env = EnvMap::new(img.clone(), 1.5, t, filter).unwrap();
                let mut s = Sampler::new(3, 3);
                for _ in 0..50_000 {
                    let Some((d, w, pdf)) = env.sample(s.next_2d()) else {
                        continue;
                    };
                    assert!((d.length() - 1.0).abs() < 1e-5);
                    assert!(pdf > 0.0 && pdf.is_finite());
                    assert_eq!(pdf, env.pdf(d), "sample and pdf disagree");
                    let want = env.eval(d) / pdf;
                    assert!(w.is_finite() && w.min_element() >= 0.0);
                    assert!((w - want).length() <= 1e-6 * want.length(), "{w} vs {want}");
                }
            }
        }
    }

    /// Irradiance on a plane with normal `n`, integrated in (u, v) on a grid
    /// of `sub` x `sub` points per texel (the bilinear radiance is
    /// continuous, so the midpoint rule converges fast).
    fn irradiance_reference(env: &EnvMap, n: Vec3, sub: usize) -> f64 {
        let (w, h) = (env.image.width * sub, env.image.height * sub);
        let pi = std::f64::consts::PI;
        let mut sum = 0.0;
        for j in 0..h {
            let v = (j as f64 + 0.5) / h as f64;
            for i in 0..w {
                let uv = Vec2::new(((i as f64 + 0.5) / w as f64) as f32, v as f32);
                let d = env.to_world.vector(EnvMap::uv_to_dir(uv));
                let c = n.dot(d).max(0.0) as f64;
                sum += luminance(env.eval(d)) as f64 * c * (pi * v).sin();
            }
        }
        sum * 2.0 * pi * pi / (w * h) as f64
    }

    /// Estimating an integral with `sample` is unbiased (Student t-test), and
    /// the test notices a 2% error.
    #[test]
    fn sampled_irradiance_is_unbiased() {
        use crate::stats::{t_test, MeanVar};
        let cases = [
            (sun_map(128, 64), rot_mirror(), EnvFilter::Bilinear),
            (gradient(96, 48), rot_a(), EnvFilter::Nearest),
            (
                one_hot(24, 12, &[(7, 3), (0, 11)]),
                rot_a(),
                EnvFilter::Bilinear,
            ),
        ];
        let alpha = sidak(0.01, cases.len());
        for (k, (img, t, filter)) in cases.into_iter().enumerate() {
            let env = EnvMap::new(img, 2.0, t, filter).unwrap();
            let n = Vec3::new(0.3, 1.0, -0.2).normalize();
            let reference = irradiance_reference(&env, n, 16);
            let mut s = Sampler::new(31, k as u64);
            let mut mv = MeanVar::default();
            for _ in 0..1_500_000 {
                let e = match env.sample(s.next_2d()) {
                    Some((d, w, _)) => luminance(w) as f64 * n.dot(d).max(0.0) as f64,
                    None => 0.0,
                };
                mv.push(e);
            }
            let r = t_test(&mv, reference);
            assert!(
                r.passes(alpha),
                "case {k}: {} vs {reference}: {r:?}",
                mv.mean()
            );
            let r = t_test(&mv, reference * 1.02);
            assert!(!r.passes(alpha), "case {k}: 2% bias not detected: {r:?}");
        }
    }

    /// Midpoint rule on a fine (cos theta, phi) grid over the sphere.
    fn integrate_pdf(env: &EnvMap, nc: usize, np: usize) -> f64 {
        let mut sum = 0.0;
        let pi = std::f64::consts::PI;
        for c in 0..nc {
            let cos_t = 1.0 - (c as f64 + 0.5) * 2.0 / nc as f64;
            let sin_t = (1.0 - cos_t * cos_t).sqrt();
            for p in 0..np {
                let phi = (p as f64 + 0.5) * 2.0 * pi / np as f64;
                let d = Vec3::new(
                    (sin_t * phi.sin()) as f32,
                    cos_t as f32,
                    (-sin_t * phi.cos()) as f32,
                );
                sum += env.pdf(d) as f64;
            }
        }
        sum * (2.0 / nc as f64) * (2.0 * pi / np as f64)
    }

    #[test]
    fn pdf_integrates_to_one() {
        let cases = [
            (gradient(96, 48), rot_a(), EnvFilter::Bilinear, 2e-3),
            (sun_map(128, 64), rot_mirror(), EnvFilter::Bilinear, 5e-3),
            // Coarse texels: the midpoint rule's error is at their edges.
            (one_hot(16, 8, &[(5, 3)]), rot_a(), EnvFilter::Nearest, 5e-3),
        ];
        for (img, t, f, tol) in cases {
            let env = EnvMap::new(img, 1.0, t, f).unwrap();
            let i = integrate_pdf(&env, 1500, 3000);
            assert!((i - 1.0).abs() < tol, "integral {i}");
        }
    }

    #[test]
    fn samples_stay_on_the_support_and_the_support_has_pdf() {
        let (w, h, hot) = (64usize, 32usize, (20usize, 9usize));
        for filter in [EnvFilter::Bilinear, EnvFilter::Nearest] {
            let env = EnvMap::new(one_hot(w, h, &[hot]), 1.0, rot_a(), filter).unwrap();
            let reach = if filter == EnvFilter::Bilinear { 1 } else { 0 };
            let mut s = Sampler::new(9, 9);
            for _ in 0..100_000 {
                let (d, _, pdf) = env.sample(s.next_2d()).expect("sample");
                assert!(pdf > 0.0);
                let uv = EnvMap::dir_to_uv(env.to_world.inv.transform_vector3(d));
                let (i, j) = ((uv.x * w as f32) as i64, (uv.y * h as f32) as i64);
                assert!((i - hot.0 as i64).abs() <= reach && (j - hot.1 as i64).abs() <= reach);
            }
            // Everywhere the map shines, the pdf is positive.
            let mut lit = 0;
            for c in 0..800 {
                for p in 0..1600 {
                    let uv = Vec2::new((p as f32 + 0.5) / 1600.0, (c as f32 + 0.5) / 800.0);
                    let d = env.to_world.vector(EnvMap::uv_to_dir(uv));
                    if env.eval(d).max_element() > 0.0 {
                        lit += 1;
                        assert!(env.pdf(d) > 0.0, "eval > 0 but pdf = 0 at {uv}");
                    }
                }
            }
            assert!(lit > 0);
        }
    }

    #[test]
    fn poles_and_degenerate_inputs_are_finite() {
        let maps = [
            EnvMap::new(
                one_hot(16, 8, &[(0, 0), (5, 7)]),
                1.0,
                Transform::IDENTITY,
                EnvFilter::Bilinear,
            )
            .unwrap(),
            EnvMap::new(sun_map(32, 16), 1.0, rot_a(), EnvFilter::Nearest).unwrap(),
            EnvMap::new(
                constant(1, 1, Rgb::ONE),
                1.0,
                Transform::IDENTITY,
                EnvFilter::Bilinear,
            )
            .unwrap(),
        ];
        let dirs = [
            Vec3::Y,
            -Vec3::Y,
            Vec3::new(1e-30, 1.0, 0.0),
            Vec3::new(0.0, -1.0, -1e-38),
            Vec3::new(-0.0, 1.0, -0.0),
            Vec3::new(1e30, 1e30, 0.0),
            Vec3::new(1e-40, 0.0, 0.0),
            Vec3::ZERO,
            Vec3::splat(f32::NAN),
            Vec3::new(f32::INFINITY, 0.0, 0.0),
        ];
        for env in &maps {
            for d in dirs {
                let (e, p) = (env.eval(d), env.pdf(d));
                assert!(e.is_finite() && e.min_element() >= 0.0, "eval({d}) = {e}");
                assert!(p.is_finite() && p >= 0.0, "pdf({d}) = {p}");
            }
            assert!(env.eval(Vec3::Y).max_element() > 0.0 || env.image.width == 16);
            assert!(env.pdf(Vec3::ZERO) == 0.0 && env.pdf(Vec3::splat(f32::NAN)) == 0.0);
            let edge = 1.0 - f32::EPSILON;
            for u in [
                Vec2::ZERO,
                Vec2::new(edge, edge),
                Vec2::new(0.5, 0.0),
                Vec2::new(0.0, edge),
                Vec2::splat(1.0),
                Vec2::splat(f32::NAN),
                Vec2::new(-3.0, 7.0),
            ] {
                if let Some((d, w, p)) = env.sample(u) {
                    assert!(d.is_finite() && w.is_finite() && p.is_finite() && p > 0.0);
                }
            }
        }
    }

    #[test]
    fn black_maps_emit_nothing_and_bad_maps_are_refused() {
        let black = EnvMap::new(
            Bitmap::new(16, 8),
            1.0,
            Transform::IDENTITY,
            EnvFilter::Bilinear,
        )
        .unwrap();
        assert!(black.sample(Vec2::splat(0.3)).is_none());
        assert_eq!(black.pdf(Vec3::X), 0.0);
        assert_eq!(black.mean_luminance(), 0.0);
        assert!(!black.has_light());
        let empty = EnvMap::new(
            Bitmap::new(0, 0),
            1.0,
            Transform::IDENTITY,
            EnvFilter::Nearest,
        );
        assert!(matches!(empty, Err(EnvMapError::Empty { .. })));
        let off = EnvMap::new(
            sun_map(16, 8),
            0.0,
            Transform::IDENTITY,
            EnvFilter::Bilinear,
        )
        .unwrap();
        assert!(off.sample(Vec2::splat(0.3)).is_none() && off.pdf(Vec3::X) == 0.0);
        let mut bad = constant(4, 2, Rgb::ONE);
        bad.set(1, 1, Rgb::new(1.0, -1.0, 1.0));
        let texel = EnvMap::new(bad.clone(), 1.0, Transform::IDENTITY, EnvFilter::Bilinear);
        assert!(
            matches!(texel, Err(EnvMapError::Texel { x: 1, y: 1, .. })),
            "{texel:?}"
        );
        bad.set(1, 1, Rgb::new(f32::NAN, 0.0, 0.0));
        let nan = EnvMap::new(bad, 1.0, Transform::IDENTITY, EnvFilter::Bilinear);
        assert!(matches!(nan, Err(EnvMapError::Texel { .. })));
        let scale = EnvMap::new(sun_map(16, 8), f32::INFINITY, rot_a(), EnvFilter::Bilinear);
        assert!(matches!(scale, Err(EnvMapError::Scale(_))));
        let sheared = Transform::new(crate::math::Mat4::from_scale(Vec3::new(1.0, 2.0, 1.0)));
        let shear = EnvMap::new(sun_map(16, 8), 1.0, sheared.unwrap(), EnvFilter::Bilinear);
        assert!(matches!(shear, Err(EnvMapError::ToWorld)));
    }

    #[test]
    fn mean_luminance_of_a_constant_map() {
        let c = Rgb::new(0.5, 2.0, 1.0);
        let env = EnvMap::new(constant(64, 32, c), 3.0, rot_a(), EnvFilter::Bilinear).unwrap();
        let want = 3.0 * luminance(c);
        assert!((env.mean_luminance() - want).abs() < 1e-3 * want);
        // A constant map is sampled almost uniformly: weights ~ eval / (1/4pi).
        let (_, w, _) = env.sample(Vec2::new(0.3, 0.6)).unwrap();
        assert!((luminance(w) / (4.0 * PI * want) - 1.0).abs() < 0.05);
    }
}
