// The wide BVH's nodes (`accel::WideBvhNode`) and the box tests and stack
// entries of its walks (generated: `kernel::glue`), which `intersect_scene`
// runs over the scene and the light density over a mesh light's faces.

// Mirrors `accel::WideBvhNode`: child i in component or byte i. Planes are
// `origin + q * scale` for a byte q; the traversal reads the box vectors alone
// (`wide_bvh_children_t`) and the chosen child's link.
struct WideBvhNode {
    // Quantised min x, min y, min z, max x.
    planes_a: vec4<u32>,
    // Quantised max y, max z; the exponents of the scales (x lowest); the
    // occupied slots' bits.
    planes_b: vec4<u32>,
    origin: vec4<f32>,
    links: array<vec2<u32>, 4>,
}

// Distances at which the ray enters the four children's boxes within (0, t_max),
// or F32_MAX where it misses (or the slot is empty). Each axis's near plane is
// chosen by the ray's sign. The far distance is widened by 2 gamma(3)
// (pbrt-v4) so rounding cannot cull a box the ray grazes.
fn wide_bvh_children_t(planes_a: vec4<u32>, planes_b: vec4<u32>, box_origin: vec4<f32>, origin: vec3<f32>, inv_dir: vec3<f32>, t_max: f32) -> vec4<f32> {
    let scale = bitcast<vec3<f32>>(((vec3<u32>(planes_b.z) >> vec3<u32>(0u, 8u, 16u)) & vec3<u32>(0xffu)) << vec3<u32>(23u));
    let min_x = box_origin.x + vec4<f32>(unpack4xU8(planes_a.x)) * scale.x;
    let min_y = box_origin.y + vec4<f32>(unpack4xU8(planes_a.y)) * scale.y;
    let min_z = box_origin.z + vec4<f32>(unpack4xU8(planes_a.z)) * scale.z;
    let max_x = box_origin.x + vec4<f32>(unpack4xU8(planes_a.w)) * scale.x;
    let max_y = box_origin.y + vec4<f32>(unpack4xU8(planes_b.x)) * scale.y;
    let max_z = box_origin.z + vec4<f32>(unpack4xU8(planes_b.y)) * scale.z;
    let negative = inv_dir < vec3<f32>(0.0);
    let near_x = (select(min_x, max_x, negative.x) - origin.x) * inv_dir.x;
    let near_y = (select(min_y, max_y, negative.y) - origin.y) * inv_dir.y;
    let near_z = (select(min_z, max_z, negative.z) - origin.z) * inv_dir.z;
    let far_x = (select(max_x, min_x, negative.x) - origin.x) * inv_dir.x;
    let far_y = (select(max_y, min_y, negative.y) - origin.y) * inv_dir.y;
    let far_z = (select(max_z, min_z, negative.z) - origin.z) * inv_dir.z;
    let near = max(max(near_x, near_y), max(near_z, vec4<f32>(0.0)));
    let far = min(min(far_x, far_y), min(far_z, vec4<f32>(t_max)));
    let occupied = (vec4<u32>(planes_b.w) & vec4<u32>(1u, 2u, 4u, 8u)) != vec4<u32>(0u);
    return select(vec4<f32>(F32_MAX), near, occupied & (near <= far * 1.0000004));
}

// Keys at or above this are misses: F32_MAX's bits with the slot bits cleared.
const WIDE_BVH_MISS: u32 = 0x7f7ffffcu;

// The children in order of distance, as keys: the distance's bits (ordered as
// the distance is, since it is not negative; abs clears the sign of -0) with
// the child's slot in the two lowest. A sorting network of min and max.
fn wide_bvh_order(t: vec4<f32>) -> vec4<u32> {
    let keys = (bitcast<vec4<u32>>(abs(t)) & vec4<u32>(~3u)) | vec4<u32>(0u, 1u, 2u, 3u);
    let a = vec4<u32>(min(keys.xz, keys.yw), max(keys.xz, keys.yw));
    let b = vec4<u32>(min(a.xz, a.yw), max(a.xz, a.yw));
    return vec4<u32>(b.x, min(b.y, b.z), max(b.y, b.z), b.w);
}

// A node's farther hit children, still to walk, as one stack entry: the node's
// index (bits 8 on), how many (bits 6-7) and their slots, nearest first (two
// bits each from bit 0), from the sorted keys.
fn wide_bvh_entry(node_index: u32, keys: vec4<u32>, pending: u32) -> u32 {
    let slots = keys & vec4<u32>(3u);
    return (node_index << 8u) | (pending << 6u) | slots.y | (slots.z << 2u) | (slots.w << 4u);
}

// The entry once its nearest child is taken: one fewer pending, the next nearest
// first (no pending left: the entry is done).
fn wide_bvh_entry_rest(entry: u32) -> u32 {
    return ((entry & ~0x3fu) - 0x40u) | ((entry & 0x3fu) >> 2u);
}
