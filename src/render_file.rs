//! lente's render files: the EXR a render writes. Beside what viewers show
//! (`R`, `G`, `B`: the image), it holds the film's exact state (the
//! filter-weighted radiance sums, channels `lente.film.R`, `.G`, `.B`, and
//! weight sums, `lente.weight.Y`; not `.W`, which Mitsuba's `Bitmap` takes
//! for a weight channel and refuses to split; AOV sums as
//! `lente.film.<channel>`) and the render's metadata in its header (`lente.*`
//! text attributes: scene, parameters, seed and sample range, spp, target
//! spp, render time, lente version).
//!
//! The film state is what makes a render continuable bit for bit (the
//! normalised image alone loses the sums to rounding) and renders of one
//! scene mergeable: two films of disjoint samples add up to the film of
//! all of them, exactly as one render would have accumulated them, up to
//! the order of float additions.

use std::fmt::Write as _;
use std::path::Path;

use crate::aov::AovList;
use crate::color::Rgb;
use crate::image::{
    load_exr_channels, save_exr_channels, Bitmap, ExrChannels, Film, ImageError, OutChannel,
    OutChannels,
};

/// lente's version, as written in render files.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");

/// The film-state channels: weighted radiance sums and the weight sum.
const FILM_CHANNELS: [&str; 4] = [
    "lente.film.R",
    "lente.film.G",
    "lente.film.B",
    "lente.weight.Y",
];

/// Samples `start..end` of every pixel, drawn with `seed`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub struct SampleRange {
    pub seed: u64,
    pub start: u32,
    pub end: u32,
}

impl SampleRange {
    pub fn len(&self) -> u32 {
        self.end - self.start
    }

    pub fn is_empty(&self) -> bool {
        self.end == self.start
    }
}

/// What a render file says about the render in it.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderMeta {
    /// The scene file, as the render command was given it.
    pub scene: String,
    /// A digest of the scene file's bytes and the parameters: renders of
    /// one scene agree on it ([`scene_digest`]).
    pub scene_digest: String,
    /// Mitsuba `$name` parameters set on the command line (`-D`).
    pub params: Vec<(String, String)>,
    /// The samples in the film, by seed; sorted, disjoint, adjacent ranges
    /// of one seed joined.
    pub ranges: Vec<SampleRange>,
    /// The spp the render was asked for (where a continued render stops).
    pub spp_target: u32,
    /// Seconds spent rendering, over every run that added samples.
    pub render_seconds: f64,
    /// The lente version that wrote it.
    pub version: String,
    /// The output variables beside the image (`lente.aovs`).
    pub aovs: AovList,
    /// The denoiser that made the image (`lente.denoiser`), if any: the
    /// root layer is then denoised and `noisy.R/G/B` holds the film's
    /// image. The film state is never denoised.
    pub denoiser: Option<String>,
    /// The scene's reconstruction filter was replaced by a one-pixel box
    /// (`lente.filter = box`), as `--denoise` does: a wider filter
    /// correlates neighbouring pixels' noise, which denoisers cannot
    /// remove. A continued render keeps it; merged renders agree on it.
    pub box_filter: bool,
}

impl RenderMeta {
    /// Samples per pixel in the film.
    pub fn spp(&self) -> u32 {
        self.ranges.iter().map(SampleRange::len).sum()
    }

    /// The metadata of a render in progress once its samples reach `end`
    /// after `seconds` more: the last range ends at `end` (empty ranges are
    /// left out) and the time adds up.
    pub fn progressed(&self, end: u32, seconds: f64) -> RenderMeta {
        let mut m = self.clone();
        if let Some(last) = m.ranges.last_mut() {
            last.end = end.max(last.start);
        }
        m.ranges.retain(|r| !r.is_empty());
        m.render_seconds += seconds;
        m
    }
}

/// A render: its film and what it is.
#[derive(Clone, Debug)]
pub struct RenderFile {
    pub meta: RenderMeta,
    pub film: Film,
}

