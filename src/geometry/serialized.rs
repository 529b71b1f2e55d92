//! Mitsuba's `.serialized` meshes (versions 3 and 4 of the format).
//!
//! A file is one or more shapes, each a little-endian header (`0x041C`,
//! the version) followed by a zlib stream: flags, (version 4) the shape's
//! name, the vertex and triangle counts, positions, then normals, uvs and
//! colours where the flags say so, in single or double precision, and the
//! triangles' `u32` indices. A dictionary at the end of the file gives each
//! shape's offset (u64 in version 4, u32 in version 3) and their count, for
//! `shape_index`. Colours become the `vertex_color` attribute
//! (`parse_serialized_full`) that `mesh_attribute` textures read; Mitsuba
//! 3.9.1 reads them past.
//!
//! Counts in a header never make the loader allocate more than the
//! compressed data could hold (zlib expands at most ~1032:1).

use std::io::Read;
use std::path::Path;

use super::{MeshAttribute, MeshError, MeshFileError, TriangleMesh};
use crate::math::{Vec2, Vec3};

const MAGIC: u16 = 0x041C;
const HAS_NORMALS: u32 = 0x0001;
const HAS_TEXCOORDS: u32 = 0x0002;
const HAS_COLORS: u32 = 0x0008;
const DOUBLE_PRECISION: u32 = 0x2000;

/// zlib's largest expansion (a stream of one repeated byte), rounded up.
const MAX_INFLATE_RATIO: u64 = 1100;

/// Longest shape name read (version 4).
const MAX_NAME: usize = 4096;

/// Why `.serialized` bytes are no mesh.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SerializedError {
    #[error("{0}")]
    Malformed(String),
    #[error("{0}")]
    Invalid(MeshError),
}

fn malformed(message: impl Into<String>) -> SerializedError {
    SerializedError::Malformed(message.into())
}

/// Loads shape `shape_index` of a `.serialized` file.
pub fn load_serialized(path: &Path, shape_index: u32) -> Result<TriangleMesh, MeshFileError> {
    load_serialized_full(path, shape_index).map(|(mesh, _)| mesh)
}

/// [`load_serialized`] with the vertex colours as a `vertex_color`
/// attribute (as Mitsuba names them), if the shape has them.
pub fn load_serialized_full(
    path: &Path,
    shape_index: u32,
) -> Result<(TriangleMesh, Vec<MeshAttribute>), MeshFileError> {
    let bytes = super::read_mesh_file(path)?;
    parse_serialized_full(&bytes, shape_index).map_err(|e| match e {
        SerializedError::Malformed(message) => MeshFileError::Serialized {
            path: path.to_path_buf(),
            message,
        },
        SerializedError::Invalid(error) => MeshFileError::Invalid {
            path: path.to_path_buf(),
            error,
        },
    })
}

/// Parses shape `shape_index` of a `.serialized` file's bytes.
pub fn parse_serialized(bytes: &[u8], shape_index: u32) -> Result<TriangleMesh, SerializedError> {
    parse_serialized_full(bytes, shape_index).map(|(mesh, _)| mesh)
}

