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

#[path = "common/checks.rs"]
mod checks;
#[path = "common/iox_reader.rs"]
mod iox_reader;
#[path = "common/options.rs"]
mod options;

use shipcast_wire::payload::Forecast;
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
        // One wake-up may find several forecasts queued: never more than --count printed.
        while options.count == 0 || received < options.count {
            let Some(sample) = subscriber.receive()? else {
                break;
            };
            let f: &Forecast = &sample;
            let (heave, pitch) = (Dof::Heave.index(), Dof::Pitch.index());
            // Shared memory is written by another process: check what is indexed and printed.
            let k5 = match checks::step_at(f, 5.0, &[heave, pitch]) {
                Ok(k) => k,
                Err(why) => {
                    eprintln!("skipped forecast seq {}: {why}", f.seq);
                    continue;
                }
            };
            received += 1;
            println!(
                "seq {} t={:.1}s v{}: in {:.1} s heave {:+.2} m (sigma {:.2}), pitch {:+.2} deg, latency {:.0} us",
                f.seq,
                f.time_s,
                f.model_version,
                (k5 + 1) as f64 * f.dt_s,
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