/// FNV-1a (64 bit) of the scene file's bytes and the parameters, in hex:
/// a cheap fingerprint that tells renders of different scenes (or of one
/// scene file since edited) apart. Files the scene includes are not in it.
pub fn scene_digest(scene_bytes: &[u8], params: &[(String, String)]) -> String {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut eat = |bytes: &[u8]| {
        for &b in bytes {
            h ^= b as u64;
            h = h.wrapping_mul(0x0000_0100_0000_01b3);
        }
    };
    eat(scene_bytes);
    let mut sorted = params.to_vec();
    sorted.sort();
    for (name, value) in &sorted {
        eat(b"\0");
        eat(name.as_bytes());
        eat(b"=");
        eat(value.as_bytes());
    }
    format!("{h:016x}")
}

/// Formats ranges as `seed 0: 0..64; seed 1: 0..64`.
fn format_ranges(ranges: &[SampleRange]) -> String {
    let mut s = String::new();
    for (i, r) in ranges.iter().enumerate() {
        if i > 0 {
            s.push_str("; ");
        }
        let _ = write!(s, "seed {}: {}..{}", r.seed, r.start, r.end);
    }
    s
}

fn parse_ranges(s: &str) -> Option<Vec<SampleRange>> {
    let mut out = Vec::new();
    if s.trim().is_empty() {
        return Some(out);
    }
    for part in s.split(';') {
        let rest = part.trim().strip_prefix("seed ")?;
        let (seed, range) = rest.split_once(':')?;
        let (start, end) = range.trim().split_once("..")?;
        let r = SampleRange {
            seed: seed.trim().parse().ok()?,
            start: start.trim().parse().ok()?,
            end: end.trim().parse().ok()?,
        };
        if r.end <= r.start {
            return None;
        }
        out.push(r);
    }
    Some(out)
}

/// Sorts ranges and joins adjacent ones of one seed; `Err` names two that
/// overlap (the same samples twice).
pub fn normalise_ranges(
    mut ranges: Vec<SampleRange>,
) -> Result<Vec<SampleRange>, (SampleRange, SampleRange)> {
    ranges.sort();
    let mut out: Vec<SampleRange> = Vec::with_capacity(ranges.len());
    for r in ranges {
        match out.last_mut() {
            Some(last) if last.seed == r.seed && r.start < last.end => return Err((*last, r)),
            Some(last) if last.seed == r.seed && r.start == last.end => last.end = r.end,
            _ => out.push(r),
        }
    }
    Ok(out)
}

