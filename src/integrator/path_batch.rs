//! The path tracer run as stages over a batch of paths (a wavefront):
//! every live path's ray is traced, then the paths that escaped gather
//! what they see at infinity, then the paths that hit a surface bounce
//! (emission, light samples, BSDF samples, each step over all of them;
//! the ones that go on are kept, in order), then their new rays are
//! located on the environment map; the next round starts.
//!
//! Each path keeps its own [`Sampler`] and runs the steps of
//! [`PathState`], so it draws the same numbers in the same order as
//! [`super::path::li`] and returns the same radiance bit for bit (tested):
//! the batch changes the order of the work, not the image. (In a scene
//! small enough for packets, a ray that meets two surfaces at exactly the
//! same distance may keep the other one: [`crate::geometry::Bvh::intersect_packet`].)
//! It is the frame for stages that work on many paths at once (SIMD lanes
//! across paths, issue 15): the trace of a small scene runs packets of
//! sixteen rays (in AVX-512's sixteen lanes on CPUs that run them at full
//! rate, in two walks of eight lanes elsewhere); the environment map's lookups of escaped paths,
//! its light samples, the cone samples of sphere lights and the
//! directions of constant skies' samples (within the bounce stage) and the location of new rays on the map (the last stage)
//! run four paths at a time; the rest takes one path at a time.

use super::path::{bsdf_numbers, PathConfig, PathState};
use super::LightNumbers;
use crate::bsdf::{Bsdf, BsdfSample};
use crate::color::Rgb;
use crate::emitter::{
    sample_triangles_lanes, AreaLight, ConstantLight, Emitter, EmitterContext, EnvMap, EnvPoint,
    LightPdf, LightSample, TriangleRequest,
};
use crate::geometry::{sample_cones_lanes, Geometry, Intersection, Sphere, PACKET_LANES};
use crate::math::{Ray, Vec2, Vec3};
use crate::sampling::{warp, Sampler};
use crate::scene::Scene;
use crate::texture::SurfacePoint;

/// Paths traced together: big enough for lanes of 8 or 16 to stay full
/// for several rounds, small enough that the batch's state (about 300
/// bytes a path) stays in the L2 cache.
pub const BATCH_PATHS: usize = 256;

/// The radiance of the scene's only light at infinity if it is a constant
/// sky, with its choice probability times its direction density: both
/// the same for every path that escapes.
fn constant_sky(scene: &Scene) -> Option<(Rgb, f32)> {
    let [i] = scene.infinite[..] else {
        return None;
    };
    let Emitter::Constant(sky) = &scene.emitters[i as usize] else {
        return None;
    };
    let choice = match &scene.light_choice {
        Some(c) => c.pdf_everywhere(i as usize)?,
        None => 0.0,
    };
    Some((sky.radiance, choice * sky.uniform_pdf()))
}

/// The state of a batch of paths, its buffers kept from batch to batch
/// (each rendering thread allocates them once).
#[derive(Default)]
pub struct PathBatch {
    /// The batch's paths: the first `rays.len()` of them (any beyond are
    /// a larger batch's, kept to be started again).
    paths: Vec<PathState>,
    /// The surfaces the live paths' rays reached, written in place by the
    /// trace (not copied about as `Option`s): `hits[k]` is path
    /// `hit_paths[k]`'s, for the first `reached` of them.
    hits: Vec<Intersection>,
    hit_paths: Vec<u32>,
    reached: usize,
    /// The paths whose rays escaped, the first `escaped` of them. Both
    /// lists are filled without branches (which path escapes is random),
    /// so the stages after the trace loop only over their own paths.
    escaped_paths: Vec<u32>,
    escaped: usize,
    /// Indices of the paths still going, in order.
    live: Vec<u32>,
    /// The bounce stage's paths that arrived and go on (indices into
    /// `hits`), each with its light sample's numbers (if it takes one),
    /// then the light sample taken (written in place by the emitter) and
    /// its emitter's choice probability.
    arrived: Vec<u32>,
    requests: Vec<Option<LightNumbers>>,
    lights: Vec<Option<LightSample>>,
    light_pchoice: Vec<f32>,
    /// The bounce stage's shadow rays, and the path and contribution of
    /// each (added where the ray is unblocked).
    shadow_rays: Vec<Ray>,
    shadow_paths: Vec<(u32, Rgb)>,
}

