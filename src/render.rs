//! Progressive tile scheduler: renders the scene in passes over the whole
//! image (each pass adds a few samples to every pixel), work units on
//! rayon's pool, with deterministic per-sample seeding, a progress
//! bar, and cooperative cancellation.
//!
//! A work unit is a tile and a slice of the pass's samples: a small image
//! has few tiles, so its passes are cut into sample slices until there are
//! at least [`MIN_UNITS`] units. Big images keep one unit per tile (and
//! the memory of one block per tile). The units of all passes wait on one
//! [`UnitQueue`], so threads never idle at the end of a pass: they go on
//! to the next one (at most [`MIN_UNITS`] units beyond the pass being
//! finished) while the calling thread merges finished passes in order.
//!
//! Determinism: sample `s` of pixel `p` always draws from the generator
//! seeded by (seed, p, s); each unit splats into its own block and blocks
//! are merged into the film in unit order (tiles in order, slices in order
//! within a tile), passes in order. The pass schedule and the units depend
//! only on the image size and the sample count, so the image is the same
//! bit for bit whatever the thread count, and whether or not anyone watches
//! the passes (live preview, checkpoints).

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use crate::aov::{AovList, MAX_AOV_CHANNELS};
use crate::color::Rgb;
use crate::image::{Bitmap, Film, FilmBlock, Filter};
use crate::integrator::{Integrator, PathBatch, PathConfig, BATCH_PATHS};
use crate::math::{Ray, Vec2, Vec3};
use crate::progress::{Progress, ProgressMode};
use crate::sampling::{PixelStreams, Sampler, SamplerKind};
use crate::scene::Scene;
use crate::unit_queue::{Take, UnitQueue};

/// Edge length of a square tile in pixels.
pub const TILE_SIZE: u32 = 32;

/// Largest number of samples per pixel in one pass.
pub const MAX_PASS_SPP: u32 = 16;

/// Work units a pass is cut into at least, where its samples allow.
pub const MIN_UNITS: usize = 256;

/// What to compute for a scene: the part of a scene file that is not the
/// world (Mitsuba's integrator, sampler and film; Nori's integrator,
/// sampler and the camera's filter).
#[derive(Clone, Debug, PartialEq)]
pub struct RenderJob {
    pub integrator: Integrator,
    /// Samples per pixel.
    pub spp: u32,
    /// How a pixel's samples are spread (independent or stratified).
    pub sampler: SamplerKind,
    /// Pixel reconstruction filter.
    pub filter: Filter,
    /// Output variables the scene asks for (Mitsuba's `aov` integrator);
    /// `render` writes them with those of `--aov`.
    pub aovs: AovList,
}

/// How to run one render of a job.
#[derive(Clone, Debug)]
pub struct RenderOptions {
    pub seed: u64,
    /// How to report progress (on stderr).
    pub progress: ProgressMode,
    /// When set, units in flight stop at their next row and are dropped
    /// (a second Ctrl-C: the passes done so far are written at once).
    pub abandon: Option<Arc<AtomicBool>>,
    /// The first sample index to take: samples `first_sample..job.spp` of
    /// every pixel are rendered (0 for a whole render).
    pub first_sample: u32,
    /// A film to add to (a render continued from its file), holding the
    /// samples before `first_sample`; `None` starts from black.
    pub film: Option<Film>,
    /// Output variables accumulated beside the image (none: no cost).
    pub aovs: AovList,
    /// Only these rows `y0..y1` of the image (a strip, for renders split
    /// across machines by memory): the film is that tall, and its pixels
    /// are bit for bit those rows of the whole render. `None`: all rows.
    pub rows: Option<(u32, u32)>,
}

impl RenderOptions {
    /// A whole render with `seed`, no progress report.
    pub fn new(seed: u64) -> RenderOptions {
        RenderOptions {
            seed,
            progress: ProgressMode::Off,
            abandon: None,
            first_sample: 0,
            film: None,
            aovs: AovList::default(),
            rows: None,
        }
    }
}

