//! The samplers: one PCG32 stream per (seed, pixel, sample index), and,
//! for Mitsuba's stratified samplers, Owen-scrambled (0, 2) points in the
//! first dimensions of each sample (`sobol.rs`).

use super::sobol::{point_1d, point_2d, to_unit};
use glam::Vec2;

/// How a pixel's samples are spread over the first dimensions.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SamplerKind {
    /// Every number independent (Mitsuba's and Nori's `independent`).
    #[default]
    Independent,
    /// The first [`STRATIFIED_DIMENSIONS`] numbers of every sample from
    /// Owen-scrambled (0, 2) sequences, one per pixel and per call
    /// (Mitsuba's `stratified`, `multijitter`, `ldsampler`, `orthogonal`):
    /// the camera's film and lens positions and the first bounces' light
    /// and BSDF samples are stratified across a pixel's samples; later
    /// numbers are independent.
    Stratified,
}

/// How many dimensions of a sample [`SamplerKind::Stratified`] draws from
/// scrambled sequences: the film and lens (4), then about two bounces'
/// light choice, light sample, BSDF sample and lobe (6 each) and their
/// roulette draws. Later dimensions are used differently by different
/// paths, where stratification no longer pays for its hashing.
pub const STRATIFIED_DIMENSIONS: u32 = 16;

/// PCG32 (O'Neill 2014), the generator Nori and Mitsuba use, with the
/// state of a stratified sample's scrambled dimensions.
#[derive(Clone, Debug)]
pub struct Sampler {
    state: u64,
    inc: u64,
    /// The sample's index within its pixel, bits reversed (stratified
    /// sampling).
    reversed_index: u32,
    /// The next dimension; scrambled points are drawn while it is below
    /// `scrambled`, which is 0 for independent sampling.
    dim: u32,
    scrambled: u32,
    /// The pixel's seed of its scrambled sequences.
    pixel_seed: u64,
}

const MULT: u64 = 6364136223846793005;

/// SplitMix64 finaliser: decorrelates nearby seeds (and scatters indices).
pub fn mix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E3779B97F4A7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58476D1CE4E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D049BB133111EB);
    z ^ (z >> 31)
}

impl Sampler {
    /// A generator from a 64-bit state seed and a stream selector.
    pub fn new(seed: u64, stream: u64) -> Sampler {
        let mut s = Sampler {
            state: 0,
            inc: (stream << 1) | 1,
            reversed_index: 0,
            dim: 0,
            scrambled: 0,
            pixel_seed: 0,
        };
        s.next_u32();
        s.state = s.state.wrapping_add(seed);
        s.next_u32();
        s
    }

    /// The generator for one pixel sample: independent of thread count and
    /// tile order, and of other seeds.
    pub fn for_pixel_sample(seed: u64, pixel_x: u32, pixel_y: u32, sample: u32) -> Sampler {
        PixelStreams::new(SamplerKind::Independent, seed, pixel_x, pixel_y).sampler(sample)
    }

    /// The generator for one pixel sample of a `kind` sampler: the
    /// independent one's stream, and for a stratified one the pixel's
    /// scrambled sequences at index `sample`.
    pub fn for_pixel_sample_of(
        kind: SamplerKind,
        seed: u64,
        pixel_x: u32,
        pixel_y: u32,
        sample: u32,
    ) -> Sampler {
        PixelStreams::new(kind, seed, pixel_x, pixel_y).sampler(sample)
    }

    /// The seed of the scrambled sequence of the current dimension.
    #[inline]
    fn dimension_seed(&self) -> u64 {
        mix64(self.pixel_seed ^ (self.dim as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15))
    }

    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(MULT).wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// Uniform in [0, 1). Inlined: the independent sampler's path is a
    /// few instructions (a call cost as much), the stratified dimensions
    /// are out of line.
    #[inline]
    pub fn next_1d(&mut self) -> f32 {
        if self.dim < self.scrambled {
            return self.scrambled_1d();
        }
        // 24 random mantissa bits: exactly representable, strictly below 1.
        to_unit(self.next_u32())
    }

    /// Two uniform numbers in [0, 1) (see [`Sampler::next_1d`]).
    #[inline]
    pub fn next_2d(&mut self) -> Vec2 {
        if self.dim < self.scrambled {
            return self.scrambled_2d();
        }
        let x = to_unit(self.next_u32());
        Vec2::new(x, to_unit(self.next_u32()))
    }

    /// [`Sampler::next_1d`] in a stratified dimension.
    #[inline(never)]
    fn scrambled_1d(&mut self) -> f32 {
        let seed = self.dimension_seed();
        self.dim += 1;
        to_unit(point_1d(self.reversed_index, seed))
    }