impl PathBatch {
    pub fn new() -> PathBatch {
        PathBatch::default()
    }

    /// The radiance along each of `rays` (at most [`BATCH_PATHS`]), the
    /// path of `rays[k]` drawing from `samplers[k]`, into `out[k]`.
    pub fn radiance(
        &mut self,
        scene: &Scene,
        cfg: &PathConfig,
        rays: &[Ray],
        samplers: &mut [Sampler],
        out: &mut [Rgb],
    ) {
        assert!(rays.len() == samplers.len() && rays.len() == out.len());
        self.live.clear();
        // At most every path arrives in the bounce stage: room for all of
        // them now, so that no later round of a batch this size allocates.
        let n = rays.len();
        self.arrived.clear();
        self.requests.clear();
        self.lights.clear();
        self.light_pchoice.clear();
        self.arrived.reserve(n);
        self.requests.reserve(n);
        self.lights.reserve(n);
        self.light_pchoice.reserve(n);
        self.shadow_rays.clear();
        self.shadow_paths.clear();
        self.shadow_rays.reserve(n);
        self.shadow_paths.reserve(n);
        for (k, (ray, sampler)) in rays.iter().zip(samplers.iter_mut()).enumerate() {
            // Each thread's batch keeps its paths from batch to batch and
            // starts them again where they lie (`PathState::restart`).
            match self.paths.get_mut(k) {
                Some(path) => path.restart(scene, cfg, ray, sampler),
                None => self.paths.push(PathState::new(scene, cfg, ray, sampler)),
            }
            self.live.push(k as u32);
        }
        while !self.live.is_empty() {
            self.trace(scene, cfg);
            self.escape(scene, cfg);
            self.bounce(scene, cfg, samplers);
            self.locate(scene, cfg);
        }
        for (o, path) in out.iter_mut().zip(&self.paths) {
            *o = path.l;
        }
    }

    /// Stage 1: the surface every live path's ray reaches first; the
    /// paths sorted into those that reached one and those that escaped.
    fn trace(&mut self, scene: &Scene, cfg: &PathConfig) {
        let n = self.live.len();
        if self.hits.len() < n {
            self.hits.resize(n, Intersection::UNSET);
            self.hit_paths.resize(n, 0);
            self.escaped_paths.resize(n, 0);
        }
        if scene.walks_packets() {
            return self.trace_packets(scene, cfg);
        }
        let (mut reached, mut escaped) = (0, 0);
        for &i in &self.live {
            // A miss leaves the slot as it was: the next path writes it.
            let found = self.paths[i as usize].trace_into(scene, cfg, &mut self.hits[reached]);
            self.hit_paths[reached] = i;
            self.escaped_paths[escaped] = i;
            reached += usize::from(found);
            escaped += usize::from(!found);
        }
        (self.reached, self.escaped) = (reached, escaped);
    }

    /// [`PathBatch::trace`] in packets of [`PACKET_LANES`] rays
    /// ([`Scene::intersect_packet_into`]), the paths in the same order;
    /// camera rays that pass through emitters (`hide_emitters`) are traced
    /// one at a time.
    fn trace_packets(&mut self, scene: &Scene, cfg: &PathConfig) {
        let (mut reached, mut escaped) = (0, 0);
        let mut rays = [Ray::new(Vec3::ZERO, Vec3::Z); PACKET_LANES];
        let mut found = [false; PACKET_LANES];
        for chunk in self.live.chunks(PACKET_LANES) {
            let hiding = chunk
                .iter()
                .any(|&i| self.paths[i as usize].hides_emitters(cfg));
            if hiding {
                for &i in chunk {
                    let path = &self.paths[i as usize];
                    let f = path.trace_into(scene, cfg, &mut self.hits[reached]);
                    self.hit_paths[reached] = i;
                    self.escaped_paths[escaped] = i;
                    reached += usize::from(f);
                    escaped += usize::from(!f);
                }
                continue;
            }
            for (ray, &i) in rays.iter_mut().zip(chunk) {
                *ray = self.paths[i as usize].ray;
            }
            let n = chunk.len();
            scene.intersect_packet_into(&rays[..n], &mut found[..n], &mut self.hits[reached..]);
            for (&i, &f) in chunk.iter().zip(&found) {
                self.hit_paths[reached] = i;
                self.escaped_paths[escaped] = i;
                reached += usize::from(f);
                escaped += usize::from(!f);
            }
        }
        (self.reached, self.escaped) = (reached, escaped);
    }

