//! The acceleration structure: one binary BVH over every primitive of the scene
//! (all kinds together), built on the host with the binned surface-area
//! heuristic (Wald 2007) and flattened depth-first for the kernel's stack
//! traversal (`shaders/bvh.wgsl`, `kernel::glue`).

use crate::gpu::layout::{SceneData, gpu_struct};
use crate::kinds::PRIMITIVE_KINDS;
use glam::Vec3;
use std::time::Instant;

gpu_struct! {
    /// Interior (`count` 0): the left child is the next node, the right one is
    /// node `first`. Leaf: `count` primitive references from `first` on.
    pub struct BvhNode {
        pub min: [f32; 3],
        pub first: u32,
        pub max: [f32; 3],
        pub count: u32,
    }
}

/// A primitive reference: its kind (index into `PRIMITIVE_KINDS`) in the top
/// bits, its index in that kind's array below.
pub const REF_KIND_SHIFT: u32 = 28;
pub const REF_INDEX_MASK: u32 = (1 << REF_KIND_SHIFT) - 1;

/// Most primitives in a leaf: a leaf is tested by a loop, and SAH rarely wants more.
pub const MAX_LEAF: usize = 4;

/// Depth limit, and so the traversal stack's size (`BVH_STACK` in WGSL): a node
/// this deep becomes a leaf whatever its size.
pub const MAX_DEPTH: u32 = 48;

const BINS: usize = 16;

#[derive(Clone, Debug, Default, PartialEq)]
pub struct Bvh {
    pub nodes: Vec<BvhNode>,
    pub refs: Vec<u32>,
    /// Levels below the root.
    pub depth: u32,
    pub build_seconds: f64,
}

#[derive(Clone, Copy)]
struct Bounds {
    min: Vec3,
    max: Vec3,
}

impl Bounds {
    const EMPTY: Bounds = Bounds {
        min: Vec3::INFINITY,
        max: Vec3::NEG_INFINITY,
    };

    fn grow(self, other: Bounds) -> Bounds {
        Bounds {
            min: self.min.min(other.min),
            max: self.max.max(other.max),
        }
    }

