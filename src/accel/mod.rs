//! The acceleration structure: one binary BVH over every primitive of the scene
//! but its few large ones (`put_large_first`), all kinds together, built on the
//! host with the binned surface-area heuristic (Wald 2007), flattened
//! depth-first and collapsed into the 4-wide BVH the kernel walks (`wide`,
//! `shaders/bvh.wgsl`, `kernel::glue`). Building it puts each kind's primitives in leaf order, so
//! a leaf is a range of one kind's array: the kernel reads no references and
//! switches on the kind once per leaf.

use crate::kinds::{KindSet, PRIMITIVE_KINDS, PackedArray};
use glam::Vec3;
use std::time::Instant;

pub mod instances;
pub mod wide;
pub use instances::{InstanceSet, Instancing, PackedInstance};
pub use wide::{WideBvh, WideBvhNode};

/// Each kind's packed primitives and the arrays indexed like them: what a BVH
/// is built over, and puts in leaf order.
#[derive(Clone, Debug, PartialEq)]
pub struct PrimitiveArrays {
    /// Per kind of `PRIMITIVE_KINDS`: the primitives rays can hit.
    pub primitives: Vec<PackedArray>,
    /// Per kind: the shading normals of `primitives`, one element each, where
    /// any of them is smooth (else empty).
    pub normals: Vec<Vec<u8>>,
    /// Per kind with `texture_uvs`: the texture coordinates of `primitives`,
    /// one element each, where the scene has textures (else empty).
    pub uvs: Vec<Vec<u8>>,
    /// Per kind: how many of `primitives`, first in its array, are large
    /// (`put_large_first`): tested by every ray beside the BVH, which holds
    /// the rest.
    pub large: Vec<usize>,
}

impl Default for PrimitiveArrays {
    fn default() -> Self {
        PrimitiveArrays {
            primitives: vec![PackedArray::default(); PRIMITIVE_KINDS.len()],
            normals: vec![Vec::new(); PRIMITIVE_KINDS.len()],
            uvs: vec![Vec::new(); PRIMITIVE_KINDS.len()],
            large: vec![0; PRIMITIVE_KINDS.len()],
        }
    }
}

impl PrimitiveArrays {
    /// Puts kind `k`'s primitives, and every array indexed like them (the
    /// shading normals, the texture coordinates), in `order`: element `j`
    /// becomes the one at `order[j]` (each index once).
    pub fn reorder(&mut self, k: usize, order: &[u32]) {
        let array = &mut self.primitives[k];
        let size = PRIMITIVE_KINDS[k].layout.size;
        let mut sorted = PackedArray::default();
        for &i in order {
            sorted
                .bytes
                .extend_from_slice(array.element(i as usize, size));
            sorted.materials.push(array.materials[i as usize]);
        }
        *array = sorted;
        for per_primitive in [&mut self.normals[k], &mut self.uvs[k]] {
            if !per_primitive.is_empty() {
                let size = per_primitive.len() / order.len();
                assert_eq!(
                    per_primitive.len(),
                    size * order.len(),
                    "one element per primitive"
                );
                *per_primitive = order
                    .iter()
                    .flat_map(|&i| &per_primitive[i as usize * size..(i as usize + 1) * size])
                    .copied()
                    .collect();
            }
        }
    }

    pub fn primitive_count(&self) -> usize {
        self.primitives.iter().map(PackedArray::len).sum()
    }

    /// The primitive kinds rays can hit.
    pub fn primitive_kinds(&self) -> KindSet {
        (0..PRIMITIVE_KINDS.len())
            .filter(|&k| !self.primitives[k].is_empty())
            .collect()
    }

    /// The primitive kinds shaded with interpolated normals.
    pub fn normal_kinds(&self) -> KindSet {
        (0..PRIMITIVE_KINDS.len())
            .filter(|&k| !self.normals[k].is_empty())
            .collect()
    }
}

