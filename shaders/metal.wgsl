// The book's metal: the mirror direction moved by a uniform point of a sphere of
// radius `fuzz`, renormalised. That density has no closed form, so the lobe is
// delta to the strategies (as in the book): followed, never mixed.

fn metal_sample(m: Material, frame: Frame, wo: vec3<f32>) -> BsdfSample {
    let wi = normalize(reflect(-wo, frame.n) + m.param * sample_sphere(sample_2d()));
    if dot(wi, frame.n) <= 0.0 {
        return bsdf_absorbed();
    }
    return BsdfSample(wi, m.albedo, 1.0, true);
}
