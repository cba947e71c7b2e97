// Quads: points q + a u + b v for a, b in [0, 1]; normal normalize(u x v).

// Mirrors `gpu::layout::Quad`. Plane and barycentric terms are precomputed on the host.
struct Quad {
    q: vec3<f32>,
    material: u32,
    u: vec3<f32>,
    // dot(normal, q): the plane is dot(normal, x) = plane_d.
    plane_d: f32,
    v: vec3<f32>,
    area: f32,
    normal: vec3<f32>,
    _pad0: u32,
    // (u x v) / |u x v|^2, so a = dot(w, p x v) and b = dot(w, u x p).
    w: vec3<f32>,
    _pad1: u32,
}

// Distance along the ray to the quad in (0, t_max), or -1. A ray parallel to the
// plane divides by zero; the NaN or infinity fails the range test, as it should.
fn quad_hit_t(quad: Quad, ray: Ray, t_max: f32) -> f32 {
    let t = (quad.plane_d - dot(quad.normal, ray.origin)) / dot(quad.normal, ray.dir);
    let planar = ray.origin + t * ray.dir - quad.q;
    let a = dot(quad.w, cross(planar, quad.v));
    let b = dot(quad.w, cross(quad.u, planar));
    // One select, not early returns (lavapipe runs the code after them anyway):
    // 0.91-0.97x the CPU time on the Cornell boxes, images identical.
    let inside = (t > 0.0) & (t < t_max) & !((a < 0.0) | (a > 1.0) | (b < 0.0) | (b > 1.0));
    return select(-1.0, t, inside);
}

// The closest hit keeps the normal: the plane's, the same at every point.
fn quad_hit_keep(quad: Quad) -> vec4<f32> {
    return vec4<f32>(quad.normal, 0.0);
}

fn quad_hit_normal(keep: vec4<f32>, p: vec3<f32>) -> vec3<f32> {
    return keep.xyz;
}

#if TEXTURES
// Mitsuba's rectangle: (a, b) of the point q + a u + b v.
fn quad_hit_uv(quad: Quad, point: vec3<f32>) -> vec2<f32> {
    let planar = point - quad.q;
    return vec2<f32>(dot(quad.w, cross(planar, quad.v)), dot(quad.w, cross(quad.u, planar)));
}
#endif

#if BUMP_MAPS
// The point is q + u a + v b at uv (a, b): its edges.
fn quad_hit_tangents(quad: Quad, point: vec3<f32>) -> Tangents {
    return Tangents(quad.u, quad.v);
}
#endif

// Direction from `origin` to a uniformly chosen point on the quad.
fn quad_light_sample(quad: Quad, origin: vec3<f32>, u: vec2<f32>) -> vec3<f32> {
    let target_point = quad.q + u.x * quad.u + u.y * quad.v;
    return normalize(target_point - origin);
}

// Solid-angle density of `quad_light_sample`: d^2 / (|cos| A) where the ray meets the quad.
fn quad_light_pdf(quad: Quad, origin: vec3<f32>, dir: vec3<f32>) -> f32 {
    let t = quad_hit_t(quad, Ray(origin, dir), F32_MAX);
    if t < 0.0 {
        return 0.0;
    }
    return (t * t) / (abs(dot(dir, quad.normal)) * quad.area);
}

#if LIGHT_SELECTION_SPATIAL
// A bound on what the quad sends toward `origin` (`PrimitiveKind::light_importance`),
// within the sphere about its centre through its corners.
fn quad_light_importance(quad: Quad, origin: vec3<f32>) -> f32 {
    let half_diagonal = 0.5 * max(length(quad.u + quad.v), length(quad.u - quad.v));
    let center = quad.q + 0.5 * (quad.u + quad.v);
    let luminance = material_emitted_luminance(quad.material);
    return planar_light_importance(luminance * quad.area, center, quad.normal, half_diagonal, origin);
}
#endif
