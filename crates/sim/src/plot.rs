//! One SVG figure that shows what the simulator makes: the wave spectrum, the response spectra
//! in encounter frequency, and the first minute of the six motions.

use super::autocorr::Channel;
use super::{ShipMotion, SimError};
use plotters::prelude::*;
use shipcast_wire::Dof;
use std::path::Path;

/// Width of the encounter-frequency histogram bins of the response spectra [rad/s].
const D_OMEGA: f64 = 0.02;
/// Upper end of the frequency axes [rad/s].
const OMEGA_MAX: f64 = 2.5;

/// Histogram spectrum smoothed over five bins and scaled to a peak of one (shapes compare).
fn normalised_spectrum(m: &ShipMotion, channel: Channel) -> Vec<(f64, f64)> {
    let bins = (OMEGA_MAX / D_OMEGA) as usize;
    let h = m.encounter_spectrum(channel, D_OMEGA, bins);
    let smooth: Vec<f64> = (0..bins)
        .map(|i| {
            h[i.saturating_sub(2)..(i + 3).min(bins)]
                .iter()
                .sum::<f64>()
                / 5.0
        })
        .collect();
    let peak = smooth
        .iter()
        .cloned()
        .fold(0.0, f64::max)
        .max(f64::MIN_POSITIVE);
    smooth
        .iter()
        .enumerate()
        .map(|(i, v)| ((i as f64 + 0.5) * D_OMEGA, v / peak))
        .collect()
}

/// A DOF in display units: metres, or degrees for rotations.
fn display(dof: Dof, v: f64) -> f64 {
    if dof.is_rotation() {
        v.to_degrees()
    } else {
        v
    }
}

/// Draws the figure to `path` (SVG): spectra on top, `seconds` of motion sampled at `rate_hz`
/// below, one panel per DOF (the wave elevation drawn with heave).
pub fn plot_overview(
    m: &ShipMotion,
    path: &Path,
    seconds: f64,
    rate_hz: f64,
) -> Result<(), SimError> {
    let plot_err = SimError::plot(path);
    let n = (seconds * rate_hz).ceil().max(2.0) as usize;
    let record: Vec<_> = m.stream(rate_hz, 0.0)?.take(n).collect();
    let root = SVGBackend::new(path, (1200, 1150)).into_drawing_area();
    root.fill(&WHITE).map_err(plot_err)?;
    let (top, bottom) = root.split_vertically(400);
    let (left, right) = top.split_horizontally(600);

    // Wave spectrum against wave frequency, and the wave seen by the moving ship.
    let s = m.spectrum();
    let wave: Vec<(f64, f64)> = (1..=500)
        .map(|i| {
            let w = i as f64 * OMEGA_MAX / 500.0;
            (w, s.density(w))
        })
        .collect();
    let smax = wave.iter().map(|p| p.1).fold(0.0, f64::max) * 1.1;
    let mut chart = ChartBuilder::on(&left)
        .caption(
            format!(
                "Wave spectrum: {:?} Hs {} m, Tp {} s",
                s.kind, s.hs_m, s.tp_s
            ),
            ("sans-serif", 18),
        )
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(60)
        .build_cartesian_2d(0f64..OMEGA_MAX, 0f64..smax.max(1e-9))
        .map_err(plot_err)?;
    chart
        .configure_mesh()
        .x_desc("frequency [rad/s]")
        .y_desc("S [m^2 s/rad]")
        .draw()
        .map_err(plot_err)?;
    chart
        .draw_series(LineSeries::new(wave, BLUE.stroke_width(2)))
        .map_err(plot_err)?
        .label("S(w), wave frequency")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLUE));
    let enc: Vec<(f64, f64)> = normalised_spectrum(m, Channel::Wave)
        .into_iter()
        .map(|(w, v)| (w, v * smax / 1.1))
        .collect();
    chart
        .draw_series(LineSeries::new(enc, RED))
        .map_err(plot_err)?
        .label("wave at the ship, encounter frequency (scaled)")
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RED));
    chart
        .configure_series_labels()
        .border_style(BLACK)
        .background_style(WHITE.mix(0.8))
        .draw()
        .map_err(plot_err)?;

    // Response spectra in encounter frequency, each scaled to its own peak.
    let mut chart = ChartBuilder::on(&right)
        .caption(
            format!(
                "Response spectra, {} kn, heading {} deg (peak = 1)",
                m.config().speed_kn,
                m.config().heading_deg
            ),
            ("sans-serif", 18),
        )
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(50)
        .build_cartesian_2d(0f64..OMEGA_MAX, 0f64..1.1f64)
        .map_err(plot_err)?;
    chart
        .configure_mesh()
        .x_desc("encounter frequency [rad/s]")
        .draw()
        .map_err(plot_err)?;
    for (i, dof) in Dof::ALL.into_iter().enumerate() {
        let color = Palette99::pick(i).to_rgba();
        chart
            .draw_series(LineSeries::new(
                normalised_spectrum(m, Channel::Motion(dof)),
                color.stroke_width(2),
            ))
            .map_err(plot_err)?
            .label(dof.name())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color));
    }
    chart
        .configure_series_labels()
        .border_style(BLACK)
        .background_style(WHITE.mix(0.8))
        .draw()
        .map_err(plot_err)?;

    // The first `seconds` of each motion.
    let t_end = record.last().map_or(seconds, |p| p.time_s);
    for (i, (area, dof)) in bottom.split_evenly((3, 2)).iter().zip(Dof::ALL).enumerate() {
        let series: Vec<(f64, f64)> = record
            .iter()
            .map(|p| (p.time_s, display(dof, p.dof[dof.index()])))
            .collect();
        let mut lim = series.iter().map(|p| p.1.abs()).fold(0.0, f64::max);
        if dof == Dof::Heave {
            lim = record.iter().map(|p| p.wave_m.abs()).fold(lim, f64::max);
        }
        let lim = if lim > 0.0 { lim * 1.1 } else { 1.0 };
        let unit = match dof {
            Dof::Surge => "m, + forward",
            Dof::Sway => "m, + starboard",
            Dof::Heave => "m, + down",
            Dof::Roll => "deg, + starboard down",
            Dof::Pitch => "deg, + bow up",
            Dof::Yaw => "deg, + bow to starboard",
        };
        let mut chart = ChartBuilder::on(area)
            .caption(format!("{dof} [{unit}]"), ("sans-serif", 16))
            .margin(8)
            .x_label_area_size(30)
            .y_label_area_size(55)
            .build_cartesian_2d(0f64..t_end, -lim..lim)
            .map_err(plot_err)?;
        chart
            .configure_mesh()
            .x_desc("time [s]")
            .draw()
            .map_err(plot_err)?;
        if dof == Dof::Heave {
            let wave: Vec<(f64, f64)> = record.iter().map(|p| (p.time_s, p.wave_m)).collect();
            chart
                .draw_series(LineSeries::new(wave, RGBColor(160, 160, 160)))
                .map_err(plot_err)?
                .label("wave elevation (up)")
                .legend(|(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], RGBColor(160, 160, 160))
                });
        }
        let color = Palette99::pick(i).to_rgba();
        chart
            .draw_series(LineSeries::new(series, color.stroke_width(2)))
            .map_err(plot_err)?
            .label(dof.name())
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], color));
        if dof == Dof::Heave {
            chart
                .configure_series_labels()
                .border_style(BLACK)
                .background_style(WHITE.mix(0.8))
                .draw()
                .map_err(plot_err)?;
        }
    }
    root.present().map_err(plot_err)?;
    Ok(())
}
