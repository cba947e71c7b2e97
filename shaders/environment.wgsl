// The environment map (`environment::EnvironmentTables`, conventions in
// src/scene/envmap.rs): the radiance an escaping ray finds, and, as one object
// of the light density, sampling a direction and its density. The density is
// the texels' luminance interpolated bilinearly in (phi, cos theta) between
// their centres, over its integral: positive exactly where the radiance is (so
// nee-mis and mixture stay unbiased) and continuous. The cell between four
// centres is chosen hierarchically, so that stratified samples stay
// stratified.

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

// The columns of texel centres around the direction `d` (map space), and how
// far from the left one toward the right one it lies.
struct EnvironmentColumns {
    left: u32,
    right: u32,
    t: f32,
}

fn environment_columns(width: u32, d: vec3<f32>) -> EnvironmentColumns {
    var u = atan2(d.x, -d.z) * (0.5 * INV_PI) - 0.5 / f32(width);
    u -= floor(u);
    let left = min(u32(u * f32(width)), width - 1u);
    let right = select(left + 1u, 0u, left + 1u == width);
    return EnvironmentColumns(left, right, u * f32(width) - f32(left));
}

// Mitsuba's lookup: bilinear between texel centres (column x on u = (x + 1/2) / W,
// row y on v = y / (H - 1)), the columns periodic.
fn environment_radiance(dir: vec3<f32>) -> vec3<f32> {
    let info = environment_info_at(0u);
    let d = environment_local(info, dir);
    let columns = environment_columns(info.width, d);
    // Not acos(d.y): lavapipe's is off by 1e-4, which shifts the lookup.
    let v = atan2(length(d.xz), d.y) * INV_PI * f32(info.height - 1u);
    let y0 = min(u32(v), max(info.height, 2u) - 2u);
    let y1 = min(y0 + 1u, info.height - 1u);
    let top = mix(environment_texels_at(y0 * info.width + columns.left).xyz, environment_texels_at(y0 * info.width + columns.right).xyz, columns.t);
    let bottom = mix(environment_texels_at(y1 * info.width + columns.left).xyz, environment_texels_at(y1 * info.width + columns.right).xyz, columns.t);
    return mix(top, bottom, v - f32(y0));
}

#if LIGHT_ENVIRONMENT
// Rows of cells between the texel rows (`environment::cell_rows`).
fn environment_cell_rows(height: u32) -> u32 {
    return max(height, 2u) - 1u;
}

// 1 - cos theta and 1 + cos theta at the texel row `y` of `rows` + 1, each
// without cancellation where it is small.
fn environment_row_versines(y: u32, rows: u32) -> vec2<f32> {
    let half_theta = 0.5 * PI * f32(y) / f32(rows);
    let s = sin(half_theta);
    let c = cos(half_theta);
    return 2.0 * vec2<f32>(s * s, c * c);
}

// Where within the cells of row `y` (0 at its upper edge, 1 at its lower one)
// a direction lies, from its 1 - cos theta and 1 + cos theta. Northern rows
// measure from the north pole and southern rows from the south pole, so that
// rows near either pole keep their precision.
fn environment_row_fraction(y: u32, rows: u32, versines: vec2<f32>) -> f32 {
    let upper = environment_row_versines(y, rows);
    let lower = environment_row_versines(y + 1u, rows);
    if 2u * y + 1u <= rows {
        return (versines.x - upper.x) / (lower.x - upper.x);
    }
    return (upper.y - versines.y) / (upper.y - lower.y);
}

