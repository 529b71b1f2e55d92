//! Mitsuba 3's `principled`: the Disney BSDF (Burley 2012/2015) as
//! Mitsuba 3.9.1 evaluates it (`bsdfs/principled.cpp`,
//! `principledhelpers.h`): a diffuse lobe with retro-reflection and an
//! optional fake subsurface (`flatness`), sheen, a GGX specular lobe whose
//! Fresnel blends the dielectric one with Schlick's metallic and tinted
//! terms, a GGX transmission lobe (`spec_trans`) and a GTR1 clearcoat.
//!
//! Sampling picks diffuse, clearcoat or the specular interface with
//! probabilities that depend on `wi` only (Mitsuba's, with its sampling
//! rates), then, on the interface, reflection or transmission by the
//! Fresnel term of the sampled visible normal; `pdf` is that density, and
//! every sample's weight is eval / pdf of the whole mixture.

use super::distribution::{MicrofacetDistribution, MicrofacetType};
use super::fresnel::{schlick, schlick_weight};
use super::rough_dielectric::{half_vector, mulsign, refract_about};
use super::{fresnel_dielectric, BsdfSample};
use crate::color::{luminance, Rgb};
use crate::math::{reflect, sin_cos_turns, Vec2, Vec3, INV_PI, PI};
use crate::sampling::warp;
use crate::texture::{SurfacePoint, Texture};

/// The parameters, each a texture (a constant one for a number). A
/// parameter that is absent or the constant zero is `None`: Mitsuba then
/// skips its terms (its `has_*` flags).
#[derive(Clone, Debug, PartialEq)]
pub struct Principled {
    pub base_color: Texture,
    pub roughness: Texture,
    pub anisotropic: Option<Texture>,
    pub spec_trans: Option<Texture>,
    pub sheen: Option<Texture>,
    pub sheen_tint: Option<Texture>,
    pub flatness: Option<Texture>,
    pub spec_tint: Option<Texture>,
    pub metallic: Option<Texture>,
    pub clearcoat: Option<Texture>,
    pub clearcoat_gloss: Texture,
    /// Interior / exterior IOR (from `eta`, or from `specular`).
    pub eta: f32,
    /// Relative sampling rates of the specular, clearcoat and diffuse lobes.
    pub spec_rate: f32,
    pub clearcoat_rate: f32,
    pub diffuse_rate: f32,
}

/// The parameters read at one surface point.
struct At {
    base_color: Rgb,
    roughness: f32,
    anisotropic: f32,
    spec_trans: f32,
    metallic: f32,
    clearcoat: f32,
}

impl At {
    /// Weights of the reflective (diffuse, sheen) and transmissive parts.
    fn brdf_bsdf(&self) -> (f32, f32) {
        (
            (1.0 - self.metallic) * (1.0 - self.spec_trans),
            (1.0 - self.metallic) * self.spec_trans,
        )
    }
}

/// The IOR Mitsuba derives from `specular` (Schlick's R0 = 0.08 specular).
pub fn specular_to_eta(specular: f32) -> f32 {
    2.0 / (1.0 - (0.08 * specular).sqrt()) - 1.0
}

/// Schlick's Fresnel with reflectance `r0` at normal incidence across an
/// interface of relative IOR `eta`: from the denser side, measured by the
/// transmitted cosine (Mitsuba's `calc_schlick`).
pub(super) fn schlick_across(r0: Rgb, cos_i: f32, eta: f32) -> Rgb {
    let (eta_it, eta_ti) = if cos_i >= 0.0 {
        (eta, 1.0 / eta)
    } else {
        (1.0 / eta, eta)
    };
    if eta_it > 1.0 {
        schlick(r0, cos_i.abs())
    } else {
        let cos_t2 = 1.0 - (1.0 - cos_i * cos_i) * eta_ti * eta_ti;
        schlick(r0, cos_t2.max(0.0).sqrt())
    }
}

/// Schlick's R0 of an interface of relative IOR `eta`.
#[inline]
pub(super) fn r0_of(eta: f32) -> f32 {
    ((eta - 1.0) / (eta + 1.0)).powi(2)
}

