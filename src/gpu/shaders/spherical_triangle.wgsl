// Uniform sampling of the solid angle a triangle subtends
// (sampling/spherical_triangle.rs: Arvo 1995), and which light triangles
// area.rs samples that way. In f32 (WGSL has no f64): the callers use it
// only for solid angles of 0.15 sr and more, whose spherical excess f32
// resolves to about 1e-6 of itself, and sampling and density decide alike.

// spherical_triangle.rs's MIN_SOLID_ANGLE and MAX_SOLID_ANGLE: below,
// area sampling does as well for less; above, the edges lie near great
// circles through the point.
const MIN_SOLID_ANGLE: f32 = 0.15;
const MAX_SOLID_ANGLE: f32 = 6.0;

// Solid angle of the spherical triangle with unit vertices a, b, c (Van
// Oosterom and Strackee).
fn solid_angle(a: vec3<f32>, b: vec3<f32>, c: vec3<f32>) -> f32 {
    let num = abs(dot(a, cross(b, c)));
    let den = 1.0 + dot(a, b) + dot(b, c) + dot(c, a);
    return 2.0 * atan2(num, den);
}

// area.rs's `spherical`: the solid angle triangle (p0, p1, p2) subtends
// from `p` if it is sampled by solid angle from there, else 0.
fn spherical_omega(p0: vec3<f32>, p1: vec3<f32>, p2: vec3<f32>, p: vec3<f32>) -> f32 {
    // Cheap first: a projected area far below the threshold over the
    // cubed centroid distance means area sampling, without trigonometry.
    let to_c = (p0 + p1 + p2) / 3.0 - p;
    let d2 = dot(to_c, to_c);
    let projected = 0.5 * abs(dot(cross(p1 - p0, p2 - p0), to_c));
    if (projected < 0.25 * MIN_SOLID_ANGLE * d2 * sqrt(d2)) {
        return 0.0;
    }
    let omega = solid_angle(normalize(p0 - p), normalize(p1 - p), normalize(p2 - p));
    if (omega >= MIN_SOLID_ANGLE && omega <= MAX_SOLID_ANGLE) {
        return omega;
    }
    return 0.0;
}

// The part of `v` orthogonal to unit `n`, normalised (zero if none).
fn orthonormal(v: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let w = v - n * dot(v, n);
    let l = length(w);
    if (l > 0.0) {
        return w / l;
    }
    return vec3<f32>(0.0);
}

// A direction uniform over the spherical triangle with unit vertices a, b,
// c (density 1 / solid angle); w = 0 for a degenerate triangle.
fn sample_spherical_triangle(a: vec3<f32>, b: vec3<f32>, c: vec3<f32>, u: vec2<f32>) -> vec4<f32> {
    let none = vec4<f32>(0.0);
    let n_ab = orthonormal(cross(a, b), vec3<f32>(0.0));
    let n_bc = orthonormal(cross(b, c), vec3<f32>(0.0));
    let n_ca = orthonormal(cross(c, a), vec3<f32>(0.0));
    if (all(n_ab == vec3<f32>(0.0)) || all(n_bc == vec3<f32>(0.0)) || all(n_ca == vec3<f32>(0.0))) {
        return none;
    }
    // Interior angles from the edges' great-circle normals; the area is
    // their excess over pi.
    let alpha = acos(clamp(-dot(n_ab, n_ca), -1.0, 1.0));
    let beta = acos(clamp(-dot(n_bc, n_ab), -1.0, 1.0));
    let gamma = acos(clamp(-dot(n_ca, n_bc), -1.0, 1.0));
    let area = alpha + beta + gamma - PI;
    if (!(area > 0.0)) {
        return none;
    }
    // The sub-triangle A B C' of area u.x * area fixes C' on the arc AC.
    let area_sub = u.x * area;
    let s = sin(area_sub - alpha);
    let t = cos(area_sub - alpha);
    let sin_alpha = sin(alpha);
    let cos_alpha = cos(alpha);
    let cos_c = dot(a, b);
    let uu = t - cos_alpha;
    let vv = s + sin_alpha * cos_c;
    let den = (vv * s + uu * t) * sin_alpha;
    var q = 1.0;
    if (den != 0.0) {
        q = clamp(((vv * t - uu * s) * cos_alpha - vv) / den, -1.0, 1.0);
    }
    let c_sub = q * a + sqrt(max(0.0, 1.0 - q * q)) * orthonormal(c, a);
    // Then a point on the arc from B to C', uniform in the sub-triangle.
    let z = 1.0 - u.y * (1.0 - dot(c_sub, b));
    let d = z * b + sqrt(max(0.0, 1.0 - z * z)) * orthonormal(c_sub, b);
    let l = length(d);
    if (!(l > 0.0)) {
        return none;
    }
    return vec4<f32>(d / l, 1.0);
}

// Barycentrics (b1, b2) where the ray from `o` along `d` meets the plane
// of triangle (p0, p1, p2), clamped into it (mesh.rs's
// barycentrics_along); w = 0 if it runs parallel or away.
fn barycentrics_along(p0: vec3<f32>, p1: vec3<f32>, p2: vec3<f32>, o: vec3<f32>, d: vec3<f32>) -> vec3<f32> {
    let e1 = p1 - p0;
    let e2 = p2 - p0;
    let pvec = cross(d, e2);
    let det = dot(e1, pvec);
    if (det == 0.0 || not_finite(det)) {
        return vec3<f32>(0.0);
    }
    let tvec = o - p0;
    let qvec = cross(tvec, e1);
    if (dot(e2, qvec) / det <= 0.0) {
        return vec3<f32>(0.0);
    }
    var b1 = clamp(dot(tvec, pvec) / det, 0.0, 1.0);
    var b2 = clamp(dot(d, qvec) / det, 0.0, 1.0);
    let sum = b1 + b2;
    if (sum > 1.0) {
        b1 /= sum;
        b2 /= sum;
    }
    return vec3<f32>(b1, b2, 1.0);
}
