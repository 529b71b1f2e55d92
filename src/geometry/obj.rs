//! Wavefront OBJ loading through tobj (from bytes read within the file
//! size bound; materials are not read).

use std::path::Path;

use super::{MeshError, MeshFileError, TriangleMesh};
use crate::math::{Vec2, Vec3};

/// Loads an OBJ file as one triangle mesh (all its objects merged).
/// Polygons are triangulated; positions, normals and uvs are unified into
/// one index per vertex. Missing normals leave `normals` empty, so the
/// geometric normal is used.
pub fn load_obj(path: &Path) -> Result<TriangleMesh, MeshFileError> {
    let bytes = super::read_mesh_file(path)?;
    parse_obj(&bytes).map_err(|e| match e {
        ObjError::Syntax(source) => MeshFileError::Obj {
            path: path.to_path_buf(),
            source,
        },
        ObjError::Face(line, message) => MeshFileError::ObjFace {
            path: path.to_path_buf(),
            line,
            message,
        },
        ObjError::Invalid(error) => MeshFileError::Invalid {
            path: path.to_path_buf(),
            error,
        },
    })
}

/// Why OBJ bytes are no mesh.
#[derive(Debug, thiserror::Error)]
pub enum ObjError {
    #[error("{0}")]
    Syntax(tobj::LoadError),
    /// A face refers to an element that does not exist (line, message).
    #[error("line {0}: {1}")]
    Face(usize, String),
    #[error("{0}")]
    Invalid(MeshError),
}

/// Parses the text of an OBJ file as one triangle mesh (see [`load_obj`]).
pub fn parse_obj(bytes: &[u8]) -> Result<TriangleMesh, ObjError> {
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ignore_points: true,
        ignore_lines: true,
    };
    check_face_indices(bytes)?;
    let no_materials = |_: &Path| Err(tobj::LoadError::OpenFileFailed);
    let (models, _) = tobj::load_obj_buf(&mut std::io::Cursor::new(bytes), &opts, no_materials)
        .map_err(ObjError::Syntax)?;
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    let mut uvs = Vec::new();
    let mut indices = Vec::new();
    let mut all_have_normals = true;
    let mut all_have_uvs = true;
    for m in &models {
        let mesh = &m.mesh;
        let nv = mesh.positions.len() / 3;
        all_have_normals &= mesh.normals.len() == nv * 3;
        all_have_uvs &= mesh.texcoords.len() == nv * 2;
    }
    for m in &models {
        let mesh = &m.mesh;
        let base = positions.len() as u32;
        let nv = mesh.positions.len() / 3;
        for i in 0..nv {
            positions.push(Vec3::new(
                mesh.positions[3 * i],
                mesh.positions[3 * i + 1],
                mesh.positions[3 * i + 2],
            ));
            if all_have_normals {
                normals.push(
                    Vec3::new(
                        mesh.normals[3 * i],
                        mesh.normals[3 * i + 1],
                        mesh.normals[3 * i + 2],
                    )
                    .normalize_or_zero(),
                );
            }
            if all_have_uvs {
                uvs.push(Vec2::new(mesh.texcoords[2 * i], mesh.texcoords[2 * i + 1]));
            }
        }
        for t in mesh.indices.chunks_exact(3) {
            // Out-of-range indices (saturating, never wrapping) are caught
            // by the mesh's own checks.
            indices.push([t[0], t[1], t[2]].map(|i| base.saturating_add(i)));
        }
    }
    TriangleMesh::new(positions, normals, uvs, indices).map_err(ObjError::Invalid)
}

/// Checks every face, line and point index before tobj sees them: an index
/// must be 1..=N of the file's N positions (uvs, normals), or -1..=-n of the
/// n defined so far. tobj turns others into wrapping arithmetic (a relative
/// index before the first uv overflowed its bounds check).
fn check_face_indices(bytes: &[u8]) -> Result<(), ObjError> {
    const KINDS: [&str; 3] = ["v", "vt", "vn"];
    const NAMES: [&str; 3] = ["positions", "texture coordinates", "normals"];
    let lines = || {
        bytes
            .split(|&b| b == b'\n')
            .map(|l| std::str::from_utf8(l).unwrap_or(""))
    };
    let mut total = [0i64; 3];
    for line in lines() {
        if let Some(k) = KINDS
            .iter()
            .position(|&k| line.split_whitespace().next() == Some(k))
        {
            total[k] += 1;
        }
    }
    let mut so_far = [0i64; 3];
    for (n, line) in lines().enumerate() {
        let mut tokens = line.split_whitespace();
        let Some(first) = tokens.next() else {
            continue;
        };
        if let Some(k) = KINDS.iter().position(|&k| first == k) {
            so_far[k] += 1;
            continue;
        }
        if !matches!(first, "f" | "l" | "p") {
            continue;
        }
        for token in tokens {
            for (k, part) in token.split('/').take(3).enumerate() {
                let Ok(i) = part.parse::<i64>() else {
                    continue; // empty (v//vn) or malformed: tobj's to judge
                };
                let ok = if i > 0 {
                    i <= total[k]
                } else {
                    i < 0 && -i <= so_far[k]
                };
                if !ok {
                    let (count, which) = if i > 0 {
                        (total[k], "in the file")
                    } else {
                        (so_far[k], "so far")
                    };
                    return Err(ObjError::Face(
                        n + 1,
                        format!(
                            "index {i} in '{token}' refers to none of the {count} {} {which}",
                            NAMES[k]
                        ),
                    ));
                }
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn face_indices_out_of_range_are_errors_at_their_line() {
        let head = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\n";
        for (face, needle) in [
            (
                "f 1 2 4",
                "index 4 in '4' refers to none of the 3 positions in the file",
            ),
            ("f -1 -2 -4", "index -4 in '-4'"),
            ("f 1/2 2/1 3/1", "texture coordinates"),
            ("f 1//-2 2//1 3//1", "normals so far"),
            ("f 0 1 2", "index 0"),
            ("f 1/-9223372036854775807 2 3", "texture coordinates"),
        ] {
            let text = format!("{head}{face}\n");
            match parse_obj(text.as_bytes()) {
                Err(ObjError::Face(6, m)) => assert!(m.contains(needle), "{face}: {m}"),
                other => panic!("{face}: {other:?}"),
            }
        }
        let good = format!("{head}f 1/1/1 2/-1/-1 -1/1/1\n");
        assert_eq!(parse_obj(good.as_bytes()).unwrap().triangle_count(), 1);
        // Positive indices may refer to vertices defined later (tobj
        // resolves them at the end), relative ones may not.
        let forward = "f 1 2 3\nv 0 0 0\nv 1 0 0\nv 0 1 0\n";
        assert!(parse_obj(forward.as_bytes()).is_ok());
        assert!(parse_obj(b"f -1 -2 -3\nv 0 0 0\nv 1 0 0\nv 0 1 0\n").is_err());
    }
}
