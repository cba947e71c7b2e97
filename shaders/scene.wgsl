// The scene's primitives and the closest-hit query. Only the kinds the scene
// contains are compiled in.

#if QUADS
@group(1) @binding(1) var<storage, read> quads: array<Quad>;
#endif
#if SPHERES
@group(1) @binding(2) var<storage, read> spheres: array<Sphere>;
#endif

fn intersect_scene(ray: Ray) -> Hit {
    var hit = no_hit();
#if QUADS
    var quad_index = 0xffffffffu;
    for (var i = 0u; i < arrayLength(&quads); i++) {
        let t = quad_hit_t(quads[i], ray, hit.t);
        if t > 0.0 {
            hit.t = t;
            quad_index = i;
        }
    }
#endif
#if SPHERES
    var sphere_index = 0xffffffffu;
    for (var i = 0u; i < arrayLength(&spheres); i++) {
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
