// Runs the environment map's sampling alone, for the test of its sampler
// against its density (tests/environment.rs). `probe_sample` draws one
// direction per invocation (independent random numbers: the invocation is the
// "pixel"); `probe_pdf` evaluates the radiance and density at given directions.

@group(0) @binding(10) var<storage, read> probe_seed: u32;
// probe_pdf: the directions (xyz); probe_sample: unused.
@group(0) @binding(11) var<storage, read> probe_directions: array<vec4<f32>>;
// probe_sample: per sample (direction, density there).
// probe_pdf: per direction (radiance, density).
@group(0) @binding(12) var<storage, read_write> probe_out: array<vec4<f32>>;

const PROBE_WORKGROUP: u32 = 64u;

@compute @workgroup_size(PROBE_WORKGROUP, 1, 1)
fn probe_sample(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let index = id.x + id.y * groups.x * PROBE_WORKGROUP;
    if index >= arrayLength(&probe_out) {
        return;
    }
    params.seed = probe_seed;
    sampler_begin(index, 0u);
    let dir = environment_sample(sample_2d());
    probe_out[index] = vec4<f32>(dir, environment_pdf(dir));
}

@compute @workgroup_size(PROBE_WORKGROUP, 1, 1)
fn probe_pdf(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let index = id.x + id.y * groups.x * PROBE_WORKGROUP;
    if index >= arrayLength(&probe_directions) {
        return;
    }
    let dir = probe_directions[index].xyz;
    probe_out[index] = vec4<f32>(environment_radiance(dir), environment_pdf(dir));
}
