//! Mitsuba's `mesh_attribute`: a texture that reads a mesh's per-vertex
//! (interpolated with the hit's barycentrics) or per-face data by name,
//! times `scale`. The loader binds it to the attribute of the mesh whose
//! BSDF holds it ([`MeshAttributeTexture::bind`]); until then it reads 0.

use std::sync::Arc;

use super::SurfacePoint;
use crate::color::Rgb;
use crate::geometry::MeshAttribute;

#[derive(Clone, Debug, PartialEq)]
pub struct MeshAttributeTexture {
    /// `vertex_...` or `face_...`.
    pub name: String,
    pub scale: f32,
    values: Arc<Values>,
}

/// The attribute laid out per triangle, so a lookup needs no indices.
#[derive(Debug, PartialEq)]
enum Values {
    Unbound,
    /// The three corners' values of each triangle.
    PerCorner(Vec<[Rgb; 3]>),
    PerTriangle(Vec<Rgb>),
}

/// Why a texture cannot be bound to a mesh.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum BindError {
    #[error("the mesh has no attribute '{name}' (it has: {available})")]
    Missing { name: String, available: String },
}

impl MeshAttributeTexture {
    pub fn new(name: String, scale: f32) -> MeshAttributeTexture {
        MeshAttributeTexture {
            name,
            scale,
            values: Arc::new(Values::Unbound),
        }
    }

    /// Reads this texture's attribute from `attributes` of a mesh with
    /// triangles `indices`.
    pub fn bind(
        &mut self,
        attributes: &[MeshAttribute],
        indices: &[[u32; 3]],
    ) -> Result<(), BindError> {
        let Some(a) = attributes.iter().find(|a| a.name == self.name) else {
            let names: Vec<&str> = attributes.iter().map(|a| a.name.as_str()).collect();
            return Err(BindError::Missing {
                name: self.name.clone(),
                available: if names.is_empty() {
                    "none".to_string()
                } else {
                    names.join(", ")
                },
            });
        };
        let at = |i: u32| a.values.get(i as usize).copied().unwrap_or(Rgb::ZERO);
        let values = if a.per_vertex {
            Values::PerCorner(indices.iter().map(|t| t.map(at)).collect())
        } else {
            Values::PerTriangle((0..indices.len() as u32).map(at).collect())
        };
        self.values = Arc::new(values);
        Ok(())
    }

    pub fn is_bound(&self) -> bool {
        !matches!(*self.values, Values::Unbound)
    }

    #[inline]
    pub fn eval(&self, at: SurfacePoint) -> Rgb {
        let v = match &*self.values {
            Values::PerCorner(c) => match c.get(at.prim as usize) {
                Some([a, b, c]) => {
                    *a * (1.0 - at.bary.x - at.bary.y) + *b * at.bary.x + *c * at.bary.y
                }
                None => Rgb::ZERO,
            },
            Values::PerTriangle(t) => t.get(at.prim as usize).copied().unwrap_or(Rgb::ZERO),
            Values::Unbound => Rgb::ZERO,
        };
        v * self.scale
    }

    /// The values (before `scale`) triangle by triangle, and how many
    /// each triangle has: its three corners' (per-vertex data) or one
    /// (per-face data); none before binding.
    pub fn values(&self) -> (&[Rgb], usize) {
        let per_triangle = match &*self.values {
            Values::PerCorner(_) => 3,
            _ => 1,
        };
        (self.all(), per_triangle)
    }

    fn all(&self) -> &[Rgb] {
        match &*self.values {
            Values::PerCorner(c) => c.as_flattened(),
            Values::PerTriangle(t) => t,
            Values::Unbound => &[],
        }
    }

    /// Mean over the values (0.5 before binding: lobe weights are built
    /// before the mesh is read).
    pub fn mean(&self) -> Rgb {
        let all = self.all();
        if all.is_empty() {
            return Rgb::splat(0.5);
        }
        all.iter().copied().sum::<Rgb>() / all.len() as f32 * self.scale
    }

    /// The largest value in any channel (1 before binding).
    pub fn max_value(&self) -> f32 {
        let all = self.all();
        if all.is_empty() {
            return self.scale;
        }
        all.iter().map(|v| v.max_element()).fold(0.0, f32::max) * self.scale
    }
}
