//! Watching a render while it runs: a live preview page served on
//! 127.0.0.1 and periodic checkpoints to the output files.
//!
//! The renderer calls [`PreviewState::publish`] after every pass (see
//! [`crate::render::render_with_passes`]). That normalises the film into a
//! new bitmap outside any lock and then swaps it in under a short one, so
//! the server never holds up the render threads and never touches the film
//! itself: the render's result is the same bit for bit with or without a
//! preview. The page polls `GET /status` (JSON) and fetches
//! `GET /image.png?exposure=STOPS|auto&tonemap=OP&v=PASS`; nothing is kept
//! per client, so it can be closed and reopened at any time.

mod http;
mod server;

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use crate::image::false_colour::exposure_zones;
use crate::image::io::Malformed;
use crate::image::{
    save_image, save_png_tonemapped, tonemap, Bitmap, Exposure, Film, ImageError, Look, Tonemap,
};
use crate::render::PassInfo;
use crate::render_file::{save_render, RenderMeta};

pub use server::{PreviewError, PreviewServer, DEFAULT_PORT};

/// Exposure values are clamped to this many stops either way.
pub const MAX_EXPOSURE: f32 = 20.0;

/// The latest finished pass, as the server sees it.
#[derive(Clone)]
pub struct Snapshot {
    /// Passes finished (0: nothing rendered yet, the image is black).
    pub pass: u32,
    pub spp_done: u32,
    pub spp_total: u32,
    /// Camera samples taken so far, and planned in all.
    pub samples: u64,
    pub samples_total: u64,
    /// Render time when the pass finished.
    pub elapsed: Duration,
    /// Wall-clock time when the snapshot was taken.
    pub taken: Instant,
    pub image: Arc<Bitmap>,
    /// The film behind `image` (kept only when saves write render files).
    pub film: Option<Arc<Film>>,
}

/// How the render ended.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Phase {
    Rendering,
    /// Finished (or interrupted) and its outputs written.
    Done {
        cancelled: bool,
        outputs: Vec<PathBuf>,
    },
}

/// How the page shows the image.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum View {
    /// Exposed and tone mapped (what the PNG output holds).
    Image,
    /// The exposed luminance in stops from middle grey, in false colour
    /// ([`crate::image::false_colour::exposure_zones`]).
    FalseColour,
}

/// The last encoded PNG: (pass, exposure bits, tone map, view, bytes).
type CachedPng = (u32, u32, Tonemap, View, Arc<Vec<u8>>);

struct Inner {
    snapshot: Mutex<Snapshot>,
    phase: Mutex<Phase>,
    /// Output path without extension; saves add `-preview-<spp>spp`.
    base: PathBuf,
    scene_name: String,
    png_cache: Mutex<Option<CachedPng>>,
    /// The stops `auto` exposure gives the image of a pass: (pass, stops).
    auto_cache: Mutex<Option<(u32, f32)>>,
    /// The render's metadata: saves write render files with it.
    meta: Mutex<Option<RenderMeta>>,
}

/// Shared between the render (which publishes passes) and the server
/// (which reads them). Cloning is cheap.
#[derive(Clone)]
pub struct PreviewState {
    inner: Arc<Inner>,
}

fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    // A panic elsewhere must not take the preview down with it.
    m.lock().unwrap_or_else(|e| e.into_inner())
}

impl PreviewState {
    /// A state for a `width` x `height` render of `spp_total` samples per
    /// pixel whose outputs go to `base` (without extension).
    pub fn new(width: usize, height: usize, spp_total: u32, base: &Path) -> PreviewState {
        let scene_name = base
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        PreviewState {
            inner: Arc::new(Inner {
                snapshot: Mutex::new(Snapshot {
                    pass: 0,
                    spp_done: 0,
                    spp_total,
                    samples: 0,
                    samples_total: width as u64 * height as u64 * spp_total as u64,
                    elapsed: Duration::ZERO,
                    taken: Instant::now(),
                    image: Arc::new(Bitmap::new(width, height)),
                    film: None,
                }),
                phase: Mutex::new(Phase::Rendering),
                base: base.to_path_buf(),
                scene_name,
                png_cache: Mutex::new(None),
                auto_cache: Mutex::new(None),
                meta: Mutex::new(None),
            }),
        }
    }

