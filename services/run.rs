//! `shipcast run`: the whole pipeline from one config. Starts predictor, deck, crane, the live
//! display (a web page) and producer as child processes of this executable, shows a compact
//! live view (latest forecast, deck advisory, predictor counters) with the display's address,
//! and stops them all on Ctrl-C or after `--duration`. With `--two-ship` (or
//! `relative.two_ship`) the target vessel of `[relative]` also gets a producer and a predictor
//! (simulated at its station in the same sea) and the relative service runs too.
//! The view checks what it shows as the crane does: forecasts through `ForecastGate`, the
//! predictor's status and verification only from their live publisher; rejections are
//! counted on the view's `checks` line and logged on one line each.

mod children;
mod view;

use crate::common_args::CommonArgs;
use anyhow::Context;
use children::{exited_early, Children, Stage};
use shipcast_pipeline::config::PipelineConfig;
use shipcast_pipeline::deck::Advisory;
use shipcast_pipeline::transport::forecast_check::{ForecastGate, PublisherWatch};
use shipcast_pipeline::transport::shutdown;
use shipcast_pipeline::transport::status::PredictorStatus;
use shipcast_pipeline::transport::zenoh::{self as zn, LatestSubscriber};
use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};
use view::{CheckedJson, View};

#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub common: CommonArgs,
    /// Directory for the children's logs (default: a new directory under the temp dir). A log
    /// already there is kept as `<service>.log.1` (one previous run's).
    #[arg(long, value_name = "DIR")]
    pub log_dir: Option<PathBuf>,
    /// Address of the live display's web page; port 0 picks a free one. Without this flag the
    /// default is used, or a free port when the default is taken.
    #[arg(long, value_name = "HOST:PORT", conflicts_with = "no_display")]
    pub display: Option<String>,
    /// Do not start the live display.
    #[arg(long)]
    pub no_display: bool,
    /// A host name the display's page may be opened by (repeatable; passed to the display as
    /// `--allow-host`): needed with `--display 0.0.0.0:PORT` for screens that open the page
    /// by the bridge machine's name.
    #[arg(long, value_name = "NAME", conflicts_with = "no_display")]
    pub allow_host: Vec<String>,
    /// Two ships in one sea (also `relative.two_ship` in the config): the target vessel of
    /// `[relative]` gets its own producer and predictor, simulated at its station, and the
    /// relative service forecasts the crane tip against its landing spot.
    #[arg(long)]
    pub two_ship: bool,
    /// Seconds between prints of the live view (default: 1 on a terminal, where it is redrawn
    /// in place; 60 otherwise, where every print is a new block of lines in a log or journal).
    #[arg(long, value_name = "S")]
    pub view_every: Option<f64>,
}

/// How often the live view is printed when stdout is not a terminal: each print adds its
/// lines to the log or journal. Soak review: at once a second, 85 MB and 683,000 lines a day.
const VIEW_EVERY_LOGGED: Duration = Duration::from_secs(60);

/// The shortest `--view-every`: the view's values arrive at 2 Hz at most.
const MIN_VIEW_EVERY_S: f64 = 0.5;

/// `HOST:PORT` split, when it has that shape (a host, a colon, a port number).
fn host_and_port(text: &str) -> Option<(&str, u16)> {
    let (host, port) = text.rsplit_once(':')?;
    let port = port.parse().ok()?;
    // An IPv6 address is bracketed ([::1]:8090); a bare one (::1) is no HOST:PORT.
    let bracketed = host.starts_with('[') && host.ends_with(']');
    (!host.is_empty() && (bracketed || !host.contains(':'))).then_some((host, port))
}

