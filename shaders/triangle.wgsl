// Triangles (mesh faces): vertices p0, p1, p2, counter-clockwise seen from the
// side the normal normalize((p1 - p0) x (p2 - p0)) faces.

// Mirrors `kinds::Triangle`: a vertex per 16 bytes; the face normal and area are
// computed where needed.
struct Triangle {
    p0: vec3<f32>,
    material: u32,
    p1: vec3<f32>,
    // Its index in the light array, or NO_LIGHT.
    light: u32,
    p2: vec3<f32>,
    _pad2: u32,
}

// (p1 - p0) x (p2 - p0): the face normal times twice the area.
fn triangle_cross(tri: Triangle) -> vec3<f32> {
    let p0 = tri.p0;
    return cross(tri.p1 - p0, tri.p2 - p0);
}

// a b - c d with one rounding (Kahan's algorithm with fma).
fn difference_of_products(a: f32, b: f32, c: f32, d: f32) -> f32 {
    let cd = c * d;
    return fma(a, b, -cd) + fma(-c, d, cd);
}

// Distance along the ray to the triangle in (0, t_max), or -1. Watertight (Woop,
// Benthin and Wald 2013, as pbrt-v4): the vertices are moved into a frame where
// the ray is the +z axis, so the edge tests of two triangles sharing an edge are
// the same numbers with opposite signs and no ray passes between them.
fn triangle_hit_t(tri: Triangle, ray: Ray, t_max: f32) -> f32 {
    let d_abs = abs(ray.dir);
    var kz = 0u;
    if d_abs.y > d_abs.x {
        kz = 1u;
    }
    if d_abs.z > max(d_abs.x, d_abs.y) {
        kz = 2u;
    }
    let kx = (kz + 1u) % 3u;
    let ky = (kx + 1u) % 3u;
    let d = vec3<f32>(ray.dir[kx], ray.dir[ky], ray.dir[kz]);
    let a = tri.p0 - ray.origin;
    let b = tri.p1 - ray.origin;
    let c = tri.p2 - ray.origin;
    var p0 = vec3<f32>(a[kx], a[ky], a[kz]);
    var p1 = vec3<f32>(b[kx], b[ky], b[kz]);
    var p2 = vec3<f32>(c[kx], c[ky], c[kz]);
    let shear = vec3<f32>(-d.x / d.z, -d.y / d.z, 1.0 / d.z);
    p0 = vec3<f32>(p0.x + shear.x * p0.z, p0.y + shear.y * p0.z, p0.z);
    p1 = vec3<f32>(p1.x + shear.x * p1.z, p1.y + shear.y * p1.z, p1.z);
    p2 = vec3<f32>(p2.x + shear.x * p2.z, p2.y + shear.y * p2.z, p2.z);
    let e0 = difference_of_products(p1.x, p2.y, p1.y, p2.x);
    let e1 = difference_of_products(p2.x, p0.y, p2.y, p0.x);
    let e2 = difference_of_products(p0.x, p1.y, p0.y, p1.x);
    // The tests end in one select, not in early returns: lavapipe runs every
    // branch anyway, and the returns took 1.045x the CPU time on Mitsuba's box
    // with the bunny (images identical).
    let det = e0 + e1 + e2;
    let t_scaled = (e0 * p0.z + e1 * p1.z + e2 * p2.z) * shear.z;
    let mixed_signs = ((e0 < 0.0) | (e1 < 0.0) | (e2 < 0.0)) & ((e0 > 0.0) | (e1 > 0.0) | (e2 > 0.0));
    // Outside (0, t_max) before the division, with det's sign.
    let outside_negative = (det < 0.0) & ((t_scaled >= 0.0) | (t_scaled < t_max * det));
    let outside_positive = (det > 0.0) & ((t_scaled <= 0.0) | (t_scaled > t_max * det));
    let t = t_scaled / det;
    let inside = !mixed_signs & (det != 0.0) & !outside_negative & !outside_positive & (t > 0.0) & (t < t_max);
    return select(-1.0, t, inside);
}

// The test of a triangle compiled into the kernel (a baked scene's, or one of
// the largest beside the BVH), which every ray runs: the ray meets the
// triangle's plane, and the point's barycentric coordinates are its
// projections on two axes, all folded to constants (as the quad's test). A
// third of the watertight test's arithmetic, which spends most of it on the
// ray's frame (docs/benchmarks.md). Not watertight: a ray within rounding of
// an edge two of them share may pass between them, as it may between
// Mitsuba's triangles (Moller-Trumbore).
fn triangle_constant_hit_t(tri: Triangle, ray: Ray, t_max: f32) -> f32 {
    let e1 = tri.p1 - tri.p0;
    let e2 = tri.p2 - tri.p0;
    let n = cross(e1, e2);
    let inv_n2 = 1.0 / dot(n, n);
    let t = (dot(n, tri.p0) - dot(n, ray.origin)) / dot(n, ray.dir);
    let planar = ray.origin + t * ray.dir - tri.p0;
    let b1 = dot(planar, cross(e2, n) * inv_n2);
    let b2 = dot(planar, cross(n, e1) * inv_n2);
    // A degenerate triangle's coordinates are NaN, and a ray along the plane's
    // distance infinite or NaN: each fails a comparison.
    let inside = (t > 0.0) & (t < t_max) & (b1 >= 0.0) & (b2 >= 0.0) & (b1 + b2 <= 1.0);
    return select(-1.0, t, inside);
}

// The closest hit keeps the face normal.
fn triangle_hit_keep(tri: Triangle) -> vec4<f32> {
    return vec4<f32>(normalize(triangle_cross(tri)), 0.0);
}

fn triangle_hit_normal(keep: vec4<f32>, p: vec3<f32>) -> vec3<f32> {
    return keep.xyz;
}

