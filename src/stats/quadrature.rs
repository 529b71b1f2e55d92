//! Adaptive Simpson quadrature in one and two dimensions: integrates a
//! density over the cells of a chi-square table. Peaky densities (narrow
//! microfacet lobes) need the adaptivity; a fixed grid misses them.

/// Limits of an adaptive integration.
#[derive(Clone, Copy, Debug)]
pub struct Adaptive {
    /// Absolute error allowed over the whole interval (or rectangle).
    pub eps: f64,
    /// An interval is also done when its error estimate is below this
    /// fraction of its value: densities computed in f32 are noisy at about
    /// 1e-7 relative, and would otherwise be refined to `max_depth`.
    pub rel: f64,
    /// Every interval is split at least this many times, so that a feature
    /// narrower than the interval is not missed between the first samples.
    pub min_depth: u32,
    /// No interval is split more than this many times.
    pub max_depth: u32,
}

impl Default for Adaptive {
    fn default() -> Self {
        Adaptive {
            eps: 1e-9,
            rel: 1e-6,
            min_depth: 2,
            max_depth: 14,
        }
    }
}

/// Integral of `f` over [a, b]: Simpson's rule on halves of each interval
/// until Richardson's error estimate is below the interval's share of
/// `eps` (after at least `min_depth` and at most `max_depth` splits).
pub fn adaptive_simpson(f: &mut impl FnMut(f64) -> f64, a: f64, b: f64, lim: Adaptive) -> f64 {
    let (fa, fm, fb) = (f(a), f(0.5 * (a + b)), f(b));
    let whole = (b - a) / 6.0 * (fa + 4.0 * fm + fb);
    refine(
        f,
        a,
        b,
        [fa, fm, fb],
        whole,
        lim,
        lim.eps,
        lim.min_depth,
        lim.max_depth,
    )
}

#[allow(clippy::too_many_arguments)]
fn refine(
    f: &mut impl FnMut(f64) -> f64,
    a: f64,
    b: f64,
    [fa, fm, fb]: [f64; 3],
    whole: f64,
    lim: Adaptive,
    eps: f64,
    min_depth: u32,
    depth_left: u32,
) -> f64 {
    let m = 0.5 * (a + b);
    let (flm, frm) = (f(0.5 * (a + m)), f(0.5 * (m + b)));
    let left = (m - a) / 6.0 * (fa + 4.0 * flm + fm);
    let right = (b - m) / 6.0 * (fm + 4.0 * frm + fb);
    let delta = left + right - whole;
    let converged = delta.abs() <= 15.0 * eps || delta.abs() <= lim.rel * (left + right).abs();
    if depth_left == 0 || (min_depth == 0 && converged) || !delta.is_finite() {
        return left + right + delta / 15.0;
    }
    let next_min = min_depth.saturating_sub(1);
    refine(
        f,
        a,
        m,
        [fa, flm, fm],
        left,
        lim,
        0.5 * eps,
        next_min,
        depth_left - 1,
    ) + refine(
        f,
        m,
        b,
        [fm, frm, fb],
        right,
        lim,
        0.5 * eps,
        next_min,
        depth_left - 1,
    )
}

/// Integral of `f(x, y)` over [x0, x1] x [y0, y1]: adaptive Simpson in x of
/// adaptive Simpson integrals in y.
pub fn adaptive_simpson_2d(
    f: impl Fn(f64, f64) -> f64,
    (x0, y0): (f64, f64),
    (x1, y1): (f64, f64),
    lim: Adaptive,
) -> f64 {
    let inner = Adaptive {
        eps: lim.eps / (x1 - x0).abs().max(f64::MIN_POSITIVE),
        ..lim
    };
    let outer = Adaptive {
        eps: 0.5 * lim.eps,
        ..lim
    };
    let mut fx = |x: f64| adaptive_simpson(&mut |y| f(x, y), y0, y1, inner);
    adaptive_simpson(&mut fx, x0, x1, outer)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn polynomials_and_smooth_functions() {
        let lim = Adaptive::default();
        let v = adaptive_simpson(&mut |x| x * x * x, 0.0, 2.0, lim);
        assert!((v - 4.0).abs() < 1e-12);
        let v = adaptive_simpson(&mut f64::sin, 0.0, std::f64::consts::PI, lim);
        assert!((v - 2.0).abs() < 1e-8);
        let v = adaptive_simpson_2d(|x, y| x * y, (0.0, 0.0), (1.0, 2.0), lim);
        assert!((v - 1.0).abs() < 1e-12);
    }

    #[test]
    fn narrow_peak_inside_the_interval_is_found() {
        // A Gaussian of width 1e-3 at 0.3717: invisible to the first five
        // samples, found thanks to the forced splits.
        let s = 1e-3;
        let mut g = |x: f64| (-(x - 0.3717f64).powi(2) / (2.0 * s * s)).exp();
        let want = s * (2.0 * std::f64::consts::PI).sqrt();
        let lim = Adaptive {
            eps: 1e-10,
            rel: 0.0,
            min_depth: 6,
            max_depth: 30,
        };
        let v = adaptive_simpson(&mut g, 0.0, 1.0, lim);
        assert!((v - want).abs() < 1e-6 * want, "{v} vs {want}");
    }

    #[test]
    fn step_function() {
        let lim = Adaptive {
            eps: 1e-9,
            rel: 0.0,
            min_depth: 2,
            max_depth: 30,
        };
        let v = adaptive_simpson(&mut |x| if x < 0.3 { 1.0 } else { 0.0 }, 0.0, 1.0, lim);
        assert!((v - 0.3).abs() < 1e-7, "{v}");
    }
}
