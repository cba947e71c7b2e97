// Point and spot lights (Mitsuba's `point` and `spot`): delta lights, which no
// sampled direction can hit. Whatever the strategy, each vertex with a smooth
// lobe sends one shadow ray toward one of them, picked in proportion to its
// power; the kernel traces it and adds what it carries where nothing is in the way.

// Mirrors `lights::DeltaLight`.
struct DeltaLight {
    position: vec3<f32>,
    cos_cutoff: f32,
    intensity: vec3<f32>,
    cos_beam: f32,
    direction: vec3<f32>,
    cutoff: f32,
    inv_transition: f32,
    pmf: f32,
    cdf: f32,
    _pad: f32,
}

struct DeltaShadow {
    ray: Ray,
    // From the ray's origin to the light: whatever the ray hits nearer occludes it.
    distance: f32,
    // What the unoccluded light adds, times the path throughput: f |cos| times the
    // intensity, falloff and 1 / d^2, over the pick probability. Zero: no shadow ray.
    weight: vec3<f32>,
}

// Mitsuba's `falloff_curve` (spot.cpp) at the cosine of the angle from the axis:
// 1 within the beam width, 0 at and beyond the cutoff, linear in the angle between.
fn delta_light_falloff(light: DeltaLight, cos_theta: f32) -> f32 {
    let beam = select((light.cutoff - acos(cos_theta)) * light.inv_transition, 1.0, cos_theta >= light.cos_beam);
    return select(0.0, beam, cos_theta > light.cos_cutoff);
}

// `p` is the hit point, `normal` its geometric normal.
fn delta_light_shadow(m: Material, frame: Frame, wo: vec3<f32>, p: vec3<f32>, normal: vec3<f32>) -> DeltaShadow {
    // Drawn at every vertex, to keep the dimensions of what follows aligned.
    let u = sample_1d();
    let none = DeltaShadow(Ray(p, vec3<f32>(0.0)), 0.0, vec3<f32>(0.0));
    if !bsdf_is_smooth(m) {
        return none;
    }
#if ONE_SIDED
    if (m.flags & MATERIAL_ONE_SIDED) != 0u && !frame.front_face {
        return none;
    }
#endif
    var light = delta_lights_at(0u);
    for (var i = 1u; i < delta_lights_count(); i++) {
        if u >= light.cdf {
            light = delta_lights_at(i);
        }
    }
    let to_light = light.position - p;
    let distance_sqr = dot(to_light, to_light);
    let wi = to_light * inverseSqrt(distance_sqr);
    let falloff = delta_light_falloff(light, dot(-wi, light.direction));
    let f = bsdf_eval(m, frame, wo, wi);
    let origin = offset_origin(p, normal, wi);
    let weight = f * light.intensity * (falloff / (distance_sqr * light.pmf));
    return DeltaShadow(Ray(origin, wi), length(light.position - origin), weight);
}
