//! MCA-800 training in shipcast against the same computation in numpy/LAPACK, on the same data
//! in the same run: `cargo bench --bench mca_vs_numpy`.
//!
//! Writes the training series (the seeded sea of `benches/predict.rs`, 5000 values at 2 Hz) and
//! shipcast's prediction matrix to a temporary directory, times `McaPredictor::fit` (order 800,
//! horizon 50, the paper's shift 10 and energy 0.015), then runs `benches/mca_vs_numpy.py` on
//! the same file and prints both times, their ratio and how far numpy's matrix is from ours.
//!
//! The Python interpreter: `SHIPCAST_NUMPY_PYTHON` if set, else `target/tmp/numpy-venv/bin/python`
//! if it exists, else `python3`. To make that venv:
//! `python3 -m venv target/tmp/numpy-venv && target/tmp/numpy-venv/bin/pip install numpy`.
//! Both sides use every core (faer through rayon, numpy through its BLAS).

use shipcast_predict::{McaPredictor, Predictor, PredictorConfig};
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

#[path = "support/sea.rs"]
mod support_sea;
use support_sea::sea;

const TRAIN: usize = 5000;
const ORDER: usize = 800;
const HORIZON: usize = 50;
const REPEATS: usize = 15;

fn python() -> PathBuf {
    if let Some(p) = std::env::var_os("SHIPCAST_NUMPY_PYTHON") {
        return p.into();
    }
    let venv = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/tmp/numpy-venv/bin/python");
    if venv.exists() {
        venv
    } else {
        "python3".into()
    }
}

fn write_values(path: &Path, values: &[f64]) -> std::io::Result<()> {
    let mut file = std::io::BufWriter::new(std::fs::File::create(path)?);
    for v in values {
        // Display of f64 is the shortest text that reads back as the same value.
        writeln!(file, "{v}")?;
    }
    file.flush()
}

/// Median and minimum of `f`'s wall time over `REPEATS` calls after one warm-up [ms].
fn time_ms(mut f: impl FnMut()) -> (f64, f64) {
    f();
    let mut times: Vec<f64> = (0..REPEATS)
        .map(|_| {
            let start = Instant::now();
            f();
            start.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    times.sort_by(f64::total_cmp);
    (times[REPEATS / 2], times[0])
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // `cargo bench` passes `--bench`; nothing here takes arguments.
    let config = PredictorConfig {
        order: ORDER,
        horizon: HORIZON,
        ..PredictorConfig::default()
    };
    let x = sea(TRAIN, 1);
    let mut mca = McaPredictor::new(&config)?;
    let (rust_median, rust_min) = time_ms(|| mca.fit(&x).expect("MCA-800 fits the bench sea"));
    let matrix = mca.prediction_matrix().ok_or("fitted")?;

    let dir = tempfile::tempdir()?;
    let (series, reference) = (dir.path().join("series.txt"), dir.path().join("p.txt"));
    write_values(&series, &x)?;
    write_values(&reference, matrix.coefficients())?;
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/mca_vs_numpy.py");
    let python = python();
    let out = Command::new(&python)
        .arg(&script)
        .arg(&series)
        .args([
            "--order",
            &ORDER.to_string(),
            "--horizon",
            &HORIZON.to_string(),
        ])
        .args(["--shift", &config.mca_shift.to_string()])
        .args(["--energy", &config.mca_energy.to_string()])
        .args(["--repeats", &REPEATS.to_string()])
        .arg("--reference")
        .arg(&reference)
        .output()
        .map_err(|e| format!("cannot run {}: {e}", python.display()))?;
    if !out.status.success() {
        return Err(format!(
            "{} {} failed: {}",
            python.display(),
            script.display(),
            String::from_utf8_lossy(&out.stderr).trim()
        )
        .into());
    }
    let numpy: serde_json::Value = serde_json::from_slice(&out.stdout)?;
    let numpy_median = numpy["median_ms"].as_f64().ok_or("no median_ms")?;
    let numpy_min = numpy["min_ms"].as_f64().ok_or("no min_ms")?;
    println!(
        "MCA-{ORDER} fit, H {HORIZON}, shift {}, energy {}, {TRAIN} values, {REPEATS} repeats, {} cores",
        config.mca_shift,
        config.mca_energy,
        std::thread::available_parallelism().map_or(1, |n| n.get())
    );
    println!(
        "shipcast (faer): median {rust_median:.1} ms, min {rust_min:.1} ms, {} minor components",
        mca.diagnostics().minor_components.unwrap_or(0)
    );
    println!(
        "numpy {}:       median {numpy_median:.1} ms, min {numpy_min:.1} ms, {} minor components",
        numpy["numpy"].as_str().unwrap_or("?"),
        numpy["minor_components"]
    );
    println!(
        "ratio shipcast / numpy: median {:.2}, min {:.2}; numpy's P differs from ours by {:.1e} of its largest entry",
        rust_median / numpy_median,
        rust_min / numpy_min,
        numpy["max_relative_difference"].as_f64().unwrap_or(f64::NAN)
    );
    Ok(())
}