    /// Saves become render files with `meta` (the render's, its samples
    /// and time brought up to the pass saved), which `--resume` and
    /// `merge` take; each pass then keeps a copy of the film.
    pub fn set_meta(&self, meta: RenderMeta) {
        *lock(&self.inner.meta) = Some(meta);
    }

    /// Takes a snapshot of a finished pass: the film is normalised here, on
    /// the calling thread, and swapped in under a short lock.
    pub fn publish(&self, info: &PassInfo) {
        self.publish_image(info, Arc::new(info.film.to_bitmap()));
    }

    /// [`Self::publish`] with the pass's image already normalised (by a
    /// caller that also hands it elsewhere, e.g. to tev).
    pub fn publish_image(&self, info: &PassInfo, image: Arc<Bitmap>) {
        let keep_film = lock(&self.inner.meta).is_some();
        let film = keep_film.then(|| Arc::new(info.film.clone()));
        let mut s = lock(&self.inner.snapshot);
        s.pass += 1;
        s.spp_done = info.spp_done;
        s.spp_total = info.spp_total;
        s.samples = info.samples;
        s.elapsed = info.elapsed;
        s.taken = Instant::now();
        s.image = image;
        s.film = film;
    }

    /// Marks the render as finished with its outputs written.
    pub fn finish(&self, cancelled: bool, outputs: Vec<PathBuf>) {
        *lock(&self.inner.phase) = Phase::Done { cancelled, outputs };
    }

    pub fn snapshot(&self) -> Snapshot {
        lock(&self.inner.snapshot).clone()
    }

    pub fn phase(&self) -> Phase {
        lock(&self.inner.phase).clone()
    }

    /// The status as JSON: progress, rate, ETA and, once done, the outputs.
    pub fn status_json(&self) -> String {
        let s = self.snapshot();
        let phase = self.phase();
        let secs = s.elapsed.as_secs_f64();
        let rate = if secs > 0.0 && s.samples > 0 {
            s.samples as f64 / secs
        } else {
            f64::NAN
        };
        let percent = if s.samples_total > 0 {
            100.0 * s.samples as f64 / s.samples_total as f64
        } else {
            100.0
        };
        let (state, outputs, eta) = match &phase {
            Phase::Rendering => {
                let left = s.samples_total.saturating_sub(s.samples) as f64 / rate
                    - s.taken.elapsed().as_secs_f64();
                ("rendering", Vec::new(), left.max(0.0))
            }
            Phase::Done { cancelled, outputs } => (
                if *cancelled { "cancelled" } else { "done" },
                outputs.clone(),
                0.0,
            ),
        };
        let outputs: Vec<String> = outputs
            .iter()
            .map(|p| p.to_string_lossy().into_owned())
            .collect();
        // Not-finite numbers (no rate yet) become null.
        serde_json::json!({
            "state": state,
            "scene": self.inner.scene_name,
            "pass": s.pass,
            "spp": s.spp_done,
            "spp_total": s.spp_total,
            "percent": percent,
            "samples": s.samples,
            "samples_total": s.samples_total,
            "elapsed": secs,
            "samples_per_second": rate,
            "eta": eta,
            "auto_exposure": self.auto_stops(&s),
            "width": s.image.width,
            "height": s.image.height,
            "outputs": outputs,
        })
        .to_string()
    }

