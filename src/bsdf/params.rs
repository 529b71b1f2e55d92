//! Checks of BSDF parameters, shared by every model's constructor, and the
//! error that names the parameter that is wrong.

use crate::color::Rgb;

/// A BSDF parameter, as [`BsdfError`] names it (scene readers map it to
/// their dialect's property name).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BsdfParam {
    /// A diffuse colour: `albedo`, `reflectance`, `kd`, `diffuse_reflectance`.
    Diffuse,
    SpecularReflectance,
    SpecularTransmittance,
    IntIor,
    ExtIor,
    /// Isotropic roughness, or the first of two (`alpha_u`).
    Alpha,
    AlphaV,
    /// A conductor's complex index of refraction: real part.
    Eta,
    /// A conductor's complex index of refraction: imaginary part.
    K,
    /// A BSDF nested in another (`twosided`'s, `mask`'s).
    Nested,
    /// A `mask`'s opacity.
    Opacity,
    /// A `blendbsdf`'s weight.
    Weight,
    /// A `normalmap`'s normals.
    NormalMap,
    /// A `bumpmap`'s scale (and its texture).
    BumpScale,
}

/// BSDF parameters that describe no BSDF. Each message completes a
/// sentence that starts with the parameter's name.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum BsdfError {
    #[error("must be finite and not negative, found {value}")]
    NegativeColor { param: BsdfParam, value: Rgb },
    #[error("must be at most 1 in every channel, found {value}")]
    AboveOne { param: BsdfParam, value: Rgb },
    #[error("must be positive and finite, found {value}")]
    NotPositive { param: BsdfParam, value: f32 },
    #[error("must be finite and not negative, found {value}")]
    Negative { param: BsdfParam, value: f32 },
    #[error("transmits light, and a two-sided BSDF can only hold BSDFs without transmission")]
    NestedTransmission,
    #[error("cannot be a texture for this BSDF; give a constant value")]
    NotTexturable { param: BsdfParam },
}

impl BsdfError {
    /// The parameter that is wrong.
    pub fn param(&self) -> BsdfParam {
        match self {
            BsdfError::NegativeColor { param, .. }
            | BsdfError::AboveOne { param, .. }
            | BsdfError::NotPositive { param, .. }
            | BsdfError::Negative { param, .. }
            | BsdfError::NotTexturable { param } => *param,
            BsdfError::NestedTransmission => BsdfParam::Nested,
        }
    }
}

/// A colour with finite, non-negative channels.
pub(super) fn color(param: BsdfParam, value: Rgb) -> Result<Rgb, BsdfError> {
    if value.is_finite() && value.min_element() >= 0.0 {
        Ok(value)
    } else {
        Err(BsdfError::NegativeColor { param, value })
    }
}

/// A texture whose values are finite and not negative (a weight or an
/// opacity, clipped to at most 1 where read).
pub(super) fn texture_color(
    param: BsdfParam,
    t: &crate::texture::Texture,
) -> Result<(), BsdfError> {
    match t.constant() {
        Some(c) => color(param, c).map(|_| ()),
        None if !t.max_value().is_finite() => Err(BsdfError::NegativeColor {
            param,
            value: Rgb::splat(t.max_value()),
        }),
        None => Ok(()),
    }
}

/// A colour with channels in [0, 1] (an albedo that energy conservation
/// bounds).
pub(super) fn albedo(param: BsdfParam, value: Rgb) -> Result<Rgb, BsdfError> {
    let value = color(param, value)?;
    if value.max_element() > 1.0 {
        return Err(BsdfError::AboveOne { param, value });
    }
    Ok(value)
}

/// A positive, finite number (an index of refraction).
pub(super) fn positive(param: BsdfParam, value: f32) -> Result<f32, BsdfError> {
    if value > 0.0 && value.is_finite() {
        Ok(value)
    } else {
        Err(BsdfError::NotPositive { param, value })
    }
}

/// A finite, non-negative number (a roughness; zero is clamped to the
/// smallest the microfacet models use).
pub(super) fn non_negative(param: BsdfParam, value: f32) -> Result<f32, BsdfError> {
    if value >= 0.0 && value.is_finite() {
        Ok(value)
    } else {
        Err(BsdfError::Negative { param, value })
    }
}

/// The relative index of refraction interior / exterior.
pub(super) fn relative_ior(int_ior: f32, ext_ior: f32) -> Result<f32, BsdfError> {
    Ok(positive(BsdfParam::IntIor, int_ior)? / positive(BsdfParam::ExtIor, ext_ior)?)
}
