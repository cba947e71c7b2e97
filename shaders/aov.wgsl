// The AOV pass (`kinds::aov`): one invocation per pixel traces the camera rays
// of `sample_count` samples in sample-index order and adds what each finds
// first, weighted as the pixel filter weighs it, to the pixel's running sums
// of the AOVs asked for: one compensated sum per AOV type (its values in the
// first components), in accumulator layers 2 * AOV_SLOT_NAME and the one after,
// over the dispatch's band of rows.
// The generated `aov_layout` module names the slots.

// Mitsuba's `eval_diffuse_reflectance`: the material's own where its albedo is
// that (`MaterialModel::diffuse_reflectance_is_albedo`), else its BSDF's value
// toward the shading normal times pi (a one-sided material is black from behind).
fn diffuse_reflectance(m: Material, frame: Frame, wo: vec3<f32>) -> vec3<f32> {
    if albedo_is_diffuse_reflectance(m) {
        return m.albedo;
    }
#if ONE_SIDED
    if (m.flags & MATERIAL_ONE_SIDED) != 0u && !frame.front_face {
        return vec3<f32>(0.0);
    }
#endif
    return bsdf_eval(m, frame, wo, frame.n) * PI;
}

// Each AOV slot's value where `ray` first meets a surface; all zero where it
// escapes, as in Mitsuba.
fn first_hit_aovs(ray: Ray) -> array<vec3<f32>, AOV_SLOTS> {
    var values: array<vec3<f32>, AOV_SLOTS>;
    let hit = intersect_scene(ray);
    if hit.t == F32_MAX {
        return values;
    }
#if AOV_DEPTH
    values[AOV_SLOT_DEPTH] = vec3<f32>(hit.t, 0.0, 0.0);
#endif
#if AOV_POSITION
    values[AOV_SLOT_POSITION] = hit.p;
#endif
#if AOV_UV
    values[AOV_SLOT_UV] = vec3<f32>(hit.uv, 0.0);
#endif
#if AOV_GEO_NORMAL
    values[AOV_SLOT_GEO_NORMAL] = hit.normal;
#endif
#if AOV_MATERIAL
    // The material the hit scatters by, as the path kernel resolves it.
    let front_face = dot(ray.dir, hit.normal) < 0.0;
    let side = material_side(hit, ray.dir, front_face);
    let scattering = hit_material(materials_at(hit.material), side, hit);
    let material = scattering.material;
#if BUMP_MAPS
    let shading_normal = bumped_normal(material, hit, -ray.dir);
#else
    let shading_normal = hit.shading_normal;
#endif
#if AOV_SH_NORMAL
    values[AOV_SLOT_SH_NORMAL] = shading_normal;
#endif
#if AOV_ALBEDO
    let frame = hit_frame(hit, shading_normal, front_face, side, scattering.front_face);
    values[AOV_SLOT_ALBEDO] = diffuse_reflectance(material, frame, -ray.dir);
#endif
#endif
    return values;
}

@compute @workgroup_size(WORKGROUP_SIZE_X, WORKGROUP_SIZE_Y, 1)
fn aovs(
    @builtin(workgroup_id) group: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(local_invocation_id) local: vec3<u32>,
) {
    load_params();
    // Rows spread over lavapipe's threads as in the path kernel (kernel.wgsl).
    let group_row = (group.y * params.workgroup_row_step) % groups.y;
    let id = vec2<u32>(group.x * WORKGROUP_SIZE_X + local.x, group_row * WORKGROUP_SIZE_Y + local.y);
    if id.x >= params.tile_size.x || id.y >= params.tile_size.y {
        return;
    }
    let pixel = params.tile_origin + id;
    let pixel_index = pixel.y * params.width + pixel.x;
    let reset = params.reset != 0u;
    // The sums hold the dispatch's band of rows (`render::aov`): they are
    // indexed from its first row.
    var sums: array<CompensatedSum, AOV_SLOTS>;
    for (var s = 0u; s < AOV_SLOTS; s++) {
        sums[s] = load_sum(id, 2u * s, 2u * s + 1u, reset);
    }
    for (var i = 0u; i < params.sample_count; i++) {
        sampler_begin(pixel_index, params.sample_start + i);
        let camera = camera_ray(pixel);
        let values = first_hit_aovs(camera.ray);
        // Through a copy, as in kernel.wgsl: naga's SPIR-V writer fails on a
        // pointer to an indexed element passed to a function.
        for (var s = 0u; s < AOV_SLOTS; s++) {
            var sum = sums[s];
            compensated_add(&sum, camera.weight * values[s]);
            sums[s] = sum;
        }
    }
    for (var s = 0u; s < AOV_SLOTS; s++) {
        store_sum(id, 2u * s, 2u * s + 1u, sums[s]);
    }
}
