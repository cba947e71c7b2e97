// Microfacet normal distributions, as Mitsuba 3's microfacet.h: Beckmann and
// GGX (Trowbridge-Reitz), anisotropic, with Smith's shadowing-masking, sampled
// from the distribution of visible normals (Heitz and d'Eon 2014; Heitz 2018)
// with its exact density. Vectors are in the local frame of the shading
// normal (z up); `alpha_u` runs along the frame's first tangent.

struct Microfacet {
    alpha_u: f32,
    alpha_v: f32,
    beckmann: bool,
}

// The distribution of a rough material (`param`, `param2`, `flags`; see
// `kinds::material`). Its `alpha` (both) or `alpha_u` and `alpha_v` may be
// textures, in the same slots in every rough kind (`ROUGHNESS_NUMBERS`:
// the rough conductor's constants name them), at least Mitsuba's 1e-4 as
// packed ones are (`MIN_ALPHA`).
fn microfacet_of(m: Material) -> Microfacet {
    let alpha = vec2<f32>(
        material_number(NUMBER_ROUGHCONDUCTOR_ALPHA_U, material_number(NUMBER_ROUGHCONDUCTOR_ALPHA, m.param)),
        material_number(NUMBER_ROUGHCONDUCTOR_ALPHA_V, material_number(NUMBER_ROUGHCONDUCTOR_ALPHA, m.param2)),
    );
    let clamped = max(alpha, vec2<f32>(1e-4));
    return Microfacet(clamped.x, clamped.y, (m.flags & MATERIAL_BECKMANN) != 0u);
}

// An orthonormal frame around the shading normal: the tangents of `onb_to_world`.
struct LocalFrame {
    t: vec3<f32>,
    s: vec3<f32>,
    n: vec3<f32>,
}

fn local_frame(n: vec3<f32>) -> LocalFrame {
    return LocalFrame(onb_to_world(n, vec3<f32>(1.0, 0.0, 0.0)), onb_to_world(n, vec3<f32>(0.0, 1.0, 0.0)), n);
}

fn to_local(f: LocalFrame, v: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(dot(f.t, v), dot(f.s, v), dot(f.n, v));
}

fn from_local(f: LocalFrame, v: vec3<f32>) -> vec3<f32> {
    return f.t * v.x + f.s * v.y + f.n * v.z;
}

// The microfacet density D(m) (normalised over projected area).
fn microfacet_d(d: Microfacet, m: vec3<f32>) -> f32 {
    let cos_theta = m.z;
    if cos_theta <= 0.0 {
        return 0.0;
    }
    let alpha_uv = d.alpha_u * d.alpha_v;
    let cos_theta_2 = cos_theta * cos_theta;
    let x = m.x / d.alpha_u;
    let y = m.y / d.alpha_v;
    var result: f32;
    if d.beckmann {
        result = exp(-(x * x + y * y) / cos_theta_2) / (PI * alpha_uv * cos_theta_2 * cos_theta_2);
    } else {
        let s = x * x + y * y + m.z * m.z;
        result = 1.0 / (PI * alpha_uv * s * s);
    }
    // Values this small are rounding noise (as Mitsuba).
    return select(0.0, result, result * cos_theta > 1e-20);
}

// Smith's masking G1(v, m) of direction `v` for microfacet normal `m`.
fn microfacet_g1(d: Microfacet, v: vec3<f32>, m: vec3<f32>) -> f32 {
    if dot(v, m) * v.z <= 0.0 {
        return 0.0;
    }
    let xy_alpha_2 = (d.alpha_u * v.x) * (d.alpha_u * v.x) + (d.alpha_v * v.y) * (d.alpha_v * v.y);
    if xy_alpha_2 == 0.0 {
        return 1.0;
    }
    let tan_theta_alpha_2 = xy_alpha_2 / (v.z * v.z);
    if d.beckmann {
        // Smith's G1 in closed form, 2 / (1 + erf(a) + exp(-a^2) / (a sqrt(pi))),
        // a = 1 / (alpha tan theta): the normalisation of the visible slopes
        // `microfacet_sample` draws. Mitsuba uses Walter et al.'s rational fit
        // here, whose error (up to 0.3% near grazing) leaves its density off
        // its sampling (measured: chi-square p < 1e-90 at 89.9 degrees).
        let a = inverseSqrt(tan_theta_alpha_2);
        return 2.0 / (1.0 + erf_approx(a) + 0.564189583547756 * exp(-a * a) / a);
    }
    return 2.0 / (1.0 + sqrt(1.0 + tan_theta_alpha_2));
}

