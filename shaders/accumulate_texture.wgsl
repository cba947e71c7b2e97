// Accumulator in a read-write rgba32float storage texture array, one layer per
// running sum (needs the adapter's TEXTURE_ADAPTER_SPECIFIC_FORMAT_FEATURES).

@group(0) @binding(BINDING_ACCUMULATOR) var accumulator: texture_storage_2d_array<rgba32float, read_write>;

fn accumulator_load(pixel: vec2<u32>, layer: u32) -> vec4<f32> {
    return textureLoad(accumulator, pixel, layer);
}

fn accumulator_store(pixel: vec2<u32>, layer: u32, value: vec4<f32>) {
    textureStore(accumulator, pixel, layer, value);
}
