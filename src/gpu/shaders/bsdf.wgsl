// The BSDFs the GPU renders (bsdf/diffuse.rs, two_sided.rs, mirror.rs,
// dielectric.rs), in the shading frame (z along the shading normal).
// A shape's record: shapes[3 s] = (reflectance, kind), shapes[3 s + 2].x = eta.

const MAT_DIFFUSE: u32 = 0u;
const MAT_TWO_SIDED_DIFFUSE: u32 = 1u;
const MAT_MIRROR: u32 = 2u;
const MAT_DIELECTRIC: u32 = 3u;

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

fn material_kind(shape: u32) -> u32 {
    return bitcast<u32>(shapes[3u * shape].w);
}

fn is_specular(shape: u32) -> bool {
    return material_kind(shape) >= MAT_MIRROR;
}

// Two-sided diffuse: the back seen as the front.
fn diffuse_side(kind: u32, wi: vec3<f32>, wo: vec3<f32>) -> vec2<f32> {
    if (kind == MAT_TWO_SIDED_DIFFUSE && wi.z < 0.0) {
        return vec2<f32>(-wi.z, -wo.z);
    }
    return vec2<f32>(wi.z, wo.z);
}

fn bsdf_eval(shape: u32, wi: vec3<f32>, wo: vec3<f32>) -> vec3<f32> {
    let kind = material_kind(shape);
    if (kind > MAT_TWO_SIDED_DIFFUSE) {
        return vec3<f32>(0.0);
    }
    let z = diffuse_side(kind, wi, wo);
    if (z.x <= 0.0 || z.y <= 0.0) {
        return vec3<f32>(0.0);
    }
    return shapes[3u * shape].xyz * INV_PI;
}

fn bsdf_pdf(shape: u32, wi: vec3<f32>, wo: vec3<f32>) -> f32 {
    let kind = material_kind(shape);
    if (kind > MAT_TWO_SIDED_DIFFUSE) {
        return 0.0;
    }
    let z = diffuse_side(kind, wi, wo);
    if (z.x <= 0.0 || z.y <= 0.0) {
        return 0.0;
    }
    return z.y * INV_PI;
}

// Unpolarised Fresnel reflectance, cosine of the refracted direction and
// the relative IOR across (fresnel.rs's fresnel_dielectric).
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

fn bsdf_sample(shape: u32, wi: vec3<f32>, u: vec2<f32>, u_lobe: f32) -> BsdfSample {
    let kind = material_kind(shape);
    if (kind <= MAT_TWO_SIDED_DIFFUSE) {
        var flip = false;
        if (wi.z <= 0.0) {
            if (kind != MAT_TWO_SIDED_DIFFUSE || wi.z == 0.0) {
                return no_sample();
            }
            flip = true;
        }
        var wo = square_to_cosine_hemisphere(u);
        if (wo.z <= 0.0) {
            return no_sample();
        }
        let pdf = wo.z * INV_PI;
        if (flip) {
            wo.z = -wo.z;
        }
        return BsdfSample(wo, shapes[3u * shape].xyz, pdf, false, 1.0, true);
    }
    if (kind == MAT_MIRROR) {
        if (wi.z <= 0.0) {
            return no_sample();
        }
        return BsdfSample(vec3<f32>(-wi.x, -wi.y, wi.z), vec3<f32>(1.0), 1.0, true, 1.0, true);
    }
    // Smooth dielectric.
    let eta = shapes[3u * shape + 2u].x;
    let f = fresnel_dielectric(wi.z, eta);
    if (u_lobe < f.x) {
        return BsdfSample(vec3<f32>(-wi.x, -wi.y, wi.z), vec3<f32>(1.0), f.x, true, 1.0, true);
    }
    let eta_ti = f.z;
    let wo = vec3<f32>(-wi.x / eta_ti, -wi.y / eta_ti, select(f.y, -f.y, wi.z >= 0.0));
    let scale = 1.0 / (eta_ti * eta_ti);
    return BsdfSample(normalize(wo), vec3<f32>(scale), 1.0 - f.x, true, eta_ti, true);
}
