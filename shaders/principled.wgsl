// Mitsuba 3's `principled` (src/bsdfs/principled.cpp and principledhelpers.h),
// term for term: a diffuse lobe with retro-reflection (blended toward the fake
// subsurface by flatness), a sheen, a specular reflection and transmission
// through anisotropic GGX microfacets, and a GTR1 clearcoat. Seen from
// behind (`front_face` false) only a transmitting one scatters, by the
// dielectric alone. Sampling picks the diffuse lobe, the clearcoat or the
// specular pair with Mitsuba's probabilities (the pair split by the Fresnel
// reflectance of the sampled normal); the density is the whole mixture's.
// Packed (`kinds::material`): albedo = base_color, param = roughness, param2 =
// the offset in `material_tables` of (anisotropic, spec_tint, sheen_tint,
// flatness), color2 = (metallic, spec_trans, eta), color3 = (sheen,
// clearcoat, clearcoat_gloss); each read through `material_number`, which
// gives a textured one's value at the hit instead.

struct Principled {
    base_color: vec3<f32>,
    roughness: f32,
    metallic: f32,
    eta: f32,
    spec_tint: f32,
    sheen: f32,
    sheen_tint: f32,
    clearcoat: f32,
    flatness: f32,
    // The weights of the diffuse lobe and of the transmission.
    brdf: f32,
    bsdf: f32,
    specular: Microfacet,
    // GTR1's alpha.
    clearcoat_alpha: f32,
}

fn principled_of(m: Material) -> Principled {
    let first = u32(m.param2);
    let roughness = material_number(NUMBER_PRINCIPLED_ROUGHNESS, m.param);
    let anisotropic = material_number(NUMBER_PRINCIPLED_ANISOTROPIC, material_tables_at(first));
    let metallic = material_number(NUMBER_PRINCIPLED_METALLIC, m.color2.x);
    let spec_trans = material_number(NUMBER_PRINCIPLED_SPEC_TRANS, m.color2.y);
    // Mitsuba's calc_dist_params (Disney's mapping).
    let aspect = sqrt(1.0 - 0.9 * anisotropic);
    let r2 = roughness * roughness;
    let specular = Microfacet(max(0.001, r2 / aspect), max(0.001, r2 * aspect), false);
    return Principled(
        m.albedo,
        roughness,
        metallic,
        m.color2.z,
        material_number(NUMBER_PRINCIPLED_SPEC_TINT, material_tables_at(first + 1u)),
        material_number(NUMBER_PRINCIPLED_SHEEN, m.color3.x),
        material_number(NUMBER_PRINCIPLED_SHEEN_TINT, material_tables_at(first + 2u)),
        material_number(NUMBER_PRINCIPLED_CLEARCOAT, m.color3.y),
        material_number(NUMBER_PRINCIPLED_FLATNESS, material_tables_at(first + 3u)),
        (1.0 - metallic) * (1.0 - spec_trans),
        (1.0 - metallic) * spec_trans,
        specular,
        mix(0.1, 0.001, material_number(NUMBER_PRINCIPLED_CLEARCOAT_GLOSS, m.color3.z)),
    );
}

// GTR1's density of normals (Burley), Mitsuba's GTR1Isotropic::eval.
fn principled_gtr1(alpha: f32, m: vec3<f32>) -> f32 {
    let a2 = alpha * alpha;
    let result = (a2 - 1.0) / (PI * log(a2) * (1.0 + (a2 - 1.0) * m.z * m.z));
    return select(0.0, result, result * m.z > 1e-20);
}

fn principled_gtr1_sample(alpha: f32, u: vec2<f32>) -> vec3<f32> {
    let phi = 2.0 * PI * u.x;
    let a2 = alpha * alpha;
    let cos_theta_2 = (1.0 - pow(a2, 1.0 - u.y)) / (1.0 - a2);
    let sin_theta = sqrt(max(0.0, 1.0 - cos_theta_2));
    return vec3<f32>(cos(phi) * sin_theta, sin(phi) * sin_theta, sqrt(max(0.0, cos_theta_2)));
}

// The index seen from the side of `wo`.
fn principled_eta_path(p: Principled, front: bool) -> f32 {
    return select(1.0 / p.eta, p.eta, front);
}

