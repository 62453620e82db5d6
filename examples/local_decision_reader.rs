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

/// Why `d` makes no sense, if it does not. A GO must come with a probability that reaches
/// its threshold (the display refuses the same): a forged or corrupted "GO" is never shown.
fn check(d: &DecisionSample) -> Result<(), String> {
    let p = d.probability_now;
    let probability = |v: f64| (0.0..=1.0).contains(&v);
    if d.go > 1 {
        return Err(format!("go {}", d.go));
    }
    if !(d.mot_s > 0.0 && d.mot_s.is_finite() && d.time_s.is_finite()) {
        return Err(format!("MOT {} s at t={}", d.mot_s, d.time_s));
    }
    if !probability(d.go_probability) || !(p.is_nan() || probability(p)) {
        return Err(format!("p {p}, threshold {}", d.go_probability));
    }
    // NaN (no probability) reaches no threshold.
    let reaches = p.is_finite() && p >= d.go_probability;
    if d.go == 1 && !reaches {
        return Err(format!(
            "GO with p {p} below its threshold {}",
            d.go_probability
        ));
    }
    Ok(())
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
        // One wake-up may find several decisions queued: never more than --count printed.
        while options.count == 0 || received < options.count {
            let Some(sample) = subscriber.receive()? else {
                break;
            };
            let d: &DecisionSample = &sample;
            // Shared memory is written by another process: check what is printed.
            if let Err(why) = check(d) {
                eprintln!("skipped decision seq {}: {why}", d.forecast_seq);
                continue;
            }
            let p = d.probability_now;
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