/// [`parse_serialized`] with the vertex colours.
pub fn parse_serialized_full(
    bytes: &[u8],
    shape_index: u32,
) -> Result<(TriangleMesh, Vec<MeshAttribute>), SerializedError> {
    let version = read_header(bytes, 0)?;
    let start = if shape_index == 0 {
        4
    } else {
        shape_offset(bytes, version, shape_index)? + 4
    };
    let compressed = &bytes[start..];
    let limit = (compressed.len() as u64).saturating_mul(MAX_INFLATE_RATIO);
    let mut z = Inflated {
        inner: flate2::read::ZlibDecoder::new(compressed),
        limit,
    };
    let flags = z.u32()?;
    if version == 4 {
        z.name()?;
    }
    let vertices = z.u64()?;
    let triangles = z.u64()?;
    let precision: u64 = if flags & DOUBLE_PRECISION != 0 { 8 } else { 4 };
    let mut per_vertex = 3;
    for (flag, dims) in [(HAS_NORMALS, 3), (HAS_TEXCOORDS, 2), (HAS_COLORS, 3)] {
        if flags & flag != 0 {
            per_vertex += dims;
        }
    }
    let needed = vertices
        .checked_mul(per_vertex * precision)
        .and_then(|v| triangles.checked_mul(12).and_then(|t| v.checked_add(t)));
    match needed {
        Some(n) if n <= z.limit => {}
        _ => {
            return Err(malformed(format!(
                "shape {shape_index} claims {vertices} vertices and {triangles} triangles, \
                 more than its {} compressed bytes can hold",
                compressed.len()
            )))
        }
    }
    if vertices > u32::MAX as u64 {
        return Err(malformed(format!(
            "shape {shape_index} has {vertices} vertices; lente reads at most 2^32"
        )));
    }
    let (nv, nt) = (vertices as usize, triangles as usize);
    let double = precision == 8;
    let positions = z.floats(nv * 3, double)?;
    let positions: Vec<Vec3> = positions.chunks_exact(3).map(Vec3::from_slice).collect();
    let normals: Vec<Vec3> = if flags & HAS_NORMALS != 0 {
        z.floats(nv * 3, double)?
            .chunks_exact(3)
            .map(|n| Vec3::from_slice(n).normalize_or_zero())
            .collect()
    } else {
        Vec::new()
    };
    let uvs: Vec<Vec2> = if flags & HAS_TEXCOORDS != 0 {
        z.floats(nv * 2, double)?
            .chunks_exact(2)
            .map(Vec2::from_slice)
            .collect()
    } else {
        Vec::new()
    };
    let mut attributes = Vec::new();
    if flags & HAS_COLORS != 0 {
        let values = z
            .floats(nv * 3, double)?
            .chunks_exact(3)
            .map(|c| {
                let c = Vec3::from_slice(c);
                if c.is_finite() {
                    c
                } else {
                    Vec3::ZERO
                }
            })
            .collect();
        attributes.push(MeshAttribute {
            name: "vertex_color".to_string(),
            per_vertex: true,
            channels: 3,
            values,
        });
    }
    let mut raw = vec![0u8; nt * 12];
    z.fill(&mut raw, "triangle indices")?;
    let indices = raw
        .chunks_exact(12)
        .map(|t| [0, 4, 8].map(|o| u32::from_le_bytes([t[o], t[o + 1], t[o + 2], t[o + 3]])))
        .collect();
    let mesh =
        TriangleMesh::new(positions, normals, uvs, indices).map_err(SerializedError::Invalid)?;
    Ok((mesh, attributes))
}

/// Checks the shape header at `at`; returns the format version (3 or 4).
fn read_header(bytes: &[u8], at: usize) -> Result<u16, SerializedError> {
    let h = bytes
        .get(at..at + 4)
        .ok_or_else(|| malformed("the file ends inside a shape header"))?;
    let magic = u16::from_le_bytes([h[0], h[1]]);
    let version = u16::from_le_bytes([h[2], h[3]]);
    if magic != MAGIC {
        return Err(malformed(format!(
            "not a Mitsuba .serialized mesh (header 0x{magic:04X} at byte {at}, expected 0x041C)"
        )));
    }
    if version != 3 && version != 4 {
        return Err(malformed(format!(
            "unsupported .serialized version {version} (Mitsuba 3 reads 3 and 4)"
        )));
    }
    Ok(version)
}

/// The byte offset of shape `index`, from the dictionary at the end.
fn shape_offset(bytes: &[u8], version: u16, index: u32) -> Result<usize, SerializedError> {
    let len = bytes.len();
    let tail =
        |from: usize, n: usize| -> Option<&[u8]> { bytes.get(len.checked_sub(from)?..)?.get(..n) };
    let count = tail(4, 4)
        .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
        .ok_or_else(|| malformed("the file is too short for its shape dictionary"))?;
    if index >= count {
        return Err(malformed(format!(
            "shape_index {index} is out of range: the file has {count} shape{}",
            if count == 1 { "" } else { "s" }
        )));
    }
    let back = (count - index) as usize;
    let offset = if version == 4 {
        back.checked_mul(8)
            .and_then(|b| tail(b + 4, 8))
            .map(|b| u64::from_le_bytes(b.try_into().expect("8 bytes")))
    } else {
        back.checked_add(1)
            .and_then(|b| b.checked_mul(4))
            .and_then(|b| tail(b, 4))
            .map(|b| u64::from(u32::from_le_bytes(b.try_into().expect("4 bytes"))))
    }
    .ok_or_else(|| malformed("the shape dictionary is longer than the file"))?;
    let offset = usize::try_from(offset)
        .ok()
        .filter(|&o| o < len)
        .ok_or_else(|| {
            malformed(format!(
                "shape {index} starts at byte {offset}, past the end"
            ))
        })?;
    let v = read_header(bytes, offset)?;
    if v != version {
        return Err(malformed(format!(
            "shape {index} has version {v}, the file's first shape {version}"
        )));
    }
    Ok(offset)
}

