// Textures on material colours (`scene::texture`, packed by `kinds::texture`),
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
    _pad0: u32,
    _pad1: u32,
}

// Texel index `i` of a row or column `n` long, wrapped into [0, n).
fn texture_wrap(i: i32, n: i32, wrap: u32) -> i32 {
    switch wrap {
        case TEXTURE_WRAP_CLAMP: {
            return clamp(i, 0, n - 1);
        }
        case TEXTURE_WRAP_MIRROR: {
            let p = ((i % (2 * n)) + 2 * n) % (2 * n);
            return select(p, 2 * n - 1 - p, p >= n);
        }
        default: {
            return ((i % n) + n) % n;
        }
    }
}

fn texture_texel(t: TextureInfo, x: i32, y: i32) -> vec3<f32> {
    let tx = u32(texture_wrap(x, i32(t.width), t.wrap));
    let ty = u32(texture_wrap(y, i32(t.height), t.wrap));
    let i = t.offset + 3u * (ty * t.width + tx);
    return vec3<f32>(texture_texels_at(i), texture_texels_at(i + 1u), texture_texels_at(i + 2u));
}

fn texture_eval(index: u32, surface_uv: vec2<f32>) -> vec3<f32> {
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
    if t.nearest != 0u {
        let q = vec2<i32>(floor(p));
        return texture_texel(t, q.x, q.y);
    }
    let c = p - 0.5;
    let c0 = floor(c);
    let f = c - c0;
    let q = vec2<i32>(c0);
    let top = (1.0 - f.x) * texture_texel(t, q.x, q.y) + f.x * texture_texel(t, q.x + 1, q.y);
    let bottom = (1.0 - f.x) * texture_texel(t, q.x, q.y + 1) + f.x * texture_texel(t, q.x + 1, q.y + 1);
    return (1.0 - f.y) * top + f.y * bottom;
}

// The material with its texture (index + 1 in the flags' high bits, 0: none)
// looked up at `uv` in place of the colour packed as `albedo`.
fn textured(m: Material, uv: vec2<f32>) -> Material {
    let index = m.flags >> MATERIAL_TEXTURE_SHIFT;
    if index == 0u {
        return m;
    }
    var out = m;
    out.albedo = texture_eval(index - 1u, uv);
    return out;
}
