//! Mitsuba 3's `roughdielectric`: Walter et al.'s microfacet model of a
//! rough interface between two dielectrics. A microfacet normal is sampled
//! (from the side `wi` is on), then reflection or refraction is chosen with
//! probability F / 1 - F. Transmitted radiance is scaled by 1/eta^2 (camera
//! paths carry radiance), as `Bsdf::Dielectric` does.

use super::distribution::{MicrofacetDistribution, Roughness};
use super::params::BsdfError;
use super::ThinDielectric;
use super::{fresnel_dielectric, BsdfSample};
use crate::color::Rgb;
use crate::math::{reflect, Vec2, Vec3};

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RoughDielectric {
    pub distr: MicrofacetDistribution,
    /// Interior IOR / exterior IOR.
    pub eta: f32,
    pub specular_reflectance: Rgb,
    pub specular_transmittance: Rgb,
}

/// `v` with the sign of `s` (Mitsuba's mulsign: +1 for s >= 0).
#[inline]
pub(super) fn mulsign(v: Vec3, s: f32) -> Vec3 {
    if s >= 0.0 {
        v
    } else {
        -v
    }
}

/// The generalised half vector of (wi, wo) across an interface of relative
/// IOR `eta` (outside over inside), turned to the outside; whether the pair
/// is a reflection; and the relative IOR seen from wi's side. None for
/// grazing `wi`.
pub(super) fn half_vector(wi: Vec3, wo: Vec3, eta: f32) -> Option<(Vec3, bool, f32)> {
    let (cos_i, cos_o) = (wi.z, wo.z);
    if cos_i == 0.0 {
        return None;
    }
    let reflect = cos_i * cos_o > 0.0;
    let eta = if cos_i > 0.0 { eta } else { 1.0 / eta };
    let m = (wi + wo * if reflect { 1.0 } else { eta }).normalize();
    if !m.is_finite() {
        return None;
    }
    Some((mulsign(m, m.z), reflect, eta))
}

impl RoughDielectric {
    /// Parameters (Mitsuba's names and defaults): `distribution`
    /// (beckmann), `alpha_u`, `alpha_v` (from `alpha`, 0.1), `int_ior`
    /// (bk7 = 1.5046), `ext_ior` (air = 1.000277), `specular_reflectance`
    /// (1), `specular_transmittance` (1), `sample_visible` (true).
    pub fn new(
        roughness: Roughness,
        int_ior: f32,
        ext_ior: f32,
        specular_reflectance: Rgb,
        specular_transmittance: Rgb,
    ) -> Result<RoughDielectric, BsdfError> {
        let smooth = ThinDielectric::new(
            int_ior,
            ext_ior,
            specular_reflectance,
            specular_transmittance,
        )?;
        Ok(RoughDielectric {
            distr: roughness.distribution()?,
            eta: smooth.eta,
            specular_reflectance: smooth.specular_reflectance,
            specular_transmittance: smooth.specular_transmittance,
        })
    }

    /// The distribution sampling uses: Walter's widened lobe when not
    /// sampling visible normals (it lowers the weights' variance).
    fn sample_distr(&self, cos_i: f32) -> MicrofacetDistribution {
        if self.distr.sample_visible {
            self.distr
        } else {
            self.distr.scaled(1.2 - 0.2 * cos_i.abs().sqrt())
        }
    }

    pub fn eval(&self, wi: Vec3, wo: Vec3) -> Rgb {
        let Some((m, reflect, eta)) = half_vector(wi, wo, self.eta) else {
            return Rgb::ZERO;
        };
        if wo.z == 0.0 {
            return Rgb::ZERO;
        }
        let d = self.distr.d(m);
        let g = self.distr.g(wi, wo, m);
        if d == 0.0 || g == 0.0 {
            return Rgb::ZERO;
        }
        let (f, _, _) = fresnel_dielectric(wi.dot(m), self.eta);
        let (cos_i, cos_o) = (wi.z.abs(), wo.z.abs());
        if reflect {
            self.specular_reflectance * (f * d * g / (4.0 * cos_i * cos_o))
        } else {
            let (dim, dom) = (wi.dot(m), wo.dot(m));
            let denom = dim + eta * dom;
            // Radiance scaling 1/eta^2 times Walter's eta^2: they cancel.
            let value = ((1.0 - f) * d * g * dim * dom / (cos_i * denom * denom)).abs();
            self.specular_transmittance * (value / cos_o)
        }
    }

