//! The GPU's light choice, flattened (`light_choice.wgsl` reads it): the
//! CPU's choice (`emitter/light_choice.rs`) per emitter, then one of the
//! emitter's light records (a triangle by area, a sphere, a disk, a delta
//! light) within it.
//!
//! Lights at infinity (the environment and directional lights) share a
//! fixed probability, by power among themselves; bounded emitters are
//! weighed per shading point by their [`LightBounds`] importance where
//! there are at most [`EXHAUSTIVE_MAX`] of them, by power beyond.

use crate::emitter::{LightBounds, EXHAUSTIVE_MAX};

use super::flatten::{bits, LIGHT_WORDS};

/// Vec4 words per emitter group: (bounds centre, radius), (emission axis,
/// cos theta_o), (power, first light record as bits, record count as bits,
/// the choice's CDF up to and including it: fixed choices only).
pub const GROUP_WORDS: usize = 3;

/// One emitter's light records, as the choice sees them.
pub struct LightGroup {
    /// Where it is and where it sends light; `None` at infinity.
    pub bounds: Option<LightBounds>,
    /// Emitted power (luminance), as the CPU's `Emitter::power`.
    pub power: f32,
    /// Its first record in the light records, and each record's weight
    /// within it (area, or 1 for a delta light).
    pub first: usize,
    pub weights: Vec<f32>,
}

/// The choice's records and constants (`Params`' fields of those names).
pub struct ChoiceTables {
    pub groups: Vec<[f32; 4]>,
    /// Probability of the environment, and of any light at infinity (the
    /// environment's included).
    pub env_prob: f32,
    pub p_unbounded: f32,
    /// Groups at infinity come first, then the bounded ones.
    pub unbounded_groups: u32,
    pub bounded_groups: u32,
    /// Whether the bounded groups are chosen by power (more than
    /// [`EXHAUSTIVE_MAX`]), not weighed per point.
    pub bounded_by_power: bool,
}

