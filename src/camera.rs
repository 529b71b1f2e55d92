//! The perspective camera, pinhole or thin lens, and Mitsuba's
//! orthographic one (Nori's and Mitsuba's conventions: image x runs
//! towards camera -x, y towards camera -y).

use crate::math::{Ray, Transform, Vec2, Vec3, PI};
use crate::sampling::warp;

/// Shape of the lens aperture.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Aperture {
    /// A disk (concentric mapping).
    Circular,
    /// A regular polygon with `blades` sides rotated by `rotation` radians.
    Polygon { blades: u32, rotation: f32 },
}

/// How camera rays leave the camera.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Projection {
    /// From the eye (or the lens) through the image plane.
    #[default]
    Perspective,
    /// Mitsuba's `orthographic`: parallel rays along camera +z from the
    /// plane z = near_clip, over x in [-1, 1] and y in [-h/w, h/w] of
    /// camera space (`to_world` scales it; the field of view is unused).
    Orthographic,
}

/// Everything a scene file says about the camera.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraParams {
    pub width: u32,
    pub height: u32,
    /// Horizontal field of view in degrees.
    pub fov_x_deg: f32,
    /// The image axis the scene gave the field of view for: a new image
    /// size ([`CameraParams::set_resolution`]) keeps the view along it.
    pub fov_axis: FovAxis,
    pub near_clip: f32,
    pub far_clip: f32,
    pub to_world: Transform,
    /// 0 is a pinhole.
    pub lens_radius: f32,
    /// Distance along the viewing axis to the plane in focus.
    pub focal_distance: f32,
    pub aperture: Aperture,
    /// Set `focal_distance` to the depth of the first surface on the
    /// optical axis when the scene is built.
    pub autofocus: bool,
    pub projection: Projection,
}

/// Which extent of the image a scene's field of view spans (Mitsuba's
/// `fov_axis`; Nori's `fov` is horizontal, `X`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum FovAxis {
    #[default]
    X,
    Y,
    Diagonal,
    /// The shorter side (y for a landscape image).
    Smaller,
    /// The longer side.
    Larger,
}

impl FovAxis {
    /// tan(half the view along this axis) / tan(half the horizontal view)
    /// for an image of aspect width / height.
    fn tan_ratio(self, aspect: f64) -> f64 {
        match self {
            FovAxis::X => 1.0,
            FovAxis::Y => 1.0 / aspect,
            FovAxis::Diagonal => (1.0 + 1.0 / (aspect * aspect)).sqrt(),
            FovAxis::Smaller if aspect > 1.0 => 1.0 / aspect,
            FovAxis::Smaller => 1.0,
            FovAxis::Larger if aspect > 1.0 => 1.0,
            FovAxis::Larger => 1.0 / aspect,
        }
    }

    /// The horizontal field of view (degrees) of an image of aspect
    /// width / height whose view along this axis is `fov` degrees.
    pub fn horizontal_fov(self, fov: f64, aspect: f64) -> f64 {
        let t = (0.5 * fov).to_radians().tan() / self.tan_ratio(aspect);
        2.0 * t.atan().to_degrees()
    }
}

impl CameraParams {
    /// A new image size that keeps the field of view along `fov_axis`, as
    /// Mitsuba does when its film changes shape (`--resolution`).
    pub fn set_resolution(&mut self, width: u32, height: u32) {
        if self.width > 0 && self.height > 0 && width > 0 && height > 0 {
            let old = self.width as f64 / self.height as f64;
            let new = width as f64 / height as f64;
            // The half-view's tangent along the axis stays; x follows it.
            let half_x = (0.5 * self.fov_x_deg as f64).to_radians().tan();
            let scaled = half_x * self.fov_axis.tan_ratio(old) / self.fov_axis.tan_ratio(new);
            self.fov_x_deg = (2.0 * scaled.atan().to_degrees()) as f32;
        }
        self.width = width;
        self.height = height;
    }
}

