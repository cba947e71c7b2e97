// The scene's primitives and the closest-hit query. Only the kinds the scene
// contains are compiled in.
//
// The primitives live in storage buffers, or (BAKED_SCENE) in module constants
// generated from the same packed data (`KernelConfig::baked_scene_wgsl`), which
// `#for_each` unrolls into straight-line code the driver's compiler folds.

#if !BAKED_SCENE
#if QUADS
@group(1) @binding(1) var<storage, read> quads: array<Quad>;
#endif
#if SPHERES
@group(1) @binding(2) var<storage, read> spheres: array<Sphere>;
#endif
#endif

// The closest hit's shading data is kept as it is found, so no primitive is
// looked up again by a dynamic index.
fn intersect_scene(ray: Ray) -> Hit {
    var hit = no_hit();
#if QUADS
#for_each quad in quads
    let t = quad_hit_t(quad, ray, hit.t);
    if t > 0.0 {
        hit.t = t;
        hit.normal = quad.normal;
        hit.material = quad.material;
    }
#end_for
#endif
#if SPHERES
    var sphere_center = vec3<f32>(0.0);
    var sphere_radius = 0.0;
#for_each sphere in spheres
    let t = sphere_hit_t(sphere, ray, hit.t);
    if t > 0.0 {
        hit.t = t;
        hit.material = sphere.material;
        sphere_center = sphere.center;
        sphere_radius = sphere.radius;
    }
#end_for
#endif
    hit.p = ray.origin + hit.t * ray.dir;
#if SPHERES
    if sphere_radius != 0.0 {
        hit.normal = (hit.p - sphere_center) / sphere_radius;
    }
#endif
    return hit;
}
