//! The unidirectional path tracer with three ways of finding light:
//! BSDF sampling (mats), emitter sampling (ems), and both with MIS.

use super::{sample_light_with, LightNumbers, PathParams, Strategy};
use crate::bsdf::BsdfSample;
use crate::color::{max_component, Rgb};
use crate::emitter::{ChoicePoint, Emitter, EnvPoint, LightHit, LightPdf, LightSample};
use crate::geometry::Intersection;
use crate::math::{Ray, Vec2, Vec3};
use crate::sampling::Sampler;
use crate::scene::Scene;
use crate::texture::SurfacePoint;

/// Power heuristic (beta = 2) weight of strategy `a` against `b`.
#[inline]
pub(super) fn power_heuristic(a: f32, b: f32) -> f32 {
    let (a2, b2) = (a * a, b * b);
    if a2 + b2 == 0.0 || !a2.is_finite() {
        if a2.is_infinite() {
            1.0
        } else {
            0.0
        }
    } else {
        a2 / (a2 + b2)
    }
}

/// Probability that emitter sampling at the shading point `at` picks
/// emitter `i`.
#[inline]
pub(super) fn choice_pdf(scene: &Scene, i: usize, at: &ChoicePoint) -> f32 {
    scene.light_choice.as_ref().map_or(0.0, |c| c.pdf(at, i))
}

/// Area emitters a camera ray passes through before its first hit, at most.
const MAX_EMITTER_SKIPS: usize = 64;

/// Mitsuba's `hide_emitters`: camera rays pass through area emitters (up
/// to [`MAX_EMITTER_SKIPS`] of them) to the surface behind.
pub(super) fn skip_area_emitters(
    scene: &Scene,
    ray: &Ray,
    mut hit: Option<Intersection>,
) -> Option<Intersection> {
    for _ in 0..MAX_EMITTER_SKIPS {
        match &hit {
            Some(its) if scene.shape_emitter[its.shape as usize].is_some() => {
                let o = its.spawn(ray.d);
                hit = scene.intersect(&Ray::new(o, ray.d));
            }
            _ => break,
        }
    }
    hit
}

/// The last real vertex of a path, against whose sampling density
/// emission found by the path is weighed (MIS with next-event estimation).
#[derive(Clone, Copy)]
pub(super) struct PrevVertex<'a> {
    /// Solid-angle density of the direction it sampled.
    pub pdf: f32,
    pub p: Vec3,
    /// Its light choice.
    pub at: &'a ChoicePoint,
}

/// Adds to `l` the emission at infinity seen along the escaping direction
/// `d`, times `beta`: weighed against NEE at `mis` if given, in full
/// otherwise. `camera_ray`: only emitters visible to the camera count.
/// `escape`: `d` located on an environment map before the ray was traced
/// ([`Scene::locate_escape`]), if it was.
#[allow(clippy::too_many_arguments)]
pub(super) fn add_infinite_emission(
    scene: &Scene,
    d: Vec3,
    escape: Option<(u32, EnvPoint)>,
    camera_ray: bool,
    beta: Rgb,
    mis: Option<PrevVertex>,
    which: LightPdf,
    l: &mut Rgb,
) {
    for &i in &scene.infinite {
        let e = &scene.emitters[i as usize];
        if camera_ray && !e.visible_to_camera() {
            continue;
        }
        let at = escape.filter(|&(j, _)| j == i).map(|(_, at)| at);
        let (le, w) = match mis {
            Some(prev) => {
                let (le, pdf) = e.eval_infinite_pdf(d, at, which, prev.at.facing);
                let pl = choice_pdf(scene, i as usize, prev.at) * pdf;
                (le, power_heuristic(prev.pdf, pl))
            }
            None => (e.eval_infinite_at(d, at), 1.0),
        };
        *l += beta * le * w;
    }
}