    pub fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        let Some((m, reflect, eta)) = half_vector(wi, wo, self.eta) else {
            return 0.0;
        };
        let (dim, dom) = (wi.dot(m), wo.dot(m));
        if dim * wi.z <= 0.0 || dom * wo.z <= 0.0 {
            return 0.0;
        }
        let dwh_dwo = if reflect {
            1.0 / (4.0 * dom)
        } else {
            eta * eta * dom / (dim + eta * dom).powi(2)
        };
        let prob = self.sample_distr(wi.z).pdf(mulsign(wi, wi.z), m);
        let (f, _, _) = fresnel_dielectric(dim, self.eta);
        let lobe = if reflect { f } else { 1.0 - f };
        (prob * lobe * dwh_dwo).abs()
    }

    pub fn sample(&self, wi: Vec3, u: Vec2, u_lobe: f32) -> Option<BsdfSample> {
        let cos_i = wi.z;
        if cos_i == 0.0 {
            return None;
        }
        let (m, pdf_m) = self.sample_distr(cos_i).sample(mulsign(wi, cos_i), u);
        if pdf_m <= 0.0 || !m.is_finite() {
            return None;
        }
        let dim = wi.dot(m);
        let (f, cos_t, eta_ti) = fresnel_dielectric(dim, self.eta);
        let is_reflection = u_lobe <= f;
        let (wo, weight, lobe_pdf, eta) = if is_reflection {
            (reflect(wi, m), self.specular_reflectance, f, 1.0)
        } else {
            let inv = 1.0 / eta_ti;
            (
                refract_about(wi, m, dim, cos_t, eta_ti),
                self.specular_transmittance * (inv * inv),
                1.0 - f,
                eta_ti,
            )
        };
        let dom = wo.dot(m);
        let dwh_dwo = if is_reflection {
            1.0 / (4.0 * dom)
        } else {
            eta * eta * dom / (dim + eta * dom).powi(2)
        };
        // The masking term; zero when wo left through the wrong side (a
        // reflection below the surface, a refraction back out): such
        // samples carry nothing and are dropped, which keeps the density
        // of the returned samples equal to pdf().
        let g = if self.distr.sample_visible {
            self.distr.smith_g1(wo, m)
        } else {
            // G |wi.m| / (|cos_i| cos_m) times D(m) / D'(m), the ratio of
            // the true distribution to the widened one that was sampled
            // (pdf_m = D'(m) cos_m). Mitsuba 3 leaves that ratio out, so its
            // weights disagree with its own eval / pdf when
            // sample_visible = false (its images come out too bright, by
            // ~10% at grazing angles); lente keeps the estimator unbiased.
            self.distr.g(wi, wo, m) * dim * self.distr.d(m) / (cos_i * pdf_m)
        };
        let reflected = wo.z * cos_i > 0.0;
        if g.is_nan() || g <= 0.0 || reflected != is_reflection || wo.z == 0.0 || !wo.is_finite() {
            return None;
        }
        Some(BsdfSample {
            wo,
            weight: weight * g,
            pdf: (pdf_m * lobe_pdf * dwh_dwo).abs(),
            specular: false,
            eta,
            null: false,
        })
    }
}

/// `wi` refracted about the microfacet normal `m` (`dim` = wi . m), given
/// the transmitted cosine and `eta_ti` = n_t / n_i in the direction of
/// travel, as [`fresnel_dielectric`] returns them.
#[inline]
pub(super) fn refract_about(wi: Vec3, m: Vec3, dim: f32, cos_t: f32, eta_ti: f32) -> Vec3 {
    let inv = 1.0 / eta_ti;
    let ct = if dim >= 0.0 { -cos_t } else { cos_t };
    (m * (dim * inv + ct) - wi * inv).normalize()
}