    /// Stage 2: the paths whose rays escaped add what they see at
    /// infinity (they end there). Where the scene's one emitter at
    /// infinity is an environment map, the paths located on it before the
    /// trace look it up four at a time in SIMD lanes
    /// ([`EnvMap::eval_pdf_at_lanes`]).
    fn escape(&mut self, scene: &Scene, cfg: &PathConfig) {
        let env = match scene.infinite[..] {
            [i] => match &scene.emitters[i as usize] {
                Emitter::Environment(env) if env.has_density(cfg.which) => Some((i, env)),
                _ => None,
            },
            _ => None,
        };
        let Some((e, env)) = env else {
            if let Some((le, pl)) = constant_sky(scene) {
                for &i in &self.escaped_paths[..self.escaped] {
                    self.paths[i as usize].escape_to_constant(cfg, le, pl);
                }
                return;
            }
            for &i in &self.escaped_paths[..self.escaped] {
                self.paths[i as usize].escape(scene, cfg);
            }
            return;
        };
        let mut group = EscapeGroup::new(e, env);
        // Camera rays are not located before their trace (most of them
        // hit something): those that escaped are located now, four at a
        // time.
        let mut unlocated = ([0usize; 4], 0usize);
        for &i in &self.escaped_paths[..self.escaped] {
            let i = i as usize;
            let path = &mut self.paths[i];
            if let Some((at, facing)) = path.escape_point(cfg, e) {
                group.push(i, at, facing, scene, cfg, &mut self.paths);
            } else if path.counts_unlocated_escape(cfg) {
                unlocated.0[unlocated.1] = i;
                unlocated.1 += 1;
                if unlocated.1 == 4 {
                    group.locate(&unlocated.0, 4, scene, cfg, &mut self.paths);
                    unlocated.1 = 0;
                }
            } else {
                path.escape(scene, cfg);
            }
        }
        if unlocated.1 > 0 {
            let (paths, n) = unlocated;
            group.locate(&paths, n, scene, cfg, &mut self.paths);
        }
        if group.n > 0 {
            group.flush(scene, cfg, &mut self.paths);
        }
    }

    /// Stage 3: the paths that reached a surface bounce there, in three
    /// steps over all of them (see [`PathState::bounce`]): emission and
    /// depth, the light samples (an environment map's four at a time, in
    /// SIMD lanes), then the light samples' contributions and the BSDF
    /// samples. Those that go on stay live, in order.
    fn bounce(&mut self, scene: &Scene, cfg: &PathConfig, samplers: &mut [Sampler]) {
        self.arrived.clear();
        self.requests.clear();
        let in_lanes = scene
            .light_choice
            .as_ref()
            .is_some_and(|c| c.weighs_points_in_lanes());
        for (k, (its, &i)) in self
            .hits
            .iter()
            .zip(&self.hit_paths[..self.reached])
            .enumerate()
        {
            let path = &mut self.paths[i as usize];
            if path.arrive(scene, cfg, its) {
                self.arrived.push(k as u32);
                self.requests.push(path.next_event(scene, its, !in_lanes));
            }
        }
        if in_lanes {
            self.weigh_choice_points(scene);
        }
        self.sample_lights(scene, cfg.which);
        let mut kept = 0;
        self.live.resize(self.arrived.len(), 0);
        self.shadow_rays.clear();
        self.shadow_paths.clear();
        // `PathState::scatter` in its three parts, four paths at a time:
        // each weighs its light sample and draws its BSDF numbers, then
        // the diffuse ones map theirs to directions together in lanes,
        // then each follows its sample (the same numbers in the same
        // order per path, the same bits).
        for ((ks, lights), pchoices) in (self.arrived.chunks(4))
            .zip(self.lights.chunks(4))
            .zip(self.light_pchoice.chunks(4))
        {
            let mut wi = [Vec3::ZERO; 4];
            let mut sp = [SurfacePoint::default(); 4];
            let mut u = [Vec2::ZERO; 4];
            let mut u_lobe = [0.0f32; 4];
            let mut diffuse = false;
            for (m, ((&k, light), &pchoice)) in ks.iter().zip(lights).zip(pchoices).enumerate() {
                let (its, i) = (&self.hits[k as usize], self.hit_paths[k as usize] as usize);
                let path = &self.paths[i];
                scene.set_surface_point(&mut sp[m], its);
                wi[m] = path.local_wi(its);
                let (rays, paths) = (&mut self.shadow_rays, &mut self.shadow_paths);
                let light = light.as_ref().map(|ls| (ls, pchoice));
                path.weigh_light(scene, cfg, its, &sp[m], wi[m], light, |test| {
                    rays.push(test.ray);
                    paths.push((i as u32, test.l));
                });
                (u[m], u_lobe[m]) = bsdf_numbers(&mut samplers[i]);
                diffuse |= matches!(scene.bsdfs[its.shape as usize], Bsdf::Diffuse(_));
            }
            let cosine = diffuse.then(|| warp::square_to_cosine_hemisphere_lanes(&u));
            // The samples side by side (independent work the CPU overlaps),
            // then each path follows its own, reading it where it was
            // written (copied whole, its fields just stored were loaded
            // back in wider pieces that waited on the stores).
            let mut samples: [Option<BsdfSample>; 4] = [None; 4];
            for (m, (&k, bs)) in ks.iter().zip(&mut samples).enumerate() {
                let its = &self.hits[k as usize];
                let bsdf = &scene.bsdfs[its.shape as usize];
                // `Diffuse::sample`, its map from the lanes. (Stored in each
                // arm: a value of the match went through a temporary.)
                match (bsdf, &cosine) {
                    (Bsdf::Diffuse(b), Some(wo)) => {
                        *bs = (wi[m].z > 0.0).then(|| b.sample_toward(wo[m])).flatten()
                    }
                    _ => *bs = bsdf.sample(sp[m], wi[m], u[m], u_lobe[m]),
                }
            }
            for (m, (&k, bs)) in ks.iter().zip(&samples).enumerate() {
                let (its, i) = (&self.hits[k as usize], self.hit_paths[k as usize] as usize);
                let bs = bs.as_ref();
                let going = self.paths[i].follow(scene, cfg, its, wi[m], bs, &mut samplers[i]);
                self.live[kept] = i as u32;
                kept += usize::from(going);
            }
        }
        self.live.truncate(kept);
        self.trace_shadows(scene);
    }

