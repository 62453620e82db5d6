#!/usr/bin/env python3
"""Replay the predictor's engine over the four records of the robustness study and print what
an operator needs to know: error relative to predicting the motion's mean (its std) at every
lead, coverage of the
sigma bands, the largest error, and how fast the error recovers after a change of sea.

Run from the repository root after `cargo build --release` and `python3 scripts/fetch_wafo.py`
(the measured record is non-commercial data and never committed). Records are written to
--work (default target/replay-study). Python standard library only.
"""
import argparse
import json
import math
import os
import subprocess
import sys

# The repository's release build, wherever the script is run from (SHIPCAST_BIN: another).
BIN = os.environ.get("SHIPCAST_BIN", os.path.join(
    os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "target", "release", "shipcast"))

RECORDS = [
    # name, simulate arguments, time of the change [s] or None
    ("paper sea, start-up model from another seed",
     ["--scenario", "paper", "--duration", "3600", "--seed", "1"], None),
    ("Gullfaks C measured waves (North Sea 1989), 0 kn",
     ["--elevation", "data/wafo/gfaks89.csv", "--heading-deg", "165", "--speed-kn", "0"], None),
    ("course change head -> beam seas at 1800 s",
     ["--scenario", "paper", "--heading-deg", "180", "--duration", "3600", "--seed", "1",
      "--course-change-s", "1800", "--new-heading-deg", "90", "--turn-s", "60"], 1800.0),
    ("sea-state change SS4 -> Hs 5 m Tp 12.4 s at 1800 s",
     ["--scenario", "ss4", "--duration", "3600", "--seed", "1", "--sea-change-s", "1800",
      "--new-hs", "5.0", "--new-tp", "12.4", "--ramp-s", "300"], 1800.0),
]

LEADS = [5.0, 10.0, 20.0]


def run(args):
    try:
        out = subprocess.run([BIN] + args, capture_output=True, text=True)
    except OSError as e:
        sys.exit(f"replay_study: cannot run {BIN} ({e.strerror}): build it with "
                 "`cargo build --release`, or set SHIPCAST_BIN")
    if out.returncode != 0:
        sys.exit(f"replay_study: shipcast {' '.join(args)} failed: {out.stderr.strip()}")
    return out.stdout


CONFIG = []


def replay(path, skip_s):
    text = run(["replay", "--input", path, "--skip-s", str(skip_s), "--json"] + CONFIG)
    rows = [json.loads(line) for line in text.splitlines() if line.strip()]
    # The per-DOF lines only: replay's `{"decisions": ...}` lines (one per station and MOT)
    # follow them and are the decisions study's business (docs/decisions.md).
    return [r for r in rows if "dof" in r]


