// Emitter sampling (next-event estimation) and the densities MIS weighs
// against: area lights (triangles by area or, where large, by solid angle;
// spheres by their cone; disks by area; one-sided) and
// point, spot and directional lights, chosen by light_choice.wgsl, and
// the environment: constant (uniform sphere) or a lat-long map.
// A light's record (flatten.rs, LIGHT_WORDS vec4s): [0] = (p0, centre,
// position or direction to the light; kind), [1] = (p1, (radius, 0, 0) or
// the spot's world-to-local row 0; area or cos cutoff), [2] = (p2 or row
// 1; CDF within its group), [3] = (radiance, intensity or irradiance;
// shape), [4] = (row 2 or a disk's front normal; cos beam), [5] = (group,
// probability within it). A disk's p0, p1, p2 are its centre
// and axes. A projector's (emitter/projector.rs) is a spot's with
// tan(fov_x / 2) in [1].w, pi scale (times a constant irradiance) in [3]
// and the image's aspect ratio in [4].w.

const LIGHT_WORDS: u32 = 6u;
const LIGHT_TRIANGLE: u32 = 0u;
const LIGHT_SPHERE: u32 = 1u;
const LIGHT_POINT: u32 = 2u;
const LIGHT_SPOT: u32 = 3u;
const LIGHT_DIRECTIONAL: u32 = 4u;
const LIGHT_DISK: u32 = 5u;
const LIGHT_PROJECTOR: u32 = 6u;

struct LightSample {
    wi: vec3<f32>,
    dist: f32,
    le: vec3<f32>,
    // Solid-angle density, the choice included; for delta lights the
    // probability of the choice.
    pdf: f32,
    delta: bool,
    ok: bool,
}