/// The address the display will listen on: the one asked for (port 0: a free one), or the
/// default, falling back to a free port when another process holds the default.
fn display_address(asked: Option<&str>) -> anyhow::Result<std::net::SocketAddr> {
    let wanted = asked.unwrap_or(crate::display::DEFAULT_LISTEN);
    // A host name (localhost, the bridge machine's name) is resolved here, an IPv4 address
    // first: the port is checked and the page's URL printed with the address itself.
    let address = match wanted.parse::<std::net::SocketAddr>() {
        Ok(a) => a,
        Err(_) => {
            use std::net::ToSocketAddrs;
            let resolved: Vec<_> = wanted
                .to_socket_addrs()
                .map_err(|e| match host_and_port(wanted) {
                    // Regression (review): a name that does not resolve was told it was not
                    // HOST:PORT.
                    Some((host, _)) => {
                        anyhow::anyhow!(
                            "--display {wanted}: the host name '{host}' does not resolve ({e})"
                        )
                    }
                    None => anyhow::anyhow!("--display must be HOST:PORT, got '{wanted}'"),
                })?
                .collect();
            resolved
                .iter()
                .find(|a| a.is_ipv4())
                .or(resolved.first())
                .copied()
                .with_context(|| format!("--display {wanted}: the host name has no address"))?
        }
    };
    // Port 0 (pick one) and a taken default port get one drawn outside the ephemeral range:
    // a port `bind(0)` hands out could be taken by any outgoing connection before the display
    // binds it (parallel tests' zenoh sessions dial out all the time).
    let pick = || {
        zn::free_port(address.ip())
            .map(|port| std::net::SocketAddr::new(address.ip(), port))
            .with_context(|| format!("no free port for the display on {}", address.ip()))
    };
    if address.port() == 0 {
        return pick();
    }
    match std::net::TcpListener::bind(address) {
        // Released again for the display process; taken by another program in between, the
        // display exits with its own one-line error and the run stops.
        Ok(probe) => Ok(probe.local_addr()?),
        Err(_) if asked.is_none() => pick(),
        Err(e) => Err(e).with_context(|| format!("--display {wanted}: cannot listen")),
    }
}

/// The host name of a `--display HOST:PORT`, unless it is an IP address or localhost (which
/// the display always serves).
fn host_name_of(display: &str) -> Option<String> {
    let (host, _port) = host_and_port(display)?;
    let host = host.trim_start_matches('[').trim_end_matches(']');
    (host.parse::<std::net::IpAddr>().is_err() && !host.eq_ignore_ascii_case("localhost"))
        .then(|| host.to_string())
}

/// The target vessel's configuration of a two-ship run: its vessel name and station, its
/// predictor listening on its own endpoint; the crane vessel's processes also connect there.
fn two_ship_configs(config: &mut PipelineConfig) -> anyhow::Result<PipelineConfig> {
    if config.zenoh.tls.is_some() {
        anyhow::bail!("--two-ship runs on plain loopback zenoh; the configuration sets zenoh.tls");
    }
    if config.relative.crane_vessel(&config.vessel) != config.vessel {
        anyhow::bail!(
            "--two-ship: relative.crane_vessel must be the pipeline's vessel '{}'",
            config.vessel
        );
    }
    // Regression (review): both were taken and made a wrong pair. The target's station is
    // measured from the simulated reference vessel, while the relative service places it
    // from the crane vessel; and a recorded input would have fed both vessels the same
    // motion.
    if config.producer.station != shipcast_sim::Station::REFERENCE {
        anyhow::bail!(
            "--two-ship simulates the crane vessel as the reference vessel: leave [producer] station out (the target's place is [relative] target_position_m)"
        );
    }
    if config.producer.input.is_some() {
        anyhow::bail!(
            "--two-ship simulates both vessels in one sea; [producer] input replays one record (run each vessel's producer with its own record instead)"
        );
    }
    let endpoint = zn::free_loopback_endpoint()?;
    let mut target = config.clone();
    target.vessel = config.relative.target_vessel.clone();
    target.relative.crane_vessel = Some(config.vessel.clone());
    target.producer.station = crate::relative::target_station(config);
    target.zenoh.listen = vec![endpoint.clone()];
    target.zenoh.connect = config
        .zenoh
        .listen
        .iter()
        .chain(&config.zenoh.connect)
        .cloned()
        .collect();
    config.zenoh.connect.push(endpoint);
    target.validate()?;
    Ok(target)
}

/// The configuration handed to the children: readable by the owner only (it may hold a
/// password or an inline private key), never written through a symlink.
fn write_config(config: &PipelineConfig, path: &Path) -> anyhow::Result<()> {
    crate::private_files::write_new(path, &config.to_toml()?, true)
}