    /// The latest image as an 8-bit sRGB PNG seen with `look` (stops
    /// clamped to +-[`MAX_EXPOSURE`]; `auto` as the render's `--exposure
    /// auto`), and its pass number. The last encoding is cached, so several
    /// viewers cost one encode.
    pub fn png(&self, look: Look, view: View) -> Result<(u32, Arc<Vec<u8>>), Malformed> {
        let s = self.snapshot();
        let stops = self.stops_of(look.exposure, &s);
        if let Some((pass, bits, op, v, bytes)) = lock(&self.inner.png_cache).as_ref() {
            if *pass == s.pass && *bits == stops.to_bits() && *op == look.tonemap && *v == view {
                return Ok((s.pass, bytes.clone()));
            }
        }
        let bytes = Arc::new(match view {
            View::Image => encode_png(&s.image, stops, look.tonemap)?,
            View::FalseColour => {
                // The scale's colours are display values (the page's legend
                // draws them as CSS colours): undo the PNG's sRGB encoding.
                let mut zones = exposure_zones(&s.image, clamp_exposure(stops));
                for p in &mut zones.pixels {
                    *p = p.map(crate::color::srgb_decode);
                }
                crate::image::io::png::encode_scaled(&zones, 1.0, true)?
            }
        });
        *lock(&self.inner.png_cache) =
            Some((s.pass, stops.to_bits(), look.tonemap, view, bytes.clone()));
        Ok((s.pass, bytes))
    }

    /// The linear value of pixel (x, y) of the latest pass, or `None`
    /// outside the image.
    pub fn pixel(&self, x: usize, y: usize) -> Option<(u32, crate::color::Rgb)> {
        let s = self.snapshot();
        (x < s.image.width
            && y < s.image.height
            && s.image.pixels.len() == s.image.width * s.image.height)
            .then(|| (s.pass, s.image.get(x, y)))
    }

    /// The stops `auto` exposure gives the snapshot's image: computed by
    /// the server the first time a pass's value is asked for (not by the
    /// render threads), then cached.
    fn auto_stops(&self, s: &Snapshot) -> f32 {
        let mut cache = lock(&self.inner.auto_cache);
        match *cache {
            Some((pass, stops)) if pass == s.pass => stops,
            _ => {
                let stops = Exposure::Auto.stops_for(&s.image);
                *cache = Some((s.pass, stops));
                stops
            }
        }
    }

    /// The stops `exposure` means for the snapshot's image (clamped).
    fn stops_of(&self, exposure: Exposure, s: &Snapshot) -> f32 {
        match exposure {
            Exposure::Stops(x) => clamp_exposure(x),
            Exposure::Auto => clamp_exposure(self.auto_stops(s)),
        }
    }

    /// Saves the latest image as `<base>-preview-<spp>spp.exr` (linear) and
    /// `.png` (with the exposure applied, as shown), atomically. Returns the
    /// two paths and the sample count.
    pub fn save(&self, look: Look) -> Result<SavedPreview, SaveError> {
        let s = self.snapshot();
        if s.pass == 0 {
            return Err(SaveError::NothingYet);
        }
        let base = suffixed(&self.inner.base, &format!("-preview-{}spp", s.spp_done));
        let exr = with_ext(&base, "exr");
        let png = with_ext(&base, "png");
        let meta = lock(&self.inner.meta).clone();
        match (meta, &s.film) {
            (Some(meta), Some(film)) => {
                let meta = meta.progressed(s.spp_done, s.elapsed.as_secs_f64());
                save_render(&exr, &meta, film, &s.image).map_err(SaveError::Image)?
            }
            _ => save_image(&exr, &s.image).map_err(SaveError::Image)?,
        }
        save_png_tonemapped(
            &png,
            &s.image,
            self.stops_of(look.exposure, &s),
            look.tonemap,
        )
        .map_err(SaveError::Image)?;
        Ok(SavedPreview {
            exr,
            png,
            spp: s.spp_done,
        })
    }
}

/// What a "Save" wrote.
#[derive(Clone, Debug)]
pub struct SavedPreview {
    pub exr: PathBuf,
    pub png: PathBuf,
    pub spp: u32,
}

