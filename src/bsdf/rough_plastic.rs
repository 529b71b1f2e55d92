//! Mitsuba 3's `roughplastic`: a rough dielectric coating (isotropic
//! Beckmann or GGX microfacets, dielectric Fresnel) over a Lambertian base.
//! Light entering and leaving the base is weighted by the coating's rough
//! transmittance, tabulated over cos theta at construction, and internal
//! bounces are summed with the coating's hemispherical internal
//! reflectance, both computed as Mitsuba does (Gauss-Legendre quadrature
//! over the visible-normal sampling domain). Sampling picks the glossy or
//! the diffuse lobe and reports the combined density (one-sample MIS).

use super::distribution::{MicrofacetDistribution, MicrofacetType, Roughness};
use super::params::BsdfError;
use super::Plastic;
use super::{fresnel_dielectric, BsdfSample};
use crate::color::Rgb;
use crate::math::{reflect, Vec2, Vec3, INV_PI};
use crate::sampling::warp;
use rayon::prelude::*;
use std::sync::Mutex;

/// Entries of the transmittance table over cos theta in [0, 1].
pub const TRANSMITTANCE_RES: usize = 64;

#[derive(Clone, Debug, PartialEq)]
pub struct RoughPlastic {
    /// Isotropic (Mitsuba refuses anisotropic roughplastic).
    pub distr: MicrofacetDistribution,
    /// Interior IOR / exterior IOR.
    pub eta: f32,
    pub diffuse_reflectance: Rgb,
    pub specular_reflectance: Rgb,
    pub nonlinear: bool,
    pub specular_sampling_weight: f32,
    /// Hemispherical reflectance of the coating seen from inside.
    pub internal_reflectance: f32,
    /// Rough transmittance of the coating from outside, at cos theta =
    /// i / (RES - 1). Boxed: built once at scene load.
    pub external_transmittance: Box<[f32; TRANSMITTANCE_RES]>,
}

/// Gauss-Legendre nodes and weights on [-1, 1] (Newton on P_n).
fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    let mut out = vec![(0.0, 0.0); n];
    let nf = n as f64;
    for i in 0..n.div_ceil(2) {
        let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (nf + 0.5)).cos();
        let mut dp = 1.0;
        for _ in 0..100 {
            let (mut p0, mut p1) = (1.0, x);
            for k in 2..=n {
                let kf = k as f64;
                let p2 = ((2.0 * kf - 1.0) * x * p1 - (kf - 1.0) * p0) / kf;
                p0 = p1;
                p1 = p2;
            }
            dp = nf * (x * p1 - p0) / (x * x - 1.0);
            let dx = p1 / dp;
            x -= dx;
            if dx.abs() < 1e-15 {
                break;
            }
        }
        let w = 2.0 / ((1.0 - x * x) * dp * dp);
        out[i] = (-x, w);
        out[n - 1 - i] = (x, w);
    }
    out
}

/// Mitsuba's `eval_transmittance` / `eval_reflectance`: the fraction of
/// light from `wi` that the rough interface (relative IOR `eta`) transmits
/// or reflects, integrated over visible normals by quadrature.
fn coating_integral(distr: &MicrofacetDistribution, wi: Vec3, eta: f32, transmit: bool) -> f32 {
    let res = if eta > 1.0 { 32 } else { 128 };
    let nodes = gauss_legendre(res);
    let us: Vec<f32> = nodes.iter().map(|&(n, _)| (n * 0.5 + 0.5) as f32).collect();
    let mut acc = 0.0f64;
    distr.sample_normal_grid(wi, &us, |i, j, m| {
        let (wx, wy) = (nodes[i].1, nodes[j].1);
        let dim = wi.dot(m);
        let (f, cos_t, eta_ti) = fresnel_dielectric(dim, eta);
        let value = if transmit {
            let inv = 1.0 / eta_ti;
            let ct = if dim >= 0.0 { -cos_t } else { cos_t };
            let wo = m * (dim * inv + ct) - wi * inv;
            if wo.z * wi.z >= 0.0 {
                0.0
            } else {
                distr.smith_g1(wo, m) * (1.0 - f)
            }
        } else {
            let wo = reflect(wi, m);
            if wo.z <= 0.0 || wi.z <= 0.0 {
                0.0
            } else {
                distr.smith_g1(wo, m) * f
            }
        };
        acc += value as f64 * wx * wy * 0.25;
    });
    acc as f32
}

