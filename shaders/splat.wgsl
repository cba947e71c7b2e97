// The splatting pass (`gpu::pipeline`, Mitsuba's reconstruction): once the
// kernel has traced a submission's samples of every pixel into `splat_samples`,
// each pixel adds to its sums, sample index by sample index, the samples of
// every pixel its filter reaches, each weighted by the filter at its offset
// from this pixel's centre. The sums then hold, per sample index k,
//
//     T_k = sum over the pixels q around of f(x_qk - c) L_qk / (F_x F_y),
//
// F_x F_y being the filter's integral over the image around the centre c: the
// mean of T_k over k is an unbiased estimate of the image filtered by f (with
// the filter truncated at the image's edges, as Mitsuba's film truncates it).
// The T_k of different k are independent (or, with Sobol, the replicates'
// sums are), so the error estimate stays honest. The order of the additions
// depends only on the sample indices: the same sums however the samples are
// split into submissions.

@compute @workgroup_size(WORKGROUP_SIZE_X, WORKGROUP_SIZE_Y, 1)
fn splat(@builtin(global_invocation_id) id: vec3<u32>) {
    load_params();
    if id.x >= params.width || id.y >= params.height {
        return;
    }
    let pixel = id.xy;
    let reset = params.reset != 0u;
    var radiance_sum = load_sum(pixel, LAYER_SUM, LAYER_SUM_COMPENSATION, reset);
#if VARIANCE
    var squares_sum = load_sum(pixel, LAYER_SQUARES, LAYER_SQUARES_COMPENSATION, reset);
#endif
#if REPLICATE_SUMS
    var replicate_sums: array<CompensatedSum, REPLICATES - 1u>;
    for (var r = 0u; r < REPLICATES - 1u; r++) {
        replicate_sums[r] = load_sum(pixel, LAYER_REPLICATES + 2u * r, LAYER_REPLICATES + 2u * r + 1u, reset);
    }
#endif
    let far = vec2<u32>(params.width - 1u, params.height - 1u) - pixel;
    let integral_x = splat_edge_integral(min(pixel.x, SPLAT_REACH)) + splat_edge_integral(min(far.x, SPLAT_REACH));
    let integral_y = splat_edge_integral(min(pixel.y, SPLAT_REACH)) + splat_edge_integral(min(far.y, SPLAT_REACH));
    let scale = 1.0 / (integral_x * integral_y);
    let reach = i32(SPLAT_REACH);
    let image_pixels = params.width * params.height;
    for (var k = 0u; k < params.sample_count; k++) {
        var total = vec3<f32>(0.0);
        for (var dy = -reach; dy <= reach; dy++) {
            let y = i32(pixel.y) + dy;
            if y < 0 || y >= i32(params.height) {
                continue;
            }
            for (var dx = -reach; dx <= reach; dx++) {
                let x = i32(pixel.x) + dx;
                if x < 0 || x >= i32(params.width) {
                    continue;
                }
                let s = splat_samples[k * image_pixels + u32(y) * params.width + u32(x)];
                let offset = vec2<f32>(f32(dx), f32(dy)) + vec2<f32>(s.x, s.y) - 0.5;
                let weight = filter_eval(abs(offset.x)) * filter_eval(abs(offset.y));
                total += weight * vec3<f32>(s.r, s.g, s.b);
            }
        }
        total *= scale;
        compensated_add(&radiance_sum, total);
#if VARIANCE
        compensated_add(&squares_sum, total * total);
#endif
#if REPLICATE_SUMS
        let replicate = (params.sample_start + k) % REPLICATES;
        for (var r = 0u; r < REPLICATES - 1u; r++) {
            if replicate == r + 1u {
                var replicate_sum = replicate_sums[r];
                compensated_add(&replicate_sum, total);
                replicate_sums[r] = replicate_sum;
            }
        }
#endif
    }
    store_sum(pixel, LAYER_SUM, LAYER_SUM_COMPENSATION, radiance_sum);
#if VARIANCE
    store_sum(pixel, LAYER_SQUARES, LAYER_SQUARES_COMPENSATION, squares_sum);
#endif
#if REPLICATE_SUMS
    for (var r = 0u; r < REPLICATES - 1u; r++) {
        store_sum(pixel, LAYER_REPLICATES + 2u * r, LAYER_REPLICATES + 2u * r + 1u, replicate_sums[r]);
    }
#endif
}
