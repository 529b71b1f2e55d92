// Ray queries against the flattened BVH (flatten.rs): nodes two vec4s
// each, primitives three, children of an inner node side by side.

struct Hit {
    t: f32,
    prim: u32,
    b1: f32,
    b2: f32,
}

// Distance at which the ray enters node `i`'s box, or INF if it misses it
// before `tmax`.
fn box_entry(i: u32, o: vec3<f32>, inv_d: vec3<f32>, tmax: f32) -> f32 {
    let lo = (nodes[2u * i].xyz - o) * inv_d;
    let hi = (nodes[2u * i + 1u].xyz - o) * inv_d;
    let t0 = min(lo, hi);
    let t1 = max(lo, hi);
    let enter = max(max(t0.x, t0.y), max(t0.z, 0.0));
    // Rounded outwards, like wide_bvh.rs's slab test.
    let exit = min(min(t1.x, t1.y), min(t1.z, tmax)) * 1.0000004;
    return select(INF, enter, enter <= exit);
}

fn safe_inverse(d: vec3<f32>) -> vec3<f32> {
    let tiny = abs(d) < vec3<f32>(1e-30);
    return select(1.0 / d, select(vec3<f32>(1e30), vec3<f32>(-1e30), d < vec3<f32>(0.0)), tiny);
}

// The ray (origin, direction) in the space of an unevenly scaled
// instance's group, by the world-to-group rows at vertex-data slot
// `placement` (flatten.rs), or as it is for NONE.
fn placed_ray(placement: u32, o: vec3<f32>, d: vec3<f32>) -> array<vec3<f32>, 2> {
    if (placement == NONE) {
        return array<vec3<f32>, 2>(o, d);
    }
    let k = SLOT_WORDS * placement;
    let m0 = normals[k];
    let m1 = normals[k + 1u];
    let m2 = normals[k + 2u];
    let lo = vec3<f32>(dot(m0.xyz, o) + m0.w, dot(m1.xyz, o) + m1.w, dot(m2.xyz, o) + m2.w);
    let ld = vec3<f32>(dot(m0.xyz, d), dot(m1.xyz, d), dot(m2.xyz, d));
    return array<vec3<f32>, 2>(lo, ld);
}

// Whether a primitive's second word marks a disk.
fn is_disk(marker: u32) -> bool {
    return marker == DISK || marker == DISK_FLIPPED;
}

// Whether primitive `i` is hit in (tmin, tmax); the hit's distance and
// barycentrics go to `hit`.
fn intersect_prim(i: u32, o: vec3<f32>, d: vec3<f32>, tmin: f32, tmax: f32, hit: ptr<function, Hit>) -> bool {
    let r0 = prims[3u * i];
    let r1 = prims[3u * i + 1u];
    if (bitcast<u32>(r1.w) == SPHERE) {
        // An ellipsoid's ray in the group's space: the same t.
        let ray = placed_ray(bitcast<u32>(r1.z), o, d);
        let oc = ray[0] - r0.xyz;
        let r = r1.x;
        let a = dot(ray[1], ray[1]);
        let b = dot(oc, ray[1]);
        let c = dot(oc, oc) - r * r;
        let disc = b * b - a * c;
        if (disc < 0.0) {
            return false;
        }
        let q = sqrt(disc);
        var t = (-b - q) / a;
        if (t <= tmin) {
            t = (-b + q) / a;
        }
        if (t <= tmin || t >= tmax) {
            return false;
        }
        *hit = Hit(t, i, 0.0, 0.0);
        return true;
    }
    if (is_disk(bitcast<u32>(r1.w))) {
        // The plane through the centre, then the unit disk in the dual
        // basis's coordinates (geometry/disk.rs).
        let dy = prims[3u * i + 2u].xyz;
        let n = cross(r1.xyz, dy);
        let dn = dot(d, n);
        if (dn == 0.0) {
            return false;
        }
        let t = dot(r0.xyz - o, n) / dn;
        if (t <= tmin || t >= tmax) {
            return false;
        }
        let q = o + t * d - r0.xyz;
        let l = vec2<f32>(dot(q, r1.xyz), dot(q, dy));
        if (dot(l, l) > 1.0) {
            return false;
        }
        *hit = Hit(t, i, l.x, l.y);
        return true;
    }
    // Moeller and Trumbore.
    let a = r0.xyz;
    let e1 = r1.xyz - a;
    let e2 = prims[3u * i + 2u].xyz - a;
    let pv = cross(d, e2);
    let det = dot(e1, pv);
    if (det == 0.0) {
        return false;
    }
    let inv = 1.0 / det;
    let tv = o - a;
    let u = dot(tv, pv) * inv;
    if (u < 0.0 || u > 1.0) {
        return false;
    }
    let qv = cross(tv, e1);
    let v = dot(d, qv) * inv;
    if (v < 0.0 || u + v > 1.0) {
        return false;
    }
    let t = dot(e2, qv) * inv;
    if (t <= tmin || t >= tmax) {
        return false;
    }
    *hit = Hit(t, i, u, v);
    return true;
}

