//! BSDFs: Mitsuba's diffuse, dielectrics, conductors, plastics and
//! twosided, the wrappers (mask, blendbsdf, normalmap, bumpmap) and
//! principled, with Mitsuba's names and defaults (`bsdfs/*.cpp`), built by
//! lente's own checked constructors of the same models.

use std::collections::HashMap;

use super::{Child, Ctx};
use crate::bsdf::presets::{conductor_preset_names, ior_preset_names};
use crate::bsdf::{conductor_preset, ior_preset, Bsdf, BsdfError, BsdfParam};
use crate::bsdf::{MicrofacetType, Principled, PrincipledThin, Roughness};
use crate::color::{Rgb, SpectrumUse};
use crate::load::props::{positive, Kind, Props};
use crate::load::xml::{describe, SceneNode};
use crate::load::SceneError;
use crate::texture::Texture;

type Result<T> = std::result::Result<T, SceneError>;

/// BSDFs built so far, by element: a BSDF that shapes share by reference
/// is built once (rough plastics compute tables, up to half a second).
#[derive(Default)]
pub(super) struct BuiltBsdfs(HashMap<*const SceneNode, Bsdf>);

/// Mitsuba's name of a BSDF parameter, for a BSDF of type `ty`.
fn param_name(ty: &str, param: BsdfParam) -> &'static str {
    match param {
        BsdfParam::Diffuse if ty == "diffuse" => "reflectance",
        BsdfParam::Diffuse => "diffuse_reflectance",
        BsdfParam::SpecularReflectance => "specular_reflectance",
        BsdfParam::SpecularTransmittance if ty == "polarizer" => "transmittance",
        BsdfParam::SpecularTransmittance => "specular_transmittance",
        BsdfParam::IntIor => "int_ior",
        BsdfParam::ExtIor => "ext_ior",
        BsdfParam::Alpha => "alpha",
        BsdfParam::AlphaV => "alpha_v",
        BsdfParam::Eta => "eta",
        BsdfParam::K => "k",
        BsdfParam::Nested => "bsdf",
        BsdfParam::Opacity => "opacity",
        BsdfParam::Weight => "weight",
        BsdfParam::NormalMap => "normalmap",
        BsdfParam::BumpScale => "scale",
    }
}

impl<'d> Ctx<'d> {
    /// The BSDF of a `<bsdf>` element (built once per element).
    pub(super) fn bsdf(&mut self, node: &'d SceneNode) -> Result<Bsdf> {
        if let Some(b) = self.built.0.get(&(node as *const SceneNode)) {
            return Ok(b.clone());
        }
        let b = self.read_bsdf(node)?;
        self.built.0.insert(node, b.clone());
        Ok(b)
    }