impl Default for CameraParams {
    /// Nori's defaults.
    fn default() -> Self {
        CameraParams {
            width: 1280,
            height: 720,
            fov_x_deg: 30.0,
            fov_axis: FovAxis::X,
            near_clip: 1e-4,
            far_clip: 1e4,
            to_world: Transform::IDENTITY,
            lens_radius: 0.0,
            focal_distance: 1.0,
            aperture: Aperture::Circular,
            autofocus: false,
            projection: Projection::Perspective,
        }
    }
}

/// Largest image width or height.
pub const MAX_RESOLUTION: u32 = 65536;

/// Most blades a polygonal aperture may have.
pub const MAX_APERTURE_BLADES: u32 = 1024;

/// The parameter of [`CameraParams`] a [`CameraError`] is about (scene
/// readers name it as their dialect spells it).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CameraParam {
    Width,
    Height,
    FieldOfView,
    NearClip,
    FarClip,
    LensRadius,
    FocalDistance,
    ApertureBlades,
    ApertureRotation,
}

/// Camera parameters that describe no camera. Each message completes a
/// sentence that starts with the parameter's name.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum CameraError {
    #[error("must be between 1 and {MAX_RESOLUTION} pixels, found {0}")]
    Width(u32),
    #[error("must be between 1 and {MAX_RESOLUTION} pixels, found {0}")]
    Height(u32),
    #[error(
        "({height}) times the width ({width}) is {} pixels, more than the {} lente renders",
        *width as u64 * *height as u64, crate::limits::MAX_IMAGE_PIXELS
    )]
    TooManyPixels { width: u32, height: u32 },
    #[error("must be between 0 and 180 degrees (exclusive), found {0}")]
    FieldOfView(f32),
    #[error("must not be negative, found {0}")]
    NearClip(f32),
    #[error("({far}) must be greater than the near clip distance ({near})")]
    FarClip { near: f32, far: f32 },
    #[error("must not be negative, found {0}")]
    LensRadius(f32),
    #[error("must be positive, found {0}")]
    FocalDistance(f32),
    #[error("must be 0 (a circular aperture) or between 3 and {MAX_APERTURE_BLADES}, found {0}")]
    ApertureBlades(u32),
    #[error("must be a finite number, found {0}")]
    ApertureRotation(f32),
}

impl CameraParam {
    /// The parameter in words, for messages that name no scene dialect.
    pub fn describe(self) -> &'static str {
        match self {
            CameraParam::Width => "image width",
            CameraParam::Height => "image height",
            CameraParam::FieldOfView => "field of view",
            CameraParam::NearClip => "near clip distance",
            CameraParam::FarClip => "far clip distance",
            CameraParam::LensRadius => "lens radius",
            CameraParam::FocalDistance => "focal distance",
            CameraParam::ApertureBlades => "number of aperture blades",
            CameraParam::ApertureRotation => "aperture rotation",
        }
    }
}

impl CameraError {
    /// The parameter that is wrong.
    pub fn param(&self) -> CameraParam {
        match self {
            CameraError::Width(_) => CameraParam::Width,
            CameraError::Height(_) | CameraError::TooManyPixels { .. } => CameraParam::Height,
            CameraError::FieldOfView(_) => CameraParam::FieldOfView,
            CameraError::NearClip(_) => CameraParam::NearClip,
            CameraError::FarClip { .. } => CameraParam::FarClip,
            CameraError::LensRadius(_) => CameraParam::LensRadius,
            CameraError::FocalDistance(_) => CameraParam::FocalDistance,
            CameraError::ApertureBlades(_) => CameraParam::ApertureBlades,
            CameraError::ApertureRotation(_) => CameraParam::ApertureRotation,
        }
    }
}