/// Writes a render file (atomically): `image` (the film normalised, which
/// viewers show), the film's state and `m` (the metadata) in the header.
pub fn save_render(
    path: &Path,
    m: &RenderMeta,
    film: &Film,
    image: &Bitmap,
) -> Result<(), ImageError> {
    let data = film.data();
    let params = serde_json::to_string(&m.params).unwrap_or_default();
    let mut attributes = vec![
        ("lente.version".to_string(), m.version.clone()),
        ("lente.scene".to_string(), m.scene.clone()),
        ("lente.sceneDigest".to_string(), m.scene_digest.clone()),
        ("lente.params".to_string(), params),
        ("lente.samples".to_string(), format_ranges(&m.ranges)),
        ("lente.spp".to_string(), m.spp().to_string()),
        ("lente.sppTarget".to_string(), m.spp_target.to_string()),
        (
            "lente.renderTime".to_string(),
            format!("{:.3}", m.render_seconds),
        ),
    ];
    if let [single] = m.ranges[..] {
        attributes.push(("lente.seed".to_string(), single.seed.to_string()));
    }
    if !m.aovs.is_empty() {
        attributes.push(("lente.aovs".to_string(), m.aovs.to_string()));
    }
    if m.box_filter {
        attributes.push(("lente.filter".to_string(), "box".to_string()));
    }
    if let Some(d) = &m.denoiser {
        attributes.push(("lente.denoiser".to_string(), d.clone()));
    }
    // Every channel is read from the film and the image as the file is
    // written: no copy of either (see `OutChannel`).
    let px = &image.pixels;
    let mut channels = OutChannels {
        width: film.width,
        height: film.height,
        channels: vec![
            OutChannel::new("R", |i| px[i].x),
            OutChannel::new("G", |i| px[i].y),
            OutChannel::new("B", |i| px[i].z),
            OutChannel::new(FILM_CHANNELS[0], |i| data[i].0.x),
            OutChannel::new(FILM_CHANNELS[1], |i| data[i].0.y),
            OutChannel::new(FILM_CHANNELS[2], |i| data[i].0.z),
            OutChannel::new(FILM_CHANNELS[3], |i| data[i].1),
        ],
        attributes,
    };
    if m.denoiser.is_some() {
        for (c, name) in ["noisy.R", "noisy.G", "noisy.B"].into_iter().enumerate() {
            channels
                .channels
                .push(OutChannel::new(name, move |i| film.value(i)[c]));
        }
    }
    // AOVs: normalised as viewers and denoisers read them, and their sums.
    let names = m.aovs.channel_names();
    if names.len() == film.aov_channels() {
        let n = names.len();
        let sums = film.aov_sums();
        for (c, name) in names.iter().enumerate() {
            channels
                .channels
                .push(OutChannel::new(name.to_string(), move |i| {
                    film.aov_value(i, c)
                }));
            channels
                .channels
                .push(OutChannel::new(format!("lente.film.{name}"), move |i| {
                    sums[i * n + c]
                }));
        }
    }
    save_exr_channels(path, &channels)
}

impl RenderFile {
    /// The image viewers see: weighted radiance over weight.
    pub fn image(&self) -> Bitmap {
        self.film.to_bitmap()
    }

    /// Writes the render file (atomically); `image` must be [`Self::image`]
    /// (passed in because the caller usually has it already).
    pub fn save(&self, path: &Path, image: &Bitmap) -> Result<(), ImageError> {
        save_render(path, &self.meta, &self.film, image)
    }

    /// Reads a render file written by lente; any other EXR is an error
    /// saying what it lacks.
    pub fn load(path: &Path) -> Result<RenderFile, ImageError> {
        let exr = load_exr_channels(path)?;
        Self::from_channels(&exr).map_err(|m| ImageError::new(path, m))
    }

    /// [`Self::load`] from the file's bytes (what the fuzzer feeds).
    pub fn decode(bytes: &[u8]) -> Result<RenderFile, String> {
        let exr = crate::image::io::decode_exr_channels(bytes).map_err(|m| m.0)?;
        Self::from_channels(&exr)
    }

