//! Surface scattering models. Directions are in the local shading frame
//! (z = shading normal) and both point away from the surface: `wi` towards
//! where light is gathered from the camera side (Nori's convention: `wi` is
//! the direction the path arrived from, `wo` the sampled continuation).

pub mod beckmann_slopes;
mod blend;
mod bump_map;
mod conductor;
mod dielectric;
mod diffuse;
pub mod distribution;
mod fresnel;
mod mask;
mod microfacet;
mod mirror;
mod normal_map;
mod params;
mod plastic;
mod polarized_plastic;
mod polarizer;
pub mod presets;
mod principled;
mod principled_thin;
mod rough_conductor;
mod rough_dielectric;
mod rough_plastic;
mod rough_substrate;
mod schlick_conductor;
mod textured;
mod thin_dielectric;
mod tilted;
mod two_sided;

use crate::color::Rgb;
use crate::math::{Vec2, Vec3};
use crate::texture::SurfacePoint;

pub use blend::Blend;
pub use bump_map::BumpMap;
pub use conductor::Conductor;
pub use dielectric::Dielectric;
pub use diffuse::Diffuse;
pub use distribution::{MicrofacetDistribution, MicrofacetType, Roughness};
pub use fresnel::{
    fresnel_conductor, fresnel_conductor_1, fresnel_dielectric, fresnel_diffuse_reflectance,
};
pub use mask::Mask;
pub use microfacet::Microfacet;
pub use mirror::Mirror;
pub use normal_map::NormalMap;
pub use params::{BsdfError, BsdfParam};
pub use plastic::Plastic;
pub use polarized_plastic::PolarizedPlastic;
pub use polarizer::Polarizer;
pub use presets::{conductor_preset, ior_preset};
pub use principled::{specular_to_eta, Principled};
pub use principled_thin::PrincipledThin;
pub use rough_conductor::RoughConductor;
pub use rough_dielectric::RoughDielectric;
pub use rough_plastic::RoughPlastic;
pub use rough_substrate::RoughSubstrate;
pub use schlick_conductor::SchlickConductor;
pub use textured::Textured;
pub use thin_dielectric::ThinDielectric;
pub use tilted::{Tilt, Tilted};
pub use two_sided::TwoSided;

/// The closed set of BSDFs lente renders, one model per file; each is
/// built by its own checked constructor.
#[derive(Clone, Debug, PartialEq)]
pub enum Bsdf {
    Diffuse(Diffuse),
    Mirror(Mirror),
    Dielectric(Dielectric),
    /// Nori's `microfacet`.
    Microfacet(Microfacet),
    Conductor(Conductor),
    RoughConductor(RoughConductor),
    ThinDielectric(ThinDielectric),
    RoughDielectric(RoughDielectric),
    /// Mitsuba's smooth `plastic`. Not "specular" as a whole: NEE applies
    /// to its smooth lobe.
    Plastic(Plastic),
    RoughPlastic(RoughPlastic),
    /// Mitsuba's `pplastic`, unpolarised as its RGB variants render it.
    PolarizedPlastic(PolarizedPlastic),
    /// Mitsuba's `polarizer`, unpolarised: half the light passes.
    Polarizer(Polarizer),
    /// Mitsuba's `null`: no surface at all (a medium's boundary); light
    /// passes straight through.
    Null,
    TwoSided(TwoSided),
    /// The Zaragoza Nori fork's `roughconductor` (Schlick's Fresnel).
    SchlickConductor(SchlickConductor),
    /// The Zaragoza Nori fork's `roughsubstrate` (Ashikhmin-Shirley).
    RoughSubstrate(RoughSubstrate),
    /// Mitsuba's `mask`: opacity, the rest passes straight through
    /// (boxed: rare, and its texture is large).
    Mask(Box<Mask>),
    /// Mitsuba's `blendbsdf`: a weighted mix of two BSDFs (boxed: rare).
    Blend(Box<Blend>),
    /// Mitsuba's `normalmap` and `bumpmap`: a nested BSDF in a frame
    /// tilted by a texture (boxed: rare).
    Tilted(Box<Tilted>),
    /// Mitsuba's `principled` (the Disney BSDF; boxed: large).
    Principled(Box<Principled>),
    /// Mitsuba's `principledthin` (the thin Disney BSDF; boxed: large).
    PrincipledThin(Box<PrincipledThin>),
    /// A model with textured parameters (boxed: rare, and large).
    Textured(Box<Textured>),
}

