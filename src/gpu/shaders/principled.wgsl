// Mitsuba's `principled` and `principledthin` (bsdf/principled.rs and
// principled_thin.rs, as Mitsuba 3.9.1 evaluates them). `principled`: Burley's diffuse with retro-reflection and the fake subsurface
// (`flatness`), sheen, a GGX interface whose reflection blends the
// dielectric Fresnel term with Schlick's metallic and tinted ones, GGX
// transmission (`spec_trans`) and a GTR1 clearcoat. Sampling picks the
// diffuse lobe, the clearcoat or the interface by principled.rs's
// probabilities, then reflection or transmission by the Fresnel term of
// the sampled normal; `front_sample` weighs the direction with
// principled_eval and principled_pdf.
//
// The current layer's words (flatten.rs's `principled`): A the base
// colour (mat_a); B (metallic, anisotropic, clearcoat) in mat_b and the
// roughness in mat_alpha; C (spec_trans, eta, clearcoat_gloss) in mat_c,
// C.w the index of (sheen, sheen_tint, flatness, spec_tint) and the
// (diffuse, clearcoat, specular) sampling rates. Absent parameters are
// zero, which turns their terms off as principled.rs's `None` does.
// Textured parameters are read once per hit by `load_material`: base
// colour, metallic, spec_trans, eta and roughness by their flags, the
// others from the records their words box (`load_disney_params`); the
// (sheen, sheen_tint, flatness, spec_tint) word is then in mat_extra.

struct Disney {
    base: vec3<f32>,
    roughness: f32,
    metallic: f32,
    anisotropic: f32,
    clearcoat: f32,
    spec_trans: f32,
    eta: f32,
    gloss: f32,
    // (sheen, sheen_tint, flatness, spec_tint)
    extra: vec4<f32>,
    rates: vec3<f32>,
}

fn disney() -> Disney {
    let more = bitcast<u32>(material_word(2u).w);
    return Disney(
        mat_a, mat_alpha, mat_b.x, mat_b.y, mat_b.z, mat_c.x, mat_c.y, mat_c.z,
        mat_extra, shapes[more + 1u].xyz,
    );
}

// The weights of the reflective (diffuse, sheen) and transmissive parts.
fn disney_brdf_bsdf(d: Disney) -> vec2<f32> {
    return vec2<f32>(1.0 - d.spec_trans, d.spec_trans) * (1.0 - d.metallic);
}

// principled.rs's `disney_ggx`: roughness squared, stretched by
// `anisotropic`, at least 0.001.
fn disney_ggx(roughness: f32, anisotropic: f32) -> Microfacet {
    let r2 = roughness * roughness;
    let aspect = sqrt(1.0 - 0.9 * anisotropic);
    return Microfacet(max(r2 / aspect, 0.001), max(r2 * aspect, 0.001), true);
}

// fresnel.rs's `schlick_weight`, (1 - cos)^5.
fn schlick_weight(cos: f32) -> f32 {
    let m = clamp(1.0 - cos, 0.0, 1.0);
    return (m * m) * (m * m) * m;
}

// principled.rs's `schlick_across`: Schlick's Fresnel with reflectance
// `r0` across an interface of relative IOR `eta`, from the denser side
// measured by the transmitted cosine.
fn schlick_across(r0: vec3<f32>, cos_i: f32, eta: f32) -> vec3<f32> {
    let eta_it = select(1.0 / eta, eta, cos_i >= 0.0);
    var cos = abs(cos_i);
    if (eta_it <= 1.0) {
        cos = sqrt(max(1.0 - (1.0 - cos_i * cos_i) * eta_it * eta_it, 0.0));
    }
    return r0 + (vec3<f32>(1.0) - r0) * schlick_weight(cos);
}

// `base / luminance(base)`, or white for black.
fn disney_tint(base: vec3<f32>) -> vec3<f32> {
    let lum = dot(base, LUMINANCE);
    return select(vec3<f32>(1.0), base / lum, lum > 0.0);
}

