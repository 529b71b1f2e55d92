//! Arbitrary output variables: per-pixel albedo, normal, depth and position,
//! written as extra EXR channels beside the image (what denoisers such as
//! Intel Open Image Denoise take as auxiliary inputs).
//!
//! Albedo and normal follow OIDN's recommendation: through perfectly
//! specular bounces (mirror, glass, smooth conductors) to the first
//! non-specular hit, so a mirror shows the albedo and normals of what it
//! reflects. The albedo is the hit's directional albedo, estimated by one
//! BSDF sample (`f cos / pdf`: exactly the reflectance for a diffuse
//! surface, an unbiased estimate for any other), times the specular
//! weights on the way. Depth (the distance along the camera ray) and
//! position are those of the first hit. Rays that escape give zeros.
//!
//! AOVs draw from their own random stream, so asking for them leaves the
//! image bit for bit the same.
//!
//! Beside lente's four, a list can hold Mitsuba 3's `aov` integrator
//! entries, `NAME:TYPE` (what `<string name="aovs" value="dd:depth,nn:sh_normal"/>`
//! holds), with Mitsuba's definitions and channel names: values at the
//! first hit only, `albedo` the BSDF's diffuse reflectance
//! ([`crate::bsdf::Bsdf::diffuse_reflectance`], zero for mirror and
//! glass), `depth` as `NAME.T`, and so on ([`MitsubaAov`]).

use std::fmt;
use std::str::FromStr;

use crate::color::Rgb;
use crate::math::Ray;
use crate::sampling::Sampler;
use crate::scene::Scene;

/// One output variable.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Aov {
    Albedo,
    Normal,
    Depth,
    Position,
}

/// Most channels an AOV list may have.
pub const MAX_AOV_CHANNELS: usize = 32;

/// Specular bounces followed to the first non-specular hit.
const MAX_SPECULAR_BOUNCES: u32 = 8;

impl Aov {
    pub const ALL: [Aov; 4] = [Aov::Albedo, Aov::Normal, Aov::Depth, Aov::Position];

    /// Its name on the command line and in the EXR's channel names.
    pub fn name(self) -> &'static str {
        match self {
            Aov::Albedo => "albedo",
            Aov::Normal => "normal",
            Aov::Depth => "depth",
            Aov::Position => "position",
        }
    }

    /// Its EXR channels, as Mitsuba's `aov` integrator and OIDN's tools
    /// name them.
    pub fn channels(self) -> &'static [&'static str] {
        match self {
            Aov::Albedo => &["albedo.R", "albedo.G", "albedo.B"],
            Aov::Normal => &["normal.X", "normal.Y", "normal.Z"],
            Aov::Depth => &["depth.Z"],
            Aov::Position => &["position.X", "position.Y", "position.Z"],
        }
    }
}

impl FromStr for Aov {
    type Err = String;
    fn from_str(s: &str) -> Result<Aov, String> {
        let s = s.trim();
        Aov::ALL
            .into_iter()
            .find(|a| a.name().eq_ignore_ascii_case(s))
            .ok_or_else(|| {
                format!(
                    "unknown AOV '{s}' (expected albedo, normal, depth or position, or \
                     Mitsuba's NAME:TYPE)"
                )
            })
    }
}

/// A type of Mitsuba 3's `aov` integrator.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MitsubaAovType {
    Albedo,
    Depth,
    Position,
    Uv,
    GeoNormal,
    ShNormal,
    PrimIndex,
    ShapeIndex,
}

impl MitsubaAovType {
    const ALL: [MitsubaAovType; 8] = [
        MitsubaAovType::Albedo,
        MitsubaAovType::Depth,
        MitsubaAovType::Position,
        MitsubaAovType::Uv,
        MitsubaAovType::GeoNormal,
        MitsubaAovType::ShNormal,
        MitsubaAovType::PrimIndex,
        MitsubaAovType::ShapeIndex,
    ];

