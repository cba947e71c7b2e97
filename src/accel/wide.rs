//! The 4-wide BVH the kernel walks for closest hits: the binary SAH BVH
//! (`Bvh`) collapsed so that a node holds up to four children, each opened in
//! turn from the binary children by largest surface area (the standard
//! collapse; Wald et al. 2008). On lavapipe a node visit is one loop iteration
//! and one load instruction per vector, whatever its width, so four boxes
//! read as structure-of-arrays vectors cost fewer iterations and loads than
//! the binary walk's pairs of boxes. Leaves stay ranges of one kind's array,
//! encoded as in `BvhNode`.

use super::{Bvh, BvhNode, MAX_DEPTH};
use crate::gpu::layout::{SceneData, gpu_struct};
use glam::Vec3;
use std::time::Instant;

/// Children per node.
pub const WIDTH: usize = 4;

/// Most nodes: the kernel's stack entry keeps a node's index above 8 bits of
/// pending children (`wide_bvh_entry`).
pub const MAX_NODES: usize = 1 << 24;

gpu_struct! {
    /// Four children: component i of each field is child i's. Boxes as
    /// structure of arrays; an interior child is node `first` with `count` 0,
    /// a leaf is `first` and `count` as in a `BvhNode` leaf. An empty slot has
    /// an inverted box (min +inf, max -inf), which the kernel's slab test,
    /// taking each axis's near plane by the ray's sign, never enters.
    pub struct WideBvhNode {
        pub min_x: [f32; 4],
        pub min_y: [f32; 4],
        pub min_z: [f32; 4],
        pub max_x: [f32; 4],
        pub max_y: [f32; 4],
        pub max_z: [f32; 4],
        pub first: [u32; 4],
        pub count: [u32; 4],
    }
}

impl WideBvhNode {
    const EMPTY: WideBvhNode = WideBvhNode {
        min_x: [f32::INFINITY; 4],
        min_y: [f32::INFINITY; 4],
        min_z: [f32::INFINITY; 4],
        max_x: [f32::NEG_INFINITY; 4],
        max_y: [f32::NEG_INFINITY; 4],
        max_z: [f32::NEG_INFINITY; 4],
        first: [0; 4],
        count: [0; 4],
    };

    fn set_child(&mut self, slot: usize, child: &BvhNode, first: u32) {
        self.min_x[slot] = child.min[0];
        self.min_y[slot] = child.min[1];
        self.min_z[slot] = child.min[2];
        self.max_x[slot] = child.max[0];
        self.max_y[slot] = child.max[1];
        self.max_z[slot] = child.max[2];
        self.first[slot] = first;
        self.count[slot] = child.count;
    }

    /// Child `slot`'s box.
    pub fn child_bounds(&self, slot: usize) -> (Vec3, Vec3) {
        (
            Vec3::new(self.min_x[slot], self.min_y[slot], self.min_z[slot]),
            Vec3::new(self.max_x[slot], self.max_y[slot], self.max_z[slot]),
        )
    }
}

#[derive(Clone, Debug, Default, PartialEq)]
pub struct WideBvh {
    pub nodes: Vec<WideBvhNode>,
    /// Levels of nodes below the root.
    pub depth: u32,
    pub build_seconds: f64,
}

impl WideBvh {
    /// The wide BVH over every primitive of `data`, whose arrays `Bvh::build`
    /// puts in leaf order; `None` (and `data` unchanged) when it has none.
    pub fn build(data: &mut SceneData) -> Option<WideBvh> {
        let started = Instant::now();
        let binary = Bvh::build(data)?;
        let mut wide = WideBvh::collapse(&binary);
        wide.build_seconds = started.elapsed().as_secs_f64();
        Some(wide)
    }

    /// `binary` collapsed: its leaves, each once, under nodes of up to four children.
    pub fn collapse(binary: &Bvh) -> WideBvh {
        let mut wide = WideBvh::default();
        let root = &binary.nodes[0];
        if root.count == 0 {
            wide.node(binary, 0, 0);
        } else {
            // A single leaf: a root holding it alone.
            let mut node = WideBvhNode::EMPTY;
            node.set_child(0, root, root.first);
            wide.nodes.push(node);
        }
        // The kernel's stack holds an entry per level: `MAX_DEPTH` (`BVH_STACK`)
        // bounds the binary tree's depth and so the collapsed one's.
        assert!(wide.depth < MAX_DEPTH, "depth {}", wide.depth);
        assert!(
            wide.nodes.len() <= MAX_NODES,
            "{} wide BVH nodes: the kernel's stack entries address {MAX_NODES}",
            wide.nodes.len()
        );
        wide
    }

