// The BSDFs the GPU renders (bsdf/diffuse.rs, two_sided.rs, blend.rs,
// mirror.rs, dielectric.rs, thin_dielectric.rs, conductor.rs,
// rough_conductor.rs, plastic.rs, rough_plastic.rs, rough_dielectric.rs,
// microfacet.rs, schlick_conductor.rs, rough_substrate.rs,
// polarized_plastic.rs, polarizer.rs and `null`,
// principled.rs, principled_thin.rs (principled.wgsl);
// their reflectances, transmittances and isotropic roughness textured as
// textured.rs reads them, texture.wgsl), in the shading frame (z along
// the shading normal).
// A shape's record (flatten.rs's `material`, SHAPE_WORDS vec4s):
// [0] = (A, kind), [1] = (B, alpha), [2] = (C, distribution), with A the
// diffuse reflectance, the specular reflectance (conductors) or the
// diffuse term (plastics); B (eta, 0, 0), eta (conductors), the specular
// transmittance (rough dielectric) or the specular reflectance (plastics);
// C k (conductors), (eta, 0, 0) (rough and thin dielectric) or (eta,
// specular sampling weight, transmittance table) (plastics). The thin
// dielectric's A and B are its specular reflectance and transmittance.
// [3] = (D, back, 0, 0): a `mask`'s opacity (1 otherwise; mask.rs), the
// other words its nested BSDF's; where the kind has MAT_BACK, `back` is
// the index of a two-sided material's different back: its three words,
// read instead of these when the hit is seen from behind. A blend's
// (MAT_BLEND, blend.rs) A is (its weight or the weight's texture record,
// the index of its first BSDF's three words, of its second's): layers
// that `use_layer` makes current in turn. The principled BSDF's words are
// principled.wgsl's.
//
// Rough lobes draw their microfacet normals from the visible normals, as
// the CPU does: GGX's by Heitz 2018, Beckmann's by the CPU's table of
// guesses and one Halley step (in f32).

const SHAPE_WORDS: u32 = 4u;

const MAT_DIFFUSE: u32 = 0u;
const MAT_ROUGH_CONDUCTOR: u32 = 2u;
const MAT_PLASTIC: u32 = 3u;
const MAT_ROUGH_PLASTIC: u32 = 4u;
const MAT_ROUGH_DIELECTRIC: u32 = 5u;
const MAT_PRINCIPLED: u32 = 6u;
const MAT_PRINCIPLED_THIN: u32 = 1u;
const MAT_BLEND: u32 = 7u;
const MAT_MICROFACET: u32 = 8u;
const MAT_SCHLICK_CONDUCTOR: u32 = 9u;
const MAT_ROUGH_SUBSTRATE: u32 = 10u;
const MAT_POLARIZED_PLASTIC: u32 = 11u;
const MAT_MIRROR: u32 = 12u;
const MAT_DIELECTRIC: u32 = 13u;
const MAT_CONDUCTOR: u32 = 14u;
const MAT_THIN_DIELECTRIC: u32 = 15u;
// Straight through with weight A (`null`, `polarizer`).
const MAT_PASS: u32 = 16u;

// Whether the scene has blends and Disney BSDFs (principled.wgsl): set
// per scene at pipeline creation (flatten.rs's `shader_constants`), so the
// compiler drops their code from kernels that never run it.
override BLENDS: bool = true;
override DISNEY: bool = true;

struct BsdfSample {
    wo: vec3<f32>,
    weight: vec3<f32>,
    pdf: f32,
    specular: bool,
    eta: f32,
    ok: bool,
}

fn no_sample() -> BsdfSample {
    return BsdfSample(vec3<f32>(0.0), vec3<f32>(0.0), 0.0, false, 1.0, false);
}

// A non-delta sample's direction (and relative IOR), to be weighed by
// `front_sample` with the whole material's value and density: one place
// that evaluates them, however many lobes and layers there are.
fn direction_only(wo: vec3<f32>, eta: f32) -> BsdfSample {
    return BsdfSample(wo, vec3<f32>(0.0), 0.0, false, eta, true);
}

// The layer whose words `material_word` reads and whose values `mat_a`
// and the rest hold (`use_layer`): the record `load_material` chose (the
// shape's, or the back's of a two-sided material with a different back
// seen from behind), or one of its blend's two BSDFs.
var<private> mat_base: u32;

fn material_word(k: u32) -> vec4<f32> {
    return shapes[mat_base + k];
}

// The `i`th scalar of the shapes buffer (tables stored four to a word).
fn shape_scalar(i: u32) -> f32 {
    return shapes[i / 4u][i % 4u];
}

// Set in the kind word of shapes with an area emitter (flatten.rs).
const MAT_EMITS: u32 = 0x100u;

// Set in the kind word of materials whose word A colour (a diffuse or
// specular reflectance) is a texture (texture.wgsl); word A then holds
// (its record's index, the plastics' internal reflectance, 1 if
// nonlinear) (flatten.rs). A blend's weight is then its texture's.
const MAT_TEXTURED: u32 = 0x200u;
// Word B's colour is a texture: B.x is its record's index.
const MAT_TEXTURED_B: u32 = 0x400u;
// Word C's colour (a conductor's k) is a texture: C.x is its record's
// index.
const MAT_TEXTURED_C: u32 = 0x20000u;
const DISNEY_RECORD: u32 = 0x7fc00000u;
const DISNEY_RECORD_INDICES: u32 = 0x400000u;
// The roughness is a texture read as one value: B.w is its record's index.
const MAT_TEXTURED_ALPHA: u32 = 0x800u;
// A `mask` over the BSDF: D is its opacity, or its texture's record index
// if MAT_TEXTURED_MASK (read as one value).
const MAT_MASK: u32 = 0x2000u;
const MAT_TEXTURED_MASK: u32 = 0x4000u;
// A two-sided material's front whose back differs (D.y: the back's record).
const MAT_BACK: u32 = 0x8000u;
// A normal or bump map over the BSDF: D.z is the normal or height
// texture's record, D.w the TILT_* flags (flatten.rs), D.y a bump map's
// scale.
const MAT_NORMAL_MAP: u32 = 0x10000u;
// Set in a shape's front record where the BSDF favours facing light
// (bsdf/mod.rs's favours_facing_light): the environment map's facing
// density serves light sampling at the path's first vertex.
const MAT_FACING: u32 = 0x40000u;
const MAT_FLAGS: u32 = MAT_EMITS | MAT_TEXTURED | MAT_TEXTURED_B | MAT_TEXTURED_C | MAT_TEXTURED_ALPHA
    | MAT_TWO_SIDED | MAT_MASK | MAT_TEXTURED_MASK | MAT_BACK | MAT_NORMAL_MAP | MAT_FACING;

// The current layer's kind.
fn material_kind() -> u32 {
    return bitcast<u32>(material_word(0u).w) & ~MAT_FLAGS;
}

// The shaded point's material values, its textures read once per hit
// (path.wgsl calls `load_material` after each hit; shaders inline every
// call, so one texture read here instead of one per use keeps the kernel
// small), per layer: where its words start; A, the diffuse reflectance,
// the specular reflectance or the plastics' diffuse term (the reflectance
// over what the coating reflects back inside: flatten.rs's
// `plastic_diffuse`); B, word B's colour; C, word C's colour (a
// conductor's k); the roughness; a Disney BSDF's (sheen, sheen_tint,
// flatness, spec_tint) (zero for other kinds). The current layer's are in
// mat_base, mat_a, mat_b, mat_c, mat_alpha and mat_extra. (Two structs
// rather than an array: an array indexed per lane is slower on lavapipe.)
struct Layer {
    base: u32,
    a: vec3<f32>,
    b: vec3<f32>,
    c: vec3<f32>,
    alpha: f32,
    extra: vec4<f32>,
}

