// Bitmap and checkerboard textures (texture/bitmap.rs, checkerboard.rs).
// Bitmaps: Dr.Jit's conventions (uv (0, 0)
// is the top-left corner of the first row; bilinear filtering between
// texel centres at (i + 1/2) / res; nearest takes the texel containing
// uv), wrapped by repeat, mirror or clamp. A record in `shapes`
// (flatten.rs's texture_record): (to_uv row 0, first texel), (to_uv row 1,
// width), (height, filter, wrap, 0), then the texels (RGB, 0); a
// checkerboard's filter is TEX_CHECKERBOARD and its texels its colours; a
// mesh_attribute's is TEX_MESH_ATTRIBUTE, its width the values per
// triangle (3 or 1), its height the triangles.

const TEX_NEAREST: u32 = 0u;
const TEX_BILINEAR: u32 = 1u;
const TEX_CHECKERBOARD: u32 = 2u;
// texture/nori_checker.rs: the wrap word holds its rule.
const TEX_NORI_CHECKER: u32 = 3u;
const TEX_MESH_ATTRIBUTE: u32 = 4u;
const CHECKER_ETH: u32 = 0u;
const CHECKER_ZARAGOZA: u32 = 1u;
const WRAP_REPEAT: u32 = 0u;
const WRAP_MIRROR: u32 = 1u;
// color/mod.rs's luminance weights: a bitmap's `eval_1`.
const LUMINANCE: vec3<f32> = vec3<f32>(0.212671, 0.715160, 0.072169);

// texture/mod.rs's `bounded`: finite values clamped to +-2^30, others 0.
fn tex_bounded(x: f32) -> f32 {
    if (not_finite(x)) {
        return 0.0;
    }
    return clamp(x, -1073741824.0, 1073741824.0);
}

// WrapMode::wrap: the texel index in [0, n) that integer coordinate `i`
// reads.
fn tex_wrap(i: i32, n: i32, mode: u32) -> i32 {
    if (mode == WRAP_REPEAT) {
        return ((i % n) + n) % n;
    }
    if (mode == WRAP_MIRROR) {
        let k = ((i % (2 * n)) + 2 * n) % (2 * n);
        return select(k, 2 * n - 1 - k, k >= n);
    }
    return clamp(i, 0, n - 1);
}

fn tex_texel(first: u32, w: i32, x: i32, y: i32) -> vec3<f32> {
    return shapes[first + u32(y * w + x)].xyz;
}

// Texture::eval_1 (roughness) of the colour `c` that `texture_lookup`
// read with `swap`: a bitmap's luminance; a checkerboard colour's channel
// mean.
fn texture_value_1(record: u32, c: vec3<f32>) -> f32 {
    let kind = bitcast<u32>(shapes[record + 2u].y);
    if (kind == TEX_CHECKERBOARD || kind == TEX_NORI_CHECKER) {
        return (c.x + c.y + c.z) / 3.0;
    }
    return dot(c, LUMINANCE);
}

// NoriChecker::key: ETH's floor(x) mod 2, the Zaragoza fork's trunc(x) % 2
// (-1 on the negative side).
fn nori_checker_key(x: f32, rule: u32) -> i32 {
    let b = tex_bounded(x);
    if (rule == CHECKER_ETH) {
        return ((i32(floor(b)) % 2) + 2) % 2;
    }
    return i32(trunc(b)) % 2;
}

// A record's header (texture_record): where `uv` falls in texel units
// (`to_uv` applied), the first texel, the size, the filter and the wrap,
// and `to_uv`'s linear part (rows 0 and 1: u and v coefficients).
struct TexHeader {
    st: vec2<f32>,
    first: u32,
    w: i32,
    h: i32,
    filter_type: u32,
    wrap: u32,
    to_uv: vec4<f32>,
}

fn tex_header(record: u32, uv: vec2<f32>) -> TexHeader {
    let h0 = shapes[record];
    let h1 = shapes[record + 1u];
    let h2 = shapes[record + 2u];
    let st = vec2<f32>(h0.x * uv.x + h0.y * uv.y + h0.z, h1.x * uv.x + h1.y * uv.y + h1.z);
    return TexHeader(st, bitcast<u32>(h0.w), i32(bitcast<u32>(h1.w)), i32(bitcast<u32>(h2.x)),
        bitcast<u32>(h2.y), bitcast<u32>(h2.z), vec4<f32>(h0.xy, h1.xy));
}

// The four texels a bilinear lookup blends (bitmap.rs's `bilinear_cell`):
// columns x0, x1 and rows y0, y1, wrapped, and the weights of x1 and y1.
struct TexCell {
    x0: i32,
    x1: i32,
    y0: i32,
    y1: i32,
    t: vec2<f32>,
}

