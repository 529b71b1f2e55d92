//! Portable float map: `PF` (RGB) or `Pf` (grey), a text header
//! `PF\n<width> <height>\n<scale>\n`, then 32-bit floats, rows bottom to top.
//! A negative scale means little-endian data, a positive one big-endian.

use super::Malformed;
use super::RawImage;
use crate::image::Bitmap;

/// Reads the next whitespace-separated header token starting at `*pos`.
fn token<'a>(bytes: &'a [u8], pos: &mut usize, what: &str) -> Result<&'a str, Malformed> {
    while *pos < bytes.len() && bytes[*pos].is_ascii_whitespace() {
        *pos += 1;
    }
    let start = *pos;
    while *pos < bytes.len() && !bytes[*pos].is_ascii_whitespace() && *pos - start < 64 {
        *pos += 1;
    }
    if start == *pos {
        return Err(Malformed::from(format!(
            "PFM header ends before the {what}"
        )));
    }
    std::str::from_utf8(&bytes[start..*pos])
        .map_err(|_| Malformed(format!("PFM header: {what} is not text")))
}

pub(super) fn decode(bytes: &[u8]) -> Result<RawImage, Malformed> {
    let mut pos = 0;
    let magic = token(bytes, &mut pos, "'PF' or 'Pf' signature")?;
    let channels = match magic {
        "PF" => 3,
        "Pf" => 1,
        _ => {
            return Err(Malformed::from(format!(
                "not a PFM file: starts with '{}' instead of 'PF' or 'Pf'",
                magic.escape_default()
            )))
        }
    };
    let parse_dim = |s: &str, what: &str| {
        s.parse::<usize>()
            .map_err(|_| format!("PFM header: bad {what} '{}'", s.escape_default()))
    };
    let width = parse_dim(token(bytes, &mut pos, "width")?, "width")?;
    let height = parse_dim(token(bytes, &mut pos, "height")?, "height")?;
    super::check_size(width, height)?;
    let scale_text = token(bytes, &mut pos, "scale")?;
    let scale: f32 = scale_text
        .parse()
        .map_err(|_| format!("PFM header: bad scale '{}'", scale_text.escape_default()))?;
    if scale == 0.0 || !scale.is_finite() {
        return Err(Malformed::from(format!(
            "PFM header: scale must be a non-zero number, found {scale_text}"
        )));
    }
    let little_endian = scale < 0.0;
    // Exactly one whitespace character separates the header from the data.
    match bytes.get(pos) {
        Some(b) if b.is_ascii_whitespace() => pos += 1,
        _ => return Err(Malformed::from("PFM header is not followed by pixel data")),
    }
    let values = width
        .checked_mul(height)
        .and_then(|n| n.checked_mul(channels))
        .filter(|n| n.checked_mul(4).is_some())
        .ok_or_else(|| format!("PFM size {width}x{height} is too large"))?;
    let data = &bytes[pos..];
    if data.len() < values * 4 {
        return Err(Malformed::from(format!(
            "PFM file is truncated: {width}x{height}x{channels} needs {} bytes of pixel data, found {}",
            values * 4,
            data.len()
        )));
    }
    let row = width * channels;
    let mut out = Vec::with_capacity(values);
    // Rows are stored bottom to top: emit the last stored row first.
    for y in (0..height).rev() {
        let row_bytes = &data[y * row * 4..(y + 1) * row * 4];
        out.extend(row_bytes.chunks_exact(4).map(|b| {
            let b = [b[0], b[1], b[2], b[3]];
            if little_endian {
                f32::from_le_bytes(b)
            } else {
                f32::from_be_bytes(b)
            }
        }));
    }
    Ok(RawImage {
        width,
        height,
        channels,
        data: out,
    })
}

