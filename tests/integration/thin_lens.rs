//! Thin-lens depth of field: geometry of the circle of confusion, and
//! renders of point-like lights in and out of focus.

use std::sync::atomic::AtomicBool;

use crate::common::*;
use lente::camera::{Aperture, Camera, CameraParams};
use lente::color::{luminance, Rgb};
use lente::image::Bitmap;
use lente::integrator::Strategy;
use lente::math::{Vec2, Vec3};
use lente::render::{render, RenderOptions};
use lente::sampling::Sampler;
use lente::scene::Scene;

fn camera(lens_radius: f32, focal_distance: f32, aperture: Aperture) -> Camera {
    Camera::new(CameraParams {
        width: 200,
        height: 150,
        fov_x_deg: 40.0,
        fov_axis: lente::camera::FovAxis::X,
        lens_radius,
        focal_distance,
        aperture,
        ..Default::default()
    })
    .unwrap()
}

/// Normalised image-plane position (camera space, z = 1) of a film position.
fn plane_pos(cam: &Camera, film: Vec2) -> Vec2 {
    let d = cam.camera_direction(film);
    Vec2::new(d.x, d.y)
}

/// For a camera-space point P and lens point L, the image-plane position
/// whose thin-lens ray through L passes through P is
/// P_xy / P_z - L (1/P_z - 1/f): a disk of radius R |1/f - 1/P_z|.
#[test]
fn points_map_through_the_lens_as_the_thin_lens_formula_says() {
    let f = 3.0;
    for aperture in [
        Aperture::Circular,
        Aperture::Polygon {
            blades: 5,
            rotation: 0.2,
        },
    ] {
        let cam = camera(0.25, f, aperture);
        let mut s = Sampler::new(3, 3);
        for depth in [1.0f32, 3.0, 8.0, 40.0] {
            let p = Vec3::new(0.3, -0.2, 1.0) * depth;
            let expect_radius = 0.25 * (1.0 / f - 1.0 / depth).abs();
            let centre = Vec2::new(p.x / p.z, p.y / p.z);
            let mut max_r = 0.0f32;
            for _ in 0..2000 {
                let u = s.next_2d();
                let lens = cam.lens_point(u);
                let img = centre - lens * (1.0 / depth - 1.0 / f);
                max_r = max_r.max((img - centre).length());
                assert!((img - centre).length() <= expect_radius * (1.0 + 1e-4) + 1e-7);
                // Find the film position of `img` and check the ray hits P.
                let film = {
                    let probe = Vec3::new(img.x, img.y, 1.0);
                    cam.camera_to_film(probe)
                };
                assert!((plane_pos(&cam, film) - img).length() < 1e-5);
                let r = cam.generate_ray(film, u);
                let t = (p - r.o).dot(r.d);
                let miss = (r.at(t) - p).length();
                assert!(miss < 1e-4 * depth, "depth {depth}: ray misses P by {miss}");
            }
            if depth == f {
                assert!(max_r < 1e-6);
            } else {
                // The spread reaches the formula's radius (up to sampling).
                let reach = match aperture {
                    Aperture::Circular => 0.97,
                    Aperture::Polygon { blades, .. } => {
                        0.97 * (std::f32::consts::PI / blades as f32).cos()
                    }
                };
                assert!(
                    max_r > reach * expect_radius,
                    "depth {depth}: {max_r} vs {expect_radius}"
                );
            }
        }
    }
}

#[test]
fn zero_lens_radius_is_bit_identical_to_the_pinhole() {
    let pin = camera(0.0, 1.0, Aperture::Circular);
    let thin = camera(
        0.0,
        7.5,
        Aperture::Polygon {
            blades: 6,
            rotation: 0.0,
        },
    );
    let mut s = Sampler::new(1, 1);
    for _ in 0..10_000 {
        let f = s.next_2d() * Vec2::new(200.0, 150.0);
        let u = s.next_2d();
        let (a, b) = (pin.generate_ray(f, u), thin.generate_ray(f, u));
        assert_eq!(
            a.o.to_array().map(f32::to_bits),
            b.o.to_array().map(f32::to_bits)
        );
        assert_eq!(
            a.d.to_array().map(f32::to_bits),
            b.d.to_array().map(f32::to_bits)
        );
    }
}

const SIZE: u32 = 81;
const FOV: f32 = 20.0;
/// Radius in pixels of the emitting sphere's own (pinhole) image.
const SPHERE_PX: f32 = 1.5;

fn pixels_per_unit() -> f32 {
    SIZE as f32 / (2.0 * (FOV / 2.0).to_radians().tan())
}

/// A scene of one small emitting sphere on the optical axis at `depth`.
fn point_scene(depth: f32, lens_radius: f32, focal: f32, aperture: Aperture) -> TestScene {
    let mut cam = look_at(Vec3::ZERO, Vec3::Z, FOV, SIZE, SIZE);
    cam.lens_radius = lens_radius;
    cam.focal_distance = focal;
    cam.aperture = aperture;
    let mut d = desc(cam, path(Strategy::Mats));
    d.shapes.push(shape(
        sphere(
            Vec3::new(0.0, 0.0, depth),
            SPHERE_PX / pixels_per_unit() * depth,
        ),
        diffuse(0.0),
        Some(Rgb::splat(1000.0)),
    ));
    d.build()
}

fn render_image(scene: &Scene, spp: u32) -> Bitmap {
    let opts = RenderOptions::new(1);
    let job = job(path(Strategy::Mats), spp);
    render(scene, &job, &opts, &AtomicBool::new(false)).image
}