    /// Mitsuba's name of the type.
    pub fn name(self) -> &'static str {
        match self {
            MitsubaAovType::Albedo => "albedo",
            MitsubaAovType::Depth => "depth",
            MitsubaAovType::Position => "position",
            MitsubaAovType::Uv => "uv",
            MitsubaAovType::GeoNormal => "geo_normal",
            MitsubaAovType::ShNormal => "sh_normal",
            MitsubaAovType::PrimIndex => "prim_index",
            MitsubaAovType::ShapeIndex => "shape_index",
        }
    }

    /// The suffixes Mitsuba gives its channels.
    fn suffixes(self) -> &'static [&'static str] {
        match self {
            MitsubaAovType::Albedo => &["R", "G", "B"],
            MitsubaAovType::Depth => &["T"],
            MitsubaAovType::Position | MitsubaAovType::GeoNormal | MitsubaAovType::ShNormal => {
                &["X", "Y", "Z"]
            }
            MitsubaAovType::Uv => &["U", "V"],
            MitsubaAovType::PrimIndex | MitsubaAovType::ShapeIndex => &["I"],
        }
    }
}

/// One entry of Mitsuba's `aovs` list: channels `NAME.<suffix>`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MitsubaAov {
    pub name: String,
    pub ty: MitsubaAovType,
}

impl FromStr for MitsubaAov {
    type Err = String;
    /// `NAME:TYPE`.
    fn from_str(s: &str) -> Result<MitsubaAov, String> {
        let (name, ty) = s
            .split_once(':')
            .ok_or_else(|| format!("'{s}' is not NAME:TYPE"))?;
        let (name, ty) = (name.trim(), ty.trim());
        if name.is_empty() || !name.chars().all(|c| c.is_ascii_graphic() && c != ',') {
            return Err(format!("bad AOV name '{name}' in '{s}'"));
        }
        let ty = MitsubaAovType::ALL
            .into_iter()
            .find(|t| t.name() == ty)
            .ok_or_else(|| {
                let known: Vec<&str> = MitsubaAovType::ALL.iter().map(|t| t.name()).collect();
                let why = if ["dp_du", "dp_dv", "duv_dx", "duv_dy"].contains(&ty) {
                    "is not supported by lente"
                } else {
                    "is not one of Mitsuba's"
                };
                format!("AOV type '{ty}' {why} (lente reads: {})", known.join(", "))
            })?;
        Ok(MitsubaAov {
            name: name.to_string(),
            ty,
        })
    }
}

/// The AOVs a render writes: lente's, each once in a fixed order, then
/// Mitsuba-style entries in the order given.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct AovList(Vec<Aov>, Vec<MitsubaAov>);

impl AovList {
    /// The list of `aovs` (repeats dropped).
    pub fn new(aovs: &[Aov]) -> AovList {
        AovList(
            Aov::ALL.into_iter().filter(|a| aovs.contains(a)).collect(),
            Vec::new(),
        )
    }

    /// This list and `other`'s entries (lente's merged, Mitsuba's
    /// appended unless already there); an error when two channels would
    /// share a name or there are too many.
    pub fn union(&self, other: &AovList) -> Result<AovList, String> {
        let mut out = self.with(&other.0);
        for m in &other.1 {
            if !out.1.contains(m) {
                out.1.push(m.clone());
            }
        }
        out.check()?;
        Ok(out)
    }

    /// Channel names are distinct and at most [`MAX_AOV_CHANNELS`].
    fn check(&self) -> Result<(), String> {
        let names = self.channel_names();
        for (i, n) in names.iter().enumerate() {
            if names[..i].contains(n) {
                return Err(format!("two AOVs write the channel '{n}'"));
            }
        }
        if names.len() > MAX_AOV_CHANNELS {
            return Err(format!(
                "{} AOV channels asked for; at most {MAX_AOV_CHANNELS}",
                names.len()
            ));
        }
        Ok(())
    }

    /// This list with `more` of lente's added.
    pub fn with(&self, more: &[Aov]) -> AovList {
        let mut out = AovList::new(&[&self.0[..], more].concat());
        out.1 = self.1.clone();
        out
    }

    pub fn is_empty(&self) -> bool {
        self.0.is_empty() && self.1.is_empty()
    }

    /// lente's own AOVs in the list.
    pub fn aovs(&self) -> &[Aov] {
        &self.0
    }

    /// The Mitsuba-style entries.
    pub fn mitsuba(&self) -> &[MitsubaAov] {
        &self.1
    }