/// Adds to `l` the emission of the area light hit at `its` by a ray along
/// `d` (if it is one, seen from its front), times `beta`: weighed against
/// NEE at `mis` if given, in full otherwise.
pub(super) fn add_area_emission(
    scene: &Scene,
    its: &Intersection,
    d: Vec3,
    beta: Rgb,
    mis: Option<PrevVertex>,
    which: LightPdf,
    l: &mut Rgb,
) {
    let Some(ei) = scene.shape_emitter[its.shape as usize] else {
        return;
    };
    let e = &scene.emitters[ei as usize];
    let Emitter::Area(light) = e else {
        return;
    };
    if its.ng.dot(-d) <= 0.0 {
        return;
    }
    let w = match mis {
        Some(prev) => {
            let hit = LightHit {
                p: its.p,
                n: its.ng,
                prim: its.prim,
            };
            let pl = choice_pdf(scene, ei as usize, prev.at)
                * e.pdf(
                    &scene.emitter_context(),
                    prev.p,
                    d,
                    &hit,
                    which,
                    prev.at.facing,
                );
            power_heuristic(prev.pdf, pl)
        }
        None => 1.0,
    };
    *l += beta * light.radiance_at(its.surface_point()) * w;
}

/// The numbers of a BSDF sample (the direction's, then the lobe's),
/// drawn after the vertex's light sample is weighed.
#[inline]
pub(super) fn bsdf_numbers(sampler: &mut Sampler) -> (Vec2, f32) {
    let u = sampler.next_2d();
    (u, sampler.next_1d())
}

/// Russian roulette from `rr_depth` on (survival probability the
/// throughput's largest channel times `eta_scale`, at most 0.99); false
/// if the path ends.
#[inline]
pub(super) fn roulette(
    beta: &mut Rgb,
    eta_scale: f32,
    depth: u32,
    params: &PathParams,
    sampler: &mut Sampler,
) -> bool {
    if depth < params.rr_depth {
        return true;
    }
    let q = (max_component(*beta) * eta_scale).min(0.99);
    if sampler.next_1d() >= q {
        return false;
    }
    *beta /= q;
    true
}

/// What every path of one render shares: the strategy and its parameters,
/// worked out once.
#[derive(Clone, Copy, Debug)]
pub struct PathConfig {
    strategy: Strategy,
    pub which: LightPdf,
    max_depth: u32,
    /// A vertex at a depth below this draws the next vertex's light-sample
    /// numbers: `max_depth - 1` with next-event estimation (the vertex at
    /// `max_depth` ends the path before it would sample a light), 0
    /// without (`path_mats`). One comparison where a test of NEE and one
    /// of the depth would be two.
    light_numbers_below: u32,
    params: PathParams,
}

impl PathConfig {
    pub fn new(strategy: Strategy, params: &PathParams) -> PathConfig {
        let max_depth = params.max_depth.unwrap_or(u32::MAX);
        PathConfig {
            strategy,
            which: strategy.light_pdf(),
            max_depth,
            light_numbers_below: if strategy == Strategy::Mats {
                0
            } else {
                max_depth.saturating_sub(1)
            },
            params: *params,
        }
    }

    /// Whether emission a path finds by following it counts, after a
    /// bounce that was `specular` (or from the camera).
    #[inline]
    fn count_emission(&self, specular: bool) -> bool {
        match self.strategy {
            Strategy::Mats | Strategy::Mis => true,
            Strategy::Ems => specular,
        }
    }
}

/// One path between its vertices: what the loop of [`li`] carries from
/// one ray to the next. The steps are methods so that the same code runs
/// one path at a time ([`li`]) and as stages over a batch of paths
/// (`path_batch.rs`): both draw the same numbers in the same order and
/// give the same radiance, bit for bit.
#[derive(Clone)]
pub(super) struct PathState {
    /// The ray to trace next.
    pub ray: Ray,
    /// Radiance gathered so far.
    pub l: Rgb,
    beta: Rgb,
    /// Whether the last bounce was specular (or this is the camera ray).
    specular: bool,
    /// Solid-angle pdf of the BSDF sample that produced `ray`, and its origin.
    prev_pdf: f32,
    prev_p: Vec3,
    /// The light choice at the vertex that sampled `ray` (for MIS weights).
    prev_at: ChoicePoint,
    eta_scale: f32,
    /// Vertices so far (0 while the camera ray is traced).
    depth: u32,
    /// The next vertex's light-sample numbers, drawn ahead (LightNumbers).
    light_numbers: Option<LightNumbers>,
    /// Where `ray` meets the environment map, found (and its texels
    /// prefetched) before it is traced: bounce rays escape to random parts
    /// of the map, whose texels are rarely in the cache. Set by the caller
    /// after each bounce.
    escape: Option<(u32, EnvPoint)>,
}