// Where the hit's textures are read (`load_material`).
var<private> mat_at: TexPoint;
var<private> first_layer: Layer;
var<private> second_layer: Layer;
var<private> mat_a: vec3<f32>;
var<private> mat_b: vec3<f32>;
var<private> mat_c: vec3<f32>;
var<private> mat_alpha: f32;
var<private> mat_extra: vec4<f32>;
// The chosen record's kind word (the layers' flags are their own), the
// number of layers (2 for a blend), the blend's weight (its second
// layer's share), whether every layer is purely specular, and a mask's
// opacity (1 without a mask).
var<private> mat_flags: u32;
var<private> mat_layers: u32;
var<private> mat_blend_w: f32;
var<private> mat_specular: bool;
var<private> mat_facing: bool;
var<private> mat_opacity: f32;
// A normal map's texel as a normal (2c - 1), or a bump map's height
// slopes along u and v (times its scale) in x and y; the TILT_* flags
// with TILT_ON (0 without a map).
var<private> mat_tilt_n: vec3<f32>;
var<private> mat_tilt_flags: u32;

// Makes layer `l` the one the BSDF functions below read.
fn use_layer(l: u32) {
    var layer = first_layer;
    if (l == 1u) {
        layer = second_layer;
    }
    mat_base = layer.base;
    mat_a = layer.a;
    mat_b = layer.b;
    mat_c = layer.c;
    mat_alpha = layer.alpha;
    mat_extra = layer.extra;
}

// Layer `l`'s share of the material: 1 - w and w for a blend's first and
// second BSDF (bsdf/blend.rs), 1 for a single one.
fn layer_share(l: u32) -> f32 {
    if (mat_layers == 1u) {
        return 1.0;
    }
    return select(1.0 - mat_blend_w, mat_blend_w, l == 1u);
}

// The layer whose three words start at `base`, its textures not read.
fn layer_at(base: u32) -> Layer {
    let b = shapes[base + 1u];
    return Layer(base, shapes[base].xyz, b.xyz, shapes[base + 2u].xyz, b.w, vec4<f32>(0.0));
}

// Whether a Disney BSDF's B.x or C.x texture (principled.wgsl) is in
// texture `slot` (0: A, 1: B, 2: the roughness, 3: C) of a material of
// kind `kind`: a single value, as the roughness is.
fn disney_value_slot(kind: u32, slot: u32) -> bool {
    return (slot == 1u || slot == 3u) && (kind == MAT_PRINCIPLED || kind == MAT_PRINCIPLED_THIN);
}

// `layer` with the texel `t` of its texture `slot` read in.
fn with_texel(layer_in: Layer, slot: u32, t: vec3<f32>, record: u32) -> Layer {
    var layer = layer_in;
    let w0 = shapes[layer.base];
    let kind = bitcast<u32>(w0.w) & ~MAT_FLAGS;
    if (disney_value_slot(kind, slot)) {
        let v = texture_value_1(record, t);
        if (slot == 1u) {
            layer.b.x = v;
        } else {
            layer.c.x = v;
        }
    } else if (slot == 0u) {
        if (kind != MAT_PLASTIC && kind != MAT_ROUGH_PLASTIC) {
            layer.a = t;
        } else if (w0.z != 0.0) {
            layer.a = t / (vec3<f32>(1.0) - t * w0.y);
        } else {
            layer.a = t / (1.0 - w0.y);
        }
    } else if (slot == 1u) {
        layer.b = t;
    } else if (slot == 2u) {
        // textured.rs: at least distribution.rs's MIN_ALPHA.
        layer.alpha = max(texture_value_1(record, t), 1e-4);
    } else {
        layer.c = t;
    }
    return layer;
}

fn load_material(s: Surface, from_behind: bool) {
    let at = TexPoint(s.uv, s.tri, s.bary);
    mat_at = at;
    let top = SHAPE_WORDS * s.shape;
    // The mask's and the map's words stay the front record's.
    let w3 = shapes[top + 3u];
    let front_flags = bitcast<u32>(shapes[top].w);
    var base = top;
    if (from_behind && (front_flags & MAT_BACK) != 0u) {
        base = bitcast<u32>(w3.y);
    }
    let w0 = shapes[base];
    mat_flags = (bitcast<u32>(w0.w) & ~(MAT_MASK | MAT_TEXTURED_MASK))
        | (front_flags & (MAT_MASK | MAT_TEXTURED_MASK));
    let blend = BLENDS && (mat_flags & ~MAT_FLAGS) == MAT_BLEND;
    mat_layers = select(1u, 2u, blend);
    mat_blend_w = w0.x;
    mat_opacity = w3.x;
    mat_tilt_flags = select(0u, bitcast<u32>(w3.w) | TILT_ON, (mat_flags & MAT_NORMAL_MAP) != 0u);
    first_layer = layer_at(select(base, bitcast<u32>(w0.y), blend));
    var kinds = vec2<u32>(bitcast<u32>(shapes[first_layer.base].w), 0u);
    if (blend) {
        second_layer = layer_at(bitcast<u32>(w0.z));
        kinds.y = bitcast<u32>(shapes[second_layer.base].w);
    }
    mat_facing = (front_flags & MAT_FACING) != 0u;
    mat_specular = (kinds.x & ~MAT_FLAGS) >= MAT_MIRROR
        && (!blend || (kinds.y & ~MAT_FLAGS) >= MAT_MIRROR);
    // One loop, so the texture lookup is inlined once: the mask's opacity,
    // the normal or height map, the blend's weight, then each layer's A,
    // B, alpha and C (their records where the values would be).
    let textured = array<bool, 11>(
        (mat_flags & MAT_TEXTURED_MASK) != 0u,
        (mat_flags & MAT_NORMAL_MAP) != 0u,
        blend && (mat_flags & MAT_TEXTURED) != 0u,
        (kinds.x & MAT_TEXTURED) != 0u,
        (kinds.x & MAT_TEXTURED_B) != 0u,
        (kinds.x & MAT_TEXTURED_ALPHA) != 0u,
        (kinds.x & MAT_TEXTURED_C) != 0u,
        (kinds.y & MAT_TEXTURED) != 0u,
        (kinds.y & MAT_TEXTURED_B) != 0u,
        (kinds.y & MAT_TEXTURED_ALPHA) != 0u,
        (kinds.y & MAT_TEXTURED_C) != 0u,
    );
    let l0 = first_layer;
    let l1 = second_layer;
    let records = array<f32, 11>(w3.x, w3.z, w0.x, l0.a.x, l0.b.x, l0.alpha, l0.c.x, l1.a.x, l1.b.x, l1.alpha, l1.c.x);
    // (A single BSDF's loop stops before the second layer's.)
    let slots = select(7u, 11u, blend);
    for (var k = 0u; k < slots; k++) {
        if (!textured[k]) {
            continue;
        }
        let record = bitcast<u32>(records[k]);
        if (k == 1u && (mat_tilt_flags & TILT_BUMP) != 0u) {
            mat_tilt_n = vec3<f32>(texture_gradient_1(record, s.uv) * w3.y, 0.0);
            continue;
        }
        // Opacity, weight and roughness are read as one value (`eval_1`).
        let slot = (k + 1u) % 4u;
        let kind = select(kinds.x, kinds.y, k >= 7u) & ~MAT_FLAGS;
        let one = k == 0u || k == 2u || (k >= 3u && (slot == 2u || disney_value_slot(kind, slot)));
        let t = texture_lookup(record, at, one);
        if (k == 0u) {
            mat_opacity = clamp(texture_value_1(record, t), 0.0, 1.0);
        } else if (k == 1u) {
            mat_tilt_n = t * 2.0 - vec3<f32>(1.0);
        } else if (k == 2u) {
            mat_blend_w = clamp(texture_value_1(record, t), 0.0, 1.0);
        } else if (k < 7u) {
            first_layer = with_texel(first_layer, slot, t, record);
        } else {
            second_layer = with_texel(second_layer, slot, t, record);
        }
    }
    if (DISNEY) {
        load_disney_params();
    }
    use_layer(0u);
}