/// The name in the log directory of a configuration `run` hands its children (`pipeline` or
/// `target`): its own, with the run's process id. Regression (review): written as
/// `pipeline.toml` and `target.toml`, a user's files of those names (their --config among
/// them) were written over and then removed.
fn run_config_name(which: &str) -> String {
    format!("run-{}-{which}.toml", std::process::id())
}

/// Remove the configurations this run wrote (they may hold a password or a private key).
fn remove_configs(pipeline: &Path, target: Option<&PathBuf>) {
    let _ = std::fs::remove_file(pipeline);
    if let Some(target) = target {
        let _ = std::fs::remove_file(target);
    }
}

/// What `run` starts, every value checked: built from [`Args`] by [`Config::try_from`] (the
/// configuration file, the flags over it, then the checks).
#[derive(Debug, Clone)]
pub struct Config {
    pub pipeline: PipelineConfig,
    /// Wall-clock limit (`--duration`).
    pub limit: Option<Duration>,
    /// Directory of the children's logs; it exists.
    pub log_dir: PathBuf,
    /// Where the live display listens (None: `--no-display`); free when checked.
    pub display: Option<std::net::SocketAddr>,
    /// Host names the display serves requests for: the one `--display` gave, if a name, and
    /// every `--allow-host` (checked by the display itself).
    pub display_names: Vec<String>,
    /// `--two-ship` or `relative.two_ship`.
    pub two_ship: bool,
    /// `--view-every` (None: by whether stdout is a terminal).
    pub view_every: Option<Duration>,
}

impl TryFrom<Args> for Config {
    type Error = anyhow::Error;

    fn try_from(args: Args) -> anyhow::Result<Self> {
        let pipeline = args.common.load()?;
        let display = if args.no_display {
            None
        } else {
            Some(display_address(args.display.as_deref())?)
        };
        let mut display_names: Vec<String> = args
            .display
            .as_deref()
            .and_then(host_name_of)
            .into_iter()
            .collect();
        display_names.extend(args.allow_host);
        let limit = args.common.duration()?;
        let view_every = args
            .view_every
            .map(|s| {
                if s < MIN_VIEW_EVERY_S {
                    return Err(format!(
                        "--view-every must be at least {MIN_VIEW_EVERY_S} s (its values arrive \
                         at 2 Hz at most), got {s}"
                    ));
                }
                shipcast_pipeline::limits::seconds("--view-every", s)
            })
            .transpose()
            .map_err(anyhow::Error::msg)?;
        // Created last: a refused flag must not leave an empty directory behind.
        // The default is a new directory only this user can enter: a fixed name under the
        // shared temp dir could be made in advance by another user, with symlinks in it.
        let log_dir = match args.log_dir {
            Some(d) => {
                std::fs::create_dir_all(&d).with_context(|| format!("creating {}", d.display()))?;
                d
            }
            None => crate::private_files::new_private_temp_dir("shipcast-run")?,
        };
        Ok(Config {
            two_ship: args.two_ship || pipeline.relative.two_ship,
            pipeline,
            limit,
            log_dir,
            display,
            display_names,
            view_every,
        })
    }
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let Config {
        pipeline: mut config,
        limit,
        log_dir: logs,
        display,
        display_names,
        two_ship,
        view_every,
    } = Config::try_from(args)?;
    let limit = shutdown::RunLimit::new(limit);
    let names = config.names()?;
    let target = two_ship
        .then(|| two_ship_configs(&mut config))
        .transpose()?;
    let config_path = logs.join(run_config_name("pipeline"));
    write_config(&config, &config_path)?;
    let target_path = logs.join(run_config_name("target"));
    if let Some(t) = &target {
        write_config(t, &target_path)?;
        let r = &config.relative;
        // Written, not println!: a closed stdout (`run | head -1`) must not panic.
        let _ = writeln!(
            std::io::stdout(),
            "two ships in one sea (scenario {:?}, seed {}): {} with the crane (tip {:?} m), {} at \
             {} m forward, {} m starboard, heading {:+} deg (landing spot {:?} m); each runs \
             producer and predictor, `relative` publishes {}",
            config.producer.scenario,
            config.producer.seed,
            config.vessel,
            config.crane.tip_m,
            t.vessel,
            r.target_position_m[0],
            r.target_position_m[1],
            r.target_heading_offset_deg,
            r.landing_spot_m,
            names.advisory("relative")
        );
    }