    /// Stage 3's light choices, where [`PathState::next_event`] left them
    /// unweighed: the bounded lights weighed at the points of the paths
    /// that take a light sample, eight points at a time in AVX lanes
    /// ([`crate::emitter::LightChoice::weigh_points`]; the same weights
    /// as one point at a time). On Veach's scene weighing one point's five
    /// lights at a time was 15% of a render.
    #[cfg(target_arch = "x86_64")]
    fn weigh_choice_points(&mut self, scene: &Scene) {
        let Some(choice) = scene.light_choice.as_ref() else {
            return;
        };
        let mut chunk = [0usize; 8];
        let mut n = 0;
        let mut weights = crate::emitter::PointWeights8::default();
        let mut flush = |paths: &mut [PathState], chunk: &[usize; 8], n: usize| {
            // Unused lanes repeat the last point; their weights are dropped.
            let (mut p, mut nrm) = ([Vec3::ZERO; 8], [Vec3::ZERO; 8]);
            for k in 0..8 {
                (p[k], nrm[k]) = paths[chunk[k.min(n - 1)]].choice_point().point();
            }
            choice.weigh_points(&p, &nrm, &mut weights);
            for (lane, &i) in chunk[..n].iter().enumerate() {
                paths[i].choice_point_mut().take_weights(&weights, lane);
            }
        };
        for (&k, request) in self.arrived.iter().zip(&self.requests) {
            if request.is_some() {
                chunk[n] = self.hit_paths[k as usize] as usize;
                n += 1;
                if n == 8 {
                    flush(&mut self.paths, &chunk, n);
                    n = 0;
                }
            }
        }
        if n > 0 {
            flush(&mut self.paths, &chunk, n);
        }
    }

    /// [`PathBatch::weigh_choice_points`] where no CPU weighs in lanes
    /// (`weighs_points_in_lanes` is false, so never called).
    #[cfg(not(target_arch = "x86_64"))]
    fn weigh_choice_points(&mut self, _scene: &Scene) {}