// The Disney layers' parameters whose words box a texture's record
// (flatten.rs's DISNEY_RECORD: a quiet NaN holding its index): B.y, B.z,
// C.z and the (sheen, sheen_tint, flatness, spec_tint) word, read as one
// value each (`Texture::eval_1`) into the layer, once per hit and with
// one lookup in the code for both layers.
fn load_disney_params() {
    for (var l = 0u; l < mat_layers; l++) {
        var layer = first_layer;
        if (l == 1u) {
            layer = second_layer;
        }
        let kind = bitcast<u32>(shapes[layer.base].w) & ~MAT_FLAGS;
        if (kind != MAT_PRINCIPLED && kind != MAT_PRINCIPLED_THIN) {
            continue;
        }
        let extra = shapes[bitcast<u32>(shapes[layer.base + 2u].w)];
        var v = array<f32, 7>(layer.b.y, layer.b.z, layer.c.z, extra.x, extra.y, extra.z, extra.w);
        for (var k = 0u; k < 7u; k++) {
            let b = bitcast<u32>(v[k]);
            if ((b & DISNEY_RECORD) == DISNEY_RECORD) {
                let record = b & (DISNEY_RECORD_INDICES - 1u);
                v[k] = texture_value_1(record, texture_lookup(record, mat_at, true));
            }
        }
        layer.b = vec3<f32>(layer.b.x, v[0], v[1]);
        layer.c.z = v[2];
        layer.extra = vec4<f32>(v[3], v[4], v[5], v[6]);
        if (l == 1u) {
            second_layer = layer;
        } else {
            first_layer = layer;
        }
    }
}

// Read before `load_material`: the shape's own record.
fn shape_emits(shape: u32) -> bool {
    return (bitcast<u32>(shapes[SHAPE_WORDS * shape].w) & MAT_EMITS) != 0u;
}

// Purely specular materials: no light sampling at their surfaces.
fn is_specular() -> bool {
    return mat_specular;
}

// bsdf/mod.rs's favours_facing_light, decided per shape (MAT_FACING).
fn favours_facing_light() -> bool {
    return mat_facing;
}

fn reflect_about(wi: vec3<f32>, m: vec3<f32>) -> vec3<f32> {
    return 2.0 * dot(wi, m) * m - wi;
}

// --- Fresnel (fresnel.rs).

// Unpolarised Fresnel reflectance, cosine of the refracted direction and
// the relative IOR across (fresnel_dielectric).
fn fresnel_dielectric(cos_in: f32, eta: f32) -> vec3<f32> {
    var cos_i = cos_in;
    var eta_ti = eta;
    if (cos_in < 0.0) {
        cos_i = -cos_in;
        eta_ti = 1.0 / eta;
    }
    if (eta_ti == 1.0) {
        return vec3<f32>(0.0, cos_i, 1.0);
    }
    let sin2_t = max(1.0 - cos_i * cos_i, 0.0) / (eta_ti * eta_ti);
    if (sin2_t >= 1.0) {
        return vec3<f32>(1.0, 0.0, eta_ti);
    }
    let cos_t = sqrt(1.0 - sin2_t);
    let rs = (cos_i - eta_ti * cos_t) / (cos_i + eta_ti * cos_t);
    let rp = (eta_ti * cos_i - cos_t) / (eta_ti * cos_i + cos_t);
    return vec3<f32>(0.5 * (rs * rs + rp * rp), cos_t, eta_ti);
}

// Conductor Fresnel reflectance per channel (fresnel_conductor).
fn fresnel_conductor(cos_i: f32, eta: vec3<f32>, k: vec3<f32>) -> vec3<f32> {
    let cos2 = cos_i * cos_i;
    let sin2 = 1.0 - cos2;
    let sin4 = sin2 * sin2;
    let temp_1 = eta * eta - k * k - vec3<f32>(sin2);
    let a2_pb2 = sqrt(max(temp_1 * temp_1 + 4.0 * k * k * eta * eta, vec3<f32>(0.0)));
    let a = sqrt(max(0.5 * (a2_pb2 + temp_1), vec3<f32>(0.0)));
    let term_1 = a2_pb2 + vec3<f32>(cos2);
    let term_2 = 2.0 * cos_i * a;
    let r_s = (term_1 - term_2) / (term_1 + term_2);
    let term_3 = a2_pb2 * cos2 + vec3<f32>(sin4);
    let term_4 = term_2 * sin2;
    let r_p = r_s * (term_3 - term_4) / (term_3 + term_4);
    return 0.5 * (r_s + r_p);
}

// --- Microfacet distributions (distribution.rs), anisotropic: alpha_u
// along the shading frame's s axis (dp/du), alpha_v along t.

struct Microfacet {
    alpha_u: f32,
    alpha_v: f32,
    ggx: bool,
}

// The material's distribution: word 2's w is alpha_v / alpha_u, negated for
// Beckmann's (flatten.rs's `roughness`).
fn microfacet() -> Microfacet {
    let word = material_word(2u).w;
    return Microfacet(mat_alpha, mat_alpha * abs(word), word > 0.0);
}

// D(m), zero below the horizon.
fn microfacet_d(md: Microfacet, m: vec3<f32>) -> f32 {
    let cos2 = m.z * m.z;
    let sx = m.x / md.alpha_u;
    let sy = m.y / md.alpha_v;
    let s2 = sx * sx + sy * sy;
    let a2 = md.alpha_u * md.alpha_v;
    var d: f32;
    if (md.ggx) {
        let t = s2 + cos2;
        d = 1.0 / (PI * a2 * t * t);
    } else {
        d = exp(-s2 / cos2) / (PI * a2 * cos2 * cos2);
    }
    if (d * m.z > 1e-20 && !not_finite(d)) {
        return d;
    }
    return 0.0;
}

// Smith's G1(v, m) with the sidedness check.
fn smith_g1(md: Microfacet, v: vec3<f32>, m: vec3<f32>) -> f32 {
    if (dot(v, m) * v.z <= 0.0) {
        return 0.0;
    }
    let xu = md.alpha_u * v.x;
    let yv = md.alpha_v * v.y;
    let xy = xu * xu + yv * yv;
    if (xy == 0.0) {
        return 1.0;
    }
    let tan2 = xy / (v.z * v.z);
    if (md.ggx) {
        return 2.0 / (1.0 + sqrt(1.0 + tan2));
    }
    let a = 1.0 / sqrt(tan2);
    if (a >= 1.6) {
        return 1.0;
    }
    let a2 = a * a;
    return (3.535 * a + 2.181 * a2) / (1.0 + 2.276 * a + 2.577 * a2);
}

