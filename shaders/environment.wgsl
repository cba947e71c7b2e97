// The environment map (`environment::EnvironmentTables`, conventions in
// src/scene/envmap.rs): the radiance an escaping ray finds, and, as one object
// of the light density, sampling a direction and its density. The density is
// constant over each texel's cell (the directions nearest its centre), in
// proportion to the mean over the cell of the bilinear radiance, which makes it
// positive wherever the radiance is: nee-mis and mixture stay unbiased, and the
// density's mismatch with the radiance inside a cell costs only variance.

// Mirrors `environment::EnvironmentInfo`.
struct EnvironmentInfo {
    to_local_x: vec3<f32>,
    width: u32,
    to_local_y: vec3<f32>,
    height: u32,
    to_local_z: vec3<f32>,
    _pad: u32,
}

// The world direction `dir` in map space.
fn environment_local(info: EnvironmentInfo, dir: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(dot(info.to_local_x, dir), dot(info.to_local_y, dir), dot(info.to_local_z, dir));
}

// Mitsuba's lookup: bilinear between texel centres (column x on u = (x + 1/2) / W,
// row y on v = y / (H - 1)), the columns periodic.
fn environment_radiance(dir: vec3<f32>) -> vec3<f32> {
    let info = environment_info_at(0u);
    let d = environment_local(info, dir);
    var u = atan2(d.x, -d.z) * (0.5 * INV_PI) - 0.5 / f32(info.width);
    u -= floor(u);
    // Not acos(d.y): lavapipe's is off by 1e-4, which shifts the lookup.
    let v = atan2(length(d.xz), d.y) * INV_PI;
    let p = vec2<f32>(u * f32(info.width), v * f32(info.height - 1u));
    let x0 = min(u32(p.x), info.width - 1u);
    let y0 = min(u32(p.y), max(info.height, 2u) - 2u);
    let t = p - vec2<f32>(f32(x0), f32(y0));
    let x1 = select(x0 + 1u, 0u, x0 + 1u == info.width);
    let y1 = min(y0 + 1u, info.height - 1u);
    let top = mix(environment_texels_at(y0 * info.width + x0).xyz, environment_texels_at(y0 * info.width + x1).xyz, t.x);
    let bottom = mix(environment_texels_at(y1 * info.width + x0).xyz, environment_texels_at(y1 * info.width + x1).xyz, t.x);
    return mix(top, bottom, t.y);
}

#if LIGHT_ENVIRONMENT
// The v of row y's upper edge (src/scene/envmap.rs `row_edge`).
fn environment_row_edge(y: u32, height: u32) -> f32 {
    if y == 0u {
        return 0.0;
    }
    if y >= height {
        return 1.0;
    }
    return (f32(y) - 0.5) / f32(height - 1u);
}

// The cell of the sampling density a world direction falls in: its nearest
// texel centre's.
fn environment_texel(dir: vec3<f32>) -> vec2<u32> {
    let info = environment_info_at(0u);
    let d = environment_local(info, dir);
    let u = atan2(d.x, -d.z) * (0.5 * INV_PI);
    let x = min(u32((u - floor(u)) * f32(info.width)), info.width - 1u);
    let cos_theta = d.y / length(d);
    let v = acos(clamp(cos_theta, -1.0, 1.0)) * INV_PI;
    var y = min(u32(v * f32(info.height - 1u) + 0.5), info.height - 1u);
    // acos may be off by 1e-4 (lavapipe): the row is settled against the cosines
    // of its edges, computed as the sampler computes them.
    if y > 0u && cos_theta > cos(PI * environment_row_edge(y, info.height)) {
        y -= 1u;
    } else if y + 1u < info.height && cos_theta <= cos(PI * environment_row_edge(y + 1u, info.height)) {
        y += 1u;
    }
    return vec2<u32>(x, y);
}

// cos(pi a) - cos(pi b), without cancellation at the poles (`environment::cos_difference`).
fn environment_cos_difference(a: f32, b: f32) -> f32 {
    return 2.0 * sin(0.5 * PI * (a + b)) * sin(0.5 * PI * (b - a));
}

// Entry x of row `base`'s conditional CDF: the texel's w, 1 past the row's end.
fn environment_column_cdf(base: u32, x: u32, width: u32) -> f32 {
    if x >= width {
        return 1.0;
    }
    return environment_texels_at(base + x).w;
}

// A direction drawn from the map's density: a row by the marginal CDF, a texel
// by the row's, then uniformly in (cos theta, phi) within the texel's cell
// (what is left of each number after its choice places the point).
fn environment_sample(u: vec2<f32>) -> vec3<f32> {
    let info = environment_info_at(0u);
    // The last entry <= u of each CDF (0 first, 1 last): bisection keeps
    // cdf[lo] <= u < cdf[hi], so cells of no mass are never chosen.
    var lo = 0u;
    var hi = info.height;
    while hi - lo > 1u {
        let mid = (lo + hi) / 2u;
        if environment_rows_at(mid) <= u.y {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let y = lo;
    let row_lo = environment_rows_at(y);
    let t_row = clamp((u.y - row_lo) / (environment_rows_at(y + 1u) - row_lo), 0.0, 1.0);
    let base = y * info.width;
    lo = 0u;
    hi = info.width;
    while hi - lo > 1u {
        let mid = (lo + hi) / 2u;
        if environment_column_cdf(base, mid, info.width) <= u.x {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let x = lo;
    let column_lo = environment_column_cdf(base, x, info.width);
    let t_column = clamp((u.x - column_lo) / (environment_column_cdf(base, x + 1u, info.width) - column_lo), 0.0, 1.0);
    let v_top = environment_row_edge(y, info.height);
    let cos_theta = cos(PI * v_top) - t_row * environment_cos_difference(v_top, environment_row_edge(y + 1u, info.height));
    let sin_theta = sqrt(max(0.0, (1.0 - cos_theta) * (1.0 + cos_theta)));
    let phi = 2.0 * PI * (f32(x) + t_column) / f32(info.width);
    let local = vec3<f32>(sin(phi) * sin_theta, cos_theta, -cos(phi) * sin_theta);
    // Map space to world: the transpose of the rows kept.
    return local.x * info.to_local_x + local.y * info.to_local_y + local.z * info.to_local_z;
}

// The solid-angle density of `environment_sample` at `dir`: the cell's
// probability over its solid angle.
fn environment_pdf(dir: vec3<f32>) -> f32 {
    let info = environment_info_at(0u);
    let texel = environment_texel(dir);
    let base = texel.y * info.width;
    let row = environment_rows_at(texel.y + 1u) - environment_rows_at(texel.y);
    let column = environment_column_cdf(base, texel.x + 1u, info.width) - environment_column_cdf(base, texel.x, info.width);
    let solid_angle = 2.0 * PI / f32(info.width) * environment_cos_difference(environment_row_edge(texel.y, info.height), environment_row_edge(texel.y + 1u, info.height));
    return row * column / solid_angle;
}
#endif
