// What Mitsuba 3's `principled` and `principledthin` share
// (src/bsdfs/principledhelpers.h and the lobes both evaluate alike): Schlick's
// Fresnel, the tint toward the base colour, Burley's diffuse with
// retro-reflection and the fake subsurface, and the sheen.

// (1 - cos)^5, cos clamped to [0, 1].
fn disney_schlick_weight(cos_theta: f32) -> f32 {
    let m = clamp(1.0 - cos_theta, 0.0, 1.0);
    return m * m * m * m * m;
}

// Schlick's Fresnel from `r0` at microfacet cosine `cos_theta_i` (>= 0) into
// index `eta`; for an index below 1, at the refracted cosine (1 past the
// critical angle), as Mitsuba's calc_schlick.
fn disney_schlick(r0: vec3<f32>, cos_theta_i: f32, eta: f32) -> vec3<f32> {
    var cos_theta = cos_theta_i;
    if eta <= 1.0 {
        cos_theta = sqrt(max(1.0 - (1.0 - cos_theta_i * cos_theta_i) / (eta * eta), 0.0));
    }
    return mix(vec3<f32>(disney_schlick_weight(cos_theta)), vec3<f32>(1.0), r0);
}

// A dielectric's normal-incidence reflectance, ((eta - 1) / (eta + 1))^2.
fn disney_r0(eta: f32) -> f32 {
    let r = (eta - 1.0) / (eta + 1.0);
    return r * r;
}

// The base colour over its luminance (white where it is black).
fn disney_tint(base_color: vec3<f32>) -> vec3<f32> {
    let lum = dot(base_color, LUMINANCE);
    return select(vec3<f32>(1.0), base_color / lum, lum > 0.0);
}

// Burley's diffuse BSDF with retro-reflection, blended toward Hanrahan and
// Krueger's fake subsurface by `flatness`, for incidence and exitance cosines
// `cos_i`, `cos_o` (> 0) and the cosine `cos_d` between the exitant direction
// and the half vector.
fn disney_diffuse(base_color: vec3<f32>, roughness: f32, flatness: f32, cos_i: f32, cos_o: f32, cos_d: f32) -> vec3<f32> {
    let fo = disney_schlick_weight(cos_o);
    let fi = disney_schlick_weight(cos_i);
    let diffuse = (1.0 - 0.5 * fi) * (1.0 - 0.5 * fo);
    let rr = 2.0 * roughness * cos_d * cos_d;
    let retro = rr * (fo + fi + fo * fi * (rr - 1.0));
    let fss = mix(1.0, 0.5 * rr, fo) * mix(1.0, 0.5 * rr, fi);
    let subsurface = 1.25 * (fss * (1.0 / (cos_o + cos_i) - 0.5) + 0.5);
    return base_color * (INV_PI * mix(diffuse + retro, subsurface, flatness));
}

// The sheen's colour and angular falloff (times `sheen` and |cos_o| by the caller).
fn disney_sheen(base_color: vec3<f32>, sheen_tint: f32, cos_d: f32) -> vec3<f32> {
    return mix(vec3<f32>(1.0), disney_tint(base_color), sheen_tint) * disney_schlick_weight(abs(cos_d));
}