// --- Beckmann's visible slopes (bsdf/beckmann_slopes.rs, in f32 as
// Mitsuba's GPU variants sample them): the x slope inverts
// F(x) = 1 + x + tan(theta_i) exp(-erfinv(x)^2) / sqrt(pi) in the erf
// domain, from the CPU's table of guesses (`P.beckmann_table`) and one
// Halley step; the y slope is Gaussian.

const INV_SQRT_PI: f32 = 0.5641895835;
const HALF_SQRT_PI: f32 = 0.8862269255;
const BECKMANN_ROWS: u32 = 32u;
const BECKMANN_COLS: u32 = 64u;

// erf(x) and exp(-x^2) (Abramowitz and Stegun 7.1.26).
fn erf_and_gauss(x: f32) -> vec2<f32> {
    let gauss = exp(-x * x);
    let t = 1.0 / (1.0 + 0.3275911 * abs(x));
    let poly = t * (0.254829592 + t * (-0.284496736 + t * (1.421413741 + t * (-1.453152027 + t * 1.061405429))));
    let y = 1.0 - poly * gauss;
    return vec2<f32>(select(y, -y, x < 0.0), gauss);
}

// Giles' single-precision erfinv, the argument kept inside (-1, 1).
fn erfinv(x_in: f32) -> f32 {
    let x = clamp(x_in, -0.99999994, 0.99999994);
    var w = -log((1.0 - x) * (1.0 + x));
    var p: f32;
    if (w < 5.0) {
        w -= 2.5;
        p = 2.81022636e-08;
        p = 3.43273939e-07 + p * w;
        p = -3.5233877e-06 + p * w;
        p = -4.39150654e-06 + p * w;
        p = 0.00021858087 + p * w;
        p = -0.00125372503 + p * w;
        p = -0.00417768164 + p * w;
        p = 0.246640727 + p * w;
        p = 1.50140941 + p * w;
    } else {
        w = sqrt(w) - 3.0;
        p = -0.000200214257;
        p = 0.000100950558 + p * w;
        p = 0.00134934322 + p * w;
        p = -0.00367342844 + p * w;
        p = 0.00573950773 + p * w;
        p = -0.0076224613 + p * w;
        p = 0.00943887047 + p * w;
        p = 1.00167406 + p * w;
        p = 2.83297682 + p * w;
    }
    return p * x;
}

fn beckmann_guess_entry(i: u32, j: u32) -> f32 {
    return shape_scalar(4u * P.beckmann_table + i * BECKMANN_COLS + j);
}

// The table's bilinear guess of (x + 1) / (max_x + 1).
fn beckmann_guess(sin_i: f32, w: f32) -> f32 {
    let fr = sin_i * f32(BECKMANN_ROWS - 1u);
    let fc = w * f32(BECKMANN_COLS - 1u);
    let i = min(u32(fr), BECKMANN_ROWS - 2u);
    let j = min(u32(fc), BECKMANN_COLS - 2u);
    let a = fr - f32(i);
    let b = fc - f32(j);
    let top = mix(beckmann_guess_entry(i, j), beckmann_guess_entry(i, j + 1u), b);
    let bottom = mix(beckmann_guess_entry(i + 1u, j), beckmann_guess_entry(i + 1u, j + 1u), b);
    return mix(top, bottom, a);
}

// Slopes of the visible normals of the alpha = 1 Beckmann distribution
// seen from elevation `cos_theta_i` (azimuth 0).
fn beckmann_visible_slopes(cos_theta_i: f32, u: vec2<f32>) -> vec2<f32> {
    let cos_i = clamp(cos_theta_i, 1e-6, 1.0);
    let sin_i = sqrt(max(1.0 - cos_i * cos_i, 0.0));
    let tan_i = sin_i / cos_i;
    // cot theta_i, kept finite (WGSL promises no infinities).
    let eg = erf_and_gauss(cos_i / max(sin_i, 1e-7));
    let max_x = eg.x;
    let ux = clamp(u.x, 1e-6, 1.0 - 1e-6);
    let uy = clamp(u.y, 1e-6, 1.0 - 1e-6);
    let target_f = ux * (1.0 + max_x + INV_SQRT_PI * tan_i * eg.y);
    let t = beckmann_guess(sin_i, 1.0 - sqrt(1.0 - ux));
    var x = clamp(t * (1.0 + max_x) - 1.0, -1.0, max_x);
    // One Halley step on F(x) - target.
    let slope = erfinv(x);
    let gauss = exp(-slope * slope);
    let f = 1.0 + x + INV_SQRT_PI * tan_i * gauss - target_f;
    let d1 = 1.0 - slope * tan_i;
    let d2 = -tan_i * HALF_SQRT_PI / max(gauss, 1e-30);
    let denominator = 2.0 * d1 * d1 - f * d2;
    if (denominator > 0.0) {
        x = clamp(x - 2.0 * f * d1 / denominator, -1.0, max_x);
    }
    return vec2<f32>(erfinv(x), erfinv(2.0 * uy - 1.0));
}

// GGX's visible slopes for alpha = 1 seen from elevation `cos_theta_i`
// (azimuth 0; distribution.rs's `sample_visible_11`).
fn ggx_visible_slopes(cos_theta_i: f32, u: vec2<f32>) -> vec2<f32> {
    var p = square_to_uniform_disk(u);
    let s = 0.5 * (1.0 + cos_theta_i);
    let h = sqrt(max(1.0 - p.x * p.x, 0.0));
    p.y = h * (1.0 - s) + p.y * s;
    let z = sqrt(max(1.0 - dot(p, p), 0.0));
    let sin_i = sqrt(max(1.0 - cos_theta_i * cos_theta_i, 0.0));
    let norm = 1.0 / (sin_i * p.y + cos_theta_i * z);
    return vec2<f32>((cos_theta_i * p.y - sin_i * z) * norm, p.x * norm);
}

// A visible microfacet normal seen from `wi` (upper hemisphere):
// distribution.rs's `sample_visible_normal`, stretched to alpha = 1,
// slopes drawn, rotated back and unstretched.
fn sample_microfacet(md: Microfacet, wi: vec3<f32>, u: vec2<f32>) -> vec3<f32> {
    let wi_p = normalize(vec3<f32>(md.alpha_u * wi.x, md.alpha_v * wi.y, wi.z));
    let r = sqrt(wi_p.x * wi_p.x + wi_p.y * wi_p.y);
    var sin_phi = 0.0;
    var cos_phi = 1.0;
    if (r > 1e-7) {
        sin_phi = clamp(wi_p.y / r, -1.0, 1.0);
        cos_phi = clamp(wi_p.x / r, -1.0, 1.0);
    }
    var s11: vec2<f32>;
    if (md.ggx) {
        s11 = ggx_visible_slopes(wi_p.z, u);
    } else {
        s11 = beckmann_visible_slopes(wi_p.z, u);
    }
    let sx = (cos_phi * s11.x - sin_phi * s11.y) * md.alpha_u;
    let sy = (sin_phi * s11.x + cos_phi * s11.y) * md.alpha_v;
    return normalize(vec3<f32>(-sx, -sy, 1.0));
}

// Solid-angle density over `m` of sample_microfacet seen from `wi` (upper
// hemisphere).
fn microfacet_normal_pdf(md: Microfacet, wi: vec3<f32>, m: vec3<f32>) -> f32 {
    return microfacet_d(md, m) * smith_g1(md, wi, m) * abs(dot(wi, m)) / wi.z;
}

