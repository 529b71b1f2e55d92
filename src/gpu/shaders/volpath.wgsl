// Mitsuba's `volpath` (integrator/volpath.rs) through homogeneous media
// (medium/mod.rs, phase.rs): a path is in one medium at a time (the
// camera's, then the one behind the last surface it crossed that names
// media); in a medium each segment either reaches the next surface or
// scatters at a sampled distance, where the path samples an emitter and
// the phase function, weighed by the power heuristic as at surfaces.
// Shadow rays pass through null lobes (`null`, a mask's holes, a
// polarizer, a thin dielectric's transmission) with their null
// transmission, changing medium as they cross, attenuated by every medium
// on the way. Null crossings are not bounces.
// Heterogeneous media (heterogeneous.rs) by delta tracking and, for shadow
// rays, ratio tracking against the medium's one majorant (Mitsuba's
// choice; the CPU's majorant grid draws other collisions of the same
// expectation), the channel mixture as on the CPU; volumes (volume.rs:
// constants and grids, trilinear or nearest, wrapped) for extinction and
// albedo.
// The media tables (flatten.rs's `media_words`, from P.media_base in
// `shapes`): per shape (interior, exterior, 0, 0), the sides' medium
// records as bits (NONE: vacuum); a medium record, MEDIUM_WORDS words:
// (sigma_t, flags) or, heterogeneous, (scale, majorant, 0, flags), (its
// extinction's box min, g), (box max, 0), (albedo and extinction volume
// records as bits); a volume record, VOLUME_WORDS words: world-to-volume
// rows, (constant, NONE) or (resolution, first value), (values per voxel,
// filter, wrap, 0); grid values four to a word.

const PHASE_ISOTROPIC: u32 = 0u;
const PHASE_HG: u32 = 1u;
const PHASE_RAYLEIGH: u32 = 2u;
const MEDIUM_SAMPLES_EMITTERS: u32 = 0x100u;
const MEDIUM_ABSORBS_ONLY: u32 = 0x200u;
const MEDIUM_HETEROGENEOUS: u32 = 0x400u;
const MEDIUM_WORDS: u32 = 4u;
const VOLUME_WORDS: u32 = 5u;
// heterogeneous.rs's MAX_COLLISIONS and ROULETTE_BELOW.
const MAX_COLLISIONS: u32 = 16777216u;
const ROULETTE_BELOW: f32 = 0.05;
// volpath.rs's MAX_NULL_CROSSINGS: surfaces passed straight through in a
// row before the path (or shadow ray) is given up.
const MAX_NULL_CROSSINGS: u32 = 256u;
const INV_FOUR_PI: f32 = 0.0795774715459477;

fn medium_interface(shape: u32) -> vec2<u32> {
    let w = shapes[P.media_base + shape];
    return vec2<u32>(bitcast<u32>(w.x), bitcast<u32>(w.y));
}

// MediumInterface::is_transition.
fn is_transition(sides: vec2<u32>) -> bool {
    return sides.x != NONE || sides.y != NONE;
}

// MediumInterface::target: the medium a ray leaving the surface along `d`
// enters (the exterior in front of the geometric normal).
fn medium_target(sides: vec2<u32>, ng: vec3<f32>, d: vec3<f32>) -> u32 {
    return select(sides.x, sides.y, dot(ng, d) > 0.0);
}

fn medium_flags(m: u32) -> u32 {
    return bitcast<u32>(shapes[m].w);
}

// Beer-Lambert transmittance, 1 through an empty channel.
fn beer(sigma: vec3<f32>, t: f32) -> vec3<f32> {
    return select(exp(-sigma * t), vec3<f32>(1.0), sigma == vec3<f32>(0.0));
}

struct FreeFlight {
    scatter: bool,
    t: f32,
    weight: vec3<f32>,
}

fn grid_voxel(first: u32, res: vec3<i32>, channels: u32, x: i32, y: i32, z: i32) -> vec3<f32> {
    let i = first + u32((z * res.y + y) * res.x + x) * channels;
    if (channels == 1u) {
        return vec3<f32>(shape_scalar(i));
    }
    return vec3<f32>(shape_scalar(i), shape_scalar(i + 1u), shape_scalar(i + 2u));
}

