// Materials: the packed material and the BSDF interface that every material
// kind implements in a module of its own (lambertian.wgsl, metal.wgsl, ...).
// Strategies (strategy.wgsl) are written against this interface only; the
// dispatch by kind (`bsdf_sample`, `bsdf_eval`, `bsdf_pdf`, `bsdf_is_smooth`)
// is generated from the kinds the scene uses (`kernel::glue`).
//
// Directions point away from the surface: `wo` back along the path, `wi` where
// it goes next. A kind with a smooth lobe (`Lobe::Smooth`) defines
//   fn KIND_eval(m: Material, frame: Frame, wo: vec3<f32>, wi: vec3<f32>) -> vec3<f32>
//       f(wo, wi) |cos(n, wi)|: the BSDF already multiplied by the cosine;
//   fn KIND_pdf(m: Material, frame: Frame, wo: vec3<f32>, wi: vec3<f32>) -> f32
//       the solid-angle density with which KIND_sample draws wi;
//   fn KIND_sample(m: Material, frame: Frame, wo: vec3<f32>) -> BsdfSample.
// A kind with a smooth and a delta lobe (`Lobe::SmoothAndDelta`: a specular coat
// over a diffuse base) defines the same three: eval and pdf cover the smooth
// lobe only (pdf integrates to the probability of sampling it), and a sample
// drawn from the delta lobe sets `delta`, with `pdf` the probability of that lobe.
// A kind whose lobes are all delta (`Lobe::Delta`: specular, or with no density
// to evaluate) defines only KIND_sample and sets `delta`: its eval and pdf are
// zero for any direction a strategy could choose, so no strategy mixes it.
//
// KIND_sample draws its random numbers from the path's sampler (`sample_1d`,
// `sample_2d`) in a fixed order; a strategy draws its own before it, so the
// mixture's light and BSDF branches use the same dimensions for their 2D point.

// Mirrors `abi::PackedMaterial`; what each field holds per kind is said in
// the kind's file (`src/kinds/material/`).
struct Material {
    albedo: vec3<f32>,
    // Index into `kinds::MATERIAL_KINDS` (the generated `MATERIAL_*` constants).
    kind: u32,
    // Radiance leaving the side the normal faces.
    emit: vec3<f32>,
    param: f32,
    color2: vec3<f32>,
    param2: f32,
    color3: vec3<f32>,
    // Bits named by the generated `MATERIAL_BECKMANN`, `MATERIAL_NONLINEAR`.
    flags: u32,
}

#if LIGHT_SELECTION_SPATIAL
// The luminance (Rec. 709) of material `index`'s emitted radiance, which the
// spatial light pick weighs a light by.
fn material_emitted_luminance(index: u32) -> f32 {
    return dot(materials_at(index).emit, LUMINANCE);
}
#endif

// Where a BSDF is evaluated: `n` is the normal the BSDF uses (the shading
// normal: interpolated on smooth meshes, else the geometric one) and `ng` the
// geometric normal, both turned to the side of `wo` (`n` to the side of the
// shading normal's plane under SIDES_BY_SHADING_NORMAL); `front_face` says
// whether `n`'s is the outward side (`material_side`).
struct Frame {
    n: vec3<f32>,
    front_face: bool,
    ng: vec3<f32>,
#if BUMP_MAPS
    // The shading normal before a bump or normal map perturbed it (turned as
    // `n`), and `bump_shadowing`'s alpha^2 from the angle between the two.
    unperturbed: vec3<f32>,
    bump_alpha2: f32,
#endif
}

struct BsdfSample {
    wi: vec3<f32>,
    // f |cos| / pdf: what the path throughput is multiplied by.
    weight: vec3<f32>,
    // Solid-angle density of wi (delta lobes: the probability of the lobe chosen).
    // 0: no direction (absorbed), and wi is zero.
    pdf: f32,
    delta: bool,
}

#if TEXTURED_NUMBERS
// The numbers of the material being shaded that textures give at its hit, by
// slot (its kind's `MaterialModel::textured_numbers`), and the bits of the
// slots they fill: set once per hit by `texture_numbers` (textures.wgsl),
// before the BSDF is sampled or evaluated there, so that its sample, eval and
// pdf all see the same values.
var<private> textured_numbers: array<f32, MATERIAL_NUMBER_SLOTS>;
var<private> textured_slots: u32;
#endif

