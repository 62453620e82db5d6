#!/usr/bin/env python3
"""Add white Gaussian noise to the six DOF columns of a motion CSV, as a motion sensor would:
noise of PCT % of each column's own std, from a seeded generator. time_s, wave_m and any other
column are copied unchanged. Python standard library only.

    python3 scripts/add_sensor_noise.py --input REC.csv --out REC_noisy.csv --pct 1 --seed 1
"""
import argparse
import math
import random
import sys

DOF_COLUMNS = ("surge_m", "sway_m", "heave_m", "roll_rad", "pitch_rad", "yaw_rad")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--input", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--pct", type=float, default=1.0, help="noise std, %% of each DOF's std")
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args()
    if not (a.pct >= 0.0 and math.isfinite(a.pct)):
        sys.exit(f"add_sensor_noise: --pct must be a finite number >= 0, got {a.pct}")
    with open(a.input) as f:
        header = f.readline().rstrip("\n").split(",")
        rows = [line.rstrip("\n").split(",") for line in f if line.strip()]
    columns = [i for i, name in enumerate(header) if name in DOF_COLUMNS]
    if not columns:
        sys.exit(f"add_sensor_noise: {a.input} has none of the columns {', '.join(DOF_COLUMNS)}")
    rng = random.Random(a.seed)
    for j in columns:
        try:
            values = [float(r[j]) for r in rows]
        except (ValueError, IndexError) as e:
            sys.exit(f"add_sensor_noise: {a.input}, column {header[j]}: {e}")
        # A gap's non-finite values stay as they are and do not count in the std.
        finite = [v for v in values if math.isfinite(v)]
        if not finite:
            continue
        mean = sum(finite) / len(finite)
        std = math.sqrt(sum((v - mean) ** 2 for v in finite) / len(finite))
        for r, v in zip(rows, values):
            noise = rng.gauss(0.0, 1.0)
            if math.isfinite(v):
                r[j] = repr(v + a.pct / 100.0 * std * noise)
    with open(a.out, "w") as f:
        f.write(",".join(header) + "\n")
        for r in rows:
            f.write(",".join(r) + "\n")


if __name__ == "__main__":
    main()