    /// [`Sampler::next_2d`] from a stratified dimension: a 2D point of the
    /// sequence, or, from the last stratified dimension, its 1D point and
    /// an independent number.
    #[inline(never)]
    fn scrambled_2d(&mut self) -> Vec2 {
        if self.dim + 1 < self.scrambled {
            let seed = self.dimension_seed();
            self.dim += 2;
            let (x, y) = point_2d(self.reversed_index, seed);
            return Vec2::new(to_unit(x), to_unit(y));
        }
        let x = self.next_1d();
        Vec2::new(x, self.next_1d())
    }
}

/// The part of a pixel's samplers that depends on the pixel only, made
/// once for all of its samples (two to five fewer hashes per sample).
#[derive(Clone, Copy, Debug)]
pub struct PixelStreams {
    /// The state seed of every sample's generator.
    seed: u64,
    /// Stratified only: the pixel's seed of its scrambled sequences.
    pixel_seed: Option<u64>,
}

impl PixelStreams {
    /// Pixel (`pixel_x`, `pixel_y`)'s streams of a `kind` sampler under `seed`.
    pub fn new(kind: SamplerKind, seed: u64, pixel_x: u32, pixel_y: u32) -> PixelStreams {
        let pixel = ((pixel_y as u64) << 32) | pixel_x as u64;
        let pixel_hash = mix64(pixel);
        PixelStreams {
            seed: mix64(seed ^ pixel_hash),
            pixel_seed: (kind == SamplerKind::Stratified)
                .then(|| mix64(mix64(seed ^ 0x57a7_1f1e_d5ee_d000) ^ pixel_hash)),
        }
    }

