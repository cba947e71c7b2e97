// Textures on material colours (`kinds::texture`: one file per kind, which packs it),
// with Mitsuba 3's semantics: a checkerboard, or a bitmap looked up bilinearly
// (or at the nearest texel) with its integer texel coordinates wrapped.

// Mirrors `kinds::TextureInfo`.
struct TextureInfo {
    to_uv_u: vec3<f32>,
    kind: u32,
    to_uv_v: vec3<f32>,
    wrap: u32,
    color0: vec3<f32>,
    width: u32,
    color1: vec3<f32>,
    height: u32,
    offset: u32,
    nearest: u32,
    bump_scale: f32,
    texel_format: u32,
}

// Texel indices `i` and `i + 1` of a row or column `n` long, each wrapped into
// [0, n). One integer division for both: lavapipe divides lane by lane.
fn texture_wrap_pair(i: i32, n: i32, wrap: u32) -> vec2<i32> {
    // Repeat and mirror are periodic, a mirror's period two images long.
    let mirror = wrap == TEXTURE_WRAP_MIRROR;
    let period = select(n, 2 * n, mirror);
    let r = i % period;
    let first = select(r, r + period, r < 0);
    let periodic = vec2<i32>(first, select(first + 1, 0, first + 1 == period));
    let folded = select(periodic, vec2<i32>(period - 1) - periodic, vec2<bool>(mirror) & (periodic >= vec2<i32>(n)));
    let clamped = clamp(vec2<i32>(i, i + 1), vec2<i32>(0), vec2<i32>(n - 1));
    return select(folded, clamped, wrap == TEXTURE_WRAP_CLAMP);
}

#if BYTE_TEXELS
// What each 8-bit code stands for (`kinds::texel_byte_values`: sRGB-decoded,
// then raw), in private memory, which lavapipe reads at a computed index in
// about 1.4 cycles a lane; a constant array so read was 75 times slower.
var<private> texel_byte_values: array<f32, 512> = TEXEL_BYTE_VALUES;
#endif

// The texel at column `x` and row `y`, both within the image: three floats,
// or a word of 8-bit codes (`kinds::TexelFormat`).
fn texture_texel(t: TextureInfo, x: i32, y: i32) -> vec3<f32> {
    let texel = u32(y) * t.width + u32(x);
#if FLOAT_TEXELS
    let i = t.offset + 3u * texel;
    let floats = bitcast<vec3<f32>>(vec3<u32>(texture_texels_at(i), texture_texels_at(i + 1u), texture_texels_at(i + 2u)));
#if !BYTE_TEXELS
    return floats;
#endif
#endif
#if BYTE_TEXELS
    let codes = (vec3<u32>(texture_texels_at(t.offset + texel)) >> vec3<u32>(0u, 8u, 16u)) & vec3<u32>(0xffu);
    let table = select(0u, 256u, t.texel_format == TEXELS_RAW8) + codes;
    let bytes = vec3<f32>(texel_byte_values[table.x], texel_byte_values[table.y], texel_byte_values[table.z]);
#if FLOAT_TEXELS
    return select(bytes, floats, t.texel_format == TEXELS_FLOAT);
#else
    return bytes;
#endif
#endif
#if !FLOAT_TEXELS
#if !BYTE_TEXELS
    // Checkerboards alone: no bitmap to read.
    return vec3<f32>(0.0);
#endif
#endif
}

// The four texels about texel coordinates `c0` (integers: the lower corner),
// wrapped: columns x0 and x0 + 1 of rows y0 and y0 + 1, as a bilinear lookup
// and its gradient read them.
struct TexelQuad {
    t00: vec3<f32>,
    t10: vec3<f32>,
    t01: vec3<f32>,
    t11: vec3<f32>,
}

fn texture_quad(t: TextureInfo, c0: vec2<f32>) -> TexelQuad {
    let xs = texture_wrap_pair(i32(c0.x), i32(t.width), t.wrap);
    let ys = texture_wrap_pair(i32(c0.y), i32(t.height), t.wrap);
    return TexelQuad(
        texture_texel(t, xs.x, ys.x),
        texture_texel(t, xs.y, ys.x),
        texture_texel(t, xs.x, ys.y),
        texture_texel(t, xs.y, ys.y),
    );
}