impl CameraParams {
    /// Checks that the parameters describe a camera: an image of 1 to
    /// [`MAX_RESOLUTION`] pixels each way and at most
    /// [`crate::limits::MAX_IMAGE_PIXELS`] in all, a field of view strictly
    /// between 0 and 180 degrees, clip distances with 0 <= near < far, a
    /// finite non-negative lens radius, a positive finite focal distance
    /// (unless autofocus is to set it), an aperture polygon
    /// of 3 to [`MAX_APERTURE_BLADES`] blades.
    pub fn validate(&self) -> Result<(), CameraError> {
        let pixels = 1..=MAX_RESOLUTION;
        if !pixels.contains(&self.width) {
            return Err(CameraError::Width(self.width));
        }
        if !pixels.contains(&self.height) {
            return Err(CameraError::Height(self.height));
        }
        if self.width as u64 * self.height as u64 > crate::limits::MAX_IMAGE_PIXELS {
            return Err(CameraError::TooManyPixels {
                width: self.width,
                height: self.height,
            });
        }
        if !(self.fov_x_deg > 0.0 && self.fov_x_deg < 180.0) {
            return Err(CameraError::FieldOfView(self.fov_x_deg));
        }
        if self.near_clip.is_nan() || self.near_clip < 0.0 {
            return Err(CameraError::NearClip(self.near_clip));
        }
        if self.far_clip.is_nan() || self.far_clip <= self.near_clip {
            return Err(CameraError::FarClip {
                near: self.near_clip,
                far: self.far_clip,
            });
        }
        if !(self.lens_radius >= 0.0 && self.lens_radius.is_finite()) {
            return Err(CameraError::LensRadius(self.lens_radius));
        }
        // Autofocus sets the focal distance when the scene is built.
        let focus_ok = self.focal_distance > 0.0 && self.focal_distance.is_finite();
        if !self.autofocus && !focus_ok {
            return Err(CameraError::FocalDistance(self.focal_distance));
        }
        if let Aperture::Polygon { blades, rotation } = self.aperture {
            if !(3..=MAX_APERTURE_BLADES).contains(&blades) {
                return Err(CameraError::ApertureBlades(blades));
            }
            if !rotation.is_finite() {
                return Err(CameraError::ApertureRotation(rotation));
            }
        }
        Ok(())
    }
}

/// A camera ready to generate rays.
#[derive(Clone, Debug)]
pub struct Camera {
    pub params: CameraParams,
    tan_half_x: f32,
    inv_aspect: f32,
    /// `params.to_world.point(Vec3::ZERO)`: a pinhole's every ray starts
    /// there (the same bits, without a matrix product and a division per
    /// camera ray).
    pinhole_origin: Vec3,
}

impl Camera {
    /// A camera for valid parameters (see [`CameraParams::validate`]).
    pub fn new(params: CameraParams) -> Result<Camera, CameraError> {
        params.validate()?;
        Ok(Camera::new_unchecked(params))
    }

    /// A camera for parameters already validated.
    fn new_unchecked(params: CameraParams) -> Camera {
        let tan_half_x = (params.fov_x_deg.to_radians() * 0.5).tan();
        let inv_aspect = params.height as f32 / params.width as f32;
        Camera {
            pinhole_origin: params.to_world.point(Vec3::ZERO),
            params,
            tan_half_x,
            inv_aspect,
        }
    }

    pub fn width(&self) -> u32 {
        self.params.width
    }

    pub fn height(&self) -> u32 {
        self.params.height
    }

    /// Camera-space direction (z = 1) through a film position in pixels.
    pub fn camera_direction(&self, film: Vec2) -> Vec3 {
        let sx = film.x / self.params.width as f32;
        let sy = film.y / self.params.height as f32;
        Vec3::new(
            (1.0 - 2.0 * sx) * self.tan_half_x,
            (1.0 - 2.0 * sy) * self.tan_half_x * self.inv_aspect,
            1.0,
        )
    }

    /// Maps a camera-space point to its film position in pixels (the inverse
    /// of [`camera_direction`](Self::camera_direction) for the pinhole).
    pub fn camera_to_film(&self, p: Vec3) -> Vec2 {
        let x = p.x / p.z / self.tan_half_x;
        let y = p.y / p.z / (self.tan_half_x * self.inv_aspect);
        Vec2::new(
            (1.0 - x) * 0.5 * self.params.width as f32,
            (1.0 - y) * 0.5 * self.params.height as f32,
        )
    }

