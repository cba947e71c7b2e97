// A uniform run's error estimate, reduced on the device (`gpu::error_estimate`):
// per strip of ERROR_STRIP_PIXELS pixels of a row, the sums over its pixels and
// channels of the mean and of the squared standard error of the mean, as
// `stats::Accumulation` defines them, and how many sums are NaN or infinite. The
// host adds the strips in f64, and reads back 12 bytes per strip instead of every
// layer of every pixel.
//
// In f32 where the host works in f64: the error of a pixel whose samples hardly
// vary comes out at up to about 2.4e-4 of its mean instead of 0 (the sample
// variance's cancellation, without replicates), far below any pilot's noise.

// Mirrors `gpu::error_estimate::EstimateParams`.
struct EstimateParams {
    width: u32,
    height: u32,
    // Samples per pixel.
    samples: u32,
    // Strips per row.
    strips: u32,
    // With replicates: samples per pixel in each.
    replicate_samples: vec4<u32>,
}

// Mirrors `gpu::error_estimate::ErrorStrip`.
struct ErrorStrip {
    mean: f32,
    squared_error: f32,
    non_finite: u32,
}

@group(0) @binding(BINDING_PARAMS) var<storage, read> params: EstimateParams;
@group(0) @binding(BINDING_ERROR_STRIPS) var<storage, read_write> strips: array<ErrorStrip>;

// A running sum less its compensation.
fn compensated_sum(pixel: vec2<u32>, layer: u32) -> vec3<f32> {
    return accumulator_load(pixel, layer).xyz - accumulator_load(pixel, layer + 1u).xyz;
}

// On the bits (all-ones exponent), which no floating-point optimisation can
// assume away.
fn count_non_finite(v: vec3<f32>) -> u32 {
    let exponent = bitcast<vec3<u32>>(v) & vec3<u32>(0x7f800000u);
    let flags = select(vec3<u32>(0u), vec3<u32>(1u), exponent == vec3<u32>(0x7f800000u));
    return flags.x + flags.y + flags.z;
}

fn channel_sum(v: vec3<f32>) -> f32 {
    return v.x + v.y + v.z;
}

@compute @workgroup_size(ERROR_WORKGROUP_SIZE)
fn estimate_error(@builtin(global_invocation_id) id: vec3<u32>) {
    // Lanes of a workgroup take neighbouring rows of one strip.
    let row = id.x;
    let strip = id.y;
    if row >= params.height || strip >= params.strips {
        return;
    }
    let n = f32(params.samples);
    var mean_sum = 0.0;
    var squared_error_sum = 0.0;
    var non_finite = 0u;
    let end = min((strip + 1u) * ERROR_STRIP_PIXELS, params.width);
    for (var x = strip * ERROR_STRIP_PIXELS; x < end; x++) {
        let pixel = vec2<u32>(x, row);
        let sum = compensated_sum(pixel, LAYER_SUM);
        non_finite += count_non_finite(sum);
        let mean = sum / n;
        mean_sum += channel_sum(mean);
#if REPLICATE_SUMS
        // The spread of the replicates' means; replicate 0 holds the rest of the total.
        var means: array<vec3<f32>, REPLICATES>;
        var rest = sum;
        for (var r = 1u; r < REPLICATES; r++) {
            let replicate = compensated_sum(pixel, LAYER_REPLICATES + 2u * (r - 1u));
            rest -= replicate;
            means[r] = replicate / f32(params.replicate_samples[r]);
        }
        means[0] = rest / f32(params.replicate_samples[0]);
        var average = vec3<f32>(0.0);
        for (var r = 0u; r < REPLICATES; r++) {
            average += means[r];
        }
        average /= f32(REPLICATES);
        var spread = vec3<f32>(0.0);
        for (var r = 0u; r < REPLICATES; r++) {
            let d = means[r] - average;
            spread += d * d;
        }
        squared_error_sum += channel_sum(spread) / f32(REPLICATES * (REPLICATES - 1u));
#else
        let squares = compensated_sum(pixel, LAYER_SQUARES);
        non_finite += count_non_finite(squares);
        let variance = max((squares - n * mean * mean) / (n - 1.0), vec3<f32>(0.0));
        squared_error_sum += channel_sum(variance) / n;
#endif
    }
    strips[strip * params.height + row] = ErrorStrip(mean_sum, squared_error_sum, non_finite);
}
