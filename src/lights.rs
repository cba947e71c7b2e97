//! The light density's tables for kinds whose lights come in groups (a mesh's
//! faces, `PrimitiveKind::grouped_lights`): each group is one entry of the
//! uniform pick among the light density's objects, and within it a primitive is
//! picked in proportion to its power by an alias table (Walker 1977, Vose 1991)
//! in O(1). The density of a direction sums every primitive of the kind the ray
//! meets, found through a BVH over the light primitives alone, so evaluating it
//! costs O(log n), not O(n) (a few are tested each instead). Next-event
//! estimation over many faces weighs by the density of the point hit, with no
//! walk. (`kernel::GroupedDensity`.)
//!
//! Also the point and spot lights ([`DeltaLight`]), which are no part of the
//! light density: the kernel sends them shadow rays of their own.

use crate::abi::{PackedMaterial, gpu_struct};
use crate::accel::PrimitiveArrays;
use crate::accel::{Bvh, WideBvh};
use crate::kinds::PackedArray;
use crate::scene::PointLight;
use crate::stats::luminance_f64;
use glam::Vec3;
use std::sync::OnceLock;

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

gpu_struct! {
    /// A leaf entry of the light BVH (`LightBvh::refs`): a light primitive and
    /// its `LightPick::pmf`, together so the density's walk reads both in one
    /// load where it read the index, then the pick.
    pub struct LightRef {
        /// Index in the kind's light array.
        pub light: u32,
        pub pmf: f32,
    }
}

gpu_struct! {
    /// A point, spot or directional light as the kernel reads it
    /// (`shaders/delta_lights.wgsl`). A point light is a spot whose cone covers
    /// every direction; a directional one has `infinite` set.
    pub struct DeltaLight {
        pub position: [f32; 3],
        /// Cosine of the cutoff angle: dark at and beyond it (-2 for a point light).
        pub cos_cutoff: f32,
        pub intensity: [f32; 3],
        /// Cosine of the beam width: full intensity at and within it.
        pub cos_beam: f32,
        /// The cone's axis (unit).
        pub direction: [f32; 3],
        /// The cutoff angle in radians.
        pub cutoff: f32,
        /// 1 / (cutoff - beam width) in radians; 0 where they are equal (then unused).
        pub inv_transition: f32,
        /// The probability of picking this light at a vertex.
        pub pmf: f32,
        /// The probabilities of the lights up to this one, included (1 for the last).
        pub cdf: f32,
        /// 1 for a directional light (at infinity, shining along `direction`,
        /// `intensity` its irradiance), else 0.
        pub infinite: f32,
    }
}

/// The packed delta lights, each picked in proportion to its power: the
/// intensity's luminance times the solid angle it lights (a spot's counted to
/// the middle of its falloff). Lights that all have no power are picked uniformly.
pub fn pack_delta_lights(lights: &[PointLight], extent: f32) -> Vec<DeltaLight> {
    let power: Vec<f64> = lights
        .iter()
        .map(|l| {
            if l.directional.is_some() {
                // Mitsuba's: its irradiance over the scene's bounding disk.
                let radius = extent as f64;
                return luminance_f64(l.intensity.to_array().map(f64::from))
                    * std::f64::consts::PI
                    * radius
                    * radius;
            }
            let solid_angle = match l.spot {
                None => 4.0 * std::f64::consts::PI,
                Some(spot) => {
                    let middle = 0.5 * (spot.cutoff_angle as f64 + spot.beam_width as f64);
                    2.0 * std::f64::consts::PI * (1.0 - middle.to_radians().cos())
                }
            };
            luminance_f64(l.intensity.to_array().map(f64::from)) * solid_angle
        })
        .collect();
    let total: f64 = power.iter().sum();
    let mut cumulative = 0.0;
    lights
        .iter()
        .zip(&power)
        .enumerate()
        .map(|(i, (l, &p))| {
            let pmf = if total > 0.0 {
                p / total
            } else {
                1.0 / lights.len() as f64
            };
            cumulative += pmf;
            // As Mitsuba computes them: f32 radians, then cosines.
            let (cos_cutoff, cos_beam, direction, cutoff, inv_transition) = match l.spot {
                None => (
                    -2.0,
                    -2.0,
                    l.directional.unwrap_or(Vec3::Z).to_array(),
                    0.0,
                    0.0,
                ),
                Some(spot) => {
                    let (cutoff, beam) =
                        (spot.cutoff_angle.to_radians(), spot.beam_width.to_radians());
                    let inv = if cutoff > beam {
                        1.0 / (cutoff - beam)
                    } else {
                        0.0
                    };
                    (
                        cutoff.cos(),
                        beam.cos(),
                        spot.direction.to_array(),
                        cutoff,
                        inv,
                    )
                }
            };
            DeltaLight {
                position: l.position.to_array(),
                cos_cutoff,
                intensity: l.intensity.to_array(),
                cos_beam,
                direction,
                cutoff,
                inv_transition,
                pmf: pmf as f32,
                cdf: if i + 1 == lights.len() {
                    1.0
                } else {
                    cumulative as f32
                },
                infinite: if l.directional.is_some() { 1.0 } else { 0.0 },
            }
        })
        .collect()
}