    /// Point on the lens (camera space, z = 0) for an aperture sample.
    pub fn lens_point(&self, u: Vec2) -> Vec2 {
        let disk = match self.params.aperture {
            Aperture::Circular => warp::square_to_uniform_disk(u),
            Aperture::Polygon { blades, rotation } => sample_regular_polygon(u, blades, rotation),
        };
        self.params.lens_radius * disk
    }

    /// Generates a world-space ray (unit direction) through `film` (pixels).
    pub fn generate_ray(&self, film: Vec2, aperture: Vec2) -> Ray {
        if self.params.projection == Projection::Orthographic {
            return self.orthographic_ray(film);
        }
        let d = self.camera_direction(film);
        let (wo, d) = if self.params.lens_radius > 0.0 {
            let lens = self.lens_point(aperture);
            let focus = d * self.params.focal_distance;
            let o = Vec3::new(lens.x, lens.y, 0.0);
            (self.params.to_world.point(o), (focus - o).normalize())
        } else {
            (self.pinhole_origin, d.normalize())
        };
        let inv_z = 1.0 / d.z;
        let wd = self.params.to_world.vector(d).normalize();
        Ray::with_range(
            wo,
            wd,
            self.params.near_clip * inv_z,
            self.params.far_clip * inv_z,
        )
    }
}

impl Camera {
    /// [`Camera::generate_ray`] of each film position (pixels) and its
    /// aperture sample, into `rays`: the same rays bit for bit. Where the
    /// CPU has AVX2, perspective rays are made eight at a time in SIMD
    /// lanes: each ray's two normalisations are a chain of square roots
    /// and divisions (7% of a Veach render, 9% of the constant cube's,
    /// one ray at a time) that the lanes run once for eight rays.
    pub fn generate_rays(&self, films: &[Vec2], apertures: &[Vec2], rays: &mut [Ray]) {
        assert!(films.len() == apertures.len() && films.len() == rays.len());
        #[cfg(target_arch = "x86_64")]
        if self.params.projection == Projection::Perspective
            && crate::geometry::PacketIsa::detect().is_some()
        {
            // SAFETY: the CPU has AVX2 (`PacketIsa::detect`).
            return unsafe { self.perspective_rays_avx2(films, apertures, rays) };
        }
        for ((ray, &film), &aperture) in rays.iter_mut().zip(films).zip(apertures) {
            *ray = self.generate_ray(film, aperture);
        }
    }

