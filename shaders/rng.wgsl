// Random numbers. A sample's numbers depend only on (seed, pixel, sample index),
// so images do not depend on how samples are split across dispatches or runs.
//
// Consumers ask for `sample_1d()` and `sample_2d()` in a fixed order per path
// vertex; each call is the next dimension of the sample. SAMPLER_SOBOL draws
// them from a per-pixel Owen-scrambled Sobol sequence (Burley, "Practical
// Hash-based Owen Scrambling", JCGT 2020): every 2D pair is stratified over a
// pixel's samples, which removes most of the noise of pixel edges and direct
// light. Each scrambled point is uniform, so the estimator stays unbiased.
// Otherwise the numbers are independent (PCG).

// PCG-RXS-M-XS hash (Jarzynski & Olano, "Hash Functions for GPU Rendering", 2020).
fn pcg_hash(v: u32) -> u32 {
    let state = v * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// The top 24 bits as a float in [0, 1).
fn unit_float(bits: u32) -> f32 {
    return f32(bits >> 8u) * (1.0 / 16777216.0);
}

#if SAMPLER_SOBOL
var<private> sampler_pixel_seed: u32;
var<private> sampler_index: u32;
var<private> sampler_dimension: u32;

// SAMPLER_REPLICATES: randomised QMC with independent replicates: sample i
// belongs to replicate i mod REPLICATES and is point i div REPLICATES of that
// replicate's own scramble. Interleaving keeps every replicate a stratified net
// at any sample count, and independent scrambles make the replicates' means
// independent, so their spread estimates the error of the pixel's mean
// (`stats::Accumulation`). Otherwise, where no estimate is asked for, sample i
// is point i of one scramble (replicate 0's): one net of all the pixel's
// samples, finer than REPLICATES nets of a quarter of them each.
fn sampler_begin(pixel: u32, sample_index: u32) {
#if SAMPLER_REPLICATES
    let replicate = sample_index % REPLICATES;
    sampler_index = sample_index / REPLICATES;
#else
    let replicate = 0u;
    sampler_index = sample_index;
#endif
    sampler_pixel_seed = pcg_hash(pcg_hash(pcg_hash(params.seed) ^ pixel) ^ replicate);
    sampler_dimension = 0u;
}

// Flips each bit of `x` depending only on the bits below it: with bits
// reversed, an Owen scramble (Vegdahl's constants, 2021).
fn laine_karras(x: u32, seed: u32) -> u32 {
    var v = x ^ (x * 0x3d20adeau);
    v += seed;
    v *= (seed >> 16u) | 1u;
    v ^= v * 0x05526c56u;
    v ^= v * 0x53a22864u;
    return v;
}

// Owen-scrambles the binary digits of `x` read as a fraction (most significant first).
fn owen_scramble(x: u32, seed: u32) -> u32 {
    return reverseBits(laine_karras(reverseBits(x), seed));
}

// Sobol's second dimension before bit reversal: its generator matrix is Pascal's
// triangle mod 2, so digit r takes index bit c exactly when r's bits are a subset
// of c's (Lucas); a superset-sum over the 5-bit positions computes all 32 digits.
fn sobol_pascal_reversed(index: u32) -> u32 {
    var w = index;
    w ^= (w >> 1u) & 0x55555555u;
    w ^= (w >> 2u) & 0x33333333u;
    w ^= (w >> 4u) & 0x0f0f0f0fu;
    w ^= (w >> 8u) & 0x00ff00ffu;
    w ^= (w >> 16u) & 0x0000ffffu;
    return w;
}

// The dimension's own seed, and this sample's index in its own shuffled order:
// an Owen scramble of the index keeps each aligned block of 2^k indices a block,
// so every prefix of 2^k samples stays a (0, k, 2)-net.
fn next_dimension() -> vec2<u32> {
    let seed = pcg_hash(sampler_pixel_seed ^ (sampler_dimension * 0x9e3779b9u));
    sampler_dimension += 1u;
    return vec2<u32>(seed, owen_scramble(sampler_index, seed));
}

fn sample_1d() -> f32 {
    let dimension = next_dimension();
    // Van der Corput (Sobol's first dimension) is the reversed index, so its Owen
    // scramble is reverseBits(laine_karras(index)).
    return unit_float(reverseBits(laine_karras(dimension.y, pcg_hash(dimension.x))));
}

fn sample_2d() -> vec2<f32> {
    let dimension = next_dimension();
    let seed_x = pcg_hash(dimension.x);
    let seed_y = pcg_hash(seed_x);
    let x = reverseBits(laine_karras(dimension.y, seed_x));
    let y = reverseBits(laine_karras(sobol_pascal_reversed(dimension.y), seed_y));
    return vec2<f32>(unit_float(x), unit_float(y));
}
#else
var<private> rng_state: u32;

fn sampler_begin(pixel: u32, sample_index: u32) {
    rng_state = pcg_hash(pcg_hash(pcg_hash(params.seed) ^ pixel) ^ sample_index);
}

fn sample_1d() -> f32 {
    rng_state = rng_state * 747796405u + 2891336453u;
    let word = ((rng_state >> ((rng_state >> 28u) + 4u)) ^ rng_state) * 277803737u;
    return unit_float((word >> 22u) ^ word);
}

fn sample_2d() -> vec2<f32> {
    let x = sample_1d();
    return vec2<f32>(x, sample_1d());
}
#endif
