//! `shipcast simulate --elevation`: the ship driven by a measured wave record, segment by
//! segment (the method is in `shipcast_sim::measured`).

use super::{degrees, Config, RecordOut};
use anyhow::Context;
use shipcast_series::motion_csv::MotionData;
use shipcast_sim::build_rao;
use shipcast_sim::measured::{split_segments, SegmentResponse};
use shipcast_sim::{Channel, Station};
use std::fs::File;
use std::path::Path;
use std::time::Instant;

/// Motion driven by a measured elevation record, segment by segment.
pub(super) fn run_measured(
    config: &Config,
    path: &Path,
    edge_s: f64,
    station: &Station,
) -> anyhow::Result<()> {
    let started = Instant::now();
    let (cfg, rate_hz) = (&config.sim, config.rate_hz);
    let file = File::open(path).with_context(|| format!("cannot read {}", path.display()))?;
    let data = MotionData::read_with_gaps(std::io::BufReader::new(file))
        .with_context(|| path.display().to_string())?;
    let wave = data.column("wave_m").with_context(|| {
        format!(
            "{}: line 1: no 'wave_m' column (an elevation record has columns time_s,wave_m)",
            path.display()
        )
    })?;
    // The checks every record's stamps get (eval, replay): stamps in milliseconds read as a
    // record 1000 times longer, and were expanded into hundreds of thousands of rows
    // (regression, review).
    shipcast_series::median_rate(&data.time).with_context(|| path.display().to_string())?;
    check_wave_height(path, wave)?;
    // Regression (review): a 500 m spike in a 0.74 m sea was simulated without a word.
    crate::eval::warn_of_spikes(
        path,
        &data,
        "the simulation takes them as waves and the ship answers them",
    );
    let segments = split_segments(&data.time, wave).with_context(|| path.display().to_string())?;
    let rao = build_rao(&cfg.rao)?;
    let (beta, speed) = (cfg.heading_deg.to_radians(), cfg.speed_mps());
    if let Some(why) = rao.coverage_gap(speed, station.direction(beta).to_degrees()) {
        tracing::warn!("RAO table: {why}");
    }
    if speed > 0.0 {
        tracing::info!(
            "speed {} kn: each Fourier line of the record is met at its encounter frequency \
             (long-crested frozen-field approximation; wave_m is the elevation at the moving CG)",
            cfg.speed_kn
        );
    }
    if *station != Station::REFERENCE {
        tracing::info!(
            "vessel at {} m forward, {} m starboard of the record's CG, heading {} deg to \
             starboard of the reference vessel (waves from {} deg relative to the reference bow)",
            station.x_m,
            station.y_m,
            station.heading_offset_deg,
            cfg.heading_deg
        );
    }
    let input_rate = segments.first().map_or(0.0, |s| 1.0 / s.dt_s);
    if rate_hz < input_rate {
        tracing::warn!(
            "--rate {} Hz is below the record's {} Hz: the output is sampled without an \
             anti-alias filter",
            rate_hz,
            input_rate
        );
    }
    // Checked before writing: a record whose samples lie far apart in time (a corrupt or
    // mis-scaled time column) would otherwise fill the disk at --rate.
    let rows: f64 = segments
        .iter()
        .map(|s| s.values.len() as f64 * s.dt_s * rate_hz)
        .sum();
    if rows > super::config::MAX_ROWS as f64 {
        anyhow::bail!(
            "{}: its segments span {:.3e} s, {rows:.0} rows at --rate {rate_hz} Hz, at most {}",
            path.display(),
            rows / rate_hz,
            super::config::MAX_ROWS
        );
    }
    // Every row sums one term per Fourier line of its segment (half its samples), so the
    // work grows with the record's length squared: hours of record at a high rate take
    // minutes, and would look like a hang without the bar (and, off a terminal, the estimate).
    let terms: f64 = segments
        .iter()
        .map(|s| s.values.len() as f64 * s.dt_s * rate_hz * (s.values.len() / 2) as f64)
        .sum();
    if terms > 1e10 {
        tracing::info!(
            "{rows:.0} rows summing {:.1e} Fourier terms in all: about a minute per 1e10 terms",
            terms
        );
    }
    let bar = crate::progress::styled(rows as u64, "{elapsed_precise} [{bar:30}] {pos}/{len} rows");
    let mut out = RecordOut::create(&config.out)?;
    let mut previous_end: Option<f64> = None;
    let (mut written, mut skipped) = (0usize, 0usize);
    for seg in &segments {
        let Some(response) = SegmentResponse::new(seg, rao.as_ref(), beta, speed, edge_s, station)?
        else {
            skipped += 1;
            // One line, not one per segment: a record with a NaN every other sample has
            // thousands of one-sample segments (review: 2400 lines).
            if skipped == 1 {
                tracing::warn!(
                    "segment {:.2}..{:.2} s ({} samples) is not longer than twice --edge-s {} s: skipped (further ones are counted at the end)",
                    seg.start_s,
                    seg.end_s(),
                    seg.values.len(),
                    edge_s
                );
            }
            continue;
        };
        let rows_before = out.rows;
        let mut first_t = None;
        let mut last_t = 0.0;
        for p in response.stream(rate_hz)? {
            if let Some(end) = previous_end {
                if first_t.is_none() {
                    tracing::info!(
                        "gap: the output jumps from {end:.3} s to {:.3} s ({:.1} s missing)",
                        p.time_s,
                        p.time_s - end
                    );
                }
            }
            first_t.get_or_insert(p.time_s);
            last_t = p.time_s;
            out.write(&p)?;
            if out.rows % 4096 == 0 {
                bar.set_position(out.rows);
            }
        }
        if out.rows > rows_before {
            written += 1;
            previous_end = Some(last_t);
            tracing::info!(
                "segment {:.2}..{:.2} s of the record ({} samples at {:.3} Hz): wrote {:.3}..{last_t:.3} s, {} rows",
                seg.start_s,
                seg.end_s(),
                seg.values.len(),
                1.0 / seg.dt_s,
                first_t.unwrap_or(last_t),
                out.rows - rows_before
            );
        }
    }
    bar.finish_and_clear();
    if skipped > 1 {
        tracing::warn!(
            skipped,
            "{skipped} segments not longer than twice --edge-s {edge_s} s were skipped in all"
        );
    }
    if written == 0 {
        // Regression (review): a header-only file was left to be taken for a record. Dropped
        // unfinished, a regular file is removed (a pipe or a device is left alone).
        drop(out);
        anyhow::bail!(
            "{}: no segment is longer than twice --edge-s {} s ({} segments, {} skipped)",
            path.display(),
            edge_s,
            segments.len(),
            skipped
        );
    }
    let rows = out.rows;
    tracing::info!(
        "wrote {rows} rows at {} Hz from {} ({written} segments written, {skipped} skipped; \
         waves from {} deg, {} kn) to {} in {:.2} s",
        rate_hz,
        path.display(),
        cfg.heading_deg,
        cfg.speed_kn,
        config.out.display(),
        started.elapsed().as_secs_f64()
    );
    for ch in Channel::ALL {
        let rms = out.rms(ch);
        tracing::info!("{:<10} RMS {rms:.4}{}", ch.column(), degrees(ch, rms));
    }
    out.finish()
}