    /// [`Camera::generate_rays`] of perspective rays in AVX2 lanes: each
    /// lane does `generate_ray`'s operations in its order (glam's
    /// normalisation is `v * (1 / sqrt(dot(v, v)))`, its matrix product
    /// sums the axes' terms in order); the lens points and the ray origins
    /// behind a lens, a polygon's or a disk's sample and one matrix
    /// product each, are computed one ray at a time.
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn perspective_rays_avx2(&self, films: &[Vec2], apertures: &[Vec2], rays: &mut [Ray]) {
        use crate::geometry::lanes::{Avx2Lanes, Lanes, MAX_LANES};
        // Eight rays at a time, in arrays of MAX_LANES.
        const W: usize = <Avx2Lanes as Lanes>::WIDTH;
        // SAFETY: the caller saw AVX2.
        let l = unsafe { Avx2Lanes::new_unchecked() };
        let p = &self.params;
        let m = &p.to_world.m;
        let axis = |a: crate::math::Vec4| [l.splat(a.x), l.splat(a.y), l.splat(a.z)];
        let axes = [axis(m.x_axis), axis(m.y_axis), axis(m.z_axis)];
        let (w, h) = (l.splat(p.width as f32), l.splat(p.height as f32));
        let (one, two) = (l.splat(1.0), l.splat(2.0));
        let (tan_x, inv_aspect) = (l.splat(self.tan_half_x), l.splat(self.inv_aspect));
        let (near, far) = (l.splat(p.near_clip), l.splat(p.far_clip));
        let lens = p.lens_radius > 0.0;
        let focal = l.splat(p.focal_distance);
        let chunks = films.chunks(W).zip(apertures.chunks(W));
        for ((films, apertures), rays) in chunks.zip(rays.chunks_mut(W)) {
            // Lanes beyond the rays compute a ray through (0, 0), unused.
            let (mut fx, mut fy) = ([0.0f32; MAX_LANES], [0.0f32; MAX_LANES]);
            for (k, f) in films.iter().enumerate() {
                (fx[k], fy[k]) = (f.x, f.y);
            }
            let sx = l.load(&fx) / w;
            let sy = l.load(&fy) / h;
            let dx = (one - two * sx) * tan_x;
            let dy = (one - two * sy) * tan_x * inv_aspect;
            let mut o = [
                l.splat(self.pinhole_origin.x),
                l.splat(self.pinhole_origin.y),
                l.splat(self.pinhole_origin.z),
            ];
            let d = if lens {
                let (mut lx, mut ly) = ([0.0f32; MAX_LANES], [0.0f32; MAX_LANES]);
                let mut wo = [[0.0f32; MAX_LANES]; 3];
                for (k, &a) in apertures.iter().enumerate() {
                    let q = self.lens_point(a);
                    (lx[k], ly[k]) = (q.x, q.y);
                    let at = p.to_world.point(Vec3::new(q.x, q.y, 0.0));
                    (wo[0][k], wo[1][k], wo[2][k]) = (at.x, at.y, at.z);
                }
                o = [l.load(&wo[0]), l.load(&wo[1]), l.load(&wo[2])];
                // (d * focal - (lens.x, lens.y, 0)), d.z being 1.
                let v = [
                    dx * focal - l.load(&lx),
                    dy * focal - l.load(&ly),
                    one * focal - l.zero(),
                ];
                normalize_lanes(l, v)
            } else {
                normalize_lanes(l, [dx, dy, one])
            };
            let inv_z = one / d[2];
            // `Mat4::transform_vector3`: the x axis's term, plus the y
            // axis's, plus the z axis's.
            let [ax, ay, az] = axes;
            let wd = [
                ax[0] * d[0] + ay[0] * d[1] + az[0] * d[2],
                ax[1] * d[0] + ay[1] * d[1] + az[1] * d[2],
                ax[2] * d[0] + ay[2] * d[1] + az[2] * d[2],
            ];
            let wd = normalize_lanes(l, wd);
            let fields = [
                o[0],
                o[1],
                o[2],
                wd[0],
                wd[1],
                wd[2],
                near * inv_z,
                far * inv_z,
            ];
            l.store_rays(fields, rays);
        }
    }

    /// Mitsuba's orthographic ray: from the near plane, along +z, over
    /// the near clip to the far one.
    fn orthographic_ray(&self, film: Vec2) -> Ray {
        let sx = film.x / self.params.width as f32;
        let sy = film.y / self.params.height as f32;
        let p = Vec3::new(
            1.0 - 2.0 * sx,
            (1.0 - 2.0 * sy) * self.inv_aspect,
            self.params.near_clip,
        );
        let o = self.params.to_world.point(p);
        let d = self.params.to_world.vector(Vec3::Z).normalize();
        Ray::with_range(o, d, 0.0, self.params.far_clip - self.params.near_clip)
    }
}

/// glam's `Vec3::normalize` in lanes: `v * (1 / sqrt(dot(v, v)))`, the
/// dot product summed x, y, z.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn normalize_lanes<L: crate::geometry::lanes::Lanes>(l: L, [x, y, z]: [L::F; 3]) -> [L::F; 3] {
    let r = l.splat(1.0) / l.sqrt(x * x + y * y + z * z);
    [x * r, y * r, z * r]
}

