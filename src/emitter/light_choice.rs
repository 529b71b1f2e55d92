//! Which light next-event estimation samples from a shading point.
//!
//! Lights with bounds (area and point lights) are chosen in proportion to
//! an upper bound of what they can deliver to the point: power over
//! squared distance, times how far the point lies inside the light's
//! emission cone and the light inside the point's normal hemisphere
//! (pbrt-v4's light-bounds importance). Choosing by power alone, as lente
//! did, sends almost every sample to a big distant light and starves the
//! small near ones (Veach's MIS scene: 2.6x Mitsuba's error; Mitsuba picks
//! uniformly). Lights at infinity (environment, constant, directional)
//! have no position: they share a fixed probability, by power among
//! themselves. With more than [`EXHAUSTIVE_MAX`] bounded lights the
//! per-point sums would cost too much, and bounded lights are chosen by
//! power.

use super::light_lanes::BoundsLanes;
#[cfg(target_arch = "x86_64")]
use super::light_lanes::{BoundsLanes8, PointLanes8};
use super::{Emitter, EmitterContext};
use crate::geometry::Geometry;
use crate::math::Vec3;
use crate::sampling::{Distribution1D, ONE_MINUS_EPSILON};

/// Most bounded lights weighed one by one at every shading point.
pub const EXHAUSTIVE_MAX: usize = 64;

/// Smallest factor the cone and normal terms may give: a light near a
/// surface's tangent plane still lights it at grazing angles (f cos of a
/// glossy BSDF stays finite there), and rounding must not starve a light
/// that can reach the point.
pub(super) const MIN_FACTOR: f32 = 0.02;

/// Where a bounded light is and where it sends light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightBounds {
    /// Centre and radius of a sphere holding the light.
    pub centre: Vec3,
    pub radius: f32,
    /// Emitted power (luminance).
    pub power: f32,
    /// Emission normals lie within `cos_theta_o` of `axis` (-1: all
    /// directions); each emits into the hemisphere around its normal.
    pub axis: Vec3,
    pub cos_theta_o: f32,
}

impl LightBounds {
    /// Bounds of a light that emits in all directions from a sphere.
    fn omni(centre: Vec3, radius: f32, power: f32) -> LightBounds {
        LightBounds {
            centre,
            radius,
            power,
            axis: Vec3::Z,
            cos_theta_o: -1.0,
        }
    }

    /// A flat shape in `frame` with box `b`, emitting from its front.
    fn flat(frame: &crate::geometry::PlaneFrame, b: crate::math::Aabb, power: f32) -> LightBounds {
        LightBounds {
            centre: frame.center,
            radius: 0.5 * b.diagonal().length(),
            power,
            axis: frame.n,
            cos_theta_o: 1.0,
        }
    }

    /// Bounds of an emitter of power `power`, `None` for lights at
    /// infinity.
    pub fn of(emitter: &Emitter, ctx: &EmitterContext, power: f32) -> Option<LightBounds> {
        match emitter {
            Emitter::Point(p) => Some(LightBounds::omni(p.position, 0.0, power)),
            // Emission within the cone only; the bound's 90 degrees beyond
            // it are conservative.
            Emitter::Spot(s) => Some(LightBounds {
                centre: s.position,
                radius: 0.0,
                power,
                axis: s.axis,
                cos_theta_o: s.cos_cutoff(),
            }),
            Emitter::Projector(p) => Some(LightBounds {
                centre: p.position,
                radius: 0.0,
                power,
                axis: p.axis,
                cos_theta_o: p.cos_cone(),
            }),
            Emitter::Area(a) => match &ctx.shapes[a.shape as usize] {
                Geometry::Sphere(s) => Some(LightBounds::omni(s.center, s.radius, power)),
                Geometry::Disk(d) => Some(LightBounds::flat(&d.frame, d.bounds(), power)),
                Geometry::Rectangle(r) => Some(LightBounds::flat(&r.frame, r.bounds(), power)),
                Geometry::Mesh(m) => {
                    let b = m.bounds();
                    let (axis, cos_theta_o) = normal_cone(m);
                    Some(LightBounds {
                        centre: b.center(),
                        radius: 0.5 * b.diagonal().length(),
                        power,
                        axis,
                        cos_theta_o,
                    })
                }
                Geometry::Curve(_) => None,
            },
            Emitter::Directional(_) | Emitter::Constant(_) | Emitter::Environment(_) => None,
        }
    }

    /// [`LightBounds::importance`] at a point inside the bounding sphere,
    /// where no direction can be excluded (the same everywhere there).
    #[inline]
    pub(super) fn inside_importance(&self) -> f32 {
        self.power / (self.radius * self.radius).max(f32::MIN_POSITIVE)
    }

    /// sin(theta_o), from `cos_theta_o`.
    #[inline]
    pub(super) fn sin_theta_o(&self) -> f32 {
        (1.0 - self.cos_theta_o * self.cos_theta_o).max(0.0).sqrt()
    }

