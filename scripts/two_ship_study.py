#!/usr/bin/env python3
"""Replay two ships in the same simulated paper sea through their engines and score the
relative-motion forecast against the true relative motion, beside each ship's own forecast, on
the four geometries of docs/two_ships.md (the tables there are this script's output).

Geometries (ship A, the crane ship, is the same record in all four):
- default: B 40 m to starboard, bow +10 deg (the `[relative]` defaults);
- same heading: B 40 m to starboard, bow 0 deg;
- close: B 15 m ahead, its landing spot at the crane tip's lever arm;
- turned: B 40 m to starboard, bow +30 deg, a 100 m hull.

On a measured sea (`--elevation data/wafo/gfaks89.csv`, fetched by scripts/fetch_wafo.py) both
ships are driven by the measured record (`simulate --elevation`, zero speed, waves from
`--heading-deg`), B placed as in each geometry; the records are cut at their first time jump (a
gap in the measured record), so the study runs on the first gap-free stretch.

Run from the repository root after `cargo build --release`; about a minute on 2 cores for the
simulated sea, a few minutes for Gullfaks. Python standard library only.
"""
import argparse
import json
import os
import subprocess
import sys

# The repository's release build, wherever the script is run from (SHIPCAST_BIN: another).
BIN = os.environ.get("SHIPCAST_BIN", os.path.join(
    os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "target", "release", "shipcast"))
SEA = ["--scenario", "paper", "--duration", "3600", "--rate", "8"]
SKIP_S = "1200"

# name, extra `simulate` arguments for ship B, `[relative]` configuration
GEOMETRIES = [
    ("default: B 40 m to starboard, bow +10 deg",
     ["--vessel-y-m", "40", "--vessel-heading-offset-deg", "10"], ""),
    ("same heading, B 40 m to starboard",
     ["--vessel-y-m", "40"], "target_heading_offset_deg = 0.0\n"),
    ("B 15 m ahead, spot at the tip's lever arm",
     ["--vessel-x-m", "15"],
     "target_position_m = [15.0, 0.0]\ntarget_heading_offset_deg = 0.0\n"
     "landing_spot_m = [10.0, 15.0, -20.0]\n"),
    ("B 40 m to starboard, bow +30 deg, 100 m hull",
     ["--vessel-y-m", "40", "--vessel-heading-offset-deg", "30", "--hull-length", "100"],
     "target_heading_offset_deg = 30.0\n"),
]


def run(args):
    try:
        out = subprocess.run([BIN] + args, capture_output=True, text=True)
    except OSError as e:
        sys.exit(f"two_ship_study: cannot run {BIN} ({e.strerror}): build it with "
                 "`cargo build --release`, or set SHIPCAST_BIN")
    if out.returncode != 0:
        sys.exit(f"two_ship_study: shipcast {' '.join(args)} failed: {out.stderr.strip()}")
    return out.stdout


def cut_at_first_jump(path):
    """Keeps a motion CSV's rows up to its first time jump (above 1.5 sample intervals)."""
    with open(path) as f:
        lines = f.readlines()
    times = [float(l.split(",", 1)[0]) for l in lines[1:3]]
    dt = times[1] - times[0]
    keep, last = 1, None
    for line in lines[1:]:
        t = float(line.split(",", 1)[0])
        if last is not None and t - last > 1.5 * dt:
            break
        keep, last = keep + 1, t
    if keep < len(lines):
        with open(path, "w") as f:
            f.writelines(lines[:keep])
        print(f"two_ship_study: {os.path.basename(path)} cut at its first time jump, "
              f"{last:.1f} s", file=sys.stderr)


def relative(work, sea, tag, index, sim, config, raw_mean=False):
    a = os.path.join(work, f"a_{tag}.csv")
    if not os.path.exists(a):
        run(["simulate"] + sea + ["--out", a])
        cut_at_first_jump(a)
    b = os.path.join(work, f"b{index}_{tag}.csv")
    run(["simulate"] + sea + sim + ["--out", b])
    cut_at_first_jump(b)
    args = ["relative", "--crane-record", a, "--target-record", b, "--skip-s", SKIP_S, "--json"]
    if raw_mean:
        config += "shrink_mean = false\n"
    if config:
        path = os.path.join(work, f"relative{index}.toml")
        with open(path, "w") as f:
            f.write("[relative]\n" + config)
        args += ["--config", path]
    lines = [l for l in run(args).splitlines() if l.strip().startswith("{")]
    if len(lines) != 1:
        sys.exit(f"two_ship_study: expected one JSON report from `shipcast relative`, got {len(lines)}")
    return json.loads(lines[0])


def f3(v):
    return "-" if v is None else f"{v:.3f}"


def coverage_band(rows):
    c1 = [r["coverage_1sigma"] for r in rows]
    c2 = [r["coverage_2sigma"] for r in rows]
    return f"+-1 sigma {min(c1):.3f}-{max(c1):.3f}, +-2 sigma {min(c2):.3f}-{max(c2):.3f}"


def point_coverage(rows, point):
    """Coverage of one ship's own point sigma per axis, over leads (`point`: tip, spot, or
    tip_calibrated, the tip's sigma as `shipcast crane` scales it)."""
    parts = []
    for axis in ("x", "y", "z"):
        sel = [r for r in rows if r["axis"] == axis]
        c1 = [r[f"{point}_coverage_1sigma"] for r in sel]
        c2 = [r[f"{point}_coverage_2sigma"] for r in sel]
        parts.append(f"{axis} {min(c1):.2f}-{max(c1):.2f} / {min(c2):.2f}-{max(c2):.2f}")
    return ", ".join(parts)


