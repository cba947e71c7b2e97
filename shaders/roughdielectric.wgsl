// Mitsuba's `roughdielectric` (Walter et al. 2007): reflection and refraction
// through a rough interface of relative index eta = int_ior / ext_ior
// (`color3.x`), each microfacet chosen from the visible normals and the lobe by
// its Fresnel reflectance. Radiance crossing the interface is scaled by the
// squared index ratio, as Mitsuba does in radiance mode. The frame's normal
// faces `wo`, so the index seen is eta from outside and 1 / eta from inside.

fn roughdielectric_eta(m: Material, frame: Frame) -> f32 {
    return select(1.0 / m.color3.x, m.color3.x, frame.front_face);
}

// The generalised half vector of (i, o) on the side of the normal, and the
// Jacobian |d h / d o|; `reflect` says on which side o lies.
struct RoughDielectricHalf {
    h: vec3<f32>,
    jacobian: f32,
}

fn roughdielectric_half(i: vec3<f32>, o: vec3<f32>, eta: f32) -> RoughDielectricHalf {
    let reflect = o.z > 0.0;
    var h = normalize(i + o * select(eta, 1.0, reflect));
    h *= sign(h.z);
    let o_h = dot(o, h);
    let denominator = dot(i, h) + eta * o_h;
    let jacobian = select(eta * eta * o_h / (denominator * denominator), 1.0 / (4.0 * o_h), reflect);
    return RoughDielectricHalf(h, abs(jacobian));
}

fn roughdielectric_eval(m: Material, frame: Frame, wo: vec3<f32>, wi: vec3<f32>) -> vec3<f32> {
    let f = local_frame(frame.n);
    let i = to_local(f, wo);
    let o = to_local(f, wi);
    if i.z <= 0.0 || o.z == 0.0 {
        return vec3<f32>(0.0);
    }
    let eta = roughdielectric_eta(m, frame);
    let half = roughdielectric_half(i, o, eta);
    let h = half.h;
    let d = microfacet_of(m);
    let g = microfacet_g1(d, i, h) * microfacet_g1(d, o, h);
    if g == 0.0 {
        return vec3<f32>(0.0);
    }
    let fresnel = fresnel_dielectric(dot(i, h), eta).r;
    let dh = microfacet_d(d, h);
    if o.z > 0.0 {
        return m.albedo * (fresnel * dh * g / (4.0 * i.z));
    }
    // Transmission: the Jacobian term, with the radiance scale 1 / eta^2.
    let i_h = dot(i, h);
    let o_h = dot(o, h);
    let denominator = i_h + eta * o_h;
    let value = abs((1.0 - fresnel) * dh * g * i_h * o_h / (i.z * denominator * denominator));
    return m.color2 * value;
}

fn roughdielectric_pdf(m: Material, frame: Frame, wo: vec3<f32>, wi: vec3<f32>) -> f32 {
    let f = local_frame(frame.n);
    let i = to_local(f, wo);
    let o = to_local(f, wi);
    if i.z <= 0.0 || o.z == 0.0 {
        return 0.0;
    }
    let eta = roughdielectric_eta(m, frame);
    let half = roughdielectric_half(i, o, eta);
    let h = half.h;
    // Micro- and macrosurface must agree on each direction's side (as in G1).
    if dot(i, h) <= 0.0 || dot(o, h) * o.z <= 0.0 {
        return 0.0;
    }
    let fresnel = fresnel_dielectric(dot(i, h), eta).r;
    let lobe = select(1.0 - fresnel, fresnel, o.z > 0.0);
    return microfacet_pdf(microfacet_of(m), i, h) * lobe * half.jacobian;
}

fn roughdielectric_sample(m: Material, frame: Frame, wo: vec3<f32>) -> BsdfSample {
    let f = local_frame(frame.n);
    let i = to_local(f, wo);
    let u = sample_2d();
    let choice = sample_1d();
    if i.z <= 0.0 {
        return bsdf_absorbed();
    }
    let eta = roughdielectric_eta(m, frame);
    let d = microfacet_of(m);
    let h = microfacet_sample(d, i, u);
    let i_h = dot(i, h);
    var pdf = microfacet_pdf(d, i, h);
    let fr = fresnel_dielectric(i_h, eta);
    var o: vec3<f32>;
    var weight: vec3<f32>;
    var jacobian: f32;
    if choice <= fr.r {
        o = 2.0 * i_h * h - i;
        weight = m.albedo;
        jacobian = 1.0 / (4.0 * dot(o, h));
        pdf *= fr.r;
    } else {
        o = h * (i_h * fr.eta_ti + fr.cos_theta_t) - i * fr.eta_ti;
        weight = m.color2 * (fr.eta_ti * fr.eta_ti);
        let o_h = dot(o, h);
        let denominator = i_h + fr.eta_it * o_h;
        jacobian = fr.eta_it * fr.eta_it * o_h / (denominator * denominator);
        pdf *= 1.0 - fr.r;
    }
    // f cos / pdf simplifies to the tint times G1(o) (the lobe choice cancels F).
    weight *= microfacet_g1(d, o, h);
    pdf *= abs(jacobian);
    if pdf <= 0.0 || all(weight == vec3<f32>(0.0)) {
        return bsdf_absorbed();
    }
    return BsdfSample(from_local(f, normalize(o)), weight, pdf, false);
}
