//! Log-log line plots as PNG (plotters, bitmap backend). Text is drawn with a bundled subset of the
//! DejaVu Sans font through ab_glyph (`assets/fonts/`), so no system font library is needed.

use crate::output::FileError;
use plotters::coord::combinators::WithKeyPoints;
use plotters::prelude::*;
use plotters::style::{FontStyle, register_font};
use std::path::Path;
use std::sync::Once;

/// DejaVu Sans cut to ASCII and a few symbols (σ, ±, −, superscripts); see `assets/fonts/LICENSE`.
static FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans-subset.ttf");

fn register() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The bundled font is valid; a failure would only leave text undrawn.
        let _ = register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

/// How a series is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Line {
    /// Solid line with a circle at every point.
    Markers,
    /// Solid line with a square at every point (a second set of curves, e.g. a baseline's).
    Squares,
    /// Dashed line, no markers.
    Dashed,
    /// Thin solid line, no markers.
    Thin,
}

/// One curve: (x, y) points (non-positive values are left out on log axes).
#[derive(Clone, Debug)]
pub struct Series {
    pub label: String,
    pub points: Vec<(f64, f64)>,
    pub color: (u8, u8, u8),
    pub line: Line,
}

/// Compact tick labels for log axes: 0.02, 1, 500, 1e-4, 5e5.
fn tick(v: f64) -> String {
    if !(v > 0.0) || !v.is_finite() {
        return String::new();
    }
    let a = v.abs();
    if (1e-3..1e4).contains(&a) {
        let s = format!("{v:.4}");
        let s = s.trim_end_matches('0').trim_end_matches('.');
        s.to_string()
    } else {
        format!("{v:.0e}")
    }
}

/// Ticks of a log axis over `r`: labelled (bold) at 1, 2, 5 × 10^k (only 10^k over many decades,
/// every m × 10^k over less than about a factor 5), light grid lines at every m × 10^k.
fn log_ticks(r: &std::ops::Range<f64>) -> (Vec<f64>, Vec<f64>) {
    let (k0, k1) = (r.start.log10().floor() as i32, r.end.log10().ceil() as i32);
    let at = |ms: &[f64]| -> Vec<f64> {
        (k0..=k1)
            .flat_map(|k| ms.iter().map(move |m| m * 10f64.powi(k)))
            .filter(|v| r.contains(v))
            .collect()
    };
    let all: Vec<f64> = at(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0]);
    let mut bold = at(&[1.0, 2.0, 5.0]);
    if bold.len() > 10 {
        bold = at(&[1.0]);
    } else if bold.len() < 3 {
        bold = all.clone();
    }
    let light = if k1 - k0 <= 4 { all } else { at(&[1.0]) };
    (bold, light)
}

/// Widens [lo, hi] by a factor on each side (log axes), and makes an empty range non-empty.
fn log_range((lo, hi): (f64, f64)) -> std::ops::Range<f64> {
    let (lo, hi) = if lo < hi {
        (lo, hi)
    } else {
        (lo * 0.5, lo * 2.0)
    };
    (lo / 1.3)..(hi * 1.3)
}

/// Whether a point can be drawn on log axes: positive and finite.
fn drawable(&(x, y): &(f64, f64)) -> bool {
    x > 0.0 && y > 0.0 && x.is_finite() && y.is_finite()
}

/// The smallest and largest of `values`.
fn min_max(values: impl Iterator<Item = f64>) -> (f64, f64) {
    values.fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
        (a.min(v), b.max(v))
    })
}

/// Draws the series on log-log axes and writes a `size` PNG (atomically).
pub fn write_loglog_png(
    path: &Path,
    size: (u32, u32),
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
) -> Result<(), FileError> {
    register();
    let (w, h) = size;
    let pos: Vec<(f64, f64)> = series
        .iter()
        .flat_map(|s| s.points.iter().copied())
        .filter(drawable)
        .collect();
    if pos.is_empty() {
        return Err(FileError::unfit(
            path,
            "a plot without positive finite points to draw on log axes",
        ));
    }
    let x = log_range(min_max(pos.iter().map(|p| p.0)));
    let y = log_range(min_max(pos.iter().map(|p| p.1)));
    let mut buf = vec![0u8; w as usize * h as usize * 3];
    draw(&mut buf, size, (title, x_label, y_label), (x, y), series)
        .map_err(|e| FileError::encode(path, format!("plot: {e}")))?;
    // write_png takes row 0 as the bottom row; the bitmap's row 0 is the top.
    let rgb: Vec<[u8; 3]> = buf
        .chunks_exact(w as usize * 3)
        .rev()
        .flat_map(|row| row.chunks_exact(3).map(|p| [p[0], p[1], p[2]]))
        .collect();
    crate::output::png::write_png(path, w as usize, h as usize, &rgb)
}

