// Accumulator in a storage buffer, layer-major: the portable fallback for
// adapters without read-write rgba32float storage textures.

@group(0) @binding(BINDING_ACCUMULATOR) var<storage, read_write> accumulator: array<vec4<f32>>;

fn accumulator_load(pixel: vec2<u32>, layer: u32) -> vec4<f32> {
    return accumulator[(layer * params.height + pixel.y) * params.width + pixel.x];
}

fn accumulator_store(pixel: vec2<u32>, layer: u32, value: vec4<f32>) {
    accumulator[(layer * params.height + pixel.y) * params.width + pixel.x] = value;
}