    /// Channels in all (at most [`MAX_AOV_CHANNELS`]).
    pub fn channel_count(&self) -> usize {
        self.0.iter().map(|a| a.channels().len()).sum::<usize>()
            + self.1.iter().map(|m| m.ty.suffixes().len()).sum::<usize>()
    }

    /// Every channel's name, in the order [`AovList::evaluate`] fills them.
    pub fn channel_names(&self) -> Vec<String> {
        let own = self
            .0
            .iter()
            .flat_map(|a| a.channels().iter())
            .map(|c| c.to_string());
        let mitsuba = self.1.iter().flat_map(|m| {
            m.ty.suffixes()
                .iter()
                .map(move |s| format!("{}.{s}", m.name))
        });
        own.chain(mitsuba).collect()
    }

    /// Traces `ray` for the AOVs and writes their values to `out` (at least
    /// [`AovList::channel_count`] long), drawing from `sampler`.
    pub fn evaluate(&self, scene: &Scene, ray: &Ray, sampler: &mut Sampler, out: &mut [f32]) {
        let first = scene.intersect(ray);
        let (mut albedo, mut normal) = (Rgb::ZERO, Rgb::ZERO);
        if self
            .0
            .iter()
            .any(|a| matches!(a, Aov::Albedo | Aov::Normal))
        {
            (albedo, normal) = albedo_and_normal(scene, *ray, first, sampler);
        }
        let mut i = 0;
        for aov in &self.0 {
            let values: [f32; 3] = match (aov, first) {
                (Aov::Albedo, _) => albedo.to_array(),
                (Aov::Normal, _) => normal.to_array(),
                (Aov::Depth, Some(its)) => [its.t, 0.0, 0.0],
                (Aov::Position, Some(its)) => its.p.to_array(),
                (_, None) => [0.0; 3],
            };
            let n = aov.channels().len();
            out[i..i + n].copy_from_slice(&values[..n]);
            i += n;
        }
        for m in &self.1 {
            let values = first.map_or([0.0; 3], |its| mitsuba_value(scene, ray.d, &its, m.ty));
            let n = m.ty.suffixes().len();
            out[i..i + n].copy_from_slice(&values[..n]);
            i += n;
        }
    }
}

/// A Mitsuba AOV's value at the first hit (Mitsuba's `aov` integrator).
fn mitsuba_value(
    scene: &Scene,
    ray_d: glam::Vec3,
    its: &crate::geometry::Intersection,
    ty: MitsubaAovType,
) -> [f32; 3] {
    match ty {
        MitsubaAovType::Albedo => {
            let bsdf = &scene.bsdfs[its.shape as usize];
            let wi = its.shading.to_local(-ray_d);
            bsdf.diffuse_reflectance(scene.surface_point(its), wi)
                .to_array()
        }
        MitsubaAovType::Depth => [its.t, 0.0, 0.0],
        MitsubaAovType::Position => its.p.to_array(),
        MitsubaAovType::Uv => [its.uv.x, its.uv.y, 0.0],
        MitsubaAovType::GeoNormal => its.ng.to_array(),
        MitsubaAovType::ShNormal => its.shading.n.to_array(),
        MitsubaAovType::PrimIndex => [its.prim as f32, 0.0, 0.0],
        // Mitsuba numbers the scene's shapes from 1 (0: no hit).
        MitsubaAovType::ShapeIndex => [(its.shape + 1) as f32, 0.0, 0.0],
    }
}

impl fmt::Display for AovList {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        let names: Vec<String> = self
            .0
            .iter()
            .map(|a| a.name().to_string())
            .chain(self.1.iter().map(|m| format!("{}:{}", m.name, m.ty.name())))
            .collect();
        f.write_str(&names.join(","))
    }
}

impl FromStr for AovList {
    type Err = String;
    /// A comma-separated list, e.g. `albedo,normal` or Mitsuba's
    /// `dd:depth,nn:sh_normal` (or both); empty for none.
    fn from_str(s: &str) -> Result<AovList, String> {
        let mut list = AovList::default();
        for item in s.split(',').filter(|p| !p.trim().is_empty()) {
            if item.contains(':') {
                let m: MitsubaAov = item.parse()?;
                if !list.1.contains(&m) {
                    list.1.push(m);
                }
            } else {
                let a: Aov = item.parse()?;
                list = list.with(&[a]);
            }
        }
        list.check()?;
        Ok(list)
    }
}

