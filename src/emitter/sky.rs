//! A procedural clear sky baked into a lat-long map: no downloads, no data
//! files.
//!
//! # Model
//!
//! * **Sky**: Preetham, Shirley and Smits, "A Practical Analytic Model for
//!   Daylight" (SIGGRAPH 1999): the Perez et al. distribution
//!   `F(theta, gamma) = (1 + A e^(B / cos theta)) (1 + C e^(D gamma) + E cos^2 gamma)`
//!   for luminance Y and chromaticity x, y, with the paper's turbidity fits
//!   for A..E, its zenith luminance `Y_z` (kcd/m^2) and zenith chromaticity
//!   polynomials; `Y = Y_z F(theta, gamma) / F(0, theta_sun)` and likewise for
//!   x and y. CIE xyY is converted to XYZ and then to linear sRGB (Rec. 709
//!   primaries, D65 white); negative components (colours outside sRGB) are
//!   clipped to zero. Turbidity is clamped to [2, 10].
//! * **Sun**: a uniform disk of angular radius [`SUN_ANGULAR_RADIUS_DEG`]
//!   (solid angle [`sun_solid_angle`] = 6.81e-5 sr). Its spectral radiance is
//!   the extraterrestrial sun, approximated by a 5772 K black body (the Sun's
//!   effective temperature: with the Sun's angular size this gives the solar
//!   constant, 1361 W/m^2, and about 128 klux), times Preetham's (Appendix A.2)
//!   transmittances for Rayleigh scattering, `exp(-0.008735 lambda^-4.08 m)`,
//!   aerosols, `exp(-beta lambda^-1.3 m)` with
//!   `beta = 0.04608 T - 0.04586`, and ozone (`l = 0.35 cm`, Preetham's
//!   Table 2 absorption), with `lambda` in micrometres and relative air mass
//!   `m = 1 / (cos z + 0.15 (93.885 - z_deg)^-1.253)` (Kasten 1966). Water
//!   vapour and mixed-gas absorption (red and near-infrared bands) are
//!   neglected. The spectrum is integrated against the CIE 1931 colour matching
//!   functions (the analytic fit of Wyman, Sloan and Shirley 2013) from 380 to
//!   780 nm. At turbidity 3 and 60 degrees elevation this gives a direct
//!   normal illuminance of about 86 klux (slightly warm white, x, y = 0.346,
//!   0.356), about 75 klux on a horizontal plane. No limb darkening.
//! * **Ground** (below the horizon): a Lambertian grey ground of albedo
//!   [`GROUND_ALBEDO`] = 0.3 lit by this sky and sun, i.e. a constant
//!   radiance albedo * E_horizontal / pi, so a mirror shows a plausible
//!   ground and diffuse objects get light from below. The sun disk is
//!   hidden where it dips below the horizon.
//! * **Sun below the horizon** (elevation < 0, outside Preetham's domain):
//!   the sky is the Preetham sky for the sun on the horizon dimmed by a factor
//!   `10^(elevation_deg / 3)` (one decade per 3 degrees), a rough twilight
//!   fade, not physics.
//!
//! Preetham's sky is bright in absolute terms: on a horizontal plane at
//! turbidity 3 it gives 29 klux at 45 degrees sun elevation and 31 klux at
//! 60 (the sun adds 56 and 75 klux), so the sun-to-sky irradiance ratio on a
//! horizontal plane is only about 2 to 2.6 at turbidity 3 and 2.6 to 4.1 at
//! turbidity 2 (45 to 80 degrees elevation), below the roughly 4 to 8
//! measured under clear skies. Sun and sky are both left as the published
//! models give them.
//!
//! # Units
//!
//! Radiance is photometric and scaled: one unit of luminance is
//! [`LUMINANCE_UNIT_CD_M2`] = 10^4 cd/m^2 (the luminance of the linear RGB
//! value, with the Rec. 709 weights of [`crate::color::luminance`]). So the
//! zenith at turbidity 3 and 45 degrees elevation is 0.73, the sun disk
//! about 1.2e5 to 1.3e5 (45 to 90 degrees), and a white Lambertian plane facing up under the sun at 45 to 90
//! degrees elevation has radiance 2.7 to 4.2. `scale` multiplies everything.
//!
//! # Directions
//!
//! The map uses the lat-long convention of [`crate::emitter::EnvMap`]: +y
//! is up (top row), u = 0 looks down -z, u = 0.25 down +x. The sun is at
//! `elevation` degrees above the horizon and at **azimuth** degrees measured
//! like u: azimuth 0 is towards -z, 90 towards +x, 180 towards +z, 270
//! towards -x ([`sun_direction`]).
//!
//! # Baking
//!
//! The map is `resolution` x `resolution / 2` texels; each sky texel holds the
//! sky at its centre. The sun (0.53 degrees across) is smaller than a texel at
//! common resolutions (0.35 degrees at 1024 x 512), so it is integrated: the
//! part of the disk's solid angle that falls in each texel is estimated on a
//! fine grid (uniform in solid angle, at least 32 points per sun radius), and
//! the texel receives `L_sun * overlap / texel solid angle`. The overlaps are
//! then rescaled to sum to the disk's exact solid angle, so the sun's power
//! `L_sun * Omega_sun` (and the irradiance it gives) is the same at any
//! resolution.

