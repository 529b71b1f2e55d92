//! False-colour maps: one scale (blue, cyan, green, yellow, red) for the
//! error image of `lente compare --diff` and the preview's exposure view.

use super::Bitmap;
use crate::color::{luminance, Rgb};

/// Stops either side of middle grey that [`exposure_zones`] spans.
pub const ZONE_STOPS: f32 = 6.0;

/// Middle grey: 0 EV of the exposure view.
const MIDDLE_GREY: f32 = 0.18;

/// False colour for t in [0, 1]: blue, cyan, green, yellow, red (NaN shows
/// red).
pub fn false_colour(t: f32) -> Rgb {
    const STOPS: [Rgb; 5] = [
        Rgb::new(0.0, 0.0, 1.0),
        Rgb::new(0.0, 1.0, 1.0),
        Rgb::new(0.0, 1.0, 0.0),
        Rgb::new(1.0, 1.0, 0.0),
        Rgb::new(1.0, 0.0, 0.0),
    ];
    let t = if t.is_nan() { 1.0 } else { t.clamp(0.0, 1.0) };
    let s = t * (STOPS.len() - 1) as f32;
    let i = (s as usize).min(STOPS.len() - 2);
    STOPS[i].lerp(STOPS[i + 1], s - i as f32)
}

/// Each pixel's luminance after `stops` of exposure, in stops from middle
/// grey, as false colour over -[`ZONE_STOPS`]..+[`ZONE_STOPS`] (green is
/// middle grey; below and above the range clamp to blue and red). Black
/// pixels stay black; non-finite ones show red.
pub fn exposure_zones(image: &Bitmap, stops: f32) -> Bitmap {
    let scale = stops.exp2();
    image.map(|p| {
        let l = luminance(p) * scale;
        if l.is_nan() || l == f32::INFINITY {
            false_colour(1.0)
        } else if l <= 0.0 {
            Rgb::ZERO
        } else {
            let ev = (l / MIDDLE_GREY).log2();
            false_colour((ev + ZONE_STOPS) / (2.0 * ZONE_STOPS))
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn zones_put_middle_grey_at_green_and_stops_apart() {
        let mut image = Bitmap::new(5, 1);
        image.pixels = vec![
            Rgb::splat(0.18),
            Rgb::splat(0.18 * 2f32.powi(6)),
            Rgb::splat(0.18 * 2f32.powi(-9)),
            Rgb::ZERO,
            Rgb::splat(f32::NAN),
        ];
        let z = exposure_zones(&image, 0.0);
        let close = |a: Rgb, b: Rgb| (a - b).abs().max_element() < 1e-4;
        assert!(
            close(z.pixels[0], Rgb::new(0.0, 1.0, 0.0)),
            "{:?}",
            z.pixels[0]
        );
        assert!(close(z.pixels[1], Rgb::new(1.0, 0.0, 0.0)));
        assert!(close(z.pixels[2], Rgb::new(0.0, 0.0, 1.0)), "clamped");
        assert_eq!(z.pixels[3], Rgb::ZERO);
        assert_eq!(z.pixels[4], Rgb::new(1.0, 0.0, 0.0));
        // Exposure shifts the zones: +3 stops puts grey halfway to red.
        let z = exposure_zones(&image, 3.0);
        assert!(
            close(z.pixels[0], Rgb::new(1.0, 1.0, 0.0)),
            "{:?}",
            z.pixels[0]
        );
    }
}