/// A node of the binary BVH, which the kernel reads collapsed (`WideBvh`).
/// Interior (`count` 0): the left child is the next node, the right one is
/// node `first`. Leaf: primitives `first` to `first + (count & LEAF_COUNT_MASK)`
/// of the kind `count >> LEAF_KIND_SHIFT` (index into `PRIMITIVE_KINDS`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BvhNode {
    pub min: [f32; 3],
    pub first: u32,
    pub max: [f32; 3],
    pub count: u32,
}

/// A leaf's kind is in the top bits of its `count`, its size below.
pub const LEAF_KIND_SHIFT: u32 = 28;
pub const LEAF_COUNT_MASK: u32 = (1 << LEAF_KIND_SHIFT) - 1;

/// Most primitives in a leaf: a leaf is tested by a loop, and SAH rarely wants more.
pub const MAX_LEAF: usize = 4;

/// Depth limit, and so the largest traversal stack (`KernelConfig::bvh_stack`,
/// sized to the BVH built; this one where the BVH is not known). The
/// SAH stops short of it by one level per kind, which the split of a leaf by
/// kind may need; a node that deep becomes a leaf whatever its size.
pub const MAX_DEPTH: u32 = 48;

const BINS: usize = 16;

/// A node visit's cost in the SAH, in primitive tests. On lavapipe a visit
/// reads two child boxes (as many words as a triangle): 2 made 5-16% more
/// paths/s than 1 on sphere fields and the knot, with fewer nodes.
const TRAVERSAL_COST: f32 = 2.0;

/// A primitive whose box has at least this fraction of the surface area of
/// the scene's box is large: tested by every ray beside the BVH, compiled into
/// the kernel, rather than in it (`put_large_first`). Such a primitive (a
/// Cornell box's wall, a ground sphere) sits near the BVH's root and overlaps
/// most boxes, and on lavapipe every ray through a BVH pays for loads a baked
/// test does not make. Process CPU time against none taken out (lavapipe,
/// alternating runs) on Mitsuba's box with the bunny, 4 000 spheres and the
/// knot: 1/10 (the 10 wall triangles; the ground; the floor) 0.76x, 0.75x,
/// 0.80x; 1/100 (the walls, boxes and light: 38) 0.64x, 0.72x, 0.80x; 1/1000
/// 0.64x, 0.74x, 0.75x.
pub const LARGE_AREA_FRACTION: f32 = 0.01;

/// Most large primitives: each costs every ray a test.
pub const MAX_LARGE: usize = 64;

/// A kind with at most this many primitives, beside a kind with more, goes
/// beside the BVH whatever their sizes: its leaves would make the walk switch
/// on the kind at every leaf, and lavapipe runs every case of the switch. On
/// Bitterli's hall (28 k triangles, 4 quads and 5 disks in the BVH) the leaves
/// then hold triangles alone: 0.98x the CPU time (Intel Xeon, 6 alternating
/// pairs, all faster), the image the same bit for bit.
pub const FEW_OF_A_KIND: usize = 16;

