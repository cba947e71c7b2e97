// The book's dielectric: reflection or refraction, chosen with Schlick's
// approximation of the Fresnel reflectance; the weight is 1 either way.

fn schlick(cosine: f32, eta: f32) -> f32 {
    var r0 = (1.0 - eta) / (1.0 + eta);
    r0 = r0 * r0;
    return r0 + (1.0 - r0) * pow(1.0 - cosine, 5.0);
}

fn dielectric_sample(m: Material, frame: Frame, wo: vec3<f32>) -> BsdfSample {
    let eta = select(m.param, 1.0 / m.param, frame.front_face);
    let cos_theta = min(dot(wo, frame.n), 1.0);
    let sin_theta = sqrt(max(0.0, 1.0 - cos_theta * cos_theta));
    // Drawn even under total internal reflection, to keep the dimensions aligned.
    let u = sample_1d();
    var wi: vec3<f32>;
    var probability: f32;
    let reflectance = schlick(cos_theta, eta);
    if eta * sin_theta > 1.0 || reflectance > u {
        wi = reflect(-wo, frame.n);
        probability = select(reflectance, 1.0, eta * sin_theta > 1.0);
    } else {
        wi = refract(-wo, frame.n, eta);
        probability = 1.0 - reflectance;
    }
    return BsdfSample(normalize(wi), vec3<f32>(1.0), probability, true);
}
