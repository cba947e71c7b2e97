// Mitsuba's `dielectric`: a smooth interface of relative index eta = int_ior /
// ext_ior (`param`). It reflects by the exact Fresnel reflectance and refracts
// the rest, each lobe drawn with its probability, so the weight is the lobe's
// tint alone (`albedo` = specular_reflectance, `color2` =
// specular_transmittance), the refracted one scaled by the squared index ratio
// as Mitsuba does in radiance mode. The frame's normal faces `wo`, so the index
// seen is eta from outside and 1 / eta from inside.

fn smoothdielectric_sample(m: Material, frame: Frame, wo: vec3<f32>) -> BsdfSample {
    let eta = select(1.0 / m.param, m.param, frame.front_face);
    let cos_theta_i = clamp(dot(wo, frame.n), 0.0, 1.0);
    let fr = fresnel_dielectric(cos_theta_i, eta);
    // Drawn under total internal reflection too, to keep the dimensions aligned.
    if sample_1d() < fr.r || fr.r >= 1.0 {
        return BsdfSample(reflect(-wo, frame.n), m.albedo, fr.r, true);
    }
    // Snell's law: the tangential part scaled by eta_ti, the normal part across.
    let wi = frame.n * fr.cos_theta_t - (wo - frame.n * cos_theta_i) * fr.eta_ti;
    return BsdfSample(normalize(wi), m.color2 * (fr.eta_ti * fr.eta_ti), 1.0 - fr.r, true);
}