/// Moves the scene's large primitives (`LARGE_AREA_FRACTION`, at most
/// `MAX_LARGE`, the largest first), and those of kinds with few
/// (`FEW_OF_A_KIND`), to the front of their kind's arrays and sets
/// `data.large`. None is large where no primitive would be left for the BVH.
pub fn put_large_first(data: &mut PrimitiveArrays) {
    let mut boxes = Vec::new();
    let mut scene = Bounds::EMPTY;
    for (k, kind) in PRIMITIVE_KINDS.iter().enumerate() {
        let array = &data.primitives[k];
        for i in 0..array.len() {
            let element = array.element(i, kind.layout.size);
            let (min, max) = (kind.bounds)(element);
            let bounds = Bounds { min, max };
            scene = scene.grow(bounds);
            // Only a finite primitive has literals to compile in.
            if (kind.layout.is_finite)(element) {
                boxes.push((bounds.half_area(), k, i as u32));
            }
        }
    }
    let counts: Vec<usize> = data.primitives.iter().map(PackedArray::len).collect();
    let most = counts.iter().copied().max().unwrap_or(0);
    let few = |k: usize| counts[k] <= FEW_OF_A_KIND && counts[k] < most;
    let (mut of_few, mut boxes): (Vec<_>, Vec<_>) =
        boxes.into_iter().partition(|&(_, k, _)| few(k));
    let threshold = LARGE_AREA_FRACTION * scene.half_area();
    boxes.retain(|&(area, _, _)| area >= threshold);
    if boxes.len() + of_few.len() == data.primitive_count() {
        return;
    }
    boxes.sort_by(|a, b| b.0.total_cmp(&a.0));
    boxes.truncate(MAX_LARGE);
    boxes.append(&mut of_few);
    for k in 0..PRIMITIVE_KINDS.len() {
        let mut large: Vec<u32> = boxes
            .iter()
            .filter(|&&(_, kind, _)| kind == k)
            .map(|&(_, _, i)| i)
            .collect();
        large.sort_unstable();
        let rest = (0..data.primitives[k].len() as u32).filter(|i| large.binary_search(i).is_err());
        data.large[k] = large.len();
        let order: Vec<u32> = large.iter().copied().chain(rest).collect();
        data.reorder(k, &order);
    }
}

#[derive(Clone, Debug, Default, PartialEq)]
pub struct Bvh {
    pub nodes: Vec<BvhNode>,
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
    /// Its kind (index into `PRIMITIVE_KINDS`) and index in that kind's array.
    kind: u32,
    index: u32,
}

impl Bvh {
    /// The BVH over the primitives of `data` after its large ones
    /// (`PrimitiveArrays::large`), whose primitive arrays it puts in leaf order
    /// after those, and with them every array indexed like them (the shading
    /// normals, the texture coordinates); `None` (and `data` unchanged) when
    /// there are none.
    pub fn build(data: &mut PrimitiveArrays) -> Option<Bvh> {
        let started = Instant::now();
        let (mut bvh, leaf_order) = Bvh::build_order(data)?;
        for (k, order) in leaf_order.iter().enumerate() {
            data.reorder(k, order);
        }
        bvh.build_seconds = started.elapsed().as_secs_f64();
        Some(bvh)
    }

    /// The BVH over the primitives of `data` after its large ones, leaving
    /// `data` as it is, and per kind its order: the large primitives (in
    /// place), then the leaves' (leaf ranges index `leaf_order[k]`, whose
    /// entries are indices into `data.primitives[k]`, each once). `build`
    /// applies it; the light density's BVH (`lights::LightTables`) keeps it as
    /// references.
    pub fn build_order(data: &PrimitiveArrays) -> Option<(Bvh, Vec<Vec<u32>>)> {
        Bvh::build_order_with_instances(data, &[])
    }