// The child of inner node children `first`, `first + 1` to visit next
// (the nearer one the ray enters), the other pushed if entered too; NONE if
// the ray enters neither before `tmax`.
fn enter_children(
    first: u32,
    o: vec3<f32>,
    inv_d: vec3<f32>,
    tmax: f32,
    stack: ptr<function, array<u32, 64>>,
    sp: ptr<function, u32>,
) -> u32 {
    let tl = box_entry(first, o, inv_d, tmax);
    let tr = box_entry(first + 1u, o, inv_d, tmax);
    if (tl < INF && tr < INF) {
        let near_left = tl <= tr;
        if (*sp < 64u) {
            (*stack)[*sp] = select(first, first + 1u, near_left);
            *sp = *sp + 1u;
        }
        return select(first + 1u, first, near_left);
    }
    if (tl < INF) {
        return first;
    }
    if (tr < INF) {
        return first + 1u;
    }
    return NONE;
}

// Walks the BVH for primitives hit in (tmin, tmax), nearer children
// first: the closest hit into `hit` (true if any), or with `any`, true at
// the first hit found.
fn traverse(o: vec3<f32>, d: vec3<f32>, tmin: f32, tmax_in: f32, any: bool, hit: ptr<function, Hit>) -> bool {
    let inv_d = safe_inverse(d);
    var stack: array<u32, 64>;
    var sp = 0u;
    var node = 0u;
    var tmax = tmax_in;
    var found = false;
    loop {
        let count = bitcast<u32>(nodes[2u * node + 1u].w);
        let first = bitcast<u32>(nodes[2u * node].w);
        var descend = false;
        if (count > 0u) {
            for (var k = first; k < first + count; k++) {
                if (intersect_prim(k, o, d, tmin, tmax, hit)) {
                    if (any) {
                        return true;
                    }
                    tmax = (*hit).t;
                    found = true;
                }
            }
        } else {
            node = enter_children(first, o, inv_d, tmax, &stack, &sp);
            descend = node != NONE;
        }
        if (!descend) {
            if (sp == 0u) {
                break;
            }
            sp--;
            node = stack[sp];
        }
    }
    return found;
}

// The closest hit along the ray in (tmin, tmax), or false.
fn closest_hit(o: vec3<f32>, d: vec3<f32>, tmin: f32, tmax: f32, hit: ptr<function, Hit>) -> bool {
    return traverse(o, d, tmin, tmax, false, hit);
}

// Whether anything blocks the ray in (0, tmax).
fn occluded(o: vec3<f32>, d: vec3<f32>, tmax: f32) -> bool {
    var hit: Hit;
    return traverse(o, d, 0.0, tmax, true, &hit);
}

// What a path needs of the surface it hit.
struct Surface {
    p: vec3<f32>,
    ng: vec3<f32>,
    ns: vec3<f32>,
    shape: u32,
    light: u32,
    // The texture coordinates: disks, spheres with a (u, v) frame and
    // triangles with a vertex-data slot (flatten.rs gives those to every
    // sphere and triangle of a textured or anisotropic shape); zero
    // elsewhere.
    uv: vec2<f32>,
    // dp/du and dp/dv as the CPU's shapes have them (`dpdu_dpdv`): dp/du is
    // where the shading frame's s axis points (anisotropic roughness), and
    // both tilt a bump map's normal: disks, spheres with a (u, v) frame and
    // triangles with a slot; the edges of other triangles.
    dpdu: vec3<f32>,
    dpdv: vec3<f32>,
    // A slotted triangle's index in its mesh and the hit's barycentrics in
    // the mesh's corner order (mesh_attribute textures); NONE elsewhere.
    tri: u32,
    bary: vec2<f32>,
}