// The inverse of `environment_row_fraction`: cos theta and sin theta at the
// fraction `t` of row `y`.
fn environment_row_angle(y: u32, rows: u32, t: f32) -> vec2<f32> {
    let upper = environment_row_versines(y, rows);
    let lower = environment_row_versines(y + 1u, rows);
    if 2u * y + 1u <= rows {
        let a = mix(upper.x, lower.x, t);
        return vec2<f32>(1.0 - a, sqrt(max(0.0, a * (2.0 - a))));
    }
    let b = mix(upper.y, lower.y, t);
    return vec2<f32>(b - 1.0, sqrt(max(0.0, b * (2.0 - b))));
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

// Of a density linear over [0, 1] from `a` to `b`, the point where its CDF is
// `u` (pbrt-v4's `SampleLinear`, free of cancellation); `u` itself where both
// are 0.
fn environment_sample_linear(u: f32, a: f32, b: f32) -> f32 {
    // Scaled to a largest end of 1, so that the squares neither overflow nor vanish.
    let scale = max(max(a, b), 1e-30);
    let a1 = a / scale;
    let b1 = b / scale;
    let denominator = a1 + sqrt(mix(a1 * a1, b1 * b1, u));
    return select(u, clamp(u * (a1 + b1) / denominator, 0.0, 1.0), denominator > 0.0);
}

// The densities at the corners of the cell in row `y` between the texel
// columns `left` and `right`: upper left, upper right, lower left, lower right.
fn environment_corners(info: EnvironmentInfo, left: u32, right: u32, y: u32) -> vec4<f32> {
    let upper = min(y, info.height - 1u) * info.width;
    let lower = min(y + 1u, info.height - 1u) * info.width;
    return vec4<f32>(
        environment_texels_at(upper + left).w,
        environment_texels_at(upper + right).w,
        environment_texels_at(lower + left).w,
        environment_texels_at(lower + right).w,
    );
}

// A direction drawn from the map's density: a cell by descending the pyramid of
// the cells' probabilities (`environment::EnvironmentTables::pyramid`), a row
// then a column of each node's 2 x 2 children; then within the cell, with what
// is left of the numbers after the choices, cos theta from the bilinear
// density's marginal and phi from its conditional.
fn environment_sample(u_in: vec2<f32>) -> vec3<f32> {
    let info = environment_info_at(0u);
    let rows = environment_cell_rows(info.height);
    var u = u_in;
    var cell = vec2<u32>(0u);
    var level_start = 0u;
    for (var level = info.levels; level > 0u; level--) {
        let width = environment_pyramid_size(info.width, level);
        let m = environment_pyramid_at(level_start + cell.y * width + cell.x);
        level_start += width * environment_pyramid_size(rows, level);
        let row = environment_choose(u.y, m.x + m.y, m.z + m.w);
        let column = environment_choose(u.x, select(m.x, m.z, row.second), select(m.y, m.w, row.second));
        u = vec2<f32>(column.u, row.u);
        cell = 2u * cell + vec2<u32>(select(0u, 1u, column.second), select(0u, 1u, row.second));
    }
    let right = select(cell.x + 1u, 0u, cell.x + 1u == info.width);
    let c = environment_corners(info, cell.x, right, cell.y);
    let t_row = environment_sample_linear(u.y, c.x + c.y, c.z + c.w);
    let t_column = environment_sample_linear(u.x, mix(c.x, c.z, t_row), mix(c.y, c.w, t_row));
    let angle = environment_row_angle(cell.y, rows, t_row);
    let phi = 2.0 * PI * (f32(cell.x) + 0.5 + t_column) / f32(info.width);
    let local = vec3<f32>(sin(phi) * angle.y, angle.x, -cos(phi) * angle.y);
    // Map space to world: the transpose of the rows kept.
    return local.x * info.to_local_x + local.y * info.to_local_y + local.z * info.to_local_z;
}

// The solid-angle density of `environment_sample` at `dir`: the corners'
// densities interpolated bilinearly in (phi, cos theta).
fn environment_pdf(dir: vec3<f32>) -> f32 {
    let info = environment_info_at(0u);
    let rows = environment_cell_rows(info.height);
    let d = environment_local(info, dir);
    let columns = environment_columns(info.width, d);
    let rho2 = dot(d.xz, d.xz);
    let norm = sqrt(rho2 + d.y * d.y);
    // 1 - cos theta and 1 + cos theta, the small one of the two from sin^2 theta.
    let versines = select(
        vec2<f32>(1.0 - d.y / norm, rho2 / (norm * (norm - d.y))),
        vec2<f32>(rho2 / (norm * (norm + d.y)), 1.0 + d.y / norm),
        d.y > 0.0,
    );
    // The row from theta: a direction within rounding of a row's edge may fall
    // in the neighbour's, where the continuous density is the same to rounding.
    let y = min(u32(atan2(sqrt(rho2), d.y) * INV_PI * f32(rows)), rows - 1u);
    let t_row = clamp(environment_row_fraction(y, rows, versines), 0.0, 1.0);
    let c = environment_corners(info, columns.left, columns.right, y);
    return mix(mix(c.x, c.y, columns.t), mix(c.z, c.w, columns.t), t_row);
}
#endif