    /// `build_order` over the primitives of `data` and the boxes of
    /// `instances` too (`instances::INSTANCE_LEAF`, one leaf kind past the
    /// primitive kinds), whose order is then one more entry of the leaf order.
    pub fn build_order_with_instances(
        data: &PrimitiveArrays,
        instances: &[(Vec3, Vec3)],
    ) -> Option<(Bvh, Vec<Vec<u32>>)> {
        let started = Instant::now();
        let mut items = Vec::with_capacity(data.primitive_count() + instances.len());
        let mut leaf_order: Vec<Vec<u32>> = data
            .large
            .iter()
            .map(|&large| (0..large as u32).collect())
            .collect();
        for (k, kind) in PRIMITIVE_KINDS.iter().enumerate() {
            let array = &data.primitives[k];
            assert!(
                array.len() <= LEAF_COUNT_MASK as usize,
                "too many primitives of one kind for a BVH leaf"
            );
            for i in data.large[k]..array.len() {
                let (min, max) = (kind.bounds)(array.element(i, kind.layout.size));
                items.push(Item {
                    bounds: Bounds { min, max },
                    centroid: 0.5 * (min + max),
                    kind: k as u32,
                    index: i as u32,
                });
            }
        }
        if !instances.is_empty() {
            leaf_order.push(Vec::new());
            for (i, &(min, max)) in instances.iter().enumerate() {
                items.push(Item {
                    bounds: Bounds { min, max },
                    centroid: 0.5 * (min + max),
                    kind: instances::INSTANCE_LEAF,
                    index: i as u32,
                });
            }
        }
        if items.is_empty() {
            return None;
        }
        let mut bvh = Bvh::default();
        bvh.node(&mut items, 0, &mut leaf_order);
        bvh.build_seconds = started.elapsed().as_secs_f64();
        Some((bvh, leaf_order))
    }

    /// Appends the subtree over `items` (reordered) and returns its root's
    /// index; each leaf's primitives go to the end of their kind's `leaf_order`.
    fn node(&mut self, items: &mut [Item], depth: u32, leaf_order: &mut [Vec<u32>]) -> u32 {
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
        // One level per leaf kind (`leaf_order`'s entries) for `kind_split`.
        let sah_depth = MAX_DEPTH - leaf_order.len() as u32;
        let split = if depth + 1 < sah_depth && items.len() > 1 {
            sah_split(items, bounds)
        } else {
            None
        };
        match split.or_else(|| kind_split(items)) {
            None => {
                let kind = items[0].kind as usize;
                let node = &mut self.nodes[index as usize];
                node.first = leaf_order[kind].len() as u32;
                node.count = (kind as u32) << LEAF_KIND_SHIFT | items.len() as u32;
                leaf_order[kind].extend(items.iter().map(|item| item.index));
            }
            Some(mid) => {
                let (left, right) = items.split_at_mut(mid);
                self.node(left, depth + 1, leaf_order);
                let right = self.node(right, depth + 1, leaf_order);
                self.nodes[index as usize].first = right;
            }
        }
        index
    }
}

/// A leaf holds one kind: items of several are split by kind (reordered).
fn kind_split(items: &mut [Item]) -> Option<usize> {
    let first = items[0].kind;
    if items.iter().all(|item| item.kind == first) {
        return None;
    }
    items.sort_by_key(|item| item.kind != first);
    Some(items.iter().take_while(|item| item.kind == first).count())
}

/// Where to split `items` (reordering them), or `None` for a leaf: the binned
/// SAH's best plane along the widest axis of the centroids, a traversal step
/// costing `TRAVERSAL_COST` primitive tests. Leaves of more than `MAX_LEAF`
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
    let split_cost = TRAVERSAL_COST + best.0 / bounds.half_area().max(f32::MIN_POSITIVE);
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
pub(crate) mod tests {
    use super::*;
    use crate::kinds::{PackedQuad, PackedSphere};

    pub(crate) fn kind_index(name: &str) -> usize {
        PRIMITIVE_KINDS.iter().position(|k| k.name == name).unwrap()
    }

    /// Spheres of radius 0.5 at `centers`, material `i` for the i-th (so each is
    /// recognisable after reordering).
    pub(crate) fn spheres(centers: &[[f32; 3]]) -> PrimitiveArrays {
        let mut data = PrimitiveArrays::default();
        let array = &mut data.primitives[kind_index("sphere")];
        for (i, &center) in centers.iter().enumerate() {
            let sphere = PackedSphere {
                center,
                radius: 0.5,
                material: i as u32,
                ..PackedSphere::default()
            };
            array.bytes.extend_from_slice(bytemuck::bytes_of(&sphere));
            array.materials.push(i as u32);
        }
        data
    }

