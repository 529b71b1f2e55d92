// Emitter sampling (next-event estimation) and the densities MIS weighs
// against: area lights (triangles and spheres, by area, one-sided) chosen
// in proportion to power, and a constant environment (uniform sphere).
// A light's record: lights[4 i] = (p0 or centre, kind), [4 i + 1] = (p1 or
// (radius, 0, 0), area), [4 i + 2] = (p2, CDF), [4 i + 3] = (radiance, shape).

struct LightSample {
    wi: vec3<f32>,
    dist: f32,
    le: vec3<f32>,
    // Solid-angle density, the choice included.
    pdf: f32,
    ok: bool,
}

fn no_light() -> LightSample {
    return LightSample(vec3<f32>(0.0), 0.0, vec3<f32>(0.0), 0.0, false);
}

// Probability that emitter sampling picks area light `i`.
fn light_choice_pdf(i: u32) -> f32 {
    var below = 0.0;
    if (i > 0u) {
        below = lights[4u * (i - 1u) + 2u].w;
    }
    return (1.0 - P.env_prob) * (lights[4u * i + 2u].w - below);
}

// Cosine of the half-angle of the cone a sphere (centre `c`, radius `r`)
// fills seen from `p`, or 2 if `p` is inside it (then it is sampled by area).
fn sphere_cone_cos(p: vec3<f32>, c: vec3<f32>, r: f32) -> f32 {
    let d2 = dot(c - p, c - p);
    if (d2 <= r * r * 1.0001) {
        return 2.0;
    }
    return sqrt(max(0.0, 1.0 - r * r / d2));
}

// Solid-angle density of sampling area light `i` at the point `q` with
// normal `n`, seen from `p`.
fn area_pdf(i: u32, p: vec3<f32>, q: vec3<f32>, n: vec3<f32>) -> f32 {
    let r0 = lights[4u * i];
    if (bitcast<u32>(r0.w) == 1u) {
        let cos_max = sphere_cone_cos(p, r0.xyz, lights[4u * i + 1u].x);
        if (cos_max < 1.0) {
            return light_choice_pdf(i) / (2.0 * PI * (1.0 - cos_max));
        }
    }
    let d = q - p;
    let dist2 = dot(d, d);
    let cos_l = abs(dot(n, d)) / sqrt(dist2);
    if (cos_l <= 0.0) {
        return 0.0;
    }
    return light_choice_pdf(i) * dist2 / (cos_l * lights[4u * i + 1u].w);
}

fn env_pdf() -> f32 {
    return P.env_prob * (0.25 * INV_PI);
}

fn sample_light(p: vec3<f32>, u_choice: f32, u: vec2<f32>) -> LightSample {
    if (u_choice < P.env_prob) {
        let wi = square_to_uniform_sphere(u);
        return LightSample(wi, INF, P.env.xyz, env_pdf(), true);
    }
    if (P.light_count == 0u) {
        return no_light();
    }
    let uc = (u_choice - P.env_prob) / (1.0 - P.env_prob);
    // The first light whose CDF exceeds uc.
    var lo = 0u;
    var hi = P.light_count - 1u;
    while (lo < hi) {
        let mid = (lo + hi) / 2u;
        if (lights[4u * mid + 2u].w > uc) {
            hi = mid;
        } else {
            lo = mid + 1u;
        }
    }
    let i = lo;
    let r0 = lights[4u * i];
    let r1 = lights[4u * i + 1u];
    var q: vec3<f32>;
    var n: vec3<f32>;
    if (bitcast<u32>(r0.w) == 1u) {
        // A sphere seen from outside: uniformly in the cone it fills
        // (geometry/sphere.rs's sample_cone), else by area.
        let cos_max = sphere_cone_cos(p, r0.xyz, r1.x);
        if (cos_max < 1.0) {
            let axis = normalize(r0.xyz - p);
            let cos_t = 1.0 - u.x * (1.0 - cos_max);
            let sin_t = sqrt(max(0.0, 1.0 - cos_t * cos_t));
            let phi = 2.0 * PI * u.y;
            let f = frame_from_normal(axis);
            let wi = to_world(f, vec3<f32>(sin_t * cos(phi), sin_t * sin(phi), cos_t));
            // The nearer intersection with the sphere (the cone's rays all
            // meet it; rounding may graze it: take the closest point).
            let oc = p - r0.xyz;
            let b = dot(oc, wi);
            let disc = max(b * b - (dot(oc, oc) - r1.x * r1.x), 0.0);
            let t = -b - sqrt(disc);
            let pdf = light_choice_pdf(i) / (2.0 * PI * (1.0 - cos_max));
            return LightSample(wi, t, lights[4u * i + 3u].xyz, pdf, t > 0.0);
        }
        n = square_to_uniform_sphere(u);
        q = r0.xyz + r1.x * n;
    } else {
        let b = square_to_uniform_triangle(u);
        let p2 = lights[4u * i + 2u].xyz;
        q = (1.0 - b.x - b.y) * r0.xyz + b.x * r1.xyz + b.y * p2;
        n = normalize(cross(r1.xyz - r0.xyz, p2 - r0.xyz));
    }
    let d = q - p;
    let dist = length(d);
    if (dist <= 0.0) {
        return no_light();
    }
    let wi = d / dist;
    let cos_l = -dot(n, wi);
    if (cos_l <= 0.0) {
        return no_light();
    }
    let pdf = light_choice_pdf(i) * dist * dist / (cos_l * r1.w);
    return LightSample(wi, dist, lights[4u * i + 3u].xyz, pdf, true);
}