use crate::color::Rgb;
use crate::image::Bitmap;
use crate::math::Vec3;
use glam::DVec3;
use rayon::prelude::*;
use std::f64::consts::PI;

/// Angular radius of the Sun seen from the Earth (mean), degrees.
pub const SUN_ANGULAR_RADIUS_DEG: f64 = 0.2667;

/// Luminance, in cd/m^2, of one unit of the baked radiance.
pub const LUMINANCE_UNIT_CD_M2: f64 = 1.0e4;

/// Albedo of the grey ground below the horizon.
pub const GROUND_ALBEDO: f64 = 0.3;

/// Solid angle of the sun disk, steradians.
pub fn sun_solid_angle() -> f64 {
    2.0 * PI * (1.0 - SUN_ANGULAR_RADIUS_DEG.to_radians().cos())
}

/// Parameters of the procedural sky.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SkyParams {
    /// Preetham turbidity, 2 (very clear) to 10 (hazy); clamped to [2, 10].
    pub turbidity: f32,
    /// Sun elevation above the horizon, degrees (-90..90).
    pub sun_elevation_deg: f32,
    /// Sun azimuth, degrees: 0 towards -z, 90 towards +x (the lat-long u
    /// convention; see the module docs).
    pub sun_azimuth_deg: f32,
    /// Multiplier on sky and sun radiance.
    pub scale: f32,
    /// Width of the baked lat-long map (height is half).
    pub resolution: usize,
}

impl Default for SkyParams {
    fn default() -> Self {
        SkyParams {
            turbidity: 3.0,
            sun_elevation_deg: 45.0,
            sun_azimuth_deg: 0.0,
            scale: 1.0,
            resolution: 1024,
        }
    }
}

/// Bakes the sky (and its sun disk) into a linear lat-long bitmap.
pub fn bake_sky(params: &SkyParams) -> Bitmap {
    bake(params, true)
}

/// Unit direction towards the centre of the sun (world frame, +y up).
pub fn sun_direction(params: &SkyParams) -> Vec3 {
    let m = SkyModel::new(params);
    m.sun_dir.as_vec3()
}

/// Radiance of the sun disk (uniform over the disk), including `scale`.
pub fn sun_radiance(params: &SkyParams) -> Rgb {
    let m = SkyModel::new(params);
    (m.sun_radiance * m.scale).as_vec3()
}

/// Radiance of the sky (above the horizon) or the ground (below) in world
/// direction `d`, without the sun disk, including `scale`. Builds the model
/// on every call: use [`bake_sky`] for maps.
pub fn sky_radiance(params: &SkyParams, d: Vec3) -> Rgb {
    let m = SkyModel::new(params);
    let d = d.as_dvec3().normalize_or_zero();
    if d == DVec3::ZERO {
        return Rgb::ZERO;
    }
    (m.radiance(d) * m.scale).as_vec3()
}

/// Width and height of the baked map.
fn map_size(params: &SkyParams) -> (usize, usize) {
    let w = params.resolution.max(2);
    (w, (w / 2).max(1))
}

/// Lat-long direction of (u, v), as in [`crate::emitter::EnvMap::uv_to_dir`].
fn uv_to_dir(u: f64, v: f64) -> DVec3 {
    let (sp, cp) = (2.0 * PI * u).sin_cos();
    let (st, ct) = (PI * v).sin_cos();
    DVec3::new(st * sp, ct, -st * cp)
}

fn bake(params: &SkyParams, with_sun: bool) -> Bitmap {
    let (w, h) = map_size(params);
    let m = SkyModel::new(params);
    let mut bmp = Bitmap::new(w, h);
    bmp.pixels
        .par_chunks_mut(w)
        .enumerate()
        .for_each(|(j, row)| {
            let v = (j as f64 + 0.5) / h as f64;
            for (i, px) in row.iter_mut().enumerate() {
                let u = (i as f64 + 0.5) / w as f64;
                *px = (m.radiance(uv_to_dir(u, v)) * m.scale).as_vec3();
            }
        });
    if with_sun {
        add_sun(&mut bmp, &m);
    }
    bmp
}

/// Exact solid angle of texel row `j` (any column) of an h-row map.
fn texel_solid_angle(w: usize, h: usize, j: usize) -> f64 {
    let (t0, t1) = (PI * j as f64 / h as f64, PI * (j + 1) as f64 / h as f64);
    2.0 * PI / w as f64 * (t0.cos() - t1.cos())
}

