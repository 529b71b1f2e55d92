// Which light next-event estimation samples from a shading point
// (emitter/light_choice.rs; the records are light_groups.rs's): an emitter
// group, then one of its light records by its CDF within the group (a
// triangle by area). Lights at infinity (the environment, then directional
// lights) share P.p_unbounded by power; bounded emitters are weighed at
// each point by their light-bounds importance (pbrt-v4's), or by power
// when there are more than light_choice.rs's EXHAUSTIVE_MAX of them
// (P.bounded_by_power, decided by light_groups.rs).
// A group's words (GROUP_WORDS vec4s from P.group_base in `lights`): (bounds
// centre, radius), (emission axis, cos theta_o), (power, first record as
// bits, record count as bits, the fixed choice's CDF up to and including
// it). A light record's word 5: (its group as bits, probability within it).

const GROUP_WORDS: u32 = 3u;
// light_choice.rs's MIN_FACTOR: the least the cone and normal terms give.
const MIN_FACTOR: f32 = 0.02;
const ONE_MINUS_EPSILON: f32 = 0.99999994;

fn group_word(g: u32, k: u32) -> vec4<f32> {
    return lights[P.group_base + GROUP_WORDS * g + k];
}

// LightBounds::importance: an upper bound (up to a common factor) of what
// group `g` can send to `p` with unit normal `n` (zero: none), either side.
fn group_importance(g: u32, p: vec3<f32>, n: vec3<f32>) -> f32 {
    let b0 = group_word(g, 0u);
    let b1 = group_word(g, 1u);
    let power = group_word(g, 2u).x;
    if (power <= 0.0) {
        return 0.0;
    }
    let to_p = p - b0.xyz;
    let d2 = dot(to_p, to_p);
    let r2 = b0.w * b0.w;
    if (d2 <= r2) {
        // Inside the bounding sphere: no direction can be excluded.
        return power / max(r2, 1.17549435e-38);
    }
    let dist = sqrt(d2);
    let w = to_p / dist;
    // Half-angle of the cone the bounding sphere subtends from p.
    let sin_b = b0.w / dist;
    let cos_b = sqrt(max(0.0, 1.0 - sin_b * sin_b));
    var factor = 1.0;
    let cos_o = b1.w;
    if (cos_o > -1.0) {
        // The angle between the emission cone and p, less the light's
        // extent, must stay below 90 degrees.
        let cos_w = clamp(dot(b1.xyz, w), -1.0, 1.0);
        let sin_w = sqrt(max(0.0, 1.0 - cos_w * cos_w));
        let sin_o = sqrt(max(0.0, 1.0 - cos_o * cos_o));
        var cos_x = 1.0;
        var sin_x = 0.0;
        if (cos_w < cos_o) {
            cos_x = cos_w * cos_o + sin_w * sin_o;
            sin_x = sin_w * cos_o - cos_w * sin_o;
        }
        var c = 1.0;
        if (cos_x < cos_b) {
            c = cos_x * cos_b + sin_x * sin_b;
        }
        if (c <= -1e-4) {
            return 0.0;
        }
        factor = max(c, MIN_FACTOR);
    }
    if (any(n != vec3<f32>(0.0))) {
        // The (two-sided) normal against the light, less its extent.
        let cos_i = min(abs(dot(n, w)), 1.0);
        var c = 1.0;
        if (cos_i < cos_b) {
            let sin_i = sqrt(max(0.0, 1.0 - cos_i * cos_i));
            c = cos_i * cos_b + sin_i * sin_b;
        }
        factor *= max(c, MIN_FACTOR);
    }
    return power * factor / d2;
}

// Whether the bounded groups are weighed one by one at each point.
fn weighs_per_point() -> bool {
    return P.bounded_groups >= 2u && P.bounded_by_power == 0u;
}

// LightChoice::at: the sum of the bounded groups' importance at (p, n),
// which sampling and the MIS weight of a light a BSDF sample from the same
// point finds share (0 where the choice does not weigh them).
fn choice_total(p: vec3<f32>, n: vec3<f32>) -> f32 {
    var total = 0.0;
    if (weighs_per_point()) {
        let end = P.unbounded_groups + P.bounded_groups;
        for (var g = P.unbounded_groups; g < end; g++) {
            total += group_importance(g, p, n);
        }
    }
    return total;
}

// The probability of group `g` where it does not depend on the point (at
// infinity, or bounded and chosen by power): its step of the CDF.
fn fixed_group_prob(g: u32) -> f32 {
    var below = P.env_prob;
    if (g == P.unbounded_groups) {
        below = P.p_unbounded;
    } else if (g > 0u) {
        below = group_word(g - 1u, 2u).w;
    }
    return group_word(g, 2u).w - below;
}

