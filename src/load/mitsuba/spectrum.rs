//! Spectra in Mitsuba scenes: `<spectrum name=".." value=".."/>` (one
//! number, or wavelength:value pairs), `<spectrum filename="x.spd"/>`, and
//! the spectrum objects `blackbody`, `regular`, `irregular` and `d65`. They
//! become [`Value::Spectrum`], turned into RGB where read
//! ([`crate::color::spectrum`]), as Mitsuba's RGB variants do.

use std::path::Path;

use super::Ctx;
use crate::color::{Rgb, SampledSpectrum, Spectrum, SpectrumError};
use crate::load::props::{self, Props, Value};
use crate::load::reader;
use crate::load::xml::{Attribute, Pos, SceneNode};
use crate::load::SceneError;

type Result<T> = std::result::Result<T, SceneError>;

/// Largest `.spd` file read (real ones are a few kB).
const MAX_SPD_BYTES: u64 = 1 << 20;

impl<'d> Ctx<'d> {
    /// A `<spectrum>` property element (without a `type`), else `None`.
    pub(super) fn spectrum_property(
        &self,
        file: &Path,
        node: &SceneNode,
    ) -> Result<Option<(Value, Pos)>> {
        if node.tag != "spectrum" {
            return Ok(None);
        }
        reader::check_attributes(file, node, &["name", "value", "filename"], &["name"])?;
        reader::no_content(file, node)?;
        match (node.attr("value"), node.attr("filename")) {
            (Some(v), None) => {
                let value = if v.value.contains(':') {
                    let pairs = parse_pairs(file, v)?;
                    Value::Spectrum(Spectrum::Sampled(
                        SampledSpectrum::new(&pairs)
                            .map_err(|e| SceneError::new(file, v.value_pos, e.to_string()))?,
                    ))
                } else {
                    match props::parse_numbers(file, v)?[..] {
                        [x] => Value::Spectrum(Spectrum::Uniform(x)),
                        // lente also takes three numbers, as an RGB colour.
                        [r, g, b] => Value::Color(Rgb::new(r, g, b)),
                        ref n => {
                            return Err(SceneError::new(
                                file,
                                v.value_pos,
                                format!(
                                    "a <spectrum> value is one number or wavelength:value pairs \
                                     (e.g. \"400:0.1, 700:0.9\"), found {} numbers",
                                    n.len()
                                ),
                            ))
                        }
                    }
                };
                Ok(Some((value, v.value_pos)))
            }
            (None, Some(f)) => {
                let path = self.resolve(&f.value);
                let s = read_spd(&path).map_err(|e| SceneError::new(file, f.value_pos, e))?;
                Ok(Some((Value::Spectrum(Spectrum::Sampled(s)), f.value_pos)))
            }
            _ => Err(SceneError::new(
                file,
                node.pos,
                "<spectrum> needs either a 'value' or a 'filename' attribute (not both)",
            )),
        }
    }
}

/// A spectrum object's value: `blackbody` (`temperature`, `wavelength_min`
/// 360, `wavelength_max` 830), `regular` (`values` evenly spaced from
/// `wavelength_min` to `wavelength_max`), `irregular` (`wavelengths`,
/// `values`), `d65` (in RGB: its `color` times `scale`, or `scale`).
pub(super) fn spectrum_object(ty: &str, p: &mut Props) -> Result<Value> {
    let bad = |p: &Props, name: &str, e: SpectrumError| p.error(name, e.to_string());
    match ty {
        "blackbody" => {
            let t = p.require_float("temperature")?;
            let lo = p.get_float("wavelength_min", 360.0)?;
            let hi = p.get_float("wavelength_max", 830.0)?;
            Spectrum::blackbody(t, (lo, hi))
                .map(Value::Spectrum)
                .map_err(|e| bad(p, "temperature", e))
        }
        "regular" => {
            let lo = p.require_float("wavelength_min")?;
            let hi = p.require_float("wavelength_max")?;
            let values = number_list(p, "values")?;
            let n = values.len();
            let pairs: Vec<(f32, f32)> = values
                .iter()
                .enumerate()
                .map(|(i, &v)| {
                    let t = if n > 1 {
                        i as f32 / (n - 1) as f32
                    } else {
                        0.0
                    };
                    (lo + t * (hi - lo), v)
                })
                .collect();
            sampled(p, "values", &pairs)
        }
        "irregular" => {
            let wavelengths = number_list(p, "wavelengths")?;
            let values = number_list(p, "values")?;
            if wavelengths.len() != values.len() {
                return Err(p.error(
                    "values",
                    format!(
                        "'values' has {} numbers but 'wavelengths' has {}",
                        values.len(),
                        wavelengths.len()
                    ),
                ));
            }
            let pairs: Vec<(f32, f32)> = wavelengths.into_iter().zip(values).collect();
            sampled(p, "wavelengths", &pairs)
        }
        _ => {
            // d65: in RGB modes Mitsuba expands it to its colour times its
            // scale (or a uniform `scale`).
            let scale = p.get_float("scale", 1.0)?;
            Ok(match p.opt_rgb("color")? {
                Some(c) => Value::Color(c * scale),
                None => Value::Float(scale),
            })
        }
    }
}

