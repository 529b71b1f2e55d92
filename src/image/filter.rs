//! Pixel reconstruction filters with Nori's parameters and defaults.

/// A separable reconstruction filter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Filter {
    Gaussian {
        radius: f32,
        stddev: f32,
    },
    Box {
        radius: f32,
    },
    Tent {
        radius: f32,
    },
    /// Mitchell-Netravali with parameters B and C.
    Mitchell {
        radius: f32,
        b: f32,
        c: f32,
    },
}

impl Default for Filter {
    /// Nori's default: gaussian, radius 2, stddev 0.5.
    fn default() -> Self {
        Filter::Gaussian {
            radius: 2.0,
            stddev: 0.5,
        }
    }
}

impl Filter {
    pub fn radius(&self) -> f32 {
        match *self {
            Filter::Gaussian { radius, .. }
            | Filter::Box { radius }
            | Filter::Tent { radius }
            | Filter::Mitchell { radius, .. } => radius,
        }
    }

    /// One-dimensional filter value at offset `x` (pixels).
    pub fn eval_1d(&self, x: f32) -> f32 {
        match *self {
            Filter::Gaussian { radius, stddev } => {
                let alpha = -1.0 / (2.0 * stddev * stddev);
                ((alpha * x * x).exp() - (alpha * radius * radius).exp()).max(0.0)
            }
            Filter::Box { radius } => {
                if x.abs() <= radius {
                    1.0
                } else {
                    0.0
                }
            }
            Filter::Tent { radius } => (1.0 - x.abs() / radius).max(0.0),
            Filter::Mitchell { radius, b, c } => {
                let x = (2.0 * x / radius).abs();
                let x2 = x * x;
                let x3 = x2 * x;
                (if x < 1.0 {
                    (12.0 - 9.0 * b - 6.0 * c) * x3
                        + (-18.0 + 12.0 * b + 6.0 * c) * x2
                        + (6.0 - 2.0 * b)
                } else if x < 2.0 {
                    (-b - 6.0 * c) * x3
                        + (6.0 * b + 30.0 * c) * x2
                        + (-12.0 * b - 48.0 * c) * x
                        + (8.0 * b + 24.0 * c)
                } else {
                    0.0
                }) / 6.0
            }
        }
    }

    /// Separable 2D weight.
    pub fn eval(&self, dx: f32, dy: f32) -> f32 {
        self.eval_1d(dx) * self.eval_1d(dy)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn filters_vanish_at_their_radius() {
        for f in [
            Filter::default(),
            Filter::Tent { radius: 1.0 },
            Filter::Mitchell {
                radius: 2.0,
                b: 1.0 / 3.0,
                c: 1.0 / 3.0,
            },
        ] {
            assert!(f.eval_1d(f.radius()).abs() < 1e-6, "{f:?}");
            assert!(f.eval_1d(0.0) > 0.0);
        }
        assert_eq!(Filter::Box { radius: 0.5 }.eval_1d(0.6), 0.0);
    }
}
