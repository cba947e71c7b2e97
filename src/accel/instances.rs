//! Instancing's two-level BVH: one wide BVH per shape group, built once over
//! the group's primitives in its own space, and the scene's BVH over the
//! scene's primitives and the instances' world boxes, whose instance leaves
//! are ranges of `PackedInstance`s (`INSTANCE_LEAF`). Everything shares the
//! scene's arrays: each group's primitives follow the scene's in their kind's
//! array, its nodes follow the scene's in the node array, and its leaves and
//! interior links are offset to point there. A copy of a group is then one
//! instance record and a share of the top-level nodes, whatever the group's size.

use super::{Bvh, PrimitiveArrays, WideBvh};
use crate::abi::gpu_struct;
use crate::kinds::PRIMITIVE_KINDS;
use glam::{DAffine3, DVec3, Vec3};
use std::time::Instant;

/// The leaf kind of a range of instances: the one past the primitive kinds.
pub const INSTANCE_LEAF: u32 = PRIMITIVE_KINDS.len() as u32;

gpu_struct! {
    /// An instance as the kernel walks it (112 bytes): the rows of its
    /// world-to-object and object-to-world affine matrices, and the root of its
    /// group's BVH. A ray goes into the group's space by `to_object`; the hit
    /// point and the tangents come back by `to_world`, the normals by the
    /// transpose of `to_object`'s linear part (the inverse transpose of
    /// `to_world`'s, as Mitsuba's `instance` carries them).
    pub struct PackedInstance as Instance {
        pub to_object_x: [f32; 4],
        pub to_object_y: [f32; 4],
        pub to_object_z: [f32; 4],
        pub to_world_x: [f32; 4],
        pub to_world_y: [f32; 4],
        pub to_world_z: [f32; 4],
        /// The group's root node in the scene's node array.
        pub root: u32,
        pub _pad0: u32,
        pub _pad1: u32,
        pub _pad2: u32,
    }
}

/// The rows `[linear | translation]` of `affine`, in f32.
fn rows(affine: &DAffine3) -> [[f32; 4]; 3] {
    std::array::from_fn(|r| {
        let row = affine.matrix3.row(r);
        [row.x, row.y, row.z, affine.translation[r]].map(|x| x as f32)
    })
}

impl PackedInstance {
    pub fn new(to_world: &DAffine3, root: u32) -> PackedInstance {
        let [wx, wy, wz] = rows(to_world);
        let [ox, oy, oz] = rows(&to_world.inverse());
        PackedInstance {
            to_object_x: ox,
            to_object_y: oy,
            to_object_z: oz,
            to_world_x: wx,
            to_world_y: wy,
            to_world_z: wz,
            root,
            ..PackedInstance::default()
        }
    }
}

/// The scene's groups and instances as `SceneData::pack` gives them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct InstanceSet {
    /// Each group's primitives, in the group's space (no large ones).
    pub groups: Vec<PrimitiveArrays>,
    /// Each instance's group (index into `groups`) and object-to-world transform.
    pub instances: Vec<(u32, DAffine3)>,
}

/// What the kernel reads of instancing once the BVHs are built.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Instancing {
    /// The instances in the top level's leaf order.
    pub records: Vec<PackedInstance>,
    /// Levels of the deepest group's wide BVH.
    pub group_depth: u32,
}

/// The box in world space of the object-space box `(min, max)` under `to_world`.
fn world_box(to_world: &DAffine3, (min, max): (Vec3, Vec3)) -> (Vec3, Vec3) {
    let mut world = (DVec3::INFINITY, DVec3::NEG_INFINITY);
    for corner in 0..8 {
        let pick = |axis: usize| match corner >> axis & 1 {
            0 => f64::from(min[axis]),
            _ => f64::from(max[axis]),
        };
        let p = to_world.transform_point3(DVec3::new(pick(0), pick(1), pick(2)));
        world = (world.0.min(p), world.1.max(p));
    }
    // Widened by an f32 step before rounding to f32, so the box holds every
    // point of the group.
    let margin = |x: f64| x.abs() * f64::from(f32::EPSILON) + f64::from(f32::MIN_POSITIVE);
    let down = |x: f64| (x - margin(x)) as f32;
    let up = |x: f64| (x + margin(x)) as f32;
    (
        Vec3::new(down(world.0.x), down(world.0.y), down(world.0.z)),
        Vec3::new(up(world.1.x), up(world.1.y), up(world.1.z)),
    )
}

