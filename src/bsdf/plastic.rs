//! Mitsuba 3's smooth `plastic`: a smooth dielectric coating over a
//! Lambertian base, with the internal scattering between the two summed in
//! closed form. It has a delta lobe (the coating's mirror reflection) and a
//! smooth one (light that entered, scattered and left): `eval` and `pdf`
//! cover only the smooth lobe; `sample` returns either.

use super::params::{self, BsdfError, BsdfParam};
use super::{fresnel_dielectric, fresnel_diffuse_reflectance, BsdfSample};
use crate::color::Rgb;
use crate::math::{Vec2, Vec3, INV_PI};
use crate::sampling::warp;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plastic {
    /// Interior IOR / exterior IOR.
    pub eta: f32,
    pub diffuse_reflectance: Rgb,
    pub specular_reflectance: Rgb,
    /// Mitsuba's `nonlinear`: account for the colour shift of repeated
    /// internal bounces on the base.
    pub nonlinear: bool,
    /// Diffuse Fresnel reflectance of the coating seen from inside.
    pub fdr_int: f32,
    /// Share of samples steered to the specular lobe before Fresnel:
    /// mean(specular) / (mean(diffuse) + mean(specular)).
    pub specular_sampling_weight: f32,
}

impl Plastic {
    /// Parameters (Mitsuba's names and defaults): `int_ior`
    /// (polypropylene = 1.49), `ext_ior` (air = 1.000277),
    /// `diffuse_reflectance` (0.5), `specular_reflectance` (1), `nonlinear`
    /// (false).
    pub fn new(
        int_ior: f32,
        ext_ior: f32,
        diffuse_reflectance: Rgb,
        specular_reflectance: Rgb,
        nonlinear: bool,
    ) -> Result<Plastic, BsdfError> {
        let eta = params::relative_ior(int_ior, ext_ior)?;
        let diffuse_reflectance = params::color(BsdfParam::Diffuse, diffuse_reflectance)?;
        let specular_reflectance =
            params::color(BsdfParam::SpecularReflectance, specular_reflectance)?;
        let d_mean = diffuse_reflectance.element_sum() / 3.0;
        let s_mean = specular_reflectance.element_sum() / 3.0;
        Ok(Plastic {
            eta,
            diffuse_reflectance,
            specular_reflectance,
            nonlinear,
            fdr_int: fresnel_diffuse_reflectance(1.0 / eta),
            specular_sampling_weight: if d_mean + s_mean > 0.0 {
                s_mean / (d_mean + s_mean)
            } else {
                0.5
            },
        })
    }

    /// Probability of sampling the specular lobe at incidence with Fresnel
    /// reflectance `f_i`.
    fn prob_specular(&self, f_i: f32) -> f32 {
        let ps = f_i * self.specular_sampling_weight;
        let pd = (1.0 - f_i) * (1.0 - self.specular_sampling_weight);
        ps / (ps + pd)
    }

    /// The base's albedo after the internal bounces (divided by 1 - Fdr, or
    /// per channel by 1 - kd Fdr when nonlinear).
    fn diffuse_term(&self) -> Rgb {
        let kd = self.diffuse_reflectance;
        if self.nonlinear {
            kd / (Rgb::ONE - kd * self.fdr_int)
        } else {
            kd / (1.0 - self.fdr_int)
        }
    }

    /// The smooth lobe: (1 - F_i)(1 - F_o) kd' / (pi eta^2).
    pub fn eval(&self, wi: Vec3, wo: Vec3) -> Rgb {
        self.eval_pdf(wi, wo).0
    }

    /// Density of the smooth lobe's samples (times its selection probability).
    pub fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        self.eval_pdf(wi, wo).1
    }

    /// `(eval, pdf)`, where both formulas live: the incoming side's Fresnel
    /// term computed once.
    #[inline]
    pub fn eval_pdf(&self, wi: Vec3, wo: Vec3) -> (Rgb, f32) {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return (Rgb::ZERO, 0.0);
        }
        let (f_i, _, _) = fresnel_dielectric(wi.z, self.eta);
        let (f_o, _, _) = fresnel_dielectric(wo.z, self.eta);
        let f = self.diffuse_term() * (INV_PI / (self.eta * self.eta) * (1.0 - f_i) * (1.0 - f_o));
        let pdf = (1.0 - self.prob_specular(f_i)) * warp::square_to_cosine_hemisphere_pdf(wo);
        (f, pdf)
    }

    pub fn sample(&self, wi: Vec3, u: Vec2, u_lobe: f32) -> Option<BsdfSample> {
        if wi.z <= 0.0 {
            return None;
        }
        let (f_i, _, _) = fresnel_dielectric(wi.z, self.eta);
        let p_spec = self.prob_specular(f_i);
        if u_lobe < p_spec {
            return Some(BsdfSample {
                wo: Vec3::new(-wi.x, -wi.y, wi.z),
                weight: self.specular_reflectance * (f_i / p_spec),
                pdf: p_spec,
                specular: true,
                eta: 1.0,
                null: false,
            });
        }
        let wo = warp::square_to_cosine_hemisphere(u);
        if wo.z <= 0.0 {
            return None;
        }
        let p_diff = 1.0 - p_spec;
        let (f_o, _, _) = fresnel_dielectric(wo.z, self.eta);
        let weight =
            self.diffuse_term() * ((1.0 - f_i) * (1.0 - f_o) / (self.eta * self.eta * p_diff));
        Some(BsdfSample {
            wo,
            weight,
            pdf: p_diff * warp::square_to_cosine_hemisphere_pdf(wo),
            specular: false,
            eta: 1.0,
            null: false,
        })
    }
}