    /// Appends the node for binary interior node `interior` at `depth` and
    /// its subtree, returning its index.
    fn node(&mut self, binary: &Bvh, interior: usize, depth: u32) -> u32 {
        self.depth = self.depth.max(depth);
        let index = self.nodes.len();
        self.nodes.push(WideBvhNode::EMPTY);
        let children_of = |i: usize| [i + 1, binary.nodes[i].first as usize];
        let mut children = children_of(interior).to_vec();
        while children.len() < WIDTH {
            let largest = children
                .iter()
                .enumerate()
                .filter(|&(_, &c)| binary.nodes[c].count == 0)
                .max_by(|a, b| half_area(&binary.nodes[*a.1]).total_cmp(&half_area(&binary.nodes[*b.1])));
            let Some((slot, &open)) = largest else { break };
            children.splice(slot..=slot, children_of(open));
        }
        for (slot, &child) in children.iter().enumerate() {
            let node = &binary.nodes[child];
            let first = match node.count {
                0 => self.node(binary, child, depth + 1),
                _ => node.first,
            };
            self.nodes[index].set_child(slot, node, first);
        }
        index as u32
    }
}

fn half_area(node: &BvhNode) -> f32 {
    let d = (Vec3::from(node.max) - Vec3::from(node.min)).max(Vec3::ZERO);
    d.x * d.y + d.y * d.z + d.z * d.x
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::{LEAF_COUNT_MASK, LEAF_KIND_SHIFT, MAX_LEAF};
    use crate::accel::tests::{box_contains, kind_index, sphere_t, spheres, uniforms};
    use crate::kinds::{PRIMITIVE_KINDS, Sphere};

    /// The kernel's slab test of a node's four children (`wide_bvh_children_t`):
    /// each axis's near plane chosen by the ray's sign; at least `f32::MAX` is a miss.
    fn children_t(node: &WideBvhNode, origin: Vec3, inv_dir: Vec3, t_max: f32) -> [f32; 4] {
        std::array::from_fn(|slot| {
            let (min, max) = node.child_bounds(slot);
            let negative = inv_dir.cmplt(Vec3::ZERO);
            let near = (Vec3::select(negative, max, min) - origin) * inv_dir;
            let far = (Vec3::select(negative, min, max) - origin) * inv_dir;
            let t_near = near.max_element().max(0.0);
            let t_far = far.min_element().min(t_max);
            if t_near <= t_far * 1.0000004 {
                t_near
            } else {
                f32::MAX
            }
        })
    }

    /// Builds the wide BVH over `data` and checks it: every primitive of every
    /// kind in exactly one leaf, each leaf one kind's range, every child box
    /// inside its parent's slot and every primitive inside its leaf's box, the
    /// depth as reported and within the stack.
    fn build_checked(data: &SceneData) -> (WideBvh, SceneData) {
        let mut sorted = data.clone();
        let wide = WideBvh::build(&mut sorted).unwrap();
        let mut covered: Vec<Vec<bool>> = sorted
            .primitives
            .iter()
            .map(|array| vec![false; array.len()])
            .collect();
        let infinite = (Vec3::NEG_INFINITY, Vec3::INFINITY);
        let mut stack = vec![(0usize, 0u32, infinite)];
        let mut deepest = 0;
        while let Some((i, depth, parent)) = stack.pop() {
            deepest = deepest.max(depth);
            let node = &wide.nodes[i];
            for slot in 0..WIDTH {
                let (min, max) = node.child_bounds(slot);
                if min.x == f32::INFINITY {
                    assert!(min.cmpeq(Vec3::INFINITY).all() && max.cmpeq(Vec3::NEG_INFINITY).all());
                    assert_eq!((node.first[slot], node.count[slot]), (0, 0), "empty slot");
                    continue;
                }
                assert!(box_contains(parent, (min, max)), "child box outside its parent");
                if node.count[slot] == 0 {
                    stack.push((node.first[slot] as usize, depth + 1, (min, max)));
                    continue;
                }
                let kind = (node.count[slot] >> LEAF_KIND_SHIFT) as usize;
                let count = (node.count[slot] & LEAF_COUNT_MASK) as usize;
                assert!((1..=MAX_LEAF).contains(&count));
                let layout = PRIMITIVE_KINDS[kind].layout;
                let range = node.first[slot] as usize..node.first[slot] as usize + count;
                for (covered, p) in covered[kind][range.clone()].iter_mut().zip(range) {
                    assert!(!*covered, "primitive {p} in two leaves");
                    *covered = true;
                    let bounds = (PRIMITIVE_KINDS[kind].bounds)(
                        sorted.primitives[kind].element(p, layout.size),
                    );
                    assert!(box_contains((min, max), bounds));
                }
            }
        }
        assert!(covered.iter().flatten().all(|&c| c), "a primitive is in no leaf");
        assert_eq!(deepest, wide.depth);
        assert!(wide.depth < MAX_DEPTH);
        (wide, sorted)
    }

    #[test]
    fn every_primitive_is_in_one_leaf() {
        let grid: Vec<[f32; 3]> = (0..1000)
            .map(|i| [(i % 10) as f32, (i / 10 % 10) as f32, (i / 100) as f32])
            .collect();
        let data = spheres(&grid);
        let (wide, _) = build_checked(&data);
        // About log4(1000 / 4) levels, and most slots filled: a full collapse
        // makes one node of every three binary interior nodes.
        assert!((3..=6).contains(&wide.depth), "depth {}", wide.depth);
        let (binary, _) = Bvh::build_order(&data).unwrap();
        let interior = binary.nodes.iter().filter(|n| n.count == 0).count();
        assert!(wide.nodes.len() <= interior / 2, "{} nodes", wide.nodes.len());
    }

    #[test]
    fn one_leaf_is_a_root_with_one_child() {
        let (wide, _) = build_checked(&spheres(&[[0.0; 3], [1.0, 0.0, 0.0]]));
        assert_eq!(wide.nodes.len(), 1);
        assert_eq!(wide.nodes[0].count[1..], [0; 3]);
    }

    #[test]
    fn coincident_primitives_still_collapse() {
        build_checked(&spheres(&[[1.0, 2.0, 3.0]; 37]));
    }

    /// No ray enters an empty slot, whatever its direction's signs and zeros.
    #[test]
    fn empty_slots_are_never_hit() {
        let mut random = uniforms(3);
        let components = [-1.0, -0.0, 0.0, 1.0];
        for _ in 0..1000 {
            let origin = (Vec3::new(random(), random(), random()) - 0.5) * 1e6;
            let mut dir = Vec3::new(random(), random(), random()) - 0.5;
            // Some directions with zero components of either sign.
            for a in 0..3 {
                if random() < 0.3 {
                    dir[a] = components[(random() * 4.0) as usize];
                }
            }
            for t_max in [1.0, f32::MAX] {
                let t = children_t(&WideBvhNode::EMPTY, origin, dir.recip(), t_max);
                assert!(t.iter().all(|&t| t >= f32::MAX), "ray from {origin} along {dir}");
            }
        }
    }

    /// The kernel's walk (nearest hit child first, the node's other hit ones
    /// one stack entry, taken nearest first; boxes behind the closest hit
    /// culled) finds the same closest sphere as testing every one, with at
    /// most one stack entry per level.
    #[test]
    fn ordered_traversal_finds_the_closest_hit() {
        let mut random = uniforms(11);
        let centers: Vec<[f32; 3]> = (0..2000)
            .map(|_| [40.0 * random(), 40.0 * random(), 40.0 * random()])
            .collect();
        let (wide, sorted) = build_checked(&spheres(&centers));
        let array = &sorted.primitives[kind_index("sphere")];
        let sphere =
            |i: usize| -> Sphere { *bytemuck::from_bytes(array.element(i, size_of::<Sphere>())) };
        let mut hits = 0;
        for _ in 0..2000 {
            let origin = Vec3::new(random(), random(), random()) * 40.0;
            let dir = (Vec3::new(random(), random(), random()) - 0.5).normalize();
            let brute = (0..array.len())
                .filter_map(|i| sphere_t(&sphere(i), origin, dir, f32::MAX).map(|t| (t, i)))
                .min_by(|a, b| a.0.total_cmp(&b.0));
            let inv_dir = dir.recip();
            let mut closest: Option<(f32, usize)> = None;
            // Entries: a node and its pending slots, the nearest last.
            let mut stack: Vec<(usize, Vec<usize>)> = Vec::new();
            let mut link = Some((0u32, 0u32));
            while let Some((first, count)) = link {
                if count == 0 {
                    let node = &wide.nodes[first as usize];
                    let t_max = closest.map_or(f32::MAX, |c| c.0);
                    let t = children_t(node, origin, inv_dir, t_max);
                    let mut order: Vec<usize> = (0..WIDTH).filter(|&s| t[s] < f32::MAX).collect();
                    order.sort_by(|&a, &b| t[b].total_cmp(&t[a]));
                    let nearest = order.pop();
                    if !order.is_empty() {
                        stack.push((first as usize, order));
                        assert!(stack.len() <= wide.depth as usize + 1);
                    }
                    if let Some(slot) = nearest {
                        link = Some((node.first[slot], node.count[slot]));
                        continue;
                    }
                } else {
                    for p in first as usize..(first + (count & LEAF_COUNT_MASK)) as usize {
                        let t_max = closest.map_or(f32::MAX, |c| c.0);
                        if let Some(t) = sphere_t(&sphere(p), origin, dir, t_max) {
                            closest = Some((t, p));
                        }
                    }
                }
                link = stack.last_mut().map(|(index, pending)| {
                    let slot = pending.pop().unwrap();
                    let node = &wide.nodes[*index];
                    (node.first[slot], node.count[slot])
                });
                if stack.last().is_some_and(|(_, pending)| pending.is_empty()) {
                    stack.pop();
                }
            }
            assert_eq!(closest, brute, "ray from {origin} along {dir}");
            hits += brute.is_some() as usize;
        }
        assert!(
            hits > 500,
            "only {hits} rays hit: the test would prove little"
        );
    }
}