/// A shape's zlib stream, read with an upper bound on what it may expand to.
struct Inflated<'a> {
    inner: flate2::read::ZlibDecoder<&'a [u8]>,
    limit: u64,
}

impl Inflated<'_> {
    fn fill(&mut self, buf: &mut [u8], what: &str) -> Result<(), SerializedError> {
        self.inner.read_exact(buf).map_err(|e| {
            if e.kind() == std::io::ErrorKind::UnexpectedEof {
                malformed(format!("the compressed data ends inside the {what}"))
            } else {
                malformed(format!(
                    "the compressed data is corrupt ({e}) in the {what}"
                ))
            }
        })
    }

    fn u32(&mut self) -> Result<u32, SerializedError> {
        let mut b = [0; 4];
        self.fill(&mut b, "shape header")?;
        Ok(u32::from_le_bytes(b))
    }

    fn u64(&mut self) -> Result<u64, SerializedError> {
        let mut b = [0; 8];
        self.fill(&mut b, "shape header")?;
        Ok(u64::from_le_bytes(b))
    }

    /// Reads past the NUL-terminated shape name.
    fn name(&mut self) -> Result<(), SerializedError> {
        for _ in 0..MAX_NAME {
            let mut b = [0; 1];
            self.fill(&mut b, "shape name")?;
            if b[0] == 0 {
                return Ok(());
            }
        }
        Err(malformed(format!(
            "the shape name is longer than {MAX_NAME} bytes"
        )))
    }

    /// `n` values in single or double precision, as f32.
    fn floats(&mut self, n: usize, double: bool) -> Result<Vec<f32>, SerializedError> {
        let size = if double { 8 } else { 4 };
        let mut raw = vec![0u8; n * size];
        self.fill(&mut raw, "vertex data")?;
        Ok(if double {
            raw.chunks_exact(8)
                .map(|b| f64::from_le_bytes(b.try_into().expect("8 bytes")) as f32)
                .collect()
        } else {
            raw.chunks_exact(4)
                .map(|b| f32::from_le_bytes(b.try_into().expect("4 bytes")))
                .collect()
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    /// One shape's bytes: header and zlib stream.
    fn shape(version: u16, flags: u32, positions: &[f64], extra: &[f64], tris: &[u32]) -> Vec<u8> {
        let mut raw = Vec::new();
        raw.extend_from_slice(&flags.to_le_bytes());
        if version == 4 {
            raw.extend_from_slice(b"tri\0");
        }
        raw.extend_from_slice(&((positions.len() / 3) as u64).to_le_bytes());
        raw.extend_from_slice(&((tris.len() / 3) as u64).to_le_bytes());
        for &v in positions.iter().chain(extra) {
            if flags & DOUBLE_PRECISION != 0 {
                raw.extend_from_slice(&v.to_le_bytes());
            } else {
                raw.extend_from_slice(&(v as f32).to_le_bytes());
            }
        }
        for &i in tris {
            raw.extend_from_slice(&i.to_le_bytes());
        }
        let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
        z.write_all(&raw).unwrap();
        let mut out = MAGIC.to_le_bytes().to_vec();
        out.extend_from_slice(&version.to_le_bytes());
        out.extend(z.finish().unwrap());
        out
    }

    /// Shapes concatenated, with the end-of-file dictionary.
    fn file(version: u16, shapes: &[Vec<u8>]) -> Vec<u8> {
        let mut out = Vec::new();
        let mut offsets = Vec::new();
        for s in shapes {
            offsets.push(out.len() as u64);
            out.extend_from_slice(s);
        }
        for o in offsets {
            if version == 4 {
                out.extend_from_slice(&o.to_le_bytes());
            } else {
                out.extend_from_slice(&(o as u32).to_le_bytes());
            }
        }
        out.extend_from_slice(&(shapes.len() as u32).to_le_bytes());
        out
    }

    const TRI: [f64; 9] = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0];

    #[test]
    fn both_versions_precisions_and_shape_indices_read() {
        for version in [3, 4] {
            let quad = [0.0, 0.0, 1.0, 2.0, 0.0, 1.0, 2.0, 2.0, 1.0, 0.0, 2.0, 1.0];
            let normals = [0.0, 0.0, 2.0].repeat(4);
            let uvs = [0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0, 1.0];
            let colors = [0.5; 12];
            let extra: Vec<f64> = [&normals[..], &uvs, &colors].concat();
            let a = shape(version, 0x1000, &TRI, &[], &[0, 1, 2]);
            let b = shape(
                version,
                DOUBLE_PRECISION | HAS_NORMALS | HAS_TEXCOORDS | HAS_COLORS,
                &quad,
                &extra,
                &[0, 1, 2, 0, 2, 3],
            );
            let bytes = file(version, &[a, b]);
            let m0 = parse_serialized(&bytes, 0).unwrap();
            assert_eq!(m0.triangle_count(), 1);
            assert!(m0.normals().is_empty() && m0.uvs().is_empty());
            let m1 = parse_serialized(&bytes, 1).unwrap();
            assert_eq!(m1.triangle_count(), 2, "version {version}");
            assert_eq!(m1.positions()[2], Vec3::new(2.0, 2.0, 1.0));
            assert_eq!(m1.normals()[3], Vec3::Z, "normals are normalised");
            assert_eq!(m1.uvs()[2], Vec2::new(1.0, 1.0));
            assert!((m1.area() - 4.0).abs() < 1e-6);
            let err = parse_serialized(&bytes, 2).unwrap_err();
            assert!(err.to_string().contains("out of range"), "{err}");
        }
    }

    #[test]
    fn bad_files_are_errors_not_panics_or_huge_allocations() {
        let good = file(4, &[shape(4, 0x1000, &TRI, &[], &[0, 1, 2])]);
        assert!(parse_serialized(&good, 0).is_ok());
        let mut cases: Vec<(Vec<u8>, &str)> = vec![
            (b"\x1c".to_vec(), "ends inside"),
            (b"PK\x03\x04xxxx".to_vec(), "not a Mitsuba"),
            (b"\x1c\x04\x05\x00xxxx".to_vec(), "version 5"),
            (good[..good.len() / 2].to_vec(), "compressed data"),
        ];
        // Counts that ask for far more than the stream can hold.
        let mut raw = 0x1000u32.to_le_bytes().to_vec();
        raw.extend_from_slice(b"\0");
        raw.extend_from_slice(&(1u64 << 40).to_le_bytes());
        raw.extend_from_slice(&(1u64 << 40).to_le_bytes());
        let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
        z.write_all(&raw).unwrap();
        let mut huge = b"\x1c\x04\x04\x00".to_vec();
        huge.extend(z.finish().unwrap());
        cases.push((huge, "more than its"));
        for (bytes, needle) in cases {
            let err = parse_serialized(&bytes, 0).unwrap_err().to_string();
            assert!(err.contains(needle), "{needle}: {err}");
        }
        let two = file(
            4,
            &[
                good[..good.len() - 12].to_vec(),
                good[..good.len() - 12].to_vec(),
            ],
        );
        assert!(parse_serialized(&two, 1).is_ok());
        let mut broken = two.clone();
        let n = broken.len();
        broken[n - 12..n - 4].copy_from_slice(&u64::MAX.to_le_bytes());
        let err = parse_serialized(&broken, 1).unwrap_err().to_string();
        assert!(err.contains("past the end"), "{err}");
        let out_of_range = shape(3, 0x1000, &TRI, &[], &[0, 1, 7]);
        assert!(matches!(
            parse_serialized(&out_of_range, 0),
            Err(SerializedError::Invalid(MeshError::IndexOutOfRange { .. }))
        ));
    }
}
