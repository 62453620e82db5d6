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

use iceoryx2::port::listener::ListenerWaitError;
use shipcast_wire::payload::DecisionSample;
use std::process::ExitCode;
use std::time::Duration;

struct Options {
    instance: String,
    vessel: String,
    station: String,
    /// Stop after this many decisions; 0 runs until Ctrl-C.
    count: usize,
}

fn parse_options() -> Result<Options, String> {
    let mut options = Options {
        instance: String::new(),
        vessel: "ddg51".into(),
        station: "deck".into(),
        count: 0,
    };
    let mut args = std::env::args().skip(1);
    while let Some(flag) = args.next() {
        let mut value = || args.next().ok_or(format!("{flag} needs a value"));
        match flag.as_str() {
            "--instance" => options.instance = value()?,
            "--vessel" => options.vessel = value()?,
            "--station" => options.station = value()?,
            "--count" => {
                let v = value()?;
                options.count = v
                    .parse()
                    .map_err(|_| format!("--count must be a whole number, got '{v}'"))?;
            }
            other => {
                return Err(format!(
                    "unknown option '{other}' (--instance, --vessel, --station, --count)"
                ))
            }
        }
    }
    Ok(options)
}

/// "in 3.5 s" or the text for an absent value (NaN in the payload).
fn seconds(v: f64, absent: &str) -> String {
    if v.is_finite() {
        format!("in {v:.1} s")
    } else {
        absent.to_string()
    }
}

fn run(options: &Options) -> Result<(), Box<dyn std::error::Error>> {
    // The deck notifies the event service after every sample: no polling needed.
    let reader = iox_reader::open::<DecisionSample>(
        &options.instance,
        &format!("{}/advisory/{}", options.vessel, options.station),
    )?;
    let (subscriber, listener) = (&reader.subscriber, &reader.listener);
    eprintln!("reading {} (iceoryx2)", reader.name);

    let mut received = 0;
    while options.count == 0 || received < options.count {
        match listener.timed_wait(|_| {}, Duration::from_millis(500)) {
            Ok(_) => {}
            Err(ListenerWaitError::InterruptSignal) => break,
            Err(e) => return Err(e.into()),
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
                "MOT beyond the horizon".to_string()
            } else {
                format!("p {p:.3} over {:.0} s", d.mot_s)
            };
            println!(
                "{} seq {} t={:.1}s: {verdict} {now} (threshold {:.2}), next window {}, next exceedance {}, from {} verified errors",
                options.station,
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
    let result = parse_options().map_err(Into::into).and_then(|o| run(&o));
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