/// Uniform sample of a regular polygon inscribed in the unit circle:
/// pick a triangle fan wedge uniformly, then a uniform point in it.
pub fn sample_regular_polygon(u: Vec2, blades: u32, rotation: f32) -> Vec2 {
    let n = blades as f32;
    let k = ((u.x * n) as u32).min(blades - 1);
    let ux = u.x * n - k as f32;
    let a0 = rotation + 2.0 * PI * k as f32 / n;
    let a1 = rotation + 2.0 * PI * (k + 1) as f32 / n;
    let b = warp::square_to_uniform_triangle(Vec2::new(ux, u.y));
    let p1 = Vec2::new(a0.cos(), a0.sin());
    let p2 = Vec2::new(a1.cos(), a1.sin());
    b.x * p1 + b.y * p2
}

/// Area of the regular polygon inscribed in the unit circle.
pub fn regular_polygon_area(blades: u32) -> f32 {
    let n = blades as f32;
    0.5 * n * (2.0 * PI / n).sin()
}

#[cfg(test)]
mod tests {
    #[test]
    fn orthographic_rays_are_parallel_and_span_the_scaled_plane() {
        let params = CameraParams {
            width: 40,
            height: 20,
            near_clip: 0.5,
            far_clip: 10.0,
            to_world: Transform::new(crate::math::Mat4::from_scale(Vec3::new(3.0, 3.0, 1.0)))
                .unwrap(),
            projection: Projection::Orthographic,
            ..CameraParams::default()
        };
        let cam = Camera::new(params).unwrap();
        let corner = cam.generate_ray(Vec2::ZERO, Vec2::ZERO);
        let centre = cam.generate_ray(Vec2::new(20.0, 10.0), Vec2::ZERO);
        let far = cam.generate_ray(Vec2::new(40.0, 20.0), Vec2::ZERO);
        for r in [corner, centre, far] {
            assert!((r.d - Vec3::Z).length() < 1e-6, "{:?}", r.d);
            assert_eq!(r.o.z, 0.5);
        }
        // Image x runs towards camera -x: the top-left pixel sees +x, +y.
        assert!(
            (corner.o - Vec3::new(3.0, 1.5, 0.5)).length() < 1e-5,
            "{:?}",
            corner.o
        );
        assert!((centre.o - Vec3::new(0.0, 0.0, 0.5)).length() < 1e-5);
        assert!((far.o - Vec3::new(-3.0, -1.5, 0.5)).length() < 1e-5);
    }

    use super::*;

    fn cam(lens_radius: f32) -> Camera {
        Camera::new(CameraParams {
            width: 64,
            height: 48,
            lens_radius,
            focal_distance: 5.0,
            ..Default::default()
        })
        .unwrap()
    }

    #[test]
    fn invalid_parameters_name_the_parameter() {
        let ok = CameraParams::default();
        assert_eq!(ok.validate(), Ok(()));
        let bad = |p: CameraParams| p.validate().unwrap_err().param();
        assert_eq!(
            bad(CameraParams {
                width: 0,
                ..ok.clone()
            }),
            CameraParam::Width
        );
        let fov = CameraParams {
            fov_x_deg: 180.0,
            fov_axis: FovAxis::X,
            ..ok.clone()
        };
        assert_eq!(bad(fov), CameraParam::FieldOfView);
        let clip = CameraParams {
            near_clip: 2.0,
            far_clip: 1.0,
            ..ok.clone()
        };
        assert_eq!(bad(clip), CameraParam::FarClip);
        let lens = CameraParams {
            lens_radius: f32::NAN,
            ..ok.clone()
        };
        assert_eq!(bad(lens), CameraParam::LensRadius);
        let focus = CameraParams {
            lens_radius: 0.1,
            focal_distance: 0.0,
            ..ok.clone()
        };
        assert_eq!(bad(focus.clone()), CameraParam::FocalDistance);
        // Autofocus sets the focal distance later.
        let auto = CameraParams {
            autofocus: true,
            ..focus
        };
        assert_eq!(auto.validate(), Ok(()));
        let blades = CameraParams {
            aperture: Aperture::Polygon {
                blades: 2,
                rotation: 0.0,
            },
            ..ok
        };
        assert_eq!(bad(blades), CameraParam::ApertureBlades);
    }