/// The group records for `groups` (those without power are never chosen)
/// and an environment of power `env_power` (if any). Writes into each
/// light record the CDF of the choice within its group (word 2's w) and
/// (group index, probability within the group) (word 5).
pub fn choice_tables(
    groups: &[LightGroup],
    env_power: Option<f32>,
    lights: &mut [[f32; 4]],
) -> ChoiceTables {
    let has_power = |p: f32| p > 0.0 && p.is_finite();
    let env_power = env_power.filter(|&p| has_power(p));
    let live = |g: &&LightGroup| has_power(g.power) && g.weights.iter().any(|&w| has_power(w));
    let unbounded: Vec<&LightGroup> = groups
        .iter()
        .filter(live)
        .filter(|g| g.bounds.is_none())
        .collect();
    let bounded: Vec<&LightGroup> = groups
        .iter()
        .filter(live)
        .filter(|g| g.bounds.is_some())
        .collect();
    // The CPU's share: each light at infinity counts as much as all the
    // bounded lights together.
    let at_infinity = unbounded.len() + usize::from(env_power.is_some());
    let shares = at_infinity + usize::from(!bounded.is_empty());
    let p_unbounded = if shares == 0 {
        0.0
    } else {
        at_infinity as f64 / shares as f64
    };
    let unbounded_total: f64 =
        env_power.map_or(0.0, f64::from) + unbounded.iter().map(|g| g.power as f64).sum::<f64>();
    let env_prob = env_power.map_or(0.0, |p| p_unbounded * p as f64 / unbounded_total);
    let bounded_total: f64 = bounded.iter().map(|g| g.power as f64).sum();
    let by_power = bounded.len() > EXHAUSTIVE_MAX;

    let mut records = Vec::with_capacity(GROUP_WORDS * (unbounded.len() + bounded.len()));
    // Fixed choices' CDF in the choice number's own range: the lights at
    // infinity after the environment, the bounded ones (by power) after
    // them.
    let mut upper = env_prob;
    for (k, g) in unbounded.iter().chain(&bounded).enumerate() {
        let fixed = match g.bounds {
            None => p_unbounded * g.power as f64 / unbounded_total,
            Some(_) if by_power => (1.0 - p_unbounded) * g.power as f64 / bounded_total,
            Some(_) => 0.0,
        };
        upper = if k == unbounded.len() {
            p_unbounded + fixed
        } else {
            upper + fixed
        };
        let b = g.bounds.unwrap_or(LightBounds {
            centre: glam::Vec3::ZERO,
            radius: 0.0,
            power: g.power,
            axis: glam::Vec3::Z,
            cos_theta_o: -1.0,
        });
        records.push([b.centre.x, b.centre.y, b.centre.z, b.radius]);
        records.push([b.axis.x, b.axis.y, b.axis.z, b.cos_theta_o]);
        records.push([
            g.power,
            bits(g.first as u32),
            bits(g.weights.len() as u32),
            upper as f32,
        ]);
        // The choice within the group.
        let total: f64 = g.weights.iter().map(|&w| w.max(0.0) as f64).sum();
        let mut below = 0.0f64;
        for (j, &w) in g.weights.iter().enumerate() {
            let p = w.max(0.0) as f64 / total;
            below += p;
            let rec = &mut lights[LIGHT_WORDS * (g.first + j)..][..LIGHT_WORDS];
            rec[2][3] = if j + 1 == g.weights.len() {
                1.0
            } else {
                below as f32
            };
            rec[5] = [bits(k as u32), p as f32, 0.0, 0.0];
        }
    }
    // The last fixed choice ends at one (rounding).
    if by_power || (bounded.is_empty() && !unbounded.is_empty()) {
        if let Some(last) = records.last_mut() {
            last[3] = 1.0;
        }
    }
    ChoiceTables {
        groups: records,
        env_prob: env_prob as f32,
        p_unbounded: p_unbounded as f32,
        unbounded_groups: unbounded.len() as u32,
        bounded_groups: bounded.len() as u32,
        bounded_by_power: by_power,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn bounded(power: f32, first: usize, weights: Vec<f32>) -> LightGroup {
        LightGroup {
            bounds: Some(LightBounds {
                centre: Vec3::ZERO,
                radius: 1.0,
                power,
                axis: Vec3::Z,
                cos_theta_o: -1.0,
            }),
            power,
            first,
            weights,
        }
    }

    /// Shares as the CPU's: the environment and a directional light each
    /// as much as the bounded lights together, by power among themselves;
    /// records within a group by weight, their CDF ending at one.
    #[test]
    fn shares_follow_the_cpu_choice() {
        let mut lights = vec![[0.0f32; 4]; LIGHT_WORDS * 4];
        let groups = vec![
            bounded(2.0, 0, vec![1.0, 3.0]),
            LightGroup {
                bounds: None,
                power: 1.0,
                first: 2,
                weights: vec![1.0],
            },
            bounded(0.0, 3, vec![1.0]),
        ];
        let t = choice_tables(&groups, Some(3.0), &mut lights);
        assert_eq!((t.unbounded_groups, t.bounded_groups), (1, 1));
        assert!(!t.bounded_by_power);
        assert!((t.p_unbounded - 2.0 / 3.0).abs() < 1e-6);
        assert!((t.env_prob - 0.5).abs() < 1e-6, "{}", t.env_prob);
        // The directional group first (fixed, ending at p_unbounded),
        // then the bounded one.
        assert!((t.groups[2][3] - 2.0 / 3.0).abs() < 1e-6);
        assert_eq!(t.groups[2][1].to_bits(), 2);
        assert_eq!(t.groups[5][1].to_bits(), 0);
        assert_eq!(t.groups[5][2].to_bits(), 2);
        // Within the bounded group: 1/4 and 3/4; the record names group 1.
        assert!((lights[2][3] - 0.25).abs() < 1e-6);
        assert_eq!(lights[LIGHT_WORDS + 2][3], 1.0);
        assert_eq!(lights[LIGHT_WORDS + 5][0].to_bits(), 1);
        assert!((lights[LIGHT_WORDS + 5][1] - 0.75).abs() < 1e-6);
        // The powerless group is never chosen: no record names it.
        assert_eq!(lights[LIGHT_WORDS * 3 + 5], [0.0; 4]);
    }

    /// Past `EXHAUSTIVE_MAX` bounded emitters the choice among them is by
    /// power, a CDF from p_unbounded to one.
    #[test]
    fn many_bounded_emitters_are_chosen_by_power() {
        let n = EXHAUSTIVE_MAX + 1;
        let mut lights = vec![[0.0f32; 4]; LIGHT_WORDS * n];
        let groups: Vec<LightGroup> = (0..n)
            .map(|i| bounded(1.0 + i as f32, i, vec![1.0]))
            .collect();
        let t = choice_tables(&groups, Some(1.0), &mut lights);
        assert!(t.bounded_by_power);
        assert!((t.p_unbounded - 0.5).abs() < 1e-6);
        let uppers: Vec<f32> = t.groups.chunks(GROUP_WORDS).map(|g| g[2][3]).collect();
        let total = (n * (n + 1) / 2) as f32;
        assert!((uppers[0] - (0.5 + 0.5 / total)).abs() < 1e-6);
        assert!(uppers.windows(2).all(|w| w[1] > w[0]));
        assert_eq!(*uppers.last().unwrap(), 1.0);
    }
}