/// Result of sampling a BSDF.
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    /// Sampled outgoing direction (local frame).
    pub wo: Vec3,
    /// eval * |cos theta_o| / pdf (for specular lobes: the lobe's weight).
    pub weight: Rgb,
    /// Solid-angle pdf; for a specular (delta) lobe, the discrete probability.
    pub pdf: f32,
    /// True if the lobe is a Dirac delta (eval and pdf are zero for it).
    pub specular: bool,
    /// Relative IOR crossed (1 for reflection), for radiance scaling and RR.
    pub eta: f32,
    /// True for a null lobe: the path goes on straight through, as if the
    /// surface were not there (a mask's holes, a polarizer, `null`).
    /// Mitsuba's `volpath` does not count it as a bounce.
    pub null: bool,
}

impl BsdfSample {
    /// A sample `wo` of a smooth reflection lobe with density `pdf`: its
    /// weight f(wo) cos / pdf (`f` is evaluated only for a kept sample);
    /// `None` below the horizon or where the density vanishes.
    #[inline]
    fn smooth_reflection(wo: Vec3, pdf: f32, f: impl FnOnce() -> Rgb) -> Option<BsdfSample> {
        if wo.z <= 0.0 || pdf <= 0.0 {
            return None;
        }
        Some(BsdfSample {
            wo,
            weight: f() * wo.z / pdf,
            pdf,
            specular: false,
            eta: 1.0,
            null: false,
        })
    }
}

impl Default for Bsdf {
    /// Nori's and Mitsuba's default: diffuse, albedo 0.5.
    fn default() -> Self {
        Bsdf::Diffuse(Diffuse {
            albedo: Rgb::splat(0.5),
        })
    }
}

impl Bsdf {
    /// Perfect specular reflector.
    pub fn mirror() -> Bsdf {
        Bsdf::Mirror(Mirror)
    }

    /// Lambertian reflector (see [`Diffuse::new`]).
    pub fn diffuse(albedo: Rgb) -> Result<Bsdf, BsdfError> {
        Ok(Bsdf::Diffuse(Diffuse::new(albedo)?))
    }

    /// Smooth dielectric (see [`Dielectric::new`]).
    pub fn dielectric(int_ior: f32, ext_ior: f32) -> Result<Bsdf, BsdfError> {
        Ok(Bsdf::Dielectric(Dielectric::new(int_ior, ext_ior)?))
    }

    /// Nori's microfacet (see [`Microfacet::new`]).
    pub fn microfacet(alpha: f32, int_ior: f32, ext_ior: f32, kd: Rgb) -> Result<Bsdf, BsdfError> {
        Ok(Bsdf::Microfacet(Microfacet::new(
            alpha, int_ior, ext_ior, kd,
        )?))
    }

    /// Mitsuba's `conductor` (see [`Conductor::new`]).
    pub fn conductor(eta: Rgb, k: Rgb, specular_reflectance: Rgb) -> Result<Bsdf, BsdfError> {
        Ok(Bsdf::Conductor(Conductor::new(
            eta,
            k,
            specular_reflectance,
        )?))
    }

    /// Mitsuba's `roughconductor` (see [`RoughConductor::new`]).
    #[allow(clippy::too_many_arguments)]
    pub fn rough_conductor(
        distribution: MicrofacetType,
        alpha_u: f32,
        alpha_v: f32,
        eta: Rgb,
        k: Rgb,
        specular_reflectance: Rgb,
        sample_visible: bool,
    ) -> Result<Bsdf, BsdfError> {
        let roughness = Roughness::new(distribution, alpha_u, alpha_v, sample_visible);
        Ok(Bsdf::RoughConductor(RoughConductor::new(
            roughness,
            eta,
            k,
            specular_reflectance,
        )?))
    }