// Probability that the choice at (p, n), whose choice_total is `total`,
// picks group `g`.
fn group_prob(g: u32, p: vec3<f32>, n: vec3<f32>, total: f32) -> f32 {
    if (g < P.unbounded_groups || P.bounded_by_power != 0u) {
        return fixed_group_prob(g);
    }
    let p_bounded = 1.0 - P.p_unbounded;
    if (P.bounded_groups == 1u) {
        return p_bounded;
    }
    let w = group_importance(g, p, n);
    if (w <= 0.0 || !(total > 0.0)) {
        return 0.0;
    }
    return p_bounded * w / total;
}

// LightChoice::pdf for light record `i` (an area light a BSDF sample found).
fn light_choice_pdf(i: u32, p: vec3<f32>, n: vec3<f32>, total: f32) -> f32 {
    let c = lights[LIGHT_WORDS * i + 5u];
    return group_prob(bitcast<u32>(c.x), p, n, total) * c.y;
}

struct LightChoice {
    light: u32,
    // Probability of the choice, the group's and the record's.
    prob: f32,
    ok: bool,
}

// The first group in [lo, hi] whose CDF step ends past `u` (hi if rounding
// leaves none).
fn search_groups(lo_in: u32, hi_in: u32, u: f32) -> u32 {
    var lo = lo_in;
    var hi = hi_in;
    while (lo < hi) {
        let mid = (lo + hi) / 2u;
        if (group_word(mid, 2u).w > u) {
            hi = mid;
        } else {
            lo = mid + 1u;
        }
    }
    return lo;
}

// LightChoice::sample for a choice number `u` in [P.env_prob, 1) (below
// that the caller samples the environment), at (p, n) with choice_total
// `total`.
fn choose_light(p: vec3<f32>, n: vec3<f32>, total: f32, u: f32) -> LightChoice {
    let none = LightChoice(0u, 0.0, false);
    var g = 0u;
    var prob = 0.0;
    // `u` rescaled to [0, 1) within the chosen group's share.
    var ug = 0.0;
    if (u < P.p_unbounded || P.bounded_by_power != 0u) {
        var lo = 0u;
        var count = P.unbounded_groups;
        if (u >= P.p_unbounded) {
            lo = P.unbounded_groups;
            count = P.bounded_groups;
        }
        if (count == 0u) {
            return none;
        }
        g = search_groups(lo, lo + count - 1u, u);
        prob = fixed_group_prob(g);
        if (!(prob > 0.0)) {
            return none;
        }
        ug = clamp((u - (group_word(g, 2u).w - prob)) / prob, 0.0, ONE_MINUS_EPSILON);
    } else {
        if (P.bounded_groups == 0u) {
            return none;
        }
        let p_bounded = 1.0 - P.p_unbounded;
        let ub = min((u - P.p_unbounded) / p_bounded, ONE_MINUS_EPSILON);
        g = P.unbounded_groups;
        if (P.bounded_groups == 1u) {
            // One emitter: nothing to weigh.
            prob = p_bounded;
            ug = ub;
        } else {
            if (!(total > 0.0)) {
                return none;
            }
            let aim = ub * total;
            var acc = 0.0;
            var found = false;
            var last = NONE;
            var last_w = 0.0;
            for (var k = 0u; k < P.bounded_groups; k++) {
                let gk = P.unbounded_groups + k;
                let w = group_importance(gk, p, n);
                if (w <= 0.0) {
                    continue;
                }
                if (aim < acc + w) {
                    g = gk;
                    prob = p_bounded * w / total;
                    ug = clamp((aim - acc) / w, 0.0, ONE_MINUS_EPSILON);
                    found = true;
                    break;
                }
                acc += w;
                last = gk;
                last_w = w;
            }
            if (!found) {
                // Rounding left the aim past the sum: the last group
                // with weight.
                if (last == NONE) {
                    return none;
                }
                g = last;
                prob = p_bounded * last_w / total;
                ug = ONE_MINUS_EPSILON;
            }
        }
    }
    // The record within the group: the first whose CDF exceeds ug.
    let gw = group_word(g, 2u);
    var lo = bitcast<u32>(gw.y);
    var hi = lo + bitcast<u32>(gw.z) - 1u;
    while (lo < hi) {
        let mid = (lo + hi) / 2u;
        if (lights[LIGHT_WORDS * mid + 2u].w > ug) {
            hi = mid;
        } else {
            lo = mid + 1u;
        }
    }
    return LightChoice(lo, prob * lights[LIGHT_WORDS * lo + 5u].y, true);
}