    fn from_channels(exr: &ExrChannels) -> Result<RenderFile, String> {
        let missing = FILM_CHANNELS
            .iter()
            .filter(|c| exr.channel(c).is_none())
            .copied()
            .collect::<Vec<_>>();
        if !missing.is_empty() {
            return Err(format!(
                "not a lente render file: no film state (channel{} {} missing); only the EXRs \
                 that lente render writes can be continued or merged",
                if missing.len() > 1 { "s" } else { "" },
                missing.join(", ")
            ));
        }
        let attr = |name: &str| {
            exr.attribute(name)
                .ok_or_else(|| format!("not a lente render file: no '{name}' attribute"))
        };
        let bad = |name: &str, value: &str| format!("bad '{name}' attribute: '{value}'");
        let samples = attr("lente.samples")?;
        let ranges = parse_ranges(samples).ok_or_else(|| bad("lente.samples", samples))?;
        let ranges = normalise_ranges(ranges).map_err(|_| bad("lente.samples", samples))?;
        let target = attr("lente.sppTarget")?;
        let time = attr("lente.renderTime")?;
        let params = attr("lente.params")?;
        let meta = RenderMeta {
            scene: attr("lente.scene")?.to_string(),
            scene_digest: attr("lente.sceneDigest")?.to_string(),
            params: serde_json::from_str(params).map_err(|_| bad("lente.params", params))?,
            ranges,
            spp_target: target.parse().map_err(|_| bad("lente.sppTarget", target))?,
            render_seconds: time
                .parse::<f64>()
                .ok()
                .filter(|t| t.is_finite() && *t >= 0.0)
                .ok_or_else(|| bad("lente.renderTime", time))?,
            version: attr("lente.version")?.to_string(),
            aovs: match exr.attribute("lente.aovs") {
                Some(list) => list.parse().map_err(|_| bad("lente.aovs", list))?,
                None => AovList::default(),
            },
            denoiser: exr.attribute("lente.denoiser").map(str::to_string),
            box_filter: match exr.attribute("lente.filter") {
                None => false,
                Some("box") => true,
                Some(other) => return Err(bad("lente.filter", other)),
            },
        };
        let [r, g, b, w] = FILM_CHANNELS.map(|c| exr.channel(c).unwrap_or_default());
        let mut data = Vec::with_capacity(exr.width * exr.height);
        for i in 0..exr.width * exr.height {
            let (sum, weight) = (Rgb::new(r[i], g[i], b[i]), w[i]);
            if !sum.is_finite() || !weight.is_finite() || weight < 0.0 {
                return Err(format!(
                    "film state of pixel ({}, {}) is not finite or has a negative weight",
                    i % exr.width,
                    i / exr.width
                ));
            }
            data.push((sum, weight));
        }
        let mut film = Film::from_data(exr.width, exr.height, data)
            .ok_or_else(|| "film state does not match the image size".to_string())?;
        let names = meta.aovs.channel_names();
        if !names.is_empty() {
            let n = names.len();
            let mut sums = vec![0.0f32; n * exr.width * exr.height];
            for (c, name) in names.iter().enumerate() {
                let state = format!("lente.film.{name}");
                let values = exr
                    .channel(&state)
                    .ok_or_else(|| format!("AOV film state channel {state} missing"))?;
                if values.iter().any(|v| !v.is_finite()) {
                    return Err(format!("AOV film state {state} is not finite"));
                }
                for (i, v) in values.iter().enumerate() {
                    sums[i * n + c] = *v;
                }
            }
            film.set_aov_sums(n, sums)
                .ok_or_else(|| "AOV film state does not match the image size".to_string())?;
        }
        Ok(RenderFile { meta, film })
    }

