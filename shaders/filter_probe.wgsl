// Runs the pixel filter's offset sampler alone, for the tests of each filter's
// sampling against its function (tests/filters.rs): one offset per invocation,
// from independent random numbers, written as (x, y, weight, 0).

@group(0) @binding(0) var<storage, read_write> probe_out: array<vec4<f32>>;

const PROBE_WORKGROUP: u32 = 64u;

@compute @workgroup_size(PROBE_WORKGROUP, 1, 1)
fn probe_filter(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let index = id.x + id.y * groups.x * PROBE_WORKGROUP;
    if index >= arrayLength(&probe_out) {
        return;
    }
    params.seed = 7u;
    sampler_begin(index, 0u);
    probe_out[index] = vec4<f32>(filter_offset(sample_2d()), 0.0);
}