// Vec4 words per vertex-data slot (flatten.rs's SLOT_WORDS): three
// normals, then (u0, v0, u1, v1), (u2, v2, index in the mesh as bits, 1
// where corners 1 and 2 were swapped).
const SLOT_WORDS: u32 = 5u;

// A sphere's (u, v) at unit normal `n`, its frame at vertex-data word `k`
// (geometry/sphere.rs's `normal_uv`): Mitsuba's u = atan2(y, x) / 2pi in
// [0, 1), v = acos(z) / pi; ETH's u = 1/2 + atan2(y, x) / 2pi,
// v = 1 - acos(z) / pi.
fn sphere_uv(n: vec3<f32>, k: u32) -> vec2<f32> {
    let ex = normals[k];
    let phi = atan2(dot(n, normals[k + 1u].xyz), dot(n, ex.xyz));
    let theta = acos(clamp(dot(n, normals[k + 2u].xyz), -1.0, 1.0));
    if (ex.w != 0.0) {
        return vec2<f32>(0.5 + phi * (0.5 * INV_PI), 1.0 - theta * INV_PI);
    }
    return vec2<f32>(select(phi, phi + 2.0 * PI, phi < 0.0) * (0.5 * INV_PI), theta * INV_PI);
}

// A disk's (u, v) at object coordinates `l` (geometry/disk.rs): (radius,
// angle from object x towards y in turns, in [0, 1)).
fn disk_uv(l: vec2<f32>) -> vec2<f32> {
    let turns = atan2(l.y, l.x) * (0.5 * INV_PI);
    return vec2<f32>(length(l), select(turns, turns + 1.0, turns < 0.0));
}

fn surface_at(h: Hit, o: vec3<f32>, d: vec3<f32>) -> Surface {
    let r0 = prims[3u * h.prim];
    let r1 = prims[3u * h.prim + 1u];
    let r2 = prims[3u * h.prim + 2u];
    let shape = bitcast<u32>(r0.w);
    let slot = bitcast<u32>(r1.w);
    let light = bitcast<u32>(r2.w);
    if (slot == SPHERE) {
        let placement = bitcast<u32>(r1.z);
        let ray = placed_ray(placement, o, d);
        let n = normalize(ray[0] + h.t * ray[1] - r0.xyz);
        let frame = bitcast<u32>(r1.y);
        var uv = vec2<f32>(0.0);
        // geometry/sphere.rs's `dpdu_dpdv`: dp/du = 2 pi r ((object x cross
        // object y) cross n); dp/dv = pi r (cos(theta) times the horizontal
        // direction of n, minus sin(theta) times the polar axis).
        var up = vec3<f32>(0.0, 0.0, 1.0);
        var axis = up;
        if (frame != NONE) {
            let k = SLOT_WORDS * frame;
            uv = sphere_uv(n, k);
            up = cross(normals[k].xyz, normals[k + 1u].xyz);
            axis = normals[k + 2u].xyz;
        }
        let r = r1.x;
        let cos_theta = dot(n, axis);
        let horizontal = n - axis * cos_theta;
        let sin_theta = length(horizontal);
        var dpdv = vec3<f32>(0.0);
        if (sin_theta > 0.0) {
            dpdv = (horizontal * (cos_theta / sin_theta) - axis * sin_theta) * (PI * r);
        }
        let dpdu = cross(up, n) * (2.0 * PI * r);
        if (placement != NONE) {
            // Back to the world (instance.rs): normals by the inverse
            // transpose (the world-to-group rows transposed), dp/du and
            // dp/dv by the group-to-world map (those rows inverted).
            let k = SLOT_WORDS * placement;
            let m0 = normals[k].xyz;
            let m1 = normals[k + 1u].xyz;
            let m2 = normals[k + 2u].xyz;
            let nw = normalize(m0 * n.x + m1 * n.y + m2 * n.z);
            let c0 = cross(m1, m2);
            let c1 = cross(m2, m0);
            let c2 = cross(m0, m1);
            let inv_det = 1.0 / dot(m0, c0);
            let du = (c0 * dpdu.x + c1 * dpdu.y + c2 * dpdu.z) * inv_det;
            let dv = (c0 * dpdv.x + c1 * dpdv.y + c2 * dpdv.z) * inv_det;
            return Surface(o + h.t * d, nw, nw, shape, light, uv, du, dv, NONE, vec2<f32>(0.0));
        }
        return Surface(r0.xyz + r * n, n, n, shape, light, uv, dpdu, dpdv, NONE, vec2<f32>(0.0));
    }
    if (is_disk(slot)) {
        var n = normalize(cross(r1.xyz, r2.xyz));
        if (slot == DISK_FLIPPED) {
            n = -n;
        }
        // The hit keeps the object coordinates in (b1, b2).
        let l = vec2<f32>(h.b1, h.b2);
        let dp = disk_derivatives(r1.xyz, r2.xyz, l);
        return Surface(o + h.t * d, n, n, shape, light, disk_uv(l), dp[0], dp[1], NONE, vec2<f32>(0.0));
    }
    let b0 = 1.0 - h.b1 - h.b2;
    let p = b0 * r0.xyz + h.b1 * r1.xyz + h.b2 * r2.xyz;
    let ng = normalize(cross(r1.xyz - r0.xyz, r2.xyz - r0.xyz));
    var ns = ng;
    var uv = vec2<f32>(0.0);
    var dp = array<vec3<f32>, 2>(r1.xyz - r0.xyz, r2.xyz - r0.xyz);
    var tri = NONE;
    var bary = vec2<f32>(h.b1, h.b2);
    if (slot != NONE) {
        let k = SLOT_WORDS * slot;
        let n = b0 * normals[k].xyz + h.b1 * normals[k + 1u].xyz + h.b2 * normals[k + 2u].xyz;
        let len = length(n);
        if (len > 0.0) {
            ns = n / len;
        }
        let t01 = normals[k + 3u];
        let w4 = normals[k + 4u];
        let uv2 = w4.xy;
        tri = bitcast<u32>(w4.z);
        if (w4.w != 0.0) {
            bary = bary.yx;
        }
        uv = b0 * t01.xy + h.b1 * t01.zw + h.b2 * uv2;
        dp = triangle_derivatives(r1.xyz - r0.xyz, r2.xyz - r0.xyz, t01.zw - t01.xy, uv2 - t01.xy);
    }
    return Surface(p, ng, ns, shape, light, uv, dp[0], dp[1], tri, bary);
}

