// Direction sampling on the hemisphere and the sphere, and orthonormal bases.

// Branchless basis around unit `n` (Duff et al., "Building an Orthonormal Basis, Revisited", 2017).
fn onb_to_world(n: vec3<f32>, local: vec3<f32>) -> vec3<f32> {
    let sign = select(-1.0, 1.0, n.z >= 0.0);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    let t = vec3<f32>(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
    let s = vec3<f32>(b, sign + n.y * n.y * a, -n.y);
    return t * local.x + s * local.y + n * local.z;
}

// Cosine-weighted direction about unit `n` from a uniform point `u` of the unit
// square; density cos(theta) / pi.
fn sample_cosine(n: vec3<f32>, u: vec2<f32>) -> vec3<f32> {
    let phi = 2.0 * PI * u.x;
    let sin_theta = sqrt(u.y);
    let local = vec3<f32>(cos(phi) * sin_theta, sin(phi) * sin_theta, sqrt(1.0 - u.y));
    return normalize(onb_to_world(n, local));
}

fn cosine_pdf(n: vec3<f32>, dir: vec3<f32>) -> f32 {
    return max(dot(n, dir), 0.0) * INV_PI;
}

// Uniform direction on the unit sphere from a uniform point `u` of the unit square.
fn sample_sphere(u: vec2<f32>) -> vec3<f32> {
    let z = 1.0 - 2.0 * u.x;
    let phi = 2.0 * PI * u.y;
    let r = sqrt(max(0.0, 1.0 - z * z));
    return vec3<f32>(r * cos(phi), r * sin(phi), z);
}

// The inverse error function in single precision (Giles 2010, "Approximating the
// erfinv function"): relative error below 4e-7 on (-1, 1). Used by the Gaussian pixel
// filter and Beckmann sampling.
fn erfinv(x: f32) -> f32 {
    var w = -log(max((1.0 - x) * (1.0 + x), 1e-30));
    var p: f32;
    if w < 5.0 {
        w = w - 2.5;
        p = 2.81022636e-08;
        p = 3.43273939e-07 + p * w;
        p = -3.5233877e-06 + p * w;
        p = -4.39150654e-06 + p * w;
        p = 0.00021858087 + p * w;
        p = -0.00125372503 + p * w;
        p = -0.00417768164 + p * w;
        p = 0.246640727 + p * w;
        p = 1.50140941 + p * w;
    } else {
        w = sqrt(w) - 3.0;
        p = -0.000200214257;
        p = 0.000100950558 + p * w;
        p = 0.00134934322 + p * w;
        p = -0.00367342844 + p * w;
        p = 0.00573950773 + p * w;
        p = -0.0076224613 + p * w;
        p = 0.00943887047 + p * w;
        p = 1.00167406 + p * w;
        p = 2.83297682 + p * w;
    }
    return p * x;
}

// Uniform point of the unit disk from the unit square (Shirley-Chiu concentric map).
fn square_to_disk_concentric(u: vec2<f32>) -> vec2<f32> {
    let x = 2.0 * u.x - 1.0;
    let y = 2.0 * u.y - 1.0;
    let quadrant_1_or_3 = abs(x) < abs(y);
    let r = select(x, y, quadrant_1_or_3);
    let rp = select(y, x, quadrant_1_or_3);
    var phi = 0.25 * PI * rp / r;
    if quadrant_1_or_3 {
        phi = 0.5 * PI - phi;
    }
    if x == 0.0 && y == 0.0 {
        phi = 0.0;
    }
    return r * vec2<f32>(cos(phi), sin(phi));
}

#if LIGHT_SELECTION_SPATIAL
// A bound on what a one-sided planar emitter of `power` (its radiance's luminance
// times its area) sends toward `origin`, for the spatial light pick: `power cos' /
// max(d^2, R^2)`, where d is the distance from `center`, R the radius of a sphere
// about it that holds the emitter, and cos' the cosine of the angle between the
// normal and the direction to `origin`, less the largest angle that sphere
// subtends (pbrt-v4's light bounds). 0 behind the plane, which it cannot light.
fn planar_light_importance(power: f32, center: vec3<f32>, normal: vec3<f32>, radius: f32, origin: vec3<f32>) -> f32 {
    let offset = origin - center;
    let height = dot(normal, offset);
    let d2 = dot(offset, offset);
    let r2 = radius * radius;
    if height <= 0.0 {
        return 0.0;
    }
    if d2 <= r2 {
        return power / r2;
    }
    let cos_theta = height * inverseSqrt(d2);
    let sin2_bound = r2 / d2;
    let cos_bound = sqrt(1.0 - sin2_bound);
    let sin_theta = sqrt(max(0.0, 1.0 - cos_theta * cos_theta));
    let cos_nearest = select(cos_theta * cos_bound + sin_theta * sqrt(sin2_bound), 1.0, cos_theta >= cos_bound);
    return power * cos_nearest / d2;
}
#endif