fn sampled(p: &Props, name: &str, pairs: &[(f32, f32)]) -> Result<Value> {
    SampledSpectrum::new(pairs)
        .map(|s| Value::Spectrum(Spectrum::Sampled(s)))
        .map_err(|e| p.error(name, e.to_string()))
}

/// A string property holding numbers separated by commas or spaces.
fn number_list(p: &mut Props, name: &str) -> Result<Vec<f32>> {
    let s = p.require_string(name)?;
    props::tokens(&s)
        .into_iter()
        .map(|(_, t)| {
            t.parse::<f32>()
                .map_err(|_| p.error(name, format!("cannot read '{t}' in '{name}' as a number")))
        })
        .collect()
}

/// `"400:0.1, 500 : 0.2"`: wavelength:value pairs, each error at its token.
fn parse_pairs(file: &Path, attr: &Attribute) -> Result<Vec<(f32, f32)>> {
    // One space on either side of ':' is allowed: drop it before
    // splitting, keeping each character's offset in the value.
    let chars: Vec<(usize, char)> = attr.value.char_indices().collect();
    let before: Vec<(usize, char)> = chars
        .iter()
        .enumerate()
        .filter(|&(i, &(_, c))| !(c == ' ' && chars.get(i + 1).is_some_and(|n| n.1 == ':')))
        .map(|(_, &x)| x)
        .collect();
    let joined: Vec<(usize, char)> = before
        .iter()
        .enumerate()
        .filter(|&(i, &(_, c))| !(c == ' ' && i > 0 && before[i - 1].1 == ':'))
        .map(|(_, &x)| x)
        .collect();
    let text: String = joined.iter().map(|&(_, c)| c).collect();
    // Byte offset in `text` -> byte offset in the value.
    let mut offsets = Vec::with_capacity(text.len());
    for &(off, c) in &joined {
        offsets.extend(std::iter::repeat_n(off, c.len_utf8()));
    }
    let mut pairs = Vec::new();
    for (off, tok) in props::tokens(&text) {
        let parsed = tok
            .split_once(':')
            .and_then(|(w, v)| Some((w.trim().parse().ok()?, v.trim().parse().ok()?)));
        match parsed {
            Some(pair) => pairs.push(pair),
            None => {
                return Err(SceneError::new(
                    file,
                    attr.pos_in_value(offsets[off]),
                    format!("cannot read '{tok}' as a wavelength:value pair (e.g. 400:0.5)"),
                ));
            }
        }
    }
    Ok(pairs)
}

/// A `.spd` file: lines of "wavelength value", `#` comments.
fn read_spd(path: &Path) -> std::result::Result<SampledSpectrum, String> {
    let is_spd = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("spd"));
    if !is_spd {
        return Err(format!(
            "cannot read '{}': spectrum files must be .spd text files (lines of \"wavelength value\")",
            path.display()
        ));
    }
    let bytes = crate::limits::read_file(path, MAX_SPD_BYTES, "spectrum files")
        .map_err(|e| format!("cannot read '{}': {e}", path.display()))?;
    let text = String::from_utf8_lossy(&bytes);
    let mut pairs = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.split('#').next().unwrap_or("");
        let nums: Vec<&str> = line.split_whitespace().collect();
        let at = |msg: String| format!("{}:{}: {msg}", path.display(), i + 1);
        match nums[..] {
            [] => {}
            [w, v] => match (w.parse::<f32>(), v.parse::<f32>()) {
                (Ok(w), Ok(v)) => pairs.push((w, v)),
                _ => {
                    return Err(at(format!(
                        "cannot read '{w} {v}' as a wavelength and a value"
                    )))
                }
            },
            _ => {
                return Err(at(format!(
                    "a line holds a wavelength and a value, found {} numbers",
                    nums.len()
                )))
            }
        }
    }
    SampledSpectrum::new(&pairs).map_err(|e| format!("'{}': {e}", path.display()))
}
