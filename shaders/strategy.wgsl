// Sampling strategies: how a path picks its next direction where the material
// has a smooth lobe (its delta lobe, if it has one too, is followed). Written
// once against the BSDF interface (materials.wgsl), so every material kind gets
// every strategy. At a delta lobe, and under the `bsdf` strategy, the path
// follows the material's own sample.
//
// - bsdf:    the material's sampling alone (cosine-weighted for Lambertian).
// - light:   the light density alone (biased: misses indirect light).
// - mixture: p = w p_light + (1 - w) p_bsdf, the full density evaluated for
//            whichever part drew the direction.
// - nee-mis: a shadow ray toward a light sample and a BSDF-sampled continuation,
//            each weighted by the power heuristic against the other's density.

struct Scatter {
    dir: vec3<f32>,
    // Multiplies the path throughput: f |cos| / p for the direction drawn.
    weight: vec3<f32>,
    absorbed: bool,
    // Next-event estimation only: the light sample's direction, and what the
    // emission its shadow ray finds is multiplied by (with the throughput): f |cos|
    // times the MIS weight, over the light density. Zero: no shadow ray.
    shadow_dir: vec3<f32>,
    shadow_weight: vec3<f32>,
    // A delta lobe drew `dir`: an emitter it hits counts fully (no MIS weight).
    delta: bool,
    // Densities of `dir` under BSDF and light sampling, for the MIS weight of an
    // emitter the continuation hits (under LIGHT_POINTS, a grouped light's share
    // is left out: the kernel adds the point's where the ray lands).
    bsdf_pdf: f32,
    light_pdf: f32,
    // Under LIGHT_POINTS, what the kernel finishes the light sample's weight
    // with where its shadow ray lands (`shadow_weight` is then f |cos| alone):
    // the sample direction's BSDF density and light density (less the grouped
    // lights' share), and the grouped light it aimed at, or NO_LIGHT.
    shadow_pdfs: vec2<f32>,
    shadow_light: u32,
}

fn absorbed() -> Scatter {
    return Scatter(vec3<f32>(0.0), vec3<f32>(0.0), true, vec3<f32>(0.0), vec3<f32>(0.0), false, 0.0, 0.0, vec2<f32>(0.0), NO_LIGHT);
}

// The BSDF's own sample, followed as it is.
fn follow(s: BsdfSample) -> Scatter {
    if s.pdf <= 0.0 {
        return absorbed();
    }
    return Scatter(s.wi, s.weight, false, vec3<f32>(0.0), vec3<f32>(0.0), s.delta, s.pdf, 0.0, vec2<f32>(0.0), NO_LIGHT);
}

// The power heuristic a^2 / (a^2 + b^2), written so huge densities cannot overflow.
fn power_heuristic(a: f32, b: f32) -> f32 {
    let ratio = b / a;
    return 1.0 / (1.0 + ratio * ratio);
}

#if LIGHT_DENSITY
// A smooth lobe under the light, mixture or nee-mis strategy.
fn scatter_smooth(m: Material, frame: Frame, wo: vec3<f32>, origin: vec3<f32>) -> Scatter {
#if STRATEGY_NEE
    // Light sample; the kernel traces its shadow ray.
    var shadow_weight = vec3<f32>(0.0);
    let light_select = sample_1d();
    let light = light_sample(origin, light_select, sample_2d());
    let light_dir = light.dir;
    let light_density = light_pdf(origin, light_dir);
    let f_light = bsdf_eval(m, frame, wo, light_dir);
#if LIGHT_POINTS
    // A grouped light's share of the density is known where the shadow ray lands.
    let shadow_pdfs = vec2<f32>(bsdf_pdf(m, frame, wo, light_dir), light_density);
    if any(f_light > vec3<f32>(0.0)) {
        shadow_weight = f_light;
    }
#else
    let shadow_pdfs = vec2<f32>(0.0);
    if light_density > 0.0 && any(f_light > vec3<f32>(0.0)) {
        let mis = power_heuristic(light_density, bsdf_pdf(m, frame, wo, light_dir));
        shadow_weight = f_light * (mis / light_density);
    }
#endif
    // BSDF sample: the continuation; its emitter hit is weighted in the kernel.
    // A sample of a delta lobe (a plastic's coat) counts the emitter it finds fully.
    let s = smooth_bsdf_sample(m, frame, wo);
    return Scatter(s.wi, s.weight, s.pdf <= 0.0, light_dir, shadow_weight, s.delta, s.pdf, light_pdf(origin, s.wi), shadow_pdfs, light.light);
#else
#if STRATEGY_LIGHT
    let light_select = sample_1d();
    let wi = light_sample(origin, light_select, sample_2d()).dir;
    let pdf = light_pdf(origin, wi);
#else
    // The choice, rescaled, also picks the light.
    let choice = sample_1d();
    var wi: vec3<f32>;
    if choice < LIGHT_WEIGHT {
        wi = light_sample(origin, choice / LIGHT_WEIGHT, sample_2d()).dir;
    } else {
        let s = smooth_bsdf_sample(m, frame, wo);
        // A delta lobe's direction has no density to mix: only this branch
        // draws it, with (1 - w) times the probability the BSDF gives it.
        if s.delta {
            return Scatter(s.wi, s.weight / (1.0 - LIGHT_WEIGHT), false, vec3<f32>(0.0), vec3<f32>(0.0), true, 0.0, 0.0, vec2<f32>(0.0), NO_LIGHT);
        }
        wi = s.wi;
    }
    // The full mixture density of the chosen direction, whichever part drew it.
    let pdf = LIGHT_WEIGHT * light_pdf(origin, wi) + (1.0 - LIGHT_WEIGHT) * bsdf_pdf(m, frame, wo, wi);
#endif
    let f = bsdf_eval(m, frame, wo, wi);
    // A direction the BSDF does not scatter into (below the surface) contributes exactly zero.
    if pdf <= 0.0 || all(f == vec3<f32>(0.0)) {
        return absorbed();
    }
    return Scatter(wi, f / pdf, false, vec3<f32>(0.0), vec3<f32>(0.0), false, 0.0, 0.0, vec2<f32>(0.0), NO_LIGHT);
#endif
}
#endif

// `origin` is the hit point moved off the surface on the side of `wo`.
fn scatter(m: Material, frame: Frame, wo: vec3<f32>, origin: vec3<f32>) -> Scatter {
#if ONE_SIDED
    // A one-sided surface (Mitsuba's BSDFs outside `twosided`) is black from behind.
    if (m.flags & MATERIAL_ONE_SIDED) != 0u && !frame.front_face {
        return absorbed();
    }
#endif
#if LIGHT_DENSITY
    if bsdf_is_smooth(m) {
        return scatter_smooth(m, frame, wo, origin);
    }
    return follow(delta_bsdf_sample(m, frame, wo));
#else
    return follow(bsdf_sample(m, frame, wo));
#endif
}
