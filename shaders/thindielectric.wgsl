// Mitsuba's `thindielectric`: a thin slab of dielectric, two parallel interfaces.
// Summing every internal bounce, it reflects R' = R + T^2 R / (1 - R^2) = 2R / (1 + R)
// (R the Fresnel reflectance of one interface at the incident angle, T = 1 - R)
// and lets 1 - R' through along the incident direction: the second interface
// undoes the first one's bending. The lobe is chosen with its probability, so
// the weight is the specular_reflectance or specular_transmittance alone.

fn thindielectric_sample(m: Material, frame: Frame, wo: vec3<f32>) -> BsdfSample {
    let r = fresnel_dielectric(min(abs(dot(wo, frame.n)), 1.0), m.param).r;
    let slab_r = 2.0 * r / (1.0 + r);
    if sample_1d() <= slab_r {
        return BsdfSample(reflect(-wo, frame.n), m.albedo, slab_r, true);
    }
    return BsdfSample(-wo, m.color2, 1.0 - slab_r, true);
}