    /// An upper bound (up to a common factor) of the light this can send
    /// to a point `p` with unit normal `n` (zero: no normal, as in a
    /// medium), on either side of the surface.
    pub fn importance(&self, p: Vec3, n: Vec3) -> f32 {
        if self.power <= 0.0 {
            return 0.0;
        }
        let to_p = p - self.centre;
        let d2 = to_p.length_squared();
        if d2 <= self.radius * self.radius {
            return self.inside_importance();
        }
        // One division for the direction and the cone's sine: divisions
        // and square roots were most of the lights' weighing.
        let inv_dist = 1.0 / d2.sqrt();
        let w = to_p * inv_dist;
        // Half-angle of the cone the bounding sphere subtends from p.
        let sin_b = self.radius * inv_dist;
        let cos_b = (1.0 - sin_b * sin_b).max(0.0).sqrt();
        let mut factor = 1.0;
        if self.cos_theta_o > -1.0 {
            // theta' = max(0, theta_w - theta_o - theta_b): the angle
            // between the emission cone and p, less the light's extent.
            // Emission needs theta' < 90 degrees.
            let cos_w = self.axis.dot(w).clamp(-1.0, 1.0);
            let sin_w = (1.0 - cos_w * cos_w).max(0.0).sqrt();
            let cos_o = self.cos_theta_o;
            let sin_o = self.sin_theta_o();
            let (cos_x, sin_x) = if cos_w >= cos_o {
                (1.0, 0.0)
            } else {
                (cos_w * cos_o + sin_w * sin_o, sin_w * cos_o - cos_w * sin_o)
            };
            let c = if cos_x >= cos_b {
                1.0
            } else {
                cos_x * cos_b + sin_x * sin_b
            };
            if c <= -1e-4 {
                return 0.0;
            }
            factor = c.max(MIN_FACTOR);
        }
        if n != Vec3::ZERO {
            // Angle between the (two-sided) normal and the light, less
            // the light's extent.
            let cos_i = n.dot(w).abs().min(1.0);
            let c = if cos_i >= cos_b {
                1.0
            } else {
                let sin_i = (1.0 - cos_i * cos_i).max(0.0).sqrt();
                cos_i * cos_b + sin_i * sin_b
            };
            factor *= c.max(MIN_FACTOR);
        }
        self.power * factor / d2
    }
}

/// Axis and cosine of the half-angle of a cone holding the emission
/// normals of a mesh: each triangle's geometric normal, turned to the side
/// its shading normals choose (both sides where they disagree).
fn normal_cone(m: &crate::geometry::TriangleMesh) -> (Vec3, f32) {
    let normals = m.normals();
    let indices = m.indices();
    let sides = |tri: usize, ng: Vec3| -> (bool, bool) {
        if normals.is_empty() {
            return (true, false);
        }
        let mut front = false;
        let mut back = false;
        for &i in &indices[tri] {
            let d = normals[i as usize].dot(ng);
            // A zero interpolated normal falls back to the geometric one.
            front |= d >= 0.0 || !d.is_finite();
            back |= d < 0.0;
        }
        (front || !back, back)
    };
    let mut sum = Vec3::ZERO;
    for tri in 0..m.triangle_count() {
        let ng = m.geometric_normal(tri);
        let (front, back) = sides(tri, ng);
        if front {
            sum += ng;
        }
        if back {
            sum -= ng;
        }
    }
    let axis = sum.normalize_or_zero();
    if axis == Vec3::ZERO {
        return (Vec3::Z, -1.0);
    }
    let mut cos_o = 1.0f32;
    for tri in 0..m.triangle_count() {
        let ng = m.geometric_normal(tri);
        if ng == Vec3::ZERO {
            continue;
        }
        let (front, back) = sides(tri, ng);
        if front {
            cos_o = cos_o.min(axis.dot(ng));
        }
        if back {
            cos_o = cos_o.min(-axis.dot(ng));
        }
    }
    // A little slack for rounding; past -0.99 the cone is everything.
    let cos_o = cos_o - 1e-4;
    if cos_o < -0.99 {
        (Vec3::Z, -1.0)
    } else {
        (axis, cos_o)
    }
}

/// The light choice of a scene.
#[derive(Clone, Debug)]
pub struct LightChoice {
    /// Emitter index and bounds of each bounded light with power.
    bounded: Vec<(u32, LightBounds)>,
    /// Power-proportional choice among `bounded`, when there are too many
    /// to weigh per point.
    bounded_by_power: Option<Distribution1D>,
    /// `bounded`'s bounds four to a group, for [`LightChoice::at`] (empty
    /// where it does not weigh them one by one).
    lanes: Vec<BoundsLanes>,
    /// The same in groups of eight, where the CPU has AVX2 (empty where
    /// it has not, or `lanes` is).
    #[cfg(target_arch = "x86_64")]
    lanes8: Vec<BoundsLanes8>,
    /// Emitter indices of the lights at infinity with power, and the
    /// choice among them by power.
    unbounded: Vec<u32>,
    unbounded_by_power: Option<Distribution1D>,
    /// Probability of choosing a light at infinity.
    p_unbounded: f32,
    /// For each emitter, its place: `Some((true, k))` for bounded[k],
    /// `Some((false, k))` for unbounded[k], `None` if never chosen.
    slot: Vec<Option<(bool, u32)>>,
}

