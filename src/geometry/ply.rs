//! Stanford PLY meshes: ASCII, binary little- and big-endian.
//!
//! Reads the `vertex` element's `x y z`, optional normals `nx ny nz` and
//! texture coordinates (`u v`, `s t`, `texture_u texture_v` or
//! `texture_s texture_t`), and the `face` element's index list
//! (`vertex_indices` or `vertex_index`, any integer count and item types).
//! Polygons are fan-triangulated. Other numeric vertex and face properties
//! become [`MeshAttribute`]s as Mitsuba 3 groups them (`parse_ply_full`);
//! every other element and property is read past and ignored. A malformed file is an error naming the file and what
//! is wrong with it, never a panic, and counts in the header never make the
//! loader allocate more than the file can hold.

use std::path::Path;

use super::attribute::{group_fields, MeshAttribute};
use super::{MeshError, MeshFileError, TriangleMesh};
use crate::color::Rgb;
use crate::math::{Vec2, Vec3};

/// Loads a PLY file as a triangle mesh.
pub fn load_ply(path: &Path) -> Result<TriangleMesh, MeshFileError> {
    load_ply_full(path).map(|(mesh, _)| mesh)
}

/// Why PLY bytes are no mesh.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum PlyError {
    /// The file breaks the format (message: what and where).
    #[error("{0}")]
    Malformed(String),
    /// The file is well-formed but its mesh is not valid.
    #[error("the mesh {0}")]
    Invalid(MeshError),
}

impl From<String> for PlyError {
    fn from(message: String) -> Self {
        PlyError::Malformed(message)
    }
}