/// The box of a wide BVH's root: the union of its children's.
fn root_box(bvh: &WideBvh) -> (Vec3, Vec3) {
    let root = &bvh.nodes[0];
    (0..super::wide::WIDTH)
        .filter(|&slot| root.occupied(slot))
        .map(|slot| root.child_bounds(slot))
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), (a, b)| {
            (lo.min(a), hi.max(b))
        })
}

impl WideBvh {
    /// The two-level BVH: each group's BVH (over `set.groups[g]`), the scene's
    /// over the primitives of `data` after its large ones and the instances'
    /// world boxes; the groups' primitives and nodes appended to the scene's,
    /// `data` put in leaf order, and the instance records in theirs. An
    /// instance of a group with no primitives is dropped. `None` where there is
    /// nothing to hit.
    pub fn build_instanced(
        data: &mut PrimitiveArrays,
        set: &InstanceSet,
    ) -> Option<(WideBvh, Instancing)> {
        let started = Instant::now();
        let groups: Vec<Option<(PrimitiveArrays, WideBvh)>> = (set.groups.iter())
            .map(|group| {
                let mut sorted = group.clone();
                WideBvh::build(&mut sorted).map(|bvh| (sorted, bvh))
            })
            .collect();
        let instances: Vec<(u32, DAffine3)> = (set.instances.iter())
            .filter(|(group, _)| groups[*group as usize].is_some())
            .copied()
            .collect();
        let boxes: Vec<(Vec3, Vec3)> = (instances.iter())
            .map(|(group, to_world)| {
                let (_, bvh) = groups[*group as usize].as_ref().expect("kept above");
                world_box(to_world, root_box(bvh))
            })
            .collect();
        let (binary, mut leaf_order) = Bvh::build_order_with_instances(data, &boxes)?;
        let instance_order = match instances.is_empty() {
            true => Vec::new(),
            false => leaf_order.pop().expect("the instances' order is last"),
        };
        for (k, order) in leaf_order.iter().enumerate() {
            data.reorder(k, order);
        }
        let mut wide = WideBvh::collapse(&binary);
        let mut roots = Vec::with_capacity(groups.len());
        let mut group_depth = 0;
        for group in &groups {
            let Some((arrays, bvh)) = group else {
                roots.push(None);
                continue;
            };
            let node_offset = wide.nodes.len() as u32;
            let primitive_offsets: Vec<u32> = (data.primitives.iter())
                .map(|array| array.len() as u32)
                .collect();
            for node in &bvh.nodes {
                let mut node = *node;
                let occupied: Vec<usize> = (0..super::wide::WIDTH)
                    .filter(|&slot| node.occupied(slot))
                    .collect();
                for slot in occupied {
                    let [first, count] = &mut node.links[slot];
                    *first += match *count {
                        0 => node_offset,
                        _ => primitive_offsets[(*count >> super::LEAF_KIND_SHIFT) as usize],
                    };
                }
                wide.nodes.push(node);
            }
            data.append(arrays);
            roots.push(Some(node_offset));
            group_depth = group_depth.max(bvh.depth);
        }
        assert!(
            wide.nodes.len() <= super::wide::MAX_NODES,
            "{} wide BVH nodes: the kernel's stack entries address {}",
            wide.nodes.len(),
            super::wide::MAX_NODES
        );
        let records = (instance_order.iter())
            .map(|&i| {
                let (group, to_world) = &instances[i as usize];
                PackedInstance::new(to_world, roots[*group as usize].expect("kept above"))
            })
            .collect();
        wide.build_seconds = started.elapsed().as_secs_f64();
        Some((
            wide,
            Instancing {
                records,
                group_depth,
            },
        ))
    }
}

