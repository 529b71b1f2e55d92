//! Radiance RGBE (`.hdr`, `.pic`): a text header ending in an empty line, a
//! resolution line (normally `-Y height +X width`), then scanlines that are
//! either flat (4 bytes a pixel, optionally with Radiance's old run-length
//! markers) or "new" run-length encoded (each of the four components
//! encoded separately).

use super::Malformed;
use super::RawImage;
use crate::image::Bitmap;

/// Shortest and longest scanlines that may use the new RLE scheme.
const MIN_RLE_LEN: usize = 8;
const MAX_RLE_LEN: usize = 0x7fff;

/// Largest accepted side; keeps a bogus header from requesting an absurd
/// allocation (the data is checked as it is decoded anyway).
const MAX_SIDE: usize = 1 << 20;

/// The linear value of one RGBE pixel (as in stb_image, pbrt, the `image`
/// crate: mantissa times 2^(e - 136); e = 0 is black).
#[cfg(test)]
fn rgbe_to_rgb(p: [u8; 4]) -> [f32; 3] {
    rgbe_to_rgb_with(&exponent_table(), p)
}

/// 2^(e - 136) for every exponent byte, with 0 for e = 0.
fn exponent_table() -> [f32; 256] {
    std::array::from_fn(|e| {
        if e == 0 {
            0.0
        } else {
            (2.0f64).powi(e as i32 - 136) as f32
        }
    })
}

fn rgbe_to_rgb_with(table: &[f32; 256], p: [u8; 4]) -> [f32; 3] {
    let f = table[usize::from(p[3])];
    [
        f32::from(p[0]) * f,
        f32::from(p[1]) * f,
        f32::from(p[2]) * f,
    ]
}

/// Encodes a linear colour as RGBE with round-to-nearest mantissas (relative
/// error of the largest channel at most 1/256). Negative and NaN channels are
/// written as zero, +infinity and huge values as the largest RGBE value.
pub(super) fn rgb_to_rgbe(c: [f32; 3]) -> [u8; 4] {
    let c = c.map(|v| if v > 0.0 { v.min(f32::MAX) } else { 0.0 });
    let max = c[0].max(c[1]).max(c[2]);
    if max < f32::MIN_POSITIVE {
        return [0; 4];
    }
    // max = f * 2^e with f in [0.5, 1).
    let mut e = ((max.to_bits() >> 23) & 0xff) as i32 - 126;
    let mut scale = (2.0f64).powi(8 - e);
    if (f64::from(max) * scale).round() >= 256.0 {
        e += 1;
        scale *= 0.5;
    }
    let biased = e + 128;
    if biased > 255 {
        return [255; 4];
    }
    if biased < 1 {
        return [0; 4];
    }
    let m = c.map(|v| (f64::from(v) * scale).round().min(255.0) as u8);
    [m[0], m[1], m[2], biased as u8]
}

/// Reads one header line (without the newline) starting at `*pos`.
fn line<'a>(bytes: &'a [u8], pos: &mut usize) -> Option<&'a [u8]> {
    if *pos >= bytes.len() {
        return None;
    }
    let rest = &bytes[*pos..];
    let end = rest.iter().position(|&b| b == b'\n')?;
    *pos += end + 1;
    let l = &rest[..end];
    Some(l.strip_suffix(b"\r").unwrap_or(l))
}

/// Where the scanlines go: the resolution line names the slow axis first.
struct Layout {
    width: usize,
    height: usize,
    /// Scanlines run along x (rows) rather than along y (columns).
    rows: bool,
    /// Scanline `i` is row (or column) `i` counted from the top (left)
    /// rather than from the bottom (right).
    slow_forward: bool,
    /// Pixels within a scanline run left to right (top to bottom).
    fast_forward: bool,
    scanlines: usize,
    scanline_len: usize,
}

