//! Local shipcast consumer in Rust: reads `Forecast` from iceoryx2 shared memory (zero copy) and
//! prints the 5 s heave and pitch forecast of every one.
//!
//! Depends only on `shipcast-wire` (the payload types and the service limits) and `iceoryx2`:
//! the payload is the same `#[repr(C)]` struct the predictor writes, under the same type name.
//! Start a pipeline on this machine (`cargo run --release -- run`), then:
//!
//! ```sh
//! cargo run --release --example local_forecast_reader -- [--instance NAME] [--vessel ddg51] [--count N]
//! ```
//!
//! With `--instance NAME` the pipeline's service names start with `NAME/` and its iceoryx2 files
//! with the prefix `iox2_NAME_`; pass the same `--instance` here.

#[path = "common/iox_reader.rs"]
mod iox_reader;
#[path = "common/options.rs"]
mod options;

use shipcast_wire::payload::{Forecast, MAX_STEPS};
use shipcast_wire::Dof;
use std::process::ExitCode;

fn run(options: &options::Options) -> Result<(), Box<dyn std::error::Error>> {
    // The predictor notifies the event service after every sample: no polling needed.
    let reader =
        iox_reader::open::<Forecast>(&options.instance, &format!("{}/forecast", options.vessel))?;
    let subscriber = &reader.subscriber;
    eprintln!("reading {} (iceoryx2)", reader.name);

    let mut received = 0;
    while options.count == 0 || received < options.count {
        if !reader.wait()? {
            break;
        }
        while let Some(sample) = subscriber.receive()? {
            let f: &Forecast = &sample;
            // Shared memory is written by another process: check what indexing relies on.
            if f.steps == 0 || f.steps as usize > MAX_STEPS || f.dt_s.is_nan() || f.dt_s <= 0.0 {
                eprintln!(
                    "skipped a forecast with steps {} and dt_s {}",
                    f.steps, f.dt_s
                );
                continue;
            }
            received += 1;
            let k5 = ((5.0 / f.dt_s).round() as usize)
                .min(f.steps as usize)
                .max(1)
                - 1;
            let (heave, pitch) = (Dof::Heave.index(), Dof::Pitch.index());
            println!(
                "seq {} t={:.1}s v{}: in 5 s heave {:+.2} m (sigma {:.2}), pitch {:+.2} deg, latency {:.0} us",
                f.seq,
                f.time_s,
                f.model_version,
                f.mean[heave][k5],
                f.sigma[heave][k5],
                f.mean[pitch][k5].to_degrees(),
                f.issued_stamp_ns.saturating_sub(f.source_stamp_ns) as f64 / 1e3
            );
        }
    }
    Ok(())
}

fn main() -> ExitCode {
    options::main_with(&[], run)
}
