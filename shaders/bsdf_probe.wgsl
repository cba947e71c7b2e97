// Runs the BSDF interface alone, for the tests of each material's sampling
// against its density (tests/bsdf.rs): one material, one outgoing direction.
// `probe_sample` draws one BSDF sample per invocation (independent random
// numbers: the invocation is the "pixel"); `probe_eval` evaluates eval and pdf
// at given directions.

struct ProbeInput {
    material: Material,
    wo: vec3<f32>,
    front_face: u32,
    n: vec3<f32>,
    seed: u32,
}

@group(0) @binding(10) var<storage, read> probe: ProbeInput;
// probe_eval: the directions (xyz); probe_sample: unused.
@group(0) @binding(11) var<storage, read> probe_directions: array<vec4<f32>>;
// probe_sample: per sample (wi, pdf), (weight, delta), (eval at wi, pdf at wi).
// probe_eval: per direction (eval, pdf).
@group(0) @binding(12) var<storage, read_write> probe_out: array<vec4<f32>>;

const PROBE_WORKGROUP: u32 = 64u;

fn probe_frame() -> Frame {
    // A flat surface: the shading normal is the geometric one.
    return Frame(probe.n, probe.front_face != 0u, probe.n);
}

@compute @workgroup_size(PROBE_WORKGROUP, 1, 1)
fn probe_sample(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let index = id.x + id.y * groups.x * PROBE_WORKGROUP;
    if 3u * index >= arrayLength(&probe_out) {
        return;
    }
    params.seed = probe.seed;
    sampler_begin(index, 0u);
    let frame = probe_frame();
    let s = bsdf_sample(probe.material, frame, probe.wo);
    var at_wi = vec4<f32>(0.0);
    if s.pdf > 0.0 && !s.delta && bsdf_is_smooth(probe.material) {
        at_wi = vec4<f32>(bsdf_eval(probe.material, frame, probe.wo, s.wi), bsdf_pdf(probe.material, frame, probe.wo, s.wi));
    }
    probe_out[3u * index] = vec4<f32>(s.wi, s.pdf);
    probe_out[3u * index + 1u] = vec4<f32>(s.weight, select(0.0, 1.0, s.delta));
    probe_out[3u * index + 2u] = at_wi;
}

@compute @workgroup_size(PROBE_WORKGROUP, 1, 1)
fn probe_eval(@builtin(global_invocation_id) id: vec3<u32>, @builtin(num_workgroups) groups: vec3<u32>) {
    let index = id.x + id.y * groups.x * PROBE_WORKGROUP;
    if index >= arrayLength(&probe_directions) {
        return;
    }
    let frame = probe_frame();
    let wi = probe_directions[index].xyz;
    var out = vec4<f32>(0.0);
    if bsdf_is_smooth(probe.material) {
        out = vec4<f32>(bsdf_eval(probe.material, frame, probe.wo, wi), bsdf_pdf(probe.material, frame, probe.wo, wi));
    }
    probe_out[index] = out;
}

// The materials' tables (`kinds::MaterialTables`), which the kernel's scene
// arrays provide as `material_tables`.
@group(0) @binding(13) var<storage, read> probe_tables: array<f32>;

fn material_tables_at(i: u32) -> f32 {
    return probe_tables[i];
}