    /// Mitsuba's `thindielectric` (see [`ThinDielectric::new`]).
    pub fn thin_dielectric(
        int_ior: f32,
        ext_ior: f32,
        specular_reflectance: Rgb,
        specular_transmittance: Rgb,
    ) -> Result<Bsdf, BsdfError> {
        Ok(Bsdf::ThinDielectric(ThinDielectric::new(
            int_ior,
            ext_ior,
            specular_reflectance,
            specular_transmittance,
        )?))
    }

    /// Mitsuba's `roughdielectric` (see [`RoughDielectric::new`]).
    #[allow(clippy::too_many_arguments)]
    pub fn rough_dielectric(
        distribution: MicrofacetType,
        alpha_u: f32,
        alpha_v: f32,
        int_ior: f32,
        ext_ior: f32,
        specular_reflectance: Rgb,
        specular_transmittance: Rgb,
        sample_visible: bool,
    ) -> Result<Bsdf, BsdfError> {
        let roughness = Roughness::new(distribution, alpha_u, alpha_v, sample_visible);
        Ok(Bsdf::RoughDielectric(RoughDielectric::new(
            roughness,
            int_ior,
            ext_ior,
            specular_reflectance,
            specular_transmittance,
        )?))
    }

    /// Mitsuba's smooth `plastic` (see [`Plastic::new`]).
    pub fn plastic(
        int_ior: f32,
        ext_ior: f32,
        diffuse_reflectance: Rgb,
        specular_reflectance: Rgb,
        nonlinear: bool,
    ) -> Result<Bsdf, BsdfError> {
        Ok(Bsdf::Plastic(Plastic::new(
            int_ior,
            ext_ior,
            diffuse_reflectance,
            specular_reflectance,
            nonlinear,
        )?))
    }

    /// Mitsuba's `roughplastic` (see [`RoughPlastic::new`]). Builds its
    /// tables (~0.1 s): call once per material.
    #[allow(clippy::too_many_arguments)]
    pub fn rough_plastic(
        distribution: MicrofacetType,
        alpha: f32,
        int_ior: f32,
        ext_ior: f32,
        diffuse_reflectance: Rgb,
        specular_reflectance: Rgb,
        nonlinear: bool,
        sample_visible: bool,
    ) -> Result<Bsdf, BsdfError> {
        Ok(Bsdf::RoughPlastic(RoughPlastic::new(
            Roughness::isotropic(distribution, alpha, sample_visible),
            int_ior,
            ext_ior,
            diffuse_reflectance,
            specular_reflectance,
            nonlinear,
        )?))
    }

    /// Mitsuba's `pplastic` (see [`PolarizedPlastic::new`]).
    pub fn polarized_plastic(
        roughness: Roughness,
        int_ior: f32,
        ext_ior: f32,
        diffuse_reflectance: Rgb,
        specular_reflectance: Rgb,
    ) -> Result<Bsdf, BsdfError> {
        Ok(Bsdf::PolarizedPlastic(PolarizedPlastic::new(
            roughness,
            int_ior,
            ext_ior,
            diffuse_reflectance,
            specular_reflectance,
        )?))
    }

    /// Mitsuba's `polarizer` (see [`Polarizer`]).
    pub fn polarizer(transmittance: Rgb) -> Result<Bsdf, BsdfError> {
        Ok(Bsdf::Polarizer(Polarizer::new(transmittance)?))
    }

    /// Mitsuba's `twosided` (see [`TwoSided::new`]).
    pub fn two_sided(front: Bsdf, back: Option<Bsdf>) -> Result<Bsdf, BsdfError> {
        Ok(Bsdf::TwoSided(TwoSided::new(front, back)?))
    }