    /// `generate_rays` (eight at a time in lanes where the CPU has AVX2)
    /// makes `generate_ray`'s rays bit for bit: pinhole, disk and polygon
    /// lenses and the orthographic camera, under a rotated, scaled
    /// `to_world`, for batches that fill their last eight lanes or not.
    #[test]
    fn batches_of_rays_are_the_single_rays() {
        let to_world = Transform::new(
            crate::math::Mat4::from_translation(Vec3::new(0.3, -1.2, 4.0))
                * crate::math::Mat4::from_axis_angle(Vec3::new(1.0, 2.0, -0.5).normalize(), 0.7)
                * crate::math::Mat4::from_scale(Vec3::new(-1.0, 1.3, 0.9)),
        )
        .unwrap();
        let polygon = Aperture::Polygon {
            blades: 6,
            rotation: 0.3,
        };
        let mut sampler = crate::sampling::Sampler::new(7, 11);
        for (lens_radius, aperture, projection) in [
            (0.0, Aperture::Circular, Projection::Perspective),
            (0.2, Aperture::Circular, Projection::Perspective),
            (0.2, polygon, Projection::Perspective),
            (0.0, Aperture::Circular, Projection::Orthographic),
        ] {
            let c = Camera::new(CameraParams {
                width: 37,
                height: 23,
                fov_x_deg: 50.0,
                near_clip: 0.01,
                far_clip: 500.0,
                to_world,
                lens_radius,
                focal_distance: 3.5,
                aperture,
                projection,
                ..Default::default()
            })
            .unwrap();
            for n in [1, 7, 8, 9, 16, 21] {
                let films: Vec<Vec2> = (0..n)
                    .map(|_| sampler.next_2d() * Vec2::new(37.0, 23.0))
                    .collect();
                let apertures: Vec<Vec2> = (0..n).map(|_| sampler.next_2d()).collect();
                let mut rays = vec![Ray::new(Vec3::ZERO, Vec3::Z); n];
                c.generate_rays(&films, &apertures, &mut rays);
                for ((r, &f), &a) in rays.iter().zip(&films).zip(&apertures) {
                    let one = c.generate_ray(f, a);
                    let bits = |r: &Ray| {
                        [r.o.to_array(), r.d.to_array(), [r.tmin, r.tmax, 0.0]]
                            .map(|v| v.map(f32::to_bits))
                    };
                    assert_eq!(bits(r), bits(&one), "lens {lens_radius}, {projection:?}");
                }
            }
        }
    }

    #[test]
    fn centre_ray_looks_down_z() {
        let c = cam(0.0);
        let r = c.generate_ray(Vec2::new(32.0, 24.0), Vec2::splat(0.5));
        assert!((r.d - Vec3::Z).length() < 1e-6);
    }

    #[test]
    fn image_x_runs_towards_camera_minus_x() {
        let c = cam(0.0);
        let r = c.generate_ray(Vec2::new(63.0, 24.0), Vec2::ZERO);
        assert!(r.d.x < 0.0);
        let r = c.generate_ray(Vec2::new(32.0, 1.0), Vec2::ZERO);
        assert!(r.d.y > 0.0);
    }

    #[test]
    fn film_mapping_round_trips() {
        let c = cam(0.0);
        let f = Vec2::new(10.3, 40.7);
        let back = c.camera_to_film(c.camera_direction(f) * 3.0);
        assert!((back - f).length() < 1e-3);
    }

    #[test]
    fn focal_plane_points_are_sharp() {
        let c = cam(0.5);
        let f = Vec2::new(20.0, 30.0);
        let target = c.camera_direction(f) * 5.0;
        for i in 0..20 {
            let r = c.generate_ray(f, Vec2::new(i as f32 / 20.0, 0.37));
            let t = (5.0 - r.o.z) / r.d.z;
            assert!((r.at(t) - target).length() < 1e-4);
        }
    }
}
