// Point, spot and directional lights (Mitsuba's `point`, `spot` and
// `directional`; the last under DIRECTIONAL_LIGHTS): delta lights, which no
// sampled direction can hit. Whatever the strategy, each vertex with a smooth
// lobe sends shadow rays toward them (`delta_shadow_rays`); the kernel traces
// them and adds what they carry where nothing is in the way.

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
    // 1: a directional light (at infinity, shining along `direction`,
    // `intensity` its irradiance); 0: a point or spot light.
    infinite: f32,
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

// Whether delta lights light this vertex: a smooth lobe, and a side that scatters.
fn delta_lights_reach(m: Material, frame: Frame) -> bool {
#if ONE_SIDED
    if (m.flags & MATERIAL_ONE_SIDED) != 0u && !frame.front_face {
        return false;
    }
#endif
    return bsdf_is_smooth(m);
}

// Shadow rays per vertex: one toward each light, or, in scenes with more than
// `KernelConfig::MAX_DELTA_SHADOW_RAYS`, one toward a light picked by power.
fn delta_shadow_rays() -> u32 {
#if DELTA_LIGHTS_PICK
    return 1u;
#else
    return delta_lights_count();
#endif
}

// The light of shadow ray `i`, its `pmf` the probability that a vertex estimates it.
fn delta_light_chosen(i: u32) -> DeltaLight {
#if DELTA_LIGHTS_PICK
    let u = sample_1d();
    var light = delta_lights_at(0u);
    for (var j = 1u; j < delta_lights_count(); j++) {
        if u >= light.cdf {
            light = delta_lights_at(j);
        }
    }
    return light;
#else
    var light = delta_lights_at(i);
    light.pmf = 1.0;
    return light;
#endif
}

// The shadow ray toward `light` from the point `hit`.
fn delta_light_shadow(m: Material, frame: Frame, wo: vec3<f32>, hit: Hit, light: DeltaLight) -> DeltaShadow {
#if DIRECTIONAL_LIGHTS
    if light.infinite != 0.0 {
        // At infinity: toward it, with no end (a ray that escapes is unoccluded),
        // the irradiance times f |cos|, no falloff, no distance.
        let wi = -light.direction;
        let f = bsdf_eval(m, frame, wo, wi);
        let origin = offset_origin(hit.p, hit.normal, wi, hit.offset);
        return DeltaShadow(Ray(origin, wi), F32_MAX, f * light.intensity / light.pmf);
    }
#endif
    let to_light = light.position - hit.p;
    let distance_sqr = dot(to_light, to_light);
    let wi = to_light * inverseSqrt(distance_sqr);
    let falloff = delta_light_falloff(light, dot(-wi, light.direction));
    let f = bsdf_eval(m, frame, wo, wi);
    let origin = offset_origin(hit.p, hit.normal, wi, hit.offset);
    let weight = f * light.intensity * (falloff / (distance_sqr * light.pmf));
    return DeltaShadow(Ray(origin, wi), length(light.position - origin), weight);
}