    /// `nested` with an opacity (see [`Mask::new`]).
    pub fn mask(opacity: crate::texture::Texture, nested: Bsdf) -> Result<Bsdf, BsdfError> {
        Ok(Bsdf::Mask(Box::new(Mask::new(opacity, nested)?)))
    }

    /// A mix of two BSDFs (see [`Blend::new`]).
    pub fn blend(
        weight: crate::texture::Texture,
        first: Bsdf,
        second: Bsdf,
    ) -> Result<Bsdf, BsdfError> {
        Ok(Bsdf::Blend(Box::new(Blend::new(weight, first, second)?)))
    }

    /// `nested` in a frame tilted by a normal map (see [`NormalMap::new`]).
    pub fn normal_map(
        normals: crate::texture::Texture,
        nested: Bsdf,
        flip_invalid_normals: bool,
        use_shadowing_function: bool,
    ) -> Result<Bsdf, BsdfError> {
        Ok(Bsdf::Tilted(Box::new(Tilted {
            tilt: Tilt::NormalMap(NormalMap::new(normals)?),
            nested,
            flip_invalid_normals,
            use_shadowing_function,
        })))
    }

    /// `nested` on a surface bumped by `height` (see [`BumpMap::new`]).
    pub fn bump_map(
        height: crate::texture::Texture,
        scale: f32,
        nested: Bsdf,
        flip_invalid_normals: bool,
        use_shadowing_function: bool,
    ) -> Result<Bsdf, BsdfError> {
        Ok(Bsdf::Tilted(Box::new(Tilted {
            tilt: Tilt::BumpMap(BumpMap::new(height, scale)?),
            nested,
            flip_invalid_normals,
            use_shadowing_function,
        })))
    }

    /// `base` with textured parameters (see [`Textured::new`]); no
    /// textures gives `base` itself.
    pub fn textured(
        base: Bsdf,
        textures: Vec<(BsdfParam, crate::texture::Texture)>,
    ) -> Result<Bsdf, BsdfError> {
        if textures.is_empty() {
            return Ok(base);
        }
        Ok(Bsdf::Textured(Box::new(Textured::new(base, textures)?)))
    }

    /// Calls `f` on every texture this BSDF (and those nested in it)
    /// reads: the loader binds mesh attribute textures to their mesh.
    pub fn for_each_texture_mut(&mut self, f: &mut dyn FnMut(&mut crate::texture::Texture)) {
        match self {
            Bsdf::Textured(b) => b.textures_mut().iter_mut().for_each(|(_, t)| f(t)),
            Bsdf::Principled(b) => b.textures_mut().for_each(f),
            Bsdf::PrincipledThin(b) => b.textures_mut().for_each(f),
            Bsdf::Mask(b) => {
                f(&mut b.opacity);
                b.nested.for_each_texture_mut(f);
            }
            Bsdf::Blend(b) => {
                f(&mut b.weight);
                b.first.for_each_texture_mut(f);
                b.second.for_each_texture_mut(f);
            }
            Bsdf::Tilted(b) => {
                f(b.texture_mut());
                b.nested.for_each_texture_mut(f);
            }
            Bsdf::TwoSided(b) => {
                b.front.for_each_texture_mut(f);
                b.back.for_each_texture_mut(f);
            }
            _ => {}
        }
    }

    /// True if the BSDF (or one nested in it) reads dp/du and dp/dv from
    /// its [`SurfacePoint`] (bump maps); the renderer computes them only
    /// for such shapes.
    pub fn needs_differentials(&self) -> bool {
        match self {
            Bsdf::Mask(b) => b.nested.needs_differentials(),
            Bsdf::Blend(b) => b.first.needs_differentials() || b.second.needs_differentials(),
            Bsdf::Tilted(b) => matches!(b.tilt, Tilt::BumpMap(_)) || b.nested.needs_differentials(),
            Bsdf::TwoSided(b) => b.front.needs_differentials() || b.back.needs_differentials(),
            _ => false,
        }
    }