    /// Stage 3's shadow rays, sixteen at a time ([`Scene::occluded_packet`]):
    /// each light sample's contribution is added to its path where nothing
    /// blocks its ray (after the path's BSDF sample, which does not read
    /// the radiance: the same sums as `li`'s).
    fn trace_shadows(&mut self, scene: &Scene) {
        let mut blocked = [false; PACKET_LANES];
        for (rays, paths) in self
            .shadow_rays
            .chunks(PACKET_LANES)
            .zip(self.shadow_paths.chunks(PACKET_LANES))
        {
            scene.occluded_packet(rays, &mut blocked[..rays.len()]);
            for (&(i, l), &b) in paths.iter().zip(&blocked) {
                if !b {
                    self.paths[i as usize].l += l;
                }
            }
        }
    }

    /// Stage 3's light samples: `lights[j]` and `light_pchoice[j]` are
    /// what `sample_light_with` gives for `requests[j]` at its path's hit,
    /// bit for bit. Samples of one environment map are gathered four at a
    /// time and drawn in lanes ([`EnvMap::sample_lanes`]); so are the cone
    /// samples of sphere lights, any mix of them ([`sample_cones_lanes`]),
    /// and constant skies' samples ([`ConstantGroup`]); other emitters
    /// sample one at a time.
    fn sample_lights(&mut self, scene: &Scene, which: LightPdf) {
        self.lights.clear();
        self.lights.resize(self.arrived.len(), None);
        self.light_pchoice.clear();
        self.light_pchoice.resize(self.arrived.len(), 0.0);
        let Some(choice) = scene.light_choice.as_ref() else {
            return;
        };
        let ctx = scene.emitter_context();
        let mut group = EnvGroup::default();
        let mut spheres = SphereGroup::default();
        let mut constants = ConstantGroup::default();
        let mut triangles = TriangleGroup::default();
        for (j, (&k, numbers)) in self.arrived.iter().zip(&self.requests).enumerate() {
            let Some(numbers) = numbers else {
                continue;
            };
            let its = &self.hits[k as usize];
            let at = self.paths[self.hit_paths[k as usize] as usize].choice_point();
            let Some((e, pchoice, u1)) = choice.sample(at, numbers.choice) else {
                continue;
            };
            self.light_pchoice[j] = pchoice;
            match &scene.emitters[e] {
                Emitter::Environment(env) if group.n == 0 || group.emitter == e => {
                    let m = group.n;
                    group.emitter = e;
                    group.env = Some(env);
                    group.slot[m] = j;
                    group.p[m] = its.p;
                    group.u[m] = numbers.u;
                    group.facing[m] = at.facing;
                    group.n += 1;
                    if group.n == 4 {
                        group.flush(&ctx, which, &mut self.lights);
                    }
                }
                Emitter::Area(area) => match &ctx.shapes[area.shape as usize] {
                    Geometry::Sphere(sphere) => {
                        let m = spheres.n;
                        spheres.slot[m] = j;
                        spheres.light[m] = Some((area, sphere));
                        spheres.p[m] = its.p;
                        spheres.u[m] = numbers.u;
                        spheres.u1[m] = u1;
                        spheres.n += 1;
                        if spheres.n == 4 {
                            spheres.flush(&ctx, &mut self.lights);
                        }
                    }
                    Geometry::Mesh(mesh) if area.samples_in_lanes() => {
                        let m = triangles.n;
                        triangles.slot[m] = j;
                        triangles.requests[m] = Some(TriangleRequest {
                            light: area,
                            mesh,
                            p: its.p,
                            u: numbers.u,
                            u1,
                        });
                        triangles.n += 1;
                        if triangles.n == 4 {
                            triangles.flush(&ctx, &mut self.lights);
                        }
                    }
                    _ => area.sample_into(&ctx, its.p, numbers.u, u1, &mut self.lights[j]),
                },
                Emitter::Constant(sky) => {
                    let m = constants.n;
                    constants.slot[m] = j;
                    constants.sky[m] = Some(sky);
                    constants.p[m] = its.p;
                    constants.u[m] = numbers.u;
                    constants.n += 1;
                    if constants.n == 4 {
                        constants.flush(&ctx, &mut self.lights);
                    }
                }
                emitter => {
                    self.lights[j] = emitter.sample(&ctx, its.p, numbers.u, u1, which, at.facing);
                }
            }
        }
        if group.n > 0 {
            group.flush(&ctx, which, &mut self.lights);
        }
        if spheres.n > 0 {
            spheres.flush(&ctx, &mut self.lights);
        }
        if constants.n > 0 {
            constants.flush(&ctx, &mut self.lights);
        }
        if triangles.n > 0 {
            triangles.flush(&ctx, &mut self.lights);
        }
    }