/// What a render produced.
pub struct RenderOutput {
    pub image: Bitmap,
    /// The film the image is from (with the options' film added in).
    pub film: Film,
    /// The end of the samples taken: the film holds samples
    /// `first_sample..spp` of every pixel (and those of the options' film).
    pub spp: u32,
    pub elapsed: Duration,
    /// Camera samples actually taken (fewer than planned if cancelled).
    pub samples: u64,
    pub cancelled: bool,
}

/// State after a finished pass, for live previews and checkpoints.
pub struct PassInfo<'a> {
    pub film: &'a Film,
    /// The end of the samples completed so far (as [`RenderOutput::spp`]).
    pub spp_done: u32,
    pub spp_total: u32,
    pub samples: u64,
    pub elapsed: Duration,
}

/// A rectangle of pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tile {
    pub x: u32,
    pub y: u32,
    pub w: u32,
    pub h: u32,
}

/// Tiles covering the image in row-major order.
pub fn tiles(width: u32, height: u32) -> Vec<Tile> {
    let mut v = Vec::new();
    for y in (0..height).step_by(TILE_SIZE as usize) {
        for x in (0..width).step_by(TILE_SIZE as usize) {
            v.push(Tile {
                x,
                y,
                w: TILE_SIZE.min(width - x),
                h: TILE_SIZE.min(height - y),
            });
        }
    }
    v
}

/// The sample-index ranges of the passes: 1, 1, 2, 4, 8, 16, 16, ... so
/// the first images appear at once and later passes amortise overhead.
pub fn pass_schedule(spp: u32) -> Vec<(u32, u32)> {
    let mut v = Vec::new();
    let mut start = 0;
    let mut size = 1;
    while start < spp {
        let end = (start + size).min(spp);
        v.push((start, end));
        start = end;
        if v.len() > 1 {
            size = (size * 2).min(MAX_PASS_SPP);
        }
    }
    v
}

/// The passes of samples `first..spp`: [`pass_schedule`]'s, less those
/// before `first` (a pass that straddles it is cut there). A render
/// continued from a pass boundary thus runs the very passes the whole
/// render would have: their films are the same bit for bit.
pub fn pass_schedule_from(first: u32, spp: u32) -> Vec<(u32, u32)> {
    pass_schedule(spp)
        .into_iter()
        .filter(|&(_, s1)| s1 > first)
        .map(|(s0, s1)| (s0.max(first), s1))
        .collect()
}

/// A tile and a slice of samples: what one worker renders into one block.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WorkUnit {
    pub tile: Tile,
    pub s0: u32,
    pub s1: u32,
}

/// The units of the pass over samples `s0..s1`, in merge order: every
/// tile cut into the same number of equal sample slices, as many as make
/// [`MIN_UNITS`] units (at most one slice per sample).
pub fn work_units(tiles: &[Tile], s0: u32, s1: u32) -> Vec<WorkUnit> {
    let slices = slices_per_tile(tiles.len(), (s1 - s0) as usize);
    (0..tiles.len() * slices)
        .map(|j| nth_unit(tiles, slices, (s0, s1), j))
        .collect()
}

/// How many sample slices each tile's share of a pass of `n` samples is
/// cut into, for an image of `tile_count` tiles.
fn slices_per_tile(tile_count: usize, n: usize) -> usize {
    MIN_UNITS.div_ceil(tile_count.max(1)).clamp(1, n.max(1))
}

/// Unit `j` of the pass over samples `s0..s1` whose tiles are each cut
/// into `slices` equal sample slices: slice `j % slices` of tile
/// `j / slices` (tiles in order, slices in order within a tile).
fn nth_unit(tiles: &[Tile], slices: usize, (s0, s1): (u32, u32), j: usize) -> WorkUnit {
    let (n, k) = ((s1 - s0) as usize, j % slices);
    WorkUnit {
        tile: tiles[j / slices],
        s0: s0 + (n * k / slices) as u32,
        s1: s0 + (n * (k + 1) / slices) as u32,
    }
}

/// Seeds the AOVs' random streams apart from the image's (the image is
/// then the same with or without AOVs).
const AOV_SEED_SALT: u64 = 0x5eed_a0a5_0f00_0001;

