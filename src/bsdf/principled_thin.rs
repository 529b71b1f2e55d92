//! Mitsuba 3's `principledthin`: the thin-surface Disney BSDF (Burley
//! 2015) as Mitsuba 3.9.1 evaluates it (`bsdfs/principledthin.cpp`). A
//! sheet with no inside: the same response from both sides, mirrored to
//! the front. Lobes: diffuse with retro-reflection, optional fake
//! subsurface (`flatness`) and sheen; Lambertian diffuse transmission
//! (`diff_trans`, 0 to 2); and, with `spec_trans`, a GGX specular
//! reflection (dielectric Fresnel of `eta`, tinted by `spec_tint`) and a
//! GGX transmission straight through the sheet (a reflection mirrored to
//! the back, roughness scaled by 0.65 eta - 0.35). As in Mitsuba, without
//! `spec_trans` there is no specular reflection at all.
//!
//! Sampling picks a lobe with Mitsuba's probabilities (sampling rates
//! times the lobe weights), then a visible GGX normal or a cosine
//! direction; `pdf` is the mixture's density.

use super::distribution::MicrofacetDistribution;
use super::fresnel::schlick_weight;
use super::principled::{
    compatible, diffuse_shape, disney_ggx, r0_of, schlick_across, sheen_colour, tint,
};
use super::rough_dielectric::mulsign;
use super::{fresnel_dielectric, BsdfSample};
use crate::color::Rgb;
use crate::math::{reflect, Vec2, Vec3, INV_PI};
use crate::sampling::warp;
use crate::texture::{SurfacePoint, Texture};

/// The parameters, each a texture (a constant one for a number). A
/// parameter that is absent or the constant zero is `None`: Mitsuba then
/// skips its terms (its `has_*` flags).
#[derive(Clone, Debug, PartialEq)]
pub struct PrincipledThin {
    pub base_color: Texture,
    pub roughness: Texture,
    pub anisotropic: Option<Texture>,
    pub spec_trans: Option<Texture>,
    pub sheen: Option<Texture>,
    pub sheen_tint: Option<Texture>,
    pub flatness: Option<Texture>,
    pub spec_tint: Option<Texture>,
    /// Diffuse transmission, 0 to 2 as Mitsuba reads it.
    pub diff_trans: Option<Texture>,
    /// The sheet's IOR (a texture: Mitsuba reads it per point).
    pub eta: Texture,
    /// Relative sampling rates: specular reflection, specular
    /// transmission, diffuse reflection, diffuse transmission.
    pub spec_refl_rate: f32,
    pub spec_trans_rate: f32,
    pub diff_refl_rate: f32,
    pub diff_trans_rate: f32,
}

/// The parameters read at one surface point.
struct At {
    base_color: Rgb,
    roughness: f32,
    anisotropic: f32,
    spec_trans: f32,
    /// `diff_trans` / 2, in [0, 1].
    diff_trans: f32,
    eta: f32,
}

/// Lobe probabilities, normalised.
struct Choice {
    spec_reflect: f32,
    spec_trans: f32,
    diff_reflect: f32,
    diff_trans: f32,
}

impl PrincipledThin {
    fn read(&self, at: SurfacePoint) -> At {
        let opt = |t: &Option<Texture>| t.as_ref().map_or(0.0, |t| t.eval_1(at));
        At {
            base_color: self.base_color.eval(at),
            roughness: self.roughness.eval_1(at),
            anisotropic: opt(&self.anisotropic),
            spec_trans: opt(&self.spec_trans),
            diff_trans: opt(&self.diff_trans) / 2.0,
            eta: self.eta.eval_1(at),
        }
    }

    /// GGX with Mitsuba's `calc_dist_params` for `roughness`.
    fn distribution(&self, p: &At, roughness: f32) -> MicrofacetDistribution {
        disney_ggx(roughness, self.anisotropic.as_ref().map(|_| p.anisotropic))
    }

    /// The transmission lobe's distribution: roughness scaled by the IOR
    /// (Burley 2015, figure 15).
    fn trans_distribution(&self, p: &At) -> MicrofacetDistribution {
        self.distribution(p, (0.65 * p.eta - 0.35) * p.roughness)
    }