/// The coating's tables: what [`RoughPlastic::new`] spends its time on,
/// and all that depends only on the distribution and the relative IOR.
#[derive(Clone, Debug, PartialEq)]
struct CoatingTables {
    internal_reflectance: f32,
    external_transmittance: Box<[f32; TRANSMITTANCE_RES]>,
}

/// Which tables an entry of the cache holds: the distribution's type and
/// roughness and the relative IOR, bit for bit.
type CoatingKey = (MicrofacetType, u32, u32, u32);

/// Tables kept for reuse: scenes give many materials the same roughness
/// and IOR and differ only in colour (a table costs about 0.03 s of CPU
/// for Beckmann, 0.1 s for GGX). Bounded, oldest out first, so a process that loads
/// scene after scene (the Python package) does not grow without end.
const COATING_CACHE: usize = 32;
static COATING_TABLES: Mutex<Vec<(CoatingKey, CoatingTables)>> = Mutex::new(Vec::new());

impl CoatingTables {
    /// The tables for `distr` and `eta`, from the cache when an earlier
    /// material had the same (they are the same bits either way).
    fn cached(distr: &MicrofacetDistribution, eta: f32) -> CoatingTables {
        let key = (
            distr.kind,
            distr.alpha_u.to_bits(),
            distr.alpha_v.to_bits(),
            eta.to_bits(),
        );
        let lock = || COATING_TABLES.lock().unwrap_or_else(|e| e.into_inner());
        if let Some((_, t)) = lock().iter().find(|(k, _)| *k == key) {
            return t.clone();
        }
        // Built outside the lock: other loads go on meanwhile.
        let tables = CoatingTables::new(distr, eta);
        let mut cache = lock();
        if !cache.iter().any(|(k, _)| *k == key) {
            if cache.len() == COATING_CACHE {
                cache.remove(0);
            }
            cache.push((key, tables.clone()));
        }
        tables
    }

    /// Computes the tables: (transmittance, mu x internal reflectance) per
    /// entry, on all cores, about a million normal samples in all.
    fn new(distr: &MicrofacetDistribution, eta: f32) -> CoatingTables {
        // The tables always use visible-normal sampling, as Mitsuba's.
        let table_distr = MicrofacetDistribution {
            sample_visible: true,
            ..*distr
        };
        let rows: Vec<(f32, f64)> = (0..TRANSMITTANCE_RES)
            .into_par_iter()
            .map(|i| {
                let mu = (i as f32 / (TRANSMITTANCE_RES - 1) as f32).max(1e-6);
                let wi = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
                let t = coating_integral(&table_distr, wi, eta, true);
                let r = coating_integral(&table_distr, wi, 1.0 / eta, false);
                (t, (r * mu) as f64)
            })
            .collect();
        let mut ext = Box::new([0.0f32; TRANSMITTANCE_RES]);
        for (e, r) in ext.iter_mut().zip(&rows) {
            *e = r.0;
        }
        let internal: f64 = rows.iter().map(|r| r.1).sum();
        CoatingTables {
            internal_reflectance: (2.0 * internal / TRANSMITTANCE_RES as f64) as f32,
            external_transmittance: ext,
        }
    }
}

