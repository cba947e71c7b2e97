// The path tracing kernel: one invocation per pixel traces `sample_count` paths
// in sample-index order. A lane whose path ends starts its next sample at once
// instead of idling until the longest path of its SIMD group is done.
//
// The running sums are compensated (`shaders/sums.wgsl`).

#if MASK
// Mitsuba's `mask`: a masked material holds its transparency (1 - opacity)
// above MATERIAL_TRANSPARENCY_SHIFT of its kind, in fixed point
// (`kinds::material::MATERIAL_TRANSPARENCY_SHIFT`), or, with the flag
// MATERIAL_OPACITY_TEXTURE, its opacity texture's index + 1 there: the opacity
// is then the texture's value as a number at the hit, clamped to [0, 1]
// (Mitsuba's `eval_1`), and the path draws against it as against a constant.
fn material_transparency(m: Material, hit: Hit) -> f32 {
#if OPACITY_TEXTURES
    if (m.flags & MATERIAL_OPACITY_TEXTURE) != 0u {
        let opacity = texture_eval_number((m.kind >> MATERIAL_TRANSPARENCY_SHIFT) - 1u, hit.uv);
        return 1.0 - clamp(opacity, 0.0, 1.0);
    }
#endif
    return f32(m.kind >> MATERIAL_TRANSPARENCY_SHIFT) / f32(MATERIAL_TRANSPARENCY_MAX);
}

// A hit found by a ray that started `travelled` along from where it was aimed:
// its distance from there (what a light point's density is measured by).
fn walked(hit: Hit, travelled: f32) -> Hit {
    var out = hit;
    out.t = select(hit.t + travelled, hit.t, hit.t == F32_MAX);
    return out;
}

// How much of a delta light's shadow ray reaches `distance`: the product of
// the transparencies of the surfaces before it, of at most MASK_RAY_HITS (one
// still in the way at the last counts as opaque). Each closest hit counts as a
// segment.
fn shadow_transmittance(ray: Ray, distance: f32, segments: ptr<function, u32>) -> f32 {
    var walk = ray;
    var travelled = 0.0;
    var transmittance = 1.0;
    for (var k = 0u; k < MASK_RAY_HITS; k++) {
        let hit = walked(intersect_scene(walk), travelled);
        *segments += 1u;
        if hit.t >= distance {
            return transmittance;
        }
        transmittance *= material_transparency(materials_at(hit.material), hit);
        if transmittance == 0.0 {
            return 0.0;
        }
        walk = Ray(offset_origin(hit.p, hit.normal, walk.dir, hit.offset), walk.dir);
        travelled = hit.t;
    }
    return 0.0;
}
#endif

#if ADAPTIVE
// Adaptive sampling: the pixels this round samples (the index, and the pixel's
// sample count when the round began), laid out in rows of `params.width`
// entries that the dispatch's tile covers like an image. A dispatch traces
// samples `sample_start..` of the round, so each pixel continues its own
// sequence; finished pixels are not in the list and cost nothing.
@group(0) @binding(BINDING_ACTIVE_PIXELS) var<storage, read> active_pixels: array<vec2<u32>>;
#endif