// Solid-angle density over `wo` of reflecting `wi` about a normal from
// sample_microfacet.
fn microfacet_reflection_pdf(md: Microfacet, wi: vec3<f32>, wo: vec3<f32>) -> f32 {
    let m = normalize(wi + wo);
    if (dot(wi, m) <= 0.0 || dot(wo, m) <= 0.0) {
        return 0.0;
    }
    return microfacet_normal_pdf(md, wi, m) / (4.0 * dot(wo, m));
}

// --- The rough dielectric (rough_dielectric.rs): reflection and
// refraction through microfacets, from either side.

// The microfacet normal between `wi` and `wo` (on wi's side of the
// surface), whether it is a reflection, and the relative IOR across from
// wi's side; m.z = 2 when there is none.
struct HalfVector {
    m: vec3<f32>,
    reflect: bool,
    eta: f32,
}

fn half_vector(wi: vec3<f32>, wo: vec3<f32>, eta_in: f32) -> HalfVector {
    let none = HalfVector(vec3<f32>(0.0, 0.0, 2.0), false, 1.0);
    if (wi.z == 0.0) {
        return none;
    }
    let reflect = wi.z * wo.z > 0.0;
    let eta = select(1.0 / eta_in, eta_in, wi.z > 0.0);
    let m = normalize(wi + wo * select(eta, 1.0, reflect));
    if (not_finite(m.x + m.y + m.z)) {
        return none;
    }
    return HalfVector(select(-m, m, m.z >= 0.0), reflect, eta);
}

// wi refracted through the microfacet `m` (dim = wi . m, fr what
// fresnel_dielectric(dim, eta) returned): rough_dielectric.rs's
// `refract_about`.
fn refract_about(wi: vec3<f32>, m: vec3<f32>, dim: f32, fr: vec3<f32>) -> vec3<f32> {
    let inv = 1.0 / fr.z;
    let ct = select(fr.y, -fr.y, dim >= 0.0);
    return normalize(m * (dim * inv + ct) - wi * inv);
}

fn rough_dielectric_eval(wi: vec3<f32>, wo: vec3<f32>) -> vec3<f32> {
    let eta_ext = material_word(2u).x;
    let h = half_vector(wi, wo, eta_ext);
    if (h.m.z > 1.0 || wo.z == 0.0) {
        return vec3<f32>(0.0);
    }
    let md = microfacet();
    let dg = microfacet_d(md, h.m) * smith_g1(md, wi, h.m) * smith_g1(md, wo, h.m);
    if (dg == 0.0) {
        return vec3<f32>(0.0);
    }
    let dim = dot(wi, h.m);
    let dom = dot(wo, h.m);
    let f = fresnel_dielectric(dim, eta_ext).x;
    let cos_i = abs(wi.z);
    let cos_o = abs(wo.z);
    if (h.reflect) {
        return mat_a * (f * dg / (4.0 * cos_i * cos_o));
    }
    let denom = dim + h.eta * dom;
    let value = abs((1.0 - f) * dg * dim * dom / (cos_i * denom * denom));
    return mat_b * (value / cos_o);
}

fn rough_dielectric_pdf(wi: vec3<f32>, wo: vec3<f32>) -> f32 {
    let eta_ext = material_word(2u).x;
    let h = half_vector(wi, wo, eta_ext);
    if (h.m.z > 1.0) {
        return 0.0;
    }
    let dim = dot(wi, h.m);
    let dom = dot(wo, h.m);
    if (dim * wi.z <= 0.0 || dom * wo.z <= 0.0) {
        return 0.0;
    }
    var dwh_dwo: f32;
    if (h.reflect) {
        dwh_dwo = 1.0 / (4.0 * dom);
    } else {
        let denom = dim + h.eta * dom;
        dwh_dwo = h.eta * h.eta * dom / (denom * denom);
    }
    let f = fresnel_dielectric(dim, eta_ext).x;
    let lobe = select(1.0 - f, f, h.reflect);
    return abs(microfacet_normal_pdf(microfacet(), select(-wi, wi, wi.z >= 0.0), h.m) * lobe * dwh_dwo);
}

fn rough_dielectric_sample(wi: vec3<f32>, u: vec2<f32>, u_lobe: f32) -> BsdfSample {
    if (wi.z == 0.0) {
        return no_sample();
    }
    let up = select(-wi, wi, wi.z >= 0.0);
    let m = sample_microfacet(microfacet(), up, u);
    // A normal facing away from wi (only rounding draws one) is not one
    // the pdf counts: the direction it would give may also come from a
    // facing normal, and counting it would add light.
    if (not_finite(m.x + m.y + m.z) || dot(up, m) <= 0.0) {
        return no_sample();
    }
    let dim = dot(wi, m);
    let fr = fresnel_dielectric(dim, material_word(2u).x);
    let reflection = u_lobe <= fr.x;
    var wo: vec3<f32>;
    var eta = 1.0;
    if (reflection) {
        wo = reflect_about(wi, m);
    } else {
        wo = refract_about(wi, m, dim, fr);
        eta = fr.z;
    }
    if ((wo.z * wi.z > 0.0) != reflection || wo.z == 0.0 || not_finite(wo.x + wo.y + wo.z)) {
        return no_sample();
    }
    return direction_only(wo, eta);
}

// --- Plastics.

fn prob_specular(f: f32, weight: f32) -> f32 {
    let ps = f * weight;
    let pd = (1.0 - f) * (1.0 - weight);
    return ps / (ps + pd);
}

// The rough plastic's coating transmittance at `cos` (rough_plastic.rs's
// 64-entry table, linear between entries).
fn coating_transmittance(cos: f32) -> f32 {
    let base = 4u * bitcast<u32>(material_word(2u).z);
    let x = cos * 63.0;
    let i = min(u32(max(x, 0.0)), 62u);
    let t = x - f32(i);
    return shape_scalar(base + i) * (1.0 - t) + shape_scalar(base + i + 1u) * t;
}

// Probability of the rough plastic's glossy lobe seen from `wi`.
fn rough_plastic_glossy_prob(wi: vec3<f32>) -> f32 {
    let t = coating_transmittance(wi.z);
    return prob_specular(1.0 - t, material_word(2u).y);
}

// --- The BSDF interface the path tracer calls.

// Whether wi and wo both lie on the side a one-sided BSDF reflects on.
fn both_in_front(wi: vec3<f32>, wo: vec3<f32>) -> bool {
    return wi.z > 0.0 && wo.z > 0.0;
}