    /// Mitsuba's BSDFs with their parameters and defaults (`bsdfs/*.cpp`).
    fn read_bsdf(&mut self, node: &'d SceneNode) -> Result<Bsdf> {
        let ty = self.object_type(
            node,
            &[
                "diffuse",
                "dielectric",
                "thindielectric",
                "roughdielectric",
                "conductor",
                "roughconductor",
                "plastic",
                "roughplastic",
                "pplastic",
                "polarizer",
                "twosided",
                "mask",
                "blendbsdf",
                "normalmap",
                "bumpmap",
                "principled",
                "principledthin",
                "null",
            ],
            &["hair", "measured", "retarder", "circular"],
        )?;
        let owner = format!("<bsdf type=\"{ty}\">");
        let (mut p, children) = self.read_object(node, &owner)?;
        let mut tex = Textures::new(ty);
        let built: std::result::Result<Bsdf, BsdfError> = match ty {
            "diffuse" => Bsdf::diffuse(tex.rgb(&mut p, BsdfParam::Diffuse, 0.5)?),
            "dielectric" | "thindielectric" | "roughdielectric" => {
                let int_ior = ior(&mut p, "int_ior", 1.5046)?;
                let ext_ior = ior(&mut p, "ext_ior", 1.000277)?;
                let reflectance = tex.rgb(&mut p, BsdfParam::SpecularReflectance, 1.0)?;
                let transmittance = tex.rgb(&mut p, BsdfParam::SpecularTransmittance, 1.0)?;
                match ty {
                    "dielectric" => {
                        if reflectance != Rgb::ONE
                            || transmittance != Rgb::ONE
                            || !tex.list.is_empty()
                        {
                            tex.list.clear();
                            self.warn(
                                node.pos,
                                format!(
                                    "{owner} is rendered without its specular_reflectance/\
                                     specular_transmittance tints (lente's smooth dielectric \
                                     has none)"
                                ),
                            );
                        }
                        Bsdf::dielectric(int_ior, ext_ior)
                    }
                    "thindielectric" => {
                        Bsdf::thin_dielectric(int_ior, ext_ior, reflectance, transmittance)
                    }
                    _ => {
                        let r = roughness(&mut p, &mut tex)?;
                        Bsdf::rough_dielectric(
                            r.distribution,
                            r.alpha_u,
                            r.alpha_v,
                            int_ior,
                            ext_ior,
                            reflectance,
                            transmittance,
                            r.sample_visible,
                        )
                    }
                }
            }
            "conductor" | "roughconductor" => {
                let (eta, k) = conductor_ior(&mut p, &mut tex)?;
                let reflectance = tex.rgb(&mut p, BsdfParam::SpecularReflectance, 1.0)?;
                if ty == "conductor" {
                    Bsdf::conductor(eta, k, reflectance)
                } else {
                    let r = roughness(&mut p, &mut tex)?;
                    Bsdf::rough_conductor(
                        r.distribution,
                        r.alpha_u,
                        r.alpha_v,
                        eta,
                        k,
                        reflectance,
                        r.sample_visible,
                    )
                }
            }
            "plastic" | "roughplastic" => {
                let diffuse = tex.rgb(&mut p, BsdfParam::Diffuse, 0.5)?;
                let specular = tex.rgb(&mut p, BsdfParam::SpecularReflectance, 1.0)?;
                let int_ior = ior(&mut p, "int_ior", 1.49)?;
                let ext_ior = ior(&mut p, "ext_ior", 1.000277)?;
                let nonlinear = p.get_bool("nonlinear", false)?;
                if ty == "plastic" {
                    Bsdf::plastic(int_ior, ext_ior, diffuse, specular, nonlinear)
                } else {
                    let r = roughness(&mut p, &mut tex)?;
                    if r.alpha_u != r.alpha_v {
                        return Err(p.error(
                            "alpha_u",
                            "roughplastic takes one 'alpha' (Mitsuba's roughplastic is \
                             isotropic only)",
                        ));
                    }
                    Bsdf::rough_plastic(
                        r.distribution,
                        r.alpha_u,
                        int_ior,
                        ext_ior,
                        diffuse,
                        specular,
                        nonlinear,
                        r.sample_visible,
                    )
                }
            }
            "pplastic" => {
                let diffuse = tex.rgb(&mut p, BsdfParam::Diffuse, 0.5)?;
                let specular = tex.rgb(&mut p, BsdfParam::SpecularReflectance, 1.0)?;
                let (int_ior, ext_ior) = if p.has("eta") {
                    if p.has("int_ior") || p.has("ext_ior") {
                        return Err(p.error("eta", "give either 'eta' or 'int_ior' and 'ext_ior'"));
                    }
                    (positive(&mut p, "eta", 1.0)?, 1.0)
                } else {
                    (
                        ior(&mut p, "int_ior", 1.49)?,
                        ior(&mut p, "ext_ior", 1.000277)?,
                    )
                };
                let r = roughness(&mut p, &mut tex)?;
                Bsdf::polarized_plastic(r, int_ior, ext_ior, diffuse, specular)
            }
            "null" => Ok(Bsdf::Null),
            "polarizer" => {
                let transmittance = tex.rgb(&mut p, BsdfParam::SpecularTransmittance, 1.0)?;
                // The angle matters only to polarised light, which RGB
                // rendering (lente's and Mitsuba's RGB variants') does not
                // carry: read and dropped, as there (README, Differences).
                p.opt_texture("theta")?;
                p.get_bool("polarizing", true)?;
                Bsdf::polarizer(transmittance)
            }
            "mask" => {
                let opacity = p.get_texture("opacity", Rgb::splat(0.5))?;
                let nested = self.one_nested(node, &owner, &children)?;
                Bsdf::mask(opacity, nested)
            }
            "blendbsdf" => {
                let Some(weight) = p.opt_texture("weight")? else {
                    return Err(self.err(
                        node.pos,
                        format!("{owner} needs a 'weight' (a number or a texture, 0 to 1)"),
                    ));
                };
                let [first, second] = self.nested_pair(node, &owner, &children)?;
                Bsdf::blend(weight, first, second)
            }
            "bumpmap" => {
                // Its one texture, under whatever name the file gives it.
                let names = p.texture_names();
                let height = match names.as_slice() {
                    [name] => p.get_texture(name, Rgb::ZERO)?,
                    [] => {
                        return Err(self.err(
                            node.pos,
                            format!("{owner} needs a nested <texture> (the height, e.g. a bitmap)"),
                        ))
                    }
                    [_, second, ..] => {
                        return Err(p.error(second, format!("{owner} takes one nested <texture>")))
                    }
                };
                let scale = p.get_float("scale", 1.0)?;
                let flip = p.get_bool("flip_invalid_normals", true)?;
                let shadowing = p.get_bool("use_shadowing_function", true)?;
                let nested = self.one_nested(node, &owner, &children)?;
                Bsdf::bump_map(height, scale, nested, flip, shadowing)
            }
            "normalmap" => {
                let Some(normals) = p.opt_texture("normalmap")? else {
                    return Err(self.err(
                        node.pos,
                        format!(
                            "{owner} needs a 'normalmap' texture (a bitmap with \
                             <boolean name=\"raw\" value=\"true\"/>)"
                        ),
                    ));
                };
                let flip = p.get_bool("flip_invalid_normals", true)?;
                let shadowing = p.get_bool("use_shadowing_function", true)?;
                let nested = self.one_nested(node, &owner, &children)?;
                Bsdf::normal_map(normals, nested, flip, shadowing)
            }
            "principled" => Ok(principled(&mut p)?),
            "principledthin" => Ok(principled_thin(&mut p)?),
            _ => self.two_sided(node, &owner, &children)?,
        };
        let bsdf = built
            .and_then(|b| Bsdf::textured(b, tex.list))
            .map_err(|e| {
                let name = match e.param() {
                    BsdfParam::Alpha if p.has("alpha_u") => "alpha_u",
                    param => param_name(ty, param),
                };
                p.param_error(name, &e)
            })?;
        if !matches!(
            ty,
            "twosided" | "mask" | "blendbsdf" | "normalmap" | "bumpmap"
        ) {
            self.no_children(&children, &owner)?;
        }
        p.finish(&mut self.warnings);
        Ok(bsdf)
    }