// principled.rs's `diffuse_shape`: Burley's diffuse with retro-reflection,
// blended towards the fake subsurface by `flatness`.
fn disney_diffuse_shape(roughness: f32, cos_i: f32, cos_o: f32, cos_d: f32, flatness: f32) -> f32 {
    let fo = schlick_weight(cos_o);
    let fi = schlick_weight(cos_i);
    let f_diff = (1.0 - 0.5 * fi) * (1.0 - 0.5 * fo);
    let rr = 2.0 * roughness * cos_d * cos_d;
    let f_retro = rr * (fo + fi + fo * fi * (rr - 1.0));
    if (flatness == 0.0) {
        return f_diff + f_retro;
    }
    let fss90 = 0.5 * rr;
    let fss = (1.0 + (fss90 - 1.0) * fo) * (1.0 + (fss90 - 1.0) * fi);
    let f_ss = 1.25 * (fss * (1.0 / (cos_o + cos_i) - 0.5) + 0.5);
    return (f_diff + f_retro) * (1.0 - flatness) + f_ss * flatness;
}

// Smith's G1 of isotropic GGX with roughness `alpha` (the clearcoat's).
fn smith_ggx1(v: vec3<f32>, m: vec3<f32>, alpha: f32) -> f32 {
    if (dot(v, m) * v.z <= 0.0) {
        return 0.0;
    }
    if (v.z == 1.0) {
        return 1.0;
    }
    let cos2 = v.z * v.z;
    let tan2 = (1.0 - cos2) / cos2;
    return 2.0 / (1.0 + sqrt(1.0 + alpha * alpha * tan2));
}

// Burley's GTR1 clearcoat distribution: gloss 0..1 maps alpha 0.1..0.001.
fn gtr1_alpha(gloss: f32) -> f32 {
    return 0.1 + (0.001 - 0.1) * gloss;
}

fn gtr1_d(alpha: f32, m: vec3<f32>) -> f32 {
    let a2 = alpha * alpha;
    let d = (a2 - 1.0) / (PI * log(a2) * (1.0 + (a2 - 1.0) * m.z * m.z));
    return select(0.0, d, d * m.z > 1e-20);
}

fn gtr1_pdf(alpha: f32, m: vec3<f32>) -> f32 {
    return select(m.z * gtr1_d(alpha, m), 0.0, m.z < 0.0);
}

fn gtr1_sample(alpha: f32, u: vec2<f32>) -> vec3<f32> {
    let phi = 2.0 * PI * u.x;
    let a2 = alpha * alpha;
    let cos2 = (1.0 - pow(a2, 1.0 - u.y)) / (1.0 - a2);
    let sin_theta = sqrt(max(1.0 - cos2, 0.0));
    return vec3<f32>(cos(phi) * sin_theta, sin(phi) * sin_theta, sqrt(max(cos2, 0.0)));
}

// principled.rs's `compatible`: both directions on the microfacet's side
// as wi sees it (reflection), or on opposite sides (transmission).
fn mac_mic_compatible(m_in: vec3<f32>, wi: vec3<f32>, wo: vec3<f32>, cos_i: f32, reflection: bool) -> bool {
    let m = select(-m_in, m_in, cos_i >= 0.0);
    let o = dot(wo, m);
    return dot(wi, m) > 0.0 && select(o < 0.0, o > 0.0, reflection);
}

// The front's lobe choice: probabilities of diffuse and clearcoat (the
// interface has the rest).
fn disney_choice(d: Disney) -> vec2<f32> {
    let diffuse = disney_brdf_bsdf(d).x * d.rates.x;
    let clearcoat = 0.25 * d.clearcoat * d.rates.y;
    return vec2<f32>(diffuse, clearcoat) / (diffuse + clearcoat + d.rates.z);
}