fn texture_eval(index: u32, surface_uv: vec2<f32>) -> vec3<f32> {
#if PROFILE
    profile(STAGE_TEXTURES);
#endif
    let t = textures_at(index);
    let uv = vec2<f32>(dot(t.to_uv_u, vec3<f32>(surface_uv, 1.0)), dot(t.to_uv_v, vec3<f32>(surface_uv, 1.0)));
    if t.kind == TEXTURE_CHECKERBOARD {
        let upper = (uv - floor(uv)) > vec2<f32>(0.5);
        return select(t.color1, t.color0, upper.x == upper.y);
    }
    // Far outside the image every wrap mode repeats a texel already in range;
    // clamping keeps the integer conversion defined.
    let size = vec2<f32>(f32(t.width), f32(t.height));
    let p = clamp(uv * size, vec2<f32>(-1.0e9), vec2<f32>(1.0e9));
    // The nearest texel is the first of the four a bilinear lookup about p
    // itself reads: one path for both, which lavapipe would run both of.
    let nearest = t.nearest != 0u;
    let c = select(p - 0.5, p, nearest);
    let c0 = floor(c);
    let f = c - c0;
    let q = texture_quad(t, c0);
    let top = (1.0 - f.x) * q.t00 + f.x * q.t10;
    let bottom = (1.0 - f.x) * q.t01 + f.x * q.t11;
    return select((1.0 - f.y) * top + f.y * bottom, q.t00, nearest);
}

// Texture `index` at `surface_uv` as one number (a material's textured number,
// a mask's opacity, a blend's weight), as Mitsuba's `eval_1` reads a float
// texture (`kinds::Texture::eval_number`): a bitmap's luminance; a
// checkerboard's colours swapped against `texture_eval` (checkerboard.cpp's
// eval_1 takes color1 where its eval takes color0), each its channels' mean.
fn texture_eval_number(index: u32, surface_uv: vec2<f32>) -> f32 {
    let t = textures_at(index);
    if t.kind == TEXTURE_CHECKERBOARD {
        let uv = vec2<f32>(dot(t.to_uv_u, vec3<f32>(surface_uv, 1.0)), dot(t.to_uv_v, vec3<f32>(surface_uv, 1.0)));
        let upper = (uv - floor(uv)) > vec2<f32>(0.5);
        let c = select(t.color0, t.color1, upper.x == upper.y);
        return (c.x + c.y + c.z) / 3.0;
    }
    return dot(texture_eval(index, surface_uv), LUMINANCE);
}

#if TEXTURED_NUMBERS
// Looks up the textured numbers of material `m` (index `index` in
// `materials`) at `uv` for `material_number` (materials.wgsl): its list in
// `material_tables` (`kinds::MaterialTables::with_number_directory`: at the
// material's index its offset, there the count, then each slot and texture).
fn texture_numbers(m: Material, index: u32, uv: vec2<f32>) {
    textured_slots = 0u;
    if (m.flags & MATERIAL_TEXTURED_NUMBERS) == 0u {
        return;
    }
    let first = u32(material_tables_at(index));
    let count = u32(material_tables_at(first));
    for (var k = 0u; k < count; k++) {
        let slot = u32(material_tables_at(first + 1u + 2u * k));
        textured_numbers[slot] = texture_eval_number(u32(material_tables_at(first + 2u + 2u * k)), uv);
        textured_slots |= 1u << slot;
    }
}
#endif

// The material with its texture (index + 1 in the flags' high bits, 0: none)
// looked up at `uv` in place of the colour packed as `albedo`.
fn textured(m: Material, uv: vec2<f32>) -> Material {
    let index = (m.flags >> MATERIAL_TEXTURE_SHIFT) & ((1u << MATERIAL_TEXTURE_BITS) - 1u);
    if index == 0u {
        return m;
    }
    var out = m;
    out.albedo = texture_eval(index - 1u, uv);
    return out;
}

#if BUMP_MAPS
// The luminance of a linear RGB colour (Mitsuba's `luminance`): the height a
// bump map's texel stands for.
fn texture_luminance(c: vec3<f32>) -> f32 {
    return dot(c, LUMINANCE);
}

