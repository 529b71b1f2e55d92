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

/// Most channels all AOVs together have (3 + 3 + 1 + 3).
pub const MAX_AOV_CHANNELS: usize = 10;

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
                format!("unknown AOV '{s}' (expected albedo, normal, depth or position)")
            })
    }
}

/// The AOVs a render writes, each once, in a fixed order.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct AovList(Vec<Aov>);

impl AovList {
    /// The list of `aovs` (repeats dropped).
    pub fn new(aovs: &[Aov]) -> AovList {
        AovList(Aov::ALL.into_iter().filter(|a| aovs.contains(a)).collect())
    }

    /// This list with `more` added.
    pub fn with(&self, more: &[Aov]) -> AovList {
        AovList::new(&[&self.0[..], more].concat())
    }

    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    pub fn aovs(&self) -> &[Aov] {
        &self.0
    }

    /// Channels in all (at most [`MAX_AOV_CHANNELS`]).
    pub fn channel_count(&self) -> usize {
        self.0.iter().map(|a| a.channels().len()).sum()
    }

    /// Every channel's name, in the order [`AovList::evaluate`] fills them.
    pub fn channel_names(&self) -> Vec<&'static str> {
        self.0
            .iter()
            .flat_map(|a| a.channels().iter().copied())
            .collect()
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
    }
}

impl fmt::Display for AovList {
    fn fmt(&self, f: &mut fmt::Formatter) -> fmt::Result {
        let names: Vec<&str> = self.0.iter().map(|a| a.name()).collect();
        f.write_str(&names.join(","))
    }
}

impl FromStr for AovList {
    type Err = String;
    /// A comma-separated list, e.g. `albedo,normal`; empty for none.
    fn from_str(s: &str) -> Result<AovList, String> {
        let aovs = s
            .split(',')
            .filter(|p| !p.trim().is_empty())
            .map(str::parse)
            .collect::<Result<Vec<Aov>, String>>()?;
        Ok(AovList::new(&aovs))
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
        assert_eq!(all.channel_count(), MAX_AOV_CHANNELS);
    }
}