// A triangle's dp/du and dp/dv from its edges and their (u, v)
// differences (mesh.rs's `dpdu_dpdv`): zero where the uvs are degenerate.
fn triangle_derivatives(dp0: vec3<f32>, dp1: vec3<f32>, duv0: vec2<f32>, duv1: vec2<f32>) -> array<vec3<f32>, 2> {
    let det = duv0.x * duv1.y - duv0.y * duv1.x;
    if (det == 0.0 || not_finite(det)) {
        return array<vec3<f32>, 2>(vec3<f32>(0.0), vec3<f32>(0.0));
    }
    return array<vec3<f32>, 2>((dp0 * duv1.y - dp1 * duv0.y) / det, (dp1 * duv0.x - dp0 * duv1.x) / det);
}

// A disk's dp/du and dp/dv at object coordinates `l` (disk.rs's
// `derivatives`): the radial direction cos ex + sin ey, and 2 pi r times
// the tangential one, with the frame's axes ex, ey recovered from the dual
// basis (dx, dy) that the record keeps (ex is orthogonal to dy in the
// plane, with ex . dx = 1; ey likewise).
fn disk_derivatives(dx: vec3<f32>, dy: vec3<f32>, l: vec2<f32>) -> array<vec3<f32>, 2> {
    let n = cross(dx, dy);
    let a = cross(dy, n);
    let b = cross(n, dx);
    let ex = a / dot(a, dx);
    let ey = b / dot(b, dy);
    let r = length(l);
    var c = vec2<f32>(1.0, 0.0);
    if (r > 0.0) {
        c = l / r;
    }
    return array<vec3<f32>, 2>(c.x * ex + c.y * ey, (2.0 * PI * r) * (c.x * ey - c.y * ex));
}

// A ray's origin off the surface at `p` on the side `d` leaves to.
fn spawn_origin(p: vec3<f32>, ng: vec3<f32>, d: vec3<f32>) -> vec3<f32> {
    let scale = max(1.0, max(abs(p.x), max(abs(p.y), abs(p.z))));
    let off = ng * (2e-4 * scale);
    return select(p - off, p + off, dot(ng, d) > 0.0);
}
