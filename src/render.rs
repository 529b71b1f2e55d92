//! Tile scheduler: renders the scene on rayon's pool with deterministic
//! per-sample seeding, a progress bar, and cooperative cancellation.

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use rayon::prelude::*;

use crate::image::{Bitmap, Film, FilmBlock};
use crate::math::Vec2;
use crate::sampling::Sampler;
use crate::scene::Scene;

/// Edge length of a square tile in pixels.
pub const TILE_SIZE: u32 = 32;

/// Options for one render.
#[derive(Clone, Debug)]
pub struct RenderOptions {
    pub spp: u32,
    pub seed: u64,
    /// Show a progress bar on stderr (only drawn if stderr is a terminal).
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

/// Renders one tile with `spp` samples per pixel into a film block.
pub fn render_tile(scene: &Scene, tile: Tile, spp: u32, seed: u64) -> FilmBlock {
    let mut block = FilmBlock::new(tile.x, tile.y, tile.w, tile.h, scene.filter);
    for y in tile.y..tile.y + tile.h {
        for x in tile.x..tile.x + tile.w {
            for s in 0..spp {
                let mut sampler = Sampler::for_pixel_sample(seed, x, y, s);
                let film = Vec2::new(x as f32, y as f32) + sampler.next_2d();
                let aperture = sampler.next_2d();
                let ray = scene.camera.generate_ray(film, aperture);
                let l = scene.integrator.li(scene, &ray, &mut sampler);
                block.put(film, l);
            }
        }
    }
    block
}

/// Renders the whole image. Setting `cancel` stops the render after the
/// tiles in flight; the finished tiles are still returned.
pub fn render(scene: &Scene, opts: &RenderOptions, cancel: &AtomicBool) -> RenderOutput {
    let start = Instant::now();
    let (w, h) = (scene.camera.width(), scene.camera.height());
    let tiles = tiles(w, h);
    let bar = if opts.progress {
        let b =
            ProgressBar::with_draw_target(Some(tiles.len() as u64), ProgressDrawTarget::stderr());
        b.set_style(
            ProgressStyle::with_template(
                "{spinner} [{elapsed_precise}] [{wide_bar}] {percent}% ETA {eta}",
            )
            .expect("valid progress template"),
        );
        b
    } else {
        ProgressBar::hidden()
    };
    let done_pixels = AtomicUsize::new(0);
    let blocks: Mutex<Vec<Option<FilmBlock>>> = Mutex::new(vec![None; tiles.len()]);
    tiles.par_iter().enumerate().for_each(|(i, &tile)| {
        if cancel.load(Ordering::Relaxed) {
            return;
        }
        let block = render_tile(scene, tile, opts.spp, opts.seed);
        done_pixels.fetch_add((tile.w * tile.h) as usize, Ordering::Relaxed);
        blocks.lock().expect("no panics while holding the lock")[i] = Some(block);
        bar.inc(1);
    });
    bar.finish_and_clear();
    // Merge in tile order: the sum is then independent of scheduling.
    let mut film = Film::new(w as usize, h as usize);
    for b in blocks
        .into_inner()
        .expect("lock not poisoned")
        .iter()
        .flatten()
    {
        film.merge(b);
    }
    let pixels = done_pixels.load(Ordering::Relaxed) as u64;
    RenderOutput {
        image: film.to_bitmap(),
        spp: opts.spp,
        elapsed: start.elapsed(),
        samples: pixels * opts.spp as u64,
        cancelled: cancel.load(Ordering::Relaxed),
    }
}