impl LightChoice {
    /// The choice over `emitters`; `None` if none emits anything.
    pub fn new(emitters: &[Emitter], ctx: &EmitterContext) -> Option<LightChoice> {
        let mut bounded = Vec::new();
        let mut unbounded = Vec::new();
        let mut unbounded_power = Vec::new();
        let mut slot = vec![None; emitters.len()];
        for (i, e) in emitters.iter().enumerate() {
            let power = e.power(ctx);
            if !(power > 0.0 && power.is_finite()) {
                continue;
            }
            match LightBounds::of(e, ctx, power) {
                Some(b) => {
                    slot[i] = Some((true, bounded.len() as u32));
                    bounded.push((i as u32, b));
                }
                None => {
                    slot[i] = Some((false, unbounded.len() as u32));
                    unbounded.push(i as u32);
                    unbounded_power.push(power);
                }
            }
        }
        if bounded.is_empty() && unbounded.is_empty() {
            return None;
        }
        // pbrt-v4's share: each light at infinity counts as much as all
        // the bounded lights together.
        let groups = unbounded.len() + usize::from(!bounded.is_empty());
        let p_unbounded = unbounded.len() as f32 / groups as f32;
        let bounded_by_power = (bounded.len() > EXHAUSTIVE_MAX).then(|| {
            let powers: Vec<f32> = bounded.iter().map(|(_, b)| b.power).collect();
            Distribution1D::new(&powers)
        });
        let unbounded_by_power =
            (!unbounded.is_empty()).then(|| Distribution1D::new(&unbounded_power));
        let lanes = if bounded_by_power.is_none() && bounded.len() > 1 {
            BoundsLanes::group(&bounded.iter().map(|(_, b)| *b).collect::<Vec<_>>())
        } else {
            Vec::new()
        };
        #[cfg(target_arch = "x86_64")]
        let lanes8 = if std::arch::is_x86_feature_detected!("avx2") {
            BoundsLanes8::pairs(&lanes)
        } else {
            Vec::new()
        };
        Some(LightChoice {
            bounded,
            bounded_by_power,
            lanes,
            #[cfg(target_arch = "x86_64")]
            lanes8,
            unbounded,
            unbounded_by_power,
            p_unbounded,
            slot,
        })
    }

    /// The shading point `p` with normal `n` (zero for none) as the
    /// choice sees it: the sum of the bounded lights' importance there is
    /// computed once, for the emitter sample and for the MIS weight of the
    /// light a BSDF sample from the same point finds.
    pub fn at(&self, p: Vec3, n: Vec3) -> ChoicePoint {
        let mut at = ChoicePoint::default();
        self.set_at(&mut at, p, n, None);
        at
    }

    /// [`LightChoice::at`] with [`ChoicePoint::facing`], stored into `at`
    /// field by field (a path keeps its point: building one on the stack
    /// and copying it in made loads that waited on the stores just made).
    pub fn set_at(&self, at: &mut ChoicePoint, p: Vec3, n: Vec3, facing: Option<Vec3>) {
        ChoicePoint::place(at, p, n, facing);
        if !self.lanes.is_empty() {
            self.weigh(at);
        }
    }

    /// Whether [`LightChoice::weigh_points`] can weigh points placed with
    /// [`ChoicePoint::place`] eight at a time: the CPU has AVX2 and the
    /// bounded lights are weighed one by one.
    #[inline]
    pub fn weighs_points_in_lanes(&self) -> bool {
        #[cfg(target_arch = "x86_64")]
        return !self.lanes8.is_empty();
        #[cfg(not(target_arch = "x86_64"))]
        false
    }

    /// The weights [`LightChoice::set_at`] gives the points `p` with
    /// normals `n` (zero for none), bit for bit, into `out`: each light
    /// weighed at the eight points at once (a path batch's points;
    /// weighing one point's few lights at a time left lanes empty).
    /// Unused lanes may hold anything; their weights are dropped.
    ///
    /// # Panics
    /// Where [`LightChoice::weighs_points_in_lanes`] is false.
    #[cfg(target_arch = "x86_64")]
    pub fn weigh_points(&self, p: &[Vec3; 8], n: &[Vec3; 8], out: &mut PointWeights8) {
        assert!(self.weighs_points_in_lanes());
        // SAFETY: `lanes8` is filled only where the CPU has AVX2.
        unsafe { self.weigh_points_avx2(p, n, out) }
    }