    /// True if some lobe scatters light through the surface.
    pub fn has_transmission(&self) -> bool {
        match self {
            Bsdf::Dielectric(_)
            | Bsdf::ThinDielectric(_)
            | Bsdf::RoughDielectric(_)
            // Light passes through a mask's holes (Mitsuba counts its null
            // lobe as transmission too: twosided refuses a mask).
            | Bsdf::Mask(_)
            | Bsdf::Polarizer(_)
            | Bsdf::Null => true,
            Bsdf::Principled(b) => b.spec_trans.is_some(),
            Bsdf::PrincipledThin(b) => b.spec_trans.is_some() || b.diff_trans.is_some(),
            Bsdf::TwoSided(b) => b.front.has_transmission() || b.back.has_transmission(),
            Bsdf::Blend(b) => b.first.has_transmission() || b.second.has_transmission(),
            Bsdf::Tilted(b) => b.nested.has_transmission(),
            Bsdf::Textured(b) => b.base().has_transmission(),
            _ => false,
        }
    }

    /// True if every lobe is a delta: NEE is pointless on it. A BSDF with
    /// both delta and smooth lobes (plastic) is not specular; its samples
    /// say which lobe they came from.
    /// (The models answered here, inlined; the wrappers, which recurse,
    /// out of line: a recursive whole was never inlined, a call per
    /// bounce.)
    #[inline]
    pub fn is_specular(&self) -> bool {
        match self {
            Bsdf::Mirror(_)
            | Bsdf::Dielectric(_)
            | Bsdf::Conductor(_)
            | Bsdf::ThinDielectric(_)
            | Bsdf::Polarizer(_)
            | Bsdf::Null => true,
            Bsdf::TwoSided(_)
            | Bsdf::Mask(_)
            | Bsdf::Blend(_)
            | Bsdf::Tilted(_)
            | Bsdf::Textured(_) => self.is_specular_wrapper(),
            _ => false,
        }
    }

    /// [`Bsdf::is_specular`] of a wrapper: from what it wraps.
    #[inline(never)]
    fn is_specular_wrapper(&self) -> bool {
        match self {
            Bsdf::TwoSided(b) => b.front.is_specular() && b.back.is_specular(),
            Bsdf::Mask(b) => b.nested.is_specular(),
            Bsdf::Blend(b) => b.first.is_specular() && b.second.is_specular(),
            Bsdf::Tilted(b) => b.nested.is_specular(),
            Bsdf::Textured(b) => b.base().is_specular(),
            _ => self.is_specular(),
        }
    }

    /// True where light sampling should favour what the surface faces: the
    /// BSDF is zero whenever `wi` and `wo` are on different sides of the
    /// shading frame (`wi.z * wo.z <= 0`), so what is behind it can be
    /// left out, and it has a diffuse lobe, for which the cosine-shaped
    /// density that environment maps then use (`envmap/facing.rs`) is close
    /// to the integrand. A purely glossy lobe gains too little from that
    /// to pay for the extra table reads. False where unsure (transmission,
    /// null lobes, tilted frames).
    /// (Inlined for the models, the wrappers out of line, as
    /// [`Bsdf::is_specular`].)
    #[inline]
    pub fn favours_facing_light(&self) -> bool {
        match self {
            Bsdf::Diffuse(_) | Bsdf::Microfacet(_) | Bsdf::Plastic(_) | Bsdf::RoughPlastic(_) => {
                true
            }
            Bsdf::TwoSided(_) | Bsdf::Blend(_) | Bsdf::Textured(_) => {
                self.favours_facing_light_wrapper()
            }
            _ => false,
        }
    }

    /// [`Bsdf::favours_facing_light`] of a wrapper: from what it wraps.
    #[inline(never)]
    fn favours_facing_light_wrapper(&self) -> bool {
        match self {
            Bsdf::TwoSided(b) => b.front.favours_facing_light() && b.back.favours_facing_light(),
            Bsdf::Blend(b) => b.first.favours_facing_light() && b.second.favours_facing_light(),
            // The same models with textured parameters.
            Bsdf::Textured(b) => b.base().favours_facing_light(),
            _ => self.favours_facing_light(),
        }
    }