/// Renders samples `s0..s1` of every pixel of one tile into a film block
/// (with `aovs` beside the image); `None` if `abandon` was set before the
/// last row was done.
pub fn render_tile(
    scene: &Scene,
    job: &RenderJob,
    tile: Tile,
    samples: (u32, u32),
    seed: u64,
    aovs: &AovList,
    abandon: &AtomicBool,
) -> Option<FilmBlock> {
    trace_tile(scene, job, tile, samples, seed, aovs, true, abandon)
}

/// [`render_tile`], the image traced only if `image` (else its samples
/// carry zero radiance: the block holds their filter weights and the
/// AOVs).
#[allow(clippy::too_many_arguments)]
fn trace_tile(
    scene: &Scene,
    job: &RenderJob,
    tile: Tile,
    (s0, s1): (u32, u32),
    seed: u64,
    aovs: &AovList,
    image: bool,
    abandon: &AtomicBool,
) -> Option<FilmBlock> {
    let mut block =
        FilmBlock::new(tile.x, tile.y, tile.w, tile.h, job.filter).with_aovs(aovs.channel_count());
    let mut aov_values = [0.0f32; MAX_AOV_CHANNELS];
    // The path tracer's samples are traced a batch at a time, in the
    // order they are drawn, and splatted in that order.
    let mut batch = image
        .then(|| job.integrator.path_config())
        .flatten()
        .map(|cfg| (cfg, SPARE_BATCH.take()));
    for y in tile.y..tile.y + tile.h {
        if abandon.load(Ordering::Relaxed) {
            return None;
        }
        for x in tile.x..tile.x + tile.w {
            let streams = PixelStreams::new(job.sampler, seed, x, y);
            let aov_streams = (!aovs.is_empty())
                .then(|| PixelStreams::new(SamplerKind::Independent, seed ^ AOV_SEED_SALT, x, y));
            for s in s0..s1 {
                let mut sampler = streams.sampler(s);
                let film = Vec2::new(x as f32, y as f32) + sampler.next_2d();
                let aperture = sampler.next_2d();
                if let (Some((cfg, batch)), None) = (&mut batch, &aov_streams) {
                    // The batch makes its camera rays together.
                    batch.push(film, aperture, sampler);
                    if batch.is_full() {
                        batch.trace_and_splat(scene, cfg, &mut block);
                    }
                    continue;
                }
                let ray = scene.camera.generate_ray(film, aperture);
                if let Some(aov_streams) = &aov_streams {
                    let mut aov_sampler = aov_streams.sampler(s);
                    aovs.evaluate(scene, &ray, &mut aov_sampler, &mut aov_values);
                }
                if let Some((cfg, batch)) = &mut batch {
                    batch.push_traced_for_aovs(film, sampler, ray, &aov_values);
                    if batch.is_full() {
                        batch.trace_and_splat(scene, cfg, &mut block);
                    }
                    continue;
                }
                let l = if image {
                    job.integrator.li(scene, &ray, &mut sampler)
                } else {
                    Rgb::ZERO
                };
                block.put(film, l);
                if aov_streams.is_some() {
                    block.put_aovs(film, &aov_values);
                }
            }
        }
    }
    if let Some((cfg, mut batch)) = batch {
        batch.trace_and_splat(scene, &cfg, &mut block);
        SPARE_BATCH.set(batch);
    }
    Some(block)
}

thread_local! {
    /// The thread's [`SampleBatch`] between render units: its buffers
    /// (about 130 KB for 256 paths) are allocated, grown and zeroed once
    /// per thread rather than once per unit. It is emptied after every
    /// batch, so what a unit traces does not depend on the units before.
    static SPARE_BATCH: std::cell::Cell<SampleBatch> = std::cell::Cell::new(SampleBatch::default());
}

/// Camera samples of a render unit waiting to be traced together
/// ([`PathBatch`]): kept in the order they were drawn, in which they are
/// splatted, so that the block is the same bit for bit as when each
/// sample is traced as it is drawn. The buffers outlive the unit: each
/// thread keeps one batch (`SPARE_BATCH`).
#[derive(Default)]
struct SampleBatch {
    films: Vec<Vec2>,
    apertures: Vec<Vec2>,
    rays: Vec<Ray>,
    samplers: Vec<Sampler>,
    /// Each sample's AOV values (when the block has AOVs).
    aovs: Vec<[f32; MAX_AOV_CHANNELS]>,
    radiance: Vec<Rgb>,
    paths: PathBatch,
}