impl RoughPlastic {
    /// Builds the tables (about a million normal samples, ~0.1 s of CPU
    /// for GGX, ~0.03 s for Beckmann, whose slopes are drawn once per
    /// grid line, spread over the cores: do it once per material, at
    /// scene load).
    ///
    /// Parameters (Mitsuba's names and defaults): `distribution`
    /// (beckmann), `alpha` (0.1; the distribution is used isotropically,
    /// with `alpha_u`, as in Mitsuba), `int_ior`
    /// (polypropylene = 1.49), `ext_ior` (air = 1.000277),
    /// `diffuse_reflectance` (0.5), `specular_reflectance` (1), `nonlinear`
    /// (false), `sample_visible` (true).
    pub fn new(
        roughness: Roughness,
        int_ior: f32,
        ext_ior: f32,
        diffuse_reflectance: Rgb,
        specular_reflectance: Rgb,
        nonlinear: bool,
    ) -> Result<RoughPlastic, BsdfError> {
        let smooth = Plastic::new(
            int_ior,
            ext_ior,
            diffuse_reflectance,
            specular_reflectance,
            nonlinear,
        )?;
        let distr = roughness.distribution()?;
        let eta = smooth.eta;
        let tables = CoatingTables::cached(&distr, eta);
        Ok(RoughPlastic {
            distr,
            eta,
            diffuse_reflectance,
            specular_reflectance,
            nonlinear,
            specular_sampling_weight: smooth.specular_sampling_weight,
            internal_reflectance: tables.internal_reflectance,
            external_transmittance: tables.external_transmittance,
        })
    }

    /// Linear interpolation in the transmittance table.
    fn transmittance(&self, cos: f32) -> f32 {
        let x = cos * (TRANSMITTANCE_RES - 1) as f32;
        let i = (x.max(0.0) as usize).min(TRANSMITTANCE_RES - 2);
        let t = x - i as f32;
        let (a, b) = (
            self.external_transmittance[i],
            self.external_transmittance[i + 1],
        );
        a * (1.0 - t) + b * t
    }

    fn prob_specular(&self, t_i: f32) -> f32 {
        let ps = (1.0 - t_i) * self.specular_sampling_weight;
        let pd = t_i * (1.0 - self.specular_sampling_weight);
        ps / (ps + pd)
    }

    pub fn eval(&self, wi: Vec3, wo: Vec3) -> Rgb {
        self.eval_tinted(self.diffuse_reflectance, self.specular_reflectance, wi, wo)
    }

    /// `eval` with the two reflectances given (a texture's values at the
    /// hit); the tables and the lobe choice do not depend on them.
    pub fn eval_tinted(&self, kd: Rgb, ks: Rgb, wi: Vec3, wo: Vec3) -> Rgb {
        self.eval_pdf_tinted(kd, ks, wi, wo).0
    }

    pub fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        let (kd, ks) = (self.diffuse_reflectance, self.specular_reflectance);
        self.eval_pdf_tinted(kd, ks, wi, wo).1
    }

    /// `(eval_tinted, pdf)` at once: they share the half vector, `D`, one
    /// `G1` and a transmittance, which next-event estimation under MIS and
    /// sampling (which weighs by both) would otherwise compute twice.
    #[inline]
    pub fn eval_pdf_tinted(&self, kd: Rgb, ks: Rgb, wi: Vec3, wo: Vec3) -> (Rgb, f32) {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return (Rgb::ZERO, 0.0);
        }
        let h = (wi + wo).normalize();
        let d = self.distr.d(h);
        let g1_i = self.distr.smith_g1(wi, h);
        let t_i = self.transmittance(wi.z);
        let (f, _, _) = fresnel_dielectric(wi.dot(h), self.eta);
        let spec = d * (g1_i * self.distr.smith_g1(wo, h)) * f / (4.0 * wi.z * wo.z);
        let diff = if self.nonlinear {
            kd / (Rgb::ONE - kd * self.internal_reflectance)
        } else {
            kd / (1.0 - self.internal_reflectance)
        };
        let t = t_i * self.transmittance(wo.z);
        let value = ks * spec + diff * (INV_PI / (self.eta * self.eta) * t);
        let p_spec = self.prob_specular(t_i);
        let spec_pdf = if self.distr.sample_visible {
            d * g1_i / (4.0 * wi.z)
        } else {
            self.distr.pdf(wi, h) / (4.0 * wo.dot(h))
        };
        let pdf = p_spec * spec_pdf + (1.0 - p_spec) * warp::square_to_cosine_hemisphere_pdf(wo);
        (value, pdf)
    }

    pub fn sample(&self, wi: Vec3, u: Vec2, u_lobe: f32) -> Option<BsdfSample> {
        let (kd, ks) = (self.diffuse_reflectance, self.specular_reflectance);
        self.sample_tinted(kd, ks, wi, u, u_lobe)
    }

    /// `sample` with the two reflectances given (see `eval_tinted`).
    pub fn sample_tinted(
        &self,
        kd: Rgb,
        ks: Rgb,
        wi: Vec3,
        u: Vec2,
        u_lobe: f32,
    ) -> Option<BsdfSample> {
        if wi.z <= 0.0 {
            return None;
        }
        let p_spec = self.prob_specular(self.transmittance(wi.z));
        sample_glossy_or_diffuse(&self.distr, wi, u, u_lobe < p_spec, |wo| {
            self.eval_pdf_tinted(kd, ks, wi, wo)
        })
    }
}

