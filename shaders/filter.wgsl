// The pixel filters (src/kinds/filter.rs): `filter_eval(x)`, the profile at
// |offset| x along one axis (what splatting weighs by, splat.wgsl), and the
// offset samplers of filter importance sampling: `filter_offset(u)` turns two
// uniform numbers into an offset from the pixel centre (in pixels, xy) and the
// weight its sample carries (z), whose mean is 1, so that a pixel's mean is the
// filter's weighted average of the radiance around it. Only the scene's filter
// is compiled in; the box filter needs none of this.

#if FILTER_GAUSSIAN
// Terms computed on the host (`GaussianFilterTerms` in src/kinds/filter.rs).
override FILTER_STDDEV: f32;
override FILTER_RADIUS: f32;
override FILTER_ERF_RADIUS: f32;
override FILTER_FLOOR: f32;
override FILTER_WEIGHT_SCALE: f32;

// At x >= 0: the Gaussian less its value at the radius (`Filter::eval`).
fn filter_eval(x: f32) -> f32 {
    let g = exp(-0.5 * (x / FILTER_STDDEV) * (x / FILTER_STDDEV));
    return max(g - FILTER_FLOOR, 0.0);
}

#if FILTER_OFFSET
// Offsets (in pixels) drawn from the Gaussian truncated to [-r, r] by inverting its
// CDF per axis, and the weight f/g * Z_g/Z_f that makes the estimate the one of the
// filter f = g - g(r) (mean weight 1).
fn filter_offset(u: vec2<f32>) -> vec3<f32> {
    let x = clamp(
        FILTER_STDDEV * 1.41421356 * vec2<f32>(erfinv((2.0 * u.x - 1.0) * FILTER_ERF_RADIUS), erfinv((2.0 * u.y - 1.0) * FILTER_ERF_RADIUS)),
        vec2<f32>(-FILTER_RADIUS),
        vec2<f32>(FILTER_RADIUS),
    );
    let g = exp(-0.5 * (x / FILTER_STDDEV) * (x / FILTER_STDDEV));
    let weight = max(g - FILTER_FLOOR, vec2<f32>(0.0)) / g * FILTER_WEIGHT_SCALE;
    return vec3<f32>(x, weight.x * weight.y);
}
#endif
#endif

#if FILTER_TENT
override FILTER_RADIUS: f32;

// At x >= 0.
fn filter_eval(x: f32) -> f32 {
    return max(1.0 - x / FILTER_RADIUS, 0.0);
}

#if FILTER_OFFSET
// The tent max(0, 1 - |x| / r) exactly, per axis: a side from the sign of
// v = 2u - 1, then the inverse of the CDF 1 - (1 - |x| / r)^2 of the half
// tent at |v|. The density is the filter normalised, so the weight is 1.
fn filter_offset(u: vec2<f32>) -> vec3<f32> {
    let v = 2.0 * u - 1.0;
    let x = sign(v) * FILTER_RADIUS * (1.0 - sqrt(1.0 - abs(v)));
    return vec3<f32>(x, 1.0);
}
#endif
#endif

#if FILTER_MITCHELL
override FILTER_B: f32;
override FILTER_C: f32;

// Mitsuba's mitchell.cpp at |x| = x >= 0 (the Catmull-Rom filter is B = 0, C = 1/2).
fn filter_eval(x: f32) -> f32 {
    let x2 = x * x;
    let x3 = x2 * x;
    let inner = (12.0 - 9.0 * FILTER_B - 6.0 * FILTER_C) * x3
        + (-18.0 + 12.0 * FILTER_B + 6.0 * FILTER_C) * x2
        + (6.0 - 2.0 * FILTER_B);
    let outer = (-FILTER_B - 6.0 * FILTER_C) * x3
        + (6.0 * FILTER_B + 30.0 * FILTER_C) * x2
        + (-12.0 * FILTER_B - 48.0 * FILTER_C) * x
        + (8.0 * FILTER_B + 24.0 * FILTER_C);
    return select(0.0, select(outer, inner, x < 1.0) / 6.0, x < 2.0);
}
#endif

#if FILTER_LANCZOS
override FILTER_LOBES: f32;

// Mitsuba's lanczos.cpp at |x| = x >= 0: sinc(x) sinc(x / lobes) within the
// radius `lobes` (1 below f32's epsilon, where the quotient is 0 / 0).
fn filter_eval(x: f32) -> f32 {
    let x1 = PI * x;
    let x2 = x1 / FILTER_LOBES;
    let value = select(sin(x1) * sin(x2) / (x1 * x2), 1.0, x < 5.9604645e-8);
    return select(value, 0.0, x > FILTER_LOBES);
}
#endif

#if FILTER_TABLE
// Generated (`glue::filter_table`, from `FilterTable` in src/kinds/filter.rs):
// FILTER_TABLE_BINS (N) and `filter_bins_at(j)`, the bounds (q_j, q_j+1) of bin
// j, the quantiles of |f| over [0, r] (|f| holds j / N of its mass below q_j);
// FILTER_TABLE_SCALE is N / (integral of f over [0, r]). Declared for the
// splatting pass too, which gets the filter's constants but draws nothing.
override FILTER_TABLE_SCALE: f32;

#if FILTER_OFFSET

// One axis of a filter with negative lobes, drawn from |f|: the side from the
// sign of v = 2u - 1, then |x| uniform in the table's bin at |v|, of density
// 1 / (2 N width) over the axis. Returns x and the weight f(x) / (p(x) integral
// of f) = f(x) width N / (integral of f over [0, r]), negative where f is.
fn filter_table_axis(u: f32) -> vec2<f32> {
    let v = 2.0 * u - 1.0;
    let scaled = abs(v) * f32(FILTER_TABLE_BINS);
    let bin = min(u32(scaled), FILTER_TABLE_BINS - 1u);
    let bounds = filter_bins_at(bin);
    let width = bounds.y - bounds.x;
    let x = bounds.x + (scaled - f32(bin)) * width;
    return vec2<f32>(select(x, -x, v < 0.0), filter_eval(x) * width * FILTER_TABLE_SCALE);
}

fn filter_offset(u: vec2<f32>) -> vec3<f32> {
    let x = filter_table_axis(u.x);
    let y = filter_table_axis(u.y);
    return vec3<f32>(x.x, y.x, x.y * y.y);
}
#endif
#endif