/// Why a "Save" failed.
#[derive(Debug, thiserror::Error)]
pub enum SaveError {
    #[error("no pass has finished yet")]
    NothingYet,
    #[error("{0}")]
    Image(ImageError),
}

fn clamp_exposure(e: f32) -> f32 {
    if e.is_finite() {
        e.clamp(-MAX_EXPOSURE, MAX_EXPOSURE)
    } else {
        0.0
    }
}

/// `path` with `suffix` appended to its file name.
fn suffixed(path: &Path, suffix: &str) -> PathBuf {
    let mut s = path.as_os_str().to_owned();
    s.push(suffix);
    PathBuf::from(s)
}

/// `base` + `.` + `ext` (the base may contain dots).
pub fn with_ext(base: &Path, ext: &str) -> PathBuf {
    suffixed(base, &format!(".{ext}"))
}

/// Encodes linear RGB as an 8-bit sRGB PNG after scaling by 2^`exposure`
/// and tone mapping with `op` (like the PNG the render writes). Fast
/// compression: the preview favours latency over size.
pub fn encode_png(image: &Bitmap, exposure: f32, op: Tonemap) -> Result<Vec<u8>, Malformed> {
    if image.width == 0 || image.height == 0 {
        return Err(Malformed(format!(
            "cannot encode a {}x{} image as PNG",
            image.width, image.height
        )));
    }
    if image.pixels.len() != image.width * image.height {
        return Err("pixel count does not match the image size".into());
    }
    let exposure = clamp_exposure(exposure);
    match op {
        Tonemap::Clamp => crate::image::io::png::encode_scaled(image, exposure.exp2(), true),
        _ => crate::image::io::png::encode_scaled(&tonemap(image, exposure, op), 1.0, true),
    }
}

/// Writes the image in progress to the normal output paths every so often.
pub struct Checkpointer {
    every: Duration,
    look: Look,
    meta: RenderMeta,
    last: Duration,
    exr: PathBuf,
    png: PathBuf,
}

impl Checkpointer {
    /// Checkpoints to `base.exr` and `base.png` when at least `every` has
    /// passed (in render time) since the last one (or the start); the PNG
    /// seen with `look`, the EXR a render file (continuable) with `meta`
    /// as it stands after each pass ([`RenderMeta::progressed`]).
    pub fn new(every: Duration, base: &Path, look: Look, meta: RenderMeta) -> Checkpointer {
        Checkpointer {
            every,
            look,
            meta,
            last: Duration::ZERO,
            exr: with_ext(base, "exr"),
            png: with_ext(base, "png"),
        }
    }

    /// Called after a pass: writes a checkpoint if one is due and this is
    /// not the last pass (whose image the caller writes anyway). Returns
    /// the sample count written, if any.
    pub fn after_pass(&mut self, info: &PassInfo) -> Result<Option<u32>, ImageError> {
        if info.spp_done >= info.spp_total || info.elapsed < self.last + self.every {
            return Ok(None);
        }
        self.last = info.elapsed;
        let image = info.film.to_bitmap();
        let meta = self
            .meta
            .progressed(info.spp_done, info.elapsed.as_secs_f64());
        save_render(&self.exr, &meta, info.film, &image)?;
        self.look.save_png(&self.png, &image)?;
        Ok(Some(info.spp_done))
    }

    pub fn paths(&self) -> (&Path, &Path) {
        (&self.exr, &self.png)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::color::Rgb;
    use crate::image::Film;

    fn meta() -> RenderMeta {
        RenderMeta {
            scene: "s.xml".into(),
            scene_digest: "0".into(),
            params: vec![],
            ranges: vec![crate::render_file::SampleRange {
                seed: 3,
                start: 0,
                end: 0,
            }],
            spp_target: 8,
            render_seconds: 0.0,
            version: crate::render_file::VERSION.into(),
            aovs: Default::default(),
            denoiser: None,
            box_filter: false,
        }
    }

    fn info(film: &Film, spp_done: u32, secs: f64) -> PassInfo<'_> {
        PassInfo {
            film,
            spp_done,
            spp_total: 8,
            samples: spp_done as u64 * (film.width * film.height) as u64,
            elapsed: Duration::from_secs_f64(secs),
        }
    }