/// `base / luminance(base)`, or white for black.
pub(super) fn tint(base: Rgb) -> Rgb {
    let lum = luminance(base);
    if lum > 0.0 {
        base / lum
    } else {
        Rgb::ONE
    }
}

/// GGX with Mitsuba's `calc_dist_params`: roughness squared, stretched by
/// `anisotropic` when the BSDF has that parameter, at least 0.001.
pub(super) fn disney_ggx(roughness: f32, anisotropic: Option<f32>) -> MicrofacetDistribution {
    let r2 = roughness * roughness;
    let (ax, ay) = match anisotropic {
        Some(anisotropic) => {
            let aspect = (1.0 - 0.9 * anisotropic).sqrt();
            (r2 / aspect, r2 * aspect)
        }
        None => (r2, r2),
    };
    MicrofacetDistribution::new(MicrofacetType::Ggx, ax.max(0.001), ay.max(0.001), true)
}

/// The diffuse lobe's shape (times base colour cos_o / pi it is the
/// lobe): Burley's diffuse with retro-reflection, blended towards the
/// fake subsurface by `flatness` when given. `cos_i` and `cos_o` are
/// magnitudes; `cos_d` is the half vector's cosine with `wo`.
pub(super) fn diffuse_shape(
    roughness: f32,
    cos_i: f32,
    cos_o: f32,
    cos_d: f32,
    flatness: Option<f32>,
) -> f32 {
    let (fo, fi) = (schlick_weight(cos_o), schlick_weight(cos_i));
    let f_diff = (1.0 - 0.5 * fi) * (1.0 - 0.5 * fo);
    let rr = 2.0 * roughness * cos_d * cos_d;
    let f_retro = rr * (fo + fi + fo * fi * (rr - 1.0));
    match flatness {
        Some(flatness) => {
            let fss90 = 0.5 * rr;
            let fss = (1.0 + (fss90 - 1.0) * fo) * (1.0 + (fss90 - 1.0) * fi);
            let f_ss = 1.25 * (fss * (1.0 / (cos_o + cos_i) - 0.5) + 0.5);
            (f_diff + f_retro) * (1.0 - flatness) + f_ss * flatness
        }
        None => f_diff + f_retro,
    }
}

/// The sheen's colour: white, tinted towards the base colour by
/// `sheen_tint` when given.
pub(super) fn sheen_colour(base: Rgb, sheen_tint: Option<f32>) -> Rgb {
    match sheen_tint {
        Some(st) => Rgb::ONE + (tint(base) - Rgb::ONE) * st,
        None => Rgb::ONE,
    }
}

/// Smith's G1 of GGX with roughness `alpha` (the clearcoat's masking).
fn smith_ggx1(v: Vec3, m: Vec3, alpha: f32) -> f32 {
    if v.dot(m) * v.z <= 0.0 {
        return 0.0;
    }
    if v.z == 1.0 {
        return 1.0;
    }
    let cos2 = v.z * v.z;
    let tan2 = (1.0 - cos2) / cos2;
    2.0 / (1.0 + (1.0 + alpha * alpha * tan2).sqrt())
}

/// Burley's GTR1 (gamma = 1) distribution of the clearcoat.
#[derive(Clone, Copy)]
struct Gtr1 {
    alpha: f32,
}

impl Gtr1 {
    /// Clearcoat gloss 0..1 maps roughness 0.1..0.001.
    fn from_gloss(gloss: f32) -> Gtr1 {
        Gtr1 {
            alpha: 0.1 + (0.001 - 0.1) * gloss,
        }
    }

    fn d(&self, m: Vec3) -> f32 {
        let a2 = self.alpha * self.alpha;
        let d = (a2 - 1.0) / (PI * a2.ln() * (1.0 + (a2 - 1.0) * m.z * m.z));
        if d * m.z > 1e-20 {
            d
        } else {
            0.0
        }
    }

    fn pdf(&self, m: Vec3) -> f32 {
        if m.z < 0.0 {
            0.0
        } else {
            m.z * self.d(m)
        }
    }

    fn sample(&self, u: Vec2) -> Vec3 {
        let (sin_phi, cos_phi) = sin_cos_turns(u.x);
        let a2 = self.alpha * self.alpha;
        let cos2 = (1.0 - a2.powf(1.0 - u.y)) / (1.0 - a2);
        let sin = (1.0 - cos2).max(0.0).sqrt();
        Vec3::new(cos_phi * sin, sin_phi * sin, cos2.max(0.0).sqrt())
    }
}