fn tex_bilinear_cell(a: TexHeader) -> TexCell {
    let px = tex_bounded(a.st.x * f32(a.w) - 0.5);
    let py = tex_bounded(a.st.y * f32(a.h) - 0.5);
    let fx = floor(px);
    let fy = floor(py);
    let ix = i32(fx);
    let iy = i32(fy);
    return TexCell(
        tex_wrap(ix, a.w, a.wrap),
        tex_wrap(ix + 1, a.w, a.wrap),
        tex_wrap(iy, a.h, a.wrap),
        tex_wrap(iy + 1, a.h, a.wrap),
        vec2<f32>(px - fx, py - fy),
    );
}

// Where a texture is read (texture/mod.rs's SurfacePoint): the uv, and for
// a mesh's triangle its index in the mesh (NONE elsewhere) and the hit's
// barycentrics in the mesh's corner order.
struct TexPoint {
    uv: vec2<f32>,
    tri: u32,
    bary: vec2<f32>,
}

// A point with only a uv (lights).
fn tex_at_uv(uv: vec2<f32>) -> TexPoint {
    return TexPoint(uv, NONE, vec2<f32>(0.0));
}

// The texture's value at `at`, for the record at `record`; a
// checkerboard's squares swapped if `swap` (checkerboard.rs's `eval_1`
// swaps them, as Mitsuba 3.9's does).
fn texture_lookup(record: u32, at: TexPoint, swap: bool) -> vec3<f32> {
    let a = tex_header(record, at.uv);
    if (a.filter_type == TEX_MESH_ATTRIBUTE) {
        // MeshAttributeTexture::eval: 0 off the mesh (or unbound).
        if (at.tri >= u32(a.h)) {
            return vec3<f32>(0.0);
        }
        let k = a.first + at.tri * u32(a.w);
        if (a.w == 1) {
            return shapes[k].xyz;
        }
        return shapes[k].xyz * (1.0 - at.bary.x - at.bary.y) + shapes[k + 1u].xyz * at.bary.x
            + shapes[k + 2u].xyz * at.bary.y;
    }
    if (a.filter_type == TEX_NORI_CHECKER) {
        // NoriChecker::eval: `same` where the squares' keys agree.
        let same = nori_checker_key(a.st.x, a.wrap) == nori_checker_key(a.st.y, a.wrap);
        return shapes[a.first + select(1u, 0u, same)].xyz;
    }
    if (a.filter_type == TEX_CHECKERBOARD) {
        // Checkerboard::eval: color0 where both fractions are above a
        // half or neither is.
        let mx = a.st.x - floor(a.st.x) > 0.5;
        let my = a.st.y - floor(a.st.y) > 0.5;
        return shapes[a.first + select(1u, 0u, (mx == my) != swap)].xyz;
    }
    if (a.filter_type == TEX_NEAREST) {
        let x = tex_wrap(i32(floor(tex_bounded(a.st.x * f32(a.w)))), a.w, a.wrap);
        let y = tex_wrap(i32(floor(tex_bounded(a.st.y * f32(a.h)))), a.h, a.wrap);
        return tex_texel(a.first, a.w, x, y);
    }
    let c = tex_bilinear_cell(a);
    let top = tex_texel(a.first, a.w, c.x0, c.y0) * (1.0 - c.t.x) + tex_texel(a.first, a.w, c.x1, c.y0) * c.t.x;
    let bottom = tex_texel(a.first, a.w, c.x0, c.y1) * (1.0 - c.t.x) + tex_texel(a.first, a.w, c.x1, c.y1) * c.t.x;
    return top * (1.0 - c.t.y) + bottom * c.t.y;
}

// The gradient of `texture_value_1` (a bitmap's luminance) with respect to
// the hit's (u, v), as bitmap.rs's `eval_1_grad` (Mitsuba 3.9.1's): the
// bilinear patch's slopes taken through `to_uv` and scaled by the
// resolution; zero for nearest lookups and checkerboards.
fn texture_gradient_1(record: u32, uv: vec2<f32>) -> vec2<f32> {
    let a = tex_header(record, uv);
    if (a.filter_type != TEX_BILINEAR) {
        return vec2<f32>(0.0);
    }
    let c = tex_bilinear_cell(a);
    let f00 = dot(tex_texel(a.first, a.w, c.x0, c.y0), LUMINANCE);
    let f10 = dot(tex_texel(a.first, a.w, c.x1, c.y0), LUMINANCE);
    let f01 = dot(tex_texel(a.first, a.w, c.x0, c.y1), LUMINANCE);
    let f11 = dot(tex_texel(a.first, a.w, c.x1, c.y1), LUMINANCE);
    let dx = (1.0 - c.t.y) * (f10 - f00) + c.t.y * (f11 - f01);
    let dy = (1.0 - c.t.x) * (f01 - f00) + c.t.x * (f11 - f10);
    let m = a.to_uv;
    return vec2<f32>((m.x * dx + m.z * dy) * f32(a.w), (m.y * dx + m.w * dy) * f32(a.h));
}
