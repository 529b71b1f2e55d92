// Whether the scene is rendered with Mitsuba's `volpath` (volpath.wgsl):
// set per scene at pipeline creation, as bsdf.wgsl's BLENDS.
override VOLPATH: bool = false;

// The path tracer with MIS (integrator/path.rs, Strategy::Mis): one
// thread per pixel sample, writing the sample's radiance and its position
// in the pixel for film.wgsl to reconstruct.

@group(0) @binding(0) var<storage, read> P: Params;
@group(0) @binding(1) var<storage, read> nodes: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> prims: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> normals: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> shapes: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read> lights: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read_write> samples: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read> env_data: array<f32>;

struct Ray {
    o: vec3<f32>,
    d: vec3<f32>,
    tmin: f32,
    tmax: f32,
}

// camera.rs's sample_regular_polygon: a uniform point of the regular
// polygon with `P.aperture_blades` sides inscribed in the unit circle.
fn sample_regular_polygon(u: vec2<f32>) -> vec2<f32> {
    let n = f32(P.aperture_blades);
    let k = min(u32(u.x * n), P.aperture_blades - 1u);
    let ux = u.x * n - f32(k);
    let a0 = P.aperture_rotation + 2.0 * PI * f32(k) / n;
    let a1 = P.aperture_rotation + 2.0 * PI * f32(k + 1u) / n;
    let b = square_to_uniform_triangle(vec2<f32>(ux, u.y));
    return b.x * vec2<f32>(cos(a0), sin(a0)) + b.y * vec2<f32>(cos(a1), sin(a1));
}

// camera.rs's generate_ray: perspective, thin-lens (disk or polygon) and
// orthographic cameras.
fn camera_ray(film: vec2<f32>, aperture: vec2<f32>) -> Ray {
    let sx = film.x / f32(P.width);
    let sy = film.y / f32(P.height);
    if (P.orthographic != 0u) {
        // From the near plane along +z (camera.rs's orthographic_ray).
        let p = vec3<f32>(1.0 - 2.0 * sx, (1.0 - 2.0 * sy) * P.inv_aspect, P.near_clip);
        let wo = (P.to_world * vec4<f32>(p, 1.0)).xyz;
        let wd = normalize((P.to_world * vec4<f32>(0.0, 0.0, 1.0, 0.0)).xyz);
        return Ray(wo, wd, 0.0, P.far_clip - P.near_clip);
    }
    let dc = vec3<f32>(
        (1.0 - 2.0 * sx) * P.tan_half_x,
        (1.0 - 2.0 * sy) * P.tan_half_x * P.inv_aspect,
        1.0,
    );
    var o = vec3<f32>(0.0);
    var d = normalize(dc);
    if (P.lens_radius > 0.0) {
        var unit = square_to_uniform_disk(aperture);
        if (P.aperture_blades > 0u) {
            unit = sample_regular_polygon(aperture);
        }
        o = vec3<f32>(P.lens_radius * unit, 0.0);
        d = normalize(dc * P.focal_distance - o);
    }
    let inv_z = 1.0 / d.z;
    let wo = (P.to_world * vec4<f32>(o, 1.0)).xyz;
    let wd = normalize((P.to_world * vec4<f32>(d, 0.0)).xyz);
    return Ray(wo, wd, P.near_clip * inv_z, P.far_clip * inv_z);
}

fn power_heuristic(a: f32, b: f32) -> f32 {
    let a2 = a * a;
    let b2 = b * b;
    if (a2 + b2 == 0.0) {
        return 0.0;
    }
    return a2 / (a2 + b2);
}

fn max3(v: vec3<f32>) -> f32 {
    return max(v.x, max(v.y, v.z));
}

// Whether emission a path finds counts: always under MIS (weighed) and
// BSDF sampling alone; under emitter sampling alone only where no emitter
// sample could have found it (the camera ray, after a specular bounce).
fn count_emission(specular: bool) -> bool {
    return P.strategy != STRATEGY_EMS || specular;
}