// Volume::eval at world point `p`: the constant, or the grid looked up
// as Dr.Jit's Texture3f (voxel centres at (i + 1/2) / res).
fn volume_eval(v: u32, p: vec3<f32>) -> vec3<f32> {
    let w3 = shapes[v + 3u];
    let first = bitcast<u32>(w3.w);
    if (first == NONE) {
        return w3.xyz;
    }
    let q = vec3<f32>(
        dot(shapes[v].xyz, p) + shapes[v].w,
        dot(shapes[v + 1u].xyz, p) + shapes[v + 1u].w,
        dot(shapes[v + 2u].xyz, p) + shapes[v + 2u].w,
    );
    let res = vec3<i32>(bitcast<vec3<u32>>(w3.xyz));
    let w4 = bitcast<vec4<u32>>(shapes[v + 4u]);
    let channels = w4.x;
    let wrap = w4.z;
    if (w4.y == TEX_NEAREST) {
        let x = tex_wrap(i32(floor(tex_bounded(q.x * f32(res.x)))), res.x, wrap);
        let y = tex_wrap(i32(floor(tex_bounded(q.y * f32(res.y)))), res.y, wrap);
        let z = tex_wrap(i32(floor(tex_bounded(q.z * f32(res.z)))), res.z, wrap);
        return grid_voxel(first, res, channels, x, y, z);
    }
    let g = vec3<f32>(tex_bounded(q.x * f32(res.x) - 0.5), tex_bounded(q.y * f32(res.y) - 0.5), tex_bounded(q.z * f32(res.z) - 0.5));
    let f = floor(g);
    let t = g - f;
    let i = vec3<i32>(f);
    let x0 = tex_wrap(i.x, res.x, wrap);
    let x1 = tex_wrap(i.x + 1, res.x, wrap);
    let y0 = tex_wrap(i.y, res.y, wrap);
    let y1 = tex_wrap(i.y + 1, res.y, wrap);
    var plane: array<vec3<f32>, 2>;
    for (var k = 0; k < 2; k++) {
        let z = tex_wrap(i.z + k, res.z, wrap);
        let a = mix(grid_voxel(first, res, channels, x0, y0, z), grid_voxel(first, res, channels, x1, y0, z), t.x);
        let b = mix(grid_voxel(first, res, channels, x0, y1, z), grid_voxel(first, res, channels, x1, y1, z), t.x);
        plane[k] = mix(a, b, t.y);
    }
    return mix(plane[0], plane[1], t.z);
}

// Aabb::ray_range of the medium's extinction box: the part of the ray
// (o, d) up to t_max inside it, as (t0, t1, 1), or z = 0 where it misses.
fn medium_range(m: u32, o: vec3<f32>, d: vec3<f32>, t_max: f32) -> vec3<f32> {
    let lo = shapes[m + 1u].xyz;
    let hi = shapes[m + 2u].xyz;
    var t0 = 0.0;
    var t1 = t_max;
    for (var a = 0; a < 3; a++) {
        if (d[a] == 0.0) {
            if (o[a] < lo[a] || o[a] > hi[a]) {
                return vec3<f32>(0.0);
            }
            continue;
        }
        let inv = 1.0 / d[a];
        let n = (lo[a] - o[a]) * inv;
        let f = (hi[a] - o[a]) * inv;
        t0 = max(t0, min(n, f));
        t1 = min(t1, max(n, f));
    }
    return vec3<f32>(t0, t1, select(0.0, 1.0, t0 <= t1));
}

// The heterogeneous medium's extinction at `p`, at most the majorant.
fn hetero_sigma_t(m: u32, p: vec3<f32>) -> vec3<f32> {
    let w0 = shapes[m];
    return min(volume_eval(bitcast<u32>(shapes[m + 3u].y), p) * w0.x, vec3<f32>(w0.y));
}