    /// The fraction of light that passes straight through the surface
    /// (its null lobe's weight) along a direction at cosine `cos_i` to the
    /// shading normal: what a shadow ray keeps when it crosses it in
    /// `volpath`. Zero for surfaces that block light.
    pub fn null_transmission(&self, at: impl Into<SurfacePoint>, cos_i: f32) -> Rgb {
        let at = at.into();
        match self {
            Bsdf::Null => Rgb::ONE,
            Bsdf::ThinDielectric(b) => b.null_transmission(cos_i),
            Bsdf::Polarizer(b) => b.transmittance * 0.5,
            Bsdf::Mask(b) => {
                let alpha = b.alpha(at);
                Rgb::splat(1.0 - alpha) + b.nested.null_transmission(at, cos_i) * alpha
            }
            Bsdf::Blend(b) => {
                let w = b.w(at);
                b.first.null_transmission(at, cos_i) * (1.0 - w)
                    + b.second.null_transmission(at, cos_i) * w
            }
            // A textured thin dielectric passes its transmittance there; a
            // normal or bump map does not stop what its BSDF lets through.
            Bsdf::Textured(b) => b.null_transmission(at, cos_i),
            Bsdf::Tilted(b) => b.nested.null_transmission(at, cos_i),
            _ => Rgb::ZERO,
        }
    }

    /// Diffuse albedo for the `ao`/visualisation paths, if any (a
    /// texture's mean).
    pub fn albedo(&self) -> Option<Rgb> {
        match self {
            Bsdf::Diffuse(b) => Some(b.albedo),
            Bsdf::Microfacet(b) => Some(b.kd),
            Bsdf::Plastic(b) => Some(b.diffuse_reflectance),
            Bsdf::RoughPlastic(b) => Some(b.diffuse_reflectance),
            Bsdf::PolarizedPlastic(b) => Some(b.diffuse_reflectance),
            Bsdf::RoughSubstrate(b) => Some(b.kd),
            Bsdf::Principled(b) => Some(b.base_color.mean()),
            Bsdf::PrincipledThin(b) => Some(b.base_color.mean()),
            Bsdf::TwoSided(b) => b.front.albedo(),
            Bsdf::Mask(b) => b.nested.albedo(),
            Bsdf::Blend(b) => {
                let w = b.weight.mean_1().clamp(0.0, 1.0);
                match (b.first.albedo(), b.second.albedo()) {
                    (Some(a), Some(c)) => Some(a * (1.0 - w) + c * w),
                    (a, c) => a.or(c),
                }
            }
            Bsdf::Tilted(b) => b.nested.albedo(),
            Bsdf::Textured(b) => b.base().albedo(),
            _ => None,
        }
    }

    /// The diffuse reflectance as Mitsuba's `eval_diffuse_reflectance`
    /// defines it (its `aov` integrator's `albedo`): the diffuse albedo of
    /// diffuse, plastic and rough plastic models (textured or not), the
    /// nested models' for two-sided, mask, blend and normal/bump maps, and
    /// otherwise pi times the BSDF from `wi` to the normal (zero for
    /// mirrors and glass).
    pub fn diffuse_reflectance(&self, at: impl Into<SurfacePoint>, wi: Vec3) -> Rgb {
        let at = at.into();
        match self {
            Bsdf::Diffuse(b) => b.albedo,
            Bsdf::Plastic(b) => b.diffuse_reflectance,
            Bsdf::RoughPlastic(b) => b.diffuse_reflectance,
            Bsdf::TwoSided(b) => {
                if wi.z >= 0.0 {
                    b.front.diffuse_reflectance(at, wi)
                } else {
                    b.back.diffuse_reflectance(at, Vec3::new(wi.x, wi.y, -wi.z))
                }
            }
            Bsdf::Mask(b) => b.nested.diffuse_reflectance(at, wi),
            Bsdf::Tilted(b) => b.nested.diffuse_reflectance(at, wi),
            Bsdf::Blend(b) => {
                let w = b.weight.eval_1(at).clamp(0.0, 1.0);
                b.first.diffuse_reflectance(at, wi) * (1.0 - w)
                    + b.second.diffuse_reflectance(at, wi) * w
            }
            Bsdf::Textured(b) => b.diffuse_reflectance(at, wi),
            Bsdf::PrincipledThin(b) => b.base_color.eval(at),
            _ => self.eval(at, wi, Vec3::Z) * std::f32::consts::PI,
        }
    }

