//! `shipcast bench`: benchmarks of the running system. `bench latency` measures shipcast's
//! paths and the raw transport floors one way on two pinned cores (issue 6).

use crate::checked;
use crate::progress::Bar;
use anyhow::Context;
use shipcast_bench::latency;
use shipcast_bench::pingpong_zenoh_processes::{self, PongArgs};
use shipcast_bench::plan::parse_cores;
use shipcast_bench::report_builder::{forecast_json_bytes, FORECAST_BYTES, MOTION_BYTES};
use shipcast_bench::{Mode, ModeSelect, Plan};
use shipcast_pipeline::limits;
use std::io::Write;
use std::path::PathBuf;

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(subcommand)]
    command: Command,
}

#[derive(clap::Subcommand, Debug)]
enum Command {
    /// One-way latency of shipcast's paths and of raw iceoryx2 and zenoh, on two pinned cores.
    Latency(LatencyArgs),
    /// N vessels at 2 Hz through one `shipcast router` to one shore subscriber: delivery
    /// latency, loss, router CPU, and recovery after a router restart.
    Fleet(FleetArgs),
    /// The answering side of the inter-process zenoh floor, started by `bench latency`.
    #[command(hide = true)]
    ZenohPong(ZenohPongArgs),
}

#[derive(clap::Args, Debug)]
struct ZenohPongArgs {
    /// The ping side's listen endpoint.
    #[arg(long)]
    connect: String,
    /// Key prefix of the exchange.
    #[arg(long)]
    prefix: String,
    #[arg(long)]
    bytes: usize,
    #[arg(long, value_parser = |s: &str| s.parse::<ModeSelect>())]
    mode: ModeSelect,
    #[arg(long)]
    core: usize,
    #[arg(long)]
    warmup: u64,
    /// File for the recorded legs.
    #[arg(long)]
    out: PathBuf,
}

#[derive(clap::Args, Debug)]
struct FleetArgs {
    /// Fleet sizes to run, one after the other.
    #[arg(long, value_delimiter = ',', default_value = "10,50,200")]
    vessels: Vec<usize>,
    /// Measured seconds per fleet size.
    #[arg(long, default_value_t = 20.0)]
    seconds: f64,
    /// Forecasts per second per vessel.
    #[arg(long, default_value_t = 2.0)]
    rate: f64,
    /// Skip the router-restart measurement.
    #[arg(long)]
    no_restart: bool,
    /// Print the rows as a JSON array on stdout.
    #[arg(long)]
    json: bool,
}

#[derive(clap::Args, Debug)]
struct LatencyArgs {
    /// Measured samples (and ping-pong exchanges) per path and mode.
    #[arg(long, default_value_t = 5000)]
    samples: u64,
    /// Send rate in Hz (8 is the realistic sensor rate; thousands stress the path).
    #[arg(long, default_value_t = 1000.0)]
    rate: f64,
    /// Receive mode: event (blocking wait, woken by notify), poll (busy polling) or both.
    #[arg(long, default_value = "both", value_parser = |s: &str| s.parse::<ModeSelect>())]
    mode: ModeSelect,
    /// Print the rows as a JSON array on stdout (the conditions and the table go to stderr).
    #[arg(long)]
    json: bool,
    /// Write an SVG of the latency distributions to this file.
    #[arg(long)]
    svg: Option<PathBuf>,
    /// Cores of the sender/producer and the receiver/predictor, as A,B [default: 0,1; run
    /// unpinned, with a warning, where those are not available].
    #[arg(long, value_parser = |s: &str| parse_cores(s))]
    cores: Option<(usize, usize)>,
    /// Warm-up samples sent before measuring and not recorded (default: 10 % of --samples, at
    /// most 200).
    #[arg(long)]
    warmup: Option<u64>,
    /// The measurements take turns this many times, each with its share of --samples, so
    /// noise from the host falls on every path alike (each round restarts the services).
    #[arg(long, default_value_t = 4)]
    rounds: u64,
}

/// A latency run, every value checked: built from [`LatencyArgs`] by
/// [`LatencyConfig::try_from`].
#[derive(Debug, Clone)]
struct LatencyConfig {
    /// Checked with `Plan::validate`; `shipcast_exe` is this binary.
    plan: Plan,
    modes: &'static [Mode],
    json: bool,
    /// SVG of the distributions; its directory exists.
    svg: Option<PathBuf>,
}

impl TryFrom<LatencyArgs> for LatencyConfig {
    type Error = anyhow::Error;

