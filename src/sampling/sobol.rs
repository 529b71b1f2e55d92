//! Owen-scrambled (0, 2) points: the stratified samplers' numbers.
//!
//! One pixel's samples at one pair of dimensions are the first two
//! dimensions of the Sobol sequence (van der Corput and its (0, 2)
//! partner), taken in a shuffled order and Owen-scrambled, both by hashes
//! on the reversed bits (Burley 2020, "Practical Hash-based Owen
//! Scrambling"). Every power-of-two prefix of a pixel's samples is then a
//! (0, m, 2)-net: one point in every elementary interval of the square,
//! and one in each of 2^m equal strata of either axis. Other pixels and
//! other dimension pairs get their own seeds, so they are decorrelated;
//! each point on its own is uniform, so any estimator stays unbiased.
//!
//! Unlike a jittered grid for a fixed count, the property holds for every
//! prefix, so progressive passes, `--samples` slices and continued
//! renders keep it.

/// A bijection of u32 in which bit j of the result depends only on bits
/// 0..=j of `x` (additions, odd multiplications and xors with even
/// multiples all carry upwards): applied to reversed bits, a nested
/// (Owen) scramble. The multipliers are Laine and Karras' (2011).
#[inline]
fn upward_hash(mut x: u32, seed: u32) -> u32 {
    x = x.wrapping_add(seed);
    x ^= x.wrapping_mul(0x6c50_b47c);
    x ^= x.wrapping_mul(0xb82f_1e52);
    x ^= x.wrapping_mul(0xc7af_e638);
    x ^= x.wrapping_mul(0x8d22_f6e6);
    x
}

/// Owen scrambling of the binary fraction `x` (bit 31 first): each bit is
/// flipped as a random function, fixed by `seed`, of the bits above it.
#[cfg(test)]
fn owen_scramble(x: u32, seed: u32) -> u32 {
    upward_hash(x.reverse_bits(), seed).reverse_bits()
}

/// The second Sobol dimension (Pascal's matrix mod 2) of `index`, as a
/// binary fraction: the first dimension is `index.reverse_bits()`.
#[cfg(test)]
fn sobol_second(index: u32) -> u32 {
    sobol_second_reversed(index).reverse_bits()
}

/// [`sobol_second`] with its bits reversed, branch-free: bit j is the
/// parity of the index bits k whose binomial C(k, j) is odd, which by
/// Lucas' theorem are those with j's bits a subset of k's (a superset
/// sum over the five bits of the position, one step per bit).
#[inline]
pub fn sobol_second_reversed(index: u32) -> u32 {
    let mut x = index;
    x ^= (x >> 1) & 0x5555_5555;
    x ^= (x >> 2) & 0x3333_3333;
    x ^= (x >> 4) & 0x0f0f_0f0f;
    x ^= (x >> 8) & 0x00ff_00ff;
    x ^ (x >> 16)
}

/// A 32-bit finaliser (Wellons' lowbias32): derives one seed from another.
#[inline]
pub fn hash32(mut x: u32) -> u32 {
    x ^= x >> 16;
    x = x.wrapping_mul(0x7feb_352d);
    x ^= x >> 15;
    x = x.wrapping_mul(0x846c_a68b);
    x ^ (x >> 16)
}