    /// [`LightChoice::weigh_points`] compiled for AVX2: each light's
    /// importance added to the sums in the lights' order, as
    /// [`keep_importance`] adds them for one point.
    ///
    /// # Safety
    /// Call only where the CPU has AVX2 (where `lanes8` is filled).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn weigh_points_avx2(&self, p: &[Vec3; 8], n: &[Vec3; 8], out: &mut PointWeights8) {
        use std::arch::x86_64::*;
        let at = PointLanes8::new(p, n);
        let mut total = _mm256_setzero_ps();
        for k in 0..self.bounded.len() {
            let w = self.lanes8[k / 8].importance_at_points(k % 8, &at);
            if let Some(row) = out.importance.get_mut(k) {
                // SAFETY: eight floats.
                unsafe { _mm256_storeu_ps(row.as_mut_ptr(), w) };
            }
            total = _mm256_add_ps(total, w);
        }
        // Rows of lights there are not stay zero, as `set_at` leaves them.
        for row in out.importance.iter_mut().skip(self.bounded.len()) {
            *row = [0.0; 8];
        }
        // SAFETY: eight floats.
        unsafe { _mm256_storeu_ps(out.total.as_mut_ptr(), total) };
    }

    /// The bounded lights' importance at `at` and their sum: four or eight
    /// lights at a time (bit for bit what `LightBounds::importance`
    /// gives), summed one by one in the lights' order. Out of line: most
    /// scenes have nothing to weigh, and their `at` stays small.
    #[inline(never)]
    fn weigh(&self, at: &mut ChoicePoint) {
        let (p, n) = (at.p, at.n);
        let count = self.bounded.len();
        // Eight at a time where the CPU has AVX2 (the same bits, half the
        // instructions for five to eight lights), else four.
        #[cfg(target_arch = "x86_64")]
        if !self.lanes8.is_empty() {
            // SAFETY: `lanes8` is filled only where the CPU has AVX2.
            unsafe { self.weigh_avx2(at) };
            return;
        }
        let mut total = at.total;
        for (g, lanes) in self.lanes.iter().enumerate() {
            keep_importance(
                at,
                &mut total,
                count,
                4 * g,
                &lanes.importance(p, n).to_array(),
            );
        }
        at.total = total;
    }

    /// [`LightChoice::weigh`] eight lights at a time, compiled for AVX2 so
    /// that the lanes' importance is inlined (a call to it spilled the
    /// point and the sum around it): the same values kept and summed in
    /// the same order.
    ///
    /// # Safety
    /// Call only where the CPU has AVX2 (where `lanes8` is filled).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn weigh_avx2(&self, at: &mut ChoicePoint) {
        let (p, n) = (at.p, at.n);
        let count = self.bounded.len();
        let mut total = at.total;
        for (g, lanes) in self.lanes8.iter().enumerate() {
            keep_importance(at, &mut total, count, 8 * g, &lanes.importance(p, n));
        }
        at.total = total;
    }

    /// Importance of bounded light `k` at `at`: kept by [`LightChoice::at`]
    /// for the first [`KEPT_IMPORTANCE`] lights, computed again beyond.
    #[inline]
    fn importance(&self, at: &ChoicePoint, k: usize) -> f32 {
        match at.importance.get(k) {
            Some(&w) if self.bounded.len() <= KEPT_IMPORTANCE => w,
            _ => self.bounded[k].1.importance(at.p, at.n),
        }
    }

    /// Chooses an emitter for the shading point `at`. Returns its index,
    /// the probability of the choice and `u` rescaled to [0, 1) for reuse.
    #[inline]
    pub fn sample(&self, at: &ChoicePoint, u: f32) -> Option<(usize, f32, f32)> {
        if u < self.p_unbounded {
            // Inlined down to the one-cell distribution of a single light
            // at infinity (a sky or a probe).
            return self.sample_unbounded(u);
        }
        self.sample_bounded(at, u)
    }

    /// [`LightChoice::sample`] where `u` chooses among the bounded lights.
    #[inline(never)]
    fn sample_bounded(&self, at: &ChoicePoint, u: f32) -> Option<(usize, f32, f32)> {
        let p_bounded = 1.0 - self.p_unbounded;
        let u = ((u - self.p_unbounded) / p_bounded).min(ONE_MINUS_EPSILON);
        if let Some(d) = &self.bounded_by_power {
            let (k, pk, u) = d.sample_discrete(u);
            return Some((self.bounded[k].0 as usize, p_bounded * pk, u));
        }
        if let [(i, _)] = self.bounded[..] {
            // One light: nothing to weigh (a light behind its own back
            // gives a zero sample, as it would from any chooser).
            return Some((i as usize, p_bounded, u));
        }
        let total = at.total;
        if !(total > 0.0 && total.is_finite()) {
            return None;
        }
        let target = u * total;
        let mut acc = 0.0f32;
        let mut last = None;
        for (k, (i, _)) in self.bounded.iter().enumerate() {
            let w = self.importance(at, k);
            if w <= 0.0 {
                continue;
            }
            if target < acc + w {
                let u = ((target - acc) / w).clamp(0.0, ONE_MINUS_EPSILON);
                return Some((*i as usize, p_bounded * w / total, u));
            }
            acc += w;
            last = Some((*i as usize, w));
        }
        // Rounding left the target past the sum: the last light with weight.
        let (i, w) = last?;
        Some((i, p_bounded * w / total, ONE_MINUS_EPSILON))
    }

    /// The emitter at infinity that [`LightChoice::sample`] picks with `u`
    /// wherever the shading point is (that choice does not depend on it),
    /// or `None` if `u` chooses among the bounded lights.
    #[inline]
    pub fn choice_at_infinity(&self, u: f32) -> Option<usize> {
        if u < self.p_unbounded {
            // One light at infinity (the common case: a sky or a probe) is
            // the choice whatever `u`, without rescaling it for a choice
            // among several.
            if let [i] = self.unbounded[..] {
                return Some(i as usize);
            }
            self.sample_unbounded(u).map(|(i, _, _)| i)
        } else {
            None
        }
    }

    /// [`LightChoice::sample`] for `u < p_unbounded`.
    #[inline]
    fn sample_unbounded(&self, u: f32) -> Option<(usize, f32, f32)> {
        let d = self.unbounded_by_power.as_ref()?;
        let (k, pk, u) = d.sample_discrete((u / self.p_unbounded).min(ONE_MINUS_EPSILON));
        Some((self.unbounded[k] as usize, self.p_unbounded * pk, u))
    }

    /// [`LightChoice::pdf`] of emitter `i` where it is the same at every
    /// shading point (a light at infinity, or one never chosen); `None`
    /// for a bounded light, whose choice depends on the point.
    pub fn pdf_everywhere(&self, i: usize) -> Option<f32> {
        match self.slot.get(i).copied().flatten() {
            None => Some(0.0),
            Some((false, k)) => Some(self.unbounded_pdf(k)),
            Some((true, _)) => None,
        }
    }

    /// The probability of choosing `unbounded[k]`.
    fn unbounded_pdf(&self, k: u32) -> f32 {
        self.unbounded_by_power
            .as_ref()
            .map_or(0.0, |d| self.p_unbounded * d.discrete_pdf(k as usize))
    }

    /// Probability that [`LightChoice::sample`] at `at` picks emitter `i`.
    pub fn pdf(&self, at: &ChoicePoint, i: usize) -> f32 {
        match self.slot.get(i).copied().flatten() {
            None => 0.0,
            Some((false, k)) => self.unbounded_pdf(k),
            Some((true, k)) => {
                let p_bounded = 1.0 - self.p_unbounded;
                if let Some(d) = &self.bounded_by_power {
                    return p_bounded * d.discrete_pdf(k as usize);
                }
                if self.bounded.len() == 1 {
                    return p_bounded;
                }
                let w = self.importance(at, k as usize);
                if w <= 0.0 || at.total.is_nan() || at.total <= 0.0 {
                    return 0.0;
                }
                p_bounded * w / at.total
            }
        }
    }
}