// Heterogeneous::sample_distance: delta tracking, real-or-null choices
// by one channel, weighed by the three channels' mean probability.
fn hetero_sample_distance(m: u32, o: vec3<f32>, d: vec3<f32>, t_max: f32) -> FreeFlight {
    let maj = shapes[m].y;
    let range = medium_range(m, o, d, t_max);
    if (range.z == 0.0 || maj <= 0.0) {
        return FreeFlight(false, t_max, vec3<f32>(1.0));
    }
    let c = min(u32(next_1d() * 3.0), 2u);
    var weight = vec3<f32>(1.0);
    var probs = vec3<f32>(1.0);
    var t = range.x;
    for (var n = 0u; n < MAX_COLLISIONS; n++) {
        t -= log(1.0 - next_1d()) / maj;
        if (t >= range.y) {
            return FreeFlight(false, t_max, weight);
        }
        let p = o + d * t;
        let sigma_t = hetero_sigma_t(m, p);
        var p_real = sigma_t / maj;
        if (next_1d() < p_real[c]) {
            let sigma_s = sigma_t * volume_eval(bitcast<u32>(shapes[m + 3u].x), p);
            let mean = dot(probs * p_real, vec3<f32>(1.0 / 3.0));
            return FreeFlight(true, t, weight * sigma_s / (maj * mean));
        }
        let p_null = vec3<f32>(1.0) - p_real;
        let mean = dot(probs * p_null, vec3<f32>(1.0 / 3.0));
        if (mean <= 0.0) {
            break;
        }
        weight *= p_null / mean;
        probs *= p_null / mean;
    }
    return FreeFlight(false, t_max, vec3<f32>(0.0));
}

// Heterogeneous::transmittance: ratio tracking, with Russian roulette
// once the largest channel is small.
fn hetero_transmittance(m: u32, o: vec3<f32>, d: vec3<f32>, t_end: f32) -> vec3<f32> {
    let maj = shapes[m].y;
    let range = medium_range(m, o, d, t_end);
    if (range.z == 0.0 || maj <= 0.0) {
        return vec3<f32>(1.0);
    }
    var tr = vec3<f32>(1.0);
    var t = range.x;
    for (var n = 0u; n < MAX_COLLISIONS; n++) {
        t -= log(1.0 - next_1d()) / maj;
        if (t >= range.y) {
            return tr;
        }
        tr *= vec3<f32>(1.0) - hetero_sigma_t(m, o + d * t) / maj;
        let largest = max3(tr);
        if (largest < ROULETTE_BELOW) {
            // Survive with probability 1/4, weighted by 4.
            if (largest <= 0.0 || next_1d() >= 0.25) {
                return vec3<f32>(0.0);
            }
            tr *= 4.0;
        }
    }
    return vec3<f32>(0.0);
}

// Medium::transmittance along (o, d) up to t.
fn medium_transmittance(m: u32, o: vec3<f32>, d: vec3<f32>, t: f32) -> vec3<f32> {
    if ((medium_flags(m) & MEDIUM_HETEROGENEOUS) != 0u) {
        return hetero_transmittance(m, o, d, t);
    }
    return beer(shapes[m].xyz, t);
}

// Medium::sample_distance along (o, d) up to t_max. Homogeneous: the
// channel chosen uniformly, the distance from its exponential, weighed by
// the three channels' mixed density; an absorbing-only medium passes with
// its transmittance.
fn sample_distance(m: u32, o: vec3<f32>, d: vec3<f32>, t_max: f32) -> FreeFlight {
    if ((medium_flags(m) & MEDIUM_HETEROGENEOUS) != 0u) {
        return hetero_sample_distance(m, o, d, t_max);
    }
    let sigma = shapes[m].xyz;
    let u_channel = next_1d();
    let u = next_1d();
    if ((medium_flags(m) & MEDIUM_ABSORBS_ONLY) != 0u) {
        return FreeFlight(false, t_max, beer(sigma, t_max));
    }
    var s = sigma;
    let c = min(u32(u_channel * 3.0), 2u);
    var t = INF;
    if (s[c] > 0.0) {
        t = -log(1.0 - u) / s[c];
    }
    if (t < t_max) {
        let tr = beer(sigma, t);
        let pdf = dot(sigma * tr, vec3<f32>(1.0 / 3.0));
        if (pdf > 0.0) {
            let albedo = volume_eval(bitcast<u32>(shapes[m + 3u].x), o + d * t);
            return FreeFlight(true, t, tr * sigma * albedo / pdf);
        }
    }
    let tr = beer(sigma, t_max);
    let p_pass = dot(tr, vec3<f32>(1.0 / 3.0));
    return FreeFlight(false, t_max, select(vec3<f32>(0.0), tr / p_pass, p_pass > 0.0));
}