def recovery_minutes(trace, change_s, window=3):
    """Minutes after the change until the 10 s error, over `window`-minute windows, stays
    within 20 % of its new steady state (the last 15 minutes of the record)."""
    vals = [(i, v) for i, v in enumerate(trace) if v is not None and not math.isnan(v)]
    if not vals:
        return float("nan")
    last = [v for i, v in vals[-15:]]
    steady = math.sqrt(sum(v * v for v in last) / len(last))
    start = int(change_s // 60)
    by_min = {i: v for i, v in vals}
    ends = sorted(i for i in by_min if i >= start + window - 1)
    def win(end):
        w = [by_min[j] for j in range(end - window + 1, end + 1) if j in by_min]
        return math.sqrt(sum(v * v for v in w) / len(w)) if w else float("nan")
    for end in ends:
        if all(abs(win(e) / steady - 1.0) <= 0.2 for e in ends if e >= end):
            return end + 1 - start
    return float("nan")


def ensemble(work, seeds, duration):
    """Recovery on the two change records averaged over `seeds` realisations of `duration` s:
    one record's 3-minute RMS swings by about 20 % with the wave groups alone, so a single
    record measures mostly those; the mean square per minute over several seeds measures the
    engine."""
    for i, (name, sim, change_s) in enumerate(RECORDS):
        if change_s is None:
            continue
        traces = []
        for seed in range(1, seeds + 1):
            args = list(sim)
            args[args.index("--duration") + 1] = str(duration)
            args[args.index("--seed") + 1] = str(seed)
            path = os.path.join(work, f"ensemble{i + 1}_{duration}_{seed}.csv")
            run(["simulate"] + args + ["--rate", "8", "--out", path])
            traces.append(replay(path, 60.0))
        print(f"\n## {name}: {seeds} seeds, {duration} s\n")
        print("| dof | recovery [min] | the motion's own [min] |")
        print("|---|---|---|")
        for d in range(len(traces[0])):
            def mean_rms(key):
                rows = [t[d][key] for t in traces]
                return [math.sqrt(sum(r[m] ** 2 for r in rows) / len(rows))
                        if all(r[m] is not None for r in rows) else float("nan")
                        for m in range(len(rows[0]))]
            rec = recovery_minutes(mean_rms("rms_10s_by_minute"), change_s)
            own = recovery_minutes(mean_rms("zero_rms_10s_by_minute"), change_s)
            print(f"| {traces[0][d]['dof']} | {rec:.0f} | {own:.0f} |")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--work", default=os.path.join("target", "replay-study"))
    ap.add_argument("--ensemble", type=int, default=0, metavar="SEEDS",
                    help="instead: recovery on the change records averaged over SEEDS seeds")
    ap.add_argument("--duration", type=float, default=5400.0,
                    help="record length for --ensemble [s] (default 5400)")
    ap.add_argument("--config", metavar="F.toml",
                    help="pipeline configuration for every replay (default: the built-in one)")
    a = ap.parse_args()
    if a.config:
        CONFIG.extend(["--config", a.config])
    os.makedirs(a.work, exist_ok=True)
    if a.ensemble > 0:
        ensemble(a.work, a.ensemble, int(a.duration))
        return
    for i, (name, sim, change_s) in enumerate(RECORDS):
        path = os.path.join(a.work, f"record{i + 1}.csv")
        if "--elevation" in sim and not os.path.exists(sim[sim.index("--elevation") + 1]):
            print(f"\n## {name}: skipped (run python3 scripts/fetch_wafo.py first)")
            continue
        run(["simulate"] + sim + ["--rate", "8", "--out", path])
        first = replay(path, 60.0)
        later = replay(path, 1200.0)
        print(f"\n## {name}\n")
        print("| dof | NRMSE 5/10/20 s | max NRMSE, any lead | max error / std | "
              "largest error / sigma (at s, lead s) | beyond 3 sigma | "
              "1 sigma 5/10/20 s (after 20 min) | 2 sigma 5/10/20 s | implausible | recovery [min] | "
              "the motion's own [min] |")
        print("|---|---|---|---|---|---|---|---|---|---|---|")
        for d, l in zip(first, later):
            k = [int(round(t / 0.5)) - 1 for t in LEADS]
            fmt = lambda xs: " / ".join(f"{x:.3f}" for x in xs)
            rec = recovery_minutes(d["rms_10s_by_minute"], change_s) if change_s else None
            # The same measure applied to predicting zero: how long the motion itself takes to
            # settle by it (wave groups alone move a 3-minute RMS by about 20 %).
            own = recovery_minutes(d["zero_rms_10s_by_minute"], change_s) if change_s else None
            print(f"| {d['dof']} | {fmt(d['nrmse'][j] for j in k)} | {max(d['nrmse']):.4f} | "
                  f"{d['max_abs_error'] / d['std']:.2f} | "
                  f"{d['max_abs_z']:.1f} ({d['max_abs_z_time_s']:g}, {d['max_abs_z_lead_s']:g}) | "
                  f"{d['beyond_3sigma']:.4f} | {fmt(l['coverage_1sigma'][j] for j in k)} | "
                  f"{fmt(l['coverage_2sigma'][j] for j in k)} | {d['implausible']} | "
                  f"{'-' if rec is None else f'{rec:.0f}'} | {'-' if own is None else f'{own:.0f}'} |")


if __name__ == "__main__":
    main()