impl PrimitiveArrays {
    /// Appends `other`'s primitives and the arrays indexed like them after
    /// this one's, kind by kind (`SceneData::pack` gives both shading normals
    /// for a kind, or neither; both texture coordinates, or neither).
    pub fn append(&mut self, other: &PrimitiveArrays) {
        for k in 0..PRIMITIVE_KINDS.len() {
            let (array, added) = (&mut self.primitives[k], &other.primitives[k]);
            array.bytes.extend_from_slice(&added.bytes);
            array.materials.extend_from_slice(&added.materials);
            for (own, theirs) in [
                (&mut self.normals[k], &other.normals[k]),
                (&mut self.uvs[k], &other.uvs[k]),
            ] {
                own.extend_from_slice(theirs);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::tests::{kind_index, sphere_t, spheres, uniforms};
    use crate::accel::{LEAF_COUNT_MASK, LEAF_KIND_SHIFT};
    use crate::kinds::PackedSphere;
    use glam::{DMat3, DQuat};

    fn sphere_at(data: &PrimitiveArrays, i: usize) -> PackedSphere {
        let k = kind_index("sphere");
        *bytemuck::from_bytes(data.primitives[k].element(i, size_of::<PackedSphere>()))
    }

    /// Whether the ray enters the box before `t_max`.
    fn enters(min: Vec3, max: Vec3, origin: Vec3, dir: Vec3, t_max: f32) -> bool {
        let (a, b) = ((min - origin) / dir, (max - origin) / dir);
        let near = a.min(b).max_element().max(0.0);
        near <= a.max(b).min_element().min(t_max) * 1.0000004
    }

    /// The closest sphere along a ray through the two-level BVH, walked as the
    /// kernel does (an instance leaf carries the ray into its group's space,
    /// unit length again, distances scaled): its world distance and material.
    fn two_level_hit(
        bvh: &WideBvh,
        data: &PrimitiveArrays,
        records: &[PackedInstance],
        origin: Vec3,
        dir: Vec3,
    ) -> Option<(f32, u32)> {
        // Nodes to visit: the node, the ray in its space, and that space's scale.
        let mut stack = vec![(0u32, origin, dir, 1.0f32, false)];
        let mut closest: Option<(f32, u32)> = None;
        while let Some((index, origin, dir, scale, in_group)) = stack.pop() {
            let node = &bvh.nodes[index as usize];
            for slot in (0..super::super::wide::WIDTH).filter(|&s| node.occupied(s)) {
                let t_max = closest.map_or(f32::MAX, |c| c.0 * scale);
                let (min, max) = node.child_bounds(slot);
                if !enters(min, max, origin, dir, t_max) {
                    continue;
                }
                let [first, count] = node.links[slot];
                let (kind, n) = (count >> LEAF_KIND_SHIFT, count & LEAF_COUNT_MASK);
                match (count, kind) {
                    (0, _) => stack.push((first, origin, dir, scale, in_group)),
                    (_, INSTANCE_LEAF) => {
                        assert!(!in_group, "an instance leaf in a group's BVH");
                        for record in &records[first as usize..(first + n) as usize] {
                            let row = |r: [f32; 4]| Vec3::new(r[0], r[1], r[2]);
                            let [x, y, z] =
                                [record.to_object_x, record.to_object_y, record.to_object_z];
                            let to_object = |v: Vec3, w: f32| {
                                Vec3::new(
                                    row(x).dot(v) + w * x[3],
                                    row(y).dot(v) + w * y[3],
                                    row(z).dot(v) + w * z[3],
                                )
                            };
                            let object_dir = to_object(dir, 0.0);
                            let length = object_dir.length();
                            stack.push((
                                record.root,
                                to_object(origin, 1.0),
                                object_dir / length,
                                length,
                                true,
                            ));
                        }
                    }
                    _ => {
                        for p in first..first + n {
                            let t_max = closest.map_or(f32::MAX, |c| c.0 * scale);
                            let sphere = sphere_at(data, p as usize);
                            if let Some(t) = sphere_t(&sphere, origin, dir, t_max) {
                                closest = Some((t / scale, sphere.material));
                            }
                        }
                    }
                }
            }
        }
        closest
    }

    /// Fifty copies of a group of 200 spheres, rotated, scaled and moved, beside
    /// 100 spheres of the scene's own: the group's primitives are stored once
    /// (after the scene's, in one array), an instance is one record, and every
    /// ray finds through the two levels the closest hit that testing every
    /// sphere of the scene written out flat finds.
    #[test]
    fn two_levels_find_the_hits_of_the_scene_written_out_flat() {
        let mut random = uniforms(17);
        let group_centers: Vec<[f32; 3]> = (0..200)
            .map(|_| [random(), random(), random()].map(|u| 4.0 * u))
            .collect();
        let own_centers: Vec<[f32; 3]> = (0..100)
            .map(|_| [random(), random(), random()].map(|u| 40.0 * u))
            .collect();
        let mut own = spheres(&own_centers);
        // The scene's spheres' materials after the group's, to tell them apart.
        let k = kind_index("sphere");
        own.primitives[k].map_u32(size_of::<PackedSphere>(), 16, |m| m + 1000);
        let set = InstanceSet {
            groups: vec![spheres(&group_centers)],
            instances: (0..50)
                .map(|_| {
                    let axis = DVec3::new(random().into(), random().into(), random().into());
                    let rotation =
                        DQuat::from_axis_angle((axis - 0.5).normalize(), f64::from(random()) * 6.0);
                    let linear = DMat3::from_quat(rotation) * (0.5 + f64::from(random()) * 1.5);
                    let translation =
                        DVec3::new(random().into(), random().into(), random().into()) * 40.0;
                    (0, DAffine3::from_mat3_translation(linear, translation))
                })
                .collect(),
        };
        let mut data = own.clone();
        let (bvh, instancing) = WideBvh::build_instanced(&mut data, &set).unwrap();
        assert_eq!(
            data.primitives[k].len(),
            300,
            "the group's spheres are stored once"
        );
        assert_eq!(instancing.records.len(), 50);
        assert!(instancing.group_depth > 0);
        let roots: Vec<u32> = instancing.records.iter().map(|r| r.root).collect();
        assert!(roots.iter().all(|&r| r == roots[0] && r as usize > 0));
        // The scene written out flat: every copy's spheres in world space.
        let mut flat: Vec<(Vec3, f32, u32)> = (0..100)
            .map(|i| {
                let s = sphere_at(&own, i);
                (Vec3::from(s.center), s.radius, s.material)
            })
            .collect();
        for (_, to_world) in &set.instances {
            let scale = to_world.matrix3.x_axis.length();
            for (i, &center) in group_centers.iter().enumerate() {
                let center = to_world.transform_point3(Vec3::from(center).as_dvec3());
                flat.push((center.as_vec3(), (0.5 * scale) as f32, i as u32));
            }
        }
        let mut hits = 0;
        for _ in 0..2000 {
            let origin = Vec3::new(random(), random(), random()) * 40.0;
            let dir = (Vec3::new(random(), random(), random()) - 0.5).normalize();
            let brute = (flat.iter())
                .filter_map(|&(center, radius, material)| {
                    let sphere = PackedSphere {
                        center: center.to_array(),
                        radius,
                        ..PackedSphere::default()
                    };
                    Some((sphere_t(&sphere, origin, dir, f32::MAX)?, material))
                })
                .min_by(|a, b| a.0.total_cmp(&b.0));
            let found = two_level_hit(&bvh, &data, &instancing.records, origin, dir);
            match (brute, found) {
                (None, None) => {}
                (Some((t, m)), Some((u, n))) => {
                    assert!(
                        (t - u).abs() <= 1e-4 * t.max(1.0),
                        "ray from {origin} along {dir}: {t} {u}"
                    );
                    assert_eq!(m, n, "ray from {origin} along {dir}");
                    hits += 1;
                }
                _ => panic!("ray from {origin} along {dir}: {brute:?} against {found:?}"),
            }
        }
        assert!(
            hits > 500,
            "only {hits} rays hit: the test would prove little"
        );
    }

    /// Without instances the two-level build is the scene's BVH as before.
    #[test]
    fn no_instances_build_the_one_level_bvh() {
        let mut random = uniforms(3);
        let centers: Vec<[f32; 3]> = (0..300)
            .map(|_| [random(), random(), random()].map(|u| 10.0 * u))
            .collect();
        let (mut one, mut two) = (spheres(&centers), spheres(&centers));
        let mut bvh = WideBvh::build(&mut one).unwrap();
        let (mut instanced, instancing) =
            WideBvh::build_instanced(&mut two, &InstanceSet::default()).unwrap();
        (bvh.build_seconds, instanced.build_seconds) = (0.0, 0.0);
        assert_eq!((bvh, one), (instanced, two));
        assert!(instancing.records.is_empty());
    }
}
