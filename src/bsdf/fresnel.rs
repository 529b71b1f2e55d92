//! Fresnel reflectance.

use crate::color::Rgb;

/// Unpolarised Fresnel reflectance of a smooth dielectric interface.
/// `cos_i` is the cosine on the incident side (may be negative: the ray is
/// inside), `eta` = interior / exterior IOR. Returns (R, cos_t, eta_ti) where
/// cos_t is the (positive) transmitted cosine and eta_ti the relative IOR
/// crossed in the direction of travel. Total internal reflection gives R = 1.
pub fn fresnel_dielectric(cos_i: f32, eta: f32) -> (f32, f32, f32) {
    let (cos_i, eta_ti) = if cos_i < 0.0 {
        (-cos_i, 1.0 / eta)
    } else {
        (cos_i, eta)
    };
    if eta_ti == 1.0 {
        return (0.0, cos_i, 1.0);
    }
    let sin2_t = (1.0 - cos_i * cos_i).max(0.0) / (eta_ti * eta_ti);
    if sin2_t >= 1.0 {
        return (1.0, 0.0, eta_ti);
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let rs = (cos_i - eta_ti * cos_t) / (cos_i + eta_ti * cos_t);
    let rp = (eta_ti * cos_i - cos_t) / (eta_ti * cos_i + cos_t);
    (0.5 * (rs * rs + rp * rp), cos_t, eta_ti)
}

/// Unpolarised Fresnel reflectance of a conductor with complex relative
/// IOR `eta + i k` (per RGB channel), for light arriving from outside
/// (`cos_i` > 0). Mitsuba's `fresnel_conductor` (after Moeller, "Optics").
pub fn fresnel_conductor(cos_i: f32, eta: Rgb, k: Rgb) -> Rgb {
    Rgb::new(
        fresnel_conductor_1(cos_i, eta.x, k.x),
        fresnel_conductor_1(cos_i, eta.y, k.y),
        fresnel_conductor_1(cos_i, eta.z, k.z),
    )
}

/// One channel of [`fresnel_conductor`].
pub fn fresnel_conductor_1(cos_i: f32, eta: f32, k: f32) -> f32 {
    let cos2 = cos_i * cos_i;
    let sin2 = 1.0 - cos2;
    let sin4 = sin2 * sin2;
    let temp_1 = eta * eta - k * k - sin2;
    let a2_pb2 = (temp_1 * temp_1 + 4.0 * k * k * eta * eta).max(0.0).sqrt();
    let a = (0.5 * (a2_pb2 + temp_1)).max(0.0).sqrt();
    let term_1 = a2_pb2 + cos2;
    let term_2 = 2.0 * cos_i * a;
    let r_s = (term_1 - term_2) / (term_1 + term_2);
    let term_3 = a2_pb2 * cos2 + sin4;
    let term_4 = term_2 * sin2;
    let r_p = r_s * (term_3 - term_4) / (term_3 + term_4);
    0.5 * (r_s + r_p)
}

/// Hemispherical average of the dielectric Fresnel reflectance for light
/// arriving from the side where the relative IOR is `eta` ("Fdr"), with
/// the two fits Mitsuba uses (Egan and Hilgeman for eta < 1, d'Eon and
/// Irving otherwise).
pub fn fresnel_diffuse_reflectance(eta: f32) -> f32 {
    let inv = 1.0 / eta;
    if eta < 1.0 {
        0.0636 * inv + eta * (eta * -1.4399 + 0.7099) + 0.6681
    } else {
        // Horner in 1/eta.
        let c = [0.919317f32, -3.4793, 6.75335, -7.80989, 4.98554, -1.36881];
        c.iter().rev().fold(0.0, |acc, &ci| acc * inv + ci)
    }
}

/// Schlick's weight (1 − cos)^5, cos clipped to [0, 1].
#[inline]
pub(super) fn schlick_weight(cos: f32) -> f32 {
    let m = (1.0 - cos).clamp(0.0, 1.0);
    (m * m) * (m * m) * m
}

/// Schlick's Fresnel approximation: R0 + (1 − R0)(1 − cos)^5.
#[inline]
pub(super) fn schlick(r0: Rgb, cos: f32) -> Rgb {
    r0 + (Rgb::ONE - r0) * schlick_weight(cos)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn normal_incidence_matches_closed_form() {
        let (r, _, _) = fresnel_dielectric(1.0, 1.5);
        assert!((r - 0.04).abs() < 1e-6);
        let (r2, _, _) = fresnel_dielectric(-1.0, 1.5);
        assert!((r2 - 0.04).abs() < 1e-6);
    }

    #[test]
    fn conductor_closed_forms() {
        // Normal incidence: ((n-1)^2 + k^2) / ((n+1)^2 + k^2).
        for &(n, k) in &[(0.2f32, 3.9f32), (1.5, 0.0), (2.4, 1.3), (0.0, 1.0)] {
            let r = fresnel_conductor_1(1.0, n, k);
            let e = ((n - 1.0).powi(2) + k * k) / ((n + 1.0).powi(2) + k * k);
            assert!((r - e).abs() < 1e-5, "{n} {k}: {r} vs {e}");
        }
        // k = 0 reduces to the dielectric formula.
        for &c in &[0.1f32, 0.5, 0.9] {
            let (d, _, _) = fresnel_dielectric(c, 1.7);
            assert!((fresnel_conductor_1(c, 1.7, 0.0) - d).abs() < 1e-5);
        }
        // eta = 0, k = 1 (Mitsuba's `none`) reflects everything.
        for &c in &[1.0f32, 0.7, 0.2, 1e-3] {
            assert_eq!(fresnel_conductor_1(c, 0.0, 1.0), 1.0);
        }
    }

    #[test]
    fn diffuse_reflectance_matches_numeric_average() {
        // Fdr = 2 * integral of F(cos) cos dcos over [0, 1].
        for &eta in &[1.0f32 / 1.49, 1.33, 1.49, 2.0] {
            let n = 20000;
            let mut acc = 0.0f64;
            for i in 0..n {
                let c = (i as f32 + 0.5) / n as f32;
                acc += (fresnel_dielectric(c, eta).0 * c) as f64;
            }
            let num = 2.0 * acc / n as f64;
            let fit = fresnel_diffuse_reflectance(eta) as f64;
            assert!(
                (num - fit).abs() < 0.01 * num.max(0.05),
                "{eta}: {num} vs {fit}"
            );
        }
    }

    #[test]
    fn total_internal_reflection() {
        // Inside glass, grazing: beyond the critical angle asin(1/1.5) ~ 41.8 deg.
        let (r, _, _) = fresnel_dielectric(-0.5, 1.5);
        assert_eq!(r, 1.0);
    }
}
