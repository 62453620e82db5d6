//! SVG line charts with plotters. One generic chart; the study decides what goes in it.
//!
//! Series are thinned to at most `MAX_POINTS` points before drawing so the committed figures stay
//! small; the thinning keeps every `k`-th point, which is faithful for the smooth curves drawn here.

use anyhow::{anyhow, Context};
use plotters::prelude::*;
use std::path::Path;

/// Most points drawn per series.
pub const MAX_POINTS: usize = 600;

/// High-contrast colours in series order (the first series, usually the truth, is black).
const PALETTE: [RGBColor; 8] = [
    RGBColor(0, 0, 0),
    RGBColor(214, 39, 40),
    RGBColor(31, 119, 180),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(127, 127, 127),
];

/// One curve of a chart.
#[derive(Clone, Debug)]
pub struct Series {
    pub label: String,
    pub points: Vec<(f64, f64)>,
    pub style: Style,
}

/// How a curve is drawn. Dashes cost one SVG element per dash, so they suit short curves
/// (error against lead); long or noisy records use thin solid lines.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Style {
    Solid,
    /// Secondary curves of long records (noisy observations, the bound's trace).
    Thin,
    /// References on short curves (persistence, zero, bound).
    Dashed,
}

impl Series {
    pub fn new(label: impl Into<String>, points: Vec<(f64, f64)>) -> Self {
        Self {
            label: label.into(),
            points,
            style: Style::Solid,
        }
    }

    pub fn dashed(mut self) -> Self {
        self.style = Style::Dashed;
        self
    }

    pub fn thin(mut self) -> Self {
        self.style = Style::Thin;
        self
    }
}

/// What a chart shows.
#[derive(Clone, Debug)]
pub struct Chart<'a> {
    pub title: &'a str,
    pub x_label: &'a str,
    pub y_label: &'a str,
    pub series: &'a [Series],
}

/// Every `k`-th point so at most `max` remain (the last point is kept).
pub fn thin(points: &[(f64, f64)], max: usize) -> Vec<(f64, f64)> {
    if points.len() <= max || max < 2 {
        return points.to_vec();
    }
    let k = points.len().div_ceil(max - 1);
    let mut out: Vec<(f64, f64)> = points.iter().step_by(k).copied().collect();
    if let Some(&last) = points.last() {
        if out.last() != Some(&last) {
            out.push(last);
        }
    }
    out
}

/// Bounds of all finite points, widened a little so curves do not touch the frame.
fn extent(series: &[Series]) -> Option<((f64, f64), (f64, f64))> {
    let finite = series
        .iter()
        .flat_map(|s| s.points.iter())
        .filter(|(x, y)| x.is_finite() && y.is_finite());
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    let mut any = false;
    for &(x, y) in finite {
        any = true;
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    if !any {
        return None;
    }
    if x1 <= x0 {
        x1 = x0 + 1.0;
    }
    let pad = if y1 > y0 { 0.05 * (y1 - y0) } else { 1.0 };
    Some(((x0, x1), (y0 - pad, y1 + pad)))
}

/// Draw `chart` as an SVG file at `path`.
pub fn line_chart(path: &Path, chart: &Chart<'_>) -> anyhow::Result<()> {
    let ((x0, x1), (y0, y1)) = extent(chart.series)
        .ok_or_else(|| anyhow!("figure '{}' has no finite points", chart.title))?;
    // Drawn in memory and written whole: drawn into the file, a failed write (a full disk)
    // left a figure cut inside an element in place of the previous good one (review).
    let mut svg = String::new();
    let mut draw = || -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
        let root = SVGBackend::with_string(&mut svg, (900, 500)).into_drawing_area();
        root.fill(&WHITE)?;
        let mut ctx = ChartBuilder::on(&root)
            .caption(chart.title, ("sans-serif", 20))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(64)
            .build_cartesian_2d(x0..x1, y0..y1)?;
        ctx.configure_mesh()
            .x_desc(chart.x_label)
            .y_desc(chart.y_label)
            .light_line_style(WHITE)
            .draw()?;
        for (i, s) in chart.series.iter().enumerate() {
            let color = PALETTE[i % PALETTE.len()].to_rgba();
            let width = if s.style == Style::Solid { 2 } else { 1 };
            let style = ShapeStyle::from(color).stroke_width(width);
            let points: Vec<(f64, f64)> = thin(&s.points, MAX_POINTS)
                .into_iter()
                .filter(|(x, y)| x.is_finite() && y.is_finite())
                .collect();
            let legend_style = style;
            let anno = if s.style == Style::Dashed {
                ctx.draw_series(DashedLineSeries::new(points, 6, 4, style))?
            } else {
                ctx.draw_series(LineSeries::new(points, style))?
            };
            anno.label(s.label.as_str())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], legend_style));
        }
        ctx.configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()?;
        root.present()?;
        Ok(())
    };
    draw()
        .map_err(|e| anyhow!("{e}"))
        .with_context(|| format!("drawing {}", path.display()))?;
    shipcast_series::atomic_file::write_atomically(path, svg.as_bytes())
        .with_context(|| format!("writing {}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn thinning_keeps_ends_and_bounds_the_count() {
        let pts: Vec<(f64, f64)> = (0..1000).map(|i| (i as f64, 0.0)).collect();
        let t = thin(&pts, 100);
        assert!(t.len() <= 100, "{}", t.len());
        assert_eq!(t.first(), pts.first());
        assert_eq!(t.last(), pts.last());
        assert_eq!(thin(&pts[..50], 100).len(), 50);
    }

    #[test]
    fn writes_an_svg_with_the_labels() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("f.svg");
        let series = [
            Series::new(
                "sine",
                (0..200)
                    .map(|i| (i as f64, (i as f64 / 9.0).sin()))
                    .collect(),
            ),
            Series::new("bound", vec![(0.0, 0.1), (199.0, 0.5)]).dashed(),
        ];
        let chart = Chart {
            title: "test chart",
            x_label: "step",
            y_label: "rms",
            series: &series,
        };
        line_chart(&path, &chart).unwrap();
        let svg = std::fs::read_to_string(&path).unwrap();
        assert!(svg.starts_with("<svg"), "{}", &svg[..40.min(svg.len())]);
        assert!(svg.contains("test chart") && svg.contains("bound"));
    }

    #[test]
    fn a_chart_without_finite_points_is_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let series = [Series::new("nan", vec![(0.0, f64::NAN)])];
        let chart = Chart {
            title: "empty",
            x_label: "x",
            y_label: "y",
            series: &series,
        };
        let err = line_chart(&dir.path().join("e.svg"), &chart).unwrap_err();
        assert!(err.to_string().contains("no finite points"), "{err}");
    }
}