    /// Stage 4: the new rays that may escape are located on the
    /// environment map (and its texels prefetched), four at a time in
    /// SIMD lanes.
    fn locate(&mut self, scene: &Scene, cfg: &PathConfig) {
        // Without an environment map every point is `None`, which every
        // path holds from its start: nothing to locate (1.2% of a
        // constant-lit scene's instructions went to finding that out).
        if !scene.has_environment_map {
            return;
        }
        let mut chunk = [0usize; 4];
        let mut n = 0;
        let flush = |paths: &mut [PathState], chunk: &[usize; 4], n: usize| {
            // The directions read where they lie (see `Lanes3::gather`).
            let d = std::array::from_fn(|k| &paths[chunk[k.min(n - 1)]].ray.d);
            let at = scene.locate_escape_lanes(d, cfg.which);
            for k in 0..n {
                paths[chunk[k]].set_escape(at[k]);
            }
        };
        for &i in &self.live {
            if self.paths[i as usize].wants_escape_located(cfg) {
                chunk[n] = i as usize;
                n += 1;
                if n == 4 {
                    flush(&mut self.paths, &chunk, n);
                    n = 0;
                }
            }
        }
        if n > 0 {
            flush(&mut self.paths, &chunk, n);
        }
    }
}

/// Up to four light samples of one environment map (`env`, emitter
/// `emitter`) waiting to be drawn together: where each goes in `lights`,
/// its shading point, numbers and facing normal.
#[derive(Default)]
struct EnvGroup<'a> {
    n: usize,
    emitter: usize,
    env: Option<&'a EnvMap>,
    slot: [usize; 4],
    p: [Vec3; 4],
    u: [Vec2; 4],
    facing: [Option<Vec3>; 4],
}

impl EnvGroup<'_> {
    /// Draws the waiting samples (at least one) into their slots of
    /// `lights` (unused lanes repeat the last one and are dropped), and
    /// empties the group.
    fn flush(&mut self, ctx: &EmitterContext, which: LightPdf, lights: &mut [Option<LightSample>]) {
        let (n, Some(env)) = (self.n, self.env) else {
            unreachable!("a group with samples has its map");
        };
        let lane = |k: usize| k.min(n - 1);
        let u = std::array::from_fn(|k| self.u[lane(k)]);
        let facing = std::array::from_fn(|k| self.facing[lane(k)]);
        let drawn = env.sample_lanes(&u, which, &facing);
        for (m, d) in drawn.iter().enumerate().take(n) {
            lights[self.slot[m]] = d
                .map(|(wi, weight, pdf)| LightSample::at_infinity(ctx, self.p[m], wi, weight, pdf));
        }
        self.n = 0;
    }
}

/// Up to four light samples of sphere lights (any mix of them) waiting
/// to be drawn together: where each goes in `lights`, its light and
/// sphere, shading point and numbers.
#[derive(Default)]
struct SphereGroup<'a> {
    n: usize,
    slot: [usize; 4],
    light: [Option<(&'a AreaLight, &'a Sphere)>; 4],
    p: [Vec3; 4],
    u: [Vec2; 4],
    u1: [f32; 4],
}

impl SphereGroup<'_> {
    /// Draws the waiting samples (at least one) into their slots of
    /// `lights`: the cones in lanes ([`sample_cones_lanes`]; unused lanes
    /// repeat the last one and are dropped), a point inside its sphere by
    /// the scalar [`AreaLight::sample`], as `sample_light_with` would; and
    /// empties the group.
    fn flush(&mut self, ctx: &EmitterContext, lights: &mut [Option<LightSample>]) {
        let n = self.n;
        let light = |k: usize| self.light[k.min(n - 1)].expect("a filled lane has its light");
        let cones = sample_cones_lanes(
            std::array::from_fn(|k| light(k).1),
            std::array::from_fn(|k| &self.p[k.min(n - 1)]),
            std::array::from_fn(|k| self.u[k.min(n - 1)]),
        );
        for m in 0..n {
            let area = light(m).0;
            let out = &mut lights[self.slot[m]];
            if cones.inside & (1 << m) != 0 {
                area.sample_into(ctx, self.p[m], self.u[m], self.u1[m], out);
            } else if area.texture.is_none() {
                // `set_light_sample` of a constant radiance, written in
                // place from the lanes.
                let pdf = cones.pdf[m];
                *out = Some(LightSample {
                    wi: cones.wi.lane(m),
                    p: cones.point.lane(m),
                    err: cones.err.lane(m),
                    n: cones.n.lane(m),
                    dist: cones.dist[m],
                    weight: area.radiance / pdf,
                    pdf,
                    delta: false,
                });
            } else if let Some(c) = cones.lane(m) {
                area.set_light_sample(ctx, &c.s, c.wi, c.dist, c.pdf, out);
            }
        }
        self.n = 0;
    }
}

