//! Progressive tile scheduler: renders the scene in passes over the whole
//! image (each pass adds a few samples to every pixel), tiles of a pass on
//! rayon's pool, with deterministic per-sample seeding, a progress bar, and
//! cooperative cancellation.
//!
//! Determinism: sample `s` of pixel `p` always draws from the generator
//! seeded by (seed, p, s); within a pass each tile splats into its own block
//! and blocks are merged into the film in tile order, passes in order. The
//! pass schedule depends only on the sample count, so the image is the same
//! bit for bit whatever the thread count, and whether or not anyone watches
//! the passes (live preview, checkpoints).

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use rayon::prelude::*;

use crate::image::{Bitmap, Film, FilmBlock, Filter};
use crate::integrator::Integrator;
use crate::math::Vec2;
use crate::sampling::Sampler;
use crate::scene::Scene;

/// Edge length of a square tile in pixels.
pub const TILE_SIZE: u32 = 32;

/// Largest number of samples per pixel in one pass.
pub const MAX_PASS_SPP: u32 = 16;

/// What to compute for a scene: the part of a scene file that is not the
/// world (Mitsuba's integrator, sampler and film; Nori's integrator,
/// sampler and the camera's filter).
#[derive(Clone, Debug, PartialEq)]
pub struct RenderJob {
    pub integrator: Integrator,
    /// Samples per pixel.
    pub spp: u32,
    /// Pixel reconstruction filter.
    pub filter: Filter,
}

/// How to run one render of a job.
#[derive(Clone, Debug)]
pub struct RenderOptions {
    pub seed: u64,
    /// Show a progress bar on stderr.
    pub progress: bool,
}

/// What a render produced.
pub struct RenderOutput {
    pub image: Bitmap,
    pub spp: u32,
    pub elapsed: Duration,
    /// Camera samples actually taken (fewer than planned if cancelled).
    pub samples: u64,
    pub cancelled: bool,
}

/// State after a finished pass, for live previews and checkpoints.
pub struct PassInfo<'a> {
    pub film: &'a Film,
    /// Samples per pixel completed so far.
    pub spp_done: u32,
    pub spp_total: u32,
    pub samples: u64,
    pub elapsed: Duration,
}

/// A rectangle of pixels.
#[derive(Clone, Copy, Debug)]
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

/// Renders samples `s0..s1` of every pixel of one tile into a film block.
pub fn render_tile(
    scene: &Scene,
    job: &RenderJob,
    tile: Tile,
    s0: u32,
    s1: u32,
    seed: u64,
) -> FilmBlock {
    let mut block = FilmBlock::new(tile.x, tile.y, tile.w, tile.h, job.filter);
    for y in tile.y..tile.y + tile.h {
        for x in tile.x..tile.x + tile.w {
            for s in s0..s1 {
                let mut sampler = Sampler::for_pixel_sample(seed, x, y, s);
                let film = Vec2::new(x as f32, y as f32) + sampler.next_2d();
                let aperture = sampler.next_2d();
                let ray = scene.camera.generate_ray(film, aperture);
                let l = job.integrator.li(scene, &ray, &mut sampler);
                block.put(film, l);
            }
        }
    }
    block
}

fn progress_bar(show: bool, total: u64) -> ProgressBar {
    if !show {
        return ProgressBar::hidden();
    }
    let b = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr());
    b.set_style(
        ProgressStyle::with_template(
            "{spinner} [{elapsed_precise}] [{wide_bar}] {percent}% ({per_sec} samples) ETA {eta}",
        )
        .expect("valid progress template"),
    );
    b
}

/// Renders the whole image. Setting `cancel` stops the render after the
/// tiles in flight; everything finished is still in the image.
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
    let total = w as u64 * h as u64 * job.spp as u64;
    let bar = progress_bar(opts.progress, total);
    let samples = AtomicU64::new(0);
    let mut film = Film::new(w as usize, h as usize);
    let mut spp_done = 0;
    for (s0, s1) in pass_schedule(job.spp) {
        if cancel.load(Ordering::Relaxed) {
            break;
        }
        let blocks: Mutex<Vec<Option<FilmBlock>>> = Mutex::new(vec![None; tiles.len()]);
        tiles.par_iter().enumerate().for_each(|(i, &tile)| {
            if cancel.load(Ordering::Relaxed) {
                return;
            }
            let block = render_tile(scene, job, tile, s0, s1, opts.seed);
            let n = (tile.w * tile.h) as u64 * (s1 - s0) as u64;
            samples.fetch_add(n, Ordering::Relaxed);
            blocks.lock().expect("no panics while holding the lock")[i] = Some(block);
            bar.inc(n);
        });
        // Merge in tile order: the sum is then independent of scheduling.
        for b in blocks
            .into_inner()
            .expect("lock not poisoned")
            .iter()
            .flatten()
        {
            film.merge(b);
        }
        if cancel.load(Ordering::Relaxed) {
            break;
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
    bar.finish_and_clear();
    RenderOutput {
        image: film.to_bitmap(),
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
}