// The shaded material's number `slot` (a generated `NUMBER_KIND_KEY`): its
// texture's value at the hit where it has one, else `packed`, the value its
// kind packs.
fn material_number(slot: u32, packed: f32) -> f32 {
#if TEXTURED_NUMBERS
    if (textured_slots & (1u << slot)) != 0u {
        return textured_numbers[slot];
    }
#endif
    return packed;
}

fn bsdf_absorbed() -> BsdfSample {
    return BsdfSample(vec3<f32>(0.0), vec3<f32>(0.0), 0.0, false);
}

// The side of the surface `hit` that a ray along `dir` meets, as its material
// sees it (true: the side its normals face): the geometric normal's
// (`front_face`), or under SIDES_BY_SHADING_NORMAL the shading normal's, as
// Mitsuba's BSDFs tell a smooth surface's sides. Emission keeps the geometric
// side, which shadow rays test too.
fn material_side(hit: Hit, dir: vec3<f32>, front_face: bool) -> bool {
#if SIDES_BY_SHADING_NORMAL
    return dot(dir, hit.shading_normal) < 0.0;
#else
    return front_face;
#endif
}

// The frame a BSDF at `hit` is evaluated in: `shading_normal` (bumped, where a
// bump map applies) turned to the material's `side` (`material_side`), the
// geometric normal to the surface's `front_face`.
fn hit_frame(hit: Hit, shading_normal: vec3<f32>, front_face: bool, side: bool, material_front_face: bool) -> Frame {
    return Frame(
        select(-shading_normal, shading_normal, side),
        material_front_face,
        select(-hit.normal, hit.normal, front_face),
#if BUMP_MAPS
        select(-hit.shading_normal, hit.shading_normal, side),
        bump_alpha2(shading_normal, hit.shading_normal),
#endif
    );
}

#if SHADING_NORMALS
// With a shading normal, a direction can be on one side of `n` and the other of
// the true surface: reflected light would leak through it (or transmitted light
// stay above it). Such a direction carries nothing, as in pbrt-v3's BSDF::f
// (reflection only where wo and wi are on one side of the geometric normal).
// The density is left as it is: it stays the density the sampling draws with.
fn bsdf_leaks(frame: Frame, wi: vec3<f32>) -> bool {
#if SIDES_BY_SHADING_NORMAL
    // Mitsuba's BSDFs make no such check.
    return false;
#else
    return (dot(wi, frame.n) > 0.0) != (dot(wi, frame.ng) > 0.0);
#endif
}

fn bsdf_sample_checked(frame: Frame, s: BsdfSample) -> BsdfSample {
    if bsdf_leaks(frame, s.wi) {
        return bsdf_absorbed();
    }
#if BUMP_MAPS
    var shadowed = s;
    shadowed.weight *= bump_shadowing(frame, s.wi);
    return shadowed;
#else
    return s;
#endif
}
#endif

#if BUMP_MAPS
// Estevez et al.'s alpha^2 for a normal perturbed from `unperturbed` to `n`
// (both unit): the tilt's tan^2 / 8, at most 1 (Mitsuba's
// `eval_shadow_terminator`); exactly 0 for a normal left as it was (where
// the rounded dot(n, n) would make it a few ulps).
fn bump_alpha2(n: vec3<f32>, unperturbed: vec3<f32>) -> f32 {
    if all(n == unperturbed) {
        return 0.0;
    }
    let c2 = dot(n, unperturbed) * dot(n, unperturbed);
    return min(0.125 * max(1.0 - c2, 0.0) / c2, 1.0);
}

// The shadowing a bump or normal map casts on itself toward `wi` (Estevez et
// al. 2019, "A Microfacet-Based Shadowing Function to Solve the Bump
// Terminator Problem", as Mitsuba's `bumpmap` and `normalmap` apply it by
// default): a microfacet G1 whose roughness is the tilt, against the angle of
// `wi` to the unperturbed normal. Without the term, a tilted normal lights the
// surface's terminator where its true geometry would be in shadow. Exactly 1
// where nothing is tilted.
fn bump_shadowing(frame: Frame, wi: vec3<f32>) -> f32 {
    if frame.bump_alpha2 == 0.0 {
        return 1.0;
    }
    let c2 = dot(wi, frame.unperturbed) * dot(wi, frame.unperturbed);
    let tan2 = max(1.0 - c2, 0.0) / c2;
    return 2.0 / (1.0 + sqrt(1.0 + frame.bump_alpha2 * tan2));
}
#endif

