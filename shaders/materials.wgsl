// Materials: how a hit emits and scatters. Only the kinds the scene uses are
// compiled in; a material of any other kind (a light) absorbs.

const MATERIAL_LAMBERTIAN: u32 = 0u;
const MATERIAL_METAL: u32 = 1u;
const MATERIAL_DIELECTRIC: u32 = 2u;
const MATERIAL_LIGHT: u32 = 3u;

// Mirrors `gpu::layout::Material`.
struct Material {
    albedo: vec3<f32>,
    kind: u32,
    // Radiance leaving the side the normal faces.
    emit: vec3<f32>,
    // Metal: fuzz. Dielectric: index of refraction.
    param: f32,
}

// `materials_at` reads one material by index; a baked scene generates it.
#if !BAKED_SCENE
@group(1) @binding(0) var<storage, read> materials: array<Material>;
fn materials_at(i: u32) -> Material { return materials[i]; }
#endif

struct Scatter {
    dir: vec3<f32>,
    // Multiplies the path throughput: attenuation, times s / p for sampled directions.
    weight: vec3<f32>,
    absorbed: bool,
    // Next-event estimation only: the light sample's direction, and what the emission
    // its shadow ray finds is multiplied by (with the throughput): the BSDF, the MIS
    // weight, over the light density. Zero: no shadow ray.
    shadow_dir: vec3<f32>,
    shadow_weight: vec3<f32>,
    // Densities of `dir` under BSDF and light sampling, for the MIS weight of an emitter
    // the continuation hits; bsdf_pdf = 0 marks a specular bounce (counted fully).
    bsdf_pdf: f32,
    light_pdf: f32,
}

fn absorbed() -> Scatter {
    return Scatter(vec3<f32>(0.0), vec3<f32>(0.0), true, vec3<f32>(0.0), vec3<f32>(0.0), 0.0, 0.0);
}

fn specular(dir: vec3<f32>, weight: vec3<f32>) -> Scatter {
    return Scatter(dir, weight, false, vec3<f32>(0.0), vec3<f32>(0.0), 0.0, 0.0);
}

// The power heuristic a^2 / (a^2 + b^2), written so huge densities cannot overflow.
fn power_heuristic(a: f32, b: f32) -> f32 {
    let ratio = b / a;
    return 1.0 / (1.0 + ratio * ratio);
}

#if LAMBERTIAN
// One direction from the run's density p (cosine, light or their mixture), weighted
// by albedo * s / p with s = cos / pi, the Lambertian scattering density.
fn scatter_lambertian(albedo: vec3<f32>, n: vec3<f32>, origin: vec3<f32>) -> Scatter {
#if STRATEGY_COSINE
    // s / p = 1 exactly.
    return specular(sample_cosine(n, sample_2d()), albedo);
#else
#if STRATEGY_NEE
    // Light sample; the kernel traces its shadow ray.
    var shadow_weight = vec3<f32>(0.0);
    let light_select = sample_1d();
    let light_dir = light_sample(origin, light_select, sample_2d());
    let light_cos = dot(n, light_dir);
    let light_density = light_pdf(origin, light_dir);
    if light_cos > 0.0 && light_density > 0.0 {
        let s = light_cos * INV_PI;
        shadow_weight = albedo * (s * power_heuristic(light_density, s) / light_density);
    }
    // BSDF sample: the continuation, s / p = 1; its emitter hit is weighted in the kernel.
    let dir = sample_cosine(n, sample_2d());
    return Scatter(dir, albedo, false, light_dir, shadow_weight, cosine_pdf(n, dir), light_pdf(origin, dir));
#else
#if STRATEGY_LIGHT
    let light_select = sample_1d();
    let dir = light_sample(origin, light_select, sample_2d());
    let pdf = light_pdf(origin, dir);
#else
    // Both branches use the same dimensions, so they stay aligned across samples;
    // the choice, rescaled, also picks the light.
    let choice = sample_1d();
    let u = sample_2d();
    var dir: vec3<f32>;
    if choice < LIGHT_WEIGHT {
        dir = light_sample(origin, choice / LIGHT_WEIGHT, u);
    } else {
        dir = sample_cosine(n, u);
    }
    // The full mixture density of the chosen direction, whichever part drew it.
    let pdf = LIGHT_WEIGHT * light_pdf(origin, dir) + (1.0 - LIGHT_WEIGHT) * cosine_pdf(n, dir);
#endif
    let s = cosine_pdf(n, dir);
    // A direction below the surface contributes exactly zero.
    if s <= 0.0 || pdf <= 0.0 {
        return absorbed();
    }
    return specular(dir, albedo * (s / pdf));
#endif
#endif
}
#endif

#if METAL
fn scatter_metal(albedo: vec3<f32>, fuzz: f32, n: vec3<f32>, in_dir: vec3<f32>) -> Scatter {
    let dir = normalize(reflect(in_dir, n) + fuzz * sample_sphere(sample_2d()));
    if dot(dir, n) <= 0.0 {
        return absorbed();
    }
    return specular(dir, albedo);
}
#endif

#if DIELECTRIC
// Schlick's approximation of Fresnel reflectance, as the book.
fn schlick(cosine: f32, eta: f32) -> f32 {
    var r0 = (1.0 - eta) / (1.0 + eta);
    r0 = r0 * r0;
    return r0 + (1.0 - r0) * pow(1.0 - cosine, 5.0);
}

fn scatter_dielectric(ior: f32, n: vec3<f32>, in_dir: vec3<f32>, front_face: bool) -> Scatter {
    let eta = select(ior, 1.0 / ior, front_face);
    let cos_theta = min(dot(-in_dir, n), 1.0);
    let sin_theta = sqrt(max(0.0, 1.0 - cos_theta * cos_theta));
    // Drawn even under total internal reflection, to keep the dimensions aligned.
    let u = sample_1d();
    var dir: vec3<f32>;
    if eta * sin_theta > 1.0 || schlick(cos_theta, eta) > u {
        dir = reflect(in_dir, n);
    } else {
        dir = refract(in_dir, n, eta);
    }
    return specular(normalize(dir), vec3<f32>(1.0));
}
#endif

// `n` faces the incoming ray.
fn scatter(material: Material, n: vec3<f32>, in_dir: vec3<f32>, origin: vec3<f32>, front_face: bool) -> Scatter {
    switch material.kind {
#if LAMBERTIAN
        case MATERIAL_LAMBERTIAN: {
            return scatter_lambertian(material.albedo, n, origin);
        }
#endif
#if METAL
        case MATERIAL_METAL: {
            return scatter_metal(material.albedo, material.param, n, in_dir);
        }
#endif
#if DIELECTRIC
        case MATERIAL_DIELECTRIC: {
            return scatter_dielectric(material.param, n, in_dir, front_face);
        }
#endif
        default: {
            return absorbed();
        }
    }
}