/// A shading point with what the light choice needs there (see
/// [`LightChoice::at`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ChoicePoint {
    p: Vec3,
    n: Vec3,
    /// Sum of the bounded lights' importance (0 where the choice does not
    /// weigh them one by one).
    total: f32,
    /// Each bounded light's importance, where there are at most
    /// [`KEPT_IMPORTANCE`] of them (so `sample` and `pdf` do not compute
    /// them again: on Veach's scene, importance was 6% of a render).
    importance: [f32; KEPT_IMPORTANCE],
    /// The normal of the side a surface receives light from, where it
    /// receives light from one side only (a reflecting BSDF): light
    /// sampling may then spend less on what is behind it.
    pub facing: Option<Vec3>,
}

impl ChoicePoint {
    /// The point for a surface that receives light only from the side
    /// `facing` points to (if given).
    pub fn facing(self, facing: Option<Vec3>) -> ChoicePoint {
        ChoicePoint { facing, ..self }
    }

    /// `at` set to the point `p` with normal `n` and `facing`, its lights
    /// not weighed yet ([`LightChoice::weigh_points`] weighs them, or
    /// [`LightChoice::set_at`] places and weighs at once). Stored field by
    /// field (see `set_at`).
    #[inline]
    pub fn place(at: &mut ChoicePoint, p: Vec3, n: Vec3, facing: Option<Vec3>) {
        *at = ChoicePoint {
            p,
            n,
            total: 0.0,
            importance: [0.0f32; KEPT_IMPORTANCE],
            facing,
        };
    }

    /// The shading point and its normal (zero for none).
    #[inline]
    pub fn point(&self) -> (Vec3, Vec3) {
        (self.p, self.n)
    }

