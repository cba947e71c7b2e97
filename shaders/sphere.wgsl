// Spheres, with outward normals.

// Mirrors `gpu::layout::Sphere`.
struct Sphere {
    center: vec3<f32>,
    radius: f32,
    material: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

// Distance along the (unit-direction) ray to the sphere in (0, t_max), or -1.
// The discriminant is r^2 - |perpendicular offset|^2, and the roots are q and
// c / q with q the one computed without cancellation (Haines et al., Ray Tracing
// Gems, ch. 7): small and distant spheres keep their size, and a ray leaving
// the surface (its origin a ray offset off it) does not find it again.
fn sphere_hit_t(sphere: Sphere, ray: Ray, t_max: f32) -> f32 {
    let to_center = sphere.center - ray.origin;
    let along = dot(ray.dir, to_center);
    let perpendicular = to_center - along * ray.dir;
    let r2 = sphere.radius * sphere.radius;
    let disc = r2 - dot(perpendicular, perpendicular);
    if disc < 0.0 {
        return -1.0;
    }
    let q = along + select(-1.0, 1.0, along >= 0.0) * sqrt(disc);
    if q == 0.0 {
        return -1.0;
    }
    let other = (dot(to_center, to_center) - r2) / q;
    let near = min(q, other);
    if near > 0.0 && near < t_max {
        return near;
    }
    let far = max(q, other);
    if far > 0.0 && far < t_max {
        return far;
    }
    return -1.0;
}

// The closest hit keeps the centre and radius, from which the normal follows.
fn sphere_hit_keep(sphere: Sphere) -> vec4<f32> {
    return vec4<f32>(sphere.center, sphere.radius);
}

// The hit point moved onto the sphere along its normal (`o + t d` errs by ulps of
// the ray's origin and length, more than a ray offset).
fn sphere_hit_point(keep: vec4<f32>, p: vec3<f32>) -> vec3<f32> {
    return keep.xyz + normalize(p - keep.xyz) * keep.w;
}

fn sphere_hit_normal(keep: vec4<f32>, p: vec3<f32>) -> vec3<f32> {
    return (p - keep.xyz) / keep.w;
}

#if TEXTURES
// Mitsuba's sphere: (phi / 2 pi, theta / pi), theta from +z and phi from +x
// toward +y, about the centre.
fn sphere_hit_uv(sphere: Sphere, point: vec3<f32>) -> vec2<f32> {
    let local = (point - sphere.center) / sphere.radius;
    var phi = atan2(local.y, local.x);
    if phi < 0.0 {
        phi += 2.0 * PI;
    }
    let theta = acos(clamp(local.z, -1.0, 1.0));
    return vec2<f32>(phi / (2.0 * PI), theta / PI);
}
#endif

#if BUMP_MAPS
// Mitsuba's sphere's derivatives along its uv: dp_du = 2 pi r (-y, x, 0) and
// dp_dv = pi r (z cos phi, z sin phi, -rd) of the local point (x, y, z), rd =
// sqrt(x^2 + y^2); at the poles (rd = 0) dp_du is zero and dp_dv pi r (1, 0, 0),
// as Mitsuba's.
fn sphere_hit_tangents(sphere: Sphere, point: vec3<f32>) -> Tangents {
    let local = (point - sphere.center) / sphere.radius;
    let rd = sqrt(local.x * local.x + local.y * local.y);
    var dp_dv = vec3<f32>(1.0, 0.0, 0.0);
    if rd > 0.0 {
        dp_dv = vec3<f32>(local.z * local.x / rd, local.z * local.y / rd, -rd);
    }
    return Tangents(
        (2.0 * PI * sphere.radius) * vec3<f32>(-local.y, local.x, 0.0),
        (PI * sphere.radius) * dp_dv,
    );
}
#endif

// 1 - cos(theta_max) of the cone the sphere subtends, computed without cancellation
// so a pin-point sphere still gets a finite density.
fn sphere_cone_one_minus_cos(radius: f32, dist2: f32) -> f32 {
    let sin2 = radius * radius / dist2;
    return sin2 / (1.0 + sqrt(max(0.0, 1.0 - sin2)));
}

// Uniform direction within the cone the sphere subtends from `origin`
// (uniform over all directions when `origin` is inside the sphere).
fn sphere_light_sample(sphere: Sphere, origin: vec3<f32>, u: vec2<f32>) -> vec3<f32> {
    let to_center = sphere.center - origin;
    let dist2 = dot(to_center, to_center);
    if dist2 <= sphere.radius * sphere.radius {
        return sample_sphere(u);
    }
    let one_minus_cos_max = sphere_cone_one_minus_cos(sphere.radius, dist2);
    let phi = 2.0 * PI * u.x;
    let one_minus_z = u.y * one_minus_cos_max;
    let sin_theta = sqrt(one_minus_z * (2.0 - one_minus_z));
    let local = vec3<f32>(cos(phi) * sin_theta, sin(phi) * sin_theta, 1.0 - one_minus_z);
    return normalize(onb_to_world(to_center * inverseSqrt(dist2), local));
}

// Solid-angle density of `sphere_light_sample`.
fn sphere_light_pdf(sphere: Sphere, origin: vec3<f32>, dir: vec3<f32>) -> f32 {
    let to_center = sphere.center - origin;
    let dist2 = dot(to_center, to_center);
    let r2 = sphere.radius * sphere.radius;
    if dist2 <= r2 {
        return 1.0 / (4.0 * PI);
    }
    let along = dot(dir, to_center);
    let perpendicular = to_center - along * dir;
    if along <= 0.0 || dot(perpendicular, perpendicular) > r2 {
        return 0.0;
    }
    return 1.0 / (2.0 * PI * sphere_cone_one_minus_cos(sphere.radius, dist2));
}

#if LIGHT_SELECTION_SPATIAL
// A bound on what the sphere sends toward `origin` (`PrimitiveKind::light_importance`):
// its radiance times r^2 / d^2, the solid angle it subtends over pi (1 within it).
fn sphere_light_importance(sphere: Sphere, origin: vec3<f32>) -> f32 {
    let to_center = sphere.center - origin;
    let r2 = sphere.radius * sphere.radius;
    return material_emitted_luminance(sphere.material) * r2 / max(dot(to_center, to_center), r2);
}
#endif