// The half vector of (i, o), generalised for refraction, on the side of the normal.
fn principled_half(i: vec3<f32>, o: vec3<f32>, eta_path: f32) -> vec3<f32> {
    let h = normalize(i + o * select(eta_path, 1.0, o.z > 0.0));
    return select(h, -h, h.z < 0.0);
}

// The lobes' selection probabilities, each over their sum: x diffuse, y
// clearcoat, z transmission, w reflection, for the specular normal's
// dielectric reflectance `fresnel`.
fn principled_probabilities(p: Principled, front: bool, fresnel: f32) -> vec4<f32> {
    var probabilities: vec4<f32>;
    if front {
        probabilities = vec4<f32>(p.brdf, 0.25 * p.clearcoat, p.bsdf * (1.0 - fresnel), 1.0 - p.bsdf * (1.0 - fresnel));
    } else {
        probabilities = vec4<f32>(0.0, 0.0, 1.0 - fresnel, fresnel);
    }
    return probabilities / (probabilities.x + probabilities.y + probabilities.z + probabilities.w);
}

// Whether the side seen scatters: the front, or the back of one that transmits.
fn principled_scatters(p: Principled, front: bool) -> bool {
    return front || p.bsdf > 0.0;
}

// f |cos| in the local frame (i.z > 0).
fn principled_eval_local(p: Principled, front: bool, i: vec3<f32>, o: vec3<f32>) -> vec3<f32> {
    let reflect = o.z > 0.0;
    let refract = o.z < 0.0;
    if !(reflect || refract) || !principled_scatters(p, front) {
        return vec3<f32>(0.0);
    }
    let eta_path = principled_eta_path(p, front);
    let h = principled_half(i, o, eta_path);
    let i_h = dot(i, h);
    let o_h = dot(o, h);
    let fresnel = fresnel_dielectric(i_h, eta_path).r;
    let reflect_compatible = reflect && i_h > 0.0 && o_h > 0.0;
    let refract_compatible = refract && i_h > 0.0 && o_h < 0.0;
    let d = microfacet_d(p.specular, h);
    let g = microfacet_g1(p.specular, i, h) * microfacet_g1(p.specular, o, h);
    var value = vec3<f32>(0.0);
    if reflect_compatible && fresnel > 0.0 {
        var f = vec3<f32>(p.bsdf * fresnel);
        if front {
            // The dielectric's reflectance blended with a Schlick metal of the
            // base colour and a Schlick dielectric tinted toward it.
            let metal = disney_schlick(p.base_color, i_h, p.eta);
            let tinted = disney_schlick(disney_tint(p.base_color) * disney_r0(p.eta), i_h, p.eta);
            f = (1.0 - p.metallic) * (1.0 - p.spec_tint) * fresnel + p.metallic * metal
                + (1.0 - p.metallic) * p.spec_tint * tinted;
        }
        value += f * (d * g / (4.0 * i.z));
    }
    if refract_compatible && p.bsdf > 0.0 && fresnel < 1.0 {
        // Radiance's 1 / eta_path^2 cancels the Jacobian's eta_path^2.
        let denominator = i_h + eta_path * o_h;
        value += sqrt(p.base_color) * (p.bsdf * abs((1.0 - fresnel) * d * g * i_h * o_h / (i.z * denominator * denominator)));
    }
    if !front || !reflect {
        return value;
    }
    if reflect_compatible && p.clearcoat > 0.0 {
        let fresnel_coat = disney_schlick(vec3<f32>(0.04), i_h, p.eta).x;
        let coat = Microfacet(0.25, 0.25, false);
        let g_coat = microfacet_g1(coat, i, h) * microfacet_g1(coat, o, h);
        value += vec3<f32>(0.25 * p.clearcoat * fresnel_coat * principled_gtr1(p.clearcoat_alpha, h) * g_coat * o.z);
    }
    if p.brdf > 0.0 {
        value += disney_diffuse(p.base_color, p.roughness, p.flatness, i.z, o.z, o_h) * (p.brdf * o.z);
    }
    if p.sheen > 0.0 && p.metallic < 1.0 {
        value += disney_sheen(p.base_color, p.sheen_tint, o_h) * (p.sheen * (1.0 - p.metallic) * o.z);
    }
    return value;
}