// f(wi, wo), no cosine: Mitsuba's `eval` term by term over |cos_o|.
fn principled_eval(wi: vec3<f32>, wo: vec3<f32>) -> vec3<f32> {
    let d = disney();
    let h = half_vector(wi, wo, d.eta);
    if (h.m.z > 1.0 || wo.z == 0.0) {
        return vec3<f32>(0.0);
    }
    let cos_i = wi.z;
    let cos_o = abs(wo.z);
    let front = cos_i > 0.0;
    let w = disney_brdf_bsdf(d);
    let md = disney_ggx(d.roughness, d.anisotropic);
    let dih = dot(wi, h.m);
    let f_dielectric = fresnel_dielectric(dih, d.eta).x;
    let reflect_ok = h.reflect && mac_mic_compatible(h.m, wi, wo, cos_i, true);
    let dg = microfacet_d(md, h.m) * smith_g1(md, wi, h.m) * smith_g1(md, wo, h.m);
    var value = vec3<f32>(0.0); // f |cos_o|, as Mitsuba's eval returns it

    if (reflect_ok && f_dielectric > 0.0) {
        var fresnel = vec3<f32>(w.y * f_dielectric);
        if (front) {
            let spec_tint = d.extra.w;
            let eta_it = select(1.0 / d.eta, d.eta, dih >= 0.0);
            let r = (eta_it - 1.0) / (eta_it + 1.0);
            let r0 = disney_tint(d.base) * (r * r);
            fresnel = vec3<f32>((1.0 - d.metallic) * (1.0 - spec_tint) * f_dielectric)
                + schlick_across(d.base, dih, d.eta) * d.metallic
                + schlick_across(r0, dih, d.eta) * ((1.0 - d.metallic) * spec_tint);
        }
        value += fresnel * (dg / (4.0 * abs(cos_i)));
    }

    if (w.y > 0.0 && !h.reflect && mac_mic_compatible(h.m, wi, wo, cos_i, false) && f_dielectric < 1.0) {
        // Radiance's 1/eta^2 and Walter's eta^2 cancel.
        let eta_path = select(1.0 / d.eta, d.eta, front);
        let doh = dot(wo, h.m);
        let denom = dih + eta_path * doh;
        let t = abs((1.0 - f_dielectric) * dg * dih * doh / (cos_i * denom * denom));
        value += sqrt(d.base) * (w.y * t);
    }

    if (d.clearcoat > 0.0 && reflect_ok && front) {
        let f_cc = schlick_across(vec3<f32>(0.04), dih, d.eta).x;
        let g_cc = smith_ggx1(wi, h.m, 0.25) * smith_ggx1(wo, h.m, 0.25);
        value += vec3<f32>(d.clearcoat * 0.25 * f_cc * gtr1_d(gtr1_alpha(d.gloss), h.m) * g_cc * cos_o);
    }

    if (w.x > 0.0 && h.reflect && front) {
        let cos_d = dot(h.m, wo);
        let shape = disney_diffuse_shape(d.roughness, abs(cos_i), cos_o, cos_d, d.extra.z);
        value += d.base * (w.x * cos_o * INV_PI * shape);
        // Sheen, only where the diffuse lobe is (as in Mitsuba).
        let sheen = d.extra.x;
        if (sheen > 0.0 && 1.0 - d.metallic > 0.0) {
            let colour = vec3<f32>(1.0) + (disney_tint(d.base) - vec3<f32>(1.0)) * d.extra.y;
            value += colour * (sheen * (1.0 - d.metallic) * schlick_weight(abs(cos_d)) * cos_o);
        }
    }
    return value / cos_o;
}

