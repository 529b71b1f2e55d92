//! Wavefront OBJ loading through tobj.

use std::path::Path;

use super::{MeshFileError, TriangleMesh};
use crate::math::{Vec2, Vec3};

/// Loads an OBJ file as one triangle mesh (all its objects merged).
/// Polygons are triangulated; positions, normals and uvs are unified into
/// one index per vertex. Missing normals leave `normals` empty, so the
/// geometric normal is used.
pub fn load_obj(path: &Path) -> Result<TriangleMesh, MeshFileError> {
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ignore_points: true,
        ignore_lines: true,
    };
    let (models, _) = tobj::load_obj(path, &opts).map_err(|source| MeshFileError::Obj {
        path: path.to_path_buf(),
        source,
    })?;
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
    TriangleMesh::new(positions, normals, uvs, indices).map_err(|error| MeshFileError::Invalid {
        path: path.to_path_buf(),
        error,
    })
}