/// Adds the sun disk to the texels it covers, conserving its power.
fn add_sun(bmp: &mut Bitmap, m: &SkyModel) {
    let (w, h) = (bmp.width, bmp.height);
    let r = SUN_ANGULAR_RADIUS_DEG.to_radians();
    let cos_r = r.cos();
    let s = m.sun_dir;
    if s.y < -r.sin() || m.scale <= 0.0 || m.sun_radiance.max_element() <= 0.0 {
        return; // entirely below the horizon, or dark
    }
    let theta_s = s.y.clamp(-1.0, 1.0).acos();
    let phi_s = s.x.atan2(-s.z);
    let (dtheta, dphi) = (PI / h as f64, 2.0 * PI / w as f64);
    let j_lo = ((theta_s - r) / dtheta).floor().max(0.0) as usize;
    let j_hi = (((theta_s + r) / dtheta).floor().max(0.0) as usize).min(h - 1);
    // Sub-sample spacing: at most r / 32 in both directions.
    let per_r = 32.0;
    // (pixel index, visible overlap solid angle, texel solid angle)
    let mut hits: Vec<(usize, f64, f64)> = Vec::new();
    let mut total = 0.0; // overlap including the part below the horizon
    for j in j_lo..=j_hi {
        let (t0, t1) = (j as f64 * dtheta, (j + 1) as f64 * dtheta);
        let (a, b) = (t0.max(theta_s - r), t1.min(theta_s + r));
        if b < a {
            continue;
        }
        // Columns: the disk spans phi_s +- asin(sin r / sin theta) on rows
        // away from the poles; all columns if a pole is within reach.
        let sin_min = a.sin().min(b.sin());
        let cols: Vec<usize> = if sin_min <= (2.0 * r).sin() {
            (0..w).collect()
        } else {
            let half = (r.sin() / sin_min).min(1.0).asin() + dphi;
            let i0 = ((phi_s - half) / dphi).floor() as i64;
            let i1 = ((phi_s + half) / dphi).floor() as i64;
            if i1 - i0 + 1 >= w as i64 {
                (0..w).collect()
            } else {
                (i0..=i1).map(|i| i.rem_euclid(w as i64) as usize).collect()
            }
        };
        let omega_t = texel_solid_angle(w, h, j);
        let (c0, c1) = (t0.cos(), t1.cos());
        let sin_max = if t0 <= 0.5 * PI && t1 >= 0.5 * PI {
            1.0
        } else {
            t0.sin().max(t1.sin())
        };
        let n_t = ((dtheta / r * per_r).ceil() as usize).clamp(8, 1024);
        let n_p = ((dphi * sin_max / r * per_r).ceil() as usize).clamp(8, 1024);
        for i in cols {
            let (mut all, mut vis) = (0usize, 0usize);
            for a_t in 0..n_t {
                // Uniform in cos(theta): uniform in solid angle.
                let c = c0 + (c1 - c0) * (a_t as f64 + 0.5) / n_t as f64;
                let st = (1.0 - c * c).max(0.0).sqrt();
                for a_p in 0..n_p {
                    let phi = (i as f64 + (a_p as f64 + 0.5) / n_p as f64) * dphi;
                    let d = DVec3::new(st * phi.sin(), c, -st * phi.cos());
                    if d.dot(s) >= cos_r {
                        all += 1;
                        if d.y > 0.0 {
                            vis += 1;
                        }
                    }
                }
            }
            let n = (n_t * n_p) as f64;
            total += all as f64 / n * omega_t;
            if vis > 0 {
                hits.push((j * w + i, vis as f64 / n * omega_t, omega_t));
            }
        }
    }
    let l_sun = m.sun_radiance * m.scale;
    let omega_sun = sun_solid_angle();
    if total <= 0.0 {
        // Not reachable with the sub-sampling above; keep the power anyway.
        if s.y > 0.0 {
            let j = ((theta_s / dtheta) as usize).min(h - 1);
            let i = ((phi_s.rem_euclid(2.0 * PI) / dphi) as usize).min(w - 1);
            let px = &mut bmp.pixels[j * w + i];
            *px += (l_sun * (omega_sun / texel_solid_angle(w, h, j))).as_vec3();
        }
        return;
    }
    for (idx, overlap, omega_t) in hits {
        let frac = omega_sun * overlap / total / omega_t;
        bmp.pixels[idx] += (l_sun * frac).as_vec3();
    }
}

/// Perez et al. sky distribution function.
#[derive(Clone, Copy, Debug)]
struct Perez([f64; 5]);

impl Perez {
    fn f(&self, cos_theta: f64, gamma: f64) -> f64 {
        let [a, b, c, d, e] = self.0;
        let cg = gamma.cos();
        (1.0 + a * (b / cos_theta).exp()) * (1.0 + c * (d * gamma).exp() + e * cg * cg)
    }
}