// Solid-angle density of principled_sample.
fn principled_pdf(wi: vec3<f32>, wo: vec3<f32>) -> f32 {
    let d = disney();
    let h = half_vector(wi, wo, d.eta);
    if (h.m.z > 1.0 || wo.z == 0.0) {
        return 0.0;
    }
    let cos_i = wi.z;
    let front = cos_i > 0.0;
    let bsdf = disney_brdf_bsdf(d).y;
    if (!front && bsdf <= 0.0) {
        return 0.0;
    }
    let eta_path = select(1.0 / d.eta, d.eta, front);
    let dih = dot(wi, h.m);
    let doh = dot(wo, h.m);
    let f = fresnel_dielectric(dih, d.eta).x;
    // The interface's reflection and transmission shares, the lobes'.
    var p_reflect = f;
    var choice = vec2<f32>(0.0);
    if (front) {
        p_reflect = 1.0 - bsdf * (1.0 - f);
        choice = disney_choice(d);
    }
    let p_trans = 1.0 - p_reflect;
    let p_spec = 1.0 - choice.x - choice.y;
    var dwh_dwo: f32;
    if (h.reflect) {
        dwh_dwo = abs(1.0 / (4.0 * doh));
    } else {
        let denom = dih + eta_path * doh;
        dwh_dwo = abs(eta_path * eta_path * doh / (denom * denom));
    }
    let up = select(-wi, wi, cos_i >= 0.0);
    var pdf = 0.0;
    if (h.reflect) {
        if (mac_mic_compatible(h.m, wi, wo, cos_i, true)) {
            pdf += p_spec * p_reflect * microfacet_normal_pdf(disney_ggx(d.roughness, d.anisotropic), up, h.m) * dwh_dwo;
            if (choice.y > 0.0) {
                pdf += choice.y * gtr1_pdf(gtr1_alpha(d.gloss), h.m) * dwh_dwo;
            }
        }
        pdf += choice.x * max(wo.z, 0.0) * INV_PI;
    } else if (p_trans > 0.0 && mac_mic_compatible(h.m, wi, wo, cos_i, false)) {
        pdf += p_spec * p_trans * microfacet_normal_pdf(disney_ggx(d.roughness, d.anisotropic), up, h.m) * dwh_dwo;
    }
    return pdf;
}

// A direction from one lobe (`direction_only`); a direction on the wrong
// side for its lobe or its microfacet is dropped, as Mitsuba drops it.
fn principled_sample(wi: vec3<f32>, u: vec2<f32>, u_lobe: f32) -> BsdfSample {
    let cos_i = wi.z;
    if (cos_i == 0.0) {
        return no_sample();
    }
    let d = disney();
    let front = cos_i > 0.0;
    let bsdf = disney_brdf_bsdf(d).y;
    if (!front && bsdf <= 0.0) {
        return no_sample();
    }
    var choice = vec2<f32>(0.0);
    if (front) {
        choice = disney_choice(d);
    }
    var wo: vec3<f32>;
    var eta = 1.0;
    var reflection = true;
    var m: vec3<f32>;
    if (u_lobe < choice.x) {
        wo = square_to_cosine_hemisphere(u);
    } else {
        if (u_lobe < choice.x + choice.y) {
            m = gtr1_sample(gtr1_alpha(d.gloss), u);
        } else {
            let p_spec = 1.0 - choice.x - choice.y;
            let u_interface = min((u_lobe - choice.x - choice.y) / p_spec, 0.99999988);
            let up = select(-wi, wi, cos_i >= 0.0);
            let md = disney_ggx(d.roughness, d.anisotropic);
            m = sample_microfacet(md, up, u);
            if (not_finite(m.x + m.y + m.z) || !(microfacet_normal_pdf(md, up, m) > 0.0)) {
                return no_sample();
            }
            let dim = dot(wi, m);
            let fr = fresnel_dielectric(dim, d.eta);
            let p_reflect = select(fr.x, 1.0 - bsdf * (1.0 - fr.x), front);
            if (u_interface >= p_reflect) {
                wo = refract_about(wi, m, dim, fr);
                eta = fr.z;
                reflection = false;
            }
        }
        if (reflection) {
            wo = reflect_about(wi, m);
        }
        if ((wo.z * cos_i > 0.0) != reflection || !mac_mic_compatible(m, wi, wo, cos_i, reflection)) {
            return no_sample();
        }
    }
    if (not_finite(wo.x + wo.y + wo.z) || wo.z == 0.0) {
        return no_sample();
    }
    return direction_only(wo, eta);
}