fn henyey_greenstein(g: f32, cos_t: f32) -> f32 {
    let denom = 1.0 + g * g - 2.0 * g * cos_t;
    return INV_FOUR_PI * (1.0 - g * g) / (denom * sqrt(max(denom, 1e-12)));
}

fn rayleigh(cos_t: f32) -> f32 {
    return 3.0 / (16.0 * PI) * (1.0 + cos_t * cos_t);
}

// Phase::eval for light travelling along `d` scattered to `wo`.
fn phase_eval(m: u32, d: vec3<f32>, wo: vec3<f32>) -> f32 {
    let kind = medium_flags(m) & 0xffu;
    if (kind == PHASE_HG) {
        return henyey_greenstein(shapes[m + 1u].w, dot(d, wo));
    }
    if (kind == PHASE_RAYLEIGH) {
        return rayleigh(dot(d, wo));
    }
    return INV_FOUR_PI;
}

fn cbrt(x: f32) -> f32 {
    return sign(x) * pow(abs(x), 1.0 / 3.0);
}

struct PhaseSample {
    wo: vec3<f32>,
    pdf: f32,
}

// Phase::sample: a direction at cosine cos_t to `d`, uniform in azimuth.
fn phase_sample(m: u32, d: vec3<f32>, u: vec2<f32>) -> PhaseSample {
    let kind = medium_flags(m) & 0xffu;
    if (kind == PHASE_ISOTROPIC) {
        return PhaseSample(square_to_uniform_sphere(u), INV_FOUR_PI);
    }
    var cos_t: f32;
    var pdf: f32;
    if (kind == PHASE_HG) {
        let g = shapes[m + 1u].w;
        cos_t = 1.0 - 2.0 * u.x;
        if (abs(g) >= 1e-3) {
            let s = (1.0 - g * g) / (1.0 + g - 2.0 * g * u.x);
            cos_t = clamp((1.0 + g * g - s * s) / (2.0 * g), -1.0, 1.0);
        }
        pdf = henyey_greenstein(g, cos_t);
    } else {
        let z = 4.0 * u.x - 2.0;
        let r = sqrt(z * z + 1.0);
        cos_t = clamp(cbrt(z + r) + cbrt(z - r), -1.0, 1.0);
        pdf = rayleigh(cos_t);
    }
    let sin_t = sqrt(max(0.0, 1.0 - cos_t * cos_t));
    let phi = 2.0 * PI * u.y;
    let local = vec3<f32>(sin_t * cos(phi), sin_t * sin(phi), cos_t);
    return PhaseSample(normalize(to_world(frame_from_normal(d), local)), pdf);
}

