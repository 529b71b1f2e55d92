//! The independent sampler: one PCG32 stream per (seed, pixel, sample index).

use glam::Vec2;

/// PCG32 (O'Neill 2014), the generator Nori and Mitsuba use.
#[derive(Clone, Debug)]
pub struct Sampler {
    state: u64,
    inc: u64,
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
        };
        s.next_u32();
        s.state = s.state.wrapping_add(seed);
        s.next_u32();
        s
    }

    /// The generator for one pixel sample: independent of thread count and
    /// tile order, and of other seeds.
    pub fn for_pixel_sample(seed: u64, pixel_x: u32, pixel_y: u32, sample: u32) -> Sampler {
        let pixel = ((pixel_y as u64) << 32) | pixel_x as u64;
        let a = mix64(seed ^ mix64(pixel));
        let b = mix64(a ^ mix64(sample as u64 ^ 0xA5A5_5A5A_0000_0000));
        Sampler::new(a, b)
    }

    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(MULT).wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// Uniform in [0, 1).
    pub fn next_1d(&mut self) -> f32 {
        // 24 random mantissa bits: exactly representable, strictly below 1.
        (self.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }

    pub fn next_2d(&mut self) -> Vec2 {
        let x = self.next_1d();
        Vec2::new(x, self.next_1d())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
}