/// Up to four light samples of emitting meshes waiting to be drawn
/// together ([`sample_triangles_lanes`]): where each goes in `lights`, and
/// what it asks for.
#[derive(Default)]
struct TriangleGroup<'a> {
    n: usize,
    slot: [usize; 4],
    requests: [Option<TriangleRequest<'a>>; 4],
}

impl TriangleGroup<'_> {
    /// Draws the waiting samples (at least one) into their slots of
    /// `lights`, and empties the group.
    fn flush(&mut self, ctx: &EmitterContext, lights: &mut [Option<LightSample>]) {
        sample_triangles_lanes(ctx, &self.requests, self.n, &self.slot, lights);
        self.n = 0;
    }
}

/// Up to four light samples of constant skies waiting to be drawn
/// together: where each goes in `lights`, its sky, shading point and
/// numbers.
#[derive(Default)]
struct ConstantGroup<'a> {
    n: usize,
    slot: [usize; 4],
    sky: [Option<&'a ConstantLight>; 4],
    p: [Vec3; 4],
    u: [Vec2; 4],
}

impl ConstantGroup<'_> {
    /// Draws the waiting samples (at least one) into their slots of
    /// `lights`: the directions in lanes
    /// ([`warp::square_to_uniform_sphere_lanes`]; unused lanes repeat the
    /// last one and are dropped), the rest as [`ConstantLight::sample`];
    /// and empties the group.
    fn flush(&mut self, ctx: &EmitterContext, lights: &mut [Option<LightSample>]) {
        let n = self.n;
        let wi =
            warp::square_to_uniform_sphere_lanes(&std::array::from_fn(|k| self.u[k.min(n - 1)]));
        for (m, &wi) in wi.iter().enumerate().take(n) {
            let sky = self.sky[m].expect("a filled lane has its sky");
            lights[self.slot[m]] = Some(sky.sample_toward(ctx, self.p[m], wi));
        }
        self.n = 0;
    }
}

/// Up to four escaped paths located on the environment map `env` (emitter
/// `e`), waiting to look it up together: the paths, their points and
/// their MIS weights' facing normals.
struct EscapeGroup<'a> {
    e: u32,
    env: &'a EnvMap,
    n: usize,
    path: [usize; 4],
    at: [EnvPoint; 4],
    facing: [Option<Vec3>; 4],
}

