//! `converge.png`: RMSE against seconds and against samples, log-log, one line per
//! variant, with the ideal `N^-1/2` slope dashed. Drawn with plotters' bitmap backend;
//! text uses DejaVu Sans from the `dejavu` crate, so no system font library is needed.

use super::Row;
use crate::output::{self, OutputError};
use image::codecs::png::PngEncoder;
use image::{ExtendedColorType, ImageEncoder};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::{FontStyle, register_font};
use std::io;
use std::path::Path;
use std::sync::Once;

const WIDTH: u32 = 1100;
const HEIGHT: u32 = 460;
/// The family name the embedded font is registered under.
const FONT: &str = "sans-serif";

/// Tableau 10, the first six.
const COLORS: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
];

fn register_embedded_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        if register_font(FONT, FontStyle::Normal, dejavu::sans::regular()).is_err() {
            unreachable!("the embedded DejaVu Sans does not parse");
        }
    });
}

/// Draws the plot and writes it as an RGB PNG (atomically).
pub fn plot_png(path: &Path, rows: &[Row], title: &str) -> Result<(), OutputError> {
    let pixels = plot_rgb(rows, title).map_err(|e| OutputError {
        path: path.to_owned(),
        message: format!("cannot draw `{}`: {e}", path.display()),
    })?;
    output::write_atomically(path, |writer| {
        PngEncoder::new(writer)
            .write_image(&pixels, WIDTH, HEIGHT, ExtendedColorType::Rgb8)
            .map_err(io::Error::other)
    })
}

/// The plot as `WIDTH × HEIGHT` RGB8 pixels.
fn plot_rgb(rows: &[Row], title: &str) -> Result<Vec<u8>, String> {
    register_embedded_font();
    let mut pixels = vec![255u8; (WIDTH * HEIGHT * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut pixels, (WIDTH, HEIGHT)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| e.to_string())?;
        let root = root.titled(title, (FONT, 22)).map_err(|e| e.to_string())?;
        let (left, right) = root.split_horizontally(WIDTH / 2);
        let series = series(rows);
        panel(&left, &series, Axis::Seconds, false)?;
        panel(&right, &series, Axis::Samples, true)?;
        root.present().map_err(|e| e.to_string())?;
    }
    Ok(pixels)
}

/// A variant's name and its `(seconds, spp, rmse)` points.
type Series = (String, Vec<(f64, f64, f64)>);

/// Each variant's points, in the order of first appearance.
fn series(rows: &[Row]) -> Vec<Series> {
    let mut series: Vec<Series> = Vec::new();
    for row in rows {
        let usable = [row.seconds, row.rmse]
            .iter()
            .all(|v| v.is_finite() && *v > 0.0);
        let point = (row.seconds, row.spp as f64, row.rmse);
        match series.iter_mut().find(|(name, _)| *name == row.variant) {
            Some((_, points)) if usable => points.push(point),
            Some(_) => {}
            None => series.push((
                row.variant.clone(),
                if usable { vec![point] } else { vec![] },
            )),
        }
    }
    series
}

#[derive(Clone, Copy, PartialEq)]
enum Axis {
    Seconds,
    Samples,
}

/// `[min / margin, max × margin]` of the positive values, or `[0.1, 10]` without any.
fn log_range(values: impl Iterator<Item = f64>, margin: f64) -> std::ops::Range<f64> {
    let (min, max) = values
        .filter(|v| v.is_finite() && *v > 0.0)
        .fold((f64::INFINITY, 0.0f64), |(lo, hi), v| {
            (lo.min(v), hi.max(v))
        });
    if min > max {
        return 0.1..10.0;
    }
    let (min, max) = if min == max {
        (min / 2.0, max * 2.0)
    } else {
        (min, max)
    };
    min / margin..max * margin
}

/// Tick labels: integers from 1 up, else up to 3 significant digits.
fn tick_label(value: &f64) -> String {
    let v = *value;
    if (1.0..1e6).contains(&v) && (v - v.round()).abs() < 1e-6 * v {
        format!("{}", v.round())
    } else if v > 0.0 && v < 1e6 {
        let text = format!("{v:.*}", (2 - v.log10().floor() as i32).max(0) as usize);
        // 0.0500 -> 0.05
        if text.contains('.') {
            text.trim_end_matches('0').trim_end_matches('.').to_string()
        } else {
            text
        }
    } else {
        format!("{v:.0e}")
    }
}