impl From<&str> for PlyError {
    fn from(message: &str) -> Self {
        PlyError::Malformed(message.to_string())
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Format {
    Ascii,
    BinaryLe,
    BinaryBe,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(name: &str) -> Option<Scalar> {
        Some(match name {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    fn is_integer(self) -> bool {
        !matches!(self, Scalar::F32 | Scalar::F64)
    }
}

#[derive(Clone, Debug)]
enum PropType {
    Scalar(Scalar),
    List { count: Scalar, item: Scalar },
}

#[derive(Clone, Debug)]
struct Property {
    name: String,
    ty: PropType,
}

#[derive(Clone, Debug)]
struct Element {
    name: String,
    count: usize,
    props: Vec<Property>,
}

struct Header {
    format: Format,
    elements: Vec<Element>,
    /// Byte offset where the body starts.
    body: usize,
}

fn parse_header(bytes: &[u8]) -> Result<Header, PlyError> {
    let mut pos = 0;
    let mut line_no = 0;
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    loop {
        if pos >= bytes.len() {
            return Err(PlyError::from("the header has no 'end_header' line"));
        }
        let end = bytes[pos..]
            .iter()
            .position(|&b| b == b'\n')
            .map_or(bytes.len(), |i| pos + i);
        let line = std::str::from_utf8(&bytes[pos..end])
            .map_err(|_| format!("header line {} is not text", line_no + 1))?;
        let line = line.trim_end_matches('\r');
        pos = (end + 1).min(bytes.len());
        line_no += 1;
        let words: Vec<&str> = line.split_whitespace().collect();
        if line_no == 1 {
            if line.trim() != "ply" {
                return Err(PlyError::from(format!(
                    "the file does not start with 'ply' (found '{}')",
                    shorten(line)
                )));
            }
            continue;
        }
        let err = |what: &str| format!("header line {line_no}: {what} (found '{}')", shorten(line));
        match words.first().copied() {
            None | Some("comment") | Some("obj_info") => {}
            Some("format") => {
                if words.len() != 3 {
                    return Err(PlyError::from(err("expected 'format <type> 1.0'")));
                }
                format = Some(match words[1] {
                    "ascii" => Format::Ascii,
                    "binary_little_endian" => Format::BinaryLe,
                    "binary_big_endian" => Format::BinaryBe,
                    _ => return Err(PlyError::from(err(
                        "unknown format; expected ascii, binary_little_endian or binary_big_endian",
                    ))),
                });
            }
            Some("element") => {
                if words.len() != 3 {
                    return Err(PlyError::from(err("expected 'element <name> <count>'")));
                }
                let count = words[2]
                    .parse::<usize>()
                    .map_err(|_| err("the element count is not a non-negative integer"))?;
                elements.push(Element {
                    name: words[1].to_string(),
                    count,
                    props: Vec::new(),
                });
            }
            Some("property") => {
                let Some(el) = elements.last_mut() else {
                    return Err(PlyError::from(err("a property before any element")));
                };
                let prop = if words.get(1) == Some(&"list") {
                    if words.len() != 5 {
                        return Err(PlyError::from(err(
                            "expected 'property list <count type> <item type> <name>'",
                        )));
                    }
                    let count = Scalar::parse(words[2]).ok_or_else(|| err("unknown count type"))?;
                    let item = Scalar::parse(words[3]).ok_or_else(|| err("unknown item type"))?;
                    if !count.is_integer() {
                        return Err(PlyError::from(err(
                            "a list count must have an integer type",
                        )));
                    }
                    Property {
                        name: words[4].to_string(),
                        ty: PropType::List { count, item },
                    }
                } else {
                    if words.len() != 3 {
                        return Err(PlyError::from(err("expected 'property <type> <name>'")));
                    }
                    let ty = Scalar::parse(words[1]).ok_or_else(|| err("unknown property type"))?;
                    Property {
                        name: words[2].to_string(),
                        ty: PropType::Scalar(ty),
                    }
                };
                el.props.push(prop);
            }
            Some("end_header") => break,
            Some(_) => return Err(PlyError::from(err("unknown header keyword"))),
        }
    }
    let format = format.ok_or("the header has no 'format' line")?;
    Ok(Header {
        format,
        elements,
        body: pos,
    })
}

fn shorten(s: &str) -> String {
    let mut out: String = s.chars().take(40).collect();
    if s.chars().count() > 40 {
        out.push_str("...");
    }
    out
}

/// Reads values from the body, whatever its encoding.
enum Reader<'b> {
    Ascii {
        /// The text not read yet.
        rest: &'b str,
        /// Values read so far (for messages).
        read: usize,
    },
    Binary {
        bytes: &'b [u8],
        pos: usize,
        big_endian: bool,
    },
}

impl<'b> Reader<'b> {
    fn new(bytes: &'b [u8], header: &Header) -> Result<Reader<'b>, PlyError> {
        let body = &bytes[header.body.min(bytes.len())..];
        Ok(match header.format {
            Format::Ascii => Reader::Ascii {
                rest: std::str::from_utf8(body)
                    .map_err(|_| "the ASCII body is not text".to_string())?,
                read: 0,
            },
            Format::BinaryLe | Format::BinaryBe => Reader::Binary {
                bytes: body,
                pos: 0,
                big_endian: header.format == Format::BinaryBe,
            },
        })
    }

    /// Bytes still to come: an upper bound on the values left (each takes
    /// at least one byte), to check header counts before trusting them.
    fn remaining(&self) -> usize {
        match self {
            Reader::Ascii { rest, .. } => rest.len(),
            Reader::Binary { bytes, pos, .. } => bytes.len() - pos,
        }
    }

    fn value(&mut self, ty: Scalar) -> Result<f64, PlyError> {
        match self {
            Reader::Ascii { rest, read } => {
                let text = rest.trim_start_matches(|c: char| c.is_ascii_whitespace());
                let end = text
                    .find(|c: char| c.is_ascii_whitespace())
                    .unwrap_or(text.len());
                let tok = &text[..end];
                *rest = &text[end..];
                if tok.is_empty() {
                    return Err(PlyError::from("the file ends before all elements are read"));
                }
                *read += 1;
                let v = if ty.is_integer() {
                    tok.parse::<i64>().map(|v| v as f64).map_err(|_| ())
                } else {
                    tok.parse::<f64>().map_err(|_| ())
                };
                v.map_err(|_| {
                    PlyError::Malformed(format!(
                        "value {} of the body ('{}') is not a valid {}",
                        read,
                        shorten(tok),
                        if ty.is_integer() { "integer" } else { "number" }
                    ))
                })
            }
            Reader::Binary {
                bytes,
                pos,
                big_endian,
            } => {
                let n = ty.size();
                let Some(raw) = bytes.get(*pos..*pos + n) else {
                    return Err(PlyError::from("the file ends before all elements are read"));
                };
                *pos += n;
                let mut b = [0u8; 8];
                b[..n].copy_from_slice(raw);
                if *big_endian {
                    b[..n].reverse();
                }
                Ok(match ty {
                    Scalar::I8 => b[0] as i8 as f64,
                    Scalar::U8 => b[0] as f64,
                    Scalar::I16 => i16::from_le_bytes([b[0], b[1]]) as f64,
                    Scalar::U16 => u16::from_le_bytes([b[0], b[1]]) as f64,
                    Scalar::I32 => i32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
                    Scalar::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
                    Scalar::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
                    Scalar::F64 => f64::from_le_bytes(b),
                })
            }
        }
    }

    /// Skips `n` values of type `ty`.
    fn skip(&mut self, ty: Scalar, n: usize) -> Result<(), PlyError> {
        match self {
            Reader::Binary { bytes, pos, .. } => {
                let len = n
                    .checked_mul(ty.size())
                    .filter(|&l| *pos + l <= bytes.len())
                    .ok_or("the file ends before all elements are read")?;
                *pos += len;
                Ok(())
            }
            Reader::Ascii { .. } => {
                for _ in 0..n {
                    self.value(ty)?;
                }
                Ok(())
            }
        }
    }

    fn list_count(&mut self, ty: Scalar) -> Result<usize, PlyError> {
        let c = self.value(ty)?;
        if c < 0.0 || c.fract() != 0.0 {
            return Err(PlyError::from(format!(
                "a list has a negative length ({c})"
            )));
        }
        Ok(c as usize)
    }
}

/// Parses a whole PLY file held in memory.
pub fn parse_ply(bytes: &[u8]) -> Result<TriangleMesh, PlyError> {
    parse_ply_full(bytes).map(|(mesh, _)| mesh)
}

/// Loads a PLY file with its vertex and face attributes.
pub fn load_ply_full(path: &Path) -> Result<(TriangleMesh, Vec<MeshAttribute>), MeshFileError> {
    let bytes = super::read_mesh_file(path)?;
    parse_ply_full(&bytes).map_err(|e| match e {
        PlyError::Malformed(message) => MeshFileError::Ply {
            path: path.to_path_buf(),
            message,
        },
        PlyError::Invalid(error) => MeshFileError::Invalid {
            path: path.to_path_buf(),
            error,
        },
    })
}

/// [`parse_ply`] with the vertex and face attributes.
pub fn parse_ply_full(bytes: &[u8]) -> Result<(TriangleMesh, Vec<MeshAttribute>), PlyError> {
    let header = parse_header(bytes)?;
    let mut r = Reader::new(bytes, &header)?;
    let mut positions: Vec<Vec3> = Vec::new();
    let mut normals: Vec<Vec3> = Vec::new();
    let mut uvs: Vec<Vec2> = Vec::new();
    let mut indices: Vec<[u32; 3]> = Vec::new();
    let mut attributes: Vec<MeshAttribute> = Vec::new();
    let mut seen_vertex = false;
    let mut seen_face = false;

    for el in &header.elements {
        // Each record takes at least one byte or token: a count larger
        // than what is left is a truncated (or lying) file.
        let min_record = if el.props.is_empty() { 0 } else { 1 };
        if el.count.saturating_mul(min_record) > r.remaining() {
            return Err(PlyError::Malformed(format!(
                "the header announces {} '{}' elements, more than the file holds",
                el.count, el.name
            )));
        }
        match el.name.as_str() {
            "vertex" if !seen_vertex => {
                seen_vertex = true;
                read_vertices(
                    &mut r,
                    el,
                    &mut positions,
                    &mut normals,
                    &mut uvs,
                    &mut attributes,
                )?;
            }
            "face" if !seen_face => {
                seen_face = true;
                if !seen_vertex {
                    return Err(PlyError::Malformed(
                        "the 'face' element comes before the 'vertex' element".into(),
                    ));
                }
                read_faces(&mut r, el, positions.len(), &mut indices, &mut attributes)?;
            }
            "vertex" | "face" => {
                return Err(PlyError::Malformed(format!(
                    "the file has more than one '{}' element",
                    el.name
                )))
            }
            _ => skip_element(&mut r, el)?,
        }
    }
    if !seen_vertex {
        return Err(PlyError::Malformed(
            "the file has no 'vertex' element".into(),
        ));
    }
    let mesh = TriangleMesh::new(positions, normals, uvs, indices).map_err(PlyError::Invalid)?;
    Ok((mesh, attributes))
}

/// The attributes of an element's records: what [`group_fields`] makes of
/// its numeric properties that are not `reserved`.
fn attribute_groups(
    el: &Element,
    reserved: &[usize],
    kind: &str,
) -> Vec<(MeshAttribute, Vec<usize>)> {
    let names: Vec<&str> = el.props.iter().map(|p| p.name.as_str()).collect();
    let taken: Vec<bool> = (0..names.len())
        .map(|i| reserved.contains(&i) || matches!(el.props[i].ty, PropType::List { .. }))
        .collect();
    group_fields(&names, &taken)
        .into_iter()
        .map(|(name, fields)| {
            let attribute = MeshAttribute {
                name: format!("{kind}_{name}"),
                per_vertex: kind == "vertex",
                channels: fields.len(),
                values: Vec::new(),
            };
            (attribute, fields)
        })
        .collect()
}

/// The attribute value of one record (a single channel in all three;
/// values that are not finite read as 0).
fn attribute_value(values: &[f64], fields: &[usize]) -> Rgb {
    let v = |k: usize| {
        let x = values[fields[k]] as f32;
        if x.is_finite() {
            x
        } else {
            0.0
        }
    };
    match fields.len() {
        1 => Rgb::splat(v(0)),
        _ => Rgb::new(v(0), v(1), v(2)),
    }
}

fn skip_element(r: &mut Reader, el: &Element) -> Result<(), PlyError> {
    for _ in 0..el.count {
        for p in &el.props {
            match p.ty {
                PropType::Scalar(t) => r.skip(t, 1)?,
                PropType::List { count, item } => {
                    let n = r.list_count(count)?;
                    r.skip(item, n)?;
                }
            }
        }
    }
    Ok(())
}

fn read_vertices(
    r: &mut Reader,
    el: &Element,
    positions: &mut Vec<Vec3>,
    normals: &mut Vec<Vec3>,
    uvs: &mut Vec<Vec2>,
    attributes: &mut Vec<MeshAttribute>,
) -> Result<(), PlyError> {
    let find = |name: &str| el.props.iter().position(|p| p.name == name);
    let (Some(ix), Some(iy), Some(iz)) = (find("x"), find("y"), find("z")) else {
        return Err(PlyError::from(
            "the 'vertex' element lacks one of the properties x, y, z",
        ));
    };
    let normal_idx = match (find("nx"), find("ny"), find("nz")) {
        (Some(a), Some(b), Some(c)) => Some([a, b, c]),
        _ => None,
    };
    let uv_idx = [
        ("u", "v"),
        ("s", "t"),
        ("texture_u", "texture_v"),
        ("texture_s", "texture_t"),
    ]
    .iter()
    .find_map(|(a, b)| Some([find(a)?, find(b)?]));
    let used: Vec<usize> = [ix, iy, iz]
        .into_iter()
        .chain(normal_idx.into_iter().flatten())
        .chain(uv_idx.into_iter().flatten())
        .collect();
    let mut groups = attribute_groups(el, &used, "vertex");
    for &i in &used {
        if matches!(el.props[i].ty, PropType::List { .. }) {
            return Err(PlyError::from(format!(
                "vertex property '{}' must be a number, not a list",
                el.props[i].name
            )));
        }
    }
    let mut values = vec![0.0f64; el.props.len()];
    // The count was checked against the file size, so this cannot be huge.
    positions.reserve(el.count);
    for i in 0..el.count {
        for (k, p) in el.props.iter().enumerate() {
            match p.ty {
                PropType::Scalar(t) => values[k] = r.value(t)?,
                PropType::List { count, item } => {
                    let n = r.list_count(count)?;
                    r.skip(item, n)?;
                }
            }
        }
        let p = Vec3::new(values[ix] as f32, values[iy] as f32, values[iz] as f32);
        if !p.is_finite() {
            return Err(PlyError::from(format!("vertex {i} is not a finite point")));
        }
        positions.push(p);
        if let Some([a, b, c]) = normal_idx {
            let n = Vec3::new(values[a] as f32, values[b] as f32, values[c] as f32);
            normals.push(if n.is_finite() {
                n.normalize_or_zero()
            } else {
                Vec3::ZERO
            });
        }
        if let Some([a, b]) = uv_idx {
            let uv = Vec2::new(values[a] as f32, values[b] as f32);
            uvs.push(if uv.is_finite() { uv } else { Vec2::ZERO });
        }
        for (a, fields) in &mut groups {
            a.values.push(attribute_value(&values, fields));
        }
    }
    attributes.extend(groups.into_iter().map(|(a, _)| a));
    Ok(())
}

fn read_faces(
    r: &mut Reader,
    el: &Element,
    vertex_count: usize,
    indices: &mut Vec<[u32; 3]>,
    attributes: &mut Vec<MeshAttribute>,
) -> Result<(), PlyError> {
    let Some(list) = el
        .props
        .iter()
        .position(|p| p.name == "vertex_indices")
        .or_else(|| el.props.iter().position(|p| p.name == "vertex_index"))
    else {
        return Err(PlyError::from(
            "the 'face' element has no 'vertex_indices' (or 'vertex_index') list",
        ));
    };
    if !matches!(el.props[list].ty, PropType::List { .. }) {
        return Err(PlyError::from(format!(
            "the face property '{}' must be a list",
            el.props[list].name
        )));
    }
    indices.reserve(el.count);
    let mut groups = attribute_groups(el, &[list], "face");
    let mut values = vec![0.0f64; el.props.len()];
    let mut poly: Vec<u32> = Vec::new();
    for f in 0..el.count {
        let triangles_before = indices.len();
        for (k, p) in el.props.iter().enumerate() {
            match p.ty {
                PropType::Scalar(t) if groups.is_empty() => r.skip(t, 1)?,
                PropType::Scalar(t) => values[k] = r.value(t)?,
                PropType::List { count, item } if k == list => {
                    let n = r.list_count(count)?;
                    if n < 3 {
                        return Err(PlyError::from(format!(
                            "face {f} has {n} vertices (at least 3 are needed)"
                        )));
                    }
                    if n > r.remaining() {
                        return Err(PlyError::from("the file ends before all elements are read"));
                    }
                    if !item.is_integer() {
                        return Err(PlyError::from("face indices must have an integer type"));
                    }
                    poly.clear();
                    for _ in 0..n {
                        let v = r.value(item)?;
                        if v < 0.0 || v >= vertex_count as f64 {
                            return Err(PlyError::from(format!(
                                "face {f} refers to vertex {v}, but there are {vertex_count} vertices"
                            )));
                        }
                        poly.push(v as u32);
                    }
                    for j in 1..n - 1 {
                        indices.push([poly[0], poly[j], poly[j + 1]]);
                    }
                }
                PropType::List { count, item } => {
                    let n = r.list_count(count)?;
                    r.skip(item, n)?;
                }
            }
        }
        // A polygon's value on each of its triangles.
        for (a, fields) in &mut groups {
            let v = attribute_value(&values, fields);
            a.values
                .extend(std::iter::repeat_n(v, indices.len() - triangles_before));
        }
    }
    attributes.extend(groups.into_iter().map(|(a, _)| a));
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ascii_quad_is_fan_triangulated() {
        let ply = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n";
        let m = parse_ply(ply.as_bytes()).unwrap();
        assert_eq!(m.indices(), [[0, 1, 2], [0, 2, 3]]);
        assert!((m.area() - 1.0).abs() < 1e-6);
    }

    #[test]
    fn huge_counts_do_not_allocate() {
        let ply = "ply\nformat binary_little_endian 1.0\nelement vertex 4000000000000\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
        let e = parse_ply(ply.as_bytes()).unwrap_err();
        assert!(e.to_string().contains("more than the file holds"), "{e}");
    }
}