    /// The render of all samples of `files` (paths for messages): films
    /// added in the order given. Refuses files of another size or scene,
    /// and files holding the same samples twice.
    pub fn merge(files: &[(&Path, RenderFile)]) -> Result<RenderFile, String> {
        let Some(((first_path, first), rest)) = files.split_first() else {
            return Err("nothing to merge".to_string());
        };
        let mut merged = first.clone();
        let mut ranges = first.meta.ranges.clone();
        for (path, f) in rest {
            let (a, b) = (&first.film, &f.film);
            if (a.width, a.height) != (b.width, b.height) {
                return Err(format!(
                    "{} is {}x{} but {} is {}x{}: renders of one size only",
                    first_path.display(),
                    a.width,
                    a.height,
                    path.display(),
                    b.width,
                    b.height
                ));
            }
            let (m, n) = (&first.meta, &f.meta);
            if m.scene_digest != n.scene_digest || m.params != n.params {
                return Err(format!(
                    "{} and {} are renders of different scenes ({} {:?}, digest {}; {} {:?}, \
                     digest {}): the scene file or its parameters differ",
                    first_path.display(),
                    path.display(),
                    m.scene,
                    m.params,
                    m.scene_digest,
                    n.scene,
                    n.params,
                    n.scene_digest
                ));
            }
            if m.aovs != n.aovs {
                return Err(format!(
                    "{} has the AOVs '{}' but {} has '{}': renders with the same --aov only",
                    first_path.display(),
                    m.aovs,
                    path.display(),
                    n.aovs
                ));
            }
            if m.box_filter != n.box_filter {
                let with = |b: bool| {
                    if b {
                        "a box filter (--denoise)"
                    } else {
                        "the scene's filter"
                    }
                };
                return Err(format!(
                    "{} was rendered with {} but {} with {}: their pixels do not add up",
                    first_path.display(),
                    with(m.box_filter),
                    path.display(),
                    with(n.box_filter)
                ));
            }
            merged.film.add(&f.film);
            merged.meta.render_seconds += f.meta.render_seconds;
            ranges.extend(f.meta.ranges.iter().copied());
        }
        merged.meta.ranges = normalise_ranges(ranges).map_err(|(a, b)| {
            format!(
                "two of the files hold the same samples (seed {}: {}..{} and {}..{}): \
                 they are not independent renders; render them with different --seed or \
                 disjoint --samples",
                a.seed, a.start, a.end, b.start, b.end
            )
        })?;
        merged.meta.spp_target = merged.meta.spp();
        merged.meta.version = VERSION.to_string();
        merged.meta.denoiser = None;
        Ok(merged)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn file(seed: u64, start: u32, end: u32, value: f32) -> RenderFile {
        let data = (0..6)
            .map(|i| (Rgb::splat(value * (i + 1) as f32), (end - start) as f32))
            .collect();
        RenderFile {
            meta: RenderMeta {
                scene: "scenes/a b/ü.xml".into(),
                scene_digest: scene_digest(b"<scene/>", &[]),
                params: vec![("spp".into(), "4".into())],
                ranges: vec![SampleRange { seed, start, end }],
                spp_target: 64,
                render_seconds: 1.5,
                version: VERSION.into(),
                aovs: AovList::default(),
                denoiser: None,
                box_filter: false,
            },
            film: Film::from_data(3, 2, data).unwrap(),
        }
    }

    #[test]
    fn a_render_file_round_trips_exactly() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("r.exr");
        let f = file(7, 0, 16, 0.1);
        f.save(&path, &f.image()).unwrap();
        let back = RenderFile::load(&path).unwrap();
        assert_eq!(back.meta, f.meta);
        assert_eq!(back.film.data(), f.film.data());
        // What other readers see is the image.
        let (image, _) = crate::image::load_image(&path).unwrap();
        assert_eq!(image, f.image());
    }