impl PathState {
    /// A path starting with `camera_ray`; draws the first vertex's
    /// light-sample numbers.
    #[inline]
    pub fn new(
        scene: &Scene,
        cfg: &PathConfig,
        camera_ray: &Ray,
        sampler: &mut Sampler,
    ) -> PathState {
        // Every field is set again by `restart`, the one place that says
        // how a path starts.
        let mut path = PathState {
            ray: *camera_ray,
            l: Rgb::ZERO,
            beta: Rgb::ONE,
            specular: true,
            prev_pdf: 0.0,
            prev_p: camera_ray.o,
            prev_at: ChoicePoint::default(),
            eta_scale: 1.0,
            depth: 0,
            light_numbers: None,
            escape: None,
        };
        path.restart(scene, cfg, camera_ray, sampler);
        path
    }

    /// This path started again with `camera_ray`, field by field in
    /// place: a batch keeps its paths from batch to batch, and a whole
    /// new state assigned or pushed was built elsewhere and copied in (a
    /// `memcpy` call per sample).
    #[inline]
    pub fn restart(
        &mut self,
        scene: &Scene,
        cfg: &PathConfig,
        camera_ray: &Ray,
        sampler: &mut Sampler,
    ) {
        // Destructured without `..`: a field added to the path is a
        // compile error here until it is started too.
        let PathState {
            ray,
            l,
            beta,
            specular,
            prev_pdf,
            prev_p,
            prev_at,
            eta_scale,
            depth,
            light_numbers,
            escape,
        } = self;
        *ray = *camera_ray;
        *l = Rgb::ZERO;
        *beta = Rgb::ONE;
        *specular = true;
        *prev_pdf = 0.0;
        *prev_p = camera_ray.o;
        *prev_at = ChoicePoint::default();
        *eta_scale = 1.0;
        *depth = 0;
        *light_numbers = (cfg.light_numbers_below > 0)
            .then(|| LightNumbers::draw_ahead(scene, sampler, cfg.which));
        *escape = None;
    }

    /// Whether `ray` is a camera ray under `hide_emitters`: it passes
    /// through area emitters and counts no emission.
    #[inline]
    pub fn hides_emitters(&self, cfg: &PathConfig) -> bool {
        self.depth == 0 && cfg.params.hide_emitters
    }

    /// The surface `ray` reaches first (area emitters passed through for
    /// a camera ray under `hide_emitters`), if any.
    #[inline]
    pub fn trace(&self, scene: &Scene, cfg: &PathConfig) -> Option<Intersection> {
        let hit = scene.intersect(&self.ray);
        if self.hides_emitters(cfg) {
            skip_area_emitters(scene, &self.ray, hit)
        } else {
            hit
        }
    }

    /// [`PathState::trace`] writing the surface into `out` (left as it
    /// was if there is none); true if there is one.
    #[inline]
    pub fn trace_into(&self, scene: &Scene, cfg: &PathConfig, out: &mut Intersection) -> bool {
        if self.hides_emitters(cfg) {
            return match self.trace(scene, cfg) {
                Some(its) => {
                    *out = its;
                    true
                }
                None => false,
            };
        }
        scene.intersect_into(&self.ray, out)
    }