/// The albedo and world shading normal at the first non-specular hit along
/// `ray` (through at most [`MAX_SPECULAR_BOUNCES`] specular ones), the
/// albedo times the specular weights on the way.
fn albedo_and_normal(
    scene: &Scene,
    mut ray: Ray,
    mut hit: Option<crate::geometry::Intersection>,
    sampler: &mut Sampler,
) -> (Rgb, Rgb) {
    let mut weight = Rgb::ONE;
    for bounce in 0..=MAX_SPECULAR_BOUNCES {
        let Some(its) = hit else {
            return (Rgb::ZERO, Rgb::ZERO);
        };
        let bsdf = &scene.bsdfs[its.shape as usize];
        let sp = scene.surface_point(&its);
        let frame = its.shading;
        let wi = frame.to_local(-ray.d);
        let sample = bsdf.sample(sp, wi, sampler.next_2d(), sampler.next_1d());
        if !bsdf.is_specular() || bounce == MAX_SPECULAR_BOUNCES {
            let albedo = sample.map_or(Rgb::ZERO, |s| s.weight);
            return (weight * albedo, frame.n);
        }
        let Some(s) = sample else {
            return (Rgb::ZERO, frame.n);
        };
        weight *= s.weight;
        let d = frame.to_world(s.wo);
        ray = Ray::new(its.spawn(d), d);
        hit = scene.intersect(&ray);
    }
    (Rgb::ZERO, Rgb::ZERO)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lists_parse_in_a_fixed_order_without_repeats() {
        let l: AovList = "normal, albedo,normal,depth".parse().unwrap();
        assert_eq!(l.aovs(), [Aov::Albedo, Aov::Normal, Aov::Depth]);
        assert_eq!(l.channel_count(), 7);
        assert_eq!(l.to_string(), "albedo,normal,depth");
        assert_eq!(
            l.channel_names()[3..6],
            ["normal.X", "normal.Y", "normal.Z"]
        );
        assert!("".parse::<AovList>().unwrap().is_empty());
        let err = "albedo,uv".parse::<AovList>().unwrap_err();
        assert!(err.contains("unknown AOV 'uv'"), "{err}");
        let all = AovList::new(&Aov::ALL);
        assert_eq!(all.channel_count(), 10);
    }

    #[test]
    fn mitsuba_entries_keep_their_names_and_order() {
        let l: AovList = "nn:sh_normal, albedo, dd.y:depth".parse().unwrap();
        assert_eq!(l.aovs(), [Aov::Albedo]);
        assert_eq!(l.to_string(), "albedo,nn:sh_normal,dd.y:depth");
        assert_eq!(
            l.channel_names(),
            ["albedo.R", "albedo.G", "albedo.B", "nn.X", "nn.Y", "nn.Z", "dd.y.T"]
        );
        assert_eq!(l.to_string().parse::<AovList>().unwrap(), l);
        let err = "a:dp_du".parse::<AovList>().unwrap_err();
        assert!(err.contains("'dp_du' is not supported by lente"), "{err}");
        let err = "a:nonsense".parse::<AovList>().unwrap_err();
        assert!(err.contains("is not one of Mitsuba's"), "{err}");
        let err = "albedo.R:depth,albedo".parse::<AovList>();
        assert!(err.is_ok(), "albedo.R.T and albedo.R differ");
        let err = "x:albedo,x:albedo".parse::<AovList>().unwrap();
        assert_eq!(err.mitsuba().len(), 1, "an exact repeat is dropped");
        let err = "x:position,x:sh_normal".parse::<AovList>().unwrap_err();
        assert!(err.contains("two AOVs write the channel"), "{err}");
        let many: Vec<String> = (0..11).map(|i| format!("p{i}:position")).collect();
        let err = many.join(",").parse::<AovList>().unwrap_err();
        assert!(err.contains("at most 32"), "{err}");
        let err = ":depth".parse::<AovList>().unwrap_err();
        assert!(err.contains("bad AOV name"), "{err}");
    }
}