#if NESTED_MATERIALS
// The material a hit scatters by, and the side it sees as its front.
struct Resolved {
    material: Material,
    front_face: bool,
    // Its index in `materials`.
    index: u32,
}

// A hit on material `found`, on the side `front_face` says: the material it
// scatters by, through the materials made of others (`kinds::packed_nested`,
// their indices in `color2`) in at most MATERIAL_NESTING steps (the scene's
// materials nest no deeper): `twosided` takes its front or back material, the
// back one seeing the flipped frame as its front; `blend` takes its second
// material with probability `weight`, its first otherwise (pbrt-v4's
// MixMaterial: in expectation the blended BSDF). The result has its kind's id
// alone (no transparency) and `found`'s emission: a surface's emission and
// opacity are the outer material's.
fn resolve_material(found: Material, front_face: bool, hit: Hit) -> Resolved {
    var m = found;
    var front = front_face;
    var index = hit.material;
#if BLEND
    // The blends' random number in [0, 1), once drawn.
    var u = -1.0;
#endif
    for (var step = 0u; step < MATERIAL_NESTING; step++) {
        let kind = m.kind & MATERIAL_TRANSPARENCY_MAX;
#if TWOSIDED
        if kind == MATERIAL_TWOSIDED {
            index = u32(select(m.color2.y, m.color2.x, front));
            m = materials_at(index);
            front = true;
            continue;
        }
#endif
#if BLEND
        if kind == MATERIAL_BLEND {
            // `second` with probability `weight` (its texture's value as a
            // number at the hit, else the constant): one random number per
            // hit, drawn at the first blend, its rest reused by blends nested
            // below.
            var weight = m.param;
#if TEXTURES
            let texture = (m.flags >> MATERIAL_TEXTURE_SHIFT) & ((1u << MATERIAL_TEXTURE_BITS) - 1u);
            if texture != 0u {
                weight = clamp(texture_eval_number(texture - 1u, hit.uv), 0.0, 1.0);
            }
#endif
            if u < 0.0 {
                u = sample_1d();
            }
            if u < weight {
                u = u / weight;
                index = u32(m.color2.y);
            } else {
                u = (u - weight) / (1.0 - weight);
                index = u32(m.color2.x);
            }
            m = materials_at(index);
            continue;
        }
#endif
        break;
    }
    m.kind = m.kind & MATERIAL_TRANSPARENCY_MAX;
    m.emit = found.emit;
    return Resolved(m, front, index);
}
#endif

#if MASK
// The material with its kind's id alone, as the BSDF dispatch compares it.
fn material_unmasked(m: Material) -> Material {
    var out = m;
    out.kind = m.kind & MATERIAL_TRANSPARENCY_MAX;
    return out;
}
#endif

// The material a hit on `found` scatters by, and the side it sees as its front:
// resolved through nested materials, its textures looked up at the hit (what
// the path kernel and the AOV pass both shade with). A blend draws its random
// number here, so a caller's own draws come after.
struct HitMaterial {
    material: Material,
    front_face: bool,
}

fn hit_material(found: Material, front_face: bool, hit: Hit) -> HitMaterial {
#if NESTED_MATERIALS
    let resolved = resolve_material(found, front_face, hit);
    var material = resolved.material;
    let index = resolved.index;
    let material_front_face = resolved.front_face;
#else
#if MASK
    var material = material_unmasked(found);
#else
    var material = found;
#endif
    let index = hit.material;
    let material_front_face = front_face;
#endif
#if TEXTURES
    material = textured(material, hit.uv);
#endif
#if TEXTURED_NUMBERS
    // The textured numbers the BSDF reads (`material_number`).
    texture_numbers(material, index, hit.uv);
#endif
    return HitMaterial(material, material_front_face);
}