impl SampleBatch {
    /// A sample: its film position, its aperture sample (its camera ray
    /// is made with the batch's, [`crate::camera::Camera::generate_rays`])
    /// and its sampler.
    fn push(&mut self, film: Vec2, aperture: Vec2, sampler: Sampler) {
        debug_assert!(
            self.rays.is_empty(),
            "a batch's samples all come with rays or none"
        );
        self.films.push(film);
        self.apertures.push(aperture);
        self.samplers.push(sampler);
    }

    /// A sample of a block with AOVs: its film position, its sampler, the
    /// camera ray its AOVs were evaluated on, which the batch traces
    /// rather than make it again (`generate_rays` makes the same rays bit
    /// for bit), and its AOV values.
    fn push_traced_for_aovs(
        &mut self,
        film: Vec2,
        sampler: Sampler,
        ray: Ray,
        aovs: &[f32; MAX_AOV_CHANNELS],
    ) {
        debug_assert!(self.rays.len() == self.films.len());
        self.films.push(film);
        self.samplers.push(sampler);
        self.rays.push(ray);
        self.aovs.push(*aovs);
    }

    fn is_full(&self) -> bool {
        self.films.len() >= BATCH_PATHS
    }

    /// Traces the waiting samples' paths and splats them into `block`.
    fn trace_and_splat(&mut self, scene: &Scene, cfg: &PathConfig, block: &mut FilmBlock) {
        let n = self.films.len();
        if self.rays.len() != n {
            // Samples without AOVs come without rays: made here together.
            self.rays.resize(n, Ray::new(Vec3::ZERO, Vec3::Z));
            (scene.camera).generate_rays(&self.films, &self.apertures, &mut self.rays);
        }
        self.radiance.clear();
        self.radiance.resize(n, Rgb::ZERO);
        (self.paths).radiance(
            scene,
            cfg,
            &self.rays,
            &mut self.samplers,
            &mut self.radiance,
        );
        // The image and the AOVs are separate sums: splatting all of one,
        // then all of the other, adds what sample-by-sample adds.
        block.put_all(&self.films, &self.radiance);
        for (&film, aovs) in self.films.iter().zip(&self.aovs) {
            block.put_aovs(film, aovs);
        }
        self.films.clear();
        self.apertures.clear();
        self.rays.clear();
        self.samplers.clear();
        self.aovs.clear();
    }
}

/// The AOVs of samples `s0..s1` of every pixel, as a CPU render draws
/// them (the same random streams and film positions), in a film whose
/// image holds only the samples' filter weights: what the GPU backend
/// adds to its image. Tiles run on rayon's pool and merge in a fixed
/// order; `None` if `abandon` was set.
pub fn render_aovs(
    scene: &Scene,
    job: &RenderJob,
    samples: (u32, u32),
    seed: u64,
    aovs: &AovList,
    abandon: &AtomicBool,
) -> Option<Film> {
    use rayon::prelude::*;
    let (w, h) = (scene.camera.width(), scene.camera.height());
    let blocks = (tiles(w, h).into_par_iter())
        .map(|tile| trace_tile(scene, job, tile, samples, seed, aovs, false, abandon))
        .collect::<Option<Vec<_>>>()?;
    let mut film = Film::new(w as usize, h as usize).with_aovs(aovs.channel_count());
    for block in &blocks {
        film.merge(block);
    }
    Some(film)
}

/// Peak memory of a render per image pixel, an upper estimate: the film
/// (16 bytes) and a pass's blocks (16 and their filter margins, plus at
/// most [`MIN_UNITS`] blocks of the next pass: a constant) while
/// rendering; the film, the final bitmap (12) and the PNG's 8-bit copy (3)
/// while writing (both files are encoded straight from the film and the
/// bitmap into the file). Measured: 37.1 bytes (peak RSS of an 8000x8000
/// render at 1 spp, the showcase scene included).
pub const PEAK_BYTES_PER_PIXEL: u64 = 40;