    /// The weights of lane `lane` of `w` ([`LightChoice::weigh_points`]).
    #[cfg(target_arch = "x86_64")]
    #[inline]
    pub fn take_weights(&mut self, w: &PointWeights8, lane: usize) {
        self.total = w.total[lane];
        for (slot, row) in self.importance.iter_mut().zip(&w.importance) {
            *slot = row[lane];
        }
    }
}

/// The weights of eight points ([`LightChoice::weigh_points`]): each
/// point's sum over the bounded lights, and the importance of the first
/// eight lights (a row per light, a lane per point; zero past the
/// lights' count).
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy, Debug, Default)]
pub struct PointWeights8 {
    total: [f32; 8],
    importance: [[f32; 8]; KEPT_IMPORTANCE],
}

/// [`LightChoice::weigh`]'s step for one group of lanes: the importance
/// `values` of bounded lights `first..count` (the lanes beyond are
/// padding), kept in `at` for the first [`KEPT_IMPORTANCE`] lights and
/// added to `total` one by one in the lights' order. Inlined into both
/// weighings (the AVX2 one keeps `total` in a register).
#[inline(always)]
fn keep_importance(
    at: &mut ChoicePoint,
    total: &mut f32,
    count: usize,
    first: usize,
    values: &[f32],
) {
    for (k, &w) in (first..count).zip(values) {
        if let Some(slot) = at.importance.get_mut(k) {
            *slot = w;
        }
        *total += w;
    }
}

