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
//
// The cost is the loads (lavapipe loads a storage buffer lane by lane), so an
// invocation gathers a column of SPLAT_STRIP_ROWS = 4 pixels (written out
// below: arrays indexed by a loop variable cost more than they save), and each
// sample it loads serves every pixel of the column it reaches: with Mitsuba's
// Gaussian, 8 rows of 5 samples for 4 pixels instead of 25 samples per pixel.
// Each pixel still adds its samples row by row, column by column: the same
// sums, bit for bit, as a pixel gathering alone.

// The sums of one pixel of an invocation's strip, and the scale of its totals.
struct PixelSums {
    radiance: CompensatedSum,
#if VARIANCE
    squares: CompensatedSum,
#endif
#if REPLICATE_SUMS
    replicates: array<CompensatedSum, REPLICATES - 1u>,
#endif
    scale: f32,
}

// A strip's pixel below the image's edge loads and stores nothing.
fn load_pixel_sums(pixel: vec2<u32>, reset: bool) -> PixelSums {
    var sums: PixelSums;
    if pixel.y >= params.height {
        return sums;
    }
    sums.radiance = load_sum(pixel, LAYER_SUM, LAYER_SUM_COMPENSATION, reset);
#if VARIANCE
    sums.squares = load_sum(pixel, LAYER_SQUARES, LAYER_SQUARES_COMPENSATION, reset);
#endif
#if REPLICATE_SUMS
    for (var r = 0u; r < REPLICATES - 1u; r++) {
        sums.replicates[r] = load_sum(pixel, LAYER_REPLICATES + 2u * r, LAYER_REPLICATES + 2u * r + 1u, reset);
    }
#endif
    let far = vec2<u32>(params.width - 1u, params.height - 1u) - pixel;
    let integral_x = splat_edge_integral(min(pixel.x, SPLAT_REACH)) + splat_edge_integral(min(far.x, SPLAT_REACH));
    let integral_y = splat_edge_integral(min(pixel.y, SPLAT_REACH)) + splat_edge_integral(min(far.y, SPLAT_REACH));
    sums.scale = 1.0 / (integral_x * integral_y);
    return sums;
}

fn store_pixel_sums(pixel: vec2<u32>, sums: PixelSums) {
    if pixel.y >= params.height {
        return;
    }
    store_sum(pixel, LAYER_SUM, LAYER_SUM_COMPENSATION, sums.radiance);
#if VARIANCE
    store_sum(pixel, LAYER_SQUARES, LAYER_SQUARES_COMPENSATION, sums.squares);
#endif
#if REPLICATE_SUMS
    for (var r = 0u; r < REPLICATES - 1u; r++) {
        store_sum(pixel, LAYER_REPLICATES + 2u * r, LAYER_REPLICATES + 2u * r + 1u, sums.replicates[r]);
    }
#endif
}

// Adds T_k of sample index `sample`: the weighted sum `weighted` times the scale.
// (Copies in and out: naga cannot pass a pointer to a struct's member.)
fn add_total(sums: ptr<function, PixelSums>, weighted: vec3<f32>, sample: u32) {
    let total = weighted * (*sums).scale;
    var radiance = (*sums).radiance;
    compensated_add(&radiance, total);
    (*sums).radiance = radiance;
#if VARIANCE
#if ADAPTIVE
    // Adaptive sampling decides from replicate 0's squares alone (kernel.wgsl).
    if sample % REPLICATES == 0u {
#endif
    var squares = (*sums).squares;
    compensated_add(&squares, total * total);
    (*sums).squares = squares;
#if ADAPTIVE
    }
#endif
#endif
#if REPLICATE_SUMS
    let replicate = sample % REPLICATES;
    for (var r = 0u; r < REPLICATES - 1u; r++) {
        if replicate == r + 1u {
            var replicate_sum = (*sums).replicates[r];
            compensated_add(&replicate_sum, total);
            (*sums).replicates[r] = replicate_sum;
        }
    }
#endif
}

// The weight of sample `s` of the pixel `dy` rows below this one, its x
// weight `weight_x` given: f(x - c_x) f(y - c_y).
fn splat_weight(weight_x: f32, dy: i32, s: SplatSample) -> f32 {
    return weight_x * filter_eval(abs(f32(dy) + s.y - 0.5));
}

// The strip's pixels are written out below (sums0 to sums3).
const_assert SPLAT_STRIP_ROWS == 4u;

@compute @workgroup_size(WORKGROUP_SIZE_X, WORKGROUP_SIZE_Y, 1)
fn splat(@builtin(global_invocation_id) id: vec3<u32>) {
    load_params();
    let first = vec2<u32>(id.x, id.y * SPLAT_STRIP_ROWS);
    if first.x >= params.width || first.y >= params.height {
        return;
    }
    let reset = params.reset != 0u;
    var sums0 = load_pixel_sums(first, reset);
    var sums1 = load_pixel_sums(first + vec2<u32>(0u, 1u), reset);
    var sums2 = load_pixel_sums(first + vec2<u32>(0u, 2u), reset);
    var sums3 = load_pixel_sums(first + vec2<u32>(0u, 3u), reset);
    let reach = i32(SPLAT_REACH);
    let image_pixels = params.width * params.height;
    for (var k = 0u; k < params.sample_count; k++) {
        var weighted0 = vec3<f32>(0.0);
        var weighted1 = vec3<f32>(0.0);
        var weighted2 = vec3<f32>(0.0);
        var weighted3 = vec3<f32>(0.0);
        // `row`: from the strip's first pixel; pixel j's dy is row - j.
        for (var row = -reach; row < i32(SPLAT_STRIP_ROWS) + reach; row++) {
            let y = i32(first.y) + row;
            if y < 0 || y >= i32(params.height) {
                continue;
            }
            for (var dx = -reach; dx <= reach; dx++) {
                let x = i32(first.x) + dx;
                if x < 0 || x >= i32(params.width) {
                    continue;
                }
                let s = splat_samples[k * image_pixels + u32(y) * params.width + u32(x)];
                let radiance = vec3<f32>(s.r, s.g, s.b);
                let weight_x = filter_eval(abs(f32(dx) + s.x - 0.5));
                if row <= reach {
                    weighted0 += splat_weight(weight_x, row, s) * radiance;
                }
                if row >= 1 - reach && row <= 1 + reach {
                    weighted1 += splat_weight(weight_x, row - 1, s) * radiance;
                }
                if row >= 2 - reach && row <= 2 + reach {
                    weighted2 += splat_weight(weight_x, row - 2, s) * radiance;
                }
                if row >= 3 - reach {
                    weighted3 += splat_weight(weight_x, row - 3, s) * radiance;
                }
            }
        }
        let sample = params.sample_start + k;
        add_total(&sums0, weighted0, sample);
        add_total(&sums1, weighted1, sample);
        add_total(&sums2, weighted2, sample);
        add_total(&sums3, weighted3, sample);
    }
    store_pixel_sums(first, sums0);
    store_pixel_sums(first + vec2<u32>(0u, 1u), sums1);
    store_pixel_sums(first + vec2<u32>(0u, 2u), sums2);
    store_pixel_sums(first + vec2<u32>(0u, 3u), sums3);
}