/// Checks that a `width` x `height` render fits in `available` bytes of
/// memory (the machine's, where known: [`crate::limits::available_memory`]).
pub fn check_memory(width: u32, height: u32, available: Option<u64>) -> Result<(), String> {
    let needed = width as u64 * height as u64 * PEAK_BYTES_PER_PIXEL;
    match available {
        Some(free) if needed > free => Err(format!(
            "a {width}x{height} image needs about {:.1} GiB for the film and its outputs, \
             more than the {:.1} GiB of memory available",
            needed as f64 / (1u64 << 30) as f64,
            free as f64 / (1u64 << 30) as f64
        )),
        _ => Ok(()),
    }
}

/// Renders the whole image. Setting `cancel` stops the render after the
/// tiles in flight; the image holds the passes completed before (a pass
/// cut short is dropped, so every pixel has the same samples).
pub fn render(
    scene: &Scene,
    job: &RenderJob,
    opts: &RenderOptions,
    cancel: &AtomicBool,
) -> RenderOutput {
    render_with_passes(scene, job, opts, cancel, |_| {})
}

/// Like [`render`], calling `on_pass` after every completed pass.
pub fn render_with_passes(
    scene: &Scene,
    job: &RenderJob,
    opts: &RenderOptions,
    cancel: &AtomicBool,
    mut on_pass: impl FnMut(&PassInfo),
) -> RenderOutput {
    let start = Instant::now();
    let (w, h) = (scene.camera.width(), scene.camera.height());
    let tiles = tiles(w, h);
    // A strip: the film holds rows r0..r1, and the units are those of the
    // whole render (same tiles, slices and order, so each pixel sums the
    // same blocks in the same order) whose samples can reach those rows.
    let (r0, r1) = match opts.rows {
        Some((a, b)) => (a.min(h), b.min(h).max(a.min(h))),
        None => (0, h),
    };
    let reach = job.filter.radius().ceil() as u32 + 1;
    let reaches = |t: &Tile| t.y < r1 + reach && t.y + t.h + reach > r0;
    let film_h = (r1 - r0) as usize;
    let never = AtomicBool::new(false);
    let abandon = opts.abandon.as_deref().unwrap_or(&never);
    let first = opts.first_sample.min(job.spp);
    let passes = pass_schedule_from(first, job.spp);
    let progress = Progress::new(
        opts.progress,
        w as u64 * film_h as u64,
        job.spp - first,
        passes.len(),
    );
    let samples = AtomicU64::new(0);
    let aov_channels = opts.aovs.channel_count();
    let mut film = match &opts.film {
        Some(f)
            if (f.width, f.height) == (w as usize, film_h) && f.aov_channels() == aov_channels =>
        {
            f.clone()
        }
        _ => Film::new(w as usize, film_h).with_aovs(aov_channels),
    };
    // Every pass's units, in merge order, on one queue: threads go on to
    // the next pass while the last units of one finish. This thread merges
    // the passes in order and renders units while it waits.
    // A pass's units are [`work_units`]' (sliced as for the whole image),
    // less those of tiles that do not reach the strip.
    let reached: Vec<Tile> = tiles
        .iter()
        .copied()
        .filter(|t| opts.rows.is_none() || reaches(t))
        .collect();
    let slices: Vec<usize> = passes
        .iter()
        .map(|&(s0, s1)| slices_per_tile(tiles.len(), (s1 - s0) as usize))
        .collect();
    let queue = UnitQueue::new(slices.iter().map(|k| k * reached.len()), MIN_UNITS);
    let unit_at = |i: usize| {
        let (pass, j) = queue.locate(i);
        nth_unit(&reached, slices[pass], passes[pass], j)
    };
    let stop = || cancel.load(Ordering::Relaxed) || abandon.load(Ordering::Relaxed);
    let render_unit = |i: usize| {
        let WorkUnit { tile, s0, s1 } = unit_at(i);
        let block = render_tile(scene, job, tile, (s0, s1), opts.seed, &opts.aovs, abandon);
        if block.is_some() {
            let n = (tile.w * tile.h) as u64 * (s1 - s0) as u64;
            samples.fetch_add(n, Ordering::Relaxed);
            progress.add(n);
        }
        queue.finish(i, block);
    };
    let mut spp_done = first;
    rayon::in_place_scope(|scope| {
        for _ in 1..rayon::current_num_threads() {
            scope.spawn(|_| {
                while let Some(i) = queue.claim(stop) {
                    render_unit(i);
                }
            });
        }
        for (pass, &(_, s1)) in passes.iter().enumerate() {
            progress.start_pass(pass);
            let blocks = loop {
                match queue.try_take() {
                    Take::Pass(blocks) => break Some(blocks),
                    Take::Never => break None,
                    Take::Pending => match queue.try_claim(stop) {
                        Some(i) => render_unit(i),
                        None => queue.wait(),
                    },
                }
            };
            // A pass cut short is dropped whole: the film then holds
            // samples 0..spp_done of every pixel, no more (so it can be
            // continued).
            let Some(blocks) = blocks else { break };
            // Merge in unit order: the sum is then independent of
            // scheduling.
            for mut b in blocks {
                b.y0 -= r0 as i32;
                film.merge(&b);
            }
            spp_done = s1;
            on_pass(&PassInfo {
                film: &film,
                spp_done,
                spp_total: job.spp,
                samples: samples.load(Ordering::Relaxed),
                elapsed: start.elapsed(),
            });
        }
    });
    progress.finish();
    RenderOutput {
        image: film.to_bitmap(),
        film,
        spp: spp_done,
        elapsed: start.elapsed(),
        samples: samples.load(Ordering::Relaxed),
        cancelled: cancel.load(Ordering::Relaxed),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn memory_check_names_the_resolution_and_the_memory() {
        assert!(check_memory(1920, 1080, Some(1 << 30)).is_ok());
        assert!(check_memory(1920, 1080, None).is_ok());
        let err = check_memory(16384, 16384, Some(8 << 30)).unwrap_err();
        assert!(
            err.contains("16384x16384") && err.contains("10.0 GiB"),
            "{err}"
        );
        assert!(err.contains("8.0 GiB"), "{err}");
    }

    #[test]
    fn a_continued_schedule_is_the_tail_of_the_whole_one() {
        let whole = pass_schedule(100);
        for &(_, boundary) in &whole {
            let tail = pass_schedule_from(boundary, 100);
            assert_eq!(tail[..], whole[whole.len() - tail.len()..]);
        }
        assert_eq!(pass_schedule_from(5, 9), [(5, 8), (8, 9)]);
        assert!(pass_schedule_from(9, 9).is_empty());
    }

    #[test]
    fn passes_cover_every_sample_once() {
        for spp in [1, 2, 3, 17, 100, 4096] {
            let p = pass_schedule(spp);
            assert_eq!(p[0].0, 0);
            assert_eq!(p.last().unwrap().1, spp);
            for w in p.windows(2) {
                assert_eq!(w[0].1, w[1].0);
            }
            assert!(p.iter().all(|&(a, b)| b > a && b - a <= MAX_PASS_SPP));
        }
    }

    #[test]
    fn units_cover_every_pixel_sample_once_and_fill_small_images() {
        for (w, h) in [(160, 120), (1, 1), (2400, 1800), (33, 700)] {
            let t = tiles(w, h);
            for (s0, s1) in pass_schedule(100) {
                let units = work_units(&t, s0, s1);
                // Per tile, the slices run s0..s1 in order without gaps.
                for tile_units in units.chunks(units.len() / t.len()) {
                    assert_eq!(tile_units[0].s0, s0);
                    assert_eq!(tile_units.last().unwrap().s1, s1);
                    assert!(tile_units.windows(2).all(|p| p[0].s1 == p[1].s0));
                    assert!(tile_units
                        .iter()
                        .all(|u| u.s1 > u.s0 && u.tile == tile_units[0].tile));
                }
                let samples: u64 = units
                    .iter()
                    .map(|u| (u.tile.w * u.tile.h) as u64 * (u.s1 - u.s0) as u64)
                    .sum();
                assert_eq!(samples, w as u64 * h as u64 * (s1 - s0) as u64);
                let n = (s1 - s0) as usize;
                assert!(
                    units.len() >= MIN_UNITS.min(t.len() * n),
                    "{w}x{h} {s0}..{s1}"
                );
                // Big images keep one block per tile.
                if t.len() >= MIN_UNITS {
                    assert_eq!(units.len(), t.len());
                }
            }
        }
    }
}