#if TRIANGLE_NORMALS
// Mirrors `kinds::TriangleNormals`: the vertex normals of a smooth triangle,
// octahedral-encoded in two snorm16 each (`kinds::triangle::oct_encode`).
struct TriangleNormals {
    n0: u32,
    n1: u32,
    n2: u32,
}

fn oct_decode(bits: u32) -> vec3<f32> {
    let e = unpack2x16snorm(bits);
    let z = 1.0 - abs(e.x) - abs(e.y);
    let t = max(-z, 0.0);
    return normalize(vec3<f32>(e.x - sign_or_one(e.x) * t, e.y - sign_or_one(e.y) * t, z));
}

fn sign_or_one(x: f32) -> f32 {
    return select(-1.0, 1.0, x >= 0.0);
}

// The vertex normals interpolated at p (barycentric, from the areas of the
// sub-triangles), turned to the side of the geometric normal `ng` where they
// point away from it, and `ng` itself where they cancel out.
fn triangle_shading_normal(index: u32, p: vec3<f32>, ng: vec3<f32>) -> vec3<f32> {
    let tri = triangles_at(index);
    let normals = triangle_normals_at(index);
    let p0 = tri.p0;
    let p1 = tri.p1;
    let p2 = tri.p2;
    let n = cross(p1 - p0, p2 - p0);
    let inv_n2 = 1.0 / dot(n, n);
    let b0 = dot(cross(p1 - p, p2 - p), n) * inv_n2;
    let b1 = dot(cross(p2 - p, p0 - p), n) * inv_n2;
    let b2 = 1.0 - b0 - b1;
    let interpolated = b0 * oct_decode(normals.n0) + b1 * oct_decode(normals.n1) + b2 * oct_decode(normals.n2);
    let length2 = dot(interpolated, interpolated);
    if !(length2 > 1e-12) {
        return ng;
    }
    let shading = interpolated * inverseSqrt(length2);
    return select(-shading, shading, dot(shading, ng) >= 0.0);
}
#endif

#if TEXTURES
// Mirrors `kinds::TriangleUvs`.
struct TriangleUvs {
    uv0: vec2<f32>,
    uv1: vec2<f32>,
    uv2: vec2<f32>,
}

// The vertex uvs interpolated at `point` (barycentric, from the areas of the
// sub-triangles).
fn triangle_hit_uv(tri: Triangle, uvs: TriangleUvs, point: vec3<f32>) -> vec2<f32> {
    let n = triangle_cross(tri);
    let inv_n2 = 1.0 / dot(n, n);
    let b1 = dot(cross(tri.p2 - point, tri.p0 - point), n) * inv_n2;
    let b2 = dot(cross(tri.p0 - point, tri.p1 - point), n) * inv_n2;
    return (1.0 - b1 - b2) * uvs.uv0 + b1 * uvs.uv1 + b2 * uvs.uv2;
}
#endif

#if BUMP_MAPS
// The face's dp_du and dp_dv from its vertex uvs (Mitsuba's mesh: the edges
// p1 - p0, p2 - p0 in terms of the uv edges); where the uvs span no area (all
// equal, or on a line) any frame about the face normal.
fn triangle_hit_tangents(tri: Triangle, uvs: TriangleUvs, point: vec3<f32>) -> Tangents {
    let duv0 = uvs.uv1 - uvs.uv0;
    let duv1 = uvs.uv2 - uvs.uv0;
    let dp0 = tri.p1 - tri.p0;
    let dp1 = tri.p2 - tri.p0;
    let det = difference_of_products(duv0.x, duv1.y, duv0.y, duv1.x);
    let inv_det = 1.0 / det;
    let dp_du = (duv1.y * dp0 - duv0.y * dp1) * inv_det;
    let dp_dv = (duv0.x * dp1 - duv1.x * dp0) * inv_det;
    // Also false for NaN and infinite tangents (det zero or subnormal).
    let finite = max(max(abs(dp_du), abs(dp_dv)), vec3<f32>(abs(inv_det))) < vec3<f32>(F32_MAX);
    if !all(finite) {
        return tangents_about(normalize(triangle_cross(tri)));
    }
    return Tangents(dp_du, dp_dv);
}
#endif

// Direction from `origin` to a uniformly chosen point of the triangle. (Uniform
// in solid angle, as pbrt-v4, was measured: 2.5-4.6x as efficient under a large,
// near triangle light, but 0.7x on Mitsuba's Cornell box, where its code alone
// made every path 25% slower on lavapipe.)
fn triangle_light_sample(tri: Triangle, origin: vec3<f32>, u: vec2<f32>) -> vec3<f32> {
    let s = sqrt(u.x);
    let b0 = 1.0 - s;
    let b1 = u.y * s;
    let target_point = b0 * tri.p0 + b1 * tri.p1 + (1.0 - b0 - b1) * tri.p2;
    return normalize(target_point - origin);
}

// Solid-angle density of `triangle_light_sample`: d^2 / (|cos| A) where the ray
// meets it.
fn triangle_light_pdf(tri: Triangle, origin: vec3<f32>, dir: vec3<f32>) -> f32 {
    let t = triangle_hit_t(tri, Ray(origin, dir), F32_MAX);
    if t < 0.0 {
        return 0.0;
    }
    return triangle_light_point_pdf(tri, t, dir);
}

// The same where the unit `dir` meets the triangle at distance `t`:
// t^2 / (|cos| A), with |dir . n| A = |dir . (p1 - p0) x (p2 - p0)| / 2.
fn triangle_light_point_pdf(tri: Triangle, t: f32, dir: vec3<f32>) -> f32 {
    return (2.0 * t * t) / abs(dot(dir, triangle_cross(tri)));
}
