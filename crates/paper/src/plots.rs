//! The study's figures: predicted against true per DOF (the paper's figures 1-6), noisy heave
//! (its figure 8), and RMS error against lead time for every method on both seas.

use super::figures::{line_chart, Chart, Series};
use super::seas::SeaKind;
use super::seas::STUDY_RATE_HZ;
use super::study::{rms_curve, Study, Trace, Variant, PAPER_METHODS, REFERENCES, TRACE_LEAD};
use shipcast_predict::Method;
use shipcast_wire::Dof;
use std::path::Path;

/// A figure written to the output directory.
#[derive(Clone, Debug)]
pub struct Figure {
    /// File name inside the output directory.
    pub file: String,
    pub caption: String,
}

/// Display name of a method as the paper calls it.
pub fn method_label(method: Method) -> &'static str {
    match method {
        Method::Mca => "MCA",
        Method::Mlp => "NN (MLP)",
        Method::Ar => "AR (LMS)",
        Method::Wiener => "Wiener",
        Method::Persistence => "persistence",
        Method::Zero => "zero",
    }
}

/// Write every figure of `study` into `dir`.
pub fn write_all(study: &Study, dir: &Path) -> anyhow::Result<Vec<Figure>> {
    let mut figures = Vec::new();
    for trace in &study.traces {
        figures.push(trace_figure(study, trace, dir)?);
    }
    for sea in [SeaKind::Dense, SeaKind::Line] {
        if let Some(f) = rms_figure(study, sea, dir)? {
            figures.push(f);
        }
    }
    Ok(figures)
}

fn trace_figure(study: &Study, trace: &Trace, dir: &Path) -> anyhow::Result<Figure> {
    let order = study.plan.big_order();
    let lead_s = TRACE_LEAD as f64 / STUDY_RATE_HZ;
    let dof = trace.dof;
    let (file, title) = if trace.noise_pct > 0.0 {
        (
            "fig8_noisy_heave.svg".to_string(),
            format!(
                "Fig. 8: heave with {} % noise, MCA-{order} {lead_s} s ahead",
                trace.noise_pct
            ),
        )
    } else {
        (
            format!("fig{}_{}.svg", dof.index() + 1, dof.name()),
            format!(
                "Fig. {}: {}, predicted {lead_s} s ahead",
                dof.index() + 1,
                dof.name()
            ),
        )
    };
    let mut series = vec![Series::new("true", trace.truth.clone())];
    if let Some(obs) = &trace.observed {
        series.push(Series::new("observed (noisy)", obs.clone()).thin());
    }
    if let Ok(p) = &trace.mca {
        series.push(Series::new(format!("MCA-{order}"), p.clone()));
    }
    if let Ok(p) = &trace.bound {
        // The bound is computed for, and fed with, the clean motion.
        let label = if trace.noise_pct > 0.0 {
            format!("bound (optimal linear, order {order}, from the clean record)")
        } else {
            format!("bound (optimal linear, order {order})")
        };
        series.push(Series::new(label, p.clone()).thin());
    }
    let y_label = format!("{} [{}]", dof.name(), dof.unit());
    line_chart(
        &dir.join(&file),
        &Chart {
            title: &title,
            x_label: "time [s]",
            y_label: &y_label,
            series: &series,
        },
    )?;
    let caption = match (&trace.mca, &trace.bound) {
        (Ok(_), Ok(_)) => title,
        (mca, bound) => format!(
            "{title} (missing: {})",
            [mca.as_ref().err(), bound.as_ref().err()]
                .into_iter()
                .flatten()
                .cloned()
                .collect::<Vec<_>>()
                .join("; ")
        ),
    };
    Ok(Figure { file, caption })
}

/// RMS error of heave against lead time at the big order, every method, references and bound.
fn rms_figure(study: &Study, sea: SeaKind, dir: &Path) -> anyhow::Result<Option<Figure>> {
    let order = study.plan.big_order();
    let dt = 1.0 / STUDY_RATE_HZ;
    let curve = |rms: &[f64]| -> Vec<(f64, f64)> {
        rms.iter()
            .enumerate()
            .map(|(i, v)| ((i + 1) as f64 * dt, *v))
            .collect()
    };
    // The bound first, so it gets the first (black) colour.
    let mut series = Vec::new();
    if let Some(Ok(b)) = study.bound(sea, Dof::Heave, order).map(|b| &b.result) {
        series.push(Series::new(format!("bound-{order} (exact)"), curve(&b.exact_rms)).dashed());
    }
    // shipcast's eigenvalue-weighted MCA (dense sea only, where the study runs it) next, so it
    // gets the second, high-contrast colour beside the bound it is compared with.
    if let Some(v) = study.best_inverse().filter(|_| sea == SeaKind::Dense) {
        if let Ok(rms) = rms_curve(study.outcome(sea, Dof::Heave, order, Method::Mca, v)) {
            series.push(Series::new(
                format!("shipcast MCA-{order}, {} (not the paper's)", v.name()),
                curve(rms),
            ));
        }
    }
    for method in PAPER_METHODS.into_iter().chain(REFERENCES) {
        if let Some(Ok(r)) = study
            .outcome(sea, Dof::Heave, order, method, Variant::Paper)
            .map(|o| &o.result)
        {
            let s = Series::new(format!("{}-{order}", method_label(method)), curve(&r.rms));
            series.push(if REFERENCES.contains(&method) {
                s.dashed()
            } else {
                s
            });
        }
    }
    if series.is_empty() {
        return Ok(None);
    }
    let name = study
        .sea(sea)
        .map_or("sea".to_string(), |s| s.title.clone());
    let file = match sea {
        SeaKind::Dense => "rms_vs_lead_dense.svg",
        SeaKind::Line => "rms_vs_lead_line.svg",
        SeaKind::OtherRealisation => "rms_vs_lead_other.svg",
    }
    .to_string();
    let title = format!("Heave RMS error against lead time, {name}");
    line_chart(
        &dir.join(&file),
        &Chart {
            title: &title,
            x_label: "lead time [s]",
            y_label: "RMS error [m]",
            series: &series,
        },
    )?;
    Ok(Some(Figure {
        file,
        caption: title,
    }))
}