    /// The generator of sample `sample` of the pixel: what
    /// [`Sampler::for_pixel_sample_of`] returns.
    #[inline]
    pub fn sampler(&self, sample: u32) -> Sampler {
        let stream = mix64(self.seed ^ mix64(sample as u64 ^ 0xA5A5_5A5A_0000_0000));
        let mut s = Sampler::new(self.seed, stream);
        if let Some(pixel_seed) = self.pixel_seed {
            s.pixel_seed = pixel_seed;
            s.reversed_index = sample.reverse_bits();
            s.scrambled = STRATIFIED_DIMENSIONS;
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The streams as they were defined before `PixelStreams` split them:
    /// renders of a seed must not change.
    fn reference(kind: SamplerKind, seed: u64, x: u32, y: u32, sample: u32) -> Sampler {
        let pixel = ((y as u64) << 32) | x as u64;
        let a = mix64(seed ^ mix64(pixel));
        let b = mix64(a ^ mix64(sample as u64 ^ 0xA5A5_5A5A_0000_0000));
        let mut s = Sampler::new(a, b);
        if kind == SamplerKind::Stratified {
            s.pixel_seed = mix64(mix64(seed ^ 0x57a7_1f1e_d5ee_d000) ^ mix64(pixel));
            s.reversed_index = sample.reverse_bits();
            s.scrambled = STRATIFIED_DIMENSIONS;
        }
        s
    }

    /// `next_1d` and `next_2d` as they were defined before the stratified
    /// dimensions went out of line.
    fn reference_1d(s: &mut Sampler) -> f32 {
        if s.dim < s.scrambled {
            let seed = s.dimension_seed();
            s.dim += 1;
            return to_unit(point_1d(s.reversed_index, seed));
        }
        to_unit(s.next_u32())
    }

    fn reference_2d(s: &mut Sampler) -> Vec2 {
        if s.dim + 1 < s.scrambled {
            let seed = s.dimension_seed();
            s.dim += 2;
            let (x, y) = point_2d(s.reversed_index, seed);
            return Vec2::new(to_unit(x), to_unit(y));
        }
        let x = reference_1d(s);
        Vec2::new(x, reference_1d(s))
    }

    #[test]
    fn pixel_streams_give_the_defined_numbers() {
        for kind in [SamplerKind::Independent, SamplerKind::Stratified] {
            for (seed, x, y) in [(0u64, 0u32, 0u32), (7, 3, 4), (u64::MAX, 4095, 17)] {
                let streams = PixelStreams::new(kind, seed, x, y);
                for (sample, one_d) in [0u32, 1, 5, 1000].into_iter().zip([0, 1, 2, 1]) {
                    let mut got = streams.sampler(sample);
                    let mut want = reference(kind, seed, x, y, sample);
                    // 1D and 2D draws across the stratified dimensions'
                    // end: every third draw 1D, at offset `one_d`; offsets
                    // 1 and 2 put a 2D draw across it, offset 0 a 1D one
                    // (checked below).
                    let mut straddled = false;
                    for k in 0..40 {
                        if k % 3 == one_d {
                            assert_eq!(got.next_1d(), reference_1d(&mut want), "{kind:?} {k}");
                        } else {
                            straddled |= got.dim + 1 == got.scrambled;
                            assert_eq!(got.next_2d(), reference_2d(&mut want), "{kind:?} {k}");
                        }
                    }
                    let expected = kind == SamplerKind::Stratified && one_d != 0;
                    assert_eq!(straddled, expected, "{kind:?} offset {one_d}");
                }
            }
        }
    }

    #[test]
    fn uniform_in_unit_interval_and_deterministic() {
        let mut a = Sampler::for_pixel_sample(7, 3, 4, 5);
        let mut b = Sampler::for_pixel_sample(7, 3, 4, 5);
        let mut sum = 0.0f64;
        for _ in 0..100_000 {
            let x = a.next_1d();
            assert_eq!(x, b.next_1d());
            assert!((0.0..1.0).contains(&x));
            sum += x as f64;
        }
        assert!((sum / 100_000.0 - 0.5).abs() < 0.005);
    }

    #[test]
    fn different_seeds_differ() {
        let mut a = Sampler::for_pixel_sample(1, 0, 0, 0);
        let mut b = Sampler::for_pixel_sample(2, 0, 0, 0);
        let same = (0..64).filter(|_| a.next_u32() == b.next_u32()).count();
        assert!(same < 2);
    }

    /// Stratified samples: each number is uniform over the square and the
    /// pairs of numbers drawn by different calls are independent of each
    /// other (chi-square over 16 x 16 cells, one sample of each of 65,536
    /// pixels at a few sample indices); past the scrambled dimensions the
    /// numbers still are. Pairs tested: a 2D call's two coordinates, two
    /// calls' first coordinates, a 1D call against a 2D call's second, and
    /// two numbers beyond `STRATIFIED_DIMENSIONS`.
    #[test]
    fn stratified_numbers_are_uniform_and_independent_across_calls() {
        use crate::stats::{chi2_test, sidak};
        let pairs = 4;
        let alpha = sidak(0.01, pairs * 3);
        for index in [0u32, 5, 1000] {
            let mut counts = vec![vec![0.0f64; 256]; pairs];
            for p in 0..65_536u32 {
                let mut s = Sampler::for_pixel_sample_of(
                    SamplerKind::Stratified,
                    9,
                    p % 256,
                    p / 256,
                    index,
                );
                let film = s.next_2d();
                let lens = s.next_2d();
                let choice = s.next_1d();
                let light = s.next_2d();
                for _ in 7..STRATIFIED_DIMENSIONS + 3 {
                    s.next_1d();
                }
                let (late_a, late_b) = (s.next_1d(), s.next_1d());
                let cell = |x: f32, y: f32| (x * 16.0) as usize * 16 + (y * 16.0) as usize;
                counts[0][cell(film.x, film.y)] += 1.0;
                counts[1][cell(film.x, lens.x)] += 1.0;
                counts[2][cell(choice, light.y)] += 1.0;
                counts[3][cell(late_a, late_b)] += 1.0;
            }
            let expected = vec![65_536.0 / 256.0; 256];
            for (k, c) in counts.iter().enumerate() {
                let r = chi2_test(c, &expected, 5.0);
                assert!(
                    r.passes(alpha),
                    "index {index}, pair {k}: p = {}",
                    r.p_value
                );
            }
        }
    }

    /// One pixel's first 64 stratified samples put one film position in
    /// each of the 8 x 8 strata of the pixel, and their light numbers one
    /// in each of 64 strata of [0, 1); independent samples do not (the
    /// control: the test can fail).
    #[test]
    fn stratified_pixels_are_stratified() {
        let spread = |kind: SamplerKind| {
            let (mut cells, mut strata) = ([0u32; 64], [0u32; 64]);
            for i in 0..64 {
                let mut s = Sampler::for_pixel_sample_of(kind, 4, 17, 3, i);
                let film = s.next_2d();
                s.next_2d();
                let choice = s.next_1d();
                cells[(film.x * 8.0) as usize * 8 + (film.y * 8.0) as usize] += 1;
                strata[(choice * 64.0) as usize] += 1;
            }
            cells.iter().chain(&strata).all(|&c| c == 1)
        };
        assert!(spread(SamplerKind::Stratified));
        assert!(!spread(SamplerKind::Independent));
    }

    /// An independent kind draws exactly the stream `for_pixel_sample` does.
    #[test]
    fn independent_kind_is_the_plain_stream() {
        let mut a = Sampler::for_pixel_sample_of(SamplerKind::Independent, 7, 1, 2, 3);
        let mut b = Sampler::for_pixel_sample(7, 1, 2, 3);
        for _ in 0..40 {
            assert_eq!(a.next_2d(), b.next_2d());
        }
    }
}