    #[test]
    fn status_reports_progress_and_rate() {
        let state = PreviewState::new(4, 2, 8, Path::new("/tmp/out/scene"));
        let parse = |j: String| -> serde_json::Value { serde_json::from_str(&j).unwrap() };
        let j = parse(state.status_json());
        assert_eq!(j["state"], "rendering", "{j}");
        assert_eq!(j["pass"], 0, "{j}");
        assert!(j["samples_per_second"].is_null(), "{j}");
        assert_eq!(j["scene"], "scene", "{j}");
        let film = Film::new(4, 2);
        state.publish(&info(&film, 2, 0.5));
        let j = parse(state.status_json());
        assert_eq!(
            (j["pass"].clone(), j["spp"].clone()),
            (1.into(), 2.into()),
            "{j}"
        );
        assert_eq!(j["spp_total"], 8, "{j}");
        assert_eq!(j["percent"], 25.0, "{j}");
        assert_eq!(j["samples_per_second"], 32.0, "{j}");
        state.finish(false, vec![PathBuf::from("/tmp/a \"b\".exr")]);
        let j = parse(state.status_json());
        assert_eq!(j["state"], "done", "{j}");
        assert_eq!(j["eta"], 0.0, "{j}");
        assert_eq!(j["outputs"], serde_json::json!(["/tmp/a \"b\".exr"]), "{j}");
    }

    #[test]
    fn png_applies_exposure_and_tone_map_and_is_cached() {
        let mut img = Bitmap::new(3, 2);
        img.set(0, 0, Rgb::splat(0.25));
        img.set(1, 0, Rgb::splat(4.0));
        let clamp = Tonemap::Clamp;
        let a = encode_png(&img, 0.0, clamp).unwrap();
        let b = encode_png(&img, 2.0, clamp).unwrap();
        assert_eq!(&a[..8], b"\x89PNG\r\n\x1a\n");
        assert_ne!(a, b);
        assert!(encode_png(&Bitmap::new(0, 0), 0.0, clamp).is_err());
        // Non-finite exposure is ignored, not propagated.
        assert_eq!(encode_png(&img, f32::NAN, clamp).unwrap(), a);
        // A tone map is the render's: the same pixels as its PNG.
        let aces = encode_png(&img, 1.0, Tonemap::Aces).unwrap();
        let (decoded, _) = crate::image::io::decode_image(&aces, "png").unwrap();
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("r.png");
        save_png_tonemapped(&path, &img, 1.0, Tonemap::Aces).unwrap();
        assert_eq!(crate::image::load_image(&path).unwrap().0, decoded);

        let state = PreviewState::new(3, 2, 8, Path::new("x"));
        let look = |exposure, tonemap| Look { exposure, tonemap };
        let (pass, p1) = state
            .png(look(Exposure::Stops(1.0), clamp), View::Image)
            .unwrap();
        assert_eq!(pass, 0);
        let (_, p2) = state
            .png(look(Exposure::Stops(1.0), clamp), View::Image)
            .unwrap();
        assert!(Arc::ptr_eq(&p1, &p2));
        let (_, p3) = state
            .png(look(Exposure::Stops(1.0), Tonemap::Filmic), View::Image)
            .unwrap();
        assert!(!Arc::ptr_eq(&p1, &p3));
        let (_, p4) = state
            .png(
                look(Exposure::Stops(1.0), Tonemap::Filmic),
                View::FalseColour,
            )
            .unwrap();
        assert!(!Arc::ptr_eq(&p3, &p4), "the view is part of the cache key");
        // auto: the stops the render's --exposure auto would take.
        let mut film = Film::new(3, 2);
        let mut block =
            crate::image::FilmBlock::new(0, 0, 3, 2, crate::image::Filter::Box { radius: 0.5 });
        block.put(crate::math::Vec2::new(0.5, 0.5), Rgb::splat(0.02));
        film.merge(&block);
        state.publish(&info(&film, 1, 0.1));
        let expected = Exposure::Auto.stops_for(&film.to_bitmap());
        assert!(expected > 1.0);
        let j: serde_json::Value = serde_json::from_str(&state.status_json()).unwrap();
        assert!(
            (j["auto_exposure"].as_f64().unwrap() - expected as f64).abs() < 1e-6,
            "{j}"
        );
        let (_, auto) = state.png(look(Exposure::Auto, clamp), View::Image).unwrap();
        let (_, fixed) = state
            .png(look(Exposure::Stops(expected), clamp), View::Image)
            .unwrap();
        assert_eq!(auto, fixed);
    }

