//! The Nori forks' checkerboards, which differ from Mitsuba's in their
//! parameters and in how a square is found:
//!
//! - ETH Zurich's `checkerboard_color` / `checkerboard_float`
//!   (`src/checkerboard.cpp` of the course's framework): square
//!   (|floor(u / scale.x - delta.x)|, |floor(v / scale.y - delta.y)|),
//!   `value1` where the two parities agree, `value2` where they differ
//!   (the course's reference images; the checkerboard is the students'
//!   code, and some swap the two).
//! - The Universidad de Zaragoza fork's `checker` (`src/texture.cpp`):
//!   square (int(u scalex), int(v scaley)) with C's truncating cast, the
//!   first colour where the C remainders `% 2` agree (so the squares on
//!   either side of u = 0 are one double-width square, and the remainder
//!   keeps its sign for negative uv).

use super::bounded;
use crate::color::Rgb;
use crate::math::Vec2;

/// Which fork's rule finds the square.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CheckerRule {
    /// Floor, then the parity of the absolute value.
    Eth,
    /// Truncation toward zero, then the signed remainder.
    Zaragoza,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NoriChecker {
    /// Square coordinates are `uv * scale + offset` (ETH: scale 1 / its
    /// `scale`, offset -`delta`; Zaragoza: `scalex`, `scaley`, no offset).
    pub scale: Vec2,
    pub offset: Vec2,
    pub rule: CheckerRule,
    /// The value where the two square indices have the same key.
    pub same: Rgb,
    /// The value where they differ.
    pub differ: Rgb,
}

impl NoriChecker {
    #[inline]
    fn key(&self, x: f32) -> i64 {
        let x = bounded(x);
        match self.rule {
            CheckerRule::Eth => (x.floor() as i64).rem_euclid(2),
            CheckerRule::Zaragoza => (x.trunc() as i64) % 2,
        }
    }

    #[inline]
    pub fn eval(&self, uv: Vec2) -> Rgb {
        let st = uv * self.scale + self.offset;
        if self.key(st.x) == self.key(st.y) {
            self.same
        } else {
            self.differ
        }
    }

    /// A single value: the channel mean (the Zaragoza fork reads its
    /// roughness textures with `.mean()`; ETH's float checkerboard stores
    /// one number in all three channels).
    #[inline]
    pub fn eval_1(&self, uv: Vec2) -> f32 {
        super::channel_mean(self.eval(uv))
    }

    /// The two values in equal parts (exact over whole squares).
    pub fn mean(&self) -> Rgb {
        (self.same + self.differ) * 0.5
    }

    pub fn max_value(&self) -> f32 {
        self.same.max_element().max(self.differ.max_element())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const A: Rgb = Rgb::new(0.8, 0.8, 0.8);
    const B: Rgb = Rgb::new(0.2, 0.2, 0.2);

    /// ETH's course scene: scale (0.1, 0.2), delta (0.5, 0.5); value1
    /// where floor(u / 0.1 - 0.5) and floor(v / 0.2 - 0.5) agree in parity.
    #[test]
    fn eth_squares_follow_the_framework() {
        let c = NoriChecker {
            scale: Vec2::new(10.0, 5.0),
            offset: Vec2::new(-0.5, -0.5),
            rule: CheckerRule::Eth,
            same: A,
            differ: B,
        };
        let eth = |u: f32, v: f32| {
            let col = ((u / 0.1 - 0.5).floor() as i64).abs() % 2;
            let row = ((v / 0.2 - 0.5).floor() as i64).abs() % 2;
            if col == row {
                A
            } else {
                B
            }
        };
        let mut both = [0; 2];
        for i in 0..200 {
            for j in 0..200 {
                let (u, v) = (i as f32 * 0.0131 - 1.3, j as f32 * 0.0173 - 1.7);
                let got = c.eval(Vec2::new(u, v));
                assert_eq!(got, eth(u, v), "at ({u}, {v})");
                both[(got == A) as usize] += 1;
            }
        }
        assert!(both[0] > 15000 && both[1] > 15000, "{both:?}");
    }

    /// The Zaragoza fork: int casts truncate toward zero and C's remainder
    /// keeps the sign, so -0.5 and 0.5 share a square, and (-1.5, 1.5)
    /// (remainders -1 and 1) is the second colour.
    #[test]
    fn zaragoza_squares_truncate_and_keep_the_sign() {
        let c = NoriChecker {
            scale: Vec2::new(4.0, 4.0),
            offset: Vec2::ZERO,
            rule: CheckerRule::Zaragoza,
            same: A,
            differ: B,
        };
        let at = |u: f32, v: f32| c.eval(Vec2::new(u / 4.0, v / 4.0));
        assert_eq!(at(0.5, 0.5), A);
        assert_eq!(at(1.5, 0.5), B);
        assert_eq!(at(1.5, 1.5), A);
        assert_eq!(at(-0.5, 0.5), A);
        assert_eq!(at(-1.5, 1.5), B);
        assert_eq!(at(-1.5, -1.5), A);
        assert_eq!(at(f32::NAN, 0.5), A);
        assert!((c.eval_1(Vec2::new(0.3, 0.1)) - 0.5).abs() > 0.2);
        assert_eq!(c.mean(), Rgb::splat(0.5));
    }
}