    fn choice(&self, p: &At) -> Option<Choice> {
        let spec = self.spec_trans.is_some();
        let spec_reflect = if spec {
            p.spec_trans * self.spec_refl_rate / 2.0
        } else {
            0.0
        };
        let spec_trans = if spec {
            p.spec_trans * self.spec_trans_rate / 2.0
        } else {
            0.0
        };
        let diff_reflect = self.diff_refl_rate * (1.0 - p.spec_trans) * (1.0 - p.diff_trans);
        let diff_trans = if self.diff_trans.is_some() {
            self.diff_trans_rate * (1.0 - p.spec_trans) * p.diff_trans
        } else {
            0.0
        };
        let total = spec_reflect + spec_trans + diff_reflect + diff_trans;
        (total > 0.0 && total.is_finite()).then(|| Choice {
            spec_reflect: spec_reflect / total,
            spec_trans: spec_trans / total,
            diff_reflect: diff_reflect / total,
            diff_trans: diff_trans / total,
        })
    }

    pub fn eval(&self, at: SurfacePoint, wi: Vec3, wo: Vec3) -> Rgb {
        let p = self.read(at);
        self.eval_with(&p, at, wi, wo)
    }

    /// The half vector of `wi` (mirrored to the front) and `wo` with its
    /// transmission mirrored back: the microfacet a thin reflection or
    /// transmission turned on.
    fn half_vector(wi: Vec3, wo: Vec3) -> Vec3 {
        (wi + Vec3::new(wo.x, wo.y, wo.z.abs())).normalize()
    }

    /// f(wi, wo) (no cosine): Mitsuba's `eval` term by term, divided by
    /// |cos_o|.
    fn eval_with(&self, p: &At, at: SurfacePoint, wi: Vec3, wo: Vec3) -> Rgb {
        let cos_i = wi.z;
        if cos_i == 0.0 || wo.z == 0.0 {
            return Rgb::ZERO;
        }
        // Always on the front: the sheet is symmetric.
        let wi = mulsign(wi, cos_i);
        let wo = mulsign(wo, cos_i);
        let (cos_i, cos_o) = (wi.z, wo.z);
        let reflect = cos_o > 0.0;
        let wh = Self::half_vector(wi, wo);
        let mut value = Rgb::ZERO; // f |cos_o|, as Mitsuba's eval returns it

        if self.spec_trans.is_some() && p.spec_trans > 0.0 {
            let dih = wi.dot(wh);
            let (f_dielectric, _, _) = fresnel_dielectric(dih, p.eta);
            if reflect && compatible(wh, wi, wo, cos_i, true) {
                let distr = self.distribution(p, p.roughness);
                let fresnel = match &self.spec_tint {
                    Some(t) => {
                        let spec_tint = t.eval_1(at);
                        let r0 = tint(p.base_color) * r0_of(p.eta);
                        let f_schlick = schlick_across(r0, dih, p.eta);
                        Rgb::splat(f_dielectric * (1.0 - spec_tint)) + f_schlick * spec_tint
                    }
                    None => Rgb::splat(f_dielectric),
                };
                let dg = distr.d(wh) * distr.g(wi, wo, wh);
                value += fresnel * (p.spec_trans * dg / (4.0 * cos_i));
            }
            if !reflect && compatible(wh, wi, wo, cos_i, false) {
                let distr = self.trans_distribution(p);
                let dg = distr.d(wh) * distr.g(wi, wo, wh);
                value += p.base_color * (p.spec_trans * (1.0 - f_dielectric) * dg / (4.0 * cos_i));
            }
        }

        if reflect && p.spec_trans < 1.0 && p.diff_trans < 1.0 {
            let cos_d = wh.dot(wo);
            let flatness = self.flatness.as_ref().map(|t| t.eval_1(at));
            let shape = diffuse_shape(p.roughness, cos_i, cos_o, cos_d, flatness);
            let weight = (1.0 - p.spec_trans) * (1.0 - p.diff_trans);
            value += p.base_color * (weight * cos_o * INV_PI * shape);
            if let Some(sheen) = &self.sheen {
                let sheen = sheen.eval_1(at);
                if sheen > 0.0 {
                    let fd = schlick_weight(cos_d.abs());
                    let tint_by = self.sheen_tint.as_ref().map(|t| t.eval_1(at));
                    let colour = sheen_colour(p.base_color, tint_by);
                    value += colour * (sheen * weight * fd * cos_o);
                }
            }
        }

        if self.diff_trans.is_some() && !reflect && p.spec_trans < 1.0 && p.diff_trans > 0.0 {
            value += p.base_color * ((1.0 - p.spec_trans) * p.diff_trans * INV_PI * cos_o.abs());
        }
        value / cos_o.abs()
    }