// The current layer's f(wi, wo), of its non-specular part.
fn layer_eval(wi: vec3<f32>, wo: vec3<f32>) -> vec3<f32> {
    let kind = material_kind();
    if (kind >= MAT_MIRROR) {
        return vec3<f32>(0.0);
    }
    if (kind == MAT_ROUGH_DIELECTRIC) {
        return rough_dielectric_eval(wi, wo);
    }
    if (DISNEY) {
        if (kind == MAT_PRINCIPLED) {
            return principled_eval(wi, wo);
        }
        if (kind == MAT_PRINCIPLED_THIN) {
            return principled_thin_eval(wi, wo);
        }
    }
    if (!both_in_front(wi, wo)) {
        return vec3<f32>(0.0);
    }
    let a = mat_a;
    if (kind == MAT_DIFFUSE) {
        return a * INV_PI;
    }
    let b = mat_b;
    let c = material_word(2u);
    if (kind == MAT_PLASTIC) {
        let eta = c.x;
        let f_i = fresnel_dielectric(wi.z, eta).x;
        let f_o = fresnel_dielectric(wo.z, eta).x;
        return a * (INV_PI / (eta * eta) * (1.0 - f_i) * (1.0 - f_o));
    }
    let md = microfacet();
    let h = normalize(wi + wo);
    if (kind == MAT_MICROFACET) {
        // bsdf/microfacet.rs: kd / pi plus ks D F G / (4 cos_i cos_o).
        let f = fresnel_dielectric(dot(h, wi), c.x).x;
        let g = smith_g1(md, wi, h) * smith_g1(md, wo, h);
        return a * INV_PI + vec3<f32>(b.x * microfacet_d(md, h) * f * g / (4.0 * wi.z * wo.z));
    }
    let dg = microfacet_d(md, h) * smith_g1(md, wi, h) * smith_g1(md, wo, h) / (4.0 * wi.z * wo.z);
    if (kind == MAT_ROUGH_CONDUCTOR) {
        return a * fresnel_conductor(dot(wi, h), b, mat_c) * dg;
    }
    if (kind == MAT_SCHLICK_CONDUCTOR) {
        // schlick_conductor.rs: Schlick's Fresnel with r0 = A.
        let w = schlick_weight(dot(h, wi));
        return (a + (vec3<f32>(1.0) - a) * w) * dg;
    }
    if (kind == MAT_ROUGH_SUBSTRATE) {
        // rough_substrate.rs: a dielectric coating over Ashikhmin-Shirley's
        // diffuse base (kd in A, its constant factor in B.x).
        let f = fresnel_dielectric(dot(h, wi), c.x).x;
        let base = b.x * (1.0 - schlick_weight(0.5 * wi.z)) * (1.0 - schlick_weight(0.5 * wo.z));
        return vec3<f32>(dg * f) + a * base;
    }
    if (kind == MAT_POLARIZED_PLASTIC) {
        // polarized_plastic.rs: no internal reflections, no tables.
        let eta = c.x;
        let f = fresnel_dielectric(dot(wi, h), eta).x;
        let f_i = fresnel_dielectric(wi.z, eta).x;
        let f_o = fresnel_dielectric(wo.z, eta).x;
        return b * (dg * f) + a * ((1.0 - f_i) * (1.0 - f_o) * INV_PI);
    }
    // Rough plastic.
    let eta = c.x;
    let f = fresnel_dielectric(dot(wi, h), eta).x;
    let t = coating_transmittance(wi.z) * coating_transmittance(wo.z);
    return b * (dg * f) + a * (INV_PI / (eta * eta) * t);
}

// The probability of the glossy lobe of the Nori models, whose normals are
// drawn from D cos: ks (microfacet.rs), 1 (schlick_conductor.rs) or the
// coating's Fresnel reflectance at `wi` (rough_substrate.rs).
fn nori_glossy_prob(kind: u32, wi: vec3<f32>) -> f32 {
    if (kind == MAT_MICROFACET) {
        return material_word(1u).x;
    }
    if (kind == MAT_ROUGH_SUBSTRATE) {
        return fresnel_dielectric(wi.z, material_word(2u).x).x;
    }
    return 1.0;
}

// Solid-angle density of layer_sample's non-specular part.
fn layer_pdf(wi: vec3<f32>, wo: vec3<f32>) -> f32 {
    let kind = material_kind();
    if (kind >= MAT_MIRROR) {
        return 0.0;
    }
    if (kind == MAT_ROUGH_DIELECTRIC) {
        return rough_dielectric_pdf(wi, wo);
    }
    if (DISNEY) {
        if (kind == MAT_PRINCIPLED) {
            return principled_pdf(wi, wo);
        }
        if (kind == MAT_PRINCIPLED_THIN) {
            return principled_thin_pdf(wi, wo);
        }
    }
    if (!both_in_front(wi, wo)) {
        return 0.0;
    }
    if (kind == MAT_DIFFUSE) {
        return wo.z * INV_PI;
    }
    if (kind == MAT_PLASTIC) {
        let c = material_word(2u);
        let f_i = fresnel_dielectric(wi.z, c.x).x;
        return (1.0 - prob_specular(f_i, c.y)) * wo.z * INV_PI;
    }
    // Nori's: normals drawn from D cos.
    if (kind == MAT_MICROFACET || kind == MAT_SCHLICK_CONDUCTOR || kind == MAT_ROUGH_SUBSTRATE) {
        let h = normalize(wi + wo);
        let spec = microfacet_d(microfacet(), h) * h.z / (4.0 * abs(dot(h, wo)));
        let p = nori_glossy_prob(kind, wi);
        return p * spec + (1.0 - p) * wo.z * INV_PI;
    }
    let glossy = microfacet_reflection_pdf(microfacet(), wi, wo);
    if (kind == MAT_ROUGH_CONDUCTOR) {
        return glossy;
    }
    if (kind == MAT_POLARIZED_PLASTIC) {
        let p = material_word(2u).y;
        return p * glossy + (1.0 - p) * wo.z * INV_PI;
    }
    let p = rough_plastic_glossy_prob(wi);
    return p * glossy + (1.0 - p) * wo.z * INV_PI;
}

// A non-delta lobe's direction seen from `wi` (upper hemisphere):
// reflected about a microfacet normal if `glossy`, else
// cosine-distributed (diffuse lobes).
fn lobe_direction(wi: vec3<f32>, u: vec2<f32>, glossy: bool) -> BsdfSample {
    var wo: vec3<f32>;
    if (glossy) {
        wo = reflect_about(wi, sample_microfacet(microfacet(), wi, u));
    } else {
        wo = square_to_cosine_hemisphere(u);
    }
    if (wo.z <= 0.0 || not_finite(wo.x + wo.y + wo.z)) {
        return no_sample();
    }
    return direction_only(wo, 1.0);
}