// volpath.rs's shadow_transmittance: the fraction of light that reaches
// `o` (off any surface, in medium `m`) from `to` (or from infinity
// along `d` where `finite` is false): the media's transmittance on the
// way times the null transmission of the surfaces crossed (which this
// loads as the current material); zero if a surface blocks it.
fn shadow_transmittance(o_in: vec3<f32>, d_in: vec3<f32>, to: vec3<f32>, finite: bool, m_in: u32) -> vec3<f32> {
    var tr = vec3<f32>(1.0);
    var o = o_in;
    var m = m_in;
    var d = d_in;
    if (finite) {
        d = normalize(to - o);
    }
    for (var k = 0u; k <= MAX_NULL_CROSSINGS; k++) {
        var remaining = INF;
        if (finite) {
            remaining = length(to - o) * (1.0 - 1e-3);
        }
        var h: Hit;
        let found = closest_hit(o, d, 0.0, remaining, &h);
        if (m != NONE) {
            tr *= medium_transmittance(m, o, d, select(remaining, h.t, found));
        }
        if (!found) {
            return tr;
        }
        let s = surface_at(h, o, d);
        load_material(s, dot(d, s.ns) > 0.0);
        tr *= bsdf_null_transmission(dot(s.ns, d));
        if (max3(tr) <= 0.0) {
            return vec3<f32>(0.0);
        }
        let sides = medium_interface(s.shape);
        if (is_transition(sides)) {
            m = medium_target(sides, s.ng, d);
        }
        o = spawn_origin(s.p, s.ng, d);
    }
    return vec3<f32>(0.0);
}

