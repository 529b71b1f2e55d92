//! Wavefront OBJ loading through tobj.

use std::path::Path;

use super::TriangleMesh;
use crate::math::{Vec2, Vec3};

/// Loads an OBJ file as one triangle mesh (all its objects merged).
/// Polygons are triangulated; positions, normals and uvs are unified into
/// one index per vertex. Missing normals leave `normals` empty, so the
/// geometric normal is used.
pub fn load_obj(path: &Path) -> Result<TriangleMesh, String> {
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: true,
        ignore_points: true,
        ignore_lines: true,
    };
    let (models, _) = tobj::load_obj(path, &opts)
        .map_err(|e| format!("cannot read OBJ file '{}': {e}", path.display()))?;
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
            let tri = [base + t[0], base + t[1], base + t[2]];
            if tri.iter().any(|&i| i as usize >= positions.len()) {
                return Err(format!(
                    "OBJ file '{}' has a face index out of range",
                    path.display()
                ));
            }
            indices.push(tri);
        }
    }
    if indices.is_empty() {
        return Err(format!("OBJ file '{}' contains no faces", path.display()));
    }
    if positions.iter().any(|p| !p.is_finite()) {
        return Err(format!(
            "OBJ file '{}' has a vertex that is not a finite number",
            path.display()
        ));
    }
    Ok(TriangleMesh::new(positions, normals, uvs, indices))
}
