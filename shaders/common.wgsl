// Types, constants and the per-dispatch parameters shared by every module.

const PI: f32 = 3.14159265358979;
const INV_PI: f32 = 0.318309886183791;
const F32_MAX: f32 = 3.40282347e38;

// Pipeline-overridable: a change rebuilds the pipeline, and the compiler folds
// them into the code, so loops and branches on them cost nothing at run time.
override MAX_DEPTH: u32 = 50u;
override LIGHT_WEIGHT: f32 = 0.5;
// Russian roulette from this depth on; the maximum value turns it off.
override RR_DEPTH: u32 = 0xffffffffu;

// Mirrors `gpu::layout::Params`.
struct Params {
    origin: vec3<f32>,
    width: u32,
    // From `origin` to the centre of pixel (0, 0): relative, so the pixel grid
    // keeps its precision however far the camera is from the world's origin.
    to_pixel00: vec3<f32>,
    height: u32,
    delta_u: vec3<f32>,
    sample_start: u32,
    delta_v: vec3<f32>,
    sample_count: u32,
    background: vec3<f32>,
    seed: u32,
    tile_origin: vec2<u32>,
    tile_size: vec2<u32>,
    // Ray origins move this far off a surface, times its kind's factor
    // (`Hit.offset`): a fixed fraction of the scene's size, so the same scene
    // renders the same at any scale.
    ray_offset: f32,
    // 1: this dispatch starts the accumulation (ignore what the accumulator holds).
    reset: u32,
    // Always 0; see `compensated_add`.
    zero_bits: u32,
    // Adaptive sampling: entries of `active_pixels` (kernel.wgsl).
    active_count: u32,
    // The dispatch's workgroup row r covers the tile's row of workgroups
    // r * step mod rows (kernel.wgsl).
    workgroup_row_step: u32,
    // The thin lens's radius and distance to the plane in focus (read only
    // under THIN_LENS: `camera_ray`).
    lens_radius: f32,
    focus_distance: f32,
    // An adaptive kernel that splats: 1 where this dispatch's samples go to the
    // splatting pass (a uniform round), 0 where they are summed in their pixel.
    splatting: u32,
}

// Mirrors `gpu::layout::Counters`.
struct Counters {
    // Samples whose radiance was NaN or infinite, replaced by zero.
    discarded: atomic<u32>,
    // Invocations that ended before their last sample: the driver cut a loop
    // short (lavapipe stops all loops of an invocation after 65535 iterations).
    truncated: atomic<u32>,
    // Ray segments traced (closest-hit queries), as a 64-bit count in two words.
    segments_low: atomic<u32>,
    segments_high: atomic<u32>,
}

struct Ray {
    origin: vec3<f32>,
    dir: vec3<f32>,
}

#if BUMP_MAPS
// Mitsuba's `dp_du` and `dp_dv`: how a surface point moves with its texture
// coordinates, what bump and normal maps are oriented and scaled by.
struct Tangents {
    dp_du: vec3<f32>,
    dp_dv: vec3<f32>,
}

// Two unit tangents perpendicular to the unit `n` and to each other, for
// surfaces whose uvs give none (Duff et al. 2017, Mitsuba's
// `coordinate_system`).
fn tangents_about(n: vec3<f32>) -> Tangents {
    let sign = select(-1.0, 1.0, n.z >= 0.0);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    return Tangents(
        vec3<f32>(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        vec3<f32>(b, sign + n.y * n.y * a, -n.y),
    );
}
#endif

struct Hit {
    t: f32,
    p: vec3<f32>,
    // Geometric normal on the object's outward side (not flipped toward the ray).
    normal: vec3<f32>,
    // The normal shading uses, on the same side: interpolated on a smooth mesh,
    // else `normal`.
    shading_normal: vec3<f32>,
    material: u32,
    // How far rays leave the surface (its kind's `ray_offset_factor` times
    // `params.ray_offset`).
    offset: f32,
#if TEXTURES
    // Texture coordinates (`NAME_hit_uv` of the primitive's kind).
    uv: vec2<f32>,
#endif
#if BUMP_MAPS
    // The surface's derivatives along u and v (`NAME_hit_tangents`).
    tangents: Tangents,
#endif
#if LIGHT_POINTS
    // The grouped light hit (its index in the kind's light array), or NO_LIGHT.
    light: u32,
#endif
}

#if LIGHT_DENSITY
// A direction toward an object of the light density (`light_sample`), and the
// grouped light it aimed at (its index in the kind's light array), or NO_LIGHT.
struct LightSample {
    dir: vec3<f32>,
    light: u32,
}
#endif

// The dispatch's parameters come from a storage buffer, not a uniform buffer:
// lavapipe specialises a kernel on the uniform values that steer loops and
// branches, so every new sample count or tile size recompiled it (measured: 3.5x
// the render time of a 512-spp run without the shader cache). `load_params`
// copies them into private memory once per invocation.
@group(0) @binding(BINDING_PARAMS) var<storage, read> dispatch_params: Params;
var<private> params: Params;

fn load_params() {
    params = dispatch_params;
}
@group(0) @binding(BINDING_COUNTERS) var<storage, read_write> counters: Counters;

fn no_hit() -> Hit {
    // The fields not set here (the point, material, offset, texture coordinates) are zero.
    var hit: Hit;
    hit.t = F32_MAX;
    hit.normal = vec3<f32>(0.0, 1.0, 0.0);
    hit.shading_normal = hit.normal;
#if LIGHT_POINTS
    hit.light = NO_LIGHT;
#endif
    return hit;
}

// Moves a point off a surface by `offset` on the side `dir` leaves toward.
fn offset_origin(p: vec3<f32>, normal: vec3<f32>, dir: vec3<f32>, offset: f32) -> vec3<f32> {
    let side = select(-1.0, 1.0, dot(dir, normal) >= 0.0);
    return p + normal * (side * offset);
}
