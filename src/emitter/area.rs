//! Area lights: uniform emission from the front side of a shape (the side
//! its shading normal faces). Spheres seen from outside are sampled by the
//! cone they subtend; other shapes (and points inside a sphere) by area.

use super::{EmitterContext, EmitterError, LightSample};
use crate::color::{luminance, Rgb};
use crate::geometry::Geometry;
use crate::math::{Vec2, Vec3, PI};

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AreaLight {
    /// Index of the shape in the scene.
    pub shape: u32,
    pub radiance: Rgb,
}

impl AreaLight {
    /// `radiance`: finite and not negative.
    pub fn new(shape: u32, radiance: Rgb) -> Result<AreaLight, EmitterError> {
        Ok(AreaLight {
            shape,
            radiance: super::radiance(radiance)?,
        })
    }

    pub fn power(&self, ctx: &EmitterContext) -> f32 {
        PI * ctx.shapes[self.shape as usize].area() * luminance(self.radiance)
    }

    pub fn sample(
        &self,
        ctx: &EmitterContext,
        p_ref: Vec3,
        u: Vec2,
        u1: f32,
    ) -> Option<LightSample> {
        let s = match &ctx.shapes[self.shape as usize] {
            Geometry::Mesh(m) => m.sample_area(u1, u),
            Geometry::Sphere(sp) => match sp.visible_cone(p_ref) {
                // Outside the sphere: sample the cone it subtends.
                Some(cone) => {
                    let (s, pdf) = sp.sample_cone(p_ref, &cone, u);
                    return Some(LightSample {
                        wi: (s.p - p_ref).normalize(),
                        p: s.p,
                        err: s.err,
                        n: s.n,
                        dist: (s.p - p_ref).length(),
                        weight: self.radiance / pdf,
                        pdf,
                        delta: false,
                    });
                }
                None => sp.sample_area(u),
            },
        };
        let to = s.p - p_ref;
        let d2 = to.length_squared();
        if d2 <= 0.0 {
            return None;
        }
        let dist = d2.sqrt();
        let wi = to / dist;
        let cos_l = -wi.dot(s.n);
        if cos_l <= 0.0 {
            return None;
        }
        let pdf = s.pdf_area * d2 / cos_l;
        Some(LightSample {
            wi,
            p: s.p,
            err: s.err,
            n: s.n,
            dist,
            weight: self.radiance / pdf,
            pdf,
            delta: false,
        })
    }

    /// Solid-angle density of `sample` from `p_ref` reaching `p_light`
    /// (normal `n_light`) in direction `wi`.
    pub fn pdf(
        &self,
        ctx: &EmitterContext,
        p_ref: Vec3,
        wi: Vec3,
        p_light: Vec3,
        n_light: Vec3,
    ) -> f32 {
        let g = &ctx.shapes[self.shape as usize];
        if let Geometry::Sphere(sp) = g {
            if let Some(cone) = sp.visible_cone(p_ref) {
                return cone.pdf();
            }
        }
        let area = g.area();
        let d2 = (p_light - p_ref).length_squared();
        let cos_l = (-wi).dot(n_light);
        if cos_l <= 0.0 || area <= 0.0 {
            return 0.0;
        }
        d2 / (cos_l * area)
    }
}