fn parse_resolution(text: &str) -> Result<Layout, Malformed> {
    let bad = || {
        format!(
            "bad Radiance resolution line '{}' (expected e.g. '-Y 512 +X 1024')",
            text.escape_default()
        )
    };
    let parts: Vec<&str> = text.split_whitespace().collect();
    if parts.len() != 4 {
        return Err(Malformed::from(bad()));
    }
    let axis = |s: &str| -> Option<(bool, char)> {
        let mut ch = s.chars();
        let sign = match ch.next()? {
            '+' => true,
            '-' => false,
            _ => return None,
        };
        let a = ch.next()?;
        (ch.next().is_none() && (a == 'X' || a == 'Y')).then_some((sign, a))
    };
    let (s1, a1) = axis(parts[0]).ok_or_else(bad)?;
    let (s2, a2) = axis(parts[2]).ok_or_else(bad)?;
    if a1 == a2 {
        return Err(Malformed::from(bad()));
    }
    let n1: usize = parts[1].parse().map_err(|_| bad())?;
    let n2: usize = parts[3].parse().map_err(|_| bad())?;
    if n1 > MAX_SIDE || n2 > MAX_SIDE {
        return Err(Malformed::from(format!(
            "Radiance image size {text} is too large"
        )));
    }
    Ok(if a1 == 'Y' {
        // Scanlines are rows; -Y means the first one is the top row.
        Layout {
            width: n2,
            height: n1,
            rows: true,
            slow_forward: !s1,
            fast_forward: s2,
            scanlines: n1,
            scanline_len: n2,
        }
    } else {
        // Scanlines are columns; +X means the first one is the left column,
        // and -Y within a column means top to bottom.
        Layout {
            width: n1,
            height: n2,
            rows: false,
            slow_forward: s1,
            fast_forward: !s2,
            scanlines: n1,
            scanline_len: n2,
        }
    })
}

/// Decodes one scanline of `out.len()` pixels starting at `*pos`.
fn read_scanline(bytes: &[u8], pos: &mut usize, out: &mut [[u8; 4]]) -> Result<(), Malformed> {
    let len = out.len();
    let truncated = || "Radiance HDR file is truncated (pixel data ends early)".to_string();
    let head = bytes.get(*pos..*pos + 4).ok_or_else(truncated)?;
    if (MIN_RLE_LEN..=MAX_RLE_LEN).contains(&len)
        && head[0] == 2
        && head[1] == 2
        && head[2] & 0x80 == 0
    {
        let encoded_len = (usize::from(head[2]) << 8) | usize::from(head[3]);
        if encoded_len != len {
            return Err(Malformed::from(format!(
                "Radiance HDR scanline length {encoded_len} does not match the image width {len}"
            )));
        }
        *pos += 4;
        for ch in 0..4 {
            let mut x = 0;
            while x < len {
                let &count = bytes.get(*pos).ok_or_else(truncated)?;
                *pos += 1;
                if count > 128 {
                    let run = usize::from(count - 128);
                    if run > len - x {
                        return Err(Malformed::from("Radiance HDR run overruns its scanline"));
                    }
                    let &value = bytes.get(*pos).ok_or_else(truncated)?;
                    *pos += 1;
                    for p in &mut out[x..x + run] {
                        p[ch] = value;
                    }
                    x += run;
                } else {
                    let n = usize::from(count);
                    if n == 0 || n > len - x {
                        return Err(Malformed::from("Radiance HDR run overruns its scanline"));
                    }
                    let src = bytes.get(*pos..*pos + n).ok_or_else(truncated)?;
                    *pos += n;
                    for (p, &v) in out[x..x + n].iter_mut().zip(src) {
                        p[ch] = v;
                    }
                    x += n;
                }
            }
        }
        return Ok(());
    }
    // Flat pixels, with Radiance's old-style repeat markers (1, 1, 1, n).
    let mut x = 0;
    let mut shift = 0u32;
    while x < len {
        let p = bytes.get(*pos..*pos + 4).ok_or_else(truncated)?;
        *pos += 4;
        if p[0] == 1 && p[1] == 1 && p[2] == 1 {
            if x == 0 || shift > 16 {
                return Err(Malformed::from("bad Radiance HDR old-style run"));
            }
            let count = usize::from(p[3]) << shift;
            if count > len - x {
                return Err(Malformed::from("Radiance HDR run overruns its scanline"));
            }
            let prev = out[x - 1];
            out[x..x + count].fill(prev);
            x += count;
            shift += 8;
        } else {
            out[x] = [p[0], p[1], p[2], p[3]];
            x += 1;
            shift = 0;
        }
    }
    Ok(())
}

