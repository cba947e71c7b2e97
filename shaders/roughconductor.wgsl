// Mitsuba's `roughconductor`: Cook-Torrance with a Beckmann or GGX distribution,
// complex-IOR Fresnel (eta, k) times specular_reflectance, sampled from the
// visible normals. Two-sided, like the book's materials.

fn roughconductor_eval(m: Material, frame: Frame, wo: vec3<f32>, wi: vec3<f32>) -> vec3<f32> {
    let f = local_frame(frame.n);
    let i = to_local(f, wo);
    let o = to_local(f, wi);
    if i.z <= 0.0 || o.z <= 0.0 {
        return vec3<f32>(0.0);
    }
    let h = normalize(i + o);
    let d = microfacet_of(m);
    let g = microfacet_g1(d, i, h) * microfacet_g1(d, o, h);
    let fresnel = fresnel_conductor(dot(i, h), m.color2, m.color3);
    return m.albedo * fresnel * (microfacet_d(d, h) * g / (4.0 * i.z));
}

fn roughconductor_pdf(m: Material, frame: Frame, wo: vec3<f32>, wi: vec3<f32>) -> f32 {
    let f = local_frame(frame.n);
    let i = to_local(f, wo);
    let o = to_local(f, wi);
    if i.z <= 0.0 || o.z <= 0.0 {
        return 0.0;
    }
    let h = normalize(i + o);
    if dot(o, h) <= 0.0 {
        return 0.0;
    }
    // The visible-normal density times the reflection's Jacobian 1 / (4 o.h), o.h = i.h.
    let d = microfacet_of(m);
    return microfacet_d(d, h) * microfacet_g1(d, i, h) / (4.0 * i.z);
}

fn roughconductor_sample(m: Material, frame: Frame, wo: vec3<f32>) -> BsdfSample {
    let f = local_frame(frame.n);
    let i = to_local(f, wo);
    let u = sample_2d();
    if i.z <= 0.0 {
        return bsdf_absorbed();
    }
    let d = microfacet_of(m);
    let h = microfacet_sample(d, i, u);
    let i_h = dot(i, h);
    let o = 2.0 * i_h * h - i;
    let pdf = microfacet_d(d, h) * microfacet_g1(d, i, h) / (4.0 * i.z);
    if o.z <= 0.0 || i_h <= 0.0 || pdf <= 0.0 {
        return bsdf_absorbed();
    }
    // f cos / pdf simplifies to F G1(o): finite however small alpha is.
    let weight = m.albedo * fresnel_conductor(i_h, m.color2, m.color3) * microfacet_g1(d, o, h);
    return BsdfSample(from_local(f, o), weight, pdf, false);
}