/// The evaluated sky model for one set of parameters (f64 throughout).
struct SkyModel {
    /// True sun direction (may be below the horizon).
    sun_dir: DVec3,
    /// Sun direction the sky model uses (elevation clamped to >= 0).
    model_sun: DVec3,
    /// Perez functions for Y, x, y.
    perez: [Perez; 3],
    /// Zenith Y (units), x, y divided by F(0, theta_sun) of each.
    zenith_over_f0: [f64; 3],
    /// Twilight dimming for a sun below the horizon.
    twilight: f64,
    /// Ground luminance (units, before `scale`).
    ground: f64,
    /// Sun disk radiance, linear sRGB (units, before `scale`).
    sun_radiance: DVec3,
    scale: f64,
}

fn finite_or(x: f32, default: f64) -> f64 {
    if x.is_finite() {
        x as f64
    } else {
        default
    }
}

impl SkyModel {
    fn new(p: &SkyParams) -> SkyModel {
        let t = finite_or(p.turbidity, 3.0).clamp(2.0, 10.0);
        let elev = finite_or(p.sun_elevation_deg, 45.0).clamp(-90.0, 90.0);
        let azim = finite_or(p.sun_azimuth_deg, 0.0).rem_euclid(360.0);
        let scale = finite_or(p.scale, 1.0).max(0.0);
        let dir = |elev_deg: f64| uv_to_dir(azim / 360.0, (90.0 - elev_deg) / 180.0).normalize();
        let sun_dir = dir(elev);
        let model_elev = elev.max(0.0);
        let model_sun = dir(model_elev);
        let theta_s = (90.0 - model_elev).to_radians();

        let perez = [
            Perez([
                0.1787 * t - 1.4630,
                -0.3554 * t + 0.4275,
                -0.0227 * t + 5.3251,
                0.1206 * t - 2.5771,
                -0.0670 * t + 0.3703,
            ]),
            Perez([
                -0.0193 * t - 0.2592,
                -0.0665 * t + 0.0008,
                -0.0004 * t + 0.2125,
                -0.0641 * t - 0.8989,
                -0.0033 * t + 0.0452,
            ]),
            Perez([
                -0.0167 * t - 0.2608,
                -0.0950 * t + 0.0092,
                -0.0079 * t + 0.2102,
                -0.0441 * t - 1.6537,
                -0.0109 * t + 0.0529,
            ]),
        ];
        let chi = (4.0 / 9.0 - t / 120.0) * (PI - 2.0 * theta_s);
        // kcd/m^2 -> units.
        let y_z = ((4.0453 * t - 4.9710) * chi.tan() - 0.2155 * t + 2.4192).max(0.0) * 1.0e3
            / LUMINANCE_UNIT_CD_M2;
        let (t1, t2, t3) = (theta_s, theta_s * theta_s, theta_s * theta_s * theta_s);
        let tt = t * t;
        let x_z = (0.00166 * t3 - 0.00375 * t2 + 0.00209 * t1) * tt
            + (-0.02903 * t3 + 0.06377 * t2 - 0.03202 * t1 + 0.00394) * t
            + (0.11693 * t3 - 0.21196 * t2 + 0.06052 * t1 + 0.25886);
        let y_zc = (0.00275 * t3 - 0.00610 * t2 + 0.00317 * t1) * tt
            + (-0.04214 * t3 + 0.08970 * t2 - 0.04153 * t1 + 0.00516) * t
            + (0.15346 * t3 - 0.26756 * t2 + 0.06670 * t1 + 0.26688);
        let zenith = [y_z, x_z, y_zc];
        let mut zenith_over_f0 = [0.0; 3];
        for k in 0..3 {
            let f0 = perez[k].f(1.0, theta_s);
            zenith_over_f0[k] = if f0 > 0.0 { zenith[k] / f0 } else { 0.0 };
        }
        let mut model = SkyModel {
            sun_dir,
            model_sun,
            perez,
            zenith_over_f0,
            twilight: 10f64.powf(elev.min(0.0) / 3.0),
            ground: 0.0,
            sun_radiance: sun_spectral_to_rgb(t, 90.0 - elev),
            scale,
        };
        // Irradiance on a horizontal plane: the sky by midpoint quadrature
        // over (cos theta, phi), plus the sun disk.
        let (nt, np) = (64, 128);
        let mut e_sky = 0.0;
        for i in 0..nt {
            let cos_t = (i as f64 + 0.5) / nt as f64;
            let sin_t = (1.0 - cos_t * cos_t).sqrt();
            for j in 0..np {
                let phi = 2.0 * PI * (j as f64 + 0.5) / np as f64;
                let d = DVec3::new(sin_t * phi.cos(), cos_t, sin_t * phi.sin());
                e_sky += luminance64(model.sky(d)) * cos_t;
            }
        }
        e_sky *= 2.0 * PI / (nt * np) as f64;
        let e_sun = if elev > 0.0 {
            luminance64(model.sun_radiance) * sun_solid_angle() * elev.to_radians().sin()
        } else {
            0.0
        };
        model.ground = GROUND_ALBEDO * (e_sky + e_sun) / PI;
        model
    }

