//! The light density's tables for kinds whose lights come in groups (a mesh's
//! faces, `PrimitiveKind::grouped_lights`): each group is one entry of the
//! uniform pick among the light density's objects, and within it a primitive is
//! picked in proportion to its power by an alias table (Walker 1977, Vose 1991)
//! in O(1). The density of a direction sums every primitive of the kind the ray
//! meets, found through a BVH over the light primitives alone, so evaluating it
//! costs O(log n), not O(n).

use crate::accel::Bvh;
use crate::gpu::layout::{Material, PackedArray, SceneData, gpu_struct};

gpu_struct! {
    /// A group's primitives: `count` from `first` on in the kind's light array.
    pub struct LightGroup {
        pub first: u32,
        pub count: u32,
    }
}

gpu_struct! {
    /// One slot of a group's alias table, and the probability of the light
    /// primitive of the same index within its group.
    pub struct LightPick {
        /// Below it (for a uniform number in [0, 1)) the slot's own primitive is
        /// picked, above it `other`.
        pub threshold: f32,
        /// Index within the group.
        pub other: u32,
        /// This primitive's probability within its group.
        pub pmf: f32,
    }
}

/// The tables of one grouped kind's lights.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LightTables {
    pub groups: Vec<LightGroup>,
    /// One per light primitive, in the light array's order.
    pub picks: Vec<LightPick>,
    /// Over the light primitives, which it leaves in place (groups are
    /// contiguous there): its leaves are ranges of `refs`.
    pub bvh: Bvh,
    /// The light array's indices in the BVH's leaf order (`Bvh::build_order`).
    pub refs: Vec<u32>,
}

/// Rec. 709 luminance: how bright an emission looks, for weighing lights.
fn luminance(rgb: [f32; 3]) -> f64 {
    0.2126 * rgb[0] as f64 + 0.7152 * rgb[1] as f64 + 0.0722 * rgb[2] as f64
}

impl LightTables {
    /// The tables of the light primitives `lights` of kind `k`, with `groups[i]`
    /// and `areas[i]` the group and area of light `i` (a group's lights are
    /// contiguous). A light's power is its area times its emission's luminance;
    /// a group that does not emit (`importance = true` only) is weighed by area.
    pub fn build(
        k: usize,
        lights: &PackedArray,
        groups: &[u32],
        areas: &[f32],
        materials: &[Material],
    ) -> LightTables {
        let mut tables = LightTables::default();
        let mut start = 0;
        while start < groups.len() {
            let end = start
                + groups[start..]
                    .iter()
                    .take_while(|&&g| g == groups[start])
                    .count();
            let power: Vec<f64> = (start..end)
                .map(|i| areas[i] as f64 * luminance(materials[lights.materials[i] as usize].emit))
                .collect();
            let weights = if power.iter().sum::<f64>() > 0.0 {
                power
            } else {
                areas[start..end].iter().map(|&a| a as f64).collect()
            };
            tables.picks.extend(alias_table(&weights));
            tables.groups.push(LightGroup {
                first: start as u32,
                count: (end - start) as u32,
            });
            start = end;
        }
        let mut only_lights = SceneData::default();
        only_lights.primitives[k] = lights.clone();
        if let Some((bvh, mut leaf_order)) = Bvh::build_order(&only_lights) {
            tables.bvh = bvh;
            tables.refs = std::mem::take(&mut leaf_order[k]);
        }
        tables
    }
}

/// Vose's alias table for `weights` (not all zero): slot `i` keeps its own
/// index with probability `threshold`, else gives `other`, which together
/// pick index `i` with probability `weights[i] / sum`.
fn alias_table(weights: &[f64]) -> Vec<LightPick> {
    let n = weights.len();
    let total: f64 = weights.iter().sum();
    let mut scaled: Vec<f64> = weights.iter().map(|w| w * n as f64 / total).collect();
    let mut table: Vec<LightPick> = weights
        .iter()
        .map(|w| LightPick {
            threshold: 1.0,
            other: 0,
            pmf: (w / total) as f32,
        })
        .collect();
    for (i, pick) in table.iter_mut().enumerate() {
        pick.other = i as u32;
    }
    let (mut small, mut large): (Vec<usize>, Vec<usize>) = (0..n).partition(|&i| scaled[i] < 1.0);
    while let (Some(&s), Some(&l)) = (small.last(), large.last()) {
        small.pop();
        table[s].threshold = scaled[s] as f32;
        table[s].other = l as u32;
        scaled[l] -= 1.0 - scaled[s];
        if scaled[l] < 1.0 {
            large.pop();
            small.push(l);
        }
    }
    // What is left is 1 up to rounding: those slots keep their own index.
    table
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The probability the table gives each index, summed over its slots.
    fn realised(table: &[LightPick]) -> Vec<f64> {
        let n = table.len() as f64;
        let mut p = vec![0.0; table.len()];
        for (i, pick) in table.iter().enumerate() {
            p[i] += pick.threshold as f64 / n;
            p[pick.other as usize] += (1.0 - pick.threshold as f64) / n;
        }
        p
    }

    #[test]
    fn alias_tables_pick_in_proportion_to_the_weights() {
        let cases: [&[f64]; 5] = [
            &[1.0],
            &[1.0, 1.0, 1.0],
            &[1.0, 0.0, 3.0],
            &[1e-6, 5.0, 2.0, 0.5, 9.0, 0.0, 1.0],
            &[0.25; 100],
        ];
        for weights in cases {
            let total: f64 = weights.iter().sum();
            let table = alias_table(weights);
            for (i, (&w, p)) in weights.iter().zip(realised(&table)).enumerate() {
                assert!((p - w / total).abs() < 1e-6, "{weights:?}[{i}]: {p}");
                assert!((table[i].pmf as f64 - w / total).abs() < 1e-7);
            }
        }
    }
}