def bins_off(lift):
    """Reliability bins of at least 50 calls more than 5 points off, as text."""
    off = [f"{b['stated']:.3f} observed {b['observed']:.3f} ({b['count']} calls, "
           f"{b['episodes']} episodes)"
           for b in lift["reliability"]
           if b["count"] >= 50 and abs(b["observed"] - b["stated"]) > 0.05]
    return f"{len(off)}" + (": " + "; ".join(off) if off else "")


def lift_line(report):
    """The lift decisions as issued and the Gaussian model's on the same calls."""
    rows = []
    for name, key in (("as issued", "lift"), ("Gaussian model", "lift_gaussian")):
        l = report[key]
        rows.append(f"{name}: {l['calls']} calls, {l['go_calls']} go at {l['go_probability']}, "
                    f"false go {f3(l['false_go_rate'])}, Brier {l['brier']:.4f} (base rate's "
                    f"{l['brier_climatology']:.4f}), bins off {bins_off(l)}")
    return f"Lift decisions (MOT {report['lift']['mot_s']:.0f} s): " + "; ".join(rows) + "."


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--work", default=os.path.join("target", "two-ship-study"))
    ap.add_argument("--seed", type=int, default=1, help="the sea's realisation (default 1)")
    ap.add_argument("--elevation", help="drive both ships with this measured elevation CSV "
                    "instead of the simulated paper sea")
    ap.add_argument("--heading-deg", type=float, default=165.0,
                    help="with --elevation: where the waves come from, relative to A's bow")
    ap.add_argument("--raw-mean", action="store_true",
                    help="issue the raw difference of the two forecasts as the relative mean "
                    "(relative.shrink_mean = false), for comparison")
    args = ap.parse_args()
    work = args.work
    os.makedirs(work, exist_ok=True)
    if args.elevation:
        if not os.path.exists(args.elevation):
            sys.exit(f"two_ship_study: {args.elevation} not found (python3 scripts/fetch_wafo.py "
                     "fetches the measured records)")
        sea = ["--elevation", args.elevation, "--heading-deg", str(args.heading_deg),
               "--speed-kn", "0", "--rate", "8"]
        stem = os.path.splitext(os.path.basename(args.elevation))[0]
        tag, label = f"{stem}_{args.heading_deg:g}", f"{stem}, waves from {args.heading_deg:g} deg"
    else:
        sea = SEA + ["--seed", str(args.seed)]
        tag, label = f"seed{args.seed}", f"seed {args.seed}"
    for i, (name, sim, config) in enumerate(GEOMETRIES):
        report = relative(work, sea, tag, i, sim, config, args.raw_mean)
        leads = report["leads"]
        print(f"## {name} ({label})\n")
        print(f"{report['scored']} relative forecasts scored from {SKIP_S} s; sigma calibrated "
              f"from {report['calibrated_from_s']} s; {coverage_band(leads)} over every axis "
              f"and lead.\n")
        print(lift_line(report) + "\n")
        print("Each ship's own point sigma, linearised from its DOF sigmas taken as independent "
              "(what `shipcast crane` prints for its tip until enough tip forecasts are verified), +-1 / +-2 sigma coverage over the "
              f"leads: A's tip {point_coverage(leads, 'tip')}; B's spot "
              f"{point_coverage(leads, 'spot')}. A's tip sigma scaled by its verified forecasts, "
              f"as `shipcast crane` issues it: {point_coverage(leads, 'tip_calibrated')}.\n")
        print("| axis | lead | rel_rms | raw_rms | rel_std | tip_rms (A) | spot_rms (B) | err_corr | sigma "
              "| sigma_ind | cov1 | cov2 | cov1_ind | cov2_ind |")
        print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
        for r in sorted(leads, key=lambda r: (r["lead_s"], r["axis"])):
            print(f"| {r['axis']} | {r['lead_s']:.0f} s | {f3(r['relative_rms'])} | "
                  f"{f3(r['relative_raw_rms'])} | {f3(r['relative_zero_rms'])} | {f3(r['tip_rms'])} | {f3(r['spot_rms'])} | "
                  f"{r['error_correlation']:+.2f} | {f3(r['mean_sigma'])} | "
                  f"{f3(r['mean_sigma_independent'])} | {f3(r['coverage_1sigma'])} | "
                  f"{f3(r['coverage_2sigma'])} | {f3(r['coverage_1sigma_independent'])} | "
                  f"{f3(r['coverage_2sigma_independent'])} |")
        print()
        if i == 0:
            own = [o for o in report["own"] if o["dof"] in ("heave", "roll", "pitch")]
            leads_s = own[0]["lead_s"] if own else []
            print("Each ship's own DOF forecast, RMS error / RMS of the motion (heave in m, "
                  "roll and pitch in rad):\n")
            print("| ship | dof | " + " | ".join(f"{l:.0f} s" for l in leads_s) + " |")
            print("|---|---|" + "---|" * len(leads_s))
            for o in own:
                digits = 3 if o["dof"] == "heave" else 4
                cells = " | ".join(f"{e:.{digits}f}/{z:.{digits}f}"
                                   for e, z in zip(o["rms"], o["zero_rms"]))
                print(f"| {o['vessel']} | {o['dof']} | {cells} |")
            print()


if __name__ == "__main__":
    main()
