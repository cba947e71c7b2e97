// Fresnel reflectance, as Mitsuba 3's fresnel.h defines it.

// Unpolarised reflectance of a conductor of complex index `eta + i k` (relative
// to the outside medium), per channel, at incidence cosine `cos_theta_i` >= 0
// (after K. D. Moeller, "Optics", 1988, as Mitsuba).
fn fresnel_conductor(cos_theta_i: f32, eta: vec3<f32>, k: vec3<f32>) -> vec3<f32> {
    let cos_theta_i_2 = cos_theta_i * cos_theta_i;
    let sin_theta_i_2 = 1.0 - cos_theta_i_2;
    let sin_theta_i_4 = sin_theta_i_2 * sin_theta_i_2;
    let temp_1 = eta * eta - k * k - vec3<f32>(sin_theta_i_2);
    let a_2_pb_2 = sqrt(max(temp_1 * temp_1 + 4.0 * k * k * eta * eta, vec3<f32>(0.0)));
    let a = sqrt(max(0.5 * (a_2_pb_2 + temp_1), vec3<f32>(0.0)));
    let term_1 = a_2_pb_2 + vec3<f32>(cos_theta_i_2);
    let term_2 = 2.0 * cos_theta_i * a;
    let r_s = (term_1 - term_2) / (term_1 + term_2);
    let term_3 = a_2_pb_2 * cos_theta_i_2 + vec3<f32>(sin_theta_i_4);
    let term_4 = term_2 * sin_theta_i_2;
    let r_p = r_s * (term_3 - term_4) / (term_3 + term_4);
    return 0.5 * (r_s + r_p);
}

struct FresnelDielectric {
    // Reflectance (1 under total internal reflection).
    r: f32,
    // Cosine of the refracted direction, of the opposite sign to cos_theta_i.
    cos_theta_t: f32,
    // Relative index across the interface in the direction of travel, and its inverse.
    eta_it: f32,
    eta_ti: f32,
}

// Unpolarised reflectance of a dielectric interface of relative index `eta`
// (inside over outside) at incidence cosine `cos_theta_i` (negative: from inside).
fn fresnel_dielectric(cos_theta_i: f32, eta: f32) -> FresnelDielectric {
    let outside = cos_theta_i >= 0.0;
    let eta_it = select(1.0 / eta, eta, outside);
    let eta_ti = select(eta, 1.0 / eta, outside);
    let cos_theta_t_sqr = 1.0 - (1.0 - cos_theta_i * cos_theta_i) * eta_ti * eta_ti;
    let cos_theta_i_abs = abs(cos_theta_i);
    let cos_theta_t_abs = sqrt(max(cos_theta_t_sqr, 0.0));
    let a_s = (cos_theta_i_abs - eta_it * cos_theta_t_abs) / (cos_theta_i_abs + eta_it * cos_theta_t_abs);
    let a_p = (cos_theta_t_abs - eta_it * cos_theta_i_abs) / (cos_theta_t_abs + eta_it * cos_theta_i_abs);
    var r = 0.5 * (a_s * a_s + a_p * a_p);
    // Index-matched: nothing reflects; grazing: everything does.
    if eta == 1.0 {
        r = 0.0;
    } else if cos_theta_i_abs == 0.0 {
        r = 1.0;
    }
    let cos_theta_t = select(cos_theta_t_abs, -cos_theta_t_abs, cos_theta_i >= 0.0);
    return FresnelDielectric(r, cos_theta_t, eta_it, eta_ti);
}