    let mut children = Children::new();
    // The predictor first: the producer waits until it has subscribed (its start-up training
    // takes a moment), so the backfill reaches it.
    children.spawn("predictor", &[], &config_path, &logs)?;
    children.spawn("deck", &["--print-every", "10"], &config_path, &logs)?;
    children.spawn("crane", &[], &config_path, &logs)?;
    if target.is_some() {
        children.spawn_as("target-predictor", "predictor", &[], &target_path, &logs)?;
        children.spawn("relative", &[], &config_path, &logs)?;
    }
    if let Some(address) = display {
        let listen = address.to_string();
        let mut args = vec!["--listen", listen.as_str()];
        // The page opened by the name it was asked for must be served (the display refuses
        // other names than the ones it is told).
        for name in &display_names {
            args.extend(["--allow-host", name.as_str()]);
        }
        children.spawn("display", &args, &config_path, &logs)?;
    }
    children.spawn(
        "producer",
        &["--wait-subscriber-s", "120"],
        &config_path,
        &logs,
    )?;
    if target.is_some() {
        children.spawn_as(
            "target-producer",
            "producer",
            &["--wait-subscriber-s", "120"],
            &target_path,
            &logs,
        )?;
    }

    // Given up at the run's limit (Ctrl-C, --duration): a secure client otherwise keeps
    // trying its predictor for its whole patience, past both.
    // A service that fails at start ends the wait too, with its own reason (regression,
    // review: a predictor that could not listen left a secure run waiting the client's whole
    // patience, 60 s, and then blaming the view).
    let consumer_side = config.zenoh.consumer_side();
    let mut failed = None;
    let opened = zn::open_unless(&consumer_side, || {
        if failed.is_none() {
            failed = children.failed();
        }
        limit.reached() || failed.is_some()
    })?;
    let Some(session) = opened else {
        children.stop();
        remove_configs(&config_path, target.as_ref().map(|_| &target_path));
        // Ctrl-C reaches the children too: their exits then are no failure (review).
        if let Some((name, status)) = failed.filter(|_| !shutdown::stop_requested()) {
            return Err(exited_early(&name, status, &logs));
        }
        // Ctrl-C before the view joined is the operator's choice; the duration running out is
        // a setup that never connected, and must not look like a run that went well.
        if shutdown::stop_requested() {
            let _ = writeln!(
                std::io::stdout(),
                "shipcast run: stopped (Ctrl-C or SIGTERM) before the live view could join zenoh; all services stopped (logs in {})",
                logs.display()
            );
            return Ok(());
        }
        anyhow::bail!(
            "the live view could not join zenoh at {:?} within the run's duration (see the services' logs in {}, and docs/FAQ.md for 'open client session')",
            consumer_side.connect,
            logs.display()
        );
    };
    let forecasts = LatestSubscriber::new(&session, &names.forecast())?;
    let forecast_publishers = PublisherWatch::new(&session, &names.forecast())?;
    let mut gate = ForecastGate::new(1.0 / config.predictor.sample_rate_hz);
    let mut advisories = CheckedJson::new(&session, &names.advisory("deck"))?;
    let mut status = CheckedJson::new(&session, &names.status("predictor"))?;
    let mut verification = CheckedJson::new(&session, &names.verification())?;
    let mut lift = target
        .is_some()
        .then(|| CheckedJson::new(&session, &names.advisory("relative")))
        .transpose()?;