    /// Sky (y >= 0) or ground (y < 0) radiance for a unit direction, before
    /// `scale`.
    fn radiance(&self, d: DVec3) -> DVec3 {
        if d.y >= 0.0 {
            self.sky(d)
        } else {
            DVec3::splat(self.ground)
        }
    }

    /// Preetham sky radiance (linear sRGB, units) for a direction at or above
    /// the horizon.
    fn sky(&self, d: DVec3) -> DVec3 {
        // e^(B / cos theta) -> 0 at the horizon (B < 0 for T >= 2).
        let cos_t = d.y.max(1e-6);
        let gamma = d.dot(self.model_sun).clamp(-1.0, 1.0).acos();
        let big_y = self.zenith_over_f0[0] * self.perez[0].f(cos_t, gamma);
        let x = self.zenith_over_f0[1] * self.perez[1].f(cos_t, gamma);
        let y = self.zenith_over_f0[2] * self.perez[2].f(cos_t, gamma);
        if !(big_y > 0.0 && y > 1e-6 && x > 0.0 && big_y.is_finite()) {
            return DVec3::ZERO;
        }
        let xyz = DVec3::new(x / y * big_y, big_y, (1.0 - x - y) / y * big_y);
        (xyz_to_linear_srgb(xyz) * self.twilight).max(DVec3::ZERO)
    }
}

fn luminance64(c: DVec3) -> f64 {
    0.212671 * c.x + 0.715160 * c.y + 0.072169 * c.z
}

/// CIE XYZ to linear sRGB (Rec. 709 primaries, D65 white).
fn xyz_to_linear_srgb(c: DVec3) -> DVec3 {
    DVec3::new(
        3.2404542 * c.x - 1.5371385 * c.y - 0.4985314 * c.z,
        -0.9692660 * c.x + 1.8760108 * c.y + 0.0415560 * c.z,
        0.0556434 * c.x - 0.2040259 * c.y + 1.0572252 * c.z,
    )
}

/// Piecewise Gaussian used by the colour matching function fit.
fn g(x: f64, mu: f64, s1: f64, s2: f64) -> f64 {
    let t = (x - mu) / if x < mu { s1 } else { s2 };
    (-0.5 * t * t).exp()
}

/// CIE 1931 2-degree colour matching functions, multi-lobe fit of Wyman,
/// Sloan and Shirley, "Simple Analytic Approximations to the CIE XYZ Color
/// Matching Functions" (JCGT 2013). `lambda` in nm.
fn cie_xyz_bar(lambda: f64) -> DVec3 {
    let x = 1.056 * g(lambda, 599.8, 37.9, 31.0) + 0.362 * g(lambda, 442.0, 16.0, 26.7)
        - 0.065 * g(lambda, 501.1, 20.4, 26.2);
    let y = 0.821 * g(lambda, 568.8, 46.9, 40.5) + 0.286 * g(lambda, 530.9, 16.3, 31.1);
    let z = 1.217 * g(lambda, 437.0, 11.8, 36.0) + 0.681 * g(lambda, 459.0, 26.0, 13.8);
    DVec3::new(x, y, z)
}

/// Black-body spectral radiance, W / (m^2 sr nm), `lambda` in nm.
fn planck(lambda_nm: f64, temp: f64) -> f64 {
    const H: f64 = 6.626_070_15e-34;
    const C: f64 = 2.997_924_58e8;
    const K: f64 = 1.380_649e-23;
    let l = lambda_nm * 1e-9;
    2.0 * H * C * C / l.powi(5) / (H * C / (l * K * temp)).exp_m1() * 1e-9
}

/// Ozone absorption coefficient k_o (1/cm), Preetham et al. Table 2,
/// 440 nm to 790 nm in steps of 10 nm (zero outside).
const OZONE_K: [f64; 36] = [
    0.0, 0.003, 0.006, 0.009, 0.014, 0.021, 0.030, 0.040, 0.048, 0.063, 0.075, 0.085, 0.103, 0.120,
    0.120, 0.115, 0.125, 0.120, 0.105, 0.090, 0.079, 0.067, 0.057, 0.048, 0.036, 0.028, 0.023,
    0.018, 0.014, 0.011, 0.010, 0.009, 0.007, 0.004, 0.0, 0.0,
];

fn ozone_k(lambda_nm: f64) -> f64 {
    let x = (lambda_nm - 440.0) / 10.0;
    if !(0.0..35.0).contains(&x) {
        return 0.0;
    }
    let i = x.floor() as usize;
    let f = x - i as f64;
    OZONE_K[i] * (1.0 - f) + OZONE_K[i + 1] * f
}

