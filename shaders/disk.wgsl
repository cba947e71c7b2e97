// Disks: points center + a u + b v with a^2 + b^2 <= 1 (an ellipse unless u and v
// are perpendicular and as long); normal normalize(u x v).

// Mirrors `gpu::layout::Disk` (`kinds::disk`). Plane and coordinate terms are
// precomputed on the host.
struct Disk {
    center: vec3<f32>,
    material: u32,
    u: vec3<f32>,
    // dot(normal, center): the plane is dot(normal, x) = plane_d.
    plane_d: f32,
    v: vec3<f32>,
    // pi |u x v|.
    area: f32,
    normal: vec3<f32>,
    _pad0: u32,
    // (u x v) / |u x v|^2, so a = dot(w, p x v) and b = dot(w, u x p).
    w: vec3<f32>,
    _pad1: u32,
}

// Distance along the ray to the disk in (0, t_max), or -1. A ray parallel to the
// plane divides by zero; the NaN or infinity fails the range test, as it should.
fn disk_hit_t(disk: Disk, ray: Ray, t_max: f32) -> f32 {
    let t = (disk.plane_d - dot(disk.normal, ray.origin)) / dot(disk.normal, ray.dir);
    if !(t > 0.0 && t < t_max) {
        return -1.0;
    }
    let planar = ray.origin + t * ray.dir - disk.center;
    let a = dot(disk.w, cross(planar, disk.v));
    let b = dot(disk.w, cross(disk.u, planar));
    if a * a + b * b > 1.0 {
        return -1.0;
    }
    return t;
}

// The closest hit keeps the normal: the plane's, the same at every point.
fn disk_hit_keep(disk: Disk) -> vec4<f32> {
    return vec4<f32>(disk.normal, 0.0);
}

fn disk_hit_normal(keep: vec4<f32>, p: vec3<f32>) -> vec3<f32> {
    return keep.xyz;
}

#if TEXTURES
// Mitsuba's disk: polar, (r, phi / 2 pi) of the point center + a u + b v with
// (a, b) = r (cos phi, sin phi).
fn disk_hit_uv(disk: Disk, point: vec3<f32>) -> vec2<f32> {
    let planar = point - disk.center;
    let a = dot(disk.w, cross(planar, disk.v));
    let b = dot(disk.w, cross(disk.u, planar));
    var v = atan2(b, a) / (2.0 * PI);
    if v < 0.0 {
        v += 1.0;
    }
    return vec2<f32>(sqrt(a * a + b * b), v);
}
#endif

#if BUMP_MAPS
// Mitsuba's disk's derivatives along its uv (r, phi / 2 pi) at the local
// point (a, b) = r (cos phi, sin phi): dp_du = cos phi u + sin phi v and
// dp_dv = 2 pi r (-sin phi u + cos phi v); both zero at the centre, as
// Mitsuba's.
fn disk_hit_tangents(disk: Disk, point: vec3<f32>) -> Tangents {
    let planar = point - disk.center;
    let a = dot(disk.w, cross(planar, disk.v));
    let b = dot(disk.w, cross(disk.u, planar));
    let r = sqrt(a * a + b * b);
    var inv_r = 0.0;
    if r > 0.0 {
        inv_r = 1.0 / r;
    }
    let cos_phi = a * inv_r;
    let sin_phi = b * inv_r;
    return Tangents(
        cos_phi * disk.u + sin_phi * disk.v,
        (2.0 * PI * r) * (cos_phi * disk.v - sin_phi * disk.u),
    );
}
#endif

// Direction from `origin` to a uniformly chosen point on the disk (the concentric
// map keeps the unit square's stratification).
fn disk_light_sample(disk: Disk, origin: vec3<f32>, u: vec2<f32>) -> vec3<f32> {
    let p = square_to_disk_concentric(u);
    let target_point = disk.center + p.x * disk.u + p.y * disk.v;
    return normalize(target_point - origin);
}

// Solid-angle density of `disk_light_sample`: d^2 / (|cos| A) where the ray meets the disk.
fn disk_light_pdf(disk: Disk, origin: vec3<f32>, dir: vec3<f32>) -> f32 {
    let t = disk_hit_t(disk, Ray(origin, dir), F32_MAX);
    if t < 0.0 {
        return 0.0;
    }
    return (t * t) / (abs(dot(dir, disk.normal)) * disk.area);
}

#if LIGHT_SELECTION_SPATIAL
// A bound on what the disk sends toward `origin` (`PrimitiveKind::light_importance`),
// within the sphere about its centre through its rim.
fn disk_light_importance(disk: Disk, origin: vec3<f32>) -> f32 {
    let radius = max(length(disk.u), length(disk.v));
    let luminance = material_emitted_luminance(disk.material);
    return planar_light_importance(luminance * disk.area, disk.center, disk.normal, radius, origin);
}
#endif
