// Reconstruction (image/film.rs): each pixel gathers the filter-weighted
// samples of a pass from the pixels around it, in a fixed order, and adds
// them to the film: (weighted radiance sum, weight sum) per pixel.

@group(0) @binding(0) var<storage, read> P: Params;
@group(0) @binding(1) var<storage, read> filter_table: array<f32>;
@group(0) @binding(2) var<storage, read> samples: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read_write> film: array<vec4<f32>>;

// The filter's 1D weight at offset `x` (a table over [0, radius]).
fn filter_weight(x: f32) -> f32 {
    let ax = abs(x);
    if (ax > P.filter_radius) {
        return 0.0;
    }
    let last = arrayLength(&filter_table) - 1u;
    let f = ax / P.filter_radius * f32(last);
    let i = min(u32(f), last - 1u);
    return mix(filter_table[i], filter_table[i + 1u], f - f32(i));
}

// A sample's position in its pixel (path.wgsl packs it in 16-bit fixed
// point): the middle of its 1/65536 bin, never on the pixel's edge, where
// a box filter would count it in two pixels.
fn unpack_offset(bits: u32) -> vec2<f32> {
    return (vec2<f32>(f32(bits & 0xffffu), f32(bits >> 16u)) + 0.5) / 65536.0;
}

@compute @workgroup_size(8, 8)
fn gather(@builtin(global_invocation_id) gid: vec3<u32>) {
    if (gid.x >= P.width || gid.y >= P.height) {
        return;
    }
    let x = i32(gid.x);
    let y = i32(gid.y);
    let reach = i32(ceil(P.filter_radius));
    let pixels = P.width * P.height;
    var acc = vec4<f32>(0.0);
    for (var qy = max(y - reach, 0); qy <= min(y + reach, i32(P.height) - 1); qy++) {
        for (var qx = max(x - reach, 0); qx <= min(x + reach, i32(P.width) - 1); qx++) {
            let q = u32(qy) * P.width + u32(qx);
            for (var s = 0u; s < P.spp_pass; s++) {
                let rec = samples[s * pixels + q];
                if (not_finite(rec.x) || not_finite(rec.y) || not_finite(rec.z)) {
                    continue;
                }
                let pos = vec2<f32>(f32(qx), f32(qy)) + unpack_offset(bitcast<u32>(rec.w));
                let w = filter_weight(f32(x) - pos.x + 0.5) * filter_weight(f32(y) - pos.y + 0.5);
                if (w != 0.0) {
                    acc += vec4<f32>(rec.xyz * w, w);
                }
            }
        }
    }
    film[u32(y) * P.width + u32(x)] += acc;
}