/// Colour PFM, little-endian (scale -1).
pub(super) fn encode(image: &Bitmap) -> Vec<u8> {
    let header = format!("PF\n{} {}\n-1\n", image.width, image.height);
    let mut out = Vec::with_capacity(header.len() + image.pixels.len() * 12);
    out.extend_from_slice(header.as_bytes());
    for row in image.pixels.chunks_exact(image.width).rev() {
        for p in row {
            for v in p.to_array() {
                out.extend_from_slice(&v.to_le_bytes());
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::super::test_util::test_image;
    use super::super::{load_image, save_image};
    use crate::color::Rgb;

    /// Writes a PFM by hand (independently of the encoder above).
    fn write_pfm(values_top_first: &[Vec<f32>], channels: usize, little_endian: bool) -> Vec<u8> {
        let height = values_top_first.len();
        let width = values_top_first[0].len() / channels;
        let magic = if channels == 3 { "PF" } else { "Pf" };
        let scale = if little_endian { "-1.0" } else { "1.0" };
        let mut out = format!("{magic}\n{width} {height}\n{scale}\n").into_bytes();
        for row in values_top_first.iter().rev() {
            for v in row {
                if little_endian {
                    out.extend_from_slice(&v.to_le_bytes());
                } else {
                    out.extend_from_slice(&v.to_be_bytes());
                }
            }
        }
        out
    }

    #[test]
    fn pfm_round_trip_is_exact() {
        let dir = tempfile::tempdir().unwrap();
        let mut img = test_image(7, 5);
        img.set(6, 4, Rgb::new(1e-30, 3.0e30, 0.1));
        let path = dir.path().join("rt.pfm");
        save_image(&path, &img).unwrap();
        let bytes = std::fs::read(&path).unwrap();
        assert!(bytes.starts_with(b"PF\n7 5\n-1\n"));
        let (back, warnings) = load_image(&path).unwrap();
        assert!(warnings.is_empty());
        assert_eq!(back, img);
    }

    #[test]
    fn pfm_reads_both_byte_orders_colour_and_grey_bottom_up() {
        let dir = tempfile::tempdir().unwrap();
        // 3 wide, 2 high; top row first here.
        let rgb = vec![
            vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0],
            vec![0.5, 0.25, 0.125, 1e-3, 1e3, 1e-20, 0.0, 1.5, 2.5],
        ];
        let grey = vec![vec![0.1, 0.2, 0.3], vec![4.0, 5.0, 6.5]];
        for le in [true, false] {
            let path = dir.path().join("c.pfm");
            std::fs::write(&path, write_pfm(&rgb, 3, le)).unwrap();
            let (img, w) = load_image(&path).unwrap();
            assert!(w.is_empty());
            assert_eq!((img.width, img.height), (3, 2));
            for (y, row) in rgb.iter().enumerate() {
                for (x, r) in row.chunks_exact(3).enumerate() {
                    assert_eq!(img.get(x, y), Rgb::new(r[0], r[1], r[2]), "le={le}");
                }
            }
            let path = dir.path().join("g.pfm");
            std::fs::write(&path, write_pfm(&grey, 1, le)).unwrap();
            let (img, _) = load_image(&path).unwrap();
            assert_eq!((img.width, img.height), (3, 2));
            for (y, row) in grey.iter().enumerate() {
                for (x, &v) in row.iter().enumerate() {
                    assert_eq!(img.get(x, y), Rgb::splat(v), "le={le}");
                }
            }
        }
    }

    #[test]
    fn pfm_bad_headers_are_errors() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("b.pfm");
        let cases: [&[u8]; 7] = [
            b"P6\n1 1\n255\n\0\0\0",
            b"PF\n-1 1\n-1\n",
            b"PF\n1 1\n0\n\0\0\0\0\0\0\0\0\0\0\0\0",
            b"PF\n1 1\nnan\n\0\0\0\0\0\0\0\0\0\0\0\0",
            b"PF\n1 1\n-1",
            b"PF\n99999999999 99999999999\n-1\n",
            b"PF\n2 2\n-1\n\0\0\0\0",
        ];
        for bytes in cases {
            std::fs::write(&path, bytes).unwrap();
            let err = load_image(&path).unwrap_err();
            assert!(err.to_string().starts_with(&path.display().to_string()));
        }
    }
}
