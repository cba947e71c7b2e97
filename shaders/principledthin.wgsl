// Mitsuba 3's `principledthin` (src/bsdfs/principledthin.cpp), term for term:
// a thin sheet, the same from both sides (the frame's normal faces `wo`). A
// GGX reflection (Fresnel blended toward a tinted Schlick by spec_tint) and a
// GGX transmission straight through (the reflection of a microfacet of the
// scaled roughness (0.65 eta - 0.35) roughness, mirrored to the far side),
// weighted by spec_trans; Burley's diffuse with the sheen, and a cosine
// transmission, weighted by 1 - spec_trans. Sampled with Mitsuba's lobe
// probabilities (each specular lobe spec_trans / 2, the diffuse reflection
// and transmission (1 - spec_trans) (1 - diff_trans) and (1 - spec_trans)
// diff_trans, summing to 1); the density is the whole mixture's.
// Packed (`kinds::material`): albedo = base_color, param = roughness, param2 =
// the offset in `material_tables` of (anisotropic, spec_tint, sheen_tint,
// flatness), color2 = (spec_trans, eta, diff_trans / 2), color3.x = sheen;
// each read through `material_number`, which gives a textured one's value at
// the hit instead.

struct PrincipledThin {
    base_color: vec3<f32>,
    roughness: f32,
    spec_trans: f32,
    eta: f32,
    diff_trans: f32,
    spec_tint: f32,
    sheen: f32,
    sheen_tint: f32,
    flatness: f32,
    reflection: Microfacet,
    transmission: Microfacet,
}

// Mitsuba's calc_dist_params (Disney's mapping) of `roughness`.
fn principledthin_microfacet(roughness: f32, aspect: f32) -> Microfacet {
    let r2 = roughness * roughness;
    return Microfacet(max(0.001, r2 / aspect), max(0.001, r2 * aspect), false);
}

fn principledthin_of(m: Material) -> PrincipledThin {
    let first = u32(m.param2);
    let roughness = material_number(NUMBER_PRINCIPLEDTHIN_ROUGHNESS, m.param);
    let anisotropic = material_number(NUMBER_PRINCIPLEDTHIN_ANISOTROPIC, material_tables_at(first));
    let aspect = sqrt(1.0 - 0.9 * anisotropic);
    let eta = material_number(NUMBER_PRINCIPLEDTHIN_ETA, m.color2.y);
    return PrincipledThin(
        m.albedo,
        roughness,
        material_number(NUMBER_PRINCIPLEDTHIN_SPEC_TRANS, m.color2.x),
        eta,
        // Packed halved: `diff_trans` is twice the transmission's share.
        0.5 * material_number(NUMBER_PRINCIPLEDTHIN_DIFF_TRANS, 2.0 * m.color2.z),
        material_number(NUMBER_PRINCIPLEDTHIN_SPEC_TINT, material_tables_at(first + 1u)),
        material_number(NUMBER_PRINCIPLEDTHIN_SHEEN, m.color3.x),
        material_number(NUMBER_PRINCIPLEDTHIN_SHEEN_TINT, material_tables_at(first + 2u)),
        material_number(NUMBER_PRINCIPLEDTHIN_FLATNESS, material_tables_at(first + 3u)),
        principledthin_microfacet(roughness, aspect),
        principledthin_microfacet((0.65 * eta - 0.35) * roughness, aspect),
    );
}

// The lobes' selection probabilities: x specular reflection, y specular
// transmission, z diffuse reflection, w diffuse transmission (summing to 1).
fn principledthin_probabilities(p: PrincipledThin) -> vec4<f32> {
    let diffuse = 1.0 - p.spec_trans;
    return vec4<f32>(0.5 * p.spec_trans, 0.5 * p.spec_trans, diffuse * (1.0 - p.diff_trans), diffuse * p.diff_trans);
}

// The half vector of `i` and `o` mirrored above the sheet.
fn principledthin_half(i: vec3<f32>, o: vec3<f32>) -> vec3<f32> {
    return normalize(i + vec3<f32>(o.xy, abs(o.z)));
}