fn panel(
    area: &DrawingArea<BitMapBackend, Shift>,
    series: &[Series],
    axis: Axis,
    legend: bool,
) -> Result<(), String> {
    let x_of = |p: &(f64, f64, f64)| match axis {
        Axis::Seconds => p.0,
        Axis::Samples => p.1,
    };
    let all = || series.iter().flat_map(|(_, points)| points.iter());
    let x_range = log_range(all().map(x_of), 1.4);
    let y_range = log_range(all().map(|p| p.2), 1.4);
    let (caption, x_desc) = match axis {
        Axis::Seconds => ("RMSE vs render time", "seconds"),
        Axis::Samples => ("RMSE vs samples", "samples per pixel"),
    };
    let mut chart = ChartBuilder::on(area)
        .caption(caption, (FONT, 18))
        .margin(12)
        .x_label_area_size(44)
        .y_label_area_size(64)
        .build_cartesian_2d(x_range.clone().log_scale(), y_range.clone().log_scale())
        .map_err(|e| e.to_string())?;
    chart
        .configure_mesh()
        .x_desc(x_desc)
        .y_desc("RMSE")
        .x_labels(8)
        .y_labels(8)
        .max_light_lines(4)
        .x_label_formatter(&tick_label)
        .y_label_formatter(&tick_label)
        .label_style((FONT, 13))
        .axis_desc_style((FONT, 15))
        .light_line_style(RGBColor(242, 242, 242))
        .bold_line_style(RGBColor(205, 205, 205))
        .draw()
        .map_err(|e| e.to_string())?;

    for (index, (name, points)) in series.iter().enumerate() {
        let color = COLORS[index % COLORS.len()];
        let xy: Vec<(f64, f64)> = points.iter().map(|p| (x_of(p), p.2)).collect();
        chart
            .draw_series(LineSeries::new(xy.clone(), color.stroke_width(2)))
            .map_err(|e| e.to_string())?
            .label(name.clone())
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], color.stroke_width(2)));
        chart
            .draw_series(xy.iter().map(|&p| Circle::new(p, 3, color.filled())))
            .map_err(|e| e.to_string())?;
    }

    // The ideal N^-1/2 (time is proportional to samples), through the first variant's
    // last point (its most samples, the least noisy time), across the plot.
    if let Some(anchor) = series.iter().find_map(|(_, points)| points.last()) {
        let (x0, y0) = (x_of(anchor), anchor.2);
        let ideal = |x: f64| y0 * (x / x0).powf(-0.5);
        let (start, end) = (x_range.start, x_range.end);
        let steps = 32;
        let line: Vec<(f64, f64)> = (0..=steps)
            .map(|i| start * (end / start).powf(i as f64 / steps as f64))
            .map(|x| (x, ideal(x)))
            .filter(|(_, y)| *y >= y_range.start && *y <= y_range.end)
            .collect();
        let style = BLACK.mix(0.6).stroke_width(1);
        chart
            .draw_series(DashedLineSeries::new(line, 6, 5, style))
            .map_err(|e| e.to_string())?
            .label("ideal slope −1/2")
            .legend(move |(x, y)| {
                EmptyElement::at((x, y))
                    + PathElement::new([(0, 0), (6, 0)], style)
                    + PathElement::new([(11, 0), (17, 0)], style)
            });
    }

    if legend {
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::LowerLeft)
            .label_font((FONT, 13))
            .background_style(WHITE.mix(0.85))
            .border_style(RGBColor(160, 160, 160))
            .draw()
            .map_err(|e| e.to_string())?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tick_labels_are_short() {
        assert_eq!(tick_label(&1.0), "1");
        assert_eq!(tick_label(&256.0), "256");
        assert_eq!(tick_label(&0.05), "0.05");
        assert_eq!(tick_label(&0.0123456), "0.0123");
        assert_eq!(tick_label(&2.5), "2.5");
    }

    #[test]
    fn plot_draws_lines_in_each_variants_color() {
        let rows: Vec<Row> = [("cosine", 0.4), ("light", 0.1)]
            .iter()
            .flat_map(|&(name, scale)| {
                super::super::ladder(64).into_iter().map(move |n| Row {
                    variant: name.to_string(),
                    spp: n,
                    seconds: n as f64 * 0.02,
                    paths_per_second: 1e6,
                    rmse: scale / (n as f64).sqrt(),
                    relative_rmse: None,
                    relative_mse: scale * scale / n as f64,
                    estimated_error: None,
                    efficiency: 1.0,
                })
            })
            .collect();
        let pixels = plot_rgb(&rows, "test").unwrap();
        let count = |c: RGBColor| pixels.chunks(3).filter(|p| p == &[c.0, c.1, c.2]).count();
        assert!(count(COLORS[0]) > 200, "{}", count(COLORS[0]));
        assert!(count(COLORS[1]) > 200, "{}", count(COLORS[1]));
        assert_eq!(count(COLORS[2]), 0);
        // Text was drawn: some dark, non-line pixels.
        let dark = pixels
            .chunks(3)
            .filter(|p| p.iter().all(|&c| c < 60))
            .count();
        assert!(dark > 500, "{dark}");
    }
}