/// A binary fraction as a float in [0, 1): its top 24 bits, exactly.
#[inline]
pub fn to_unit(x: u32) -> f32 {
    (x >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// Sample `index` of the shuffled, scrambled (0, 2) sequence that `seed`
/// names, as two binary fractions; `reversed` is `index.reverse_bits()`
/// (a sampler keeps it for all its dimensions). The scrambles are written
/// on reversed bits, where they are upward hashes, so that each of the
/// three values costs one bit reversal.
#[inline]
pub fn point_2d(reversed: u32, seed: u64) -> (u32, u32) {
    let (lo, hi) = (seed as u32, (seed >> 32) as u32);
    // Shuffling by an Owen scramble of the index maps each aligned block
    // of 2^m indices onto another one: prefixes stay nets.
    let i = upward_hash(reversed, lo).reverse_bits();
    (
        // owen_scramble(i.reverse_bits(), hi)
        upward_hash(i, hi).reverse_bits(),
        // owen_scramble(sobol_second(i), ..)
        upward_hash(sobol_second_reversed(i), hash32(hi ^ 0x5bd1_e995)).reverse_bits(),
    )
}

/// Sample `index` of the shuffled, scrambled van der Corput sequence that
/// `seed` names, as a binary fraction (`reversed` as for [`point_2d`]).
#[inline]
pub fn point_1d(reversed: u32, seed: u64) -> u32 {
    let i = upward_hash(reversed, seed as u32).reverse_bits();
    upward_hash(i, (seed >> 32) as u32).reverse_bits()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The first 2^m points of a seed fall one in each elementary interval
    /// of area 2^-m (every split 2^a x 2^(m-a)), for several m and seeds.
    #[test]
    fn prefixes_are_nets() {
        for seed in [0u64, 1, 0xdead_beef_1234_5678, u64::MAX] {
            for m in [1u32, 4, 7, 10] {
                let n = 1usize << m;
                let points: Vec<(u32, u32)> = (0..n as u32)
                    .map(|i| point_2d(i.reverse_bits(), seed))
                    .collect();
                for a in 0..=m {
                    let mut seen = vec![false; n];
                    for &(x, y) in &points {
                        let cx = if a == 0 { 0 } else { (x >> (32 - a)) as usize };
                        let b = m - a;
                        let cy = if b == 0 { 0 } else { (y >> (32 - b)) as usize };
                        let cell = (cx << b) | cy;
                        assert!(
                            !seen[cell],
                            "seed {seed:x}, m {m}, split {a}: two points in a cell"
                        );
                        seen[cell] = true;
                    }
                }
                let mut seen = vec![false; n];
                for i in 0..n as u32 {
                    let x = point_1d(i.reverse_bits(), seed) >> (32 - m);
                    assert!(!seen[x as usize], "1D: two points in a stratum");
                    seen[x as usize] = true;
                }
            }
        }
    }

    /// An aligned block after the first is a net too (a pass of samples
    /// 64..128 is as well spread as the first 64).
    #[test]
    fn later_blocks_are_nets() {
        let seed = 0x0123_4567_89ab_cdef;
        let (start, m) = (64u32, 6u32);
        let mut seen = [false; 64];
        for i in start..start + (1 << m) {
            let (x, y) = point_2d(i.reverse_bits(), seed);
            let cell = ((x >> 29) << 3 | (y >> 29)) as usize;
            assert!(!seen[cell]);
            seen[cell] = true;
        }
    }

    /// The branch-free second dimension is Sobol's: the generator matrix's
    /// columns, v_0 = 1/2 and v_k = v_(k-1) xor v_(k-1) / 2, xored over
    /// the index's bits.
    #[test]
    fn second_dimension_is_sobols() {
        let by_columns = |mut index: u32| {
            let (mut v, mut x) = (1u32 << 31, 0u32);
            while index != 0 {
                if index & 1 != 0 {
                    x ^= v;
                }
                index >>= 1;
                v ^= v >> 1;
            }
            x
        };
        for i in (0..1u32 << 16).chain([u32::MAX, 0x8000_0000, 0xdead_beef]) {
            assert_eq!(sobol_second(i), by_columns(i), "{i}");
        }
    }

    /// Scrambling is a bijection that keeps a value's high bits' stratum
    /// structure: values sharing their top k bits still share them after.
    #[test]
    fn owen_scramble_is_nested() {
        for seed in [3u32, 0x9e37_79b9] {
            for x in (0..1u32 << 12).map(|i| i.wrapping_mul(0x0101_0101) ^ 0x00ff_f00f) {
                let y = x ^ 0x0000_ffff;
                // x and y agree on the top 16 bits, so their images do.
                assert_eq!(owen_scramble(x, seed) >> 16, owen_scramble(y, seed) >> 16);
            }
        }
    }
}
