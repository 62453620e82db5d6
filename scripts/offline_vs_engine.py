#!/usr/bin/env python3
"""Compare the engine's delivered error 5 s ahead, per DOF, with the offline methods on the same
record, scored both ways: by the evaluation protocol (`shipcast eval`, stride 1: linear-phase
filter, scored against the filtered series) and by the engine's own scoring (`shipcast replay`:
the engine's filter, scored against the record). In the second, an "offline" method is the
engine fitted once on the first 2500 s (one Wiener order, no retraining, no change detection),
so filter, target and lead are the same as the delivered forecast's.

Run from the repository root after `cargo build --release` and `python3 scripts/fetch_wafo.py`.
The record is the first gap-free part of the Gullfaks-driven motion (heading 165 deg, 0 kn,
8 Hz), written to --work (default target/offline-vs-engine). Python standard library only.
"""
import argparse
import json
import os
import subprocess
import sys

# The repository's release build, wherever the script is run from (SHIPCAST_BIN: another).
BIN = os.environ.get("SHIPCAST_BIN", os.path.join(
    os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "target", "release", "shipcast"))
ORDERS = [50, 100, 200]
TRAIN_S = 2500.0  # = eval's default training segment, 5000 values at 2 Hz
STEP = 10  # 5 s at 2 Hz


def run(args):
    try:
        out = subprocess.run([BIN] + args, capture_output=True, text=True)
    except OSError as e:
        sys.exit(f"offline_vs_engine: cannot run {BIN} ({e.strerror}): build it with "
                 "`cargo build --release`, or set SHIPCAST_BIN")
    if out.returncode != 0:
        sys.exit(f"offline_vs_engine: shipcast {' '.join(args)} failed: {out.stderr.strip()}")
    return [json.loads(l) for l in out.stdout.splitlines() if l.strip().startswith("{")]


DOFS = ["surge", "sway", "heave", "roll", "pitch", "yaw"]


def by_dof(rows):
    # A DOF replay could not score has null errors: it cannot be compared, so it is left out.
    return {r["dof"]: r for r in rows if "rms" in r and r["rms"][STEP - 1] is not None}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--work", default=os.path.join("target", "offline-vs-engine"))
    a = ap.parse_args()
    if not os.path.exists("data/wafo/gfaks89.csv"):
        sys.exit("offline_vs_engine: run python3 scripts/fetch_wafo.py first")
    os.makedirs(a.work, exist_ok=True)
    full = os.path.join(a.work, "gfaks_motion.csv")
    part = os.path.join(a.work, "gfaks_part1.csv")
    run(["simulate", "--elevation", "data/wafo/gfaks89.csv", "--heading-deg", "165",
         "--speed-kn", "0", "--rate", "8", "--out", full])
    with open(full) as src, open(part, "w") as dst:
        for i, line in enumerate(src):
            if i == 0 or float(line.split(",", 1)[0]) < 11000.0:
                dst.write(line)
    with open(part) as f:
        next(f)
        t0 = float(next(f).split(",", 1)[0])
    score_from = t0 + TRAIN_S
    print(f"record: {part} (first gap-free part), scored from {score_from:.0f} s; "
          f"RMS error at step {STEP} (5 s), per DOF\n")
    header = "| forecast | " + " | ".join(DOFS) + " |"
    rule = "|---|" + "---|" * len(DOFS)
    protocol, engine = [], []
    best = {d: float("inf") for d in DOFS}
    for o in ORDERS:
        name = f"Wiener-{o} fitted once on the first {TRAIN_S:.0f} s"
        ev = {d: dof_row(run(["eval", "--input", part, "--dof", d, "--method", "wiener",
                                 "--order", str(o), "--json"]), d) for d in DOFS}
        protocol.append(f"| {name} | " + " | ".join(f"{ev[d]['rms'][STEP - 1]:.4g}"
                                                   for d in DOFS) + " |")
        cfg = os.path.join(a.work, f"wiener{o}_once.toml")
        with open(cfg, "w") as f:
            f.write(f"[predictor]\nmethod = \"wiener\"\norder = {o}\ncandidate_orders = [{o}]\n"
                    f"first_fit_s = {TRAIN_S}\nretrain_every_s = 1.0e6\nretrain_window = 5000\n"
                    "holdout = 1000\nchange_ratio = 1000.0\n")
        rp = by_dof(run(["replay", "--input", part, "--config", cfg, "--skip-s",
                         str(score_from), "--json"]))
        for d in DOFS:
            if d in rp:
                best[d] = min(best[d], rp[d]["rms"][STEP - 1])
        engine.append(f"| {name} | " + " | ".join(cell(rp, d, STEP) for d in DOFS) + " |")
    eng = by_dof(run(["replay", "--input", part, "--skip-s", str(score_from), "--json"]))
    engine.append("| the engine as delivered (default configuration) | " + " | ".join(
        cell(eng, d, STEP) for d in DOFS) + " |")
    engine.append("| engine / best single fit | " + " | ".join(
        f"{eng[d]['rms'][STEP - 1] / best[d]:.3f}" if d in eng and best[d] < float("inf")
        else "-" for d in DOFS) + " |")
    print("Protocol scoring (shipcast eval, stride 1):\n")
    print("\n".join([header, rule] + protocol))
    print("\nEngine scoring (shipcast replay):\n")
    print("\n".join([header, rule] + engine))
    print(f"\nThe engine's step {STEP - 1}, the same real lead (4.0 s after the newest sample) as "
          f"eval's step {STEP}: " + " / ".join(cell(eng, d, STEP - 1) for d in DOFS))


def cell(rows, dof, step):
    """The RMS error of `dof` at `step` (1-based) for a table cell, "-" where there is none."""
    r = rows.get(dof)
    v = r["rms"][step - 1] if r else None
    return "-" if v is None else f"{v:.4g}"


def dof_row(rows, dof):
    """eval's JSON object for `dof`."""
    return next(r for r in rows if r.get("dof") == dof)


if __name__ == "__main__":
    main()