@compute @workgroup_size(WORKGROUP_SIZE_X, WORKGROUP_SIZE_Y, 1)
fn render(
    @builtin(workgroup_id) group: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(local_invocation_id) local: vec3<u32>,
#if PROFILE
    @builtin(subgroup_size) subgroup_size: u32,
#endif
) {
    load_params();
#if PROFILE
    profile_subgroup_size = subgroup_size;
#endif
    // lavapipe gives each thread one contiguous range of a dispatch's workgroups:
    // in order, one thread would take the sky and another the ground. Stepping
    // through the rows spreads every range over the whole tile.
    let group_row = (group.y * params.workgroup_row_step) % groups.y;
    let id = vec2<u32>(group.x * WORKGROUP_SIZE_X + local.x, group_row * WORKGROUP_SIZE_Y + local.y);
    if id.x >= params.tile_size.x || id.y >= params.tile_size.y {
        return;
    }
#if ADAPTIVE
    let entry_index = (params.tile_origin.y + id.y) * params.width + id.x;
    if entry_index >= params.active_count {
        return;
    }
    let entry = active_pixels[entry_index];
    let pixel_index = entry.x;
    let pixel = vec2<u32>(pixel_index % params.width, pixel_index / params.width);
    let sample_start = entry.y + params.sample_start;
    // A pixel's first samples start its sums.
    let reset = sample_start == 0u;
#else
    let pixel = params.tile_origin + id;
    let pixel_index = pixel.y * params.width + pixel.x;
    let sample_start = params.sample_start;
    let reset = params.reset != 0u;
#endif

#if SPLAT
    // Each sample goes to the splatting pass, which adds it to the sums of
    // every pixel its filter reaches (splat.wgsl); an adaptive kernel's only
    // in its uniform rounds (`params.splatting`).
    let image_pixels = params.width * params.height;
#endif
#if KERNEL_SUMS
    var radiance_sum = load_sum(pixel, LAYER_SUM, LAYER_SUM_COMPENSATION, reset);
#if VARIANCE
    var squares_sum = load_sum(pixel, LAYER_SQUARES, LAYER_SQUARES_COMPENSATION, reset);
#endif
#if REPLICATE_SUMS
    // Replicates 1.. (see `sampler_begin`); replicate 0's is the total minus theirs.
    var replicate_sums: array<CompensatedSum, REPLICATES - 1u>;
    for (var r = 0u; r < REPLICATES - 1u; r++) {
        replicate_sums[r] = load_sum(pixel, LAYER_REPLICATES + 2u * r, LAYER_REPLICATES + 2u * r + 1u, reset);
    }
#endif
#endif

    var samples_done = 0u;
    var segments = 0u;
    sampler_begin(pixel_index, sample_start);
    var camera = camera_ray(pixel);
    var ray = camera.ray;
    var throughput = vec3<f32>(camera.weight);
    var radiance = vec3<f32>(0.0);
    var depth = 0u;
#if STRATEGY_NEE
    // How the last bounce drew the ray: a delta lobe (or the camera) counts the
    // emission it finds fully; otherwise the densities give its MIS weight.
    var last_delta = true;
    var last_bsdf_pdf = 0.0;
    var last_light_pdf = 0.0;
#if MASK
    // How far the ray has come from the last bounce through masked surfaces.
    var travelled = 0.0;
#endif
#endif
#if MASK
    // The masked surfaces the ray has passed since the last bounce.
    var passes = 0u;
#endif
    loop {
        var path_done = false;
#if PROFILE
        profile(STAGE_PATH_STEP);
        profile_walk = STAGE_CLOSEST_NODES;
#endif
        let hit = intersect_scene(ray);
#if PROFILE
        // Every other walk of this step is a shadow ray's.
        profile_walk = STAGE_SHADOW_NODES;
#endif
        segments += 1u;
        if hit.t == F32_MAX {
#if ENVIRONMENT
#if STRATEGY_NEE
            // After a smooth bounce the light sample could have found this direction too.
            var mis = 1.0;
            if !last_delta {
                mis = power_heuristic(last_bsdf_pdf, last_light_pdf);
            }
            radiance += throughput * environment_radiance(ray.dir) * mis;
#else
            radiance += throughput * environment_radiance(ray.dir);
#endif
#else
            radiance += throughput * params.background;
#endif
            path_done = true;
        } else {
            // The emission and opacity are the hit material's own; the material
            // it scatters by may be one it nests (materials.wgsl).
            let front_face = dot(ray.dir, hit.normal) < 0.0;
            let found = materials_at(hit.material);
            let side = material_side(hit, ray.dir, front_face);
            let scattering = hit_material(found, side, hit);
            let material = scattering.material;
#if MASK
            let transparency = material_transparency(found, hit);
#endif
            if front_face {
#if STRATEGY_NEE
                // After a smooth bounce the shadow ray could have found this emitter too.
                var mis = 1.0;
                if !last_delta {
#if LIGHT_POINTS
#if MASK
                    mis = power_heuristic(last_bsdf_pdf, last_light_pdf + light_point_pdf(walked(hit, travelled), ray.dir));
#else
                    mis = power_heuristic(last_bsdf_pdf, last_light_pdf + light_point_pdf(hit, ray.dir));
#endif
#else
                    mis = power_heuristic(last_bsdf_pdf, last_light_pdf);
#endif
                }
                radiance += throughput * material.emit * mis;
#else
                radiance += throughput * material.emit;
#endif
            }
#if MASK
            // Whether the surface is there is drawn before the depth test: a null
            // event is no bounce, so a ray from the last bounce goes on through
            // masks to what its shadow ray would find.
            if transparency > 0.0 && sample_1d() < transparency {
                // A null event: the surface is not there, and the ray goes on
                // unchanged, not counted toward MAX_DEPTH (the shadow ray's
                // transmittance spends no depth either, so every strategy sees
                // the same light). The MIS state of the last bounce is kept: its
                // shadow ray let this surface through by its transparency, as
                // this continuation does on average. The ray ends at its
                // MASK_RAY_HITS-th surface, where a shadow ray stops too.
                passes += 1u;
                if passes == MASK_RAY_HITS {
                    path_done = true;
                } else {
                    ray = Ray(offset_origin(hit.p, hit.normal, ray.dir, hit.offset), ray.dir);
#if STRATEGY_NEE
                    travelled = walked(hit, travelled).t;
#endif
                }
            } else if depth == MAX_DEPTH {
#else
            if depth == MAX_DEPTH {
#endif
                path_done = true;
            } else {
#if BUMP_MAPS
                let shading_normal = bumped_normal(material, hit, -ray.dir);
#else
                let shading_normal = hit.shading_normal;
#endif
                let frame = hit_frame(hit, shading_normal, front_face, side, scattering.front_face);
#if DELTA_LIGHTS
                // No strategy's sampled direction finds a point or spot light: every
                // strategy estimates them by these shadow rays.
                if delta_lights_reach(material, frame) {
                    for (var j = 0u; j < delta_shadow_rays(); j++) {
                        let delta = delta_light_shadow(material, frame, -ray.dir, hit, delta_light_chosen(j));
                        if any(delta.weight > vec3<f32>(0.0)) {
#if MASK
                            radiance += throughput * delta.weight * shadow_transmittance(delta.ray, delta.distance, &segments);
#else
                            segments += 1u;
                            if !occluded(delta.ray, delta.distance) {
                                radiance += throughput * delta.weight;
                            }
#endif
                        }
                    }
                }
#endif
#if PROFILE
                profile(STAGE_SHADING);
#endif
                let scattered = scatter(material, frame, -ray.dir, hit.p + frame.ng * hit.offset);
#if STRATEGY_NEE
                // The shadow ray is traced within the vertex's iteration. As an
                // iteration of its own, lanes drifted out of step (some tracing
                // shadow rays while others shade), which cost 18-38% of the speed.
                if any(scattered.shadow_weight > vec3<f32>(0.0)) {
#if MASK
                    // Through masked surfaces: each emitter the shadow ray finds
                    // counts by the transparency of those before it (`throughput`,
                    // within the loop, includes it), as a continuation in the same
                    // direction finds it by chance; it ends at an opaque surface,
                    // or after MASK_RAY_HITS surfaces.
                    var shadow_ray = Ray(offset_origin(hit.p, hit.normal, scattered.shadow_dir, hit.offset), scattered.shadow_dir);
                    var transmittance = 1.0;
                    var shadow_travelled = 0.0;
                    for (var k = 0u; k < MASK_RAY_HITS; k++) {
                    let throughput = throughput * transmittance;
                    let shadow_hit = walked(intersect_scene(shadow_ray), shadow_travelled);
#else
                    let shadow_ray = Ray(offset_origin(hit.p, hit.normal, scattered.shadow_dir, hit.offset), scattered.shadow_dir);
#if SHADOW_LIGHTS_FIRST
                    // The nearest light, then whether anything nearer hides it.
                    let shadow_hit = intersect_shadow_ray(shadow_ray);
#else
                    let shadow_hit = intersect_scene(shadow_ray);
#endif
#endif
                    segments += 1u;
#if LIGHT_POINTS
                    // A grouped light's sample counts only where the shadow ray finds the
                    // point it aimed at first (its density is that point's); any other
                    // sample, whatever emitter it finds, with that emitter's point share.
                    let aimed = scattered.shadow_light == NO_LIGHT || scattered.shadow_light == shadow_hit.light;
                    let light_density = scattered.shadow_pdfs.y + light_point_pdf(shadow_hit, shadow_ray.dir);
                    var shadow_weight = vec3<f32>(0.0);
                    if aimed && light_density > 0.0 {
                        shadow_weight = scattered.shadow_weight * (power_heuristic(light_density, scattered.shadow_pdfs.x) / light_density);
                    }
#else
                    let shadow_weight = scattered.shadow_weight;
#endif
                    // Unoccluded emitter facing the shading point: the light sample's contribution.
                    if shadow_hit.t < F32_MAX && dot(shadow_ray.dir, shadow_hit.normal) < 0.0 {
                        radiance += throughput * shadow_weight * materials_at(shadow_hit.material).emit;
                    }
#if ENVIRONMENT
                    // Unoccluded to infinity: the environment's radiance (whichever object was sampled).
                    if shadow_hit.t == F32_MAX {
                        radiance += throughput * shadow_weight * environment_radiance(shadow_ray.dir);
                    }
#endif
#if MASK
                    if shadow_hit.t == F32_MAX {
                        break;
                    }
                    transmittance *= material_transparency(materials_at(shadow_hit.material), shadow_hit);
                    if transmittance == 0.0 {
                        break;
                    }
                    shadow_ray = Ray(offset_origin(shadow_hit.p, shadow_hit.normal, shadow_ray.dir, shadow_hit.offset), shadow_ray.dir);
                    shadow_travelled = shadow_hit.t;
                    }
#endif
                }
#endif
                if scattered.absorbed {
                    path_done = true;
                } else {
                    throughput *= scattered.weight;
                    ray = Ray(offset_origin(hit.p, hit.normal, scattered.dir, hit.offset), scattered.dir);
                    depth += 1u;
#if MASK
                    passes = 0u;
#if STRATEGY_NEE
                    travelled = 0.0;
#endif
#endif
                    // Russian roulette: end dim paths early, reweighting survivors (unbiased).
                    if depth >= RR_DEPTH {
                        let survive = clamp(max(throughput.x, max(throughput.y, throughput.z)), 0.05, 1.0);
                        if sample_1d() >= survive {
                            path_done = true;
                        } else {
                            throughput /= survive;
                        }
                    }
#if STRATEGY_NEE
                    last_delta = scattered.delta;
                    last_bsdf_pdf = scattered.bsdf_pdf;
                    last_light_pdf = scattered.light_pdf;
#endif
                }
            }
        }
        if path_done {
            // A NaN or infinite sample would poison the pixel forever: count it, add zero.
            if !all_finite(radiance) {
                atomicAdd(&counters.discarded, 1u);
                radiance = vec3<f32>(0.0);
            }
#if SPLAT
#if ADAPTIVE
            if params.splatting != 0u {
#endif
            splat_samples[samples_done * image_pixels + pixel_index] =
                SplatSample(radiance.x, radiance.y, radiance.z, camera.position.x, camera.position.y);
#if ADAPTIVE
            }
#endif
#endif
#if KERNEL_SUMS
#if SPLAT
            if params.splatting == 0u {
#endif
            compensated_add(&radiance_sum, radiance);
#if VARIANCE
#if ADAPTIVE
            // Adaptive sampling decides from replicate 0 alone, so only its squares
            // are summed; the image comes from the other replicates (`crate::adaptive`).
            if (sample_start + samples_done) % REPLICATES == 0u {
                compensated_add(&squares_sum, radiance * radiance);
            }
#else
            compensated_add(&squares_sum, radiance * radiance);
#endif
#endif
#if REPLICATE_SUMS
            let replicate = (sample_start + samples_done) % REPLICATES;
            // Constant indices once unrolled, so the sums can stay in registers.
            // Through a copy: naga's SPIR-V writer fails on a pointer to an indexed
            // element passed to a function.
            for (var r = 0u; r < REPLICATES - 1u; r++) {
                if replicate == r + 1u {
                    var replicate_sum = replicate_sums[r];
                    compensated_add(&replicate_sum, radiance);
                    replicate_sums[r] = replicate_sum;
                }
            }
#endif
#if SPLAT
            }
#endif
#endif
            samples_done += 1u;
            if samples_done == params.sample_count {
                break;
            }
            sampler_begin(pixel_index, sample_start + samples_done);
            camera = camera_ray(pixel);
            ray = camera.ray;
            throughput = vec3<f32>(camera.weight);
            radiance = vec3<f32>(0.0);
            depth = 0u;
#if STRATEGY_NEE
            last_delta = true;
#if MASK
            travelled = 0.0;
#endif
#endif
#if MASK
            passes = 0u;
#endif
        }
    }

    if samples_done != params.sample_count {
        atomicAdd(&counters.truncated, 1u);
    }
    let before = atomicAdd(&counters.segments_low, segments);
    if before > 0xffffffffu - segments {
        atomicAdd(&counters.segments_high, 1u);
    }
#if KERNEL_SUMS
#if SPLAT
    // A splatting round's sums are the splatting pass's to write.
    if params.splatting != 0u {
        return;
    }
#endif
    store_sum(pixel, LAYER_SUM, LAYER_SUM_COMPENSATION, radiance_sum);
#if VARIANCE
    store_sum(pixel, LAYER_SQUARES, LAYER_SQUARES_COMPENSATION, squares_sum);
#endif
#if REPLICATE_SUMS
    for (var r = 0u; r < REPLICATES - 1u; r++) {
        store_sum(pixel, LAYER_REPLICATES + 2u * r, LAYER_REPLICATES + 2u * r + 1u, replicate_sums[r]);
    }
#endif
#endif
}