fn principled_pdf_local(p: Principled, front: bool, i: vec3<f32>, o: vec3<f32>) -> f32 {
    let reflect = o.z > 0.0;
    let refract = o.z < 0.0;
    if !(reflect || refract) || !principled_scatters(p, front) {
        return 0.0;
    }
    let eta_path = principled_eta_path(p, front);
    let h = principled_half(i, o, eta_path);
    let i_h = dot(i, h);
    let o_h = dot(o, h);
    let probabilities = principled_probabilities(p, front, fresnel_dielectric(i_h, eta_path).r);
    if reflect {
        var pdf = probabilities.x * o.z * INV_PI;
        if i_h > 0.0 && o_h > 0.0 {
            // The visible normals' density D G1 (i.h) / i.z times the Jacobian
            // 1 / (4 o.h), with o.h = i.h cancelled: near grazing, f32's half
            // vector leaves the two unequal by more than a narrow lobe allows.
            let d = p.specular;
            pdf += probabilities.w * microfacet_d(d, h) * microfacet_g1(d, i, h) / (4.0 * i.z);
            pdf += probabilities.y * principled_gtr1(p.clearcoat_alpha, h) * h.z / (4.0 * o_h);
        }
        return pdf;
    }
    if i_h <= 0.0 || o_h >= 0.0 {
        return 0.0;
    }
    let denominator = i_h + eta_path * o_h;
    let jacobian = abs(eta_path * eta_path * o_h / (denominator * denominator));
    return probabilities.z * microfacet_pdf(p.specular, i, h) * jacobian;
}

fn principled_eval(m: Material, frame: Frame, wo: vec3<f32>, wi: vec3<f32>) -> vec3<f32> {
    let f = local_frame(frame.n);
    let i = to_local(f, wo);
    if i.z <= 0.0 {
        return vec3<f32>(0.0);
    }
    return principled_eval_local(principled_of(m), frame.front_face, i, to_local(f, wi));
}

fn principled_pdf(m: Material, frame: Frame, wo: vec3<f32>, wi: vec3<f32>) -> f32 {
    let f = local_frame(frame.n);
    let i = to_local(f, wo);
    if i.z <= 0.0 {
        return 0.0;
    }
    return principled_pdf_local(principled_of(m), frame.front_face, i, to_local(f, wi));
}

fn principled_sample(m: Material, frame: Frame, wo: vec3<f32>) -> BsdfSample {
    let choice = sample_1d();
    let u = sample_2d();
    let f = local_frame(frame.n);
    let i = to_local(f, wo);
    let p = principled_of(m);
    let front = frame.front_face;
    if i.z <= 0.0 || !principled_scatters(p, front) {
        return bsdf_absorbed();
    }
    // The diffuse and clearcoat probabilities do not depend on the Fresnel
    // reflectance (the specular pair's sum is 1 whatever it is).
    let fixed = principled_probabilities(p, front, 0.0);
    var o: vec3<f32>;
    if choice < fixed.x {
        o = to_local(f, sample_cosine(frame.n, u));
    } else if choice < fixed.x + fixed.y {
        let h = principled_gtr1_sample(p.clearcoat_alpha, u);
        o = 2.0 * dot(i, h) * h - i;
        if dot(i, h) <= 0.0 || o.z <= 0.0 {
            return bsdf_absorbed();
        }
    } else {
        let h = microfacet_sample(p.specular, i, u);
        let i_h = dot(i, h);
        let fr = fresnel_dielectric(i_h, principled_eta_path(p, front));
        let probabilities = principled_probabilities(p, front, fr.r);
        if choice < fixed.x + fixed.y + probabilities.z {
            o = h * (i_h * fr.eta_ti + fr.cos_theta_t) - i * fr.eta_ti;
            if o.z >= 0.0 || dot(o, h) >= 0.0 {
                return bsdf_absorbed();
            }
        } else {
            o = 2.0 * i_h * h - i;
            if o.z <= 0.0 || dot(o, h) <= 0.0 {
                return bsdf_absorbed();
            }
        }
        o = normalize(o);
    }
    let pdf = principled_pdf_local(p, front, i, o);
    if pdf <= 0.0 {
        return bsdf_absorbed();
    }
    return BsdfSample(from_local(f, o), principled_eval_local(p, front, i, o) / pdf, pdf, false);
}