    let tty = std::io::stdout().is_terminal();
    let view_every = view_every.unwrap_or(if tty {
        Duration::from_secs(1)
    } else {
        VIEW_EVERY_LOGGED
    });
    let mut view = View {
        lift: target.as_ref().map(|_| None),
        ..View::default()
    };
    let mut drawn = 0usize;
    // On a terminal the first block shows at once and is redrawn in place. In a log the first
    // one waits an interval: printed at once it says only that nothing has arrived yet.
    let mut last_draw: Option<Instant> = (!tty).then(Instant::now);
    // The view's lines now: a header, then what each service last said.
    let block = |view: &View| {
        let page = display
            .map(|a| format!("  display http://{a}/"))
            .unwrap_or_default();
        let header = format!(
            "shipcast run  {}  +{:.0}s{page}  (Ctrl-C stops; logs in {})",
            names,
            limit.elapsed().as_secs_f64(),
            logs.display()
        );
        view.lines(&header, Instant::now())
    };
    let outcome = loop {
        if limit.reached() {
            break Ok(if shutdown::stop_requested() {
                "stopped (Ctrl-C or SIGTERM)"
            } else {
                "duration reached"
            });
        }
        if let Some((stage, name, status)) = children.exited() {
            // A producer replaying a file (`producer.input`) or given `producer.record_s`
            // ends by itself when its record does: the run is complete, not failed. A producer
            // stopped by SIGTERM ends the same way (status 0), and cannot be told apart here.
            if stage == Stage::Producer && status.success() {
                break Ok("the producer finished (its record ended, or it was stopped)");
            }
            break Err(exited_early(&name, status, &logs));
        }
        forecast_publishers.update(&mut gate.live);
        while let Some(received) = forecasts.try_recv_with_source()? {
            // A token may arrive just after the first forecast of its publisher.
            forecast_publishers.update(&mut gate.live);
            match gate.check(&received) {
                Ok(f) => {
                    view.forecast = Some(f);
                    view.heard.forecast = Some(Instant::now());
                }
                Err(e) => {
                    shipcast_pipeline::warn_rejected!(
                        gate.stream.log,
                        gate.stream.rejected.total(),
                        "run: forecast rejected: {e}"
                    );
                }
            }
        }
        if let Some(a) = advisories.latest_as::<Advisory>()? {
            view.advisory = Some(a);
            view.heard.advisory = Some(Instant::now());
        }
        if let Some(v) = status.latest_as::<PredictorStatus>()? {
            view.status = Some(v);
            view.heard.status = Some(Instant::now());
        }
        if let Some(v) = verification.latest()? {
            view.verification = Some(v);
            view.heard.verification = Some(Instant::now());
        }
        if let Some(l) = lift
            .as_mut()
            .map(CheckedJson::latest_as)
            .transpose()?
            .flatten()
        {
            view.lift = Some(Some(l));
            view.heard.lift = Some(Instant::now());
        }
        view.rejected = (
            gate.stream.rejected,
            status.rejected
                + verification.rejected
                + advisories.rejected
                + lift.as_ref().map_or(0, |l| l.rejected),
        );
        if last_draw.is_none_or(|t| t.elapsed() >= view_every) {
            drawn = print_view(&block(&view), if tty { drawn } else { 0 });
            last_draw = Some(Instant::now());
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    if !tty {
        // The state at the stop, for the log: up to an interval newer than the last block.
        print_view(&block(&view), 0);
    }
    children.stop();
    remove_configs(&config_path, target.as_ref().map(|_| &target_path));
    let reason = outcome?;
    let _ = writeln!(
        std::io::stdout(),
        "shipcast run: {reason}; all services stopped (logs in {})",
        logs.display()
    );
    Ok(())
}

/// Print the live view's lines, over the `drawn` lines of the block before (0: below it);
/// returns how many were printed.
fn print_view(lines: &[String], drawn: usize) -> usize {
    let mut out = std::io::stdout().lock();
    if drawn > 0 {
        // Redraw the block in place.
        let _ = write!(out, "\x1b[{drawn}A\x1b[J");
    }
    for l in lines {
        let _ = writeln!(out, "{l}");
    }
    let _ = out.flush();
    lines.len()
}

#[cfg(test)]
mod config_tests {
    use super::*;

    #[test]
    fn the_display_flags_and_two_ship_are_resolved_and_checked() {
        let tmp = tempfile::tempdir().unwrap();
        let logs = tmp.path().join("logs");
        let dir = logs.to_str().unwrap();
        let missing = tmp.path().join("missing.toml");
        let c = crate::validated::<Args, Config>(&["--log-dir", dir, "--no-display"]).unwrap();
        assert!(c.display.is_none() && !c.two_ship && logs.is_dir());
        assert_eq!(c.log_dir, logs);
        assert_eq!(c.view_every, None, "chosen by whether stdout is a terminal");
        let c =
            crate::validated::<Args, Config>(&["--log-dir", dir, "--view-every", "2.5"]).unwrap();
        assert_eq!(c.view_every, Some(Duration::from_millis(2500)));
        let e = crate::refused::<Args, Config>(&["--log-dir", dir, "--view-every", "nan"]);
        assert!(e.contains("--view-every"), "{e}");
        let c = crate::validated::<Args, Config>(&[
            "--log-dir",
            dir,
            "--display",
            "127.0.0.1:0",
            "--two-ship",
        ])
        .unwrap();
        let address = c.display.unwrap();
        assert!(address.ip().is_loopback() && address.port() != 0 && c.two_ship);
        let e = crate::refused::<Args, Config>(&["--log-dir", dir, "--display", "localhost"]);
        assert!(e.starts_with("--display must be HOST:PORT"), "{e}");
        assert_eq!(host_and_port("bridge-pc:8090"), Some(("bridge-pc", 8090)));
        assert_eq!(host_and_port("[::1]:8090"), Some(("[::1]", 8090)));
        for not_host_port in [
            "localhost",
            ":8090",
            "bridge-pc:port",
            "bridge-pc:99999",
            "::1",
            "fe80::1:80",
        ] {
            assert_eq!(host_and_port(not_host_port), None, "{not_host_port}");
        }
        // A host name with a port is resolved (it was refused: an IP address only).
        let c = crate::validated::<Args, Config>(&["--log-dir", dir, "--display", "localhost:0"])
            .unwrap();
        let address = c.display.unwrap();
        assert!(
            address.ip().is_loopback() && address.port() != 0,
            "{address}"
        );
        assert!(c.display_names.is_empty(), "localhost is always served");
        assert_eq!(host_name_of("bridge-pc:8090").as_deref(), Some("bridge-pc"));
        for served in ["127.0.0.1:0", "[::1]:8090", "LocalHost:80", "0.0.0.0:8090"] {
            assert_eq!(host_name_of(served), None, "{served}");
        }
        let _ = std::fs::remove_dir_all(&logs);
        // Regression: refused flags left the (empty) log directory behind.
        for bad in [
            &["--display", "localhost"][..],
            &["--duration", "nan"],
            &["--view-every", "0"],
            &["--view-every", "0.1"],
            &["--no-display", "--config", missing.to_str().unwrap()],
        ] {
            let argv = [&["--log-dir", dir][..], bad].concat();
            crate::refused::<Args, Config>(&argv);
            assert!(!logs.exists(), "{bad:?} left {}", logs.display());
        }
    }

    /// Regression (review): a two-ship run took a station for the crane vessel (the target
    /// then stood in the wrong place relative to it) and a recorded input (both vessels
    /// replayed the same motion).
    #[test]
    fn a_two_ship_run_refuses_a_moved_crane_vessel_and_a_recorded_input() {
        let mut config = PipelineConfig::default();
        let target = two_ship_configs(&mut config.clone()).unwrap();
        assert_eq!(
            target.producer.station,
            crate::relative::target_station(&config)
        );
        assert_ne!(target.vessel, config.vessel);
        config.producer.station.y_m = 40.0;
        let e = two_ship_configs(&mut config.clone())
            .unwrap_err()
            .to_string();
        assert!(
            e.starts_with("--two-ship simulates the crane vessel as the reference"),
            "{e}"
        );
        config.producer.station = shipcast_sim::Station::REFERENCE;
        config.producer.input = Some("motion.csv".into());
        let e = two_ship_configs(&mut config).unwrap_err().to_string();
        assert!(
            e.starts_with("--two-ship simulates both vessels in one sea"),
            "{e}"
        );
    }
}
