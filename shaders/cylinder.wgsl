// Open cylinders (no caps): the points at distance `radius` from the segment
// from p0 along dir for length; normal away from the axis, times `side`.

// Mirrors `gpu::layout::Cylinder` (`kinds::cylinder`).
struct Cylinder {
    p0: vec3<f32>,
    material: u32,
    // The axis' unit direction.
    dir: vec3<f32>,
    radius: f32,
    // Mitsuba's frame about the axis: u = 0 along s, growing toward t.
    s: vec3<f32>,
    length: f32,
    t: vec3<f32>,
    // 2 pi radius length.
    area: f32,
    // 1, or -1 where the normals point toward the axis (flip_normals).
    side: f32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

// Both distances along the (unit-direction) ray to the infinite cylinder about
// the axis, nearest first, or -1 for both where it misses (or runs along it).
// Across the axis the ray is a line of unit direction `across`, met as the
// sphere's ray meets a sphere: the discriminant r^2 - |perpendicular offset|^2,
// the roots q and c / q with q computed without cancellation; dividing by the
// ray's speed across the axis makes them distances along the ray.
fn cylinder_roots(cylinder: Cylinder, ray: Ray) -> vec2<f32> {
    let o = ray.origin - cylinder.p0;
    let o_across = o - dot(o, cylinder.dir) * cylinder.dir;
    let d_across = ray.dir - dot(ray.dir, cylinder.dir) * cylinder.dir;
    let speed2 = dot(d_across, d_across);
    let inv_speed = inverseSqrt(speed2);
    let across = d_across * inv_speed;
    let along = -dot(o_across, across);
    let perpendicular = o_across + along * across;
    let r2 = cylinder.radius * cylinder.radius;
    let disc = r2 - dot(perpendicular, perpendicular);
    let q = along + select(-1.0, 1.0, along >= 0.0) * sqrt(max(disc, 0.0));
    let other = (dot(o_across, o_across) - r2) / q;
    let misses = !(speed2 > 0.0 && disc >= 0.0 && q != 0.0);
    return select(vec2<f32>(min(q, other), max(q, other)) * inv_speed, vec2<f32>(-1.0), misses);
}

// Whether the points at distances `roots` along the ray lie between the ends.
fn cylinder_within(cylinder: Cylinder, ray: Ray, roots: vec2<f32>) -> vec2<bool> {
    let h = dot(ray.origin - cylinder.p0, cylinder.dir) + roots * dot(ray.dir, cylinder.dir);
    return (h >= vec2<f32>(0.0)) & (h <= vec2<f32>(cylinder.length));
}

// Distance along the ray to the cylinder in (0, t_max): the nearer root between
// the ends, else the farther (a ray through an open end meets the inside), or -1.
fn cylinder_hit_t(cylinder: Cylinder, ray: Ray, t_max: f32) -> f32 {
    let roots = cylinder_roots(cylinder, ray);
    let within = cylinder_within(cylinder, ray, roots);
    let counts = within & (roots > vec2<f32>(0.0)) & (roots < vec2<f32>(t_max));
    return select(select(-1.0, roots.y, counts.y), roots.x, counts.x);
}

// The hit point moved onto the cylinder across its axis (`o + t d` errs by ulps
// of the ray's origin and length, more than a ray offset), as Mitsuba's is.
fn cylinder_hit_point(cylinder: Cylinder, p: vec3<f32>) -> vec3<f32> {
    let o = p - cylinder.p0;
    let along = dot(o, cylinder.dir) * cylinder.dir;
    return cylinder.p0 + along + normalize(o - along) * cylinder.radius;
}

fn cylinder_hit_normal(cylinder: Cylinder, p: vec3<f32>) -> vec3<f32> {
    let o = p - cylinder.p0;
    return cylinder.side * normalize(o - dot(o, cylinder.dir) * cylinder.dir);
}

#if TEXTURES
// Mitsuba's cylinder: (phi / 2 pi, the height's fraction of the length), phi
// from s toward t.
fn cylinder_hit_uv(cylinder: Cylinder, point: vec3<f32>) -> vec2<f32> {
    let o = point - cylinder.p0;
    var phi = atan2(dot(o, cylinder.t), dot(o, cylinder.s));
    if phi < 0.0 {
        phi += 2.0 * PI;
    }
    return vec2<f32>(phi / (2.0 * PI), dot(o, cylinder.dir) / cylinder.length);
}
#endif

#if BUMP_MAPS
// Mitsuba's `dp_du` (2 pi times the offset from the axis turned a quarter turn
// from s toward t) and `dp_dv` (the axis, p1 - p0).
fn cylinder_hit_tangents(cylinder: Cylinder, point: vec3<f32>) -> Tangents {
    let o = point - cylinder.p0;
    let across = o - dot(o, cylinder.dir) * cylinder.dir;
    return Tangents(
        (2.0 * PI) * (dot(across, cylinder.s) * cylinder.t - dot(across, cylinder.t) * cylinder.s),
        cylinder.length * cylinder.dir,
    );
}
#endif

// Direction from `origin` to a uniformly chosen point of the cylinder's area
// (as Mitsuba's `sample_position`: u.x along the axis, u.y around it).
fn cylinder_light_sample(cylinder: Cylinder, origin: vec3<f32>, u: vec2<f32>) -> vec3<f32> {
    let phi = 2.0 * PI * u.y;
    let across = cos(phi) * cylinder.s + sin(phi) * cylinder.t;
    let target_point = cylinder.p0 + (u.x * cylinder.length) * cylinder.dir + cylinder.radius * across;
    return normalize(target_point - origin);
}

// Solid-angle density of `cylinder_light_sample`: a line meets the cylinder up to
// twice, and either point gives the direction, so the density sums
// d^2 / (|cos| A) over the points ahead of `origin` between the ends.
fn cylinder_light_pdf(cylinder: Cylinder, origin: vec3<f32>, dir: vec3<f32>) -> f32 {
    let ray = Ray(origin, dir);
    let roots = cylinder_roots(cylinder, ray);
    let counts = cylinder_within(cylinder, ray, roots) & (roots > vec2<f32>(0.0));
    let o = origin - cylinder.p0;
    let o_across = o - dot(o, cylinder.dir) * cylinder.dir;
    let d_across = dir - dot(dir, cylinder.dir) * cylinder.dir;
    // |cos| at each point: the direction against the unit normal there.
    let cosines = abs(vec2<f32>(
        dot(dir, o_across + roots.x * d_across),
        dot(dir, o_across + roots.y * d_across),
    )) / cylinder.radius;
    let densities = roots * roots / (cosines * cylinder.area);
    return select(0.0, densities.x, counts.x) + select(0.0, densities.y, counts.y);
}