    /// The one nested `<bsdf>` of a BSDF that wraps another (`mask`).
    fn one_nested(
        &mut self,
        node: &'d SceneNode,
        owner: &str,
        children: &[Child<'d>],
    ) -> Result<Bsdf> {
        let mut nested = None;
        for c in children {
            if c.node.tag != "bsdf" {
                return Err(self.misplaced(c, owner));
            }
            if nested.is_some() {
                return Err(self.err(c.at, format!("{owner} takes one nested <bsdf>")));
            }
            nested = Some(self.enter(c, |x| x.bsdf(c.node))?);
        }
        nested.ok_or_else(|| self.err(node.pos, format!("{owner} needs a nested <bsdf>")))
    }

    /// The two nested `<bsdf>`s of a `blendbsdf`, in file order.
    fn nested_pair(
        &mut self,
        node: &'d SceneNode,
        owner: &str,
        children: &[Child<'d>],
    ) -> Result<[Bsdf; 2]> {
        let mut nested = Vec::with_capacity(2);
        for c in children {
            if c.node.tag != "bsdf" {
                return Err(self.misplaced(c, owner));
            }
            if nested.len() == 2 {
                return Err(self.err(c.at, format!("{owner} takes two nested <bsdf>s")));
            }
            nested.push(self.enter(c, |x| x.bsdf(c.node))?);
        }
        match <[Bsdf; 2]>::try_from(nested) {
            Ok(pair) => Ok(pair),
            Err(_) => Err(self.err(node.pos, format!("{owner} needs two nested <bsdf>s"))),
        }
    }

    /// `twosided`: one or two nested BSDFs without transmission.
    fn two_sided(
        &mut self,
        node: &'d SceneNode,
        owner: &str,
        children: &[Child<'d>],
    ) -> Result<std::result::Result<Bsdf, BsdfError>> {
        let mut inner = Vec::new();
        for c in children {
            if c.node.tag != "bsdf" {
                return Err(self.misplaced(c, owner));
            }
            if inner.len() == 2 {
                return Err(self.err(c.at, "a twosided BSDF takes one or two <bsdf>s"));
            }
            let nested = self.enter(c, |x| x.bsdf(c.node))?;
            if nested.has_transmission() {
                let hint = if matches!(nested, Bsdf::Mask(_)) {
                    "put the twosided inside the mask instead (Mitsuba refuses this too)"
                } else {
                    "a dielectric is two-sided already, use it without twosided"
                };
                return Err(self.err(
                    c.at,
                    format!(
                        "{} {}; {hint}",
                        describe(c.node),
                        BsdfError::NestedTransmission
                    ),
                ));
            }
            inner.push(nested);
        }
        let mut it = inner.into_iter();
        let Some(front) = it.next() else {
            return Err(self.err(node.pos, "a twosided BSDF needs a nested <bsdf>"));
        };
        Ok(Bsdf::two_sided(front, it.next()))
    }
}

/// The textured parameters of the BSDF being read, of Mitsuba type `ty`
/// (which names its parameters).
struct Textures<'t> {
    ty: &'t str,
    list: Vec<(BsdfParam, Texture)>,
}

impl<'t> Textures<'t> {
    fn new(ty: &'t str) -> Self {
        Textures {
            ty,
            list: Vec::new(),
        }
    }

    /// A colour parameter (read under its Mitsuba name) that may be a
    /// texture: the constant to build the model with (a varying texture's
    /// mean, which Mitsuba's lobe weights use too); a varying texture is
    /// recorded for `param`.
    fn rgb(&mut self, p: &mut Props, param: BsdfParam, default: f32) -> Result<Rgb> {
        let t = p.get_texture(param_name(self.ty, param), Rgb::splat(default))?;
        let mean = t.mean();
        if t.is_varying() {
            self.list.push((param, t));
        }
        Ok(mean)
    }

    /// A number that may be a texture (a roughness, read as a number by
    /// Mitsuba's `eval_1`); recorded for every one of `params`, its mean
    /// single value the constant the model is built with.
    fn float(
        &mut self,
        p: &mut Props,
        name: &str,
        default: f32,
        params: &[BsdfParam],
    ) -> Result<f32> {
        if p.kind_of(name) != Some(Kind::Texture) {
            return p.get_float(name, default);
        }
        let t = p.get_texture(name, Rgb::splat(default))?;
        for &param in params {
            self.list.push((param, t.clone()));
        }
        Ok(t.mean_1())
    }
}

/// A conductor's complex index of refraction: `eta` and `k`, or one of
/// Mitsuba's measured `material`s (`none`, the default, gives 0 and 1: a
/// perfect mirror).
fn conductor_ior(p: &mut Props, tex: &mut Textures<'_>) -> Result<(Rgb, Rgb)> {
    let material = p.get_string("material", "none".into())?;
    if p.has("eta") || p.has("k") || material == "none" {
        if material != "none" {
            return Err(p.error(
                "material",
                "give either 'material' or 'eta' and 'k', not both",
            ));
        }
        // Real files have negative components (RGB fits of measured data,
        // as in Bitterli's living-room-2). Mitsuba takes them as they are;
        // its Fresnel term, like ours, squares them, so the magnitude
        // renders the same image.
        for name in ["eta", "k"] {
            if let Some(c) = p.make_color_magnitude(name) {
                p.warn(
                    name,
                    format!(
                        "'{name}' has negative components ({} {} {}); a conductor's Fresnel \
                         term depends only on their squares, so their magnitudes are used, \
                         as Mitsuba in effect does",
                        c.x, c.y, c.z
                    ),
                );
            }
        }
        // Mitsuba reads these unbounded: spectra are clipped only at zero.
        let before = p.set_spectrum_use(SpectrumUse::Unbounded);
        let eta = tex.rgb(p, BsdfParam::Eta, 0.0)?;
        let k = tex.rgb(p, BsdfParam::K, 1.0)?;
        p.set_spectrum_use(before);
        return Ok((eta, k));
    }
    conductor_preset(&material).ok_or_else(|| {
        let names: Vec<&str> = conductor_preset_names().collect();
        p.error(
            "material",
            format!(
                "unknown conductor material '{material}'; Mitsuba's are: {}",
                names.join(", ")
            ),
        )
    })
}

/// An index of refraction: a number, or one of Mitsuba's names.
fn ior(p: &mut Props, name: &str, default: f32) -> Result<f32> {
    if p.kind_of(name) != Some(Kind::String) {
        return p.get_float(name, default);
    }
    let s = p.require_string(name)?;
    ior_preset(s.trim()).ok_or_else(|| {
        let names: Vec<&str> = ior_preset_names().collect();
        p.error(
            name,
            format!(
                "unknown index of refraction '{s}'; give a number or one of: {}",
                names.join(", ")
            ),
        )
    })
}

/// `distribution` (beckmann or ggx, default beckmann), `alpha` (0.1) or
/// both `alpha_u` and `alpha_v`, `sample_visible` (true).
fn roughness(p: &mut Props, tex: &mut Textures<'_>) -> Result<Roughness> {
    let dist = p.get_string("distribution", "beckmann".into())?;
    let Some(distribution) = MicrofacetType::from_name(dist.trim()) else {
        return Err(p.error(
            "distribution",
            format!("unknown distribution '{dist}'; use beckmann or ggx"),
        ));
    };
    let (alpha_u, alpha_v) = if p.has("alpha_u") || p.has("alpha_v") {
        if p.has("alpha") {
            return Err(p.error("alpha", "give either 'alpha' or 'alpha_u' and 'alpha_v'"));
        }
        if !p.has("alpha_u") {
            p.require_float("alpha_u")?;
        }
        if !p.has("alpha_v") {
            p.require_float("alpha_v")?;
        }
        (
            tex.float(p, "alpha_u", 0.1, &[BsdfParam::Alpha])?,
            tex.float(p, "alpha_v", 0.1, &[BsdfParam::AlphaV])?,
        )
    } else {
        let a = tex.float(p, "alpha", 0.1, &[BsdfParam::Alpha, BsdfParam::AlphaV])?;
        (a, a)
    };
    Ok(Roughness {
        distribution,
        alpha_u,
        alpha_v,
        sample_visible: p.get_bool("sample_visible", true)?,
    })
}

/// A Disney parameter as Mitsuba's `has_*` flags read it: `None` when
/// absent or given as the number zero (its terms are then skipped).
fn flagged(p: &mut Props, name: &str) -> Result<Option<Texture>> {
    Ok(p.opt_texture(name)?
        .filter(|t| *t != Texture::Constant(Rgb::ZERO)))
}

/// A Disney lobe's relative sampling rate (1), not negative.
fn sampling_rate(p: &mut Props, name: &str) -> Result<f32> {
    let r = p.get_float(name, 1.0)?;
    if r < 0.0 {
        return Err(p.error(name, format!("'{name}' must not be negative, found {r}")));
    }
    Ok(r)
}

/// Mitsuba 3's `principled` (`bsdfs/principled.cpp`): its parameters,
/// each a number or a texture, with its defaults; `eta` or `specular`
/// (not both) sets the IOR.
fn principled(p: &mut Props) -> Result<Bsdf> {
    let spec_trans = flagged(p, "spec_trans")?;
    let eta = match (p.has("eta"), p.has("specular")) {
        (true, true) => {
            return Err(p.error(
                "specular",
                "give either 'eta' or 'specular' (the IOR), not both",
            ))
        }
        (true, false) => {
            let eta = positive(p, "eta", 1.0)?;
            // eta = 1 is not plausible for transmission (Mitsuba's nudge).
            if spec_trans.is_some() && eta == 1.0 {
                1.001
            } else {
                eta
            }
        }
        (false, _) => {
            let specular = p.get_float("specular", 0.5)?;
            if !(0.0..12.5).contains(&specular) {
                return Err(p.error(
                    "specular",
                    format!("'specular' must be at least 0 and below 12.5 (an IOR of infinity), found {specular}"),
                ));
            }
            let specular = if spec_trans.is_some() && specular == 0.0 {
                1e-3
            } else {
                specular
            };
            crate::bsdf::specular_to_eta(specular)
        }
    };
    let spec_rate = sampling_rate(p, "main_specular_sampling_rate")?;
    let clearcoat_rate = sampling_rate(p, "clearcoat_sampling_rate")?;
    let diffuse_rate = sampling_rate(p, "diffuse_reflectance_sampling_rate")?;
    if spec_rate <= 0.0 {
        return Err(p.error(
            "main_specular_sampling_rate",
            "'main_specular_sampling_rate' must be positive (the specular lobe is always there)",
        ));
    }
    Ok(Bsdf::Principled(Box::new(Principled {
        base_color: p.get_texture("base_color", Rgb::splat(0.5))?,
        roughness: p.get_texture("roughness", Rgb::splat(0.5))?,
        anisotropic: flagged(p, "anisotropic")?,
        spec_trans,
        sheen: flagged(p, "sheen")?,
        sheen_tint: flagged(p, "sheen_tint")?,
        flatness: flagged(p, "flatness")?,
        spec_tint: flagged(p, "spec_tint")?,
        metallic: flagged(p, "metallic")?,
        clearcoat: flagged(p, "clearcoat")?,
        clearcoat_gloss: p.get_texture("clearcoat_gloss", Rgb::ZERO)?,
        eta,
        spec_rate,
        clearcoat_rate,
        diffuse_rate,
    })))
}

/// Mitsuba 3's `principledthin` (`bsdfs/principledthin.cpp`): its
/// parameters, each a number or a texture, with its defaults; `eta` (1.5)
/// may be a texture too, read unbounded.
fn principled_thin(p: &mut Props) -> Result<Bsdf> {
    let before = p.set_spectrum_use(SpectrumUse::Unbounded);
    let eta = p.get_texture("eta", Rgb::splat(1.5))?;
    p.set_spectrum_use(before);
    if let Texture::Constant(c) = &eta {
        if c.min_element().is_nan() || c.min_element() <= 0.0 {
            return Err(p.error(
                "eta",
                format!("'eta' (the sheet's IOR) must be positive, found {c}"),
            ));
        }
    }
    let diff_trans = flagged(p, "diff_trans")?;
    if let Some(Texture::Constant(c)) = &diff_trans {
        if c.max_element() > 2.0 {
            return Err(p.error(
                "diff_trans",
                format!("'diff_trans' lies in [0, 2] (Mitsuba halves it), found {c}"),
            ));
        }
    }
    Ok(Bsdf::PrincipledThin(Box::new(PrincipledThin {
        base_color: p.get_texture("base_color", Rgb::splat(0.5))?,
        roughness: p.get_texture("roughness", Rgb::splat(0.5))?,
        anisotropic: flagged(p, "anisotropic")?,
        spec_trans: flagged(p, "spec_trans")?,
        sheen: flagged(p, "sheen")?,
        sheen_tint: flagged(p, "sheen_tint")?,
        flatness: flagged(p, "flatness")?,
        spec_tint: flagged(p, "spec_tint")?,
        diff_trans,
        eta,
        spec_refl_rate: sampling_rate(p, "specular_reflectance_sampling_rate")?,
        spec_trans_rate: sampling_rate(p, "specular_transmittance_sampling_rate")?,
        diff_refl_rate: sampling_rate(p, "diffuse_reflectance_sampling_rate")?,
        diff_trans_rate: sampling_rate(p, "diffuse_transmittance_sampling_rate")?,
    })))
}