/// Bounded lights whose importance a [`ChoicePoint`] keeps.
const KEPT_IMPORTANCE: usize = 8;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::color::Rgb;
    use crate::emitter::{AreaLight, PointLight};
    use crate::geometry::{Sphere, TriangleMesh};

    fn quad(z: f32, flip: bool) -> TriangleMesh {
        let p = vec![
            Vec3::new(-1.0, -1.0, z),
            Vec3::new(1.0, -1.0, z),
            Vec3::new(1.0, 1.0, z),
            Vec3::new(-1.0, 1.0, z),
        ];
        let idx = if flip {
            vec![[0, 2, 1], [0, 3, 2]]
        } else {
            vec![[0, 1, 2], [0, 2, 3]]
        };
        TriangleMesh::new(p, vec![], vec![], idx).unwrap()
    }

    #[test]
    fn planar_light_has_a_tight_cone_and_culls_its_back() {
        let shapes = [Geometry::Mesh(quad(0.0, false))];
        let ctx = EmitterContext {
            shapes: &shapes,
            scene_radius: 10.0,
        };
        let e = Emitter::Area(AreaLight::new(0, Rgb::ONE).unwrap());
        let b = LightBounds::of(&e, &ctx, e.power(&ctx)).unwrap();
        assert!((b.axis - Vec3::Z).length() < 1e-6 && b.cos_theta_o > 0.999);
        assert!(b.importance(Vec3::new(0.0, 0.0, 3.0), Vec3::Z) > 0.0);
        assert_eq!(b.importance(Vec3::new(0.0, 0.0, -3.0), Vec3::Z), 0.0);
        // Beside the plane (past the light's edge) it may still reach.
        assert!(b.importance(Vec3::new(5.0, 0.0, 0.2), Vec3::Z) > 0.0);
    }

    #[test]
    fn near_small_lights_beat_far_big_ones() {
        let shapes = [
            Geometry::Sphere(Sphere::new(Vec3::new(0.0, 0.0, 1.0), 0.05).unwrap()),
            Geometry::Sphere(Sphere::new(Vec3::new(50.0, 0.0, 50.0), 1.0).unwrap()),
        ];
        let ctx = EmitterContext {
            shapes: &shapes,
            scene_radius: 100.0,
        };
        let emitters = [
            Emitter::Area(AreaLight::new(0, Rgb::splat(100.0)).unwrap()),
            Emitter::Area(AreaLight::new(1, Rgb::splat(100.0)).unwrap()),
        ];
        let c = LightChoice::new(&emitters, &ctx).unwrap();
        let at = c.at(Vec3::ZERO, Vec3::Z);
        let p0 = c.pdf(&at, 0);
        let p1 = c.pdf(&at, 1);
        assert!((p0 + p1 - 1.0).abs() < 1e-5);
        assert!(p0 > 0.5, "{p0}");
    }

    /// `choice_at_infinity` names the emitter at infinity that `sample`
    /// picks with the same number at any shading point, and nothing where
    /// `sample` picks a bounded light (the path tracer prefetches with it
    /// before it knows the point). Control: both kinds are picked.
    #[test]
    fn choice_at_infinity_agrees_with_sample() {
        use crate::emitter::ConstantLight;
        let shapes = [Geometry::Sphere(
            Sphere::new(Vec3::new(0.0, 0.0, 2.0), 0.5).unwrap(),
        )];
        let ctx = EmitterContext {
            shapes: &shapes,
            scene_radius: 10.0,
        };
        let constant = |l: f32| Emitter::Constant(ConstantLight::new(Rgb::splat(l)).unwrap());
        let area = || Emitter::Area(AreaLight::new(0, Rgb::splat(5.0)).unwrap());
        let point = || {
            Emitter::Point(PointLight::new(Vec3::new(-2.0, 1.0, 0.0), Rgb::splat(40.0)).unwrap())
        };
        // Two lights at infinity, then one (its own shortcut).
        for emitters in [
            vec![constant(0.5), area(), point(), constant(2.0)],
            vec![area(), constant(0.5), point()],
        ] {
            let c = LightChoice::new(&emitters, &ctx).unwrap();
            let mut picked = vec![0usize; emitters.len()];
            for (p, n) in [(Vec3::ZERO, Vec3::Z), (Vec3::new(1.0, 2.0, -1.0), Vec3::X)] {
                let at = c.at(p, n);
                for k in 0..4096 {
                    let u = (k as f32 + 0.5) / 4096.0;
                    let (i, _, _) = c.sample(&at, u).unwrap();
                    picked[i] += 1;
                    let infinite = matches!(emitters[i], Emitter::Constant(_));
                    assert_eq!(c.choice_at_infinity(u), infinite.then_some(i), "u {u}");
                }
            }
            assert!(picked.iter().all(|&k| k > 0), "{picked:?}");
        }
    }

    /// Past the lights whose importance a `ChoicePoint` keeps, `sample` and
    /// `pdf` compute it again and still agree, and the choice still favours
    /// the nearest light. Control: the test runs on both sides of the limit.
    #[test]
    fn importance_kept_or_computed_again_agree() {
        for count in [KEPT_IMPORTANCE, KEPT_IMPORTANCE + 4] {
            let emitters: Vec<Emitter> = (0..count)
                .map(|k| {
                    let p = Vec3::new(k as f32 * 2.0, 1.0, 0.5 * k as f32);
                    Emitter::Point(PointLight::new(p, Rgb::splat(10.0)).unwrap())
                })
                .collect();
            let ctx = EmitterContext {
                shapes: &[],
                scene_radius: 100.0,
            };
            let c = LightChoice::new(&emitters, &ctx).unwrap();
            let at = c.at(Vec3::new(0.1, 0.0, 0.0), Vec3::Y);
            let probs: Vec<f32> = (0..count).map(|i| c.pdf(&at, i)).collect();
            let sum: f32 = probs.iter().sum();
            assert!((sum - 1.0).abs() < 1e-5, "{count}: {probs:?}");
            assert!(probs[0] > probs[count - 1], "{count}: {probs:?}");
            for k in 0..1000 {
                let (i, pr, _) = c.sample(&at, (k as f32 + 0.5) / 1000.0).unwrap();
                assert_eq!(pr, probs[i], "{count} lights, light {i}");
            }
        }
    }

    /// Points weighed eight at a time in lanes (`weigh_points`, as a path
    /// batch weighs them) get the weights `set_at` gives one point at a
    /// time, bit for bit: sums and kept importance, for 2 to 13 lights
    /// (spheres, one-sided quads, points), points with and without a
    /// normal, inside lights' spheres and not, and partly filled groups.
    /// Control: most weights are neither zero nor all alike.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn points_weighed_in_lanes_equal_points_weighed_one_by_one() {
        use crate::sampling::Sampler;
        if !std::arch::is_x86_feature_detected!("avx2") {
            return;
        }
        fn random(s: &mut Sampler, scale: f32) -> Vec3 {
            Vec3::new(s.next_1d(), s.next_1d(), s.next_1d()) * 2.0 * scale - Vec3::splat(scale)
        }
        let mut s = Sampler::new(23, 1);
        let (mut nonzero, mut inside, mut compared) = (0, 0, 0);
        for count in [2, 3, 5, 8, 9, 13] {
            let mut shapes = Vec::new();
            let mut emitters = Vec::new();
            let mut centres = Vec::new();
            for k in 0..count {
                let radiance = Rgb::splat(1.0 + 20.0 * s.next_1d());
                let shape = shapes.len() as u32;
                match k % 3 {
                    0 => {
                        let c = random(&mut s, 2.0);
                        let r = 0.05 + 0.75 * s.next_1d();
                        shapes.push(Geometry::Sphere(Sphere::new(c, r).unwrap()));
                        emitters.push(Emitter::Area(AreaLight::new(shape, radiance).unwrap()));
                        centres.push(c);
                    }
                    1 => {
                        shapes.push(Geometry::Mesh(quad(random(&mut s, 2.0).z, k % 2 == 0)));
                        emitters.push(Emitter::Area(AreaLight::new(shape, radiance).unwrap()));
                    }
                    _ => {
                        let p = random(&mut s, 2.0);
                        emitters.push(Emitter::Point(PointLight::new(p, radiance).unwrap()));
                    }
                }
            }
            let ctx = EmitterContext {
                shapes: &shapes,
                scene_radius: 10.0,
            };
            let c = LightChoice::new(&emitters, &ctx).unwrap();
            assert!(c.weighs_points_in_lanes());
            let mut w = PointWeights8::default();
            for round in 0..400 {
                let len = 1 + round % 8;
                let p: [Vec3; 8] = std::array::from_fn(|k| match (round + k) % 5 {
                    // Inside a sphere light's bounds.
                    0 => centres[k % centres.len()] + random(&mut s, 0.04),
                    _ => random(&mut s, 3.0),
                });
                let n: [Vec3; 8] = std::array::from_fn(|k| match (round + k) % 4 {
                    0 => Vec3::ZERO,
                    _ => random(&mut s, 1.0).normalize_or(Vec3::X),
                });
                c.weigh_points(&p, &n, &mut w);
                for lane in 0..len {
                    let want = c.at(p[lane], n[lane]);
                    let mut got = ChoicePoint::default();
                    ChoicePoint::place(&mut got, p[lane], n[lane], None);
                    got.take_weights(&w, lane);
                    assert_eq!(got.total.to_bits(), want.total.to_bits(), "{count} lights");
                    let bits = |a: &ChoicePoint| a.importance.map(f32::to_bits);
                    assert_eq!(bits(&got), bits(&want), "{count} lights at {}", p[lane]);
                    nonzero += want.importance.iter().filter(|&&x| x > 0.0).count();
                    inside += usize::from(
                        want.importance
                            .contains(&c.bounded[0].1.inside_importance()),
                    );
                    compared += 1;
                }
            }
        }
        assert!(nonzero > 3 * compared, "{nonzero} of {compared}");
        assert!(inside > compared / 20, "{inside} of {compared}");
    }

    /// At several shading points: the probabilities sum to one, `sample`
    /// reports the probability `pdf` gives, its choices pass a chi-square
    /// test against `pdf`, and the rescaled u passes one against uniform.
    #[test]
    fn sample_matches_pdf() {
        use crate::sampling::Sampler;
        use crate::stats::{chi2_test, sidak};
        let shapes = [
            Geometry::Mesh(quad(2.0, true)),
            Geometry::Sphere(Sphere::new(Vec3::new(3.0, 0.0, 1.0), 0.5).unwrap()),
            Geometry::Mesh(quad(-2.0, false)),
        ];
        let ctx = EmitterContext {
            shapes: &shapes,
            scene_radius: 10.0,
        };
        let emitters = [
            Emitter::Area(AreaLight::new(0, Rgb::splat(3.0)).unwrap()),
            Emitter::Area(AreaLight::new(1, Rgb::splat(5.0)).unwrap()),
            Emitter::Point(PointLight::new(Vec3::new(-2.0, 1.0, 0.0), Rgb::splat(40.0)).unwrap()),
            Emitter::Area(AreaLight::new(2, Rgb::ZERO).unwrap()),
            Emitter::Area(AreaLight::new(2, Rgb::splat(1.0)).unwrap()),
        ];
        let c = LightChoice::new(&emitters, &ctx).unwrap();
        let points = [
            (Vec3::new(0.0, 0.0, 0.0), Vec3::Z),
            (Vec3::new(0.5, -0.3, 1.0), Vec3::X),
            (Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO),
            (Vec3::new(2.5, 0.4, 1.2), Vec3::new(0.6, 0.0, 0.8)),
        ];
        let alpha = sidak(0.01, 2 * points.len());
        let n = 100_000;
        const U_BINS: usize = 20;
        let mut sampler = Sampler::new(7, 0);
        for (p, nrm) in points {
            let at = c.at(p, nrm);
            let probs: Vec<f32> = (0..emitters.len()).map(|i| c.pdf(&at, i)).collect();
            assert_eq!(probs[3], 0.0, "a black light is never chosen");
            let sum: f32 = probs.iter().sum();
            assert!((sum - 1.0).abs() < 1e-5, "{probs:?}");
            let mut counts = vec![0.0f64; emitters.len()];
            let mut u_bins = vec![0.0f64; U_BINS];
            for _ in 0..n {
                let (i, pr, u2) = c.sample(&at, sampler.next_1d()).unwrap();
                assert!(
                    (pr - probs[i]).abs() <= 1e-5 * probs[i].max(1e-3),
                    "{pr} {}",
                    probs[i]
                );
                assert!((0.0..1.0).contains(&u2));
                counts[i] += 1.0;
                u_bins[(u2 * U_BINS as f32) as usize] += 1.0;
            }
            let expected: Vec<f64> = probs.iter().map(|&q| q as f64 * n as f64).collect();
            let r = chi2_test(&counts, &expected, 5.0);
            assert!(r.passes(alpha), "choice at {p}: {r:?}");
            let r = chi2_test(&u_bins, &[n as f64 / U_BINS as f64; U_BINS], 5.0);
            assert!(r.passes(alpha), "rescaled u at {p}: {r:?}");
        }
    }
}