    #[test]
    fn a_denoised_render_file_keeps_its_noisy_image_and_filter() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("r.exr");
        let mut f = file(7, 0, 16, 0.1);
        f.meta.box_filter = true;
        f.meta.denoiser = Some("test denoiser".into());
        let mut denoised = f.image();
        denoised.pixels.iter_mut().for_each(|p| *p *= 0.5);
        f.save(&path, &denoised).unwrap();
        let back = RenderFile::load(&path).unwrap();
        assert_eq!(back.meta, f.meta);
        assert_eq!(back.film.data(), f.film.data());
        let exr = load_exr_channels(&path).unwrap();
        assert_eq!(exr.channel("R").unwrap()[2], denoised.pixels[2].x);
        assert_eq!(exr.channel("noisy.R").unwrap()[2], f.image().pixels[2].x);
        // A box-filtered render does not merge with one of another filter.
        let other = file(8, 0, 16, 0.1);
        let err = RenderFile::merge(&[(Path::new("a"), back), (Path::new("b"), other)]);
        assert!(err.unwrap_err().contains("box filter"));
    }

    #[test]
    fn merge_adds_films_and_joins_ranges() {
        let a = file(1, 0, 16, 1.0);
        let b = file(1, 16, 48, 2.0);
        let c = file(2, 0, 8, 3.0);
        let m = RenderFile::merge(&[
            (Path::new("a.exr"), a.clone()),
            (Path::new("b.exr"), b.clone()),
            (Path::new("c.exr"), c.clone()),
        ])
        .unwrap();
        assert_eq!(
            m.meta.ranges,
            [
                SampleRange {
                    seed: 1,
                    start: 0,
                    end: 48
                },
                SampleRange {
                    seed: 2,
                    start: 0,
                    end: 8
                }
            ]
        );
        assert_eq!(m.meta.spp(), 56);
        assert_eq!(m.meta.render_seconds, 4.5);
        for i in 0..6 {
            let (s, w) = m.film.data()[i];
            assert_eq!(
                s,
                a.film.data()[i].0 + b.film.data()[i].0 + c.film.data()[i].0
            );
            assert_eq!(w, 56.0);
        }
    }

    #[test]
    fn merge_refuses_overlaps_other_scenes_and_sizes() {
        let a = file(1, 0, 16, 1.0);
        let twice = RenderFile::merge(&[
            (Path::new("a.exr"), a.clone()),
            (Path::new("b.exr"), file(1, 8, 24, 1.0)),
        ]);
        assert!(twice
            .unwrap_err()
            .contains("same samples (seed 1: 0..16 and 8..24)"));
        let mut other = file(2, 0, 16, 1.0);
        other.meta.scene_digest = scene_digest(b"<scene></scene>", &[]);
        let err =
            RenderFile::merge(&[(Path::new("a.exr"), a.clone()), (Path::new("o.exr"), other)])
                .unwrap_err();
        assert!(
            err.contains("a.exr and o.exr are renders of different scenes"),
            "{err}"
        );
        let mut params = file(2, 0, 16, 1.0);
        params.meta.params = vec![("spp".into(), "5".into())];
        assert!(RenderFile::merge(&[
            (Path::new("a.exr"), a.clone()),
            (Path::new("p.exr"), params)
        ])
        .is_err());
        let mut small = file(2, 0, 16, 1.0);
        small.film = Film::new(2, 2);
        let err =
            RenderFile::merge(&[(Path::new("a.exr"), a), (Path::new("s.exr"), small)]).unwrap_err();
        assert!(err.contains("a.exr is 3x2 but s.exr is 2x2"), "{err}");
    }

    #[test]
    fn other_exrs_are_refused_with_what_they_lack() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("plain.exr");
        crate::image::save_image(&path, &Bitmap::new(4, 4)).unwrap();
        let err = RenderFile::load(&path).unwrap_err().to_string();
        assert!(
            err.contains("plain.exr") && err.contains("not a lente render file"),
            "{err}"
        );
        assert!(err.contains("lente.weight.Y"), "{err}");
    }

    #[test]
    fn ranges_parse_as_written_and_bad_ones_are_refused() {
        let r = vec![
            SampleRange {
                seed: 0,
                start: 0,
                end: 64,
            },
            SampleRange {
                seed: 18446744073709551615,
                start: 3,
                end: 5,
            },
        ];
        assert_eq!(parse_ranges(&format_ranges(&r)), Some(r));
        assert_eq!(parse_ranges(""), Some(vec![]));
        for bad in ["seed 1: 5..5", "seed x: 0..1", "0..4", "seed 1: 4..2"] {
            assert_eq!(parse_ranges(bad), None, "{bad}");
        }
    }

    #[test]
    fn the_digest_tells_scenes_and_parameters_apart() {
        let p = |v: &str| vec![("a".to_string(), v.to_string())];
        let d = scene_digest(b"<scene/>", &p("1"));
        assert_eq!(d, scene_digest(b"<scene/>", &p("1")));
        assert_ne!(d, scene_digest(b"<scene/>", &p("2")));
        assert_ne!(d, scene_digest(b"<scene />", &p("1")));
        assert_eq!(d.len(), 16);
    }
}