/// Moments of the image about its centre: (rms radius, |n-th angular
/// harmonic| weighted by r^2). For a uniform disk of radius R the rms radius
/// is R / sqrt(2); both are averages over every pixel, so pixel noise
/// averages out and no threshold is needed.
fn moments(img: &Bitmap, n: u32) -> (f32, f32) {
    let c = Vec2::new(img.width as f32 / 2.0, img.height as f32 / 2.0);
    let (mut w, mut wr2, mut re, mut im) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
    for y in 0..img.height {
        for x in 0..img.width {
            let v = luminance(img.get(x, y)) as f64;
            let d = Vec2::new(x as f32 + 0.5, y as f32 + 0.5) - c;
            let r2 = d.length_squared() as f64;
            let phi = d.y.atan2(d.x) as f64;
            w += v;
            wr2 += v * r2;
            re += v * r2 * (n as f64 * phi).cos();
            im += v * r2 * (n as f64 * phi).sin();
        }
    }
    (
        ((wr2 / w).sqrt()) as f32,
        ((re * re + im * im).sqrt() / wr2) as f32,
    )
}

/// Second moment E[r^2] and r^2-weighted n-th harmonic of a uniform sample
/// of an aperture of unit circumradius (by Monte Carlo).
fn aperture_moments(aperture: Aperture, n: u32) -> (f32, f32) {
    let cam = Camera::new(CameraParams {
        lens_radius: 1.0,
        focal_distance: 1.0,
        aperture,
        ..Default::default()
    })
    .unwrap();
    let mut s = Sampler::new(77, 0);
    let (mut wr2, mut re, mut im) = (0.0f64, 0.0f64, 0.0f64);
    let m = 400_000;
    for _ in 0..m {
        let p = cam.lens_point(s.next_2d());
        let r2 = p.length_squared() as f64;
        let phi = p.y.atan2(p.x) as f64;
        wr2 += r2;
        re += r2 * (n as f64 * phi).cos();
        im += r2 * (n as f64 * phi).sin();
    }
    (
        (wr2 / m as f64) as f32,
        ((re * re + im * im).sqrt() / wr2) as f32,
    )
}

/// Predicted rms radius in pixels: the circle of confusion (circumradius
/// `coc`) convolved with the sphere's own disk image and the pixel box.
fn predicted_rms(coc: f32, aperture_r2: f32) -> f32 {
    (coc * coc * aperture_r2 + SPHERE_PX * SPHERE_PX / 2.0 + 1.0 / 6.0).sqrt()
}

#[test]
fn out_of_focus_point_renders_as_a_disk_of_the_predicted_radius() {
    let (r, f, depth) = (0.1, 2.0, 20.0);
    let scene = point_scene(depth, r, f, Aperture::Circular);
    let img = render_image(&scene, 1024);
    let coc = r * (1.0 / f - 1.0 / depth) * pixels_per_unit();
    let (rms, _) = moments(&img, 5);
    let predicted = predicted_rms(coc, 0.5);
    // Compare as disk radii (rms * sqrt 2): within one pixel.
    let (measured_r, predicted_r) = (rms * 2f32.sqrt(), predicted * 2f32.sqrt());
    eprintln!("disk: measured radius {measured_r} px, predicted {predicted_r}");
    assert!(
        (measured_r - predicted_r).abs() < 1.0,
        "disk radius {measured_r} px vs predicted {predicted_r} (circle of confusion {coc})"
    );
    // A different focal distance must fail the same check (the test has power).
    let wrong = predicted_rms(r * (1.0 / 1.8 - 1.0 / depth) * pixels_per_unit(), 0.5);
    assert!((measured_r - wrong * 2f32.sqrt()).abs() > 1.0);
}

#[test]
fn out_of_focus_point_takes_the_aperture_polygon_shape() {
    let (r, f, depth, blades) = (0.1, 2.0, 20.0, 5u32);
    let polygon = Aperture::Polygon {
        blades,
        rotation: 0.3,
    };
    let coc = r * (1.0 / f - 1.0 / depth) * pixels_per_unit();
    let (ap_r2, ap_c) = aperture_moments(polygon, blades);
    let img = render_image(&point_scene(depth, r, f, polygon), 1024);
    let (rms, c) = moments(&img, blades);
    let predicted = predicted_rms(coc, ap_r2);
    assert!(
        (rms - predicted).abs() < 0.7,
        "rms radius {rms} px vs predicted {predicted}"
    );
    // The pentagon's five-fold harmonic is there; a disk's is not.
    let disk = render_image(&point_scene(depth, r, f, Aperture::Circular), 1024);
    let (_, c_disk) = moments(&disk, blades);
    eprintln!("polygon: rms {rms} vs {predicted}; harmonic {c} vs {ap_c}, disk {c_disk}");
    assert!(
        (c - ap_c).abs() < 0.35 * ap_c && c_disk < 0.3 * ap_c,
        "harmonic {c} (aperture {ap_c}), disk {c_disk}"
    );
}

#[test]
fn point_on_the_focal_plane_stays_sharp() {
    let scene = point_scene(2.0, 0.1, 2.0, Aperture::Circular);
    let img = render_image(&scene, 256);
    let (rms, _) = moments(&img, 5);
    let width = rms * 2f32.sqrt();
    assert!(width < 3.0, "in-focus point spreads to radius {width} px");
}
