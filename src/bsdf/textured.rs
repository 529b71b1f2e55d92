//! A BSDF whose parameters vary over the surface: a base model built with
//! constants (each texture's mean, so lobe-selection weights are computed
//! from means as Mitsuba does) and the textures of its varying parameters.
//! At a hit the textures are read at its uv into a copy of the base model
//! (the models are plain values: nothing is allocated per ray).

use super::params::{BsdfError, BsdfParam};
use super::{
    Bsdf, BsdfSample, Conductor, Diffuse, Microfacet, Plastic, PolarizedPlastic, RoughConductor,
    RoughDielectric, RoughPlastic, RoughSubstrate, SchlickConductor, ThinDielectric,
};
use crate::color::Rgb;
use crate::math::{Vec2, Vec3};
use crate::texture::{SurfacePoint, Texture};

#[derive(Clone, Debug, PartialEq)]
pub struct Textured {
    base: Bsdf,
    textures: Vec<(BsdfParam, Texture)>,
}

/// The base model with the textures' values at one hit.
enum Local<'a> {
    Diffuse(Diffuse),
    Plastic(Plastic),
    RoughPlastic(&'a RoughPlastic, Rgb, Rgb),
    PolarizedPlastic(PolarizedPlastic),
    Conductor(Conductor),
    RoughConductor(RoughConductor),
    ThinDielectric(ThinDielectric),
    RoughDielectric(RoughDielectric),
    Microfacet(Microfacet),
    SchlickConductor(SchlickConductor),
    RoughSubstrate(RoughSubstrate),
}

/// The parameters a model takes from textures.
fn texturable(base: &Bsdf) -> &'static [BsdfParam] {
    use BsdfParam::*;
    match base {
        Bsdf::Diffuse(_) | Bsdf::Microfacet(_) => &[Diffuse],
        Bsdf::Plastic(_) | Bsdf::RoughPlastic(_) => &[Diffuse, SpecularReflectance],
        Bsdf::PolarizedPlastic(_) => &[Diffuse, SpecularReflectance, Alpha, AlphaV],
        Bsdf::Conductor(_) => &[SpecularReflectance, Eta, K],
        Bsdf::RoughConductor(_) => &[SpecularReflectance, Eta, K, Alpha, AlphaV],
        Bsdf::ThinDielectric(_) => &[SpecularReflectance, SpecularTransmittance],
        Bsdf::RoughDielectric(_) => &[SpecularReflectance, SpecularTransmittance, Alpha, AlphaV],
        // The Zaragoza Nori fork's: R0, kd and alpha take its textures.
        Bsdf::SchlickConductor(_) => &[SpecularReflectance, Alpha],
        Bsdf::RoughSubstrate(_) => &[Diffuse, Alpha],
        _ => &[],
    }
}

impl Textured {
    /// `base` with `textures` for some of its parameters; a parameter the
    /// model does not take from a texture is an error naming it.
    pub fn new(base: Bsdf, textures: Vec<(BsdfParam, Texture)>) -> Result<Textured, BsdfError> {
        let allowed = texturable(&base);
        for (param, texture) in &textures {
            if !allowed.contains(param) || texture.max_value().is_nan() {
                return Err(BsdfError::NotTexturable { param: *param });
            }
        }
        Ok(Textured { base, textures })
    }

    /// The model the constants describe (means where textures vary).
    pub fn base(&self) -> &Bsdf {
        &self.base
    }

    /// The textured parameters.
    pub fn textures(&self) -> &[(BsdfParam, Texture)] {
        &self.textures
    }

    /// The textures, to bind mesh attributes (the parameters stay).
    pub fn textures_mut(&mut self) -> &mut [(BsdfParam, Texture)] {
        &mut self.textures
    }