/// One-sample MIS over a plastic's two reflection lobes: `wo` from the
/// microfacet normals (`glossy`) or the cosine-weighted hemisphere, then
/// weighted by the model's value over its combined density (`eval_pdf`
/// gives both). `wi` is in the upper hemisphere.
pub(super) fn sample_glossy_or_diffuse(
    distr: &MicrofacetDistribution,
    wi: Vec3,
    u: Vec2,
    glossy: bool,
    eval_pdf: impl Fn(Vec3) -> (Rgb, f32),
) -> Option<BsdfSample> {
    let wo = if glossy {
        reflect(wi, distr.sample_normal(wi, u))
    } else {
        warp::square_to_cosine_hemisphere(u)
    };
    if wo.z <= 0.0 || !wo.is_finite() {
        return None;
    }
    let (value, pdf) = eval_pdf(wo);
    if pdf <= 0.0 {
        return None;
    }
    Some(BsdfSample {
        wo,
        weight: value * (wo.z / pdf),
        pdf,
        specular: false,
        eta: 1.0,
        null: false,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cached_tables_are_the_computed_ones_and_the_cache_stays_bounded() {
        let ggx = |alpha| MicrofacetDistribution::new(MicrofacetType::Ggx, alpha, alpha, true);
        // Keys no other test uses (alphas 0.3xx, eta 1.7).
        let first = CoatingTables::cached(&ggx(0.301), 1.7);
        assert_eq!(first, CoatingTables::new(&ggx(0.301), 1.7));
        assert_eq!(CoatingTables::cached(&ggx(0.301), 1.7), first);
        // Another roughness or IOR gets its own tables.
        assert_ne!(CoatingTables::cached(&ggx(0.302), 1.7), first);
        assert_ne!(CoatingTables::cached(&ggx(0.301), 1.8), first);
        // sample_visible does not change them (the tables always sample
        // visible normals).
        let all = MicrofacetDistribution::new(MicrofacetType::Ggx, 0.301, 0.301, false);
        assert_eq!(CoatingTables::cached(&all, 1.7), first);
        for k in 0..COATING_CACHE + 3 {
            CoatingTables::cached(&ggx(0.31 + 0.001 * k as f32), 1.7);
        }
        assert!(COATING_TABLES.lock().unwrap().len() <= COATING_CACHE);
    }

    #[test]
    fn gauss_legendre_integrates_polynomials() {
        for n in [32, 128] {
            let q = gauss_legendre(n);
            let w: f64 = q.iter().map(|&(_, w)| w).sum();
            assert!((w - 2.0).abs() < 1e-12);
            // x^4 over [-1, 1] = 2/5; x^(2n-1)-degree exactness.
            let i4: f64 = q.iter().map(|&(x, w)| w * x.powi(4)).sum();
            assert!((i4 - 0.4).abs() < 1e-12);
            assert!(q.windows(2).all(|p| p[0].0 < p[1].0));
        }
    }
}