impl<'a> EscapeGroup<'a> {
    fn new(e: u32, env: &'a EnvMap) -> EscapeGroup<'a> {
        EscapeGroup {
            e,
            env,
            n: 0,
            path: [0; 4],
            at: [EnvPoint::default(); 4],
            facing: [None; 4],
        }
    }

    /// Adds path `i`, located at `at`, drawing the group when it is full.
    #[inline]
    fn push(
        &mut self,
        i: usize,
        at: EnvPoint,
        facing: Option<Vec3>,
        scene: &Scene,
        cfg: &PathConfig,
        paths: &mut [PathState],
    ) {
        let n = self.n;
        (self.path[n], self.at[n], self.facing[n]) = (i, at, facing);
        self.n += 1;
        if self.n == 4 {
            self.flush(scene, cfg, paths);
        }
    }

    /// Looks the waiting points up (unused lanes repeat the last one),
    /// adds what each path sees there, and empties the group.
    fn flush(&mut self, scene: &Scene, cfg: &PathConfig, paths: &mut [PathState]) {
        let n = self.n;
        let at = std::array::from_fn(|k| self.at[k.min(n - 1)]);
        let le_pdf = self.env.eval_pdf_at_lanes(&at, cfg.which, &self.facing);
        for m in 0..n {
            paths[self.path[m]].escape_located(scene, cfg, self.e, le_pdf[m]);
        }
        self.n = 0;
    }

    /// Locates the escaped rays of paths `unlocated[..n]` (paths that
    /// count what they see at infinity but were not located before their
    /// trace) on the map, four in SIMD lanes ([`EnvMap::locate_lanes`],
    /// the scalar points bit for bit), and adds them; a direction the
    /// lanes cannot place (bad input) leaves its path to the scalar
    /// escape.
    fn locate(
        &mut self,
        unlocated: &[usize; 4],
        n: usize,
        scene: &Scene,
        cfg: &PathConfig,
        paths: &mut [PathState],
    ) {
        let d = std::array::from_fn(|k| &paths[unlocated[k.min(n - 1)]].ray.d);
        let at = self.env.locate_lanes(d);
        for (k, &i) in unlocated.iter().enumerate().take(n) {
            paths[i].set_escape(at[k].map(|at| (self.e, at)));
            match paths[i].escape_point(cfg, self.e) {
                Some((at, facing)) => self.push(i, at, facing, scene, cfg, paths),
                None => paths[i].escape(scene, cfg),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrator::{Integrator, PathParams, Strategy};
    use crate::load::load_scene;
    use crate::math::Vec2;
    use std::path::Path;

    /// A batch returns what `li` returns for each of its rays, bit for
    /// bit, whatever the batch size (lanes part-filled too), on scenes
    /// with an environment map, area lights, a thin lens and a constant
    /// sky (the escape stage's own path for it), under every
    /// strategy, `direct`, hidden emitters and early roulette. All four
    /// are small enough for the trace in packets, whose hits are the
    /// one-ray walk's (none of these rays meets two surfaces at exactly
    /// one distance).
    #[test]
    fn a_batch_is_li_bit_for_bit() {
        let root = Path::new(env!("CARGO_MANIFEST_DIR"));
        let hidden = PathParams {
            max_depth: Some(6),
            rr_depth: 1,
            hide_emitters: true,
        };
        let mut integrators = vec![
            Integrator::Direct {
                strategy: Strategy::Mis,
            },
            Integrator::Path {
                strategy: Strategy::Mis,
                params: hidden,
            },
        ];
        for strategy in [Strategy::Mats, Strategy::Ems, Strategy::Mis] {
            let params = PathParams::default();
            integrators.push(Integrator::Path { strategy, params });
        }
        let mut batch = PathBatch::new();
        let mut compared = 0;
        for file in [
            "scenes/cbox/cbox.xml",
            "scenes/envmap/envmap.xml",
            "scenes/dof/dof.xml",
            "bench/speed/constant_cube.xml",
            // Five sphere lights: their samples drawn in lanes.
            "bench/lights/veach_mis.xml",
        ] {
            let (loaded, _) = load_scene(&root.join(file)).unwrap();
            let scene = Scene::new(loaded.scene).unwrap();
            let (w, h) = (scene.camera.width(), scene.camera.height());
            for &integrator in &integrators {
                let cfg = integrator.path_config().unwrap();
                for n in [1usize, 7, BATCH_PATHS - 3] {
                    let mut rays = Vec::new();
                    let mut samplers = Vec::new();
                    let mut expected = Vec::new();
                    for k in 0..n as u32 {
                        let (x, y) = (k * 7919 % w, k * 104_729 % h);
                        let mut s = Sampler::for_pixel_sample(3, x, y, k);
                        let film = Vec2::new(x as f32, y as f32) + s.next_2d();
                        let ray = scene.camera.generate_ray(film, s.next_2d());
                        let mut alone = s.clone();
                        expected.push(integrator.li(&scene, &ray, &mut alone));
                        rays.push(ray);
                        samplers.push(s);
                    }
                    let mut out = vec![Rgb::splat(-1.0); n];
                    batch.radiance(&scene, &cfg, &rays, &mut samplers, &mut out);
                    for k in 0..n {
                        let (a, b) = (out[k].to_array(), expected[k].to_array());
                        assert_eq!(
                            a.map(f32::to_bits),
                            b.map(f32::to_bits),
                            "{file}, {}, batch of {n}, path {k}: {a:?} != {b:?}",
                            integrator.name()
                        );
                        compared += (b != [0.0; 3]) as usize;
                    }
                }
            }
        }
        // Most paths carry light (the comparison is not of zeros).
        assert!(compared > 1500, "{compared} paths with light");
    }
}
