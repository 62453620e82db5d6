//! Local reader of a station's decision in Rust: reads `DecisionSample` from iceoryx2 shared
//! memory on `shipcast/<vessel>/advisory/<station>` and prints the go/no-go of every one
//! (docs/decisions.md).
//!
//! Depends only on `shipcast-wire` (the payload types and the service limits) and `iceoryx2`.
//! Start a pipeline on this machine (`cargo run --release -- run`, whose deck publishes it),
//! then:
//!
//! ```sh
//! cargo run --release --example local_decision_reader -- [--instance NAME] [--vessel ddg51] [--station deck] [--count N]
//! ```

#[path = "common/iox_reader.rs"]
mod iox_reader;
#[path = "common/options.rs"]
mod options;

use shipcast_wire::payload::DecisionSample;
use std::process::ExitCode;

/// "in 3.5 s" or the text for an absent value (NaN in the payload).
fn seconds(v: f64, absent: &str) -> String {
    if v.is_finite() {
        format!("in {v:.1} s")
    } else {
        absent.to_string()
    }
}

fn run(options: &options::Options) -> Result<(), Box<dyn std::error::Error>> {
    let station = options.get("--station").unwrap_or("deck");
    // The deck notifies the event service after every sample: no polling needed.
    let reader = iox_reader::open::<DecisionSample>(
        &options.instance,
        &format!("{}/advisory/{station}", options.vessel),
    )?;
    let subscriber = &reader.subscriber;
    eprintln!("reading {} (iceoryx2)", reader.name);

    let mut received = 0;
    while options.count == 0 || received < options.count {
        if !reader.wait()? {
            break;
        }
        while let Some(sample) = subscriber.receive()? {
            let d: &DecisionSample = &sample;
            // Shared memory is written by another process: check what is printed.
            let p = d.probability_now;
            let bad_mot = d.mot_s.is_nan() || d.mot_s <= 0.0;
            if d.go > 1 || bad_mot || !(p.is_nan() || (0.0..=1.0).contains(&p)) {
                eprintln!(
                    "skipped a decision with go {}, MOT {}, p {p}",
                    d.go, d.mot_s
                );
                continue;
            }
            received += 1;
            let verdict = if d.go == 1 { "GO" } else { "NO-GO" };
            let now = if p.is_nan() {
                "no probability (no verified errors yet, or MOT beyond the horizon)".to_string()
            } else {
                format!("p {p:.3} over {:.0} s", d.mot_s)
            };
            println!(
                "{} seq {} t={:.1}s: {verdict} {now} (threshold {:.2}), next window {}, next exceedance {}, from {} verified errors",
                station,
                d.forecast_seq,
                d.time_s,
                d.go_probability,
                seconds(d.next_window_s, "none"),
                seconds(d.next_exceedance_s, "none predicted"),
                d.ensemble_members
            );
        }
    }
    Ok(())
}

fn main() -> ExitCode {
    options::main_with(&["--station"], run)
}
