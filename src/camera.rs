//! The perspective camera, pinhole or thin lens (Nori's and Mitsuba's
//! conventions: image x runs towards camera -x, y towards camera -y).

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

/// Everything a scene file says about the camera.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraParams {
    pub width: u32,
    pub height: u32,
    /// Horizontal field of view in degrees.
    pub fov_x_deg: f32,
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
}

impl Default for CameraParams {
    /// Nori's defaults.
    fn default() -> Self {
        CameraParams {
            width: 1280,
            height: 720,
            fov_x_deg: 30.0,
            near_clip: 1e-4,
            far_clip: 1e4,
            to_world: Transform::IDENTITY,
            lens_radius: 0.0,
            focal_distance: 1.0,
            aperture: Aperture::Circular,
            autofocus: false,
        }
    }
}

/// A camera ready to generate rays.
#[derive(Clone, Debug)]
pub struct Camera {
    pub params: CameraParams,
    tan_half_x: f32,
    inv_aspect: f32,
}

impl Camera {
    pub fn new(params: CameraParams) -> Camera {
        let tan_half_x = (params.fov_x_deg.to_radians() * 0.5).tan();
        let inv_aspect = params.height as f32 / params.width as f32;
        Camera {
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
        let d = self.camera_direction(film);
        let (o, d) = if self.params.lens_radius > 0.0 {
            let lens = self.lens_point(aperture);
            let focus = d * self.params.focal_distance;
            let o = Vec3::new(lens.x, lens.y, 0.0);
            (o, (focus - o).normalize())
        } else {
            (Vec3::ZERO, d.normalize())
        };
        let inv_z = 1.0 / d.z;
        let wo = self.params.to_world.point(o);
        let wd = self.params.to_world.vector(d).normalize();
        Ray::with_range(
            wo,
            wd,
            self.params.near_clip * inv_z,
            self.params.far_clip * inv_z,
        )
    }
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
    use super::*;

    fn cam(lens_radius: f32) -> Camera {
        Camera::new(CameraParams {
            width: 64,
            height: 48,
            lens_radius,
            focal_distance: 5.0,
            ..Default::default()
        })
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
