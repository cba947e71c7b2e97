//! The 4-wide BVH the kernel walks for closest hits: the binary SAH BVH
//! (`Bvh`) collapsed so that a node holds up to four children, each opened in
//! turn from the binary children by largest surface area (the standard
//! collapse; Wald et al. 2008), with the children's boxes quantised to bytes
//! (as in Ylitie et al. 2017). On lavapipe a node visit costs about one loop
//! over the SIMD lanes per load instruction, whatever its width: a visit here
//! loads three vectors (four boxes) and the chosen child's link, where the
//! binary walk loaded two whole nodes per pair of boxes. Leaves stay ranges of
//! one kind's array, encoded as in `BvhNode`.

use super::{Bounds, Bvh, BvhNode, LEAF_COUNT_MASK, MAX_DEPTH};
use crate::abi::gpu_struct;
use crate::accel::PrimitiveArrays;
use glam::Vec3;
use std::time::Instant;

/// Children per node.
pub const WIDTH: usize = 4;

/// Most nodes: the kernel's stack entry keeps a node's index above 8 bits of
/// pending children (`wide_bvh_entry`).
pub const MAX_NODES: usize = 1 << 24;

gpu_struct! {
    /// Four children (child i in component, byte or link i of each field), 80 bytes:
    /// their boxes quantised to a grid over the node's box (Ylitie et al.
    /// 2017): plane = `origin + q * 2^(e - 127)` for a byte `q` and the axis's
    /// biased exponent `e`, rounded outward. An interior child is node `first`
    /// (`count` 0), a leaf is `first` and `count` as in a `BvhNode` leaf; an
    /// empty slot is missing from `occupied`, which the kernel's box test reads.
    pub struct WideBvhNode {
        /// Quantised min x, min y, min z and max x, a byte per child.
        pub planes_a: [u32; 4],
        /// Quantised max y and max z, a byte per child; the three exponents
        /// (x in the lowest byte); the occupied slots' bits (`OCCUPIED`). One
        /// vector, so one load.
        pub planes_b: [u32; 4],
        /// The node's box's minimum corner (`w` unused, 0).
        pub origin: [f32; 4],
        /// Child i's `[first, count]`, together so the kernel reads a link in
        /// one load (separate `first` and `count` vectors took two, and 1.06x
        /// and 1.12x the CPU time on the bunny box and on 4 000 spheres).
        pub links: [[u32; 2]; 4],
    }
}

/// Where `planes_b` keeps the exponents and the occupied slots' bits.
const EXPONENTS: usize = 2;
const OCCUPIED: usize = 3;

impl WideBvhNode {
    /// The grid's scale along `axis`.
    fn scale(&self, axis: usize) -> f32 {
        f32::from_bits((self.planes_b[EXPONENTS] >> (8 * axis) & 0xff) << 23)
    }

    pub fn occupied(&self, slot: usize) -> bool {
        self.planes_b[OCCUPIED] >> slot & 1 == 1
    }

    /// Child `slot`'s box as the kernel reads it (`wide_bvh_children_t`).
    pub fn child_bounds(&self, slot: usize) -> (Vec3, Vec3) {
        let byte = |word: u32| (word >> (8 * slot) & 0xff) as f32;
        let [a, b] = [self.planes_a, self.planes_b];
        let plane = |axis: usize, word: u32| self.origin[axis] + byte(word) * self.scale(axis);
        (
            Vec3::new(plane(0, a[0]), plane(1, a[1]), plane(2, a[2])),
            Vec3::new(plane(0, a[3]), plane(1, b[0]), plane(2, b[1])),
        )
    }

