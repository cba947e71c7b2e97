// Random numbers. A sample's stream depends only on (seed, pixel, sample index),
// so images do not depend on how samples are split across dispatches or runs.

var<private> rng_state: u32;

// PCG-RXS-M-XS hash (Jarzynski & Olano, "Hash Functions for GPU Rendering", 2020).
fn pcg_hash(v: u32) -> u32 {
    let state = v * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

fn rng_begin_sample(pixel: u32, sample_index: u32) {
    rng_state = pcg_hash(pcg_hash(pcg_hash(params.seed) ^ pixel) ^ sample_index);
}

// Uniform in [0, 1): 24 random mantissa bits.
fn rand() -> f32 {
    rng_state = rng_state * 747796405u + 2891336453u;
    let word = ((rng_state >> ((rng_state >> 28u) + 4u)) ^ rng_state) * 277803737u;
    return f32(((word >> 22u) ^ word) >> 8u) * (1.0 / 16777216.0);
}