pub(super) fn decode(bytes: &[u8]) -> Result<RawImage, Malformed> {
    if !bytes.starts_with(b"#?") {
        return Err(Malformed::from(
            "not a Radiance HDR file (no '#?' signature)",
        ));
    }
    let mut pos = 0;
    loop {
        let l =
            line(bytes, &mut pos).ok_or("Radiance HDR header ends before its resolution line")?;
        if l.is_empty() {
            break;
        }
        if let Some(format) = l.strip_prefix(b"FORMAT=") {
            let format = String::from_utf8_lossy(format);
            if format.trim() != "32-bit_rle_rgbe" {
                return Err(Malformed::from(format!(
                    "Radiance pixel format '{}' is not supported (only 32-bit_rle_rgbe)",
                    format.trim().escape_default()
                )));
            }
        }
    }
    let res = line(bytes, &mut pos).ok_or("Radiance HDR file has no resolution line")?;
    let layout = parse_resolution(&String::from_utf8_lossy(res))?;
    let Layout {
        width,
        height,
        scanlines,
        scanline_len,
        ..
    } = layout;
    super::check_size(width, height)?;
    // Allocate as we go (capped up front) so a lying header cannot make us
    // reserve gigabytes before the data runs out.
    let mut texels: Vec<[u8; 4]> = Vec::with_capacity((width * height).min(1 << 24));
    let mut scan = vec![[0u8; 4]; scanline_len];
    for _ in 0..scanlines {
        read_scanline(bytes, &mut pos, &mut scan)?;
        texels.extend_from_slice(&scan);
    }
    let table = exponent_table();
    let mut data = vec![0.0f32; width * height * 3];
    for (i, chunk) in texels.chunks_exact(scanline_len.max(1)).enumerate() {
        let slow = if layout.slow_forward {
            i
        } else {
            scanlines - 1 - i
        };
        for (j, &p) in chunk.iter().enumerate() {
            let fast = if layout.fast_forward {
                j
            } else {
                scanline_len - 1 - j
            };
            let (x, y) = if layout.rows {
                (fast, slow)
            } else {
                (slow, fast)
            };
            let k = 3 * (y * width + x);
            data[k..k + 3].copy_from_slice(&rgbe_to_rgb_with(&table, p));
        }
    }
    Ok(RawImage {
        width,
        height,
        channels: 3,
        data,
    })
}

/// Run-length encodes one component of a scanline (the usual Radiance
/// scheme: runs of 4 or more become (128 + n, value), the rest literals).
fn rle_component(data: &[u8], out: &mut Vec<u8>) {
    let n = data.len();
    let mut cur = 0;
    while cur < n {
        // Find the next run of at least 4 equal bytes.
        let mut run_start = cur;
        let mut run_len = 0;
        while run_start < n {
            run_len = 1;
            while run_start + run_len < n
                && run_len < 127
                && data[run_start + run_len] == data[run_start]
            {
                run_len += 1;
            }
            if run_len >= 4 {
                break;
            }
            run_start += run_len;
        }
        // Literals up to the run (at most 128 at a time).
        while cur < run_start {
            let k = (run_start - cur).min(128);
            out.push(k as u8);
            out.extend_from_slice(&data[cur..cur + k]);
            cur += k;
        }
        if run_start < n && run_len >= 4 {
            out.push(128 + run_len as u8);
            out.push(data[run_start]);
            cur = run_start + run_len;
        }
    }
}

