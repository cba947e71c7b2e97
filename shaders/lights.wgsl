// The light density p_light: the average of the solid-angle densities of every
// object in the light density (emitters, and objects marked for importance).
// Choosing one object uniformly and sampling it draws from exactly this density.

// Each `*_at(i)` reads one object by index; a baked scene generates them.
#if !BAKED_SCENE
#if LIGHT_QUADS
@group(1) @binding(3) var<storage, read> light_quads: array<Quad>;
fn light_quads_at(i: u32) -> Quad { return light_quads[i]; }
#endif
#if LIGHT_SPHERES
@group(1) @binding(4) var<storage, read> light_spheres: array<Sphere>;
fn light_spheres_at(i: u32) -> Sphere { return light_spheres[i]; }
#endif
#endif

fn light_quad_count() -> u32 {
#if LIGHT_QUADS
#if BAKED_SCENE
    return LIGHT_QUADS_COUNT;
#else
    return arrayLength(&light_quads);
#endif
#else
    return 0u;
#endif
}

fn light_sphere_count() -> u32 {
#if LIGHT_SPHERES
#if BAKED_SCENE
    return LIGHT_SPHERES_COUNT;
#else
    return arrayLength(&light_spheres);
#endif
#else
    return 0u;
#endif
}

// A direction from `origin` drawn from the light density: `select` (uniform in
// [0, 1)) picks the object, `u` the point on it.
fn light_sample(origin: vec3<f32>, select: f32, u: vec2<f32>) -> vec3<f32> {
    let quad_count = light_quad_count();
    let count = quad_count + light_sphere_count();
    let k = min(u32(select * f32(count)), count - 1u);
#if LIGHT_QUADS
    if k < quad_count {
        return quad_light_sample(light_quads_at(k), origin, u);
    }
#endif
#if LIGHT_SPHERES
    return sphere_light_sample(light_spheres_at(k - quad_count), origin, u);
#else
    return vec3<f32>(0.0, 1.0, 0.0); // unreachable: k < quad_count
#endif
}

fn light_pdf(origin: vec3<f32>, dir: vec3<f32>) -> f32 {
    var total = 0.0;
#if LIGHT_QUADS
#for_each light in light_quads
    total += quad_light_pdf(light, origin, dir);
#end_for
#endif
#if LIGHT_SPHERES
#for_each light in light_spheres
    total += sphere_light_pdf(light, origin, dir);
#end_for
#endif
    return total / f32(light_quad_count() + light_sphere_count());
}