    /// BSDF value f(wi, wo) (without the cosine) at a surface point (where
    /// textured parameters are read; a bare uv converts). Zero for delta
    /// lobes.
    pub fn eval(&self, at: impl Into<SurfacePoint>, wi: Vec3, wo: Vec3) -> Rgb {
        let at = at.into();
        match self {
            Bsdf::Diffuse(b) => b.eval(wi, wo),
            Bsdf::Microfacet(b) => b.eval(wi, wo),
            Bsdf::RoughConductor(b) => b.eval(wi, wo),
            Bsdf::RoughDielectric(b) => b.eval(wi, wo),
            Bsdf::Plastic(b) => b.eval(wi, wo),
            Bsdf::RoughPlastic(b) => b.eval(wi, wo),
            Bsdf::PolarizedPlastic(b) => b.eval(wi, wo),
            Bsdf::SchlickConductor(b) => b.eval(wi, wo),
            Bsdf::RoughSubstrate(b) => b.eval(wi, wo),
            Bsdf::TwoSided(b) => b.eval(at, wi, wo),
            Bsdf::Mask(b) => b.eval(at, wi, wo),
            Bsdf::Blend(b) => b.eval(at, wi, wo),
            Bsdf::Tilted(b) => b.eval(at, wi, wo),
            Bsdf::Principled(b) => b.eval(at, wi, wo),
            Bsdf::PrincipledThin(b) => b.eval(at, wi, wo),
            Bsdf::Textured(b) => b.eval(at, wi, wo),
            Bsdf::Mirror(_)
            | Bsdf::Dielectric(_)
            | Bsdf::Conductor(_)
            | Bsdf::ThinDielectric(_)
            | Bsdf::Polarizer(_)
            | Bsdf::Null => Rgb::ZERO,
        }
    }

    /// Solid-angle density of `sample` producing `wo`. Zero for delta lobes.
    pub fn pdf(&self, at: impl Into<SurfacePoint>, wi: Vec3, wo: Vec3) -> f32 {
        let at = at.into();
        match self {
            Bsdf::Diffuse(b) => b.pdf(wi, wo),
            Bsdf::Microfacet(b) => b.pdf(wi, wo),
            Bsdf::RoughConductor(b) => b.pdf(wi, wo),
            Bsdf::RoughDielectric(b) => b.pdf(wi, wo),
            Bsdf::Plastic(b) => b.pdf(wi, wo),
            Bsdf::RoughPlastic(b) => b.pdf(wi, wo),
            Bsdf::PolarizedPlastic(b) => b.pdf(wi, wo),
            Bsdf::SchlickConductor(b) => b.pdf(wi, wo),
            Bsdf::RoughSubstrate(b) => b.pdf(wi, wo),
            Bsdf::TwoSided(b) => b.pdf(at, wi, wo),
            Bsdf::Mask(b) => b.pdf(at, wi, wo),
            Bsdf::Blend(b) => b.pdf(at, wi, wo),
            Bsdf::Tilted(b) => b.pdf(at, wi, wo),
            Bsdf::Principled(b) => b.pdf(at, wi, wo),
            Bsdf::PrincipledThin(b) => b.pdf(at, wi, wo),
            Bsdf::Textured(b) => b.pdf(at, wi, wo),
            Bsdf::Mirror(_)
            | Bsdf::Dielectric(_)
            | Bsdf::Conductor(_)
            | Bsdf::ThinDielectric(_)
            | Bsdf::Polarizer(_)
            | Bsdf::Null => 0.0,
        }
    }

