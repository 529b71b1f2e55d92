//! Participating media: Mitsuba 3's `homogeneous` medium with its
//! `isotropic` and `hg` phase functions, named by shapes (`interior`,
//! `exterior`) and sensors.

use super::{Child, Ctx};
use crate::color::{Rgb, SpectrumUse};
use crate::load::props::Kind;
use crate::load::xml::SceneNode;
use crate::load::SceneError;
use crate::medium::{Homogeneous, Medium, MediumKind, Phase};

type Result<T> = std::result::Result<T, SceneError>;

/// The media a scene's objects name, each built once however often it is
/// referenced (a path crossing from one shape's interior into another's
/// exterior stays in the same medium).
#[derive(Default)]
pub(super) struct BuiltMedia {
    pub media: Vec<Medium>,
    /// The element each medium was built from (by address), and its index.
    by_node: Vec<(usize, u32)>,
}

impl<'d> Ctx<'d> {
    /// The index of the medium `child` names, building it on first use.
    pub(super) fn medium_index(&mut self, child: &Child<'d>) -> Result<u32> {
        let key = child.node as *const SceneNode as usize;
        if let Some(&(_, i)) = self.media.by_node.iter().find(|(k, _)| *k == key) {
            return Ok(i);
        }
        let medium = self.enter(child, |c| c.medium(child.node))?;
        let i = self.media.media.len() as u32;
        self.media.media.push(medium);
        self.media.by_node.push((key, i));
        Ok(i)
    }

    /// `homogeneous` (Mitsuba's `media/homogeneous.cpp`): `sigma_t` (1)
    /// times `scale` (1), `albedo` (0.75), a phase function (isotropic),
    /// `sample_emitters` (true).
    fn medium(&mut self, node: &'d SceneNode) -> Result<Medium> {
        let ty = self.object_type(node, &["homogeneous"], &["heterogeneous"])?;
        let owner = format!("<medium type=\"{ty}\">");
        let (mut p, children) = self.read_object(node, &owner)?;
        let mut phase: Option<(Phase, crate::load::xml::Pos)> = None;
        let mut volumes: Vec<Child<'d>> = Vec::new();
        for c in children {
            match c.node.tag.as_str() {
                "phase" => {
                    if let Some((_, first)) = phase {
                        return Err(self.err(
                            c.at,
                            format!("a medium can have only one <phase> (the first is at {first})"),
                        ));
                    }
                    phase = Some((self.enter(&c, |x| x.phase(c.node))?, c.at));
                }
                "volume" => volumes.push(c),
                _ => return Err(self.misplaced(&c, &owner)),
            }
        }
        // A constant volume is a colour; grids are not read.
        for v in volumes {
            let name = v.name.unwrap_or_default();
            if !matches!(name, "sigma_t" | "albedo") {
                return Err(self.err(
                    v.at,
                    format!("a <volume> inside {owner} sets 'sigma_t' or 'albedo', not '{name}'"),
                ));
            }
            let value = self.enter(&v, |x| x.const_volume(v.node))?;
            p.insert(name, crate::load::props::Value::Color(value), v.at, v.at);
        }
        let scale = p.get_float("scale", 1.0)?;
        if scale < 0.0 {
            return Err(p.error(
                "scale",
                format!("'scale' must not be negative, found {scale}"),
            ));
        }
        let sigma_as_rgb = p.kind_of("sigma_t") == Some(Kind::Color);
        let before = p.set_spectrum_use(SpectrumUse::Unbounded);
        let sigma_t = p.get_rgb_or_float("sigma_t", Rgb::ONE)?;
        if sigma_as_rgb && sigma_t.max_element() > 1.0 {
            // Mitsuba reads an <rgb> sigma_t as a reflectance and refuses it.
            return Err(p.error(
                "sigma_t",
                format!(
                    "'sigma_t' given as an <rgb> must lie in [0, 1] (Mitsuba reads it as a \
                     reflectance), found {} {} {}; give 'scale' for denser media, or a <float>",
                    sigma_t.x, sigma_t.y, sigma_t.z
                ),
            ));
        }
        p.set_spectrum_use(SpectrumUse::Reflectance);
        let albedo = p.get_rgb_or_float("albedo", Rgb::splat(0.75))?;
        p.set_spectrum_use(before);
        if albedo.max_element() > 1.0 {
            return Err(p.error(
                "albedo",
                format!(
                    "'albedo' (scattering over extinction) must be at most 1, found {} {} {}",
                    albedo.x, albedo.y, albedo.z
                ),
            ));
        }
        let sigma_t = sigma_t * scale;
        if !sigma_t.is_finite() {
            return Err(p.error("scale", "'sigma_t' times 'scale' overflows"));
        }
        // Mitsuba's shortcut for grey media: lente's estimator is exact
        // either way, so the flag changes nothing.
        p.get_bool("has_spectral_extinction", true)?;
        let sample_emitters = p.get_bool("sample_emitters", true)?;
        p.finish(&mut self.warnings);
        Ok(Medium {
            kind: MediumKind::Homogeneous(Homogeneous { sigma_t, albedo }),
            phase: phase.map_or(Phase::Isotropic, |(ph, _)| ph),
            sample_emitters,
        })
    }

    /// `isotropic`, and `hg` with its mean cosine `g` (0.8).
    fn phase(&mut self, node: &'d SceneNode) -> Result<Phase> {
        let ty = self.object_type(
            node,
            &["isotropic", "hg"],
            &["rayleigh", "sggx", "tabphase", "blendphase"],
        )?;
        let owner = format!("<phase type=\"{ty}\">");
        let (mut p, children) = self.read_object(node, &owner)?;
        self.no_children(&children, &owner)?;
        let phase = if ty == "hg" {
            let g = p.get_float("g", 0.8)?;
            if !(g > -1.0 && g < 1.0) {
                return Err(p.error(
                    "g",
                    format!("'g' (the mean cosine) must lie strictly between -1 and 1, found {g}"),
                ));
            }
            Phase::HenyeyGreenstein { g }
        } else {
            Phase::Isotropic
        };
        p.finish(&mut self.warnings);
        Ok(phase)
    }

    /// `constvolume`: one value everywhere (`value`, 1 as in Mitsuba).
    fn const_volume(&mut self, node: &'d SceneNode) -> Result<Rgb> {
        let ty = self.object_type(node, &["constvolume"], &["gridvolume"])?;
        let owner = format!("<volume type=\"{ty}\">");
        let (mut p, children) = self.read_object(node, &owner)?;
        self.no_children(&children, &owner)?;
        let before = p.set_spectrum_use(SpectrumUse::Unbounded);
        let value = p.get_rgb_or_float("value", Rgb::ONE)?;
        p.set_spectrum_use(before);
        p.get_transform("to_world", Default::default())?;
        p.finish(&mut self.warnings);
        Ok(value)
    }
}