/// The significant wave height (4 standard deviations) of a measured elevation record, over its
/// finite values, refused where no sea has it: a constant record (all zeros: a channel that
/// sent nothing) drives no motion at all, and one of 30 m or more is in other units (wave_m in
/// millimetres drove a roll of 44 deg RMS and a pitch of 505 deg; review). `simulate` refuses
/// such an Hs for a simulated sea too.
fn check_wave_height(path: &Path, wave: &[f64]) -> anyhow::Result<()> {
    let finite: Vec<f64> = wave.iter().copied().filter(|v| v.is_finite()).collect();
    if finite.is_empty() {
        // The segments' own check says there is no data.
        return Ok(());
    }
    let hs = 4.0 * shipcast_eval::run::std_dev(&finite);
    // Exactly one value, not a spread of 0: the mean of a constant 0.1 differs from it by
    // rounding, and its "spread" of 1e-16 m passed (review).
    let (low, high) = finite
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
            (l.min(v), h.max(v))
        });
    if low == high || hs.is_nan() {
        anyhow::bail!(
            "{}: wave_m is constant ({low}): no waves to drive the ship with",
            path.display()
        );
    }
    if hs >= shipcast_sim::scenario::MAX_HS_M {
        anyhow::bail!(
            "{}: wave_m has a significant wave height of {hs:.3e} m (4 standard deviations), beyond the {} m of any sea: is it in millimetres or centimetres? wave_m is in metres",
            path.display(),
            shipcast_sim::scenario::MAX_HS_M
        );
    }
    Ok(())
}