// --- `principledthin` (bsdf/principled_thin.rs): a sheet with no inside,
// the same from both sides (directions mirrored to the front). Diffuse
// with retro-reflection, fake subsurface and sheen; Lambertian diffuse
// transmission (`diff_trans`, 0 to 2); with `spec_trans`, GGX reflection
// (the dielectric Fresnel of eta, tinted by `spec_tint`) and GGX
// transmission straight through (a reflection mirrored to the back, its
// roughness scaled by 0.65 eta - 0.35). Words: A the base colour; B
// (spec_trans, anisotropic, diff_trans) in mat_b and the roughness in
// mat_alpha; C (eta, 0, 0) in mat_c, C.w the index of (sheen,
// sheen_tint, flatness, spec_tint) and the (specular reflection,
// specular transmission, diffuse reflection, diffuse transmission)
// sampling rates.

struct Sheet {
    base: vec3<f32>,
    roughness: f32,
    spec_trans: f32,
    anisotropic: f32,
    // diff_trans / 2, in [0, 1].
    diff_trans: f32,
    eta: f32,
    // (sheen, sheen_tint, flatness, spec_tint)
    extra: vec4<f32>,
    rates: vec4<f32>,
}

fn thin_sheet() -> Sheet {
    let more = bitcast<u32>(material_word(2u).w);
    return Sheet(
        mat_a, mat_alpha, mat_b.x, mat_b.y, 0.5 * mat_b.z, mat_c.x,
        mat_extra, shapes[more + 1u],
    );
}

// The transmission lobe's distribution (Burley 2015, figure 15).
fn thin_trans_ggx(t: Sheet) -> Microfacet {
    return disney_ggx((0.65 * t.eta - 0.35) * t.roughness, t.anisotropic);
}

// Probabilities of specular reflection, specular transmission, diffuse
// reflection and diffuse transmission; zero where they do not add up.
fn thin_choice(t: Sheet) -> vec4<f32> {
    let c = vec4<f32>(
        0.5 * t.spec_trans,
        0.5 * t.spec_trans,
        (1.0 - t.spec_trans) * (1.0 - t.diff_trans),
        (1.0 - t.spec_trans) * t.diff_trans,
    ) * t.rates;
    let total = c.x + c.y + c.z + c.w;
    if (!(total > 0.0) || not_finite(total)) {
        return vec4<f32>(0.0);
    }
    return c / total;
}

// The microfacet a thin reflection or transmission turned on: wi's and
// wo's mirrored to the front.
fn thin_half(wi: vec3<f32>, wo: vec3<f32>) -> vec3<f32> {
    return normalize(wi + vec3<f32>(wo.x, wo.y, abs(wo.z)));
}

// f(wi, wo), no cosine.
fn principled_thin_eval(wi_in: vec3<f32>, wo_in: vec3<f32>) -> vec3<f32> {
    if (wi_in.z == 0.0 || wo_in.z == 0.0) {
        return vec3<f32>(0.0);
    }
    let t = thin_sheet();
    let side = select(-1.0, 1.0, wi_in.z >= 0.0);
    let wi = wi_in * side;
    let wo = wo_in * side;
    let reflect = wo.z > 0.0;
    let wh = thin_half(wi, wo);
    var value = vec3<f32>(0.0); // f |cos_o|, as Mitsuba's eval returns it

    if (t.spec_trans > 0.0) {
        let dih = dot(wi, wh);
        let f = fresnel_dielectric(dih, t.eta).x;
        if (reflect && mac_mic_compatible(wh, wi, wo, wi.z, true)) {
            let md = disney_ggx(t.roughness, t.anisotropic);
            let spec_tint = t.extra.w;
            let r = (t.eta - 1.0) / (t.eta + 1.0);
            let r0 = disney_tint(t.base) * (r * r);
            let fresnel = vec3<f32>(f * (1.0 - spec_tint)) + schlick_across(r0, dih, t.eta) * spec_tint;
            let dg = microfacet_d(md, wh) * smith_g1(md, wi, wh) * smith_g1(md, wo, wh);
            value += fresnel * (t.spec_trans * dg / (4.0 * wi.z));
        }
        if (!reflect && mac_mic_compatible(wh, wi, wo, wi.z, false)) {
            let md = thin_trans_ggx(t);
            let dg = microfacet_d(md, wh) * smith_g1(md, wi, wh) * smith_g1(md, wo, wh);
            value += t.base * (t.spec_trans * (1.0 - f) * dg / (4.0 * wi.z));
        }
    }

    if (reflect && t.spec_trans < 1.0 && t.diff_trans < 1.0) {
        let cos_d = dot(wh, wo);
        let shape = disney_diffuse_shape(t.roughness, wi.z, wo.z, cos_d, t.extra.z);
        let weight = (1.0 - t.spec_trans) * (1.0 - t.diff_trans);
        value += t.base * (weight * wo.z * INV_PI * shape);
        let sheen = t.extra.x;
        if (sheen > 0.0) {
            let colour = vec3<f32>(1.0) + (disney_tint(t.base) - vec3<f32>(1.0)) * t.extra.y;
            value += colour * (sheen * weight * schlick_weight(abs(cos_d)) * wo.z);
        }
    }

    if (!reflect && t.spec_trans < 1.0 && t.diff_trans > 0.0) {
        value += t.base * ((1.0 - t.spec_trans) * t.diff_trans * INV_PI * abs(wo.z));
    }
    return value / abs(wo.z);
}