    fn grow_point(self, p: Vec3) -> Bounds {
        Bounds {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    /// Half the surface area (the SAH only compares areas).
    fn half_area(self) -> f32 {
        let d = (self.max - self.min).max(Vec3::ZERO);
        d.x * d.y + d.y * d.z + d.z * d.x
    }
}

struct Item {
    bounds: Bounds,
    centroid: Vec3,
    reference: u32,
}

impl Bvh {
    /// The BVH over every primitive of `data`; `None` when it has none.
    pub fn build(data: &SceneData) -> Option<Bvh> {
        let started = Instant::now();
        let mut items = Vec::with_capacity(data.primitive_count());
        for (k, kind) in PRIMITIVE_KINDS.iter().enumerate() {
            let array = &data.primitives[k];
            for i in 0..array.len() {
                let (min, max) = (kind.bounds)(array.element(i, kind.layout.size));
                items.push(Item {
                    bounds: Bounds { min, max },
                    centroid: 0.5 * (min + max),
                    reference: (k as u32) << REF_KIND_SHIFT | i as u32,
                });
            }
        }
        if items.is_empty() {
            return None;
        }
        assert!(
            items.len() <= REF_INDEX_MASK as usize,
            "too many primitives for a BVH reference"
        );
        let mut bvh = Bvh::default();
        bvh.node(&mut items, 0);
        bvh.build_seconds = started.elapsed().as_secs_f64();
        Some(bvh)
    }

    /// Appends the subtree over `items` (reordered) and returns its root's index.
    fn node(&mut self, items: &mut [Item], depth: u32) -> u32 {
        self.depth = self.depth.max(depth);
        let index = self.nodes.len() as u32;
        let bounds = items
            .iter()
            .fold(Bounds::EMPTY, |b, item| b.grow(item.bounds));
        self.nodes.push(BvhNode {
            min: bounds.min.to_array(),
            max: bounds.max.to_array(),
            ..BvhNode::default()
        });
        let split = if depth + 1 < MAX_DEPTH && items.len() > 1 {
            sah_split(items, bounds)
        } else {
            None
        };
        match split {
            None => {
                let node = &mut self.nodes[index as usize];
                node.first = self.refs.len() as u32;
                node.count = items.len() as u32;
                self.refs.extend(items.iter().map(|item| item.reference));
            }
            Some(mid) => {
                let (left, right) = items.split_at_mut(mid);
                self.node(left, depth + 1);
                let right = self.node(right, depth + 1);
                self.nodes[index as usize].first = right;
            }
        }
        index
    }
}

/// Where to split `items` (reordering them), or `None` for a leaf: the binned
/// SAH's best plane along the widest axis of the centroids, with a traversal
/// step costing as much as one primitive test. Leaves of more than `MAX_LEAF`
/// are always split, at the median when the bins cannot separate them.
fn sah_split(items: &mut [Item], bounds: Bounds) -> Option<usize> {
    let centroids = items
        .iter()
        .fold(Bounds::EMPTY, |b, item| b.grow_point(item.centroid));
    let extent = centroids.max - centroids.min;
    let axis = extent.max_position();
    let must_split = items.len() > MAX_LEAF;
    if extent[axis] <= 0.0 {
        return must_split.then(|| median_split(items, axis));
    }
    let bin_of = |c: Vec3| {
        let x = (c[axis] - centroids.min[axis]) / extent[axis] * BINS as f32;
        (x as usize).min(BINS - 1)
    };
    let mut bins = [(Bounds::EMPTY, 0usize); BINS];
    for item in items.iter() {
        let bin = &mut bins[bin_of(item.centroid)];
        *bin = (bin.0.grow(item.bounds), bin.1 + 1);
    }
    // Costs of splitting after bin i: a sweep from each side.
    let mut right_area = [0.0f32; BINS];
    let mut acc = (Bounds::EMPTY, 0);
    for i in (1..BINS).rev() {
        acc = (acc.0.grow(bins[i].0), acc.1 + bins[i].1);
        right_area[i - 1] = acc.0.half_area() * acc.1 as f32;
    }
    let mut best = (f32::INFINITY, 0);
    let mut acc = (Bounds::EMPTY, 0);
    for (i, &right) in right_area.iter().enumerate().take(BINS - 1) {
        acc = (acc.0.grow(bins[i].0), acc.1 + bins[i].1);
        let cost = acc.0.half_area() * acc.1 as f32 + right;
        if acc.1 > 0 && acc.1 < items.len() && cost < best.0 {
            best = (cost, i);
        }
    }
    let leaf_cost = items.len() as f32;
    let split_cost = 1.0 + best.0 / bounds.half_area().max(f32::MIN_POSITIVE);
    if best.0.is_infinite() || (!must_split && split_cost >= leaf_cost) {
        return must_split.then(|| median_split(items, axis));
    }
    let mut mid = 0;
    for i in 0..items.len() {
        if bin_of(items[i].centroid) <= best.1 {
            items.swap(i, mid);
            mid += 1;
        }
    }
    Some(mid)
}

fn median_split(items: &mut [Item], axis: usize) -> usize {
    let mid = items.len() / 2;
    items.select_nth_unstable_by(mid, |a, b| a.centroid[axis].total_cmp(&b.centroid[axis]));
    mid
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::layout::PackedArray;
    use crate::kinds::Sphere;

    fn spheres(centers: &[[f32; 3]]) -> SceneData {
        let mut data = SceneData::default();
        let k = PRIMITIVE_KINDS
            .iter()
            .position(|k| k.name == "sphere")
            .unwrap();
        let mut array = PackedArray::default();
        for &center in centers {
            let sphere = Sphere {
                center,
                radius: 0.5,
                ..Sphere::default()
            };
            array.bytes.extend_from_slice(bytemuck::bytes_of(&sphere));
            array.materials.push(0);
        }
        data.primitives[k] = array;
        data
    }

    /// Every primitive is in exactly one leaf, every node's box holds its
    /// subtree, and leaves are small.
    fn check(bvh: &Bvh, data: &SceneData) {
        let mut seen = vec![false; data.primitive_count()];
        let mut stack = vec![(0usize, 0u32)];
        while let Some((i, depth)) = stack.pop() {
            let node = bvh.nodes[i];
            assert!(depth <= bvh.depth);
            let inside = |child: &BvhNode| {
                (0..3).all(|a| child.min[a] >= node.min[a] && child.max[a] <= node.max[a])
            };
            if node.count == 0 {
                let (left, right) = (i + 1, node.first as usize);
                assert!(inside(&bvh.nodes[left]) && inside(&bvh.nodes[right]));
                stack.push((left, depth + 1));
                stack.push((right, depth + 1));
            } else {
                assert!(node.count as usize <= MAX_LEAF || depth + 1 >= MAX_DEPTH);
                for &r in &bvh.refs[node.first as usize..(node.first + node.count) as usize] {
                    let index = (r & REF_INDEX_MASK) as usize;
                    assert!(!seen[index], "primitive {index} in two leaves");
                    seen[index] = true;
                }
            }
        }
        assert!(seen.iter().all(|&s| s), "a primitive is in no leaf");
    }

    #[test]
    fn every_primitive_is_in_one_leaf() {
        let grid: Vec<[f32; 3]> = (0..1000)
            .map(|i| [(i % 10) as f32, (i / 10 % 10) as f32, (i / 100) as f32])
            .collect();
        let data = spheres(&grid);
        let bvh = Bvh::build(&data).unwrap();
        check(&bvh, &data);
        // A balanced tree over 1000 well-spread spheres: about log2(1000 / 4) levels.
        assert!((7..=12).contains(&bvh.depth), "depth {}", bvh.depth);
    }

    #[test]
    fn coincident_primitives_still_split() {
        let data = spheres(&[[1.0, 2.0, 3.0]; 37]);
        let bvh = Bvh::build(&data).unwrap();
        check(&bvh, &data);
        assert!(bvh.nodes.len() > 1);
    }

    #[test]
    fn no_primitives_no_bvh() {
        assert_eq!(Bvh::build(&SceneData::default()), None);
    }
}