/// `mac_mic_compatibility`: both directions on the microfacet's side of
/// the macro surface as `wi` sees it (reflection), or on opposite sides
/// (transmission).
#[inline]
pub(super) fn compatible(m: Vec3, wi: Vec3, wo: Vec3, cos_i: f32, reflection: bool) -> bool {
    let m = mulsign(m, cos_i);
    wi.dot(m) > 0.0
        && if reflection {
            wo.dot(m) > 0.0
        } else {
            wo.dot(m) < 0.0
        }
}

/// The lobe choice of [`Principled::sample`]: probabilities of diffuse,
/// clearcoat and the specular interface (summing to one).
struct Choice {
    diffuse: f32,
    clearcoat: f32,
}

impl Principled {
    fn read(&self, at: SurfacePoint) -> At {
        let opt = |t: &Option<Texture>| t.as_ref().map_or(0.0, |t| t.eval_1(at));
        At {
            base_color: self.base_color.eval(at),
            roughness: self.roughness.eval_1(at),
            anisotropic: opt(&self.anisotropic),
            spec_trans: opt(&self.spec_trans),
            metallic: opt(&self.metallic),
            clearcoat: opt(&self.clearcoat),
        }
    }

    /// The GGX distribution of the specular lobes.
    fn distribution(&self, p: &At) -> MicrofacetDistribution {
        disney_ggx(
            p.roughness,
            self.anisotropic.as_ref().map(|_| p.anisotropic),
        )
    }

    /// Front side: diffuse, clearcoat and the interface by their rates.
    fn choice(&self, p: &At) -> Choice {
        let (brdf, _) = p.brdf_bsdf();
        let diffuse = brdf * self.diffuse_rate;
        let clearcoat = if self.clearcoat.is_some() {
            0.25 * p.clearcoat * self.clearcoat_rate
        } else {
            0.0
        };
        let total = diffuse + clearcoat + self.spec_rate;
        Choice {
            diffuse: diffuse / total,
            clearcoat: clearcoat / total,
        }
    }

    /// The generalised half vector (outwards) and whether (wi, wo) is a
    /// reflection; None when grazing.
    fn half_vector(&self, wi: Vec3, wo: Vec3) -> Option<(Vec3, bool)> {
        if wo.z == 0.0 {
            return None;
        }
        half_vector(wi, wo, self.eta).map(|(wh, reflect, _)| (wh, reflect))
    }

    pub fn eval(&self, at: SurfacePoint, wi: Vec3, wo: Vec3) -> Rgb {
        let p = self.read(at);
        self.eval_with(&p, at, wi, wo)
    }