    /// The vertex whose density emission found along `ray` is weighed
    /// against, under MIS after a non-specular bounce.
    #[inline]
    fn mis_vertex(&self, cfg: &PathConfig) -> Option<PrevVertex<'_>> {
        (cfg.strategy == Strategy::Mis && !self.specular).then_some(PrevVertex {
            pdf: self.prev_pdf,
            p: self.prev_p,
            at: &self.prev_at,
        })
    }

    /// `ray` reached no surface: adds what it sees at infinity. The path
    /// ends.
    #[inline]
    pub fn escape(&mut self, scene: &Scene, cfg: &PathConfig) {
        if self.counts_escape(cfg) {
            let mut l = self.l;
            let mis = self.mis_vertex(cfg);
            let d = self.ray.d;
            add_infinite_emission(
                scene,
                d,
                self.escape,
                self.depth == 0,
                self.beta,
                mis,
                cfg.which,
                &mut l,
            );
            self.l = l;
        }
    }

    /// [`PathState::escape`] where the only light at infinity is a
    /// constant sky of radiance `le`, with `pl` its choice probability
    /// times its direction density (the same everywhere): the sums and
    /// products `add_infinite_emission` takes, without its search.
    #[inline]
    pub fn escape_to_constant(&mut self, cfg: &PathConfig, le: Rgb, pl: f32) {
        if self.counts_escape(cfg) {
            let w = match self.mis_vertex(cfg) {
                Some(prev) => power_heuristic(prev.pdf, pl),
                None => 1.0,
            };
            self.l += self.beta * le * w;
        }
    }

    /// Whether the path counts what its ray sees at infinity if it
    /// escapes (not a camera ray under `hide_emitters`, not after a
    /// diffuse bounce under `path_ems`).
    #[inline]
    fn counts_escape(&self, cfg: &PathConfig) -> bool {
        !self.hides_emitters(cfg) && cfg.count_emission(self.specular)
    }

    /// Where the escaped `ray` met the environment map that is emitter
    /// `i`, and the facing normal its MIS weight takes, if the path counts
    /// what it sees there and found it before the trace: then
    /// [`PathState::escape_located`] with that map's `eval_pdf_at` there
    /// is [`PathState::escape`] for a scene whose only emitter at
    /// infinity is `i`.
    #[inline]
    pub fn escape_point(&self, cfg: &PathConfig, i: u32) -> Option<(EnvPoint, Option<Vec3>)> {
        if !self.counts_escape(cfg) {
            return None;
        }
        let (j, at) = self.escape?;
        (j == i).then(|| (at, self.mis_vertex(cfg).and_then(|prev| prev.at.facing)))
    }

    /// Whether the escaped `ray` was not located on the environment map
    /// before its trace but the path counts what it sees at infinity (a
    /// camera ray): locating it now ([`PathState::set_escape`]) gives
    /// [`PathState::escape`] the point it would find itself.
    #[inline]
    pub fn counts_unlocated_escape(&self, cfg: &PathConfig) -> bool {
        self.escape.is_none() && self.counts_escape(cfg)
    }

    /// [`PathState::escape`] of a path that [`PathState::escape_point`]
    /// located on the map that is emitter `i`, the scene's only emitter at
    /// infinity (with a density for `cfg.which`), given the map's
    /// `eval_pdf_at` there: the same bits.
    #[inline]
    pub fn escape_located(&mut self, scene: &Scene, cfg: &PathConfig, i: u32, le_pdf: (Rgb, f32)) {
        if self.depth == 0 && !scene.emitters[i as usize].visible_to_camera() {
            return;
        }
        let (le, w) = match self.mis_vertex(cfg) {
            Some(prev) => {
                let pl = choice_pdf(scene, i as usize, prev.at) * le_pdf.1;
                (le_pdf.0, power_heuristic(prev.pdf, pl))
            }
            None => (le_pdf.0, 1.0),
        };
        self.l += self.beta * le * w;
    }

    /// Whether the new `ray` should be located on the environment map
    /// before it is traced ([`Scene::locate_escape`], then
    /// [`PathState::set_escape`]): only where the path would count what it
    /// finds there (not behind a diffuse bounce under `path_ems`).
    #[inline]
    pub fn wants_escape_located(&self, cfg: &PathConfig) -> bool {
        cfg.count_emission(self.specular)
    }

    /// Where the new `ray` meets the environment map.
    #[inline]
    pub fn set_escape(&mut self, escape: Option<(u32, EnvPoint)>) {
        self.escape = escape;
    }

    /// `ray` reached `its`: adds its emission and a light sample's
    /// contribution, and samples the BSDF for the next ray. False if the
    /// path ends there. The three steps of [`PathState::arrive`],
    /// [`PathState::next_event`] (with its light sample) and
    /// [`PathState::scatter`], which a batch runs as stages.
    #[inline]
    pub fn bounce(
        &mut self,
        scene: &Scene,
        cfg: &PathConfig,
        its: &Intersection,
        sampler: &mut Sampler,
    ) -> bool {
        if !self.arrive(scene, cfg, its) {
            return false;
        }
        let light = self
            .next_event(scene, its, true)
            .and_then(|numbers| sample_light_with(scene, its.p, &self.prev_at, numbers, cfg.which));
        let mut shadow = None;
        let going = self.scatter(scene, cfg, its, light, sampler, &mut shadow);
        if let Some(test) = shadow {
            if !scene.bvh.occluded(&test.ray) {
                self.l += test.l;
            }
        }
        going
    }

    /// A bounce's first step: adds the emission of the surface `ray`
    /// reached at `its` and counts the vertex. False if the path ends
    /// there (its longest length).
    #[inline]
    pub fn arrive(&mut self, scene: &Scene, cfg: &PathConfig, its: &Intersection) -> bool {
        // (The surface's emitter looked up here too: most surfaces have
        // none, and the call and its arguments cost more than the test.)
        if cfg.count_emission(self.specular)
            && !self.hides_emitters(cfg)
            && scene.shape_emitter[its.shape as usize].is_some()
        {
            let mut l = self.l;
            add_area_emission(
                scene,
                its,
                self.ray.d,
                self.beta,
                self.mis_vertex(cfg),
                cfg.which,
                &mut l,
            );
            self.l = l;
        }
        self.depth += 1;
        self.depth < cfg.max_depth
    }

    /// A bounce's second step: if the vertex at `its` takes a light sample
    /// (next-event estimation, not on a specular surface), sets the light
    /// choice it is taken and weighed with and returns its numbers; the
    /// caller samples ([`sample_light_with`] with `its.p` and
    /// [`PathState::choice_point`]) and hands the result to
    /// [`PathState::scatter`]. Unless `weigh`, the choice's lights are not
    /// weighed: the caller weighs them (a batch, eight points at once).
    #[inline]
    pub fn next_event(
        &mut self,
        scene: &Scene,
        its: &Intersection,
        weigh: bool,
    ) -> Option<LightNumbers> {
        let numbers = self.light_numbers?;
        let bsdf = &scene.bsdfs[its.shape as usize];
        if bsdf.is_specular() {
            return None;
        }
        let frame = its.shading;
        // A surface that only reflects receives light from the side of
        // its shading normal that `wi` is on (the BSDF is zero across):
        // an environment map then samples for that side (`facing.rs`).
        // Only at the first vertex: its light reaches the pixel
        // unattenuated and brings most of the variance (studio probe:
        // MSE 0.52x with it there, 0.49x at every vertex), while each
        // facing sample costs about a fifth more than the map's own
        // (maps where it would not pay have no facing density at all).
        let facing = (self.depth == 1 && bsdf.favours_facing_light()).then(|| {
            if frame.to_local(-self.ray.d).z < 0.0 {
                -frame.n
            } else {
                frame.n
            }
        });
        scene.set_choice_point(&mut self.prev_at, its.p, frame.n, facing, weigh);
        Some(numbers)
    }

    /// The light choice of this vertex's light sample (set by
    /// [`PathState::next_event`]).
    #[inline]
    pub fn choice_point(&self) -> &ChoicePoint {
        &self.prev_at
    }

    /// [`PathState::choice_point`] to weigh ([`PathState::next_event`]
    /// without `weigh`).
    #[cfg(target_arch = "x86_64")]
    #[inline]
    pub fn choice_point_mut(&mut self) -> &mut ChoicePoint {
        &mut self.prev_at
    }

    /// A bounce's last step: the contribution of the light sample `light`
    /// (with the probability of its emitter's choice) taken at `its`, if
    /// any and not zero, set in `shadow` with the ray that must be
    /// unblocked for it to count (the caller traces it and adds it to
    /// `l`: a batch traces them together); then samples the BSDF for the
    /// next ray. False if the path ends there.
    #[inline]
    pub fn scatter(
        &mut self,
        scene: &Scene,
        cfg: &PathConfig,
        its: &Intersection,
        light: Option<(LightSample, f32)>,
        sampler: &mut Sampler,
        shadow: &mut Option<ShadowTest>,
    ) -> bool {
        let sp = scene.surface_point(its);
        let wi = self.local_wi(its);
        let light = light.as_ref().map(|(ls, pchoice)| (ls, *pchoice));
        self.weigh_light(scene, cfg, its, &sp, wi, light, |t| *shadow = Some(t));
        // Continue the path by sampling the BSDF.
        let (u, u_lobe) = bsdf_numbers(sampler);
        let bs = scene.bsdfs[its.shape as usize].sample(sp, wi, u, u_lobe);
        self.follow(scene, cfg, its, wi, bs.as_ref(), sampler)
    }

    /// The direction back along `ray` in the shading frame at `its`.
    #[inline]
    pub fn local_wi(&self, its: &Intersection) -> Vec3 {
        its.shading.to_local(-self.ray.d)
    }

    /// [`PathState::scatter`]'s first part: the contribution of the light
    /// sample `light` (with its emitter's choice probability) at `its`
    /// (its texture point `sp`; `wi` is [`PathState::local_wi`]), if any
    /// and not zero, handed to `shadow` with the ray that must be
    /// unblocked for it to count (a batch stores it where it stays: a
    /// test returned through memory was copied by loads that waited on
    /// the stores just made). A batch runs the three parts as steps over
    /// several paths (see `path_batch.rs`): each path draws the same
    /// numbers in the same order.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub fn weigh_light(
        &self,
        scene: &Scene,
        cfg: &PathConfig,
        its: &Intersection,
        sp: &SurfacePoint,
        wi: Vec3,
        light: Option<(&LightSample, f32)>,
        shadow: impl FnOnce(ShadowTest),
    ) {
        let strategy = cfg.strategy;
        let bsdf = &scene.bsdfs[its.shape as usize];
        let frame = its.shading;

        // Next-event estimation.
        if let Some((ls, pchoice)) = light {
            let wo = frame.to_local(ls.wi);
            // The BSDF's density only where MIS weighs with it, and then
            // with its value in one call (they share work).
            let mis = strategy == Strategy::Mis && !ls.delta;
            let (f, bsdf_pdf) = if mis {
                bsdf.eval_pdf(*sp, wi, wo)
            } else {
                (bsdf.eval(*sp, wi, wo), 0.0)
            };
            if f != Rgb::ZERO && ls.weight != Rgb::ZERO {
                let w = if mis {
                    power_heuristic(ls.pdf * pchoice, bsdf_pdf)
                } else {
                    1.0
                };
                shadow(ShadowTest {
                    ray: Scene::shadow_ray(its, ls),
                    l: self.beta * f * wo.z.abs() * ls.weight * (w / pchoice),
                });
            }
        }
    }

    /// [`PathState::scatter`]'s last part: the path follows the BSDF
    /// sample `bs` drawn at `its` for the local `wi` (none: it ends).
    /// False if the path ends there.
    #[inline]
    pub fn follow(
        &mut self,
        scene: &Scene,
        cfg: &PathConfig,
        its: &Intersection,
        wi: Vec3,
        bs: Option<&BsdfSample>,
        sampler: &mut Sampler,
    ) -> bool {
        let Some(bs) = bs else {
            return false;
        };
        let wi_world = -self.ray.d;
        let which = cfg.which;
        let frame = its.shading;
        let wo_world = frame.to_world(bs.wo);
        // Reject samples that cross the geometric surface against the
        // shading normal's verdict (light leaks through shading normals).
        if wo_world.dot(its.ng) * bs.wo.z <= 0.0 && wi_world.dot(its.ng) * wi.z > 0.0 {
            return false;
        }
        self.beta *= bs.weight;
        self.eta_scale *= bs.eta * bs.eta;
        self.specular = bs.specular;
        self.prev_pdf = if bs.specular { 0.0 } else { bs.pdf };
        self.prev_p = its.p;
        if self.beta == Rgb::ZERO {
            return false;
        }

        if !roulette(
            &mut self.beta,
            self.eta_scale,
            self.depth,
            &cfg.params,
            sampler,
        ) {
            return false;
        }

        let o = its.spawn(wo_world);
        self.ray = Ray::new(o, wo_world);
        // Located by the caller (`wants_escape_located`).
        self.escape = None;
        // The next vertex takes a light sample only if the path may go
        // on from it (`arrive`); at the last one nothing is drawn after
        // this, so leaving its numbers undrawn changes no other number.
        self.light_numbers = (self.depth < cfg.light_numbers_below)
            .then(|| LightNumbers::draw_ahead(scene, sampler, which));
        true
    }
}

/// A light sample's contribution to a path's radiance, which counts if
/// nothing blocks `ray` ([`Scene::shadow_ray`]).
#[derive(Clone, Copy, Debug)]
pub struct ShadowTest {
    pub ray: Ray,
    pub l: Rgb,
}

/// One sample of the radiance arriving along `camera_ray`.
pub fn li(
    scene: &Scene,
    camera_ray: &Ray,
    sampler: &mut Sampler,
    strategy: Strategy,
    params: &PathParams,
) -> Rgb {
    let cfg = PathConfig::new(strategy, params);
    let mut path = PathState::new(scene, &cfg, camera_ray, sampler);
    loop {
        match path.trace(scene, &cfg) {
            None => {
                path.escape(scene, &cfg);
                break;
            }
            Some(its) => {
                if !path.bounce(scene, &cfg, &its, sampler) {
                    break;
                }
                if path.wants_escape_located(&cfg) {
                    path.set_escape(scene.locate_escape(path.ray.d, cfg.which));
                }
            }
        }
    }
    path.l
}
