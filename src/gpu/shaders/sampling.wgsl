// Random numbers (PCG, one stream per pixel sample; a stratified
// sampler's first numbers from scrambled (0, 2) sequences, as
// sampling/sobol.rs) and warps (sampling/warp.rs).

var<private> rng_state: u32;
// A stratified sample: its index's bits reversed, its pixel's seed, the
// next dimension and where scrambled numbers end (0: independent).
var<private> ld_reversed_index: u32;
var<private> ld_seed: u32;
var<private> ld_dim: u32;
var<private> ld_dims: u32;

fn pcg_hash(v: u32) -> u32 {
    let s = v * 747796405u + 2891336453u;
    let w = ((s >> ((s >> 28u) + 4u)) ^ s) * 277803737u;
    return (w >> 22u) ^ w;
}

// The stream of sample `s` of pixel `pixel` under the render's seed.
fn rng_init(pixel: u32, s: u32) {
    let seed = pcg_hash(P.seed_lo ^ pcg_hash(P.seed_hi));
    rng_state = pcg_hash(pcg_hash(seed ^ pcg_hash(pixel)) ^ (s * 0x9e3779b9u));
    ld_reversed_index = reverseBits(s);
    ld_seed = pcg_hash(pcg_hash(seed ^ 0x57a71f1eu) ^ pcg_hash(pixel));
    ld_dim = 0u;
    ld_dims = P.stratified_dims;
}

// sobol.rs's upward_hash: bit j of the result depends on bits 0..=j of x
// only; on reversed bits, an Owen scramble.
fn upward_hash(x0: u32, seed: u32) -> u32 {
    var x = x0 + seed;
    x ^= x * 0x6c50b47cu;
    x ^= x * 0xb82f1e52u;
    x ^= x * 0xc7afe638u;
    x ^= x * 0x8d22f6e6u;
    return x;
}

// sobol.rs's sobol_second_reversed: Sobol's second dimension, bits reversed.
fn sobol_second_reversed(index: u32) -> u32 {
    var x = index;
    x ^= (x >> 1u) & 0x55555555u;
    x ^= (x >> 2u) & 0x33333333u;
    x ^= (x >> 4u) & 0x0f0f0f0fu;
    x ^= (x >> 8u) & 0x00ff00ffu;
    return x ^ (x >> 16u);
}

// A binary fraction as a float in [0, 1): its top 24 bits.
fn to_unit(x: u32) -> f32 {
    return f32(x >> 8u) * (1.0 / 16777216.0);
}

// The current dimension's seeds: the index shuffle's, the first
// coordinate's scramble; the dimension moves on by `n`.
fn ld_seeds(n: u32) -> vec2<u32> {
    let a = pcg_hash(ld_seed ^ ((ld_dim + 1u) * 0x9e3779b9u));
    ld_dim += n;
    return vec2<u32>(a, pcg_hash(a ^ 0x85ebca6bu));
}

// The shuffled sample index of the current dimension (sobol.rs's point_2d).
fn ld_index(shuffle: u32) -> u32 {
    return reverseBits(upward_hash(ld_reversed_index, shuffle));
}

fn next_1d() -> f32 {
    if (ld_dim < ld_dims) {
        let s = ld_seeds(1u);
        return to_unit(reverseBits(upward_hash(ld_index(s.x), s.y)));
    }
    return next_independent();
}

// The PCG stream's next number: the permuted output of its state, which
// then advances (the same step pcg_hash takes).
fn next_independent() -> f32 {
    let x = pcg_hash(rng_state);
    rng_state = rng_state * 747796405u + 2891336453u;
    return to_unit(x);
}

fn next_2d() -> vec2<f32> {
    if (ld_dim + 1u < ld_dims) {
        let s = ld_seeds(2u);
        let i = ld_index(s.x);
        let y_seed = pcg_hash(s.y ^ 0x5bd1e995u);
        return vec2<f32>(
            to_unit(reverseBits(upward_hash(i, s.y))),
            to_unit(reverseBits(upward_hash(sobol_second_reversed(i), y_seed))),
        );
    }
    let x = next_independent();
    return vec2<f32>(x, next_independent());
}

// sampling/warp.rs's square_to_beckmann: a normal drawn from Beckmann's
// D(m) cos(theta_m).
fn square_to_beckmann(u: vec2<f32>, alpha: f32) -> vec3<f32> {
    let tan2 = -alpha * alpha * log(1.0 - u.x);
    let cos_theta = 1.0 / sqrt(1.0 + tan2);
    let sin_theta = sqrt(tan2) * cos_theta;
    let phi = 2.0 * PI * u.y;
    return vec3<f32>(sin_theta * cos(phi), sin_theta * sin(phi), cos_theta);
}

// Shirley and Chiu's concentric map of the square to the unit disk.
fn square_to_uniform_disk(u: vec2<f32>) -> vec2<f32> {
    let o = 2.0 * u - vec2<f32>(1.0);
    if (o.x == 0.0 && o.y == 0.0) {
        return vec2<f32>(0.0);
    }
    var r: f32;
    var theta: f32;
    if (abs(o.x) > abs(o.y)) {
        r = o.x;
        theta = 0.25 * PI * (o.y / o.x);
    } else {
        r = o.y;
        theta = 0.5 * PI - 0.25 * PI * (o.x / o.y);
    }
    return r * vec2<f32>(cos(theta), sin(theta));
}

fn square_to_cosine_hemisphere(u: vec2<f32>) -> vec3<f32> {
    let d = square_to_uniform_disk(u);
    return vec3<f32>(d, sqrt(max(0.0, 1.0 - dot(d, d))));
}

fn square_to_uniform_sphere(u: vec2<f32>) -> vec3<f32> {
    let z = 1.0 - 2.0 * u.y;
    let r = sqrt(max(0.0, 1.0 - z * z));
    let phi = 2.0 * PI * u.x;
    return vec3<f32>(r * cos(phi), r * sin(phi), z);
}

// Barycentrics (b1, b2) of a uniformly distributed point of a triangle.
fn square_to_uniform_triangle(u: vec2<f32>) -> vec2<f32> {
    let su = sqrt(u.x);
    return vec2<f32>(u.y * su, 1.0 - su);
}

// Orthonormal basis around unit `n` (Duff et al. 2017).
struct Frame {
    s: vec3<f32>,
    t: vec3<f32>,
    n: vec3<f32>,
}

fn frame_from_normal(n: vec3<f32>) -> Frame {
    let sign = select(-1.0, 1.0, n.z >= 0.0);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    return Frame(
        vec3<f32>(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        vec3<f32>(b, sign + n.y * n.y * a, -n.y),
        n,
    );
}

// The frame around `n` whose s axis is `tangent` made orthogonal to it
// (math/frame.rs's `from_normal_tangent`), or `frame_from_normal(n)` where
// that is degenerate.
fn frame_from_normal_tangent(n: vec3<f32>, tangent: vec3<f32>) -> Frame {
    let v = tangent - n * dot(n, tangent);
    let rcp = inverseSqrt(dot(v, v));
    if (!(rcp > 0.0) || not_finite(rcp)) {
        return frame_from_normal(n);
    }
    let s = v * rcp;
    return Frame(s, cross(n, s), n);
}

fn to_local(f: Frame, v: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(dot(v, f.s), dot(v, f.t), dot(v, f.n));
}

fn to_world(f: Frame, v: vec3<f32>) -> vec3<f32> {
    return f.s * v.x + f.t * v.y + f.n * v.z;
}