/// Sun disk radiance in linear sRGB units for turbidity `t` and sun zenith
/// angle `zenith_deg` (clamped to the horizon for the air mass).
fn sun_spectral_to_rgb(t: f64, zenith_deg: f64) -> DVec3 {
    const T_SUN: f64 = 5772.0;
    const K_M: f64 = 683.0; // lm / W
    let z = zenith_deg.clamp(0.0, 90.0);
    let air_mass = 1.0 / (z.to_radians().cos() + 0.15 * (93.885 - z).powf(-1.253));
    let beta = 0.04608 * t - 0.04586;
    let step = 5.0;
    let mut xyz = DVec3::ZERO;
    let mut lambda: f64 = 380.0;
    while lambda <= 780.0 {
        let um = lambda * 1e-3;
        let tau = 0.008735 * um.powf(-4.08) + beta * um.powf(-1.3) + 0.35 * ozone_k(lambda);
        let l = planck(lambda, T_SUN) * (-tau * air_mass).exp();
        xyz += cie_xyz_bar(lambda) * (l * step);
        lambda += step;
    }
    xyz_to_linear_srgb(xyz * (K_M / LUMINANCE_UNIT_CD_M2)).max(DVec3::ZERO)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::color::luminance;

    fn params(turbidity: f32, elevation: f32, azimuth: f32, resolution: usize) -> SkyParams {
        SkyParams {
            turbidity,
            sun_elevation_deg: elevation,
            sun_azimuth_deg: azimuth,
            scale: 1.0,
            resolution,
        }
    }

    /// Sum over texels of value x texel solid angle x max(0, n . d): the
    /// irradiance on a plane with normal `n`; without `n`, the plain integral
    /// of the radiance over the sphere (the "power" of e.g. the sun disk).
    fn integrate(bmp: &Bitmap, n: Option<DVec3>) -> DVec3 {
        let (w, h) = (bmp.width, bmp.height);
        let mut sum = DVec3::ZERO;
        for j in 0..h {
            let omega = texel_solid_angle(w, h, j);
            for i in 0..w {
                let d = uv_to_dir((i as f64 + 0.5) / w as f64, (j as f64 + 0.5) / h as f64);
                let c = n.map_or(1.0, |n| n.dot(d).max(0.0));
                sum += bmp.get(i, j).as_dvec3() * omega * c;
            }
        }
        sum
    }

    /// The sun's part of the map: baked minus the same map without the sun.
    fn sun_only(p: &SkyParams) -> Bitmap {
        let (mut with, without) = (bake(p, true), bake(p, false));
        for (a, b) in with.pixels.iter_mut().zip(&without.pixels) {
            *a -= *b;
        }
        with
    }

    fn rel_err(a: DVec3, b: DVec3) -> f64 {
        ((a - b).abs() / b.abs().max(DVec3::splat(1e-30))).max_element()
    }

    #[test]
    fn sun_texels_are_brightest() {
        for (el, az) in [(45.0, 0.0), (10.0, 200.0), (89.9, 30.0), (70.0, 359.9)] {
            let p = params(3.0, el, az, 512);
            let bmp = bake_sky(&p);
            let s = sun_direction(&p).as_dvec3();
            let (w, h) = (bmp.width, bmp.height);
            let k = (0..w * h)
                .max_by(|&a, &b| luminance(bmp.pixels[a]).total_cmp(&luminance(bmp.pixels[b])))
                .unwrap();
            let d = uv_to_dir(
                ((k % w) as f64 + 0.5) / w as f64,
                ((k / w) as f64 + 0.5) / h as f64,
            );
            // Within the sun's radius plus a texel diagonal of the sun centre.
            let reach = SUN_ANGULAR_RADIUS_DEG.to_radians() + 1.5 * PI / h as f64;
            assert!(d.dot(s).clamp(-1.0, 1.0).acos() < reach, "{el} {az}");
            let sky_max = bake(&p, false)
                .pixels
                .iter()
                .map(|&c| luminance(c))
                .fold(0.0f32, f32::max);
            assert!(luminance(bmp.pixels[k]) > 100.0 * sky_max);
        }
    }

    #[test]
    fn sun_power_is_resolution_independent() {
        let omega = sun_solid_angle();
        assert!((omega - 6.8e-5).abs() < 0.05e-5);
        for el in [60.0, 3.0, 89.9, 90.0] {
            let powers: Vec<DVec3> = [64, 512, 2048]
                .iter()
                .map(|&res| integrate(&sun_only(&params(3.0, el, 123.0, res)), None))
                .collect();
            let want = sun_radiance(&params(3.0, el, 123.0, 8)).as_dvec3() * omega;
            for p in &powers {
                assert!(rel_err(*p, want) < 0.01, "elevation {el}: {p} vs {want}");
            }
            assert!(rel_err(powers[1], powers[2]) < 0.01);
        }
    }

    #[test]
    fn irradiance_facing_the_sun_matches_analytic() {
        let r = SUN_ANGULAR_RADIUS_DEG.to_radians();
        for (t, el, res) in [
            (3.0, 45.0, 1024),
            (2.0, 80.0, 512),
            (6.0, 20.0, 2048),
            (3.0, 90.0, 256),
        ] {
            let p = params(t, el, 77.0, res);
            let n = sun_direction(&p).as_dvec3();
            let e = integrate(&sun_only(&p), Some(n));
            // A uniform disk of angular radius r on a plane facing it.
            let want = sun_radiance(&p).as_dvec3() * PI * r.sin() * r.sin();
            assert!(rel_err(e, want) < 0.02, "{e} vs {want}");
        }
    }

    #[test]
    fn zenith_luminance_normalisation() {
        // Preetham: Y_z = (4.0453 T - 4.9710) tan(chi) - 0.2155 T + 2.4192
        // kcd/m^2, here / 10 (units of 10^4 cd/m^2).
        let p = params(3.0, 45.0, 0.0, 8);
        let chi = (4.0f64 / 9.0 - 3.0 / 120.0) * (PI - 2.0 * 45f64.to_radians());
        let want = ((4.0453 * 3.0 - 4.9710) * chi.tan() - 0.2155 * 3.0 + 2.4192) / 10.0;
        let got = luminance(sky_radiance(&p, Vec3::Y)) as f64;
        assert!((got - want).abs() < 0.01 * want, "{got} vs {want}");
        assert!((0.5..1.0).contains(&got));
    }

    #[test]
    fn high_sun_sky_shape() {
        for t in [2.0, 3.0, 5.0] {
            let p = params(t, 60.0, 0.0, 8);
            let at = |el: f64, az: f64| {
                let d = uv_to_dir(az / 360.0, (90.0 - el) / 180.0).as_vec3();
                sky_radiance(&p, d)
            };
            let zenith = at(90.0, 0.0);
            let horizon_anti = at(1.0, 180.0);
            let horizon_side = at(1.0, 90.0);
            let horizon_sun = at(1.0, 0.0);
            let mid_anti = at(30.0, 180.0);
            // Blue zenith, whiter horizon.
            assert!(zenith.z > zenith.y && zenith.y > zenith.x, "{zenith}");
            let blueness = |c: Rgb| c.z / c.x;
            assert!(blueness(zenith) > 1.5 * blueness(horizon_anti));
            assert!(blueness(zenith) > 1.5 * blueness(horizon_side));
            // Clear skies brighten towards the horizon away from the sun; the
            // horizon below the sun is brighter than the one opposite it.
            if t <= 3.0 {
                // (Under hazier skies Preetham's horizon opposite the sun is
                // dimmer than the sky above it.)
                assert!(luminance(horizon_anti) > luminance(mid_anti));
            }
            assert!(luminance(horizon_sun) > luminance(horizon_anti));
            // The sky is brightest around the sun.
            assert!(luminance(at(55.0, 0.0)) > luminance(zenith));
        }
    }

    #[test]
    fn azimuth_convention() {
        let w = 360;
        for (az, u) in [(0.0, 0.0), (90.0, 0.25), (180.0, 0.5), (270.0, 0.75)] {
            let p = params(3.0, 30.0, az, w);
            let d = sun_direction(&p);
            let want = crate::emitter::EnvMap::uv_to_dir(glam::Vec2::new(u, 60.0 / 180.0));
            assert!((d - want).length() < 1e-5, "{az}: {d} vs {want}");
            let bmp = bake_sky(&p);
            let k = (0..bmp.pixels.len())
                .max_by(|&a, &b| bmp.pixels[a].y.total_cmp(&bmp.pixels[b].y))
                .unwrap();
            let (i, j) = (k % w, k / w);
            let du = ((i as f32 + 0.5) / w as f32 - u).abs();
            assert!(du.min(1.0 - du) < 2.0 / w as f32, "{az}: column {i}");
            assert!((j as i64 - 60).abs() <= 1, "{az}: row {j}");
        }
        assert!(sun_direction(&params(3.0, 0.0, 0.0, 8)).z < -0.999);
        assert!(sun_direction(&params(3.0, 0.0, 90.0, 8)).x > 0.999);
        assert!(sun_direction(&params(3.0, 90.0, 0.0, 8)).y > 0.999);
    }

    #[test]
    fn ground_is_a_lit_grey_lambertian() {
        let p = params(3.0, 40.0, 10.0, 256);
        let bmp = bake_sky(&p);
        let (w, h) = (bmp.width, bmp.height);
        let g = bmp.get(7, h - 1);
        assert!(g.x > 0.0 && g.x == g.y && g.y == g.z);
        for i in 0..w {
            assert_eq!(bmp.get(i, h / 2 + 3), g);
        }
        // Irradiance on a horizontal plane from the baked upper half.
        let mut e = 0.0f64;
        for j in 0..h / 2 {
            let theta = (j as f64 + 0.5) / h as f64 * PI;
            for i in 0..w {
                let dw = (PI / h as f64) * (2.0 * PI / w as f64) * theta.sin();
                e += luminance(bmp.get(i, j)) as f64 * theta.cos() * dw;
            }
        }
        let expect = GROUND_ALBEDO * e / PI;
        let ratio = luminance(g) as f64 / expect;
        assert!(
            (0.95..1.05).contains(&ratio),
            "ground {} vs {expect}",
            luminance(g)
        );
    }

    #[test]
    fn sun_below_and_on_the_horizon() {
        let r = SUN_ANGULAR_RADIUS_DEG as f32;
        let full = sun_radiance(&params(3.0, 0.0, 0.0, 8)).as_dvec3() * sun_solid_angle();
        // Gone below the horizon: no sun texels; the sky fades.
        let p = params(3.0, -10.0, 30.0, 256);
        let lum = |p: &SkyParams| luminance(sky_radiance(p, Vec3::Y));
        assert_eq!(integrate(&sun_only(&p), None), DVec3::ZERO);
        assert!(lum(&p) < 1e-3 * lum(&params(3.0, 0.0, 30.0, 8)));
        assert!(lum(&params(3.0, -1.0, 0.0, 8)) < lum(&params(3.0, 0.0, 0.0, 8)));
        // Half set: about half the disk's power remains.
        let half = integrate(&sun_only(&params(3.0, 0.0, 30.0, 1024)), None);
        assert!(rel_err(half, full * 0.5) < 0.05, "{half} vs {}", full * 0.5);
        // Just above / just below the horizon.
        let p_up = params(3.0, 1.2 * r, 30.0, 1024);
        let up = integrate(&sun_only(&p_up), None);
        let full_up = sun_radiance(&p_up).as_dvec3() * sun_solid_angle();
        assert!(rel_err(up, full_up) < 0.01, "{up} vs {full_up}");
        let down = integrate(&sun_only(&params(3.0, -1.2 * r, 30.0, 1024)), None);
        assert_eq!(down, DVec3::ZERO);
    }

    #[test]
    fn no_nan_or_negative_over_parameter_range() {
        for t in [2.0, 2.5, 3.0, 4.0, 6.0, 8.0, 10.0] {
            for el in [
                -10.0, -3.0, -0.2, 0.0, 0.1, 1.0, 5.0, 15.0, 30.0, 45.0, 60.0, 75.0, 89.0, 90.0,
            ] {
                let p = params(t, el, 37.0 * el, 256);
                for c in bake_sky(&p).pixels {
                    assert!(
                        c.is_finite() && c.min_element() >= 0.0,
                        "T {t} el {el}: {c}"
                    );
                }
                let s = sun_radiance(&p);
                assert!(s.is_finite() && s.min_element() >= 0.0);
                if el >= 0.0 {
                    assert!(luminance(s) > 0.0);
                }
            }
        }
        // Nonsense parameters do not panic or poison the map.
        for p in [
            params(f32::NAN, f32::NAN, f32::INFINITY, 0),
            params(0.0, 200.0, -1e9, 1),
            params(50.0, -200.0, 0.0, 3),
        ] {
            for c in bake_sky(&p).pixels {
                assert!(c.is_finite() && c.min_element() >= 0.0);
            }
        }
    }

    #[test]
    fn scale_multiplies_everything() {
        let p = params(4.0, 35.0, 250.0, 128);
        let q = SkyParams { scale: 2.5, ..p };
        for (a, b) in bake_sky(&p).pixels.iter().zip(bake_sky(&q).pixels.iter()) {
            assert!((*a * 2.5 - *b).length() <= 1e-5 * b.length());
        }
    }

    /// Documents the absolute levels (see the module docs).
    #[test]
    fn absolute_levels_are_plausible() {
        let up = DVec3::Y;
        for (t, el) in [(2.0, 60.0), (3.0, 45.0), (3.0, 60.0), (3.0, 80.0)] {
            let p = params(t, el, 0.0, 1024);
            let sun = sun_only(&p);
            let e_sun = luminance(integrate(&sun, Some(up)).as_vec3()) as f64;
            let e_sky = luminance(integrate(&bake(&p, false), Some(up)).as_vec3()) as f64;
            let dni = luminance(sun_radiance(&p)) as f64 * sun_solid_angle() * LUMINANCE_UNIT_CD_M2;
            // Direct normal illuminance of a clear sky at moderate air mass.
            assert!((70e3..110e3).contains(&dni), "DNI {dni} lux");
            let ratio = e_sun / e_sky;
            assert!(
                (1.5..5.0).contains(&ratio),
                "T {t} el {el}: sun / sky = {ratio}"
            );
            // A white Lambertian plane facing up: radiance (E_sun + E_sky) / pi.
            let white = (e_sun + e_sky) / PI;
            assert!((1.0..5.0).contains(&white), "white plane {white}");
        }
    }
}