// A sample of the current layer: delta lobes weighed, other lobes'
// directions only (`direction_only`).
fn layer_sample(wi: vec3<f32>, u: vec2<f32>, u_lobe: f32) -> BsdfSample {
    let kind = material_kind();
    let a = mat_a;
    if (kind == MAT_ROUGH_DIELECTRIC) {
        return rough_dielectric_sample(wi, u, u_lobe);
    }
    if (DISNEY) {
        if (kind == MAT_PRINCIPLED) {
            return principled_sample(wi, u, u_lobe);
        }
        if (kind == MAT_PRINCIPLED_THIN) {
            return principled_thin_sample(wi, u, u_lobe);
        }
    }
    if (kind == MAT_DIELECTRIC) {
        let eta = material_word(1u).x;
        let f = fresnel_dielectric(wi.z, eta);
        if (u_lobe < f.x) {
            return BsdfSample(vec3<f32>(-wi.x, -wi.y, wi.z), vec3<f32>(1.0), f.x, true, 1.0, true);
        }
        let eta_ti = f.z;
        let wo = vec3<f32>(-wi.x / eta_ti, -wi.y / eta_ti, select(f.y, -f.y, wi.z >= 0.0));
        let scale = 1.0 / (eta_ti * eta_ti);
        return BsdfSample(normalize(wo), vec3<f32>(scale), 1.0 - f.x, true, eta_ti, true);
    }
    if (kind == MAT_THIN_DIELECTRIC) {
        // thin_dielectric.rs: the faces' reflections summed, 2R / (1 + R);
        // the rest passes straight through.
        let f = fresnel_dielectric(abs(wi.z), material_word(2u).x).x;
        let r = 2.0 * f / (1.0 + f);
        if (u_lobe <= r) {
            return BsdfSample(vec3<f32>(-wi.x, -wi.y, wi.z), a, r, true, 1.0, true);
        }
        sampled_null = true;
        return BsdfSample(-wi, mat_b, 1.0 - r, true, 1.0, true);
    }
    if (kind == MAT_PASS) {
        sampled_null = true;
        return BsdfSample(-wi, a, 1.0, true, 1.0, true);
    }
    // The rest are one-sided.
    if (wi.z <= 0.0) {
        return no_sample();
    }
    if (kind == MAT_DIFFUSE) {
        return lobe_direction(wi, u, false);
    }
    if (kind == MAT_MICROFACET || kind == MAT_SCHLICK_CONDUCTOR || kind == MAT_ROUGH_SUBSTRATE) {
        // Nori's: reflected about a normal drawn from D cos (not the
        // visible normals) with `nori_glossy_prob`, else
        // cosine-distributed.
        if (u_lobe >= nori_glossy_prob(kind, wi)) {
            return lobe_direction(wi, u, false);
        }
        let wo = reflect_about(wi, square_to_beckmann(u, mat_alpha));
        if (wo.z <= 0.0 || not_finite(wo.x + wo.y + wo.z)) {
            return no_sample();
        }
        return direction_only(wo, 1.0);
    }
    if (kind == MAT_POLARIZED_PLASTIC) {
        return lobe_direction(wi, u, u_lobe < material_word(2u).y);
    }
    let mirror = vec3<f32>(-wi.x, -wi.y, wi.z);
    if (kind == MAT_MIRROR) {
        return BsdfSample(mirror, vec3<f32>(1.0), 1.0, true, 1.0, true);
    }
    let b = mat_b;
    let c = material_word(2u);
    if (kind == MAT_CONDUCTOR) {
        return BsdfSample(mirror, a * fresnel_conductor(wi.z, b, mat_c), 1.0, true, 1.0, true);
    }
    if (kind == MAT_PLASTIC) {
        let eta = c.x;
        let f_i = fresnel_dielectric(wi.z, eta).x;
        let p_spec = prob_specular(f_i, c.y);
        if (u_lobe < p_spec) {
            return BsdfSample(mirror, b * (f_i / p_spec), p_spec, true, 1.0, true);
        }
        return lobe_direction(wi, u, false);
    }
    if (kind == MAT_ROUGH_CONDUCTOR) {
        return lobe_direction(wi, u, true);
    }
    // Rough plastic.
    return lobe_direction(wi, u, u_lobe < rough_plastic_glossy_prob(wi));
}

// --- The material as the front sees it: one BSDF, or a blend of two
// (bsdf/blend.rs): values and densities mixed by the weight; a sample
// from one BSDF, chosen by `u_lobe`, with the mixture's value and density
// unless it is a delta (which keeps its own weight, its density scaled by
// the choice).

// f(wi, wo) of the non-specular part (of the front of a two-sided
// material), and its solid-angle density under front_sample.
fn front_eval_pdf(wi: vec3<f32>, wo: vec3<f32>) -> vec4<f32> {
    if (!BLENDS) {
        return vec4<f32>(layer_eval(wi, wo), layer_pdf(wi, wo));
    }
    var fp = vec4<f32>(0.0);
    for (var l = 0u; l < mat_layers; l++) {
        if (mat_layers == 2u) {
            use_layer(l);
        }
        fp += vec4<f32>(layer_eval(wi, wo), layer_pdf(wi, wo)) * layer_share(l);
    }
    return fp;
}

fn front_sample(wi: vec3<f32>, u: vec2<f32>, u_lobe: f32) -> BsdfSample {
    // A blend's first BSDF where u_lobe >= w, else its second, u_lobe
    // rescaled (and kept below 1, as blend.rs does).
    var l = 0u;
    var u_layer = u_lobe;
    if (BLENDS && mat_layers == 2u) {
        let w = mat_blend_w;
        u_layer = (u_lobe - w) / (1.0 - w);
        if (u_lobe < w) {
            l = 1u;
            u_layer = u_lobe / w;
        }
        u_layer = min(u_layer, 0.99999988);
        use_layer(l);
    }
    var s = layer_sample(wi, u, u_layer);
    if (!s.ok) {
        return s;
    }
    if (s.specular) {
        s.pdf *= layer_share(l);
        return s;
    }
    let fp = front_eval_pdf(wi, s.wo);
    if (!(fp.w > 0.0)) {
        return no_sample();
    }
    s.weight = fp.xyz * (abs(s.wo.z) / fp.w);
    s.pdf = fp.w;
    return s;
}

// --- Two-sided materials (two_sided.rs): the front seen from either side,
// directions mirrored through the surface when seen from the back.

// Set in the kind word of a `twosided` material (its front and back the
// same BSDF, which does not transmit).
const MAT_TWO_SIDED: u32 = 0x1000u;

// (1, 1, -1) where the point is seen from the back of a two-sided
// material, else (1, 1, 1).
fn side_flip(wi: vec3<f32>) -> vec3<f32> {
    let two_sided = (mat_flags & MAT_TWO_SIDED) != 0u;
    return vec3<f32>(1.0, 1.0, select(1.0, -1.0, two_sided && wi.z < 0.0));
}

// A mask (mask.rs) scales its nested BSDF's value and density by the
// opacity, and samples it with that probability, else passes straight
// through (a delta lobe of weight 1).

// --- Normal and bump maps (tilted.rs): the BSDF seen in a frame tilted to
// the map's normal, whose s axis is the shading frame's x (normal maps) or
// dp/du (bump maps) made orthogonal to it (the shading frame's x is dp/du,
// as on the CPU); a bump map's normal is that of the surface displaced
// along the shading normal by the height (bump_map.rs); a normal facing away
// from `wi` is mirrored through the shading normal (flip), directions on
// opposite sides of the two frames carry nothing, and Estevez et al.'s
// term softens the terminator (shadow). Outside a two-sided material's
// mirroring, or inside it (twosided(normalmap(...))).

const TILT_FLIP: u32 = 1u;
const TILT_SHADOW: u32 = 2u;
const TILT_INSIDE_TWO_SIDED: u32 = 4u;
const TILT_ON: u32 = 8u;
const TILT_BUMP: u32 = 16u;

// The tilted frame of the hit, in its shading frame (`set_tilt`).
var<private> mat_tilt: Frame;

// tan^2 theta of a local direction.
fn tan2_theta(v: vec3<f32>) -> f32 {
    let c2 = v.z * v.z;
    return max(1.0 - c2, 0.0) / c2;
}

// Estevez et al. 2019's shadowing term for the tilted normal, seen from
// `wo` (untilted frame).
fn shadow_terminator(n: vec3<f32>, wo: vec3<f32>) -> f32 {
    let alpha2 = min(0.125 * tan2_theta(n), 1.0);
    let s = 2.0 / (1.0 + sqrt(1.0 + alpha2 * tan2_theta(wo)));
    return select(s, 0.0, not_finite(s));
}