    #[inline]
    fn at(&self, at: SurfacePoint) -> Local<'_> {
        use BsdfParam as P;
        let rgb = |p: BsdfParam, c: &mut Rgb| {
            for (q, t) in &self.textures {
                if *q == p {
                    *c = t.eval(at);
                }
            }
        };
        let alpha = |p: BsdfParam, a: &mut f32| {
            for (q, t) in &self.textures {
                if *q == p {
                    *a = t.eval_1(at).max(super::distribution::MIN_ALPHA);
                }
            }
        };
        match &self.base {
            Bsdf::Diffuse(b) => {
                let mut b = *b;
                rgb(P::Diffuse, &mut b.albedo);
                Local::Diffuse(b)
            }
            Bsdf::Microfacet(b) => {
                let mut b = *b;
                rgb(P::Diffuse, &mut b.kd);
                Local::Microfacet(b)
            }
            Bsdf::Plastic(b) => {
                let mut b = *b;
                rgb(P::Diffuse, &mut b.diffuse_reflectance);
                rgb(P::SpecularReflectance, &mut b.specular_reflectance);
                Local::Plastic(b)
            }
            Bsdf::RoughPlastic(b) => {
                let (mut kd, mut ks) = (b.diffuse_reflectance, b.specular_reflectance);
                rgb(P::Diffuse, &mut kd);
                rgb(P::SpecularReflectance, &mut ks);
                Local::RoughPlastic(b, kd, ks)
            }
            Bsdf::PolarizedPlastic(b) => {
                let mut b = *b;
                rgb(P::Diffuse, &mut b.diffuse_reflectance);
                rgb(P::SpecularReflectance, &mut b.specular_reflectance);
                alpha(P::Alpha, &mut b.distr.alpha_u);
                alpha(P::AlphaV, &mut b.distr.alpha_v);
                Local::PolarizedPlastic(b)
            }
            Bsdf::Conductor(b) => {
                let mut b = *b;
                rgb(P::SpecularReflectance, &mut b.specular_reflectance);
                rgb(P::Eta, &mut b.eta);
                rgb(P::K, &mut b.k);
                Local::Conductor(b)
            }
            Bsdf::RoughConductor(b) => {
                let mut b = *b;
                rgb(P::SpecularReflectance, &mut b.specular_reflectance);
                rgb(P::Eta, &mut b.eta);
                rgb(P::K, &mut b.k);
                alpha(P::Alpha, &mut b.distr.alpha_u);
                alpha(P::AlphaV, &mut b.distr.alpha_v);
                Local::RoughConductor(b)
            }
            Bsdf::ThinDielectric(b) => {
                let mut b = *b;
                rgb(P::SpecularReflectance, &mut b.specular_reflectance);
                rgb(P::SpecularTransmittance, &mut b.specular_transmittance);
                Local::ThinDielectric(b)
            }
            Bsdf::RoughDielectric(b) => {
                let mut b = *b;
                rgb(P::SpecularReflectance, &mut b.specular_reflectance);
                rgb(P::SpecularTransmittance, &mut b.specular_transmittance);
                alpha(P::Alpha, &mut b.distr.alpha_u);
                alpha(P::AlphaV, &mut b.distr.alpha_v);
                Local::RoughDielectric(b)
            }
            Bsdf::SchlickConductor(b) => {
                let mut b = *b;
                rgb(P::SpecularReflectance, &mut b.r0);
                alpha(P::Alpha, &mut b.alpha);
                Local::SchlickConductor(b)
            }
            Bsdf::RoughSubstrate(b) => {
                let mut b = *b;
                rgb(P::Diffuse, &mut b.kd);
                alpha(P::Alpha, &mut b.alpha);
                Local::RoughSubstrate(b)
            }
            _ => unreachable!("Textured::new accepts only texturable models"),
        }
    }

    /// [`Bsdf::diffuse_reflectance`] with the textures read at `at`.
    pub fn diffuse_reflectance(&self, at: SurfacePoint, wi: Vec3) -> Rgb {
        match self.at(at) {
            Local::Diffuse(b) => b.albedo,
            Local::Plastic(b) => b.diffuse_reflectance,
            Local::RoughPlastic(_, kd, _) => kd,
            Local::RoughSubstrate(b) => b.kd,
            _ => self.eval(at, wi, Vec3::Z) * std::f32::consts::PI,
        }
    }

    /// [`Bsdf::null_transmission`] with the textures read at `at`.
    pub fn null_transmission(&self, at: SurfacePoint, cos_i: f32) -> Rgb {
        match self.at(at) {
            Local::ThinDielectric(b) => b.null_transmission(cos_i),
            _ => Rgb::ZERO,
        }
    }

    pub fn eval(&self, at: SurfacePoint, wi: Vec3, wo: Vec3) -> Rgb {
        match self.at(at) {
            Local::Diffuse(b) => b.eval(wi, wo),
            Local::Plastic(b) => b.eval(wi, wo),
            Local::RoughPlastic(b, kd, ks) => b.eval_tinted(kd, ks, wi, wo),
            Local::PolarizedPlastic(b) => b.eval(wi, wo),
            Local::RoughConductor(b) => b.eval(wi, wo),
            Local::RoughDielectric(b) => b.eval(wi, wo),
            Local::Microfacet(b) => b.eval(wi, wo),
            Local::SchlickConductor(b) => b.eval(wi, wo),
            Local::RoughSubstrate(b) => b.eval(wi, wo),
            Local::Conductor(_) | Local::ThinDielectric(_) => Rgb::ZERO,
        }
    }

    /// `(eval, pdf)` with the textures read once (and the rough models'
    /// shared terms computed once).
    pub fn eval_pdf(&self, at: SurfacePoint, wi: Vec3, wo: Vec3) -> (Rgb, f32) {
        match self.at(at) {
            Local::RoughPlastic(b, kd, ks) => b.eval_pdf_tinted(kd, ks, wi, wo),
            Local::RoughConductor(b) => b.eval_pdf(wi, wo),
            Local::Diffuse(b) => (b.eval(wi, wo), b.pdf(wi, wo)),
            Local::Plastic(b) => (b.eval(wi, wo), b.pdf(wi, wo)),
            Local::PolarizedPlastic(b) => (b.eval(wi, wo), b.pdf(wi, wo)),
            Local::RoughDielectric(b) => (b.eval(wi, wo), b.pdf(wi, wo)),
            Local::Microfacet(b) => (b.eval(wi, wo), b.pdf(wi, wo)),
            Local::SchlickConductor(b) => (b.eval(wi, wo), b.pdf(wi, wo)),
            Local::RoughSubstrate(b) => (b.eval(wi, wo), b.pdf(wi, wo)),
            Local::Conductor(_) | Local::ThinDielectric(_) => (Rgb::ZERO, 0.0),
        }
    }

    pub fn pdf(&self, at: SurfacePoint, wi: Vec3, wo: Vec3) -> f32 {
        match self.at(at) {
            Local::Diffuse(b) => b.pdf(wi, wo),
            Local::Plastic(b) => b.pdf(wi, wo),
            Local::RoughPlastic(b, _, _) => b.pdf(wi, wo),
            Local::PolarizedPlastic(b) => b.pdf(wi, wo),
            Local::RoughConductor(b) => b.pdf(wi, wo),
            Local::RoughDielectric(b) => b.pdf(wi, wo),
            Local::Microfacet(b) => b.pdf(wi, wo),
            Local::SchlickConductor(b) => b.pdf(wi, wo),
            Local::RoughSubstrate(b) => b.pdf(wi, wo),
            Local::Conductor(_) | Local::ThinDielectric(_) => 0.0,
        }
    }

    pub fn sample(&self, at: SurfacePoint, wi: Vec3, u: Vec2, u_lobe: f32) -> Option<BsdfSample> {
        match self.at(at) {
            Local::Diffuse(b) => b.sample(wi, u),
            Local::Plastic(b) => b.sample(wi, u, u_lobe),
            Local::RoughPlastic(b, kd, ks) => b.sample_tinted(kd, ks, wi, u, u_lobe),
            Local::PolarizedPlastic(b) => b.sample(wi, u, u_lobe),
            Local::Conductor(b) => b.sample(wi),
            Local::RoughConductor(b) => b.sample(wi, u),
            Local::ThinDielectric(b) => b.sample(wi, u_lobe),
            Local::RoughDielectric(b) => b.sample(wi, u, u_lobe),
            Local::Microfacet(b) => b.sample(wi, u, u_lobe),
            Local::SchlickConductor(b) => b.sample(wi, u),
            Local::RoughSubstrate(b) => b.sample(wi, u, u_lobe),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::ThinDielectric;
    use crate::texture::{Checkerboard, UvTransform};

    /// A textured thin dielectric lets through what the untextured one with
    /// the texel's transmittance does (volpath's shadow rays keep it).
    #[test]
    fn textured_thin_dielectric_passes_its_texel_transmittance() {
        let (t0, t1) = (Rgb::new(0.9, 0.5, 0.1), Rgb::new(0.2, 0.3, 0.4));
        let plain = |t: Rgb| ThinDielectric::new(1.5, 1.0, Rgb::ONE, t).unwrap();
        let board = Texture::Checkerboard(Checkerboard {
            color0: t0,
            color1: t1,
            to_uv: UvTransform::IDENTITY,
        });
        let textured = Bsdf::Textured(Box::new(
            Textured::new(
                Bsdf::ThinDielectric(plain(Rgb::ONE)),
                vec![(BsdfParam::SpecularTransmittance, board)],
            )
            .unwrap(),
        ));
        for (uv, t) in [(Vec2::new(0.25, 0.25), t0), (Vec2::new(0.75, 0.25), t1)] {
            let at = SurfacePoint::from(uv);
            let want = plain(t).null_transmission(0.6);
            assert!(want.min_element() > 0.0);
            assert_eq!(textured.null_transmission(at, 0.6), want);
        }
    }
}