/// The tables of one grouped kind's lights.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LightTables {
    pub groups: Vec<LightGroup>,
    /// One per light primitive, in the light array's order.
    pub picks: Vec<LightPick>,
    /// Built where a kernel walks it (`SceneData::light_bvh`), once.
    pub walk: OnceLock<LightBvh>,
}

/// The BVH through which a direction's density finds the lights of a grouped
/// kind that the line meets (`kernel::GroupedDensity::Walk`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LightBvh {
    /// Over the light primitives, which it leaves in place (groups are
    /// contiguous there): its leaves are ranges of `refs`.
    pub bvh: WideBvh,
    /// The lights in the BVH's leaf order (`Bvh::build_order`), with their picks' pmf.
    pub refs: Vec<LightRef>,
}

impl LightBvh {
    /// Over `lights`, the light primitives of kind `k`, whose picks are `picks`.
    pub fn build(k: usize, lights: &PackedArray, picks: &[LightPick]) -> LightBvh {
        let mut only_lights = PrimitiveArrays::default();
        only_lights.primitives[k] = lights.clone();
        let (bvh, leaf_order) =
            Bvh::build_order(&only_lights).expect("a grouped kind's tables have lights");
        LightBvh {
            bvh: WideBvh::collapse(&bvh),
            refs: (leaf_order[k].iter())
                .map(|&light| LightRef {
                    light,
                    pmf: picks[light as usize].pmf,
                })
                .collect(),
        }
    }
}

impl LightTables {
    /// The tables of the light primitives `lights` of kind `k`, with `groups[i]`
    /// and `areas[i]` the group and area of light `i` (a group's lights are
    /// contiguous). A light's power is its area times its emission's luminance;
    /// a group that does not emit (`importance = true` only) is weighed by area.
    pub fn build(
        lights: &PackedArray,
        groups: &[u32],
        areas: &[f32],
        materials: &[PackedMaterial],
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
                .map(|i| {
                    areas[i] as f64
                        * luminance_f64(materials[lights.materials[i] as usize].emit.map(f64::from))
                })
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
    fn delta_lights_are_picked_by_power() {
        use crate::scene::Spot;
        use glam::Vec3;
        let point = |i: f32| PointLight {
            position: Vec3::ZERO,
            intensity: Vec3::splat(i),
            spot: None,
            directional: None,
        };
        let packed = pack_delta_lights(&[point(1.0), point(3.0), point(0.0)], 1.0);
        let pmf: Vec<f32> = packed.iter().map(|l| l.pmf).collect();
        let cdf: Vec<f32> = packed.iter().map(|l| l.cdf).collect();
        assert_eq!(pmf, [0.25, 0.75, 0.0]);
        assert_eq!(cdf, [0.25, 1.0, 1.0]);
        let dark = pack_delta_lights(&[point(0.0), point(0.0)], 1.0);
        assert_eq!((dark[0].pmf, dark[1].cdf), (0.5, 1.0));
        // A spot of 90 degrees lights half the sphere a point light does.
        let spot = PointLight {
            spot: Some(Spot {
                direction: Vec3::Z,
                cutoff_angle: 90.0,
                beam_width: 90.0,
            }),
            ..point(1.0)
        };
        let packed = pack_delta_lights(&[point(1.0), spot], 1.0);
        assert!((packed[0].pmf - 2.0 / 3.0).abs() < 1e-6, "{packed:?}");
        assert_eq!(packed[1].inv_transition, 0.0);
        // A directional light's power: its irradiance over the disk of the
        // scene's extent (pi 2^2 against 4 pi: an even pick).
        let sun = PointLight {
            directional: Some(Vec3::NEG_Y),
            ..point(1.0)
        };
        let packed = pack_delta_lights(&[point(1.0), sun], 2.0);
        assert!((packed[1].pmf - 0.5).abs() < 1e-6, "{packed:?}");
        assert_eq!((packed[0].infinite, packed[1].infinite), (0.0, 1.0));
        assert_eq!(packed[1].direction, [0.0, -1.0, 0.0]);
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