    fn try_from(a: LatencyArgs) -> anyhow::Result<Self> {
        let plan = Plan {
            samples: a.samples,
            warmup: a.warmup.unwrap_or((a.samples / 10).clamp(1, 200)),
            rounds: a.rounds,
            rate_hz: a.rate,
            cores: match a.cores {
                Some(cores) => checked(shipcast_bench::pinning::allowed(cores))?,
                None => DEFAULT_CORES,
            },
            instance: Plan::unique_instance("latency"),
            shipcast_exe: Some(own_executable()?),
        };
        checked(plan.validate())?;
        if let Some(svg) = &a.svg {
            // Checked now: the figure is drawn after minutes of measurement.
            crate::output_in_existing_dir("--svg", svg)?;
        }
        Ok(LatencyConfig {
            plan,
            modes: a.mode.modes(),
            json: a.json,
            svg: a.svg,
        })
    }
}

/// The cores a latency run pins to unless `--cores` says otherwise.
const DEFAULT_CORES: (usize, usize) = (0, 1);

/// A fleet run, every value checked: built from [`FleetArgs`] by [`FleetConfig::try_from`].
#[derive(Debug, Clone, PartialEq)]
struct FleetConfig {
    /// Fleet sizes, each in `1..=MAX_VESSELS`.
    vessels: Vec<usize>,
    seconds: f64,
    rate_hz: f64,
    restart: bool,
    json: bool,
}

impl TryFrom<FleetArgs> for FleetConfig {
    type Error = anyhow::Error;

    fn try_from(a: FleetArgs) -> anyhow::Result<Self> {
        // All checked before the first fleet starts: each vessel is a zenoh session in this
        // process, and --seconds becomes a Duration.
        checked(limits::seconds("--seconds", a.seconds))?;
        checked(limits::rate("--rate", a.rate, MAX_FLEET_RATE_HZ))?;
        for &n in &a.vessels {
            checked(limits::count("--vessels", n, 1, MAX_VESSELS))?;
        }
        Ok(FleetConfig {
            vessels: a.vessels,
            seconds: a.seconds,
            rate_hz: a.rate,
            restart: !a.no_restart,
            json: a.json,
        })
    }
}

impl TryFrom<ZenohPongArgs> for PongArgs {
    type Error = anyhow::Error;

    fn try_from(a: ZenohPongArgs) -> anyhow::Result<Self> {
        let &[mode] = a.mode.modes() else {
            anyhow::bail!("zenoh-pong: --mode must be event or poll");
        };
        checked(limits::core("--core", a.core))?;
        checked(limits::count("--bytes", a.bytes, 1, MAX_PONG_BYTES))?;
        checked(limits::count(
            "--warmup",
            a.warmup,
            0,
            shipcast_bench::plan::MAX_WARMUP,
        ))?;
        Ok(PongArgs {
            connect: a.connect,
            prefix: a.prefix,
            bytes: a.bytes,
            mode,
            core: a.core,
            warmup: a.warmup,
            out: a.out,
        })
    }
}

pub fn run(args: Args) -> anyhow::Result<()> {
    match args.command {
        Command::Latency(a) => run_latency(a.try_into()?),
        Command::Fleet(a) => run_fleet(a.try_into()?),
        Command::ZenohPong(a) => pingpong_zenoh_processes::serve_pong(&a.try_into()?),
    }
}

/// The running binary, for starting the services. /proc/self/exe still names this image when
/// the file on disk is replaced mid-run (a rebuild), which the plain path would not.
fn own_executable() -> anyhow::Result<PathBuf> {
    let proc_exe = PathBuf::from("/proc/self/exe");
    if proc_exe.exists() {
        return Ok(proc_exe);
    }
    std::env::current_exe().context("locate the shipcast executable")
}

/// Largest message of the zenoh ping-pong [bytes].
const MAX_PONG_BYTES: usize = 16 << 20;

/// Most vessels of one fleet run (each is a zenoh session of this process).
const MAX_VESSELS: usize = 1_000;

/// Highest forecast rate per vessel [Hz].
const MAX_FLEET_RATE_HZ: f64 = 1_000.0;