fn vol_li(camera: Ray) -> vec3<f32> {
    var l = vec3<f32>(0.0);
    var beta = vec3<f32>(1.0);
    var ray = camera;
    var medium = P.camera_medium;
    // Whether emission found by this ray counts in full (the camera ray,
    // after a delta lobe, or from a medium without emitter sampling).
    var specular = true;
    // The last real vertex: its sampled direction's density, position,
    // normal (zero in a medium) and choice_total, for MIS weights.
    var prev_pdf = 0.0;
    var prev_p = ray.o;
    var prev_n = vec3<f32>(0.0);
    var prev_total = 0.0;
    var eta_scale = 1.0;
    // Real scattering events (surfaces and media, not null crossings).
    var depth = 0u;
    var nulls = 0u;
    let hide = P.hide_emitters != 0u;
    loop {
        let start = ray;
        var h: Hit;
        let found = next_hit(&ray, &h, depth == 0u && hide);

        // The medium along the segment (measured from the segment's
        // start, whatever emitters the camera ray skipped): scatter in it,
        // or pass to its end.
        if (medium != NONE) {
            var t_max = INF;
            if (found) {
                t_max = h.t + dot(ray.o - start.o, start.d);
            }
            let flight = sample_distance(medium, start.o, start.d, t_max);
            beta *= flight.weight;
            if (flight.scatter) {
                depth++;
                if (depth >= P.max_depth || max3(beta) <= 0.0) {
                    break;
                }
                let p = start.o + start.d * flight.t;
                let d = start.d;
                let samples_emitters = (medium_flags(medium) & MEDIUM_SAMPLES_EMITTERS) != 0u;
                let u_choice = next_1d();
                let u_light = next_2d();
                if (samples_emitters) {
                    prev_n = vec3<f32>(0.0);
                    prev_total = choice_total(p, prev_n);
                    let ls = sample_light(p, prev_n, prev_total, u_choice, u_light, NONE);
                    if (ls.ok) {
                        let f = phase_eval(medium, d, ls.wi);
                        if (f > 0.0 && max3(ls.le) > 0.0) {
                            let tr = shadow_transmittance(p, ls.wi, p + ls.wi * ls.dist, ls.dist < INF, medium);
                            if (max3(tr) > 0.0) {
                                var w = 1.0;
                                if (!ls.delta) {
                                    w = power_heuristic(ls.pdf, f);
                                }
                                l += beta * ls.le * tr * (f * w / ls.pdf);
                            }
                        }
                    }
                }
                let ps = phase_sample(medium, d, next_2d());
                specular = !samples_emitters;
                prev_pdf = ps.pdf;
                prev_p = p;
                if (!roulette(&beta, eta_scale, depth)) {
                    break;
                }
                nulls = 0u;
                ray = Ray(p, ps.wo, 0.0, INF);
                continue;
            }
            if (max3(beta) <= 0.0) {
                break;
            }
        }

        if (!found) {
            if (!(depth == 0u && hide) && P.env_kind != ENV_NONE && (depth > 0u || P.env_visible != 0u)) {
                let e = env_eval_pdf(ray.d, NONE);
                l += beta * e.xyz * found_weight(specular, prev_pdf, e.w);
            }
            break;
        }
        let s = surface_at(h, ray.o, ray.d);
        let from_behind = dot(ray.d, s.ns) > 0.0;
        load_material(s, from_behind);
        if (s.light != NONE && dot(s.ng, ray.d) < 0.0 && !(depth == 0u && hide)) {
            var w = 1.0;
            if (!specular) {
                let choice = light_choice_pdf(s.light, prev_p, prev_n, prev_total);
                w = power_heuristic(prev_pdf, area_pdf(s.light, choice, prev_p, s.p, s.ng));
            }
            l += beta * light_radiance(s.light, TexPoint(s.uv, s.tri, s.bary)) * w;
        }

        let frame = frame_from_normal_tangent(s.ns, s.dpdu);
        let wi_world = -ray.d;
        let wi = to_local(frame, wi_world);
        let tilt = array<vec3<f32>, 3>(to_local(frame, s.dpdu), to_local(frame, s.dpdv), to_local(frame, s.ng));
        set_tilt(wi, tilt[0], tilt[1], tilt[2]);
        let sides = medium_interface(s.shape);

        // Next-event estimation, if a real bounce here may still see light.
        let u_choice = next_1d();
        let u_light = next_2d();
        if (!is_specular() && depth + 1u < P.max_depth) {
            prev_n = s.ns;
            prev_total = choice_total(s.p, s.ns);
            let ls = sample_light(s.p, s.ns, prev_total, u_choice, u_light, NONE);
            if (ls.ok) {
                let wo = to_local(frame, ls.wi);
                let fp = bsdf_eval_pdf(wi, wo);
                if (max3(fp.xyz) > 0.0 && max3(ls.le) > 0.0) {
                    var start_medium = medium;
                    if (is_transition(sides)) {
                        start_medium = medium_target(sides, s.ng, ls.wi);
                    }
                    let o = spawn_origin(s.p, s.ng, ls.wi);
                    let tr = shadow_transmittance(o, ls.wi, s.p + ls.wi * ls.dist, ls.dist < INF, start_medium);
                    if (max3(tr) > 0.0) {
                        var w = 1.0;
                        if (!ls.delta) {
                            w = power_heuristic(ls.pdf, fp.w);
                        }
                        l += beta * fp.xyz * ls.le * tr * (abs(wo.z) * w / ls.pdf);
                    }
                    // The shadow ray loaded the materials it crossed.
                    load_material(s, from_behind);
                    set_tilt(wi, tilt[0], tilt[1], tilt[2]);
                }
            }
        }

        let u = next_2d();
        let u_lobe = next_1d();
        let bs = bsdf_sample(wi, u, u_lobe);
        if (!bs.ok) {
            break;
        }
        let wo_world = to_world(frame, bs.wo);
        beta *= bs.weight;
        if (max3(beta) <= 0.0) {
            break;
        }
        if (is_transition(sides)) {
            medium = medium_target(sides, s.ng, wo_world);
        }
        if (sampled_null) {
            // Straight on, as if the surface were not there.
            nulls++;
            if (nulls > MAX_NULL_CROSSINGS) {
                break;
            }
            ray = Ray(spawn_origin(s.p, s.ng, wo_world), wo_world, 0.0, INF);
            continue;
        }
        // No light leaks through shading normals.
        if (dot(wo_world, s.ng) * bs.wo.z <= 0.0 && dot(wi_world, s.ng) * wi.z > 0.0) {
            break;
        }
        depth++;
        if (depth >= P.max_depth) {
            break;
        }
        eta_scale *= bs.eta * bs.eta;
        specular = bs.specular;
        prev_pdf = select(bs.pdf, 0.0, bs.specular);
        prev_p = s.p;
        if (!roulette(&beta, eta_scale, depth)) {
            break;
        }
        nulls = 0u;
        ray = Ray(spawn_origin(s.p, s.ng, wo_world), wo_world, 0.0, INF);
    }
    return l;
}