// After `load_material`, for the hit seen from `wi`, with dp/du, dp/dv
// and the geometric normal (all in the shading frame): the map's tilted
// frame (tilted.rs's `frame`).
fn set_tilt(wi: vec3<f32>, dpdu: vec3<f32>, dpdv: vec3<f32>, ng: vec3<f32>) {
    if (mat_tilt_flags == 0u) {
        return;
    }
    var w = wi;
    if ((mat_tilt_flags & TILT_INSIDE_TWO_SIDED) != 0u) {
        w = wi * side_flip(wi);
    }
    var n = mat_tilt_n;
    var tangent = vec3<f32>(1.0, 0.0, 0.0);
    if ((mat_tilt_flags & TILT_BUMP) != 0u) {
        // bump_map.rs's `normal`: dp/du and dp/dv with the height's slopes
        // as their normal parts, crossed, on the geometric normal's side.
        n = cross(vec3<f32>(dpdu.xy, mat_tilt_n.x), vec3<f32>(dpdv.xy, mat_tilt_n.y));
        if (not_finite(n.x) || not_finite(n.y) || not_finite(n.z)) {
            n = vec3<f32>(0.0);
        } else if (dot(ng, n) < 0.0) {
            n = -n;
        }
        tangent = dpdu;
    }
    if ((mat_tilt_flags & TILT_FLIP) != 0u && w.z * dot(w, n) <= 0.0) {
        n = vec3<f32>(-n.x, -n.y, n.z);
    }
    let rcp = inverseSqrt(dot(n, n));
    if (!(rcp > 0.0) || not_finite(rcp)) {
        mat_tilt = Frame(vec3<f32>(1.0, 0.0, 0.0), vec3<f32>(0.0, 1.0, 0.0), vec3<f32>(0.0, 0.0, 1.0));
        return;
    }
    n *= rcp;
    // tilted.rs's `frame_around`: the tangent, else x, made orthogonal to n.
    let v = tangent - n * dot(n, tangent);
    let rcp_v = inverseSqrt(dot(v, v));
    if (!(rcp_v > 0.0) || not_finite(rcp_v)) {
        tangent = vec3<f32>(1.0, 0.0, 0.0);
    }
    mat_tilt = frame_from_normal_tangent(n, tangent);
}

fn tilt_outside() -> bool {
    return (mat_tilt_flags & (TILT_ON | TILT_INSIDE_TWO_SIDED)) == TILT_ON;
}

fn tilt_inside() -> bool {
    return (mat_tilt_flags & TILT_INSIDE_TWO_SIDED) != 0u;
}

// Whether `wo` stays on its side in the tilted frame.
fn tilt_keeps_side(wo: vec3<f32>) -> bool {
    return wo.z * to_local(mat_tilt, wo).z > 0.0;
}

// The tilt's factor on a value: the shadowing term times the cosine in
// the tilted frame over the untilted one.
fn tilt_scale(wo: vec3<f32>) -> f32 {
    var shadow = 1.0;
    if ((mat_tilt_flags & TILT_SHADOW) != 0u) {
        shadow = shadow_terminator(mat_tilt.n, wo);
    }
    return shadow * abs(to_local(mat_tilt, wo).z) / abs(wo.z);
}

// A sample of the BSDF in the tilted frame, back in the untilted one.
fn untilt(s_in: BsdfSample) -> BsdfSample {
    var s = s_in;
    let pwo = s.wo;
    s.wo = to_world(mat_tilt, pwo);
    if (s.wo.z * pwo.z <= 0.0) {
        return no_sample();
    }
    if ((mat_tilt_flags & TILT_SHADOW) != 0u) {
        s.weight *= shadow_terminator(mat_tilt.n, s.wo);
    }
    return s;
}

// `wi` and `wo` as the front BSDF sees them: tilted by a normal map
// outside the two-sided mirroring, mirrored, tilted inside it; `scale` is
// the tilt's factor on a value, and `kept` false where `wo` changes side
// in the tilted frame (nothing then).
struct FrontDirs {
    wi: vec3<f32>,
    wo: vec3<f32>,
    scale: f32,
    kept: bool,
}

fn front_dirs(wi: vec3<f32>, wo: vec3<f32>) -> FrontDirs {
    var d = FrontDirs(wi, wo, 1.0, true);
    for (var inside = 0u; inside < 2u; inside++) {
        if (inside == 1u) {
            let f = side_flip(d.wi);
            d.wi *= f;
            d.wo *= f;
        }
        let tilted = select(tilt_outside(), tilt_inside(), inside == 1u);
        if (tilted) {
            if (!tilt_keeps_side(d.wo)) {
                d.kept = false;
                return d;
            }
            d.scale *= tilt_scale(d.wo);
            d.wi = to_local(mat_tilt, d.wi);
            d.wo = to_local(mat_tilt, d.wo);
        }
    }
    return d;
}

// f(wi, wo) and its density under bsdf_sample's non-delta lobes.
fn bsdf_eval_pdf(wi: vec3<f32>, wo: vec3<f32>) -> vec4<f32> {
    let d = front_dirs(wi, wo);
    if (!d.kept) {
        return vec4<f32>(0.0);
    }
    let fp = front_eval_pdf(d.wi, d.wo);
    return vec4<f32>(fp.xyz * d.scale, fp.w) * mat_opacity;
}

// bsdf/mod.rs's null_transmission: what passes straight through the
// loaded material along a direction at cosine `cos_i` to its shading
// normal (volpath's shadow rays keep it): a mask's holes, `null`, a
// polarizer, a thin dielectric's transmission; zero for the rest.
fn layer_null_transmission(cos_i: f32) -> vec3<f32> {
    let kind = material_kind();
    if (kind == MAT_PASS) {
        return mat_a;
    }
    if (kind == MAT_THIN_DIELECTRIC) {
        let f = fresnel_dielectric(abs(cos_i), material_word(2u).x).x;
        return mat_b * (1.0 - 2.0 * f / (1.0 + f));
    }
    return vec3<f32>(0.0);
}

fn bsdf_null_transmission(cos_i: f32) -> vec3<f32> {
    var t = vec3<f32>(0.0);
    if (BLENDS && mat_layers == 2u) {
        for (var l = 0u; l < 2u; l++) {
            use_layer(l);
            t += layer_null_transmission(cos_i) * layer_share(l);
        }
        use_layer(0u);
    } else {
        t = layer_null_transmission(cos_i);
    }
    return vec3<f32>(1.0 - mat_opacity) + t * mat_opacity;
}

// Whether bsdf_sample's last sample was a null lobe (BsdfSample::null on
// the CPU: straight on as if the surface were not there; volpath does
// not count it as a bounce).
var<private> sampled_null: bool;

fn bsdf_sample(wi: vec3<f32>, u: vec2<f32>, u_lobe: f32) -> BsdfSample {
    let opacity = mat_opacity;
    sampled_null = false;
    if (u_lobe >= opacity) {
        sampled_null = true;
        return BsdfSample(-wi, vec3<f32>(1.0), 1.0 - opacity, true, 1.0, true);
    }
    var a = wi;
    if (tilt_outside()) {
        a = to_local(mat_tilt, a);
    }
    let f = side_flip(a);
    a *= f;
    if (tilt_inside()) {
        a = to_local(mat_tilt, a);
    }
    // 1 - f32::EPSILON, as mask.rs clamps it.
    let u_nested = min(u_lobe / opacity, 0.99999988);
    var s = front_sample(a, u, u_nested);
    if (!s.ok) {
        return s;
    }
    if (tilt_inside()) {
        s = untilt(s);
        if (!s.ok) {
            return s;
        }
    }
    s.wo *= f;
    if (tilt_outside()) {
        s = untilt(s);
    }
    s.pdf *= opacity;
    return s;
}