/// RGBE with the standard header and `-Y h +X w` orientation; scanlines are
/// run-length encoded when their length allows it, flat otherwise.
pub(super) fn encode(image: &Bitmap) -> Result<Vec<u8>, Malformed> {
    let (w, h) = (image.width, image.height);
    let mut out =
        format!("#?RADIANCE\n# lente\nFORMAT=32-bit_rle_rgbe\n\n-Y {h} +X {w}\n").into_bytes();
    out.reserve(w * h * 4);
    let rle = (MIN_RLE_LEN..=MAX_RLE_LEN).contains(&w);
    let mut component = vec![0u8; w];
    for row in image.pixels.chunks_exact(w) {
        let rgbe: Vec<[u8; 4]> = row.iter().map(|p| rgb_to_rgbe(p.to_array())).collect();
        if rle {
            out.extend_from_slice(&[2, 2, (w >> 8) as u8, (w & 0xff) as u8]);
            for ch in 0..4 {
                for (c, p) in component.iter_mut().zip(&rgbe) {
                    *c = p[ch];
                }
                rle_component(&component, &mut out);
            }
        } else {
            for p in &rgbe {
                out.extend_from_slice(p);
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::super::test_util::test_image;
    use super::super::{load_image, save_image};
    use super::*;
    use crate::color::Rgb;

    /// Test-only flat encoder: header plus raw RGBE quadruples.
    fn flat_file(header_res: &str, pixels: &[[u8; 4]]) -> Vec<u8> {
        let mut out = format!("#?RADIANCE\nFORMAT=32-bit_rle_rgbe\nEXPOSURE=1.0\n\n{header_res}\n")
            .into_bytes();
        for p in pixels {
            out.extend_from_slice(p);
        }
        out
    }

    /// Test-only RLE encoder, deliberately simpler than the library's: runs
    /// of 3 or more equal bytes become runs, everything else literals of at
    /// most 5 bytes (so many short packets are exercised).
    fn rle_file(width: usize, height: usize, pixels: &[[u8; 4]]) -> Vec<u8> {
        let mut out = format!("#?RGBE\r\nFORMAT=32-bit_rle_rgbe\r\n\r\n-Y {height} +X {width}\n")
            .into_bytes();
        for row in pixels.chunks(width) {
            out.extend_from_slice(&[2, 2, (width >> 8) as u8, width as u8]);
            for ch in 0..4 {
                let data: Vec<u8> = row.iter().map(|p| p[ch]).collect();
                let mut i = 0;
                let mut literal: Vec<u8> = Vec::new();
                let flush = |lit: &mut Vec<u8>, out: &mut Vec<u8>| {
                    if !lit.is_empty() {
                        out.push(lit.len() as u8);
                        out.append(lit);
                    }
                };
                while i < data.len() {
                    let mut run = 1;
                    while i + run < data.len() && data[i + run] == data[i] && run < 127 {
                        run += 1;
                    }
                    if run >= 3 {
                        flush(&mut literal, &mut out);
                        out.push(128 + run as u8);
                        out.push(data[i]);
                        i += run;
                    } else {
                        literal.push(data[i]);
                        if literal.len() == 5 {
                            flush(&mut literal, &mut out);
                        }
                        i += 1;
                    }
                }
                flush(&mut literal, &mut out);
            }
        }
        out
    }

    /// Independent reference for the RGBE value: m * 2^(e - 136).
    fn expected(p: [u8; 4]) -> Rgb {
        if p[3] == 0 {
            return Rgb::ZERO;
        }
        let f = 2f32.powf(p[3] as f32 - 136.0);
        Rgb::new(p[0] as f32 * f, p[1] as f32 * f, p[2] as f32 * f)
    }

    /// A width x height grid of RGBE pixels with runs and noise.
    fn rgbe_pixels(width: usize, height: usize) -> Vec<[u8; 4]> {
        (0..width * height)
            .map(|i| {
                let (x, y) = (i % width, i / width);
                if x < 9 {
                    [200, 100, 50, 129] // a run
                } else {
                    [
                        (x * 7 + y) as u8 | 0x80,
                        (x * 13 + 5 * y) as u8,
                        (x / 3) as u8,
                        120 + (y % 20) as u8,
                    ]
                }
            })
            .collect()
    }

    #[test]
    fn hdr_reads_rle_scanlines() {
        let dir = tempfile::tempdir().unwrap();
        let (w, h) = (300, 7);
        let px = rgbe_pixels(w, h);
        let path = dir.path().join("rle.hdr");
        std::fs::write(&path, rle_file(w, h, &px)).unwrap();
        let (img, warnings) = load_image(&path).unwrap();
        assert!(warnings.is_empty());
        assert_eq!((img.width, img.height), (w, h));
        for (i, &p) in px.iter().enumerate() {
            assert_eq!(img.pixels[i], expected(p), "pixel {i}");
        }
    }

    #[test]
    fn hdr_reads_flat_scanlines() {
        let dir = tempfile::tempdir().unwrap();
        // Width 5 is too short for RLE; width 40000 too long; width 20 is
        // allowed to be flat too (first pixel is not 2,2,...).
        for (w, h) in [(5, 3), (20, 4), (40000, 2)] {
            let px = rgbe_pixels(w, h);
            let path = dir.path().join("flat.hdr");
            std::fs::write(&path, flat_file(&format!("-Y {h} +X {w}"), &px)).unwrap();
            let (img, _) = load_image(&path).unwrap();
            assert_eq!((img.width, img.height), (w, h));
            for (i, &p) in px.iter().enumerate() {
                assert_eq!(img.pixels[i], expected(p), "{w}x{h} pixel {i}");
            }
        }
    }

    #[test]
    fn hdr_reads_old_style_runs() {
        let dir = tempfile::tempdir().unwrap();
        let a = [10, 20, 30, 130];
        let b = [40, 50, 60, 128];
        // a, then 3 repeats of a, then b, then 1 repeat of b: 6 pixels.
        let bytes = flat_file("-Y 1 +X 6", &[a, [1, 1, 1, 3], b, [1, 1, 1, 1]]);
        let path = dir.path().join("old.hdr");
        std::fs::write(&path, bytes).unwrap();
        let (img, _) = load_image(&path).unwrap();
        let want = [a, a, a, a, b, b].map(expected);
        assert_eq!(img.pixels, want.to_vec());
    }

    #[test]
    fn hdr_respects_orientation() {
        let dir = tempfile::tempdir().unwrap();
        // Image (top row first):  p0 p1 p2
        //                         p3 p4 p5
        let p: Vec<[u8; 4]> = (0..6).map(|i| [10 + i as u8, 0, 0, 129]).collect();
        let want: Vec<Rgb> = p.iter().map(|&q| expected(q)).collect();
        let cases: [(&str, [usize; 6]); 8] = [
            ("-Y 2 +X 3", [0, 1, 2, 3, 4, 5]),
            ("-Y 2 -X 3", [2, 1, 0, 5, 4, 3]),
            ("+Y 2 +X 3", [3, 4, 5, 0, 1, 2]),
            ("+Y 2 -X 3", [5, 4, 3, 2, 1, 0]),
            ("+X 3 -Y 2", [0, 3, 1, 4, 2, 5]),
            ("+X 3 +Y 2", [3, 0, 4, 1, 5, 2]),
            ("-X 3 -Y 2", [2, 5, 1, 4, 0, 3]),
            ("-X 3 +Y 2", [5, 2, 4, 1, 3, 0]),
        ];
        for (res, order) in cases {
            let stored: Vec<[u8; 4]> = order.iter().map(|&i| p[i]).collect();
            let path = dir.path().join("o.hdr");
            std::fs::write(&path, flat_file(res, &stored)).unwrap();
            let (img, _) = load_image(&path).unwrap();
            assert_eq!((img.width, img.height), (3, 2), "{res}");
            assert_eq!(img.pixels, want, "{res}");
        }
    }

    #[test]
    fn hdr_round_trip_within_rgbe_precision() {
        let dir = tempfile::tempdir().unwrap();
        // Wide enough for RLE, plus a narrow one written flat.
        for (w, h) in [(67, 9), (4, 3)] {
            let mut img = test_image(w, h);
            img.set(0, 0, Rgb::new(1e4, 0.0, 1e-3));
            img.set(1, 0, Rgb::ZERO);
            let path = dir.path().join("rt.hdr");
            save_image(&path, &img).unwrap();
            let (back, warnings) = load_image(&path).unwrap();
            assert!(warnings.is_empty());
            assert_eq!((back.width, back.height), (w, h));
            for (a, b) in img.pixels.iter().zip(&back.pixels) {
                // Each channel is within 1/256 of the pixel's largest channel.
                let tol = a.max_element() / 256.0 * 1.0001;
                assert!((*a - *b).abs().max_element() <= tol, "{a} vs {b}");
                // and the largest channel within 0.4 %.
                assert!((a.max_element() - b.max_element()).abs() <= 0.004 * a.max_element());
            }
            // The `image` crate reads our files the same way.
            if w >= 8 {
                use image::ImageDecoder;
                let bytes = std::fs::read(&path).unwrap();
                let dec = image::codecs::hdr::HdrDecoder::new(std::io::Cursor::new(bytes)).unwrap();
                let mut buf = vec![0u8; dec.total_bytes() as usize];
                dec.read_image(&mut buf).unwrap();
                let floats: Vec<f32> = buf
                    .chunks_exact(4)
                    .map(|b| f32::from_ne_bytes([b[0], b[1], b[2], b[3]]))
                    .collect();
                for (i, p) in back.pixels.iter().enumerate() {
                    assert_eq!(
                        p.to_array(),
                        [floats[3 * i], floats[3 * i + 1], floats[3 * i + 2]]
                    );
                }
            }
        }
    }

    #[test]
    fn rgbe_encoding_edge_cases() {
        assert_eq!(rgb_to_rgbe([0.0, 0.0, 0.0]), [0; 4]);
        assert_eq!(rgb_to_rgbe([-1.0, f32::NAN, 0.0]), [0; 4]);
        assert_eq!(rgb_to_rgbe([1.0, 0.5, 0.0]), [128, 64, 0, 129]);
        // Rounding up to 256 moves to the next exponent.
        assert_eq!(rgb_to_rgbe([0.9999, 0.0, 0.0]), [128, 0, 0, 129]);
        assert_eq!(rgb_to_rgbe([f32::INFINITY, 1.0, 0.0])[3], 255);
        for v in [1e-20f32, 3.7e-3, 0.71, 1.0, 255.5, 6.1e4, 1e30] {
            let back = rgbe_to_rgb(rgb_to_rgbe([v, v * 0.5, 0.0]));
            assert!((back[0] - v).abs() <= v * 0.004, "{v} -> {}", back[0]);
        }
    }

    #[test]
    fn hdr_rejects_bad_input() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("b.hdr");
        let mut rle_bad_len = flat_file("-Y 1 +X 10", &[]);
        rle_bad_len.extend_from_slice(&[2, 2, 0, 11]);
        let mut rle_overrun = flat_file("-Y 1 +X 10", &[]);
        rle_overrun.extend_from_slice(&[2, 2, 0, 10, 128 + 11, 5]);
        let mut rle_zero = flat_file("-Y 1 +X 10", &[]);
        rle_zero.extend_from_slice(&[2, 2, 0, 10, 0]);
        let cases: Vec<Vec<u8>> = vec![
            b"P6\n".to_vec(),
            b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n".to_vec(),
            b"#?RADIANCE\nFORMAT=32-bit_rle_xyze\n\n-Y 1 +X 1\n\0\0\0\0".to_vec(),
            flat_file("-Y 1 -Y 1", &[[0; 4]]),
            flat_file("-Y 1 +X", &[[0; 4]]),
            flat_file("-Y 99999999 +X 99999999", &[[0; 4]]),
            flat_file("-Y 2 +X 2", &[[1, 1, 1, 1], [0; 4], [0; 4], [0; 4]]),
            flat_file("-Y 1 +X 2", &[[5, 5, 5, 5], [1, 1, 1, 9]]),
            flat_file("-Y 0 +X 0", &[]),
            rle_bad_len,
            rle_overrun,
            rle_zero,
        ];
        for (i, bytes) in cases.into_iter().enumerate() {
            std::fs::write(&path, bytes).unwrap();
            let err = load_image(&path).expect_err(&format!("case {i}"));
            assert!(err.to_string().contains("b.hdr"), "{err}");
        }
    }
}