// Solid-angle density of principled_thin_sample.
fn principled_thin_pdf(wi_in: vec3<f32>, wo_in: vec3<f32>) -> f32 {
    if (wi_in.z == 0.0 || wo_in.z == 0.0) {
        return 0.0;
    }
    let t = thin_sheet();
    let c = thin_choice(t);
    let side = select(-1.0, 1.0, wi_in.z >= 0.0);
    let wi = wi_in * side;
    let wo = wo_in * side;
    let reflect = wo.z > 0.0;
    let wh = thin_half(wi, wo);
    let dwh_dwo = abs(1.0 / (4.0 * dot(vec3<f32>(wo.x, wo.y, abs(wo.z)), wh)));
    var pdf = 0.0;
    if (reflect) {
        if (c.x > 0.0 && mac_mic_compatible(wh, wi, wo, wi.z, true)) {
            let md = disney_ggx(t.roughness, t.anisotropic);
            pdf += c.x * microfacet_normal_pdf(md, wi, wh) * dwh_dwo;
        }
        pdf += c.z * wo.z * INV_PI;
    } else {
        if (c.y > 0.0 && mac_mic_compatible(wh, wi, wo, wi.z, false)) {
            pdf += c.y * microfacet_normal_pdf(thin_trans_ggx(t), wi, wh) * dwh_dwo;
        }
        pdf += c.w * -wo.z * INV_PI;
    }
    return pdf;
}

// A direction from one lobe (`direction_only`), chosen by thin_choice.
fn principled_thin_sample(wi_in: vec3<f32>, u: vec2<f32>, u_lobe: f32) -> BsdfSample {
    if (wi_in.z == 0.0) {
        return no_sample();
    }
    let t = thin_sheet();
    let c = thin_choice(t);
    if (c.x + c.y + c.z + c.w == 0.0) {
        return no_sample();
    }
    let side = select(-1.0, 1.0, wi_in.z >= 0.0);
    let wi = wi_in * side;
    var wo: vec3<f32>;
    if (u_lobe < c.x + c.y) {
        let reflection = u_lobe < c.x;
        var md = thin_trans_ggx(t);
        if (reflection) {
            md = disney_ggx(t.roughness, t.anisotropic);
        }
        let m = sample_microfacet(md, wi, u);
        wo = reflect_about(wi, m);
        if (!reflection) {
            wo.z = -wo.z;
        }
        if ((wo.z > 0.0) != reflection || !mac_mic_compatible(m, wi, wo, wi.z, reflection)) {
            return no_sample();
        }
    } else if (u_lobe < c.x + c.y + c.z) {
        wo = square_to_cosine_hemisphere(u);
    } else if (c.w > 0.0) {
        wo = -square_to_cosine_hemisphere(u);
    } else {
        return no_sample();
    }
    wo *= side;
    if (not_finite(wo.x + wo.y + wo.z) || wo.z == 0.0) {
        return no_sample();
    }
    return direction_only(wo, 1.0);
}