    pub fn pdf(&self, at: SurfacePoint, wi: Vec3, wo: Vec3) -> f32 {
        let p = self.read(at);
        self.pdf_with(&p, wi, wo)
    }

    fn pdf_with(&self, p: &At, wi: Vec3, wo: Vec3) -> f32 {
        let cos_i = wi.z;
        if cos_i == 0.0 || wo.z == 0.0 {
            return 0.0;
        }
        let Some(c) = self.choice(p) else {
            return 0.0;
        };
        let wi = mulsign(wi, cos_i);
        let wo = mulsign(wo, cos_i);
        let reflect = wo.z > 0.0;
        let mut pdf = 0.0;
        if self.spec_trans.is_some() {
            let wh = Self::half_vector(wi, wo);
            let wo_r = Vec3::new(wo.x, wo.y, wo.z.abs());
            let dwh_dwo = (1.0 / (4.0 * wo_r.dot(wh))).abs();
            if reflect && compatible(wh, wi, wo, wi.z, true) {
                pdf += c.spec_reflect * self.distribution(p, p.roughness).pdf(wi, wh) * dwh_dwo;
            }
            if !reflect && compatible(wh, wi, wo, wi.z, false) {
                pdf += c.spec_trans * self.trans_distribution(p).pdf(wi, wh) * dwh_dwo;
            }
        }
        if reflect {
            pdf += c.diff_reflect * warp::square_to_cosine_hemisphere_pdf(wo);
        } else if self.diff_trans.is_some() {
            pdf += c.diff_trans * warp::square_to_cosine_hemisphere_pdf(-wo);
        }
        pdf
    }

    pub fn sample(&self, at: SurfacePoint, wi: Vec3, u: Vec2, u_lobe: f32) -> Option<BsdfSample> {
        let cos_i = wi.z;
        if cos_i == 0.0 {
            return None;
        }
        let p = self.read(at);
        let c = self.choice(&p)?;
        let wi_f = mulsign(wi, cos_i);
        let wo_f = if u_lobe < c.spec_reflect {
            let (m, _) = self.distribution(&p, p.roughness).sample(wi_f, u);
            let wo = reflect(wi_f, m);
            if !(wo.z > 0.0 && compatible(m, wi_f, wo, wi_f.z, true)) {
                return None;
            }
            wo
        } else if u_lobe < c.spec_reflect + c.spec_trans {
            let (m, _) = self.trans_distribution(&p).sample(wi_f, u);
            let r = reflect(wi_f, m);
            let wo = Vec3::new(r.x, r.y, -r.z);
            if !(wo.z < 0.0 && compatible(m, wi_f, wo, wi_f.z, false)) {
                return None;
            }
            wo
        } else if u_lobe < c.spec_reflect + c.spec_trans + c.diff_reflect {
            warp::square_to_cosine_hemisphere(u)
        } else if self.diff_trans.is_some() {
            -warp::square_to_cosine_hemisphere(u)
        } else {
            return None;
        };
        let wo = mulsign(wo_f, cos_i);
        if !wo.is_finite() || wo.z == 0.0 {
            return None;
        }
        let pdf = self.pdf_with(&p, wi, wo);
        if pdf <= 0.0 {
            return None;
        }
        let f = self.eval_with(&p, at, wi, wo);
        if f == Rgb::ZERO {
            return None;
        }
        Some(BsdfSample {
            wo,
            weight: f * wo.z.abs() / pdf,
            pdf,
            specular: false,
            eta: 1.0,
            null: false,
        })
    }

    /// The textures it reads (for binding mesh attributes).
    pub fn textures_mut(&mut self) -> impl Iterator<Item = &mut Texture> {
        [&mut self.base_color, &mut self.roughness, &mut self.eta]
            .into_iter()
            .chain(
                [
                    &mut self.anisotropic,
                    &mut self.spec_trans,
                    &mut self.sheen,
                    &mut self.sheen_tint,
                    &mut self.flatness,
                    &mut self.spec_tint,
                    &mut self.diff_trans,
                ]
                .into_iter()
                .flatten(),
            )
    }
}