// The MIS weight of emission found by a BSDF sample of density `pdf`
// against emitter sampling's `light_pdf`: 1 under a single strategy.
fn found_weight(specular: bool, pdf: f32, light_pdf: f32) -> f32 {
    if (P.strategy != STRATEGY_MIS || specular) {
        return 1.0;
    }
    return power_heuristic(pdf, light_pdf);
}

// Russian roulette from P.rr_depth on (path.rs's `roulette`): survival
// with the throughput's largest channel times `eta_scale`, at most 0.99;
// false if the path ends.
fn roulette(beta: ptr<function, vec3<f32>>, eta_scale: f32, depth: u32) -> bool {
    if (depth < P.rr_depth) {
        return true;
    }
    let q = min(max3(*beta) * eta_scale, 0.99);
    if (next_1d() >= q) {
        return false;
    }
    *beta /= q;
    return true;
}

// The closest hit along `ray`; with `skip` (Mitsuba's hide_emitters on a
// camera ray), passing through up to 64 emitting shapes (path.rs's
// skip_area_emitters), `ray` moved to start past the last one.
fn next_hit(ray: ptr<function, Ray>, h: ptr<function, Hit>, skip: bool) -> bool {
    var found = closest_hit((*ray).o, (*ray).d, (*ray).tmin, (*ray).tmax, h);
    if (skip) {
        for (var skips = 0u; skips < 64u && found; skips++) {
            let s = surface_at(*h, (*ray).o, (*ray).d);
            if (!shape_emits(s.shape)) {
                break;
            }
            *ray = Ray(spawn_origin(s.p, s.ng, (*ray).d), (*ray).d, 0.0, INF);
            found = closest_hit((*ray).o, (*ray).d, (*ray).tmin, (*ray).tmax, h);
        }
    }
    return found;
}

