// The environment map (`environment::EnvironmentTables`, conventions in
// src/scene/envmap.rs): the radiance an escaping ray finds, and, as one object
// of the light density, sampling a direction and its density. The density is
// constant over each texel's cell (the directions nearest its centre), in
// proportion to the mean over the cell of the bilinear radiance, which makes it
// positive wherever the radiance is: nee-mis and mixture stay unbiased, and the
// density's mismatch with the radiance inside a cell costs only variance. The
// cell is chosen hierarchically, so that stratified samples stay stratified.

// Mirrors `environment::EnvironmentInfo`.
struct EnvironmentInfo {
    to_local_x: vec3<f32>,
    width: u32,
    to_local_y: vec3<f32>,
    height: u32,
    to_local_z: vec3<f32>,
    levels: u32,
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

// Nodes along an axis of `n` cells on level `level` of the pyramid
// (`environment::pyramid_size`).
fn environment_pyramid_size(n: u32, level: u32) -> u32 {
    return ((n - 1u) >> level) + 1u;
}

// The largest f32 below 1: a rescaled number stays in [0, 1).
const ENVIRONMENT_U_MAX: f32 = 0.99999994;

// Of two children of masses `a` and `b`, the second where `u` (in [0, 1)) falls
// past the first's share, never one of no mass; and `u` rescaled within it.
struct EnvironmentChoice {
    second: bool,
    u: f32,
}

fn environment_choose(u: f32, a: f32, b: f32) -> EnvironmentChoice {
    let scaled = u * (a + b);
    let second = (scaled >= a && b > 0.0) || a <= 0.0;
    let rescaled = select(scaled / a, (scaled - a) / b, second);
    return EnvironmentChoice(second, clamp(rescaled, 0.0, ENVIRONMENT_U_MAX));
}

// A direction drawn from the map's density: a cell by descending the pyramid of
// the cells' probabilities (`environment::EnvironmentTables::pyramid`), a row
// then a column of each node's 2 x 2 children, then uniformly in (cos theta,
// phi) within the cell (what is left of the numbers after the choices).
fn environment_sample(u_in: vec2<f32>) -> vec3<f32> {
    let info = environment_info_at(0u);
    var u = u_in;
    var cell = vec2<u32>(0u);
    var level_start = 0u;
    for (var level = info.levels; level > 0u; level--) {
        let width = environment_pyramid_size(info.width, level);
        let m = environment_pyramid_at(level_start + cell.y * width + cell.x);
        level_start += width * environment_pyramid_size(info.height, level);
        let row = environment_choose(u.y, m.x + m.y, m.z + m.w);
        let column = environment_choose(u.x, select(m.x, m.z, row.second), select(m.y, m.w, row.second));
        u = vec2<f32>(column.u, row.u);
        cell = 2u * cell + vec2<u32>(select(0u, 1u, column.second), select(0u, 1u, row.second));
    }
    let v_top = environment_row_edge(cell.y, info.height);
    let cos_theta = cos(PI * v_top) - u.y * environment_cos_difference(v_top, environment_row_edge(cell.y + 1u, info.height));
    let sin_theta = sqrt(max(0.0, (1.0 - cos_theta) * (1.0 + cos_theta)));
    let phi = 2.0 * PI * (f32(cell.x) + u.x) / f32(info.width);
    let local = vec3<f32>(sin(phi) * sin_theta, cos_theta, -cos(phi) * sin_theta);
    // Map space to world: the transpose of the rows kept.
    return local.x * info.to_local_x + local.y * info.to_local_y + local.z * info.to_local_z;
}

// The solid-angle density of `environment_sample` at `dir`: the cell's
// probability over its solid angle.
fn environment_pdf(dir: vec3<f32>) -> f32 {
    let info = environment_info_at(0u);
    let texel = environment_texel(dir);
    let probability = environment_texels_at(texel.y * info.width + texel.x).w;
    let solid_angle = 2.0 * PI / f32(info.width) * environment_cos_difference(environment_row_edge(texel.y, info.height), environment_row_edge(texel.y + 1u, info.height));
    return probability / solid_angle;
}
#endif