    /// The node over `children` (boxes and links), at most `WIDTH`.
    fn quantised(children: &[((Vec3, Vec3), u32, u32)]) -> WideBvhNode {
        let origin = children.iter().fold(Vec3::INFINITY, |m, c| m.min(c.0.0));
        let top = children
            .iter()
            .fold(Vec3::NEG_INFINITY, |m, c| m.max(c.0.1));
        let mut node = WideBvhNode {
            origin: [origin.x, origin.y, origin.z, 0.0],
            ..WideBvhNode::default()
        };
        for axis in 0..3 {
            node.planes_b[EXPONENTS] |= grid_exponent(origin[axis], top[axis]) << (8 * axis);
        }
        for (slot, &((min, max), first, count)) in children.iter().enumerate() {
            let shift = 8 * slot;
            let scale: [f32; 3] = std::array::from_fn(|axis| node.scale(axis));
            for axis in 0..3 {
                node.planes_a[axis] |= quantise_down(origin[axis], scale[axis], min[axis]) << shift;
            }
            node.planes_a[3] |= quantise_up(origin.x, scale[0], max.x) << shift;
            node.planes_b[0] |= quantise_up(origin.y, scale[1], max.y) << shift;
            node.planes_b[1] |= quantise_up(origin.z, scale[2], max.z) << shift;
            node.planes_b[OCCUPIED] |= 1 << slot;
            node.links[slot] = [first, count];
        }
        node
    }
}

/// The smallest biased exponent whose grid of 255 steps from `origin` reaches
/// `top` in f32 arithmetic as the kernel does it (the product is exact).
fn grid_exponent(origin: f32, top: f32) -> u32 {
    // The exponent of the step the extent needs, less one for rounding.
    let guess = (((top - origin) / 255.0).to_bits() >> 23).clamp(2, 254) - 1;
    (guess..255)
        .find(|&e| origin + 255.0 * f32::from_bits(e << 23) >= top)
        .expect("a finite box fits a grid of 255 steps")
}

/// The largest byte whose plane is at most `x` (the grid starts at `origin` <= `x`).
fn quantise_down(origin: f32, scale: f32, x: f32) -> u32 {
    let mut q = (((x - origin) / scale).floor() as u32).min(255);
    while q > 0 && origin + q as f32 * scale > x {
        q -= 1;
    }
    q
}

/// The smallest byte whose plane is at least `x` (within the grid's reach).
fn quantise_up(origin: f32, scale: f32, x: f32) -> u32 {
    let mut q = (((x - origin) / scale).ceil().max(0.0) as u32).min(255);
    while q < 255 && origin + (q as f32) * scale < x {
        q += 1;
    }
    q
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
    pub fn build(data: &mut PrimitiveArrays) -> Option<WideBvh> {
        let started = Instant::now();
        let binary = Bvh::build(data)?;
        let mut wide = WideBvh::collapse(&binary);
        wide.build_seconds = started.elapsed().as_secs_f64();
        Some(wide)
    }

    /// The loop steps of the kernel's walk (`kernel::glue::wide_bvh_walk`: a
    /// step per node visited and per leaf reached, one per leaf left and one per
    /// primitive tested) for a line through the root's box that opens every box
    /// it crosses, on average over uniformly random such lines: a box is
    /// crossed with the probability its surface area bears to the root's
    /// (Crofton). The closest hit's walk skips boxes beyond its hit, so this
    /// bounds its mean from above; boxes that overlap much (long, thin faces
    /// across the scene, rotated) raise it.
    pub fn expected_steps(&self) -> f64 {
        let Some(root) = self.nodes.first() else {
            return 0.0;
        };
        fn slots(node: &WideBvhNode) -> impl Iterator<Item = usize> + '_ {
            (0..WIDTH).filter(|&slot| node.occupied(slot))
        }
        let child = |node: &WideBvhNode, slot: usize| {
            let (min, max) = node.child_bounds(slot);
            Bounds { min, max }
        };
        let root_area = slots(root)
            .map(|slot| child(root, slot))
            .fold(Bounds::EMPTY, Bounds::grow)
            .half_area();
        if root_area <= 0.0 {
            return self.nodes.len() as f64;
        }
        let mut steps = 1.0;
        for node in &self.nodes {
            for slot in slots(node) {
                let crossed = f64::from(child(node, slot).half_area() / root_area);
                let count = f64::from(node.links[slot][1] & LEAF_COUNT_MASK);
                steps += crossed * if count == 0.0 { 1.0 } else { 2.0 + count };
            }
        }
        steps
    }

    /// `binary` collapsed: its leaves, each once, under nodes of up to four children.
    pub fn collapse(binary: &Bvh) -> WideBvh {
        let mut wide = WideBvh::default();
        let root = &binary.nodes[0];
        if root.count == 0 {
            wide.node(binary, 0, 0);
        } else {
            // A single leaf: a root holding it alone.
            let bounds = (Vec3::from(root.min), Vec3::from(root.max));
            wide.nodes
                .push(WideBvhNode::quantised(&[(bounds, root.first, root.count)]));
        }
        // The kernel's stack holds an entry per level (`KernelConfig::bvh_stack`):
        // `MAX_DEPTH` bounds the binary tree's depth and so the collapsed one's.
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
        self.nodes.push(WideBvhNode::default());
        let children_of = |i: usize| [i + 1, binary.nodes[i].first as usize];
        let mut children = [0; WIDTH];
        [children[0], children[1]] = children_of(interior);
        let mut len = 2;
        while len < WIDTH {
            let largest = children[..len]
                .iter()
                .enumerate()
                .filter(|&(_, &c)| binary.nodes[c].count == 0)
                .max_by(|a, b| {
                    half_area(&binary.nodes[*a.1]).total_cmp(&half_area(&binary.nodes[*b.1]))
                });
            let Some((slot, &open)) = largest else { break };
            [children[slot], children[len]] = children_of(open);
            len += 1;
        }
        let mut links = [((Vec3::ZERO, Vec3::ZERO), 0, 0); WIDTH];
        for (link, &child) in links.iter_mut().zip(&children[..len]) {
            let node = &binary.nodes[child];
            let first = match node.count {
                0 => self.node(binary, child, depth + 1),
                _ => node.first,
            };
            *link = (
                (Vec3::from(node.min), Vec3::from(node.max)),
                first,
                node.count,
            );
        }
        self.nodes[index] = WideBvhNode::quantised(&links[..len]);
        index as u32
    }
}

