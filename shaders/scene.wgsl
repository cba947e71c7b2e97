// The scene's primitives and the closest-hit query. Only the kinds the scene
// contains are compiled in.

// Either storage buffers, or (BAKED_SCENE) arrays with constant initialisers
// generated from the same packed data and appended to the kernel
// (`KernelConfig::baked_scene_wgsl`): loops of fixed trip count over known
// data, which the driver's compiler unrolls and folds into immediates.
#if QUADS
#if BAKED_SCENE
fn quad_count() -> u32 { return QUAD_COUNT; }
#else
@group(1) @binding(1) var<storage, read> quads: array<Quad>;
fn quad_count() -> u32 { return arrayLength(&quads); }
#endif
#endif
#if SPHERES
#if BAKED_SCENE
fn sphere_count() -> u32 { return SPHERE_COUNT; }
#else
@group(1) @binding(2) var<storage, read> spheres: array<Sphere>;
fn sphere_count() -> u32 { return arrayLength(&spheres); }
#endif
#endif

fn intersect_scene(ray: Ray) -> Hit {
    var hit = no_hit();
#if QUADS
    var quad_index = 0xffffffffu;
    for (var i = 0u; i < quad_count(); i++) {
        let t = quad_hit_t(quads[i], ray, hit.t);
        if t > 0.0 {
            hit.t = t;
            quad_index = i;
        }
    }
#endif
#if SPHERES
    var sphere_index = 0xffffffffu;
    for (var i = 0u; i < sphere_count(); i++) {
        let t = sphere_hit_t(spheres[i], ray, hit.t);
        if t > 0.0 {
            hit.t = t;
            sphere_index = i;
        }
    }
#endif
    // Shading data only for the closest hit; a later kind's hit is closer.
    hit.p = ray.origin + hit.t * ray.dir;
#if SPHERES
    if sphere_index != 0xffffffffu {
        let sphere = spheres[sphere_index];
        hit.normal = (hit.p - sphere.center) / sphere.radius;
        hit.material = sphere.material;
        return hit;
    }
#endif
#if QUADS
    if quad_index != 0xffffffffu {
        hit.normal = quads[quad_index].normal;
        hit.material = quads[quad_index].material;
    }
#endif
    return hit;
}
