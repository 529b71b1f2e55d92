//! Participating media: Mitsuba 3's `homogeneous` and `heterogeneous`
//! media with their `isotropic` and `hg` phase functions and their
//! `constvolume` and `gridvolume` coefficients, named by shapes
//! (`interior`, `exterior`) and sensors.

use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::{Child, Ctx};
use crate::color::{Rgb, SpectrumUse};
use crate::load::props::Kind;
use crate::load::xml::{Pos, SceneNode};
use crate::load::SceneError;
use crate::math::{Mat4, Transform};
use crate::medium::{
    load_vol, GridLookup, Heterogeneous, Homogeneous, Medium, MediumKind, Phase, VolError, Volume,
    VolumeData, VolumeFilter, VolumeGrid, WrapMode, MAX_OPTICAL_EXTENT,
};

type Result<T> = std::result::Result<T, SceneError>;

/// The media a scene's objects name, each built once however often it is
/// referenced (a path crossing from one shape's interior into another's
/// exterior stays in the same medium).
#[derive(Default)]
pub(super) struct BuiltMedia {
    pub media: Vec<Medium>,
    /// The element each medium was built from (by address), and its index.
    by_node: Vec<(usize, u32)>,
    /// Grids read so far, by canonical path.
    grids: Vec<(PathBuf, Arc<VolumeGrid>)>,
}

impl BuiltMedia {
    /// The grid in `path`, read on first use.
    fn grid(&mut self, path: &Path) -> std::result::Result<Arc<VolumeGrid>, VolError> {
        let key = std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
        if let Some((_, g)) = self.grids.iter().find(|(k, _)| *k == key) {
            return Ok(g.clone());
        }
        let grid = Arc::new(load_vol(&key)?);
        self.grids.push((key, grid.clone()));
        Ok(grid)
    }
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