    /// f(wi, wo) (no cosine) with the parameters already read. Mitsuba's
    /// `eval` term by term, divided by |cos_o|.
    fn eval_with(&self, p: &At, at: SurfacePoint, wi: Vec3, wo: Vec3) -> Rgb {
        let Some((wh, reflect)) = self.half_vector(wi, wo) else {
            return Rgb::ZERO;
        };
        let (cos_i, cos_o) = (wi.z, wo.z);
        let front = cos_i > 0.0;
        let (brdf, bsdf) = p.brdf_bsdf();
        let eta_path = if front { self.eta } else { 1.0 / self.eta };
        let distr = self.distribution(p);
        let dih = wi.dot(wh);
        let (f_dielectric, _, _) = fresnel_dielectric(dih, self.eta);
        let reflect_ok = reflect && compatible(wh, wi, wo, cos_i, true);
        let mut value = Rgb::ZERO; // f |cos_o|, as Mitsuba's eval returns it
        let d = distr.d(wh);
        let g = distr.g(wi, wo, wh);

        if reflect_ok && f_dielectric > 0.0 {
            let fresnel = if front {
                let mut schlick_part = Rgb::ZERO;
                if self.metallic.is_some() {
                    schlick_part += schlick_across(p.base_color, dih, self.eta) * p.metallic;
                }
                let spec_tint = match &self.spec_tint {
                    Some(t) => {
                        let spec_tint = t.eval_1(at);
                        let eta_it = if dih >= 0.0 { self.eta } else { 1.0 / self.eta };
                        let r0 = tint(p.base_color) * r0_of(eta_it);
                        schlick_part +=
                            schlick_across(r0, dih, self.eta) * ((1.0 - p.metallic) * spec_tint);
                        spec_tint
                    }
                    None => 0.0,
                };
                Rgb::splat((1.0 - p.metallic) * (1.0 - spec_tint) * f_dielectric) + schlick_part
            } else {
                // Inside: the plain dielectric, weighted by transmission.
                Rgb::splat(bsdf * f_dielectric)
            };
            value += fresnel * (d * g / (4.0 * cos_i.abs()));
        }

        if self.spec_trans.is_some()
            && bsdf > 0.0
            && !reflect
            && compatible(wh, wi, wo, cos_i, false)
            && f_dielectric < 1.0
        {
            // Radiance's 1/eta^2 and Walter's eta^2 cancel.
            let doh = wo.dot(wh);
            let denom = dih + eta_path * doh;
            let t = ((1.0 - f_dielectric) * d * g * dih * doh / (cos_i * denom * denom)).abs();
            value += p.base_color.map(f32::sqrt) * (bsdf * t);
        }

        if self.clearcoat.is_some() && p.clearcoat > 0.0 && reflect_ok && front {
            let gtr1 = Gtr1::from_gloss(self.clearcoat_gloss.eval_1(at));
            let f_cc = schlick_across(Rgb::splat(0.04), dih, self.eta).x;
            let g_cc = smith_ggx1(wi, wh, 0.25) * smith_ggx1(wo, wh, 0.25);
            value += Rgb::splat(p.clearcoat * 0.25 * f_cc * gtr1.d(wh) * g_cc * cos_o.abs());
        }

        if brdf > 0.0 && reflect && front {
            let cos_d = wh.dot(wo);
            let flatness = self.flatness.as_ref().map(|t| t.eval_1(at));
            let shape = diffuse_shape(p.roughness, cos_i.abs(), cos_o.abs(), cos_d, flatness);
            value += p.base_color * (brdf * cos_o.abs() * INV_PI * shape);

            // Sheen (Mitsuba adds it only where the diffuse lobe is active).
            if let Some(sheen) = &self.sheen {
                let sheen = sheen.eval_1(at);
                if sheen > 0.0 && 1.0 - p.metallic > 0.0 {
                    let fd = schlick_weight(cos_d.abs());
                    let tint_by = self.sheen_tint.as_ref().map(|t| t.eval_1(at));
                    let colour = sheen_colour(p.base_color, tint_by);
                    value += colour * (sheen * (1.0 - p.metallic) * fd * cos_o.abs());
                }
            }
        }
        value / cos_o.abs()
    }

    pub fn pdf(&self, at: SurfacePoint, wi: Vec3, wo: Vec3) -> f32 {
        let p = self.read(at);
        self.pdf_with(&p, at, wi, wo)
    }

    fn pdf_with(&self, p: &At, at: SurfacePoint, wi: Vec3, wo: Vec3) -> f32 {
        let Some((wh, reflect)) = self.half_vector(wi, wo) else {
            return 0.0;
        };
        let cos_i = wi.z;
        let front = cos_i > 0.0;
        let (_, bsdf) = p.brdf_bsdf();
        if !front && bsdf <= 0.0 {
            return 0.0;
        }
        let eta_path = if front { self.eta } else { 1.0 / self.eta };
        let (dih, doh) = (wi.dot(wh), wo.dot(wh));
        let (f, _, _) = fresnel_dielectric(dih, self.eta);
        // The interface's reflection and transmission shares.
        let (p_reflect, p_trans) = if front {
            (1.0 - bsdf * (1.0 - f), bsdf * (1.0 - f))
        } else {
            (f, 1.0 - f)
        };
        let (p_diffuse, p_clearcoat, p_spec) = if front {
            let c = self.choice(p);
            (c.diffuse, c.clearcoat, 1.0 - c.diffuse - c.clearcoat)
        } else {
            (0.0, 0.0, 1.0)
        };
        let dwh_dwo = if reflect {
            (1.0 / (4.0 * doh)).abs()
        } else {
            (eta_path * eta_path * doh / (dih + eta_path * doh).powi(2)).abs()
        };
        let distr = self.distribution(p);
        let mut pdf = 0.0;
        if reflect {
            if compatible(wh, wi, wo, cos_i, true) {
                pdf += p_spec * p_reflect * distr.pdf(mulsign(wi, cos_i), wh) * dwh_dwo;
                if p_clearcoat > 0.0 {
                    let gtr1 = Gtr1::from_gloss(self.clearcoat_gloss.eval_1(at));
                    pdf += p_clearcoat * gtr1.pdf(wh) * dwh_dwo;
                }
            }
            pdf += p_diffuse * warp::square_to_cosine_hemisphere_pdf(wo);
        } else if self.spec_trans.is_some() && compatible(wh, wi, wo, cos_i, false) {
            pdf += p_spec * p_trans * distr.pdf(mulsign(wi, cos_i), wh) * dwh_dwo;
        }
        pdf
    }

