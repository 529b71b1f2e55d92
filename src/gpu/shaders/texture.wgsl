// Bitmap and checkerboard textures (texture/bitmap.rs, checkerboard.rs).
// Bitmaps: Dr.Jit's conventions (uv (0, 0)
// is the top-left corner of the first row; bilinear filtering between
// texel centres at (i + 1/2) / res; nearest takes the texel containing
// uv), wrapped by repeat, mirror or clamp. A record in `shapes`
// (flatten.rs's texture_record): (to_uv row 0, first texel), (to_uv row 1,
// width), (height, filter, wrap, 0), then the texels (RGB, 0); a
// checkerboard's filter is TEX_CHECKERBOARD and its texels its colours.

const TEX_NEAREST: u32 = 0u;
const TEX_BILINEAR: u32 = 1u;
const TEX_CHECKERBOARD: u32 = 2u;
const WRAP_REPEAT: u32 = 0u;
const WRAP_MIRROR: u32 = 1u;

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
    if (bitcast<u32>(shapes[record + 2u].y) == TEX_CHECKERBOARD) {
        return (c.x + c.y + c.z) / 3.0;
    }
    return dot(c, vec3<f32>(0.212671, 0.715160, 0.072169));
}

// The texture's value at `uv`, for the record at `record`; a
// checkerboard's squares swapped if `swap` (checkerboard.rs's `eval_1`
// swaps them, as Mitsuba 3.9's does).
fn texture_lookup(record: u32, uv: vec2<f32>, swap: bool) -> vec3<f32> {
    let h0 = shapes[record];
    let h1 = shapes[record + 1u];
    let h2 = shapes[record + 2u];
    let st = vec2<f32>(h0.x * uv.x + h0.y * uv.y + h0.z, h1.x * uv.x + h1.y * uv.y + h1.z);
    let first = bitcast<u32>(h0.w);
    let w = i32(bitcast<u32>(h1.w));
    let h = i32(bitcast<u32>(h2.x));
    let filter_type = bitcast<u32>(h2.y);
    let wrap = bitcast<u32>(h2.z);
    if (filter_type == TEX_CHECKERBOARD) {
        // Checkerboard::eval: color0 where both fractions are above a
        // half or neither is.
        let mx = st.x - floor(st.x) > 0.5;
        let my = st.y - floor(st.y) > 0.5;
        return shapes[first + select(1u, 0u, (mx == my) != swap)].xyz;
    }
    if (filter_type == TEX_NEAREST) {
        let x = tex_wrap(i32(floor(tex_bounded(st.x * f32(w)))), w, wrap);
        let y = tex_wrap(i32(floor(tex_bounded(st.y * f32(h)))), h, wrap);
        return tex_texel(first, w, x, y);
    }
    let px = tex_bounded(st.x * f32(w) - 0.5);
    let py = tex_bounded(st.y * f32(h) - 0.5);
    let fx = floor(px);
    let fy = floor(py);
    let ix = i32(fx);
    let iy = i32(fy);
    let x0 = tex_wrap(ix, w, wrap);
    let x1 = tex_wrap(ix + 1, w, wrap);
    let y0 = tex_wrap(iy, h, wrap);
    let y1 = tex_wrap(iy + 1, h, wrap);
    let tx = px - fx;
    let ty = py - fy;
    let top = tex_texel(first, w, x0, y0) * (1.0 - tx) + tex_texel(first, w, x1, y0) * tx;
    let bottom = tex_texel(first, w, x0, y1) * (1.0 - tx) + tex_texel(first, w, x1, y1) * tx;
    return top * (1.0 - ty) + bottom * ty;
}

// The gradient of `texture_value_1` (a bitmap's luminance) with respect to
// the hit's (u, v), as bitmap.rs's `eval_1_grad` (Mitsuba 3.9.1's): the
// bilinear patch's slopes taken through `to_uv` and scaled by the
// resolution; zero for nearest lookups and checkerboards.
fn texture_gradient_1(record: u32, uv: vec2<f32>) -> vec2<f32> {
    let h0 = shapes[record];
    let h1 = shapes[record + 1u];
    let h2 = shapes[record + 2u];
    if (bitcast<u32>(h2.y) != TEX_BILINEAR) {
        return vec2<f32>(0.0);
    }
    let st = vec2<f32>(h0.x * uv.x + h0.y * uv.y + h0.z, h1.x * uv.x + h1.y * uv.y + h1.z);
    let first = bitcast<u32>(h0.w);
    let w = i32(bitcast<u32>(h1.w));
    let h = i32(bitcast<u32>(h2.x));
    let wrap = bitcast<u32>(h2.z);
    let px = tex_bounded(st.x * f32(w) - 0.5);
    let py = tex_bounded(st.y * f32(h) - 0.5);
    let fx = floor(px);
    let fy = floor(py);
    let x0 = tex_wrap(i32(fx), w, wrap);
    let x1 = tex_wrap(i32(fx) + 1, w, wrap);
    let y0 = tex_wrap(i32(fy), h, wrap);
    let y1 = tex_wrap(i32(fy) + 1, h, wrap);
    let tx = px - fx;
    let ty = py - fy;
    let lum = vec3<f32>(0.212671, 0.715160, 0.072169);
    let f00 = dot(tex_texel(first, w, x0, y0), lum);
    let f10 = dot(tex_texel(first, w, x1, y0), lum);
    let f01 = dot(tex_texel(first, w, x0, y1), lum);
    let f11 = dot(tex_texel(first, w, x1, y1), lum);
    let dx = (1.0 - ty) * (f10 - f00) + ty * (f11 - f01);
    let dy = (1.0 - tx) * (f01 - f00) + tx * (f11 - f10);
    return vec2<f32>((h0.x * dx + h1.x * dy) * f32(w), (h0.y * dx + h1.y * dy) * f32(h));
}
