// Mitsuba's `plastic`: a diffuse base under a smooth dielectric coat. The coat
// reflects specularly (a delta lobe) with the Fresnel reflectance F; the rest
// enters, scatters diffusely (internal reflections at the coat summed as the
// geometric series of the coat's diffuse reflectance `fdr_int`) and leaves
// through (1 - F) again, scaled by 1 / eta^2. The specular lobe is sampled with
// probability F w / (F w + (1 - F)(1 - w)), w Mitsuba's specular sampling
// weight. eval and pdf cover the diffuse lobe only. Two-sided.
// Packed (`kinds::material`): albedo = diffuse_reflectance, color2 =
// specular_reflectance, color3 = (eta, fdr_int, w).

fn plastic_specular_probability(m: Material, f_i: f32) -> f32 {
    let specular = f_i * m.color3.z;
    let diffuse = (1.0 - f_i) * (1.0 - m.color3.z);
    return specular / (specular + diffuse);
}

// The diffuse lobe's f |cos| for incidence and exit Fresnel reflectances f_i, f_o.
fn plastic_diffuse(m: Material, f_i: f32, f_o: f32, cos_theta_o: f32) -> vec3<f32> {
    let eta = m.color3.x;
    var inner = vec3<f32>(m.color3.y);
    if (m.flags & MATERIAL_NONLINEAR) != 0u {
        inner = m.albedo * m.color3.y;
    }
    let diffuse = m.albedo / (vec3<f32>(1.0) - inner);
    return diffuse * (cos_theta_o * INV_PI * (1.0 - f_i) * (1.0 - f_o) / (eta * eta));
}

fn plastic_eval(m: Material, frame: Frame, wo: vec3<f32>, wi: vec3<f32>) -> vec3<f32> {
    let cos_theta_i = dot(wo, frame.n);
    let cos_theta_o = dot(wi, frame.n);
    if cos_theta_i <= 0.0 || cos_theta_o <= 0.0 {
        return vec3<f32>(0.0);
    }
    let f_i = fresnel_dielectric(cos_theta_i, m.color3.x).r;
    let f_o = fresnel_dielectric(cos_theta_o, m.color3.x).r;
    return plastic_diffuse(m, f_i, f_o, cos_theta_o);
}

fn plastic_pdf(m: Material, frame: Frame, wo: vec3<f32>, wi: vec3<f32>) -> f32 {
    let cos_theta_i = dot(wo, frame.n);
    if cos_theta_i <= 0.0 {
        return 0.0;
    }
    let f_i = fresnel_dielectric(cos_theta_i, m.color3.x).r;
    return (1.0 - plastic_specular_probability(m, f_i)) * cosine_pdf(frame.n, wi);
}

fn plastic_sample(m: Material, frame: Frame, wo: vec3<f32>) -> BsdfSample {
    let choice = sample_1d();
    let u = sample_2d();
    let cos_theta_i = dot(wo, frame.n);
    if cos_theta_i <= 0.0 {
        return bsdf_absorbed();
    }
    let f_i = fresnel_dielectric(cos_theta_i, m.color3.x).r;
    let p_specular = plastic_specular_probability(m, f_i);
    if choice < p_specular {
        return BsdfSample(reflect(-wo, frame.n), m.color2 * (f_i / p_specular), p_specular, true);
    }
    let wi = sample_cosine(frame.n, u);
    let cos_theta_o = dot(wi, frame.n);
    let pdf = (1.0 - p_specular) * cosine_pdf(frame.n, wi);
    if pdf <= 0.0 {
        return bsdf_absorbed();
    }
    let f_o = fresnel_dielectric(cos_theta_o, m.color3.x).r;
    return BsdfSample(wi, plastic_diffuse(m, f_i, f_o, cos_theta_o) / pdf, pdf, false);
}
