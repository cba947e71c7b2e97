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
    // Rounded outward to f32, so the box holds every point of the group.
    let down = |x: f64| {
        let f = x as f32;
        if f64::from(f) > x { f.next_down() } else { f }
    };
    let up = |x: f64| {
        let f = x as f32;
        if f64::from(f) < x { f.next_up() } else { f }
    };
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