fn no_light() -> LightSample {
    return LightSample(vec3<f32>(0.0), 0.0, vec3<f32>(0.0), 0.0, false, false);
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
// normal `n`, seen from `p`, where the choice picks it with probability
// `choice`.
fn area_pdf(i: u32, choice: f32, p: vec3<f32>, q: vec3<f32>, n: vec3<f32>) -> f32 {
    let r0 = lights[LIGHT_WORDS * i];
    if (bitcast<u32>(r0.w) == LIGHT_TRIANGLE) {
        // Sampled by the solid angle it subtends from p, where large.
        let omega = spherical_omega(r0.xyz, lights[LIGHT_WORDS * i + 1u].xyz, lights[LIGHT_WORDS * i + 2u].xyz, p);
        if (omega > 0.0) {
            return choice / omega;
        }
    }
    if (bitcast<u32>(r0.w) == LIGHT_SPHERE) {
        let cos_max = sphere_cone_cos(p, r0.xyz, lights[LIGHT_WORDS * i + 1u].x);
        if (cos_max < 1.0) {
            return choice / (2.0 * PI * (1.0 - cos_max));
        }
    }
    let d = q - p;
    let dist2 = dot(d, d);
    let cos_l = abs(dot(n, d)) / sqrt(dist2);
    if (cos_l <= 0.0) {
        return 0.0;
    }
    return choice * dist2 / (cos_l * lights[LIGHT_WORDS * i + 1u].w);
}

// --- The environment: constant (uniform sphere) or a lat-long map
// (emitter/envmap/: latlong.rs's (u, v), grid.rs's cells and lookup,
// warp.rs's MIS-compensated density: a band and a cell drawn from CDFs,
// then, for the bilinear filter, a point of the cell from the bilinear
// interpolant of the density's values at its corners).

fn env_u32(i: u32) -> u32 {
    return bitcast<u32>(env_data[i]);
}

fn texel(row: u32, col: u32) -> vec3<f32> {
    let i = 3u * (row * P.env_width + col);
    return vec3<f32>(env_data[i], env_data[i + 1u], env_data[i + 2u]);
}

struct EnvCell {
    col: u32,
    band: u32,
    fx: f32,
    fy: f32,
}

// grid.rs's locate.
fn env_locate(uv: vec2<f32>) -> EnvCell {
    let w = P.env_width;
    let x = uv.x * f32(w) - P.env_col_offset;
    let xf = floor(x);
    var col = u32(max(xf, 0.0));
    if (xf < 0.0) {
        col = w - 1u;
    } else if (col >= w) {
        col = 0u;
    }
    let fx = clamp(x - xf, 0.0, 1.0);
    let band = u32(clamp(floor(uv.y * P.env_band_scale + P.env_band_offset), 0.0, f32(P.env_bands - 1u)));
    let fy = clamp((uv.y - env_data[P.off_edges + band]) * env_data[P.off_inv_heights + band], 0.0, 1.0);
    return EnvCell(col, band, fx, fy);
}

// grid.rs's lookup (texels already scaled).
fn env_lookup(c: EnvCell) -> vec3<f32> {
    let r0 = env_u32(P.off_rows + c.band);
    if (P.env_bilinear == 0u) {
        return texel(r0, c.col);
    }
    let r1 = env_u32(P.off_rows + c.band + 1u);
    let c1 = select(c.col + 1u, 0u, c.col + 1u == P.env_width);
    let top = mix(texel(r0, c.col), texel(r0, c1), c.fx);
    let bottom = mix(texel(r1, c.col), texel(r1, c1), c.fx);
    return mix(top, bottom, c.fy);
}

fn env_rotate(m: array<vec4<f32>, 3>, v: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(dot(m[0].xyz, v), dot(m[1].xyz, v), dot(m[2].xyz, v));
}

// Probability of the cell under the sampling density.
fn env_cell_prob(band: u32, col: u32) -> f32 {
    var below = 0.0;
    if (band > 0u) {
        below = env_data[P.off_band_cdf + band - 1u];
    }
    let pb = env_data[P.off_band_cdf + band] - below;
    let base = P.off_col_cdf + band * P.env_width;
    var left = 0.0;
    if (col > 0u) {
        left = env_data[base + col - 1u];
    }
    return pb * (env_data[base + col] - left);
}

// The density's values at a bilinear cell's corners: (top-left,
// top-right, bottom-left, bottom-right) (warp.rs's corners).
fn env_corners(band: u32, col: u32) -> vec4<f32> {
    let w = P.env_width;
    let c1 = select(col + 1u, 0u, col + 1u == w);
    let t = P.off_density + band * w;
    let b = t + w;
    return vec4<f32>(env_data[t + col], env_data[t + c1], env_data[b + col], env_data[b + c1]);
}

// The density at (fx, fy) of its cell over the cell's mean (1 for the
// nearest filter, whose density is constant per cell).
fn env_cell_shape(c: EnvCell) -> f32 {
    if (P.env_bilinear == 0u) {
        return 1.0;
    }
    let v = env_corners(c.band, c.col);
    let sum = v.x + v.y + v.z + v.w;
    if (sum <= 0.0) {
        return 0.0;
    }
    let top = mix(v.x, v.y, c.fx);
    let bottom = mix(v.z, v.w, c.fx);
    return 4.0 * mix(top, bottom, c.fy) / sum;
}

// Solid-angle density of a point of a cell at sin(theta): the cell's
// probability over its (u, v) area, times its shape there.
fn env_cell_pdf(c: EnvCell, sin_theta: f32) -> f32 {
    if (sin_theta <= 0.0) {
        return 0.0;
    }
    let dv = env_data[P.off_edges + c.band + 1u] - env_data[P.off_edges + c.band];
    let pdf_uv = env_cell_prob(c.band, c.col) * f32(P.env_width) / dv * env_cell_shape(c);
    return pdf_uv / (2.0 * PI * PI * sin_theta);
}

// sampling/linear.rs's sample_linear: x in [0, 1] with density
// proportional to (1 - x) a + x b.
fn sample_linear(a: f32, b: f32, u: f32) -> f32 {
    let root = sqrt((1.0 - u) * a * a + u * b * b);
    let denom = a + root;
    if (denom > 0.0) {
        return clamp(u * (a + b) / denom, 0.0, 1.0);
    }
    return 0.0;
}

// Radiance along world direction `d` (rgb) and the density emitter
// sampling would have chosen it with, the choice included (w): the map's,
// or its facing density's for normal bin `bin` (NONE: the map's).
fn env_eval_pdf(d: vec3<f32>, bin: u32) -> vec4<f32> {
    if (P.env_kind == ENV_CONSTANT) {
        return vec4<f32>(P.env.xyz, P.env_prob * 0.25 * INV_PI);
    }
    let l = normalize(env_rotate(P.env_to_local, d));
    let sin_theta = sqrt(l.x * l.x + l.z * l.z);
    var u = atan2(l.x, -l.z) * (0.5 * INV_PI);
    if (u < 0.0) {
        u += 1.0;
    }
    if (u >= 1.0) {
        u = 0.0;
    }
    let v = clamp(atan2(sin_theta, l.y) * INV_PI, 0.0, 1.0);
    let c = env_locate(vec2<f32>(u, v));
    var pdf = 0.0;
    if (bin == NONE) {
        pdf = env_cell_pdf(c, sin_theta);
    } else {
        pdf = env_facing_pdf(c, sin_theta, bin);
    }
    return vec4<f32>(env_lookup(c), P.env_prob * pdf);
}

// The first index in cdf[base .. base + n] whose value exceeds `x`.
fn env_search(base: u32, n: u32, x: f32) -> u32 {
    var lo = 0u;
    var hi = n - 1u;
    while (lo < hi) {
        let mid = (lo + hi) / 2u;
        if (env_data[base + mid] > x) {
            hi = mid;
        } else {
            lo = mid + 1u;
        }
    }
    return lo;
}

// A light sample of the environment with `u`, from the map's density or,
// for normal bin `bin` (not NONE), from its facing density.
fn sample_env(u: vec2<f32>, bin: u32) -> LightSample {
    if (P.env_kind == ENV_CONSTANT) {
        let wi = square_to_uniform_sphere(u);
        return LightSample(wi, INF, P.env.xyz, P.env_prob * 0.25 * INV_PI, false, true);
    }
    if (bin != NONE) {
        return sample_env_facing(u, bin);
    }
    // A band, then a column in it; what is left of each number places the
    // point inside the cell.
    let band = env_search(P.off_band_cdf, P.env_bands, u.y);
    var b0 = 0.0;
    if (band > 0u) {
        b0 = env_data[P.off_band_cdf + band - 1u];
    }
    let fy_u = clamp((u.y - b0) / (env_data[P.off_band_cdf + band] - b0), 0.0, 1.0);
    let base = P.off_col_cdf + band * P.env_width;
    let col = env_search(base, P.env_width, u.x);
    var c0 = 0.0;
    if (col > 0u) {
        c0 = env_data[base + col - 1u];
    }
    let fx = clamp((u.x - c0) / (env_data[base + col] - c0), 0.0, 1.0);
    return env_place(band, col, fx, fy_u, NONE);
}

// The point of cell (band, col) that (fx, fy) in [0, 1]^2 places (warp.rs's
// place), as a light sample with its radiance and the density of `bin`.
fn env_place(band: u32, col: u32, fx_u: f32, fy_u: f32, bin: u32) -> LightSample {
    var fx = fx_u;
    var fy = fy_u;
    if (P.env_bilinear != 0u) {
        // warp.rs's place: the marginal in u is linear between the column
        // sums, the conditional in v linear between the edges at that u.
        let v = env_corners(band, col);
        fx = sample_linear(v.x + v.z, v.y + v.w, fx);
        fy = sample_linear(mix(v.x, v.y, fx), mix(v.z, v.w, fx), fy);
    }
    let v0 = env_data[P.off_edges + band];
    let dv = env_data[P.off_edges + band + 1u] - v0;
    // A point where the density vanishes (a pole, the border of the
    // compensated density's support) is pulled towards its cell's centre,
    // as mod.rs's sample does.
    let shrinks = array<f32, 5>(1.0, 0.999, 0.99, 0.5, 0.0);
    for (var k = 0u; k < 5u; k++) {
        let px = 0.5 + (fx - 0.5) * shrinks[k];
        let py = 0.5 + (fy - 0.5) * shrinks[k];
        var uu = (f32(col) + px + P.env_col_offset) / f32(P.env_width);
        if (uu >= 1.0) {
            uu -= 1.0;
        }
        let phi = 2.0 * PI * clamp(uu, 0.0, 1.0);
        let theta = PI * (v0 + py * dv);
        let sin_theta = sin(theta);
        let l = vec3<f32>(sin_theta * sin(phi), cos(theta), -sin_theta * cos(phi));
        let wi = normalize(env_rotate(P.env_to_world, l));
        // Radiance and density where the direction lands (the same cell
        // but for rounding).
        let e = env_eval_pdf(wi, bin);
        if (e.w > 0.0) {
            return LightSample(wi, INF, e.xyz, e.w, false, true);
        }
    }
    return no_light();
}

// --- The facing density (envmap/facing.rs): for a surface that only
// reflects, per octahedral bin of its normal (in the map's frame) a CDF
// over blocks of cells, then the CPU's running sums over the block's
// bands and over the band's cells in the block. Its pdf is read from the
// same tables, so that sampling and pdf agree on the device to the bit.

const FACING_BIN_SIDE: u32 = 8u;

// facing.rs's bin_of for a world-space normal; NONE where the map has no
// facing density, or for a zero or non-finite normal.
fn env_facing_bin(n_world: vec3<f32>) -> u32 {
    if (P.env_kind != ENV_MAP || P.env_blocks == 0u) {
        return NONE;
    }
    let n = env_rotate(P.env_to_local, n_world);
    let l1 = abs(n.x) + abs(n.y) + abs(n.z);
    if (not_finite(l1) || l1 <= 0.0) {
        return NONE;
    }
    let q = n / l1;
    var p = vec2<f32>(q.x, q.z);
    if (q.y < 0.0) {
        let sx = select(-1.0, 1.0, q.x >= 0.0);
        let sz = select(-1.0, 1.0, q.z >= 0.0);
        p = vec2<f32>((1.0 - abs(q.z)) * sx, (1.0 - abs(q.x)) * sz);
    }
    let side = FACING_BIN_SIDE - 1u;
    let cell = min(vec2<u32>((p + 1.0) * (0.5 * f32(FACING_BIN_SIDE))), vec2<u32>(side));
    return cell.y * FACING_BIN_SIDE + cell.x;
}

// A block's columns (x, y: start, end) and bands (z, w).
fn env_block_span(k: u32) -> vec4<u32> {
    let bx = k % P.env_blocks_across;
    let by = k / P.env_blocks_across;
    let cs = P.env_block_col_shift;
    let bs = P.env_block_band_shift;
    return vec4<u32>(bx << cs, min((bx + 1u) << cs, P.env_width), by << bs, min((by + 1u) << bs, P.env_bands));
}

// The share of entry `i` of the running sums at `base` (n of them).
fn running_share(base: u32, i: u32, n: u32) -> f32 {
    let total = env_data[base + n - 1u];
    if (total <= 0.0) {
        return 0.0;
    }
    var lo = 0.0;
    if (i > 0u) {
        lo = env_data[base + i - 1u];
    }
    return (env_data[base + i] - lo) / total;
}

struct RunningPick {
    i: u32,
    rest: f32,
}

// facing.rs's pick_running: the first of the n running sums at `base`
// above u times their total, and u rescaled inside it. The total is
// positive (the caller's block has weight).
fn running_pick(base: u32, n: u32, u: f32) -> RunningPick {
    let t = u * env_data[base + n - 1u];
    let i = env_search(base, n, t);
    var lo = 0.0;
    if (i > 0u) {
        lo = env_data[base + i - 1u];
    }
    let width = env_data[base + i] - lo;
    var rest = 0.5;
    if (width > 0.0) {
        rest = clamp((t - lo) / width, 0.0, 0.99999994);
    }
    return RunningPick(i, rest);
}

// Solid-angle density of the facing density of `bin` at a point of a cell
// at sin(theta): the probabilities of its block, band and cell, over the
// cell's (u, v) area, times the cell's shape there.
fn env_facing_pdf(c: EnvCell, sin_theta: f32, bin: u32) -> f32 {
    if (sin_theta <= 0.0) {
        return 0.0;
    }
    let k = (c.band >> P.env_block_band_shift) * P.env_blocks_across + (c.col >> P.env_block_col_shift);
    let span = env_block_span(k);
    let p_block = running_share(P.off_block_cdf + bin * P.env_blocks, k, P.env_blocks);
    let bands_per = 1u << P.env_block_band_shift;
    let p_band = running_share(P.off_band_sums + k * bands_per, c.band - span.z, span.w - span.z);
    let p_cell = running_share(P.off_cell_sums + c.band * P.env_width + span.x, c.col - span.x, span.y - span.x);
    let dv = env_data[P.off_edges + c.band + 1u] - env_data[P.off_edges + c.band];
    let pdf_uv = p_block * p_band * p_cell * f32(P.env_width) / dv * env_cell_shape(c);
    return pdf_uv / (2.0 * PI * PI * sin_theta);
}

// facing.rs's sample: a block from the bin's CDF, a band of it, a cell of
// that band's segment, then the point inside the cell as the map's own
// density places it.
fn sample_env_facing(u: vec2<f32>, bin: u32) -> LightSample {
    let row = P.off_block_cdf + bin * P.env_blocks;
    if (env_data[row + P.env_blocks - 1u] <= 0.0) {
        // No surface of this bin sees any light.
        return no_light();
    }
    let block = running_pick(row, P.env_blocks, u.x);
    let span = env_block_span(block.i);
    let bands_per = 1u << P.env_block_band_shift;
    let band_base = P.off_band_sums + block.i * bands_per;
    let bands = span.w - span.z;
    if (env_data[band_base + bands - 1u] <= 0.0) {
        return no_light();
    }
    let b = running_pick(band_base, bands, u.y);
    let band = span.z + b.i;
    let cell_base = P.off_cell_sums + band * P.env_width + span.x;
    let cols = span.y - span.x;
    if (env_data[cell_base + cols - 1u] <= 0.0) {
        return no_light();
    }
    let c = running_pick(cell_base, cols, block.rest);
    return env_place(band, span.x + c.i, c.rest, b.rest, bin);
}

// World direction `d` in spot light `i`'s frame (its axis along +z).
fn spot_local(i: u32, d: vec3<f32>) -> vec3<f32> {
    let rows = LIGHT_WORDS * i;
    return vec3<f32>(dot(lights[rows + 1u].xyz, d), dot(lights[rows + 2u].xyz, d), dot(lights[rows + 4u].xyz, d));
}

// Spot falloff (emitter/spot.rs's intensity_towards, before its texture)
// towards world direction `d` from spot light `i`: 1 inside the beam,
// linear in angle to 0 at the cutoff.
fn spot_falloff(i: u32, d: vec3<f32>) -> f32 {
    let local = spot_local(i, d);
    let cos_t = local.z / length(local);
    let cos_cutoff = lights[LIGHT_WORDS * i + 1u].w;
    let cos_beam = lights[LIGHT_WORDS * i + 4u].w;
    if (!(cos_t > cos_cutoff)) {
        return 0.0;
    }
    if (cos_t >= cos_beam) {
        return 1.0;
    }
    let cutoff = acos(cos_cutoff);
    return (cutoff - acos(clamp(cos_t, -1.0, 1.0))) / (cutoff - acos(cos_beam));
}

// Where world direction `d` from spot light `i` reads its projected
// texture (spot.rs's intensity_towards): 0.5 + 0.5 (x, y) / (z tan(cutoff))
// of the local direction.
fn spot_uv(i: u32, d: vec3<f32>) -> vec2<f32> {
    let local = spot_local(i, d);
    let cos_cutoff = lights[LIGHT_WORDS * i + 1u].w;
    let tan_cutoff = sqrt(max(1.0 - cos_cutoff * cos_cutoff, 0.0)) / cos_cutoff;
    let k = 0.5 / (local.z * tan_cutoff);
    return vec2<f32>(0.5 + local.x * k, 0.5 + local.y * k);
}

// Where projector `i` sends the light that reaches `p` in its image, and
// its factor there (projector.rs's `sample`: pi scale / (z^2 cos) of the
// local offset `z` and the cosine to its axis, zero outside the image).
fn projector_at(i: u32, p: vec3<f32>, wi: vec3<f32>, uv: ptr<function, vec2<f32>>) -> f32 {
    let r0 = lights[LIGHT_WORDS * i];
    let local = spot_local(i, p - r0.xyz);
    let tan_half = lights[LIGHT_WORDS * i + 1u].w;
    let aspect = lights[LIGHT_WORDS * i + 4u].w;
    if (!(local.z > 0.0)) {
        return 0.0;
    }
    let k = 0.5 / (local.z * tan_half);
    *uv = vec2<f32>(0.5 - local.x * k, 0.5 - aspect * local.y * k);
    if (any(*uv < vec2<f32>(0.0)) || any(*uv > vec2<f32>(1.0))) {
        return 0.0;
    }
    // The axis: row 2 of the world-to-local map, normalised (flatten.rs
    // takes only projectors whose row 2 lies along the axis).
    let cos_t = dot(normalize(lights[LIGHT_WORDS * i + 4u].xyz), -wi);
    if (!(cos_t > 0.0)) {
        return 0.0;
    }
    return 1.0 / (local.z * local.z * cos_t);
}

// Point, spot, directional and projector light `i` seen from `p`
// (emitter/point.rs, spot.rs, directional.rs, projector.rs): intensity /
// dist^2, the irradiance or the projector's factor, with the probability
// of the choice as its pdf; a projector's image position in `*uv`.
fn sample_delta_light(i: u32, choice: f32, p: vec3<f32>, uv: ptr<function, vec2<f32>>) -> LightSample {
    let r0 = lights[LIGHT_WORDS * i];
    let power = lights[LIGHT_WORDS * i + 3u].xyz;
    let pdf = choice;
    if (bitcast<u32>(r0.w) == LIGHT_DIRECTIONAL) {
        return LightSample(r0.xyz, INF, power, pdf, true, true);
    }
    let to = r0.xyz - p;
    let d2 = dot(to, to);
    if (d2 <= 0.0) {
        return no_light();
    }
    let dist = sqrt(d2);
    let wi = to / dist;
    var le = power / d2;
    if (bitcast<u32>(r0.w) == LIGHT_SPOT) {
        le *= spot_falloff(i, -wi);
    } else if (bitcast<u32>(r0.w) == LIGHT_PROJECTOR) {
        le = power * projector_at(i, p, wi, uv);
    }
    return LightSample(wi, dist, le, pdf, true, max(le.x, max(le.y, le.z)) > 0.0);
}

// Area light `i`'s radiance at the surface point `at` (area.rs's
// radiance_at): its texture's value there, or its constant radiance.
fn light_radiance(i: u32, at: TexPoint) -> vec3<f32> {
    let record = bitcast<u32>(lights[LIGHT_WORDS * i + 4u].w);
    if (record == NONE) {
        return lights[LIGHT_WORDS * i + 3u].xyz;
    }
    return texture_lookup(record, at, false);
}

// The (u, v) of a textured sphere light's point along unit `n` from its
// centre (intersect.wgsl's surface_at), (0, 0) for an untextured one.
fn light_sphere_uv(i: u32, n: vec3<f32>) -> vec2<f32> {
    let slot = bitcast<u32>(lights[LIGHT_WORDS * i + 4u].x);
    if (slot == NONE) {
        return vec2<f32>(0.0);
    }
    return sphere_uv(n, SLOT_WORDS * slot);
}

// A light sample from `p` with shading normal `n`, whose choice_total is
// `total`: the environment with probability P.env_prob (for a surface of
// facing bin `bin`, or NONE), else the light light_choice.wgsl picks.
fn sample_light(p: vec3<f32>, n: vec3<f32>, total: f32, u_choice: f32, u: vec2<f32>, bin: u32) -> LightSample {
    if (u_choice < P.env_prob) {
        return sample_env(u, bin);
    }
    let c = choose_light(p, n, total, u_choice);
    if (!c.ok) {
        return no_light();
    }
    let i = c.light;
    let kind = bitcast<u32>(lights[LIGHT_WORDS * i].w);
    // One texture read for every kind (shaders inline each call): an area
    // light's radiance (its record in word 4) at the sampled point `at`,
    // or a spot's or projector's projected tint (word 3) at `uv`.
    var uv = vec2<f32>(0.0);
    var at = tex_at_uv(uv);
    var record = NONE;
    var ls: LightSample;
    let projects = kind == LIGHT_SPOT || kind == LIGHT_PROJECTOR;
    if ((kind >= LIGHT_POINT && kind <= LIGHT_DIRECTIONAL) || kind == LIGHT_PROJECTOR) {
        ls = sample_delta_light(i, c.prob, p, &uv);
        if (projects) {
            record = bitcast<u32>(lights[LIGHT_WORDS * i + 3u].w);
        }
        if (kind == LIGHT_SPOT) {
            uv = spot_uv(i, -ls.wi);
        }
        at = tex_at_uv(uv);
    } else {
        ls = sample_area_light(i, c.prob, p, u, &at);
        record = bitcast<u32>(lights[LIGHT_WORDS * i + 4u].w);
    }
    if (record != NONE && ls.ok) {
        let t = texture_lookup(record, at, false);
        // A spot's or projector's texture tints its intensity; an area
        // light's is its radiance.
        ls.le = select(t, ls.le * t, projects);
    }
    return ls;
}

// Area light `i` sampled from `p`: its constant radiance (the mean of a
// textured one, which the caller reads at `*at`: the sampled point's uv,
// and on a slotted triangle its index in the mesh and barycentrics in the
// mesh's corner order, as surface_at gives them).
fn sample_area_light(i: u32, choice: f32, p: vec3<f32>, u: vec2<f32>, at: ptr<function, TexPoint>) -> LightSample {
    let r0 = lights[LIGHT_WORDS * i];
    let r1 = lights[LIGHT_WORDS * i + 1u];
    let kind = bitcast<u32>(r0.w);
    var q: vec3<f32>;
    var n: vec3<f32>;
    // A direction drawn in a sphere's cone: its distance and density.
    var cone_wi = vec3<f32>(0.0);
    var cone_t = 0.0;
    var cone_pdf = 0.0;
    // A triangle's solid-angle density where it is sampled so.
    var solid_pdf = 0.0;
    if (kind == LIGHT_SPHERE) {
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
            cone_wi = wi;
            cone_t = -b - sqrt(disc);
            cone_pdf = choice / (2.0 * PI * (1.0 - cos_max));
            n = normalize(oc + cone_t * wi);
        } else {
            n = square_to_uniform_sphere(u);
            q = r0.xyz + r1.x * n;
        }
        *at = tex_at_uv(light_sphere_uv(i, n));
    } else if (kind == LIGHT_DISK) {
        let l = square_to_uniform_disk(u);
        q = r0.xyz + l.x * r1.xyz + l.y * lights[LIGHT_WORDS * i + 2u].xyz;
        n = lights[LIGHT_WORDS * i + 4u].xyz;
        *at = tex_at_uv(disk_uv(l));
    } else {
        let p2 = lights[LIGHT_WORDS * i + 2u].xyz;
        var b = square_to_uniform_triangle(u);
        // A triangle large from p: uniformly in the solid angle it
        // subtends (area.rs's sample_spherical), else by area.
        let omega = spherical_omega(r0.xyz, r1.xyz, p2, p);
        if (omega > 0.0) {
            let d = sample_spherical_triangle(normalize(r0.xyz - p), normalize(r1.xyz - p), normalize(p2 - p), u);
            let along = barycentrics_along(r0.xyz, r1.xyz, p2, p, d.xyz);
            if (d.w == 0.0 || along.z == 0.0) {
                return no_light();
            }
            b = along.xy;
            solid_pdf = choice / omega;
        }
        q = (1.0 - b.x - b.y) * r0.xyz + b.x * r1.xyz + b.y * p2;
        n = normalize(cross(r1.xyz - r0.xyz, p2 - r0.xyz));
        // The triangle's vertex uvs, index and corner order, as
        // surface_at reads them.
        let slot = bitcast<u32>(lights[LIGHT_WORDS * i + 4u].x);
        if (slot != NONE) {
            let k = SLOT_WORDS * slot;
            let t01 = normals[k + 3u];
            let w4 = normals[k + 4u];
            let uv = (1.0 - b.x - b.y) * t01.xy + b.x * t01.zw + b.y * w4.xy;
            *at = TexPoint(uv, bitcast<u32>(w4.z), select(b, b.yx, w4.w != 0.0));
        }
    }
    let le = lights[LIGHT_WORDS * i + 3u].xyz;
    if (cone_pdf > 0.0) {
        return LightSample(cone_wi, cone_t, le, cone_pdf, false, cone_t > 0.0);
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
    var pdf = choice * dist * dist / (cos_l * r1.w);
    if (solid_pdf > 0.0) {
        pdf = solid_pdf;
    }
    return LightSample(wi, dist, le, pdf, false, true);
}