    /// `(eval, pdf)` at once: what next-event estimation under MIS needs.
    /// The same values as the two calls; the models whose two share work
    /// (plastics, rough conductors, textured ones' lookups) do it once,
    /// and the diffuse model, most scenes' commonest, is inlined here (the
    /// others' dispatch out of line: a call and a returned pair through
    /// memory cost the diffuse model's estimate as much as its formula).
    #[inline]
    pub fn eval_pdf(&self, at: impl Into<SurfacePoint>, wi: Vec3, wo: Vec3) -> (Rgb, f32) {
        match self {
            Bsdf::Diffuse(b) => b.eval_pdf(wi, wo),
            _ => self.eval_pdf_other(at.into(), wi, wo),
        }
    }

    /// [`Bsdf::eval_pdf`] of the models other than the diffuse one.
    #[inline(never)]
    fn eval_pdf_other(&self, at: SurfacePoint, wi: Vec3, wo: Vec3) -> (Rgb, f32) {
        match self {
            Bsdf::Diffuse(b) => b.eval_pdf(wi, wo),
            Bsdf::Plastic(b) => b.eval_pdf(wi, wo),
            Bsdf::RoughConductor(b) => b.eval_pdf(wi, wo),
            Bsdf::RoughPlastic(b) => {
                let (kd, ks) = (b.diffuse_reflectance, b.specular_reflectance);
                b.eval_pdf_tinted(kd, ks, wi, wo)
            }
            Bsdf::Textured(b) => b.eval_pdf(at, wi, wo),
            _ => (self.eval(at, wi, wo), self.pdf(at, wi, wo)),
        }
    }

    /// Samples `wo` given `wi`; `u` drives the direction, `u_lobe` the lobe choice.
    pub fn sample(
        &self,
        at: impl Into<SurfacePoint>,
        wi: Vec3,
        u: Vec2,
        u_lobe: f32,
    ) -> Option<BsdfSample> {
        let at = at.into();
        match self {
            Bsdf::Diffuse(b) => b.sample(wi, u),
            Bsdf::Mirror(b) => b.sample(wi),
            Bsdf::Dielectric(b) => b.sample(wi, u_lobe),
            Bsdf::Microfacet(b) => b.sample(wi, u, u_lobe),
            Bsdf::Conductor(b) => b.sample(wi),
            Bsdf::RoughConductor(b) => b.sample(wi, u),
            Bsdf::ThinDielectric(b) => b.sample(wi, u_lobe),
            Bsdf::RoughDielectric(b) => b.sample(wi, u, u_lobe),
            Bsdf::Plastic(b) => b.sample(wi, u, u_lobe),
            Bsdf::RoughPlastic(b) => b.sample(wi, u, u_lobe),
            Bsdf::PolarizedPlastic(b) => b.sample(wi, u, u_lobe),
            Bsdf::Polarizer(b) => b.sample(wi),
            Bsdf::Null => Some(BsdfSample {
                wo: -wi,
                weight: Rgb::ONE,
                pdf: 1.0,
                specular: true,
                eta: 1.0,
                null: true,
            }),
            Bsdf::SchlickConductor(b) => b.sample(wi, u),
            Bsdf::RoughSubstrate(b) => b.sample(wi, u, u_lobe),
            Bsdf::TwoSided(b) => b.sample(at, wi, u, u_lobe),
            Bsdf::Mask(b) => b.sample(at, wi, u, u_lobe),
            Bsdf::Blend(b) => b.sample(at, wi, u, u_lobe),
            Bsdf::Tilted(b) => b.sample(at, wi, u, u_lobe),
            Bsdf::Principled(b) => b.sample(at, wi, u, u_lobe),
            Bsdf::PrincipledThin(b) => b.sample(at, wi, u, u_lobe),
            Bsdf::Textured(b) => b.sample(at, wi, u, u_lobe),
        }
    }
}
