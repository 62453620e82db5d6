//! An SVG figure comparing RAO amplitude curves, one panel per DOF (closed form against a
//! reference such as a boundary-element solution), in the style of [`super::plot`].

use super::SimError;
use plotters::prelude::*;
use std::path::Path;

/// One panel: a title, the unit of the amplitude axis, and named curves of (omega, amplitude).
#[derive(Clone, Debug)]
pub struct RaoPanel {
    pub title: String,
    pub unit: String,
    pub curves: Vec<(String, Vec<(f64, f64)>)>,
}

/// Draws the panels side by side (one row) to `path` as SVG.
pub fn plot_rao_panels(panels: &[RaoPanel], path: &Path) -> Result<(), SimError> {
    if panels.is_empty() {
        return Err(SimError::NothingToPlot {
            path: path.to_path_buf(),
            problem: "no panels to draw".into(),
        });
    }
    let plot_err = SimError::plot(path);
    let root = SVGBackend::new(path, (450 * panels.len() as u32, 400)).into_drawing_area();
    root.fill(&WHITE).map_err(plot_err)?;
    for (area, panel) in root.split_evenly((1, panels.len())).iter().zip(panels) {
        let points = panel.curves.iter().flat_map(|c| c.1.iter());
        let (mut w_lo, mut w_hi, mut a_hi) = (f64::INFINITY, f64::NEG_INFINITY, 0.0f64);
        for &(w, a) in points {
            w_lo = w_lo.min(w);
            w_hi = w_hi.max(w);
            a_hi = a_hi.max(a);
        }
        if w_lo.partial_cmp(&w_hi) != Some(std::cmp::Ordering::Less) {
            return Err(SimError::NothingToPlot {
                path: path.to_path_buf(),
                problem: format!("panel '{}' has no data", panel.title),
            });
        }
        let a_hi = if a_hi > 0.0 { a_hi * 1.1 } else { 1.0 };
        let mut chart = ChartBuilder::on(area)
            .caption(&panel.title, ("sans-serif", 18))
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(w_lo..w_hi, 0f64..a_hi)
            .map_err(plot_err)?;
        chart
            .configure_mesh()
            .x_desc("wave frequency [rad/s]")
            .y_desc(panel.unit.as_str())
            .draw()
            .map_err(plot_err)?;
        for (i, (name, curve)) in panel.curves.iter().enumerate() {
            let color = Palette99::pick(i).to_rgba();
            chart
                .draw_series(LineSeries::new(
                    curve.iter().copied(),
                    color.stroke_width(2),
                ))
                .map_err(plot_err)?
                .label(name.as_str())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color));
        }
        chart
            .configure_series_labels()
            .border_style(BLACK)
            .background_style(WHITE.mix(0.8))
            .draw()
            .map_err(plot_err)?;
    }
    root.present().map_err(plot_err)?;
    Ok(())
}
