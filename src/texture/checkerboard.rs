//! Mitsuba 3's `checkerboard`: two colours in alternating squares, four
//! per unit of uv (the square containing uv in (0, 0.5)^2 has `color0`).

use super::UvTransform;
use crate::color::Rgb;
use crate::math::Vec2;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Checkerboard {
    /// Mitsuba's defaults: 0.4 and 0.2.
    pub color0: Rgb,
    pub color1: Rgb,
    pub to_uv: UvTransform,
}

impl Checkerboard {
    /// True where the colour is `color0` (both fractional parts on the
    /// same side of 1/2).
    #[inline]
    fn first(&self, uv: Vec2) -> bool {
        let uv = self.to_uv.apply(uv);
        let mx = uv.x - uv.x.floor() > 0.5;
        let my = uv.y - uv.y.floor() > 0.5;
        mx == my
    }

    #[inline]
    pub fn eval(&self, uv: Vec2) -> Rgb {
        if self.first(uv) {
            self.color0
        } else {
            self.color1
        }
    }

    /// Mitsuba 3.9's `eval_1` swaps the squares relative to `eval` (its
    /// mask test is inverted there); kept so scalar uses (roughness) match.
    /// Its colours are constants: their `eval_1` is the channel mean.
    #[inline]
    pub fn eval_1(&self, uv: Vec2) -> f32 {
        super::channel_mean(if self.first(uv) {
            self.color1
        } else {
            self.color0
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn squares_alternate_at_half_units() {
        let c = Checkerboard {
            color0: Rgb::splat(0.4),
            color1: Rgb::splat(0.2),
            to_uv: UvTransform::IDENTITY,
        };
        assert_eq!(c.eval(Vec2::new(0.25, 0.25)), Rgb::splat(0.4));
        assert_eq!(c.eval(Vec2::new(0.75, 0.75)), Rgb::splat(0.4));
        assert_eq!(c.eval(Vec2::new(0.75, 0.25)), Rgb::splat(0.2));
        assert_eq!(c.eval(Vec2::new(-0.25, 0.25)), Rgb::splat(0.2));
        assert!((c.eval_1(Vec2::new(0.25, 0.25)) - 0.2).abs() < 1e-6);
        let scaled = Checkerboard {
            to_uv: UvTransform {
                row0: [2.0, 0.0, 0.0],
                row1: [0.0, 2.0, 0.0],
            },
            ..c
        };
        assert_eq!(scaled.eval(Vec2::new(0.3, 0.1)), Rgb::splat(0.2));
    }
}
