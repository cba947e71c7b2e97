// Mitsuba's `conductor`: a perfectly smooth mirror with the Fresnel reflectance
// of the complex index eta + i k, times specular_reflectance. Two-sided: it
// reflects on whichever side the path arrives (see `kinds::material`).

fn conductor_sample(m: Material, frame: Frame, wo: vec3<f32>) -> BsdfSample {
    let cos_theta_i = dot(wo, frame.n);
    let f = fresnel_conductor(min(cos_theta_i, 1.0), m.color2, m.color3);
    return BsdfSample(reflect(-wo, frame.n), m.albedo * f, 1.0, true);
}