// f |cos| in the local frame (i.z > 0).
fn principledthin_eval_local(p: PrincipledThin, i: vec3<f32>, o: vec3<f32>) -> vec3<f32> {
    let reflect = o.z > 0.0;
    let refract = o.z < 0.0;
    let h = principledthin_half(i, o);
    let i_h = dot(i, h);
    let o_h = dot(o, h);
    var value = vec3<f32>(0.0);
    if p.spec_trans > 0.0 && i_h > 0.0 {
        let fresnel = fresnel_dielectric(i_h, p.eta).r;
        if reflect && o_h > 0.0 {
            let tinted = disney_schlick(disney_tint(p.base_color) * disney_r0(p.eta), i_h, p.eta);
            let f = mix(vec3<f32>(fresnel), tinted, p.spec_tint);
            let d = p.reflection;
            let g = microfacet_g1(d, i, h) * microfacet_g1(d, o, h);
            value += f * (p.spec_trans * microfacet_d(d, h) * g / (4.0 * i.z));
        }
        if refract && o_h < 0.0 {
            let d = p.transmission;
            let g = microfacet_g1(d, i, h) * microfacet_g1(d, o, h);
            value += p.base_color * (p.spec_trans * (1.0 - fresnel) * microfacet_d(d, h) * g / (4.0 * i.z));
        }
    }
    if p.spec_trans >= 1.0 {
        return value;
    }
    if reflect && p.diff_trans < 1.0 {
        let weight = (1.0 - p.spec_trans) * (1.0 - p.diff_trans) * o.z;
        value += disney_diffuse(p.base_color, p.roughness, p.flatness, i.z, o.z, o_h) * weight;
        if p.sheen > 0.0 {
            value += disney_sheen(p.base_color, p.sheen_tint, o_h) * (p.sheen * weight);
        }
    }
    if refract && p.diff_trans > 0.0 {
        value += p.base_color * ((1.0 - p.spec_trans) * p.diff_trans * INV_PI * -o.z);
    }
    return value;
}

fn principledthin_pdf_local(p: PrincipledThin, i: vec3<f32>, o: vec3<f32>) -> f32 {
    let probabilities = principledthin_probabilities(p);
    let h = principledthin_half(i, o);
    let i_h = dot(i, h);
    let o_h = dot(o, h);
    var pdf = 0.0;
    // The visible normals' density D G1 (i.h) / i.z times the reflection's
    // Jacobian 1 / (4 i.h), cancelled (f32's half vector near grazing).
    if i_h > 0.0 && o.z > 0.0 && o_h > 0.0 {
        let d = p.reflection;
        pdf += probabilities.x * microfacet_d(d, h) * microfacet_g1(d, i, h) / (4.0 * i.z);
    }
    if i_h > 0.0 && o.z < 0.0 && o_h < 0.0 {
        let d = p.transmission;
        pdf += probabilities.y * microfacet_d(d, h) * microfacet_g1(d, i, h) / (4.0 * i.z);
    }
    if o.z > 0.0 {
        pdf += probabilities.z * o.z * INV_PI;
    } else {
        pdf += probabilities.w * -o.z * INV_PI;
    }
    return pdf;
}

fn principledthin_eval(m: Material, frame: Frame, wo: vec3<f32>, wi: vec3<f32>) -> vec3<f32> {
    let f = local_frame(frame.n);
    let i = to_local(f, wo);
    if i.z <= 0.0 {
        return vec3<f32>(0.0);
    }
    return principledthin_eval_local(principledthin_of(m), i, to_local(f, wi));
}

fn principledthin_pdf(m: Material, frame: Frame, wo: vec3<f32>, wi: vec3<f32>) -> f32 {
    let f = local_frame(frame.n);
    let i = to_local(f, wo);
    if i.z <= 0.0 {
        return 0.0;
    }
    return principledthin_pdf_local(principledthin_of(m), i, to_local(f, wi));
}

fn principledthin_sample(m: Material, frame: Frame, wo: vec3<f32>) -> BsdfSample {
    let choice = sample_1d();
    let u = sample_2d();
    let f = local_frame(frame.n);
    let i = to_local(f, wo);
    if i.z <= 0.0 {
        return bsdf_absorbed();
    }
    let p = principledthin_of(m);
    let probabilities = principledthin_probabilities(p);
    var o: vec3<f32>;
    if choice < probabilities.x + probabilities.y {
        // Both specular lobes reflect about a visible normal; the
        // transmission's is of its own roughness, and its reflection mirrored.
        let transmits = choice >= probabilities.x;
        var d = p.reflection;
        if transmits {
            d = p.transmission;
        }
        let h = microfacet_sample(d, i, u);
        o = 2.0 * dot(i, h) * h - i;
        if dot(i, h) <= 0.0 || o.z <= 0.0 {
            return bsdf_absorbed();
        }
        if transmits {
            o.z = -o.z;
            if dot(o, h) >= 0.0 {
                return bsdf_absorbed();
            }
        }
    } else {
        o = to_local(f, sample_cosine(frame.n, u));
        if choice >= probabilities.x + probabilities.y + probabilities.z {
            o.z = -o.z;
        }
    }
    let pdf = principledthin_pdf_local(p, i, o);
    if pdf <= 0.0 {
        return bsdf_absorbed();
    }
    return BsdfSample(from_local(f, o), principledthin_eval_local(p, i, o) / pdf, pdf, false);
}
