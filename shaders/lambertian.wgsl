// Lambertian (ideal diffuse) reflection: f = albedo / pi on the side of the normal.

fn lambertian_eval(m: Material, frame: Frame, wo: vec3<f32>, wi: vec3<f32>) -> vec3<f32> {
    return m.albedo * cosine_pdf(frame.n, wi);
}

fn lambertian_pdf(m: Material, frame: Frame, wo: vec3<f32>, wi: vec3<f32>) -> f32 {
    return cosine_pdf(frame.n, wi);
}

// Cosine-weighted, so f |cos| / pdf is the albedo exactly.
fn lambertian_sample(m: Material, frame: Frame, wo: vec3<f32>) -> BsdfSample {
    let wi = sample_cosine(frame.n, sample_2d());
    return BsdfSample(wi, m.albedo, cosine_pdf(frame.n, wi), false);
}
