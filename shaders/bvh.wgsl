// The BVH's nodes (`accel::BvhNode`) and the ray-box test of its traversal,
// which `intersect_scene` runs (generated: `kernel::glue`).

// Mirrors `accel::BvhNode`. Interior (count 0): left child next, right child
// `first`. Leaf: `count` primitive references from `first` on.
struct BvhNode {
    min: vec3<f32>,
    first: u32,
    max: vec3<f32>,
    count: u32,
}

// Distance at which the ray enters the box within (0, t_max), or F32_MAX if it
// misses. The far distance is widened by 2 gamma(3) (pbrt-v4) so rounding
// cannot cull a box the ray grazes.
fn bvh_box_t(node: BvhNode, origin: vec3<f32>, inv_dir: vec3<f32>, t_max: f32) -> f32 {
    let t0 = (node.min - origin) * inv_dir;
    let t1 = (node.max - origin) * inv_dir;
    let near = max(max(min(t0.x, t1.x), min(t0.y, t1.y)), max(min(t0.z, t1.z), 0.0));
    let far = min(min(max(t0.x, t1.x), max(t0.y, t1.y)), min(max(t0.z, t1.z), t_max));
    return select(F32_MAX, near, near <= far * 1.0000004);
}