    #[test]
    fn save_needs_a_pass_and_names_files_by_spp() {
        let dir = tempfile::tempdir().unwrap();
        let state = PreviewState::new(4, 2, 8, &dir.path().join("render.v1"));
        assert!(matches!(
            state.save(Look::default()),
            Err(SaveError::NothingYet)
        ));
        let film = Film::new(4, 2);
        state.publish(&info(&film, 3, 0.1));
        let saved = state
            .save(Look {
                exposure: Exposure::Stops(1.0),
                tonemap: Tonemap::Reinhard,
            })
            .unwrap();
        assert_eq!(saved.exr, dir.path().join("render.v1-preview-3spp.exr"));
        assert_eq!(saved.png, dir.path().join("render.v1-preview-3spp.png"));
        assert!(saved.exr.exists() && saved.png.exists());
        // With the render's metadata, a save is a render file of the
        // samples so far, which --resume and merge take.
        state.set_meta(meta());
        state.publish(&info(&film, 5, 0.25));
        let saved = state.save(Look::default()).unwrap();
        let file = crate::render_file::RenderFile::load(&saved.exr).unwrap();
        assert_eq!(file.meta, meta().progressed(5, 0.25));
        assert_eq!(file.film.data(), film.data());
    }

    #[test]
    fn checkpoints_when_due_but_not_on_the_last_pass() {
        let dir = tempfile::tempdir().unwrap();
        let film = Film::new(4, 2);
        let mut c = Checkpointer::new(
            Duration::from_secs(1),
            &dir.path().join("out"),
            Look::default(),
            meta(),
        );
        assert_eq!(c.after_pass(&info(&film, 1, 0.5)).unwrap(), None);
        assert!(!dir.path().join("out.exr").exists());
        assert_eq!(c.after_pass(&info(&film, 2, 1.0)).unwrap(), Some(2));
        assert!(dir.path().join("out.exr").exists() && dir.path().join("out.png").exists());
        // The EXR is a render file of the samples so far, continuable.
        let file = crate::render_file::RenderFile::load(&dir.path().join("out.exr")).unwrap();
        assert_eq!(file.meta, meta().progressed(2, 1.0));
        assert_eq!(file.meta.spp(), 2);
        assert_eq!(c.after_pass(&info(&film, 4, 1.9)).unwrap(), None);
        assert_eq!(c.after_pass(&info(&film, 6, 2.0)).unwrap(), Some(6));
        assert_eq!(c.after_pass(&info(&film, 8, 9.0)).unwrap(), None);
        // Every pass when the interval is zero.
        let mut c = Checkpointer::new(
            Duration::ZERO,
            &dir.path().join("z"),
            Look::default(),
            meta(),
        );
        assert_eq!(c.after_pass(&info(&film, 1, 0.0)).unwrap(), Some(1));
        assert_eq!(c.after_pass(&info(&film, 2, 0.0)).unwrap(), Some(2));
    }
}