// The gradient of bitmap `t`'s luminance along the surface's (u, v): analytic
// on the bilinear patch between the four texels `texture_eval` reads
// (Mitsuba's `eval_1_grad`), through `to_uv`; zero for the nearest texel,
// whose lookup is flat almost everywhere.
fn texture_gradient(t: TextureInfo, surface_uv: vec2<f32>) -> vec2<f32> {
    if t.nearest != 0u {
        return vec2<f32>(0.0);
    }
    let uv = vec2<f32>(dot(t.to_uv_u, vec3<f32>(surface_uv, 1.0)), dot(t.to_uv_v, vec3<f32>(surface_uv, 1.0)));
    let size = vec2<f32>(f32(t.width), f32(t.height));
    let c = clamp(uv * size, vec2<f32>(-1.0e9), vec2<f32>(1.0e9)) - 0.5;
    let c0 = floor(c);
    let f = c - c0;
    let q = texture_quad(t, c0);
    let f00 = texture_luminance(q.t00);
    let f10 = texture_luminance(q.t10);
    let f01 = texture_luminance(q.t01);
    let f11 = texture_luminance(q.t11);
    // Along the texture's own u' and v' ...
    let d = size * vec2<f32>(mix(f10 - f00, f11 - f01, f.y), mix(f01 - f00, f11 - f10, f.x));
    // ... and so along the surface's: d/du = d/du' du'/du + d/dv' dv'/du.
    return vec2<f32>(t.to_uv_u.x * d.x + t.to_uv_v.x * d.y, t.to_uv_u.y * d.x + t.to_uv_v.y * d.y);
}

// The shading normal of material `m` at `hit`, perturbed by its bump or normal
// map (`kinds::Bump`) as Mitsuba's `bumpmap` and `normalmap` perturb theirs;
// `hit.shading_normal` for a material without. `wo` points back along the ray.
fn bumped_normal(m: Material, hit: Hit, wo: vec3<f32>) -> vec3<f32> {
    let n = hit.shading_normal;
    let index = m.flags >> MATERIAL_BUMP_SHIFT;
    if index == 0u {
        return n;
    }
    let t = textures_at(index - 1u);
    var perturbed: vec3<f32>;
    if (m.flags & MATERIAL_NORMAL_MAP) != 0u {
        // The texel is the normal in the frame (s, n x s, n), s along dp_du.
        let along = hit.tangents.dp_du - n * dot(n, hit.tangents.dp_du);
        let length2 = dot(along, along);
        var s = tangents_about(n).dp_du;
        if length2 > 1e-30 && length2 < F32_MAX {
            s = along * inverseSqrt(length2);
        }
        let c = 2.0 * texture_eval(index - 1u, hit.uv) - 1.0;
        perturbed = c.x * s + c.y * cross(n, s) + c.z * n;
    } else {
        // The surface moved along n by the height: its tangents gain the
        // height's slope along n (and lose any part of them along n).
        let g = t.bump_scale * texture_gradient(t, hit.uv);
        // A flat height leaves n as it is: what the formula gives, without
        // its rounding.
        if all(g == vec2<f32>(0.0)) {
            return n;
        }
        let dp_du = hit.tangents.dp_du + n * (g.x - dot(n, hit.tangents.dp_du));
        let dp_dv = hit.tangents.dp_dv + n * (g.y - dot(n, hit.tangents.dp_dv));
        let c = cross(dp_du, dp_dv);
        perturbed = select(c, -c, dot(c, hit.normal) < 0.0);
    }
    // Normalised by its largest component first, so that tiny and huge tangents
    // neither underflow nor overflow; NaN and zero keep the unperturbed normal.
    let largest = max(max(abs(perturbed.x), abs(perturbed.y)), abs(perturbed.z));
    if !(largest > 0.0 && largest < F32_MAX) {
        return n;
    }
    let b = normalize(perturbed / largest);
    // Mitsuba's `flip_invalid_normals`: a normal that turns away from the side
    // `wo` is on is mirrored about n, so the viewer never sees the back of it.
    if dot(wo, n) * dot(wo, b) <= 0.0 {
        return 2.0 * dot(b, n) * n - b;
    }
    return b;
}
#endif