    /// A small pseudo-random sequence in [0, 1) (xorshift), for test layouts.
    pub(crate) fn uniforms(seed: u32) -> impl FnMut() -> f32 {
        let mut state = seed;
        move || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            (state >> 8) as f32 / (1u32 << 24) as f32
        }
    }

    /// `count` points drawn uniformly in the cube [0, extent]³.
    fn random_points(random: &mut impl FnMut() -> f32, count: usize, extent: f32) -> Vec<[f32; 3]> {
        (0..count)
            .map(|_| [random(), random(), random()].map(|u| extent * u))
            .collect()
    }

    /// Whether box `outer` holds box `inner`.
    pub(crate) fn box_contains(outer: (Vec3, Vec3), inner: (Vec3, Vec3)) -> bool {
        outer.0.cmple(inner.0).all() && inner.1.cmple(outer.1).all()
    }

    /// Builds the BVH over `data` and checks it: each kind's primitives are the
    /// same set, reordered after the large ones, which stay in place; every leaf
    /// is a range of one kind, small unless at the depth limit, and the leaves
    /// partition every array after its large primitives; every node's box holds
    /// its children's and its primitives' boxes.
    fn build_checked(data: &PrimitiveArrays) -> (Bvh, PrimitiveArrays) {
        let mut sorted = data.clone();
        let bvh = Bvh::build(&mut sorted).unwrap();
        for (k, kind) in PRIMITIVE_KINDS.iter().enumerate() {
            let elements = |d: &PrimitiveArrays| {
                let mut e: Vec<Vec<u8>> = (0..d.primitives[k].len())
                    .map(|i| d.primitives[k].element(i, kind.layout.size).to_vec())
                    .collect();
                e.sort();
                e
            };
            assert_eq!(elements(&sorted), elements(data), "{} reordered", kind.name);
        }
        // The large primitives stay first, in no leaf.
        let mut covered: Vec<Vec<bool>> = sorted
            .primitives
            .iter()
            .zip(&sorted.large)
            .map(|(array, &large)| (0..array.len()).map(|i| i < large).collect())
            .collect();
        assert_eq!(sorted.large, data.large);
        for (k, kind) in PRIMITIVE_KINDS.iter().enumerate() {
            let size = kind.layout.size;
            assert_eq!(
                sorted.primitives[k].bytes[..data.large[k] * size],
                data.primitives[k].bytes[..data.large[k] * size]
            );
        }
        let mut stack = vec![(0usize, 0u32)];
        while let Some((i, depth)) = stack.pop() {
            let node = bvh.nodes[i];
            assert!(depth <= bvh.depth && bvh.depth < MAX_DEPTH);
            let inside = |min: [f32; 3], max: [f32; 3]| {
                (0..3).all(|a| min[a] >= node.min[a] && max[a] <= node.max[a])
            };
            if node.count == 0 {
                let (left, right) = (i + 1, node.first as usize);
                for child in [left, right] {
                    assert!(inside(bvh.nodes[child].min, bvh.nodes[child].max));
                    stack.push((child, depth + 1));
                }
            } else {
                let kind = (node.count >> LEAF_KIND_SHIFT) as usize;
                let count = (node.count & LEAF_COUNT_MASK) as usize;
                assert!(count >= 1);
                assert!(count <= MAX_LEAF || depth + PRIMITIVE_KINDS.len() as u32 >= MAX_DEPTH);
                let layout = PRIMITIVE_KINDS[kind].layout;
                let range = node.first as usize..node.first as usize + count;
                for (covered, p) in covered[kind][range.clone()].iter_mut().zip(range) {
                    assert!(!*covered, "primitive {p} in two leaves");
                    *covered = true;
                    let (min, max) = (PRIMITIVE_KINDS[kind].bounds)(
                        sorted.primitives[kind].element(p, layout.size),
                    );
                    assert!(inside(min.to_array(), max.to_array()));
                }
            }
        }
        assert!(
            covered.iter().flatten().all(|&c| c),
            "a primitive is in no leaf"
        );
        (bvh, sorted)
    }

    #[test]
    fn every_primitive_is_in_one_leaf() {
        let grid: Vec<[f32; 3]> = (0..1000)
            .map(|i| [(i % 10) as f32, (i / 10 % 10) as f32, (i / 100) as f32])
            .collect();
        let (bvh, _) = build_checked(&spheres(&grid));
        // A balanced tree over 1000 well-spread spheres: about log2(1000 / 4) levels.
        assert!((7..=12).contains(&bvh.depth), "depth {}", bvh.depth);
    }

    #[test]
    fn coincident_primitives_still_split() {
        let (bvh, _) = build_checked(&spheres(&[[1.0, 2.0, 3.0]; 37]));
        assert!(bvh.nodes.len() > 1);
    }

    #[test]
    fn leaves_hold_one_kind() {
        // Quads and spheres interleaved in space: SAH alone would mix them.
        let mut random = uniforms(7);
        let centers: Vec<[f32; 3]> = (0..200).map(|_| [random(), random(), random()]).collect();
        let mut data = spheres(&centers);
        add_small_quads(&mut data, &centers);
        build_checked(&data);
    }

    /// A quad 0.01 wide at each of `centers`, material `i` for the i-th.
    fn add_small_quads(data: &mut PrimitiveArrays, centers: &[[f32; 3]]) {
        let quads = &mut data.primitives[kind_index("quad")];
        for (i, c) in centers.iter().enumerate() {
            let quad = PackedQuad {
                q: *c,
                u: [0.01, 0.0, 0.0],
                v: [0.0, 0.01, 0.0],
                material: i as u32,
                ..PackedQuad::default()
            };
            quads.bytes.extend_from_slice(bytemuck::bytes_of(&quad));
            quads.materials.push(i as u32);
        }
    }

    /// A kind with few primitives beside a numerous one goes beside the BVH,
    /// however small they are, so that its leaves hold one kind; one more and
    /// it stays in.
    #[test]
    fn a_kind_with_few_primitives_goes_beside_the_bvh() {
        let mut random = uniforms(11);
        let centers = random_points(&mut random, 300, 10.0);
        for (quads, beside) in [(FEW_OF_A_KIND, FEW_OF_A_KIND), (FEW_OF_A_KIND + 1, 0)] {
            let mut data = spheres(&centers);
            add_small_quads(&mut data, &centers[..quads]);
            put_large_first(&mut data);
            assert_eq!(data.large[kind_index("quad")], beside);
            assert_eq!(data.large[kind_index("sphere")], 0);
            build_checked(&data);
        }
    }

    /// The kernel's slab test (`wide_bvh_children_t`) of one binary node.
    fn box_t(node: &BvhNode, origin: Vec3, inv_dir: Vec3, t_max: f32) -> f32 {
        let t0 = (Vec3::from(node.min) - origin) * inv_dir;
        let t1 = (Vec3::from(node.max) - origin) * inv_dir;
        let near = t0.min(t1).max_element().max(0.0);
        let far = t0.max(t1).min_element().min(t_max);
        if near <= far * 1.0000004 {
            near
        } else {
            f32::MAX
        }
    }

    pub(crate) fn sphere_t(
        sphere: &PackedSphere,
        origin: Vec3,
        dir: Vec3,
        t_max: f32,
    ) -> Option<f32> {
        let to_center = Vec3::from(sphere.center) - origin;
        let along = dir.dot(to_center);
        let disc = sphere.radius * sphere.radius - (to_center - along * dir).length_squared();
        let near = along - disc.max(0.0).sqrt();
        (disc >= 0.0 && near > 0.0 && near < t_max).then_some(near)
    }

    /// Casts 2 000 random rays into a field of 2 000 random spheres and checks
    /// that `walk` finds the same closest sphere (distance and index in leaf
    /// order) as testing every one. `build` makes the hierarchy and the scene in
    /// leaf order; `walk` gets the hierarchy, the ray (origin, direction) and
    /// `hit(p, t_max)`, sphere `p`'s distance along the ray if below `t_max`.
    pub(crate) fn assert_walk_finds_closest_hits<H>(
        build: impl FnOnce(&PrimitiveArrays) -> (H, PrimitiveArrays),
        walk: impl Fn(&H, Vec3, Vec3, &dyn Fn(usize, f32) -> Option<f32>) -> Option<(f32, usize)>,
    ) {
        let mut random = uniforms(11);
        let centers = random_points(&mut random, 2000, 40.0);
        let (hierarchy, sorted) = build(&spheres(&centers));
        let array = &sorted.primitives[kind_index("sphere")];
        let sphere = |i: usize| -> PackedSphere {
            *bytemuck::from_bytes(array.element(i, size_of::<PackedSphere>()))
        };
        let mut hits = 0;
        for _ in 0..2000 {
            let origin = Vec3::new(random(), random(), random()) * 40.0;
            let dir = (Vec3::new(random(), random(), random()) - 0.5).normalize();
            let brute = (0..array.len())
                .filter_map(|i| sphere_t(&sphere(i), origin, dir, f32::MAX).map(|t| (t, i)))
                .min_by(|a, b| a.0.total_cmp(&b.0));
            let hit = |p: usize, t_max: f32| sphere_t(&sphere(p), origin, dir, t_max);
            let closest = walk(&hierarchy, origin, dir, &hit);
            assert_eq!(closest, brute, "ray from {origin} along {dir}");
            hits += brute.is_some() as usize;
        }
        assert!(
            hits > 500,
            "only {hits} rays hit: the test would prove little"
        );
    }

    /// The kernel's traversal order (nearer child first, boxes behind the
    /// closest hit culled) finds the same closest sphere as testing every one.
    #[test]
    fn ordered_traversal_finds_the_closest_hit() {
        assert_walk_finds_closest_hits(build_checked, |bvh: &Bvh, origin, dir, hit| {
            ordered_walk(bvh, origin, dir, hit, None)
        });
    }

    /// The closest hit through `bvh` as the kernel walks it (nearer child
    /// first, boxes behind the closest hit culled), from `closest` on.
    fn ordered_walk(
        bvh: &Bvh,
        origin: Vec3,
        dir: Vec3,
        hit: &dyn Fn(usize, f32) -> Option<f32>,
        mut closest: Option<(f32, usize)>,
    ) -> Option<(f32, usize)> {
        let inv_dir = dir.recip();
        let mut stack = vec![0usize];
        while let Some(i) = stack.pop() {
            let node = &bvh.nodes[i];
            let t_max = closest.map_or(f32::MAX, |c| c.0);
            if node.count == 0 {
                let (left, right) = (i + 1, node.first as usize);
                let t_left = box_t(&bvh.nodes[left], origin, inv_dir, t_max);
                let t_right = box_t(&bvh.nodes[right], origin, inv_dir, t_max);
                let (near, far) = if t_right < t_left {
                    ((right, t_right), (left, t_left))
                } else {
                    ((left, t_left), (right, t_right))
                };
                for (child, t) in [far, near] {
                    if t < f32::MAX {
                        stack.push(child);
                    }
                }
            } else {
                let first = node.first as usize;
                for p in first..first + (node.count & LEAF_COUNT_MASK) as usize {
                    let t_max = closest.map_or(f32::MAX, |c| c.0);
                    if let Some(t) = hit(p, t_max) {
                        closest = Some((t, p));
                    }
                }
            }
        }
        closest
    }

    /// Large primitives (two big spheres among 500 small ones) are put first
    /// and left out of the BVH, and testing them before walking the BVH, as
    /// the kernel does, finds every closest hit.
    #[test]
    fn large_primitives_are_tested_beside_the_bvh() {
        let mut random = uniforms(3);
        let centers = random_points(&mut random, 500, 20.0);
        let mut data = spheres(&centers);
        let k = kind_index("sphere");
        let size = size_of::<PackedSphere>();
        for big in [100, 300] {
            let sphere: &mut PackedSphere = bytemuck::from_bytes_mut(
                &mut data.primitives[k].bytes[big * size..(big + 1) * size],
            );
            sphere.radius = 6.0;
        }
        put_large_first(&mut data);
        assert_eq!(data.large[k], 2);
        assert_eq!(data.primitives[k].materials[..3], [100, 300, 0]);
        let (bvh, sorted) = build_checked(&data);
        let array = &sorted.primitives[k];
        let sphere = |i: usize| -> PackedSphere { *bytemuck::from_bytes(array.element(i, size)) };
        let mut large_hits = 0;
        for _ in 0..2000 {
            let origin = Vec3::new(random(), random(), random()) * 20.0;
            let dir = (Vec3::new(random(), random(), random()) - 0.5).normalize();
            let brute = (0..array.len())
                .filter_map(|i| sphere_t(&sphere(i), origin, dir, f32::MAX).map(|t| (t, i)))
                .min_by(|a, b| a.0.total_cmp(&b.0));
            let hit = |p: usize, t_max: f32| sphere_t(&sphere(p), origin, dir, t_max);
            let mut closest = None;
            for p in 0..sorted.large[k] {
                let t_max = closest.map_or(f32::MAX, |c: (f32, usize)| c.0);
                if let Some(t) = hit(p, t_max) {
                    closest = Some((t, p));
                }
            }
            let closest = ordered_walk(&bvh, origin, dir, &hit, closest);
            assert_eq!(closest, brute, "ray from {origin} along {dir}");
            large_hits += brute.is_some_and(|(_, p)| p < 2) as usize;
        }
        assert!(
            large_hits > 100,
            "only {large_hits} closest hits on the large spheres"
        );
    }

    /// Where every primitive would be large, none is: the BVH needs some.
    #[test]
    fn a_scene_of_large_primitives_keeps_them_in_the_bvh() {
        let mut data = spheres(&[[0.0; 3], [1.0, 0.0, 0.0]]);
        let before = data.clone();
        put_large_first(&mut data);
        assert_eq!(data, before);
    }

    /// Arrays indexed like the primitives (the shading normals) are put in the
    /// same order; `build_order` leaves `data` as it is and gives that order.
    #[test]
    fn per_primitive_arrays_follow_the_leaf_order() {
        let mut random = uniforms(5);
        let centers = random_points(&mut random, 300, 10.0);
        let mut data = spheres(&centers);
        let k = kind_index("sphere");
        // Two words per primitive, both its original index (its material).
        data.normals[k] = (0..centers.len() as u32)
            .flat_map(|i| [i, i])
            .flat_map(u32::to_le_bytes)
            .collect();
        let (_, order) = Bvh::build_order(&data).unwrap();
        let mut sorted = data.clone();
        Bvh::build(&mut sorted).unwrap();
        let words: Vec<u32> = sorted.normals[k]
            .chunks_exact(4)
            .map(|w| u32::from_le_bytes(w.try_into().unwrap()))
            .collect();
        for (j, &i) in order[k].iter().enumerate() {
            assert_eq!(sorted.primitives[k].materials[j], i);
            assert_eq!(words[2 * j..2 * j + 2], [i, i]);
        }
        assert_ne!(order[k], (0..centers.len() as u32).collect::<Vec<_>>());
    }

    #[test]
    fn no_primitives_no_bvh() {
        let mut data = PrimitiveArrays::default();
        assert_eq!(Bvh::build(&mut data), None);
        assert_eq!(data, PrimitiveArrays::default());
    }
}
