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

#if INSTANCES
// Mirrors `accel::PackedInstance`: the rows of the world-to-object and
// object-to-world affine matrices, and the root of the group's BVH.
struct Instance {
    to_object_x: vec4<f32>,
    to_object_y: vec4<f32>,
    to_object_z: vec4<f32>,
    to_world_x: vec4<f32>,
    to_world_y: vec4<f32>,
    to_world_z: vec4<f32>,
    root: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

// The closest hit is in no instance.
const NO_INSTANCE: u32 = 0xffffffffu;

// `p` by the affine matrix of rows `x`, `y`, `z`.
fn instance_point(x: vec4<f32>, y: vec4<f32>, z: vec4<f32>, p: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(dot(x.xyz, p) + x.w, dot(y.xyz, p) + y.w, dot(z.xyz, p) + z.w);
}

// `v` by the linear part of the matrix of rows `x`, `y`, `z`.
fn instance_vector(x: vec4<f32>, y: vec4<f32>, z: vec4<f32>, v: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(dot(x.xyz, v), dot(y.xyz, v), dot(z.xyz, v));
}

// A ray in an instance's group's space, its direction unit length again: a
// distance there is `scale` times the world's.
struct InstanceRay {
    ray: Ray,
    scale: f32,
}

fn instance_ray(instance: Instance, ray: Ray) -> InstanceRay {
    let dir = instance_vector(instance.to_object_x, instance.to_object_y, instance.to_object_z, ray.dir);
    let scale = length(dir);
    let origin = instance_point(instance.to_object_x, instance.to_object_y, instance.to_object_z, ray.origin);
    return InstanceRay(Ray(origin, dir / scale), scale);
}

// A normal carried out of an instance by the inverse transpose of its
// object-to-world matrix (the transpose of world-to-object), unit length, as
// Mitsuba's `instance` carries them.
fn instance_normal(instance: Instance, n: vec3<f32>) -> vec3<f32> {
    return normalize(n.x * instance.to_object_x.xyz + n.y * instance.to_object_y.xyz + n.z * instance.to_object_z.xyz);
}

// The closest hit, shaded in its instance's group's space, in world space: the
// point and tangents by the object-to-world matrix, the normals as normals.
fn instance_to_world(hit: Hit, instance: Instance) -> Hit {
    var world = hit;
    world.p = instance_point(instance.to_world_x, instance.to_world_y, instance.to_world_z, hit.p);
    world.normal = instance_normal(instance, hit.normal);
    world.shading_normal = instance_normal(instance, hit.shading_normal);
#if BUMP_MAPS
    world.tangents = Tangents(
        instance_vector(instance.to_world_x, instance.to_world_y, instance.to_world_z, hit.tangents.dp_du),
        instance_vector(instance.to_world_x, instance.to_world_y, instance.to_world_z, hit.tangents.dp_dv),
    );
#endif
    return world;
}
#endif
