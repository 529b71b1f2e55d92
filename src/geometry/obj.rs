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
    let bytes = crate::limits::read_file(path, crate::limits::MAX_DATA_FILE_BYTES, "mesh files")
        .map_err(|source| MeshFileError::Read {
            path: path.to_path_buf(),
            source,
        })?;
    parse_obj(&bytes).map_err(|e| match e {
        ObjError::Syntax(source) => MeshFileError::Obj {
            path: path.to_path_buf(),
            source,
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