    pub fn sample(&self, at: SurfacePoint, wi: Vec3, u: Vec2, u_lobe: f32) -> Option<BsdfSample> {
        let cos_i = wi.z;
        if cos_i == 0.0 {
            return None;
        }
        let p = self.read(at);
        let front = cos_i > 0.0;
        let (_, bsdf) = p.brdf_bsdf();
        if !front && bsdf <= 0.0 {
            return None;
        }
        // Lobe: diffuse, clearcoat, or the interface (u_lobe rescaled).
        let (p_diffuse, p_clearcoat) = if front {
            let c = self.choice(&p);
            (c.diffuse, c.clearcoat)
        } else {
            (0.0, 0.0)
        };
        // A sampled direction on the wrong side of the surface for its
        // lobe, or of its microfacet, is dropped (as Mitsuba drops it), so
        // the density of what is returned is pdf()'s.
        let reflection = |m: Vec3| {
            let wo = reflect(wi, m);
            (wo.z * cos_i > 0.0 && compatible(m, wi, wo, cos_i, true)).then_some(wo)
        };
        let mut eta = 1.0;
        let wo = if u_lobe < p_diffuse {
            warp::square_to_cosine_hemisphere(u)
        } else if u_lobe < p_diffuse + p_clearcoat {
            reflection(Gtr1::from_gloss(self.clearcoat_gloss.eval_1(at)).sample(u))?
        } else {
            let p_spec = 1.0 - p_diffuse - p_clearcoat;
            let u_lobe = ((u_lobe - p_diffuse - p_clearcoat) / p_spec).min(1.0 - f32::EPSILON);
            let (m, pdf_m) = self.distribution(&p).sample(mulsign(wi, cos_i), u);
            if pdf_m <= 0.0 || !m.is_finite() {
                return None;
            }
            let dim = wi.dot(m);
            let (f, cos_t, eta_ti) = fresnel_dielectric(dim, self.eta);
            let p_reflect = if front { 1.0 - bsdf * (1.0 - f) } else { f };
            if u_lobe < p_reflect {
                reflection(m)?
            } else {
                let wo = refract_about(wi, m, dim, cos_t, eta_ti);
                if wo.z * cos_i >= 0.0 || !compatible(m, wi, wo, cos_i, false) {
                    return None;
                }
                eta = eta_ti;
                wo
            }
        };
        if !wo.is_finite() || wo.z == 0.0 {
            return None;
        }
        let pdf = self.pdf_with(&p, at, wi, wo);
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
            eta,
            null: false,
        })
    }

    /// The textures it reads (for binding mesh attributes).
    pub fn textures_mut(&mut self) -> impl Iterator<Item = &mut Texture> {
        [
            &mut self.base_color,
            &mut self.roughness,
            &mut self.clearcoat_gloss,
        ]
        .into_iter()
        .chain(
            [
                &mut self.anisotropic,
                &mut self.spec_trans,
                &mut self.sheen,
                &mut self.sheen_tint,
                &mut self.flatness,
                &mut self.spec_tint,
                &mut self.metallic,
                &mut self.clearcoat,
            ]
            .into_iter()
            .flatten(),
        )
    }
}
