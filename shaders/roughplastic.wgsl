// Mitsuba's `roughplastic`: a diffuse base under a rough dielectric coat. The
// coat reflects as a microfacet dielectric (F D G / (4 cos_i), isotropic); the
// rest enters, scatters diffusely (internal reflections summed as the geometric
// series of the coat's internal reflectance) and leaves, scaled by the coat's
// transmittance in and out and by 1 / eta^2. The transmittance is tabulated per
// material on the host (`kinds::coat`) and interpolated as Mitsuba does. The
// coat is sampled from its visible normals with probability
// (1 - T_i) w / ((1 - T_i) w + T_i (1 - w)), w Mitsuba's specular sampling
// weight, the base by the cosine; both lobes have densities. Two-sided.
// Packed (`kinds::material`): albedo = diffuse_reflectance, color2 =
// specular_reflectance, color3 = (eta, internal reflectance, w), param = alpha,
// param2 = the table's offset in `material_tables`.

// The coat's transmittance at incidence cosine `cos_theta` (Mitsuba's lerp_gather).
fn roughplastic_transmittance(m: Material, cos_theta: f32) -> f32 {
    let x = cos_theta * f32(ROUGH_TRANSMITTANCE_RES - 1u);
    let index = min(u32(x), ROUGH_TRANSMITTANCE_RES - 2u);
    let first = u32(m.param2) + index;
    return mix(material_tables_at(first), material_tables_at(first + 1u), x - f32(index));
}

fn roughplastic_microfacet(m: Material) -> Microfacet {
    return Microfacet(m.param, m.param, (m.flags & MATERIAL_BECKMANN) != 0u);
}

fn roughplastic_specular_probability(m: Material, t_i: f32) -> f32 {
    let specular = (1.0 - t_i) * m.color3.z;
    let diffuse = t_i * (1.0 - m.color3.z);
    return specular / (specular + diffuse);
}

// f |cos| in the local frame (i, o above the surface), with t_i the coat's
// transmittance at i (looked up once by each caller).
fn roughplastic_eval_local(m: Material, i: vec3<f32>, o: vec3<f32>, t_i: f32) -> vec3<f32> {
    let h = normalize(i + o);
    let d = roughplastic_microfacet(m);
    let g = microfacet_g1(d, i, h) * microfacet_g1(d, o, h);
    let fresnel = fresnel_dielectric(dot(i, h), m.color3.x).r;
    let specular = m.color2 * (fresnel * microfacet_d(d, h) * g / (4.0 * i.z));
    var inner = vec3<f32>(m.color3.y);
    if (m.flags & MATERIAL_NONLINEAR) != 0u {
        inner = m.albedo * m.color3.y;
    }
    let t_o = roughplastic_transmittance(m, o.z);
    let eta = m.color3.x;
    let diffuse = m.albedo / (vec3<f32>(1.0) - inner) * (INV_PI * o.z * t_i * t_o / (eta * eta));
    return specular + diffuse;
}

fn roughplastic_pdf_local(m: Material, i: vec3<f32>, o: vec3<f32>, t_i: f32) -> f32 {
    let p_specular = roughplastic_specular_probability(m, t_i);
    let h = normalize(i + o);
    let d = roughplastic_microfacet(m);
    // The visible-normal density times the reflection's Jacobian 1 / (4 o.h), o.h = i.h.
    let specular = microfacet_d(d, h) * microfacet_g1(d, i, h) / (4.0 * i.z);
    return p_specular * specular + (1.0 - p_specular) * o.z * INV_PI;
}

fn roughplastic_eval(m: Material, frame: Frame, wo: vec3<f32>, wi: vec3<f32>) -> vec3<f32> {
    let f = local_frame(frame.n);
    let i = to_local(f, wo);
    let o = to_local(f, wi);
    if i.z <= 0.0 || o.z <= 0.0 {
        return vec3<f32>(0.0);
    }
    return roughplastic_eval_local(m, i, o, roughplastic_transmittance(m, i.z));
}

fn roughplastic_pdf(m: Material, frame: Frame, wo: vec3<f32>, wi: vec3<f32>) -> f32 {
    let f = local_frame(frame.n);
    let i = to_local(f, wo);
    let o = to_local(f, wi);
    if i.z <= 0.0 || o.z <= 0.0 {
        return 0.0;
    }
    return roughplastic_pdf_local(m, i, o, roughplastic_transmittance(m, i.z));
}

fn roughplastic_sample(m: Material, frame: Frame, wo: vec3<f32>) -> BsdfSample {
    let choice = sample_1d();
    let u = sample_2d();
    let f = local_frame(frame.n);
    let i = to_local(f, wo);
    if i.z <= 0.0 {
        return bsdf_absorbed();
    }
    let t_i = roughplastic_transmittance(m, i.z);
    var o: vec3<f32>;
    if choice < roughplastic_specular_probability(m, t_i) {
        let h = microfacet_sample(roughplastic_microfacet(m), i, u);
        o = 2.0 * dot(i, h) * h - i;
    } else {
        o = to_local(f, sample_cosine(frame.n, u));
    }
    if o.z <= 0.0 {
        return bsdf_absorbed();
    }
    let pdf = roughplastic_pdf_local(m, i, o, t_i);
    if pdf <= 0.0 {
        return bsdf_absorbed();
    }
    return BsdfSample(from_local(f, o), roughplastic_eval_local(m, i, o, t_i) / pdf, pdf, false);
}