// The density of visible normals seen from `wi` (wi.z > 0): D(m) G1(wi, m) |wi.m| / wi.z.
fn microfacet_pdf(d: Microfacet, wi: vec3<f32>, m: vec3<f32>) -> f32 {
    return microfacet_d(d, m) * microfacet_g1(d, wi, m) * abs(dot(wi, m)) / wi.z;
}

// erf (Abramowitz and Stegun 7.1.26: absolute error below 1.5e-7).
fn erf_approx(x: f32) -> f32 {
    let t = 1.0 / (1.0 + 0.3275911 * abs(x));
    let poly = t * (0.254829592 + t * (-0.284496736 + t * (1.421413741 + t * (-1.453152027 + t * 1.061405429))));
    return sign(x) * (1.0 - poly * exp(-x * x));
}


// A slope of the unit-roughness distribution's visible normals, seen at
// incidence cosine `cos_theta_i` (Mitsuba's `sample_visible_11`).
fn microfacet_sample_visible_11(beckmann: bool, cos_theta_i: f32, u: vec2<f32>) -> vec2<f32> {
    if beckmann {
        // Jakob's inversion of the Beckmann visible-slope CDF in the erf
        // domain, from Mitsuba's initial guess. Mitsuba takes three Newton
        // steps; here they run until the CDF matches to 1e-6 (kept inside a
        // bisection bracket), so the samples follow the density whatever the
        // incidence.
        let sqrt_pi_inv = 0.564189583547756;
        let tan_theta_i = sqrt(max(1.0 - cos_theta_i * cos_theta_i, 0.0)) / cos_theta_i;
        let cot_theta_i = 1.0 / tan_theta_i;
        let maxval = erf_approx(cot_theta_i);
        var s = clamp(u, vec2<f32>(1e-6), vec2<f32>(1.0 - 1e-6));
        var x = maxval - (maxval + 1.0) * erf_approx(sqrt(-log(s.x)));
        let total = 1.0 + maxval + sqrt_pi_inv * tan_theta_i * exp(-cot_theta_i * cot_theta_i);
        s.x *= total;
        var lo = -1.0;
        var hi = maxval;
        for (var i = 0; i < 16; i++) {
            if !(x >= lo && x <= hi) {
                x = 0.5 * (lo + hi);
            }
            let slope = erfinv(x);
            let value = 1.0 + x + sqrt_pi_inv * tan_theta_i * exp(-slope * slope) - s.x;
            if abs(value) <= 1e-6 * total {
                break;
            }
            if value > 0.0 {
                hi = x;
            } else {
                lo = x;
            }
            x -= value / (1.0 - slope * tan_theta_i);
        }
        return vec2<f32>(erfinv(x), erfinv(2.0 * s.y - 1.0));
    }
    // GGX: a point of the projected visible hemisphere (Heitz 2018), as a slope.
    var p = square_to_disk_concentric(u);
    let s = 0.5 * (1.0 + cos_theta_i);
    p.y = mix(sqrt(max(1.0 - p.x * p.x, 0.0)), p.y, s);
    let z = sqrt(max(1.0 - dot(p, p), 0.0));
    let sin_theta_i = sqrt(max(1.0 - cos_theta_i * cos_theta_i, 0.0));
    // On the disk's rim the normal is horizontal: keep its slope finite.
    let norm = 1.0 / max(sin_theta_i * p.y + cos_theta_i * z, 1e-8);
    return vec2<f32>(cos_theta_i * p.y - sin_theta_i * z, p.x) * norm;
}

// A microfacet normal visible from `wi` (wi.z > 0), drawn with density
// `microfacet_pdf(d, wi, m)`: stretch, sample the unit distribution, unstretch.
fn microfacet_sample(d: Microfacet, wi: vec3<f32>, u: vec2<f32>) -> vec3<f32> {
    let wi_p = normalize(vec3<f32>(d.alpha_u * wi.x, d.alpha_v * wi.y, wi.z));
    let sin_theta_2 = wi_p.x * wi_p.x + wi_p.y * wi_p.y;
    var cos_phi = 1.0;
    var sin_phi = 0.0;
    if sin_theta_2 > 4.0 * 1.1920929e-7 {
        let inv_sin_theta = inverseSqrt(sin_theta_2);
        cos_phi = clamp(wi_p.x * inv_sin_theta, -1.0, 1.0);
        sin_phi = clamp(wi_p.y * inv_sin_theta, -1.0, 1.0);
    }
    let slope = microfacet_sample_visible_11(d.beckmann, wi_p.z, u);
    let stretched = vec2<f32>(
        (cos_phi * slope.x - sin_phi * slope.y) * d.alpha_u,
        (sin_phi * slope.x + cos_phi * slope.y) * d.alpha_v,
    );
    return normalize(vec3<f32>(-stretched.x, -stretched.y, 1.0));
}