type DrawResult = Result<(), Box<dyn std::error::Error>>;

/// Draws the chart into the RGB bitmap `buf` of `size`: title and axis labels, log axes over the
/// ranges with their ticks and grid, every series, and the legend.
fn draw(
    buf: &mut [u8],
    size: (u32, u32),
    (title, x_label, y_label): (&str, &str, &str),
    (x, y): (std::ops::Range<f64>, std::ops::Range<f64>),
    series: &[Series],
) -> DrawResult {
    let axis = |r: std::ops::Range<f64>| {
        let (bold, light) = log_ticks(&r);
        r.log_scale().with_key_points(bold).with_light_points(light)
    };
    let root = BitMapBackend::with_buffer(buf, size).into_drawing_area();
    root.fill(&WHITE)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 20))
        .margin(12)
        .x_label_area_size(42)
        .y_label_area_size(64)
        .build_cartesian_2d(axis(x), axis(y))?;
    chart
        .configure_mesh()
        .x_desc(x_label)
        .y_desc(y_label)
        .x_label_formatter(&|v| tick(*v))
        .y_label_formatter(&|v| tick(*v))
        .label_style(("sans-serif", 15))
        .axis_desc_style(("sans-serif", 16))
        .bold_line_style(RGBColor(222, 222, 222))
        .light_line_style(RGBColor(240, 240, 240))
        .draw()?;
    for s in series {
        draw_series(&mut chart, s)?;
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperRight)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font(("sans-serif", 14))
        .draw()?;
    root.present()?;
    Ok(())
}

/// A chart on log-log axes with their chosen ticks, drawn into a bitmap.
type LogAxis = WithKeyPoints<LogCoord<f64>>;
type LogLogChart<'a, 'b> = ChartContext<'a, BitMapBackend<'b>, Cartesian2d<LogAxis, LogAxis>>;

/// One series in its style ([`Line`]), with its legend entry; nothing for a series without a
/// drawable point.
fn draw_series(chart: &mut LogLogChart<'_, '_>, s: &Series) -> DrawResult {
    let c = RGBColor(s.color.0, s.color.1, s.color.2);
    let pts: Vec<(f64, f64)> = s.points.iter().copied().filter(drawable).collect();
    if pts.is_empty() {
        return Ok(());
    }
    let legend = match s.line {
        Line::Markers => {
            chart.draw_series(pts.iter().map(|p| Circle::new(*p, 4, c.filled())))?;
            chart.draw_series(LineSeries::new(pts.clone(), c.stroke_width(2)))?
        }
        Line::Squares => {
            chart.draw_series(pts.iter().map(|&(x, y)| {
                EmptyElement::at((x, y)) + Rectangle::new([(-4, -4), (4, 4)], c.filled())
            }))?;
            chart.draw_series(LineSeries::new(pts.clone(), c.stroke_width(2)))?
        }
        Line::Dashed => {
            chart.draw_series(DashedLineSeries::new(pts.clone(), 8, 5, c.stroke_width(2)))?
        }
        Line::Thin => chart.draw_series(LineSeries::new(pts.clone(), c.stroke_width(1)))?,
    };
    legend
        .label(s.label.as_str())
        .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 22, y)], c.stroke_width(2)));
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_are_compact() {
        assert_eq!(tick(1.0), "1");
        assert_eq!(tick(0.02), "0.02");
        assert_eq!(tick(300.0), "300");
        assert_eq!(tick(1e-4), "1e-4");
        assert_eq!(tick(5e5), "5e5");
        let (bold, light) = log_ticks(&(0.0009..0.03));
        assert_eq!(bold, vec![0.001, 0.002, 0.005, 0.01, 0.02]);
        assert_eq!(light.len(), 9 + 2 + 1);
    }
}
