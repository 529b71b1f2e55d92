//! Fresnel reflectance.

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
    fn total_internal_reflection() {
        // Inside glass, grazing: beyond the critical angle asin(1/1.5) ~ 41.8 deg.
        let (r, _, _) = fresnel_dielectric(-0.5, 1.5);
        assert_eq!(r, 1.0);
    }
}