fn run_fleet(a: FleetConfig) -> anyhow::Result<()> {
    let exe = own_executable()?;
    let dir = crate::private_files::new_private_temp_dir("shipcast-fleet")?;
    let mut rows = Vec::new();
    // Progress lines to stderr, written (not eprintln!) so a closed stderr does not panic.
    let mut err = std::io::stderr();
    let _ = writeln!(
        err,
        "fleet: vessels at {} Hz -> shipcast router -> 1 shore subscriber, {} s each, loopback TCP",
        a.rate_hz, a.seconds
    );
    let _ = writeln!(err, "vessels  bytes     sent  received  lost   p50 us   p99 us   max us  router CPU %  restart s");
    for &n in &a.vessels {
        let r = shipcast_bench::fleet::run(&exe, &dir, n, a.seconds, a.rate_hz, a.restart)?;
        let _ = writeln!(
            err,
            "{:>7}  {:>5}  {:>7}  {:>8}  {:>4}  {:>7.0}  {:>7.0}  {:>7.0}  {:>12.1}  {}",
            r.vessels,
            r.payload_bytes,
            r.sent,
            r.received,
            r.lost,
            r.p50_us,
            r.p99_us,
            r.max_us,
            r.router_cpu_pct,
            r.restart_recovery_s
                .map(|s| format!("{s:.1}"))
                .unwrap_or_else(|| "-".into())
        );
        rows.push(r);
    }
    if a.json {
        writeln!(
            std::io::stdout(),
            "{}",
            serde_json::to_string_pretty(&rows)?
        )
        .context("write the JSON to stdout")?;
    }
    // The router logs are kept only when a run failed (the error names nothing else to read).
    let _ = std::fs::remove_dir_all(&dir);
    Ok(())
}

fn run_latency(a: LatencyConfig) -> anyhow::Result<()> {
    let bar = Bar::new();
    let report = latency::run(&a.plan, a.modes, &bar);
    bar.finish();
    let report = report?;
    let targets = report.targets(MOTION_BYTES, FORECAST_BYTES, forecast_json_bytes());
    if a.json {
        // The table goes to stderr too, so one run gives both the JSON and the readable form.
        let _ = write!(
            std::io::stderr(),
            "{}\n{}\n{}",
            report.header(),
            report.table(),
            targets
        );
        let json = report.json().context("encode JSON")?;
        writeln!(std::io::stdout(), "{json}").context("write the JSON to stdout")?;
    } else {
        write!(
            std::io::stdout(),
            "{}\n{}\n{}",
            report.header(),
            report.table(),
            targets
        )
        .context("write the report to stdout")?;
    }
    if let Some(svg) = &a.svg {
        report.write_svg(svg)?;
        let _ = writeln!(std::io::stderr(), "wrote {}", svg.display());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fleet_and_latency_runs_are_checked_before_they_start() {
        let c = crate::validated::<FleetArgs, FleetConfig>(&["--vessels", "2,3", "--no-restart"])
            .unwrap();
        assert_eq!(
            c,
            FleetConfig {
                vessels: vec![2, 3],
                seconds: 20.0,
                rate_hz: 2.0,
                restart: false,
                json: false
            }
        );
        assert_eq!(
            crate::refused::<FleetArgs, FleetConfig>(&["--vessels", "10,0"]),
            format!("--vessels must be 1..={MAX_VESSELS}, got 0")
        );
        assert_eq!(
            crate::refused::<FleetArgs, FleetConfig>(&["--rate", "5000"]),
            format!(
                "--rate must be a number in [{}, {MAX_FLEET_RATE_HZ}], got 5000",
                limits::MIN_RATE_HZ
            )
        );
        let c = crate::validated::<LatencyArgs, LatencyConfig>(&["--samples", "100"]).unwrap();
        assert_eq!((c.plan.samples, c.plan.warmup, c.plan.rounds), (100, 10, 4));
        assert_eq!(c.modes.len(), 2);
        assert_eq!(
            crate::refused::<LatencyArgs, LatencyConfig>(&["--samples", "3"]),
            "--rounds 4 must be at least 1 and at most --samples 3"
        );
        let dir = tempfile::tempdir().unwrap();
        let svg = dir.path().join("missing").join("l.svg");
        let svg = svg.to_str().unwrap();
        assert_eq!(
            crate::refused::<LatencyArgs, LatencyConfig>(&["--svg", svg]),
            format!(
                "--svg {svg}: the directory {} does not exist",
                dir.path().join("missing").display()
            )
        );
    }

    #[test]
    fn the_pong_side_takes_one_mode() {
        let pong = |mode: &str| {
            crate::validated::<ZenohPongArgs, PongArgs>(&[
                "--connect",
                "tcp/127.0.0.1:9",
                "--prefix",
                "p",
                "--bytes",
                "64",
                "--mode",
                mode,
                "--core",
                "0",
                "--warmup",
                "0",
                "--out",
                "legs.bin",
            ])
        };
        assert!(pong("event").is_ok());
        assert_eq!(
            format!("{:#}", pong("both").unwrap_err()),
            "zenoh-pong: --mode must be event or poll"
        );
    }
}