fn li(camera: Ray) -> vec3<f32> {
    var l = vec3<f32>(0.0);
    var beta = vec3<f32>(1.0);
    var ray = camera;
    var specular = true;
    var prev_pdf = 0.0;
    var prev_p = ray.o;
    // The previous vertex's shading normal and choice_total (for the MIS
    // weight of a light its BSDF sample finds).
    var prev_n = vec3<f32>(0.0);
    var prev_total = 0.0;
    // The previous vertex's facing bin for the environment (NONE: none).
    var prev_bin = NONE;
    var eta_scale = 1.0;
    var depth = 0u;
    // Mitsuba's hide_emitters: the camera ray passes through up to 64
    // emitting shapes (path.rs's skip_area_emitters) and sees no sky.
    let hide = P.hide_emitters != 0u;
    loop {
        var h: Hit;
        let found = next_hit(&ray, &h, depth == 0u && hide);
        if (!found) {
            if (depth == 0u && hide) {
                break;
            }
            if (P.env_kind != ENV_NONE && (depth > 0u || P.env_visible != 0u) && count_emission(specular)) {
                let e = env_eval_pdf(ray.d, prev_bin);
                l += beta * e.xyz * found_weight(specular, prev_pdf, e.w);
            }
            break;
        }
        let s = surface_at(h, ray.o, ray.d);
        // Seen from behind the shading normal: a two-sided material's back.
        load_material(s, dot(ray.d, s.ns) > 0.0);
        // Emission found by following the path (front side only).
        if (s.light != NONE && dot(s.ng, ray.d) < 0.0 && !(depth == 0u && hide) && count_emission(specular)) {
            var w = 1.0;
            if (!specular && P.strategy == STRATEGY_MIS) {
                let choice = light_choice_pdf(s.light, prev_p, prev_n, prev_total);
                w = power_heuristic(prev_pdf, area_pdf(s.light, choice, prev_p, s.p, s.ng));
            }
            l += beta * light_radiance(s.light, TexPoint(s.uv, s.tri, s.bary)) * w;
        }
        depth++;
        if (depth >= P.max_depth) {
            break;
        }
        let frame = frame_from_normal_tangent(s.ns, s.dpdu);
        let wi_world = -ray.d;
        let wi = to_local(frame, wi_world);
        set_tilt(wi, to_local(frame, s.dpdu), to_local(frame, s.dpdv), to_local(frame, s.ng));

        // Next-event estimation.
        let u_choice = next_1d();
        let u_light = next_2d();
        var total = 0.0;
        var bin = NONE;
        if (!is_specular() && P.strategy != STRATEGY_MATS) {
            total = choice_total(s.p, s.ns);
            // path.rs: at the first vertex, a surface that only reflects
            // samples the environment for the side of its shading normal
            // that `wi` is on (envmap/facing.rs).
            if (depth == 1u && favours_facing_light()) {
                bin = env_facing_bin(select(s.ns, -s.ns, wi.z < 0.0));
            }
            let ls = sample_light(s.p, s.ns, total, u_choice, u_light, bin);
            if (ls.ok) {
                let wo = to_local(frame, ls.wi);
                let fp = bsdf_eval_pdf(wi, wo);
                let f = fp.xyz;
                if (max3(f) > 0.0 && max3(ls.le) > 0.0) {
                    let o = spawn_origin(s.p, s.ng, ls.wi);
                    // Towards the sampled point itself from the offset
                    // origin: a ray parallel to `wi` from there may enter a
                    // curved light before that point (near its silhouette)
                    // and call it occluded.
                    var d = ls.wi;
                    var tmax = INF;
                    if (ls.dist < INF) {
                        let to = s.p + ls.wi * ls.dist - o;
                        tmax = length(to);
                        d = to / tmax;
                        tmax *= 1.0 - 1e-3;
                    }
                    if (!occluded(o, d, tmax)) {
                        var w = 1.0;
                        if (!ls.delta && P.strategy == STRATEGY_MIS) {
                            w = power_heuristic(ls.pdf, fp.w);
                        }
                        l += beta * f * abs(wo.z) * ls.le * (w / ls.pdf);
                    }
                }
            }
        }

        // Continue the path by sampling the BSDF.
        let u = next_2d();
        let u_lobe = next_1d();
        let bs = bsdf_sample(wi, u, u_lobe);
        if (!bs.ok) {
            break;
        }
        let wo_world = to_world(frame, bs.wo);
        // No light leaks through shading normals.
        if (dot(wo_world, s.ng) * bs.wo.z <= 0.0 && dot(wi_world, s.ng) * wi.z > 0.0) {
            break;
        }
        beta *= bs.weight;
        eta_scale *= bs.eta * bs.eta;
        specular = bs.specular;
        prev_pdf = select(bs.pdf, 0.0, bs.specular);
        prev_p = s.p;
        prev_n = s.ns;
        prev_total = total;
        prev_bin = bin;
        if (max3(beta) <= 0.0) {
            break;
        }
        if (!roulette(&beta, eta_scale, depth)) {
            break;
        }
        ray = Ray(spawn_origin(s.p, s.ng, wo_world), wo_world, 0.0, INF);
    }
    return l;
}

@compute @workgroup_size(64)
fn trace_samples(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let idx = gid.x + gid.y * groups.x * 64u;
    let pixels = P.width * P.height;
    if (idx >= pixels * P.spp_pass) {
        return;
    }
    let pixel = idx % pixels;
    let s = P.sample_base + idx / pixels;
    rng_init(pixel, s);
    let film = vec2<f32>(f32(pixel % P.width), f32(pixel / P.width)) + next_2d();
    let aperture = next_2d();
    var l: vec3<f32>;
    if (VOLPATH) {
        l = vol_li(camera_ray(film, aperture));
    } else {
        l = li(camera_ray(film, aperture));
    }
    let offset = film - floor(film);
    // The position in the pixel in 16-bit fixed point: its bin of 1/65536
    // (film.wgsl's unpack_offset).
    let q = min(vec2<u32>(offset * 65536.0), vec2<u32>(65535u));
    samples[idx] = vec4<f32>(l, bitcast<f32>(q.x | (q.y << 16u)));
}
