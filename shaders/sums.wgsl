// Running sums, compensated (Kahan): the accumulator holds each sum and its
// compensation, so the mean stays exact to f32 rounding after any number of
// samples, and the arithmetic per pixel does not depend on how samples are split
// across dispatches. Shared by the kernel and the splatting pass (splat.wgsl).

struct CompensatedSum {
    sum: vec3<f32>,
    compensation: vec3<f32>,
}

// Driver compilers simplify `((s + y) - s) - y` to zero, which silently turns
// this into a plain sum; `params.zero_bits` (always 0, unknown at compile
// time) hides that `t` is `s + y`, so the rounding error is really computed.
fn compensated_add(acc: ptr<function, CompensatedSum>, value: vec3<f32>) {
    let y = value - (*acc).compensation;
    let t = bitcast<vec3<f32>>(bitcast<vec3<u32>>((*acc).sum + y) ^ vec3<u32>(params.zero_bits));
    (*acc).compensation = (t - (*acc).sum) - y;
    (*acc).sum = t;
}

fn load_sum(pixel: vec2<u32>, layer: u32, compensation_layer: u32, reset: bool) -> CompensatedSum {
    if reset {
        return CompensatedSum(vec3<f32>(0.0), vec3<f32>(0.0));
    }
    return CompensatedSum(
        accumulator_load(pixel, layer).xyz,
        accumulator_load(pixel, compensation_layer).xyz,
    );
}

fn store_sum(pixel: vec2<u32>, layer: u32, compensation_layer: u32, acc: CompensatedSum) {
    accumulator_store(pixel, layer, vec4<f32>(acc.sum, 0.0));
    accumulator_store(pixel, compensation_layer, vec4<f32>(acc.compensation, 0.0));
}

// Tested on the bits (all-ones exponent: NaN or infinity), which no
// floating-point optimisation of the driver's compiler can assume away.
fn all_finite(v: vec3<f32>) -> bool {
    let exponent = bitcast<vec3<u32>>(v) & vec3<u32>(0x7f800000u);
    return all(exponent != vec3<u32>(0x7f800000u));
}


#if SPLAT
// A sample on its way to the splatting pass (splat.wgsl): its radiance and
// where in its pixel it was taken ([0, 1)^2). Sample k of pixel i is element
// k * width * height + i of a submission's samples.
struct SplatSample {
    r: f32,
    g: f32,
    b: f32,
    x: f32,
    y: f32,
}

@group(0) @binding(BINDING_SPLAT_SAMPLES) var<storage, read_write> splat_samples: array<SplatSample>;
#endif