fn half_area(node: &BvhNode) -> f32 {
    let (min, max) = (Vec3::from(node.min), Vec3::from(node.max));
    Bounds { min, max }.half_area()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::tests::{assert_walk_finds_closest_hits, box_contains, spheres, uniforms};
    use crate::accel::{LEAF_COUNT_MASK, LEAF_KIND_SHIFT, MAX_LEAF};
    use crate::kinds::PRIMITIVE_KINDS;

    /// The kernel's slab test of a node's four children (`wide_bvh_children_t`):
    /// each axis's near plane chosen by the ray's sign, empty slots missed; at
    /// least `f32::MAX` is a miss.
    fn children_t(node: &WideBvhNode, origin: Vec3, inv_dir: Vec3, t_max: f32) -> [f32; 4] {
        std::array::from_fn(|slot| {
            let (min, max) = node.child_bounds(slot);
            let negative = inv_dir.cmplt(Vec3::ZERO);
            let near = (Vec3::select(negative, max, min) - origin) * inv_dir;
            let far = (Vec3::select(negative, min, max) - origin) * inv_dir;
            let t_near = near.max_element().max(0.0);
            let t_far = far.min_element().min(t_max);
            if node.occupied(slot) && t_near <= t_far * 1.0000004 {
                t_near
            } else {
                f32::MAX
            }
        })
    }

    /// Builds the wide BVH over `data` and checks it: every primitive of every
    /// kind in exactly one leaf, each leaf one kind's range, every primitive
    /// inside the box (as the kernel reads it) of each slot above it, empty
    /// slots without links, the depth as reported and within the stack.
    fn build_checked(data: &PrimitiveArrays) -> (WideBvh, PrimitiveArrays) {
        let mut sorted = data.clone();
        let wide = WideBvh::build(&mut sorted).unwrap();
        let mut covered: Vec<Vec<bool>> = sorted
            .primitives
            .iter()
            .map(|array| vec![false; array.len()])
            .collect();
        // Nodes to check, with their depth and the boxes of the slots above them.
        let mut stack = vec![(0usize, 0u32, Vec::new())];
        let mut deepest = 0;
        while let Some((i, depth, above)) = stack.pop() {
            deepest = deepest.max(depth);
            let node = &wide.nodes[i];
            assert_eq!(node.origin[3], 0.0);
            for slot in 0..WIDTH {
                if !node.occupied(slot) {
                    assert_eq!(node.links[slot], [0, 0], "empty slot");
                    continue;
                }
                let mut boxes = above.clone();
                boxes.push(node.child_bounds(slot));
                let [first, count] = node.links[slot];
                if count == 0 {
                    stack.push((first as usize, depth + 1, boxes));
                    continue;
                }
                let kind = (count >> LEAF_KIND_SHIFT) as usize;
                let count = (count & LEAF_COUNT_MASK) as usize;
                assert!((1..=MAX_LEAF).contains(&count));
                let layout = PRIMITIVE_KINDS[kind].layout;
                let range = first as usize..first as usize + count;
                for (covered, p) in covered[kind][range.clone()].iter_mut().zip(range) {
                    assert!(!*covered, "primitive {p} in two leaves");
                    *covered = true;
                    let bounds = (PRIMITIVE_KINDS[kind].bounds)(
                        sorted.primitives[kind].element(p, layout.size),
                    );
                    for &outer in &boxes {
                        assert!(box_contains(outer, bounds), "{bounds:?} outside {outer:?}");
                    }
                }
            }
        }
        assert!(
            covered.iter().flatten().all(|&c| c),
            "a primitive is in no leaf"
        );
        assert_eq!(deepest, wide.depth);
        assert!(wide.depth < MAX_DEPTH);
        (wide, sorted)
    }

    /// Quantised boxes hold what they bound, however far from the origin and
    /// however thin, and are not much larger.
    #[test]
    fn quantised_boxes_are_conservative_and_tight() {
        let mut random = uniforms(9);
        for _ in 0..2000 {
            let offset = (random() - 0.5) * 10f32.powf(8.0 * random() - 2.0);
            let size = 10f32.powf(6.0 * random() - 4.0);
            let children: Vec<((Vec3, Vec3), u32, u32)> = (0..WIDTH)
                .map(|_| {
                    let min = Vec3::new(random(), random(), random()) * size + offset;
                    let extent = Vec3::new(random(), random(), random()) * size * 0.5;
                    let extent =
                        Vec3::select(extent.cmplt(Vec3::splat(0.1 * size)), Vec3::ZERO, extent);
                    ((min, min + extent), 0, 0)
                })
                .collect();
            let node = WideBvhNode::quantised(&children);
            for (slot, &((min, max), ..)) in children.iter().enumerate() {
                let (q_min, q_max) = node.child_bounds(slot);
                assert!(
                    box_contains((q_min, q_max), (min, max)),
                    "{slot}: {min} {max} in {q_min} {q_max}"
                );
                // Within two grid steps, and a rounding of the origin, of the box.
                for axis in 0..3 {
                    let slack = 2.0 * node.scale(axis) + offset.abs() * 2.0 * f32::EPSILON;
                    assert!(min[axis] - q_min[axis] <= slack && q_max[axis] - max[axis] <= slack);
                }
            }
        }
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
        assert!(
            wide.nodes.len() <= interior / 2,
            "{} nodes",
            wide.nodes.len()
        );
    }

    #[test]
    fn one_leaf_is_a_root_with_one_child() {
        let (wide, _) = build_checked(&spheres(&[[0.0; 3], [1.0, 0.0, 0.0]]));
        assert_eq!(wide.nodes.len(), 1);
        assert_eq!(wide.nodes[0].planes_b[OCCUPIED], 1);
    }

    #[test]
    fn coincident_primitives_still_collapse() {
        build_checked(&spheres(&[[1.0, 2.0, 3.0]; 37]));
    }

    /// No ray enters an empty slot, whatever its direction's signs and zeros,
    /// even one whose quantised planes are those of the occupied slot.
    #[test]
    fn empty_slots_are_never_hit() {
        let mut random = uniforms(3);
        let components = [-1.0, -0.0, 0.0, 1.0];
        let mut node = WideBvhNode::quantised(&[((Vec3::ZERO, Vec3::ONE), 0, 1)]);
        node.planes_a = node.planes_a.map(|w| w * 0x0101_0101);
        node.planes_b[0] *= 0x0101_0101;
        node.planes_b[1] *= 0x0101_0101;
        let mut entered = 0;
        for _ in 0..1000 {
            let origin = (Vec3::new(random(), random(), random()) - 0.5) * 4.0;
            let mut dir = Vec3::new(random(), random(), random()) - 0.5;
            // Some directions with zero components of either sign.
            for a in 0..3 {
                if random() < 0.3 {
                    dir[a] = components[(random() * 4.0) as usize];
                }
            }
            for t_max in [1.0, f32::MAX] {
                let t = children_t(&node, origin, dir.recip(), t_max);
                assert!(
                    t[1..].iter().all(|&t| t >= f32::MAX),
                    "ray from {origin} along {dir}"
                );
                entered += (t[0] < f32::MAX) as usize;
            }
        }
        assert!(
            entered > 100,
            "only {entered} rays entered the occupied slot"
        );
    }

    /// The kernel's walk (nearest hit child first, the node's other hit ones
    /// one stack entry, taken nearest first; boxes behind the closest hit
    /// culled) finds the same closest sphere as testing every one, with at
    /// most one stack entry per level.
    #[test]
    fn ordered_traversal_finds_the_closest_hit() {
        assert_walk_finds_closest_hits(build_checked, |wide: &WideBvh, origin, dir, hit| {
            let inv_dir = dir.recip();
            let mut closest: Option<(f32, usize)> = None;
            // Entries: a node and its pending slots, the nearest last.
            let mut stack: Vec<(usize, Vec<usize>)> = Vec::new();
            let mut link = Some([0u32, 0u32]);
            while let Some([first, count]) = link {
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
                        link = Some(node.links[slot]);
                        continue;
                    }
                } else {
                    for p in first as usize..(first + (count & LEAF_COUNT_MASK)) as usize {
                        let t_max = closest.map_or(f32::MAX, |c| c.0);
                        if let Some(t) = hit(p, t_max) {
                            closest = Some((t, p));
                        }
                    }
                }
                link = stack
                    .last_mut()
                    .map(|(index, pending)| wide.nodes[*index].links[pending.pop().unwrap()]);
                if stack.last().is_some_and(|(_, pending)| pending.is_empty()) {
                    stack.pop();
                }
            }
            closest
        });
    }

    /// `expected_steps` is the mean, over uniformly random lines through the
    /// root's box, of the steps of a walk that opens every box the line crosses:
    /// checked against 20 000 such lines, within 3%.
    #[test]
    fn expected_steps_is_the_mean_over_random_lines() {
        let mut random = uniforms(5);
        let centers: Vec<[f32; 3]> = (0..300)
            .map(|_| [random() * 20.0, random() * 4.0, random() * 10.0])
            .collect();
        let (wide, _) = build_checked(&spheres(&centers));
        let crosses = |(min, max): (Vec3, Vec3), origin: Vec3, dir: Vec3| {
            let (a, b) = ((min - origin) / dir, (max - origin) / dir);
            a.min(b).max_element() <= a.max(b).min_element()
        };
        let root = &wide.nodes[0];
        let root_box = (0..WIDTH)
            .filter(|&s| root.occupied(s))
            .map(|s| root.child_bounds(s))
            .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), (a, b)| {
                (lo.min(a), hi.max(b))
            });
        // Lines of a direction through a disk across the box's bounding sphere:
        // those that meet the box then come in proportion to its shadow.
        let center = (root_box.0 + root_box.1) / 2.0;
        let radius = (root_box.1 - root_box.0).length() / 2.0;
        let (mut lines, mut total) = (0, 0.0);
        while lines < 20_000 {
            let z = 2.0 * random() - 1.0;
            let phi = std::f32::consts::TAU * random();
            let r = (1.0 - z * z).sqrt();
            let dir = Vec3::new(r * phi.cos(), r * phi.sin(), z);
            let (u, v) = dir.any_orthonormal_pair();
            let (rho, theta) = (radius * random().sqrt(), std::f32::consts::TAU * random());
            let origin = center + rho * (theta.cos() * u + theta.sin() * v);
            if !crosses(root_box, origin, dir) {
                continue;
            }
            lines += 1;
            total += 1.0;
            for node in &wide.nodes {
                for slot in (0..WIDTH).filter(|&s| node.occupied(s)) {
                    if crosses(node.child_bounds(slot), origin, dir) {
                        let count = (node.links[slot][1] & LEAF_COUNT_MASK) as f64;
                        total += if count == 0.0 { 1.0 } else { 2.0 + count };
                    }
                }
            }
        }
        let (mean, expected) = (total / lines as f64, wide.expected_steps());
        assert!(
            (mean / expected - 1.0).abs() < 0.03,
            "{mean} lines, {expected} expected"
        );
        assert!(expected > 5.0, "{expected}");
    }
}