    /// `homogeneous` and `heterogeneous` (Mitsuba's `media/*.cpp`):
    /// `sigma_t` (1) times `scale` (1), `albedo` (0.75), a phase function
    /// (isotropic), `sample_emitters` (true). Each coefficient is a
    /// `<float>`, a colour or a `<volume>`; a homogeneous medium's
    /// extinction must be constant.
    fn medium(&mut self, node: &'d SceneNode) -> Result<Medium> {
        let ty = self.object_type(node, &["homogeneous", "heterogeneous"], &[])?;
        let owner = format!("<medium type=\"{ty}\">");
        let (mut p, children) = self.read_object(node, &owner)?;
        let mut phase: Option<(Phase, crate::load::xml::Pos)> = None;
        let mut sigma_t: Option<(Volume, Pos)> = None;
        let mut albedo: Option<(Volume, Pos)> = None;
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
                "volume" => {
                    let slot = match c.name.unwrap_or_default() {
                        "sigma_t" => &mut sigma_t,
                        "albedo" => &mut albedo,
                        name => {
                            return Err(self.err(
                                c.at,
                                format!(
                                    "a <volume> inside {owner} sets 'sigma_t' or 'albedo', not \
                                     '{name}'"
                                ),
                            ))
                        }
                    };
                    if slot.is_some() || p.has(c.name.unwrap_or_default()) {
                        return Err(self.err(
                            c.at,
                            format!("'{}' is given twice", c.name.unwrap_or_default()),
                        ));
                    }
                    *slot = Some((self.enter(&c, |x| x.volume(c.node))?, c.at));
                }
                _ => return Err(self.misplaced(&c, &owner)),
            }
        }
        let scale = p.get_float("scale", 1.0)?;
        if scale < 0.0 {
            return Err(p.error(
                "scale",
                format!("'scale' must not be negative, found {scale}"),
            ));
        }
        let (sigma_t, sigma_at) = match sigma_t {
            Some((v, at)) => (v, Some(at)),
            None => {
                let sigma_as_rgb = p.kind_of("sigma_t") == Some(Kind::Color);
                let before = p.set_spectrum_use(SpectrumUse::Unbounded);
                let value = p.get_rgb_or_float("sigma_t", Rgb::ONE)?;
                p.set_spectrum_use(before);
                if sigma_as_rgb && value.max_element() > 1.0 {
                    // Mitsuba reads an <rgb> sigma_t as a reflectance and
                    // refuses it.
                    return Err(p.error(
                        "sigma_t",
                        format!(
                            "'sigma_t' given as an <rgb> must lie in [0, 1] (Mitsuba reads it as \
                             a reflectance), found {} {} {}; give 'scale' for denser media, or \
                             a <float>",
                            value.x, value.y, value.z
                        ),
                    ));
                }
                (Volume::constant(value), None)
            }
        };
        let albedo = match albedo {
            Some((v, at)) => {
                if v.min() < 0.0 || v.max() > 1.0 {
                    return Err(self.err(
                        at,
                        format!(
                            "'albedo' (scattering over extinction) must lie in [0, 1], but the \
                             volume's values span [{}, {}]",
                            v.min(),
                            v.max()
                        ),
                    ));
                }
                v
            }
            None => {
                let before = p.set_spectrum_use(SpectrumUse::Reflectance);
                let value = p.get_rgb_or_float("albedo", Rgb::splat(0.75))?;
                p.set_spectrum_use(before);
                if value.max_element() > 1.0 {
                    return Err(p.error(
                        "albedo",
                        format!(
                            "'albedo' (scattering over extinction) must be at most 1, found {} \
                             {} {}",
                            value.x, value.y, value.z
                        ),
                    ));
                }
                Volume::constant(value)
            }
        };
        let sigma_pos = sigma_at.unwrap_or_else(|| p.value_pos("sigma_t"));
        let sigma_error = |c: &Self, message: String| c.err(sigma_pos, message);
        if sigma_t.min() < 0.0 {
            return Err(sigma_error(
                self,
                format!("'sigma_t' must not be negative, found {}", sigma_t.min()),
            ));
        }
        if !(sigma_t.max() * scale).is_finite() {
            return Err(sigma_error(
                self,
                "'sigma_t' times 'scale' overflows".into(),
            ));
        }
        let kind = if ty == "homogeneous" {
            let Some(value) = sigma_t.as_constant() else {
                return Err(sigma_error(
                    self,
                    "a homogeneous medium's 'sigma_t' must be constant; use \
                     <medium type=\"heterogeneous\"> for a grid"
                        .into(),
                ));
            };
            MediumKind::Homogeneous(Homogeneous {
                sigma_t: value * scale,
                albedo,
            })
        } else {
            if sigma_t.as_constant().is_some() {
                // Mitsuba bounds the medium by the volume's unit cube, even
                // for a constant.
                let w = "a constant 'sigma_t' in a heterogeneous medium fills only its volume's \
                     box, the unit cube [0, 1]^3 unless a <volume> with 'to_world' places it \
                     (Mitsuba's rule); use <medium type=\"homogeneous\"> to fill the shape";
                self.warn(sigma_pos, w);
            }
            let h = Heterogeneous::new(sigma_t, scale, albedo);
            if h.optical_extent() > MAX_OPTICAL_EXTENT {
                return Err(sigma_error(
                    self,
                    format!(
                    "the medium is too dense for lente: 'scale' times the largest 'sigma_t' ({}) \
                     times its box's diagonal is {:.3e}, more than {:.0e} collisions per ray \
                     across it",
                    h.majorant,
                    h.optical_extent(),
                    MAX_OPTICAL_EXTENT
                ),
                ));
            }
            MediumKind::Heterogeneous(Box::new(h))
        };
        // Mitsuba's shortcut for grey media: lente's estimators are
        // unbiased either way, so the flag changes nothing.
        p.get_bool("has_spectral_extinction", true)?;
        let sample_emitters = p.get_bool("sample_emitters", true)?;
        p.finish(&mut self.warnings);
        Ok(Medium {
            kind,
            phase: phase.map_or(Phase::Isotropic, |(ph, _)| ph),
            sample_emitters,
        })
    }

    /// `isotropic`, `hg` with its mean cosine `g` (0.8), and `rayleigh`.
    fn phase(&mut self, node: &'d SceneNode) -> Result<Phase> {
        let ty = self.object_type(
            node,
            &["isotropic", "hg", "rayleigh"],
            &["sggx", "tabphase", "blendphase"],
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
        } else if ty == "rayleigh" {
            Phase::Rayleigh
        } else {
            Phase::Isotropic
        };
        p.finish(&mut self.warnings);
        Ok(phase)
    }

    /// `constvolume` (`value`, 1) and `gridvolume` (`filename`,
    /// `filter_type` trilinear, `wrap_mode` clamp, `use_grid_bbox` false,
    /// `max_value`), each placed by `to_world`. Grids are shared by the
    /// volumes naming one file.
    fn volume(&mut self, node: &'d SceneNode) -> Result<Volume> {
        let ty = self.object_type(node, &["constvolume", "gridvolume"], &[])?;
        let owner = format!("<volume type=\"{ty}\">");
        let (mut p, children) = self.read_object(node, &owner)?;
        self.no_children(&children, &owner)?;
        let mut to_world = p.get_transform("to_world", Transform::IDENTITY)?;
        let data = if ty == "constvolume" {
            let before = p.set_spectrum_use(SpectrumUse::Unbounded);
            let value = p.get_rgb_or_float("value", Rgb::ONE)?;
            p.set_spectrum_use(before);
            VolumeData::Constant(value)
        } else {
            let name = p.require_string("filename")?;
            let filter = match p.get_string("filter_type", "trilinear".into())?.as_str() {
                "trilinear" => VolumeFilter::Trilinear,
                "nearest" => VolumeFilter::Nearest,
                other => {
                    return Err(p.error(
                        "filter_type",
                        format!("unknown filter_type '{other}'; use trilinear or nearest"),
                    ))
                }
            };
            let wrap = super::texture::wrap_mode(&mut p, WrapMode::Clamp)?;
            // RGB rendering reads grids as they are: `raw` (no spectral
            // upsampling) and `accel` (GPU textures) change nothing.
            p.get_bool("raw", false)?;
            p.get_bool("accel", true)?;
            let path = self.resolve(&name);
            let grid = self.media.grid(&path).map_err(|e| {
                p.error("filename", "cannot load the volume grid")
                    .caused_by(e)
            })?;
            if grid.channels == 6 {
                return Err(p.error(
                    "filename",
                    format!(
                        "'{name}' has 6 channels (SGGX parameters); a medium's 'sigma_t' or \
                         'albedo' grid has 1 or 3"
                    ),
                ));
            }
            if p.get_bool("use_grid_bbox", false)? {
                let b = grid.bbox;
                let extent = b.diagonal();
                let placed =
                    Transform::new(Mat4::from_translation(b.min) * Mat4::from_scale(extent))
                        .ok_or_else(|| {
                            p.error(
                                "use_grid_bbox",
                                format!(
                                    "'{name}' gives the box {} .. {}, which is empty along an axis",
                                    b.min, b.max
                                ),
                            )
                        })?;
                to_world = to_world.then_after(&placed);
            }
            if p.has("max_value") {
                // Mitsuba takes it as the majorant, trusted; lente uses the
                // grid's own largest value, which is never too small.
                p.get_float("max_value", 0.0)?;
                p.warn(
                    "max_value",
                    "'max_value' is ignored: lente bounds the medium by the grid's largest value",
                );
            }
            VolumeData::Grid(GridLookup { grid, filter, wrap })
        };
        p.finish(&mut self.warnings);
        Ok(Volume::new(data, to_world))
    }
}
