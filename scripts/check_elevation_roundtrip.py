#!/usr/bin/env python3
"""Check that `shipcast simulate --elevation REC --speed-kn 0` reproduces the record.

    python3 scripts/check_elevation_roundtrip.py data/wafo/gfaks89.csv MOTION.csv

At zero speed the motion CSV's `wave_m`, at the instants where its time grid meets the record's,
must equal the record minus its segment's mean. Prints the number of instants compared and the
largest difference [m]. Exit status 1 when no instant could be compared (grids that never meet,
a motion file without rows) or the largest difference exceeds 1e-6 m. Standard library only.
"""

import csv
import sys


# Largest difference that is still "the record": the round trip is exact to float rounding
# (2e-11 m on Gullfaks).
TOLERANCE_M = 1e-6


def main():
    if len(sys.argv) != 3 or sys.argv[1] in ("-h", "--help"):
        sys.exit(__doc__.strip().splitlines()[2].strip())
    try:
        return check(sys.argv[1], sys.argv[2])
    except (OSError, KeyError, ValueError, IndexError) as e:
        sys.exit(f"check_elevation_roundtrip: {type(e).__name__}: {e}")


def check(record_path, motion_path):
    times, values = [], []
    with open(record_path, newline="") as f:
        for row in csv.DictReader(f):
            times.append(float(row["time_s"]))
            values.append(float(row["wave_m"]))
    # Segments: split where the step exceeds 1.5 times the first step (NaN rows are absent).
    step = times[1] - times[0]
    segments, start = [], 0
    for i in range(1, len(times) + 1):
        if i == len(times) or times[i] - times[i - 1] > 1.5 * step:
            chunk = values[start:i]
            segments.append((times[start], times[i - 1], sum(chunk) / len(chunk)))
            start = i
    by_time = {round(t / step): (t, z) for t, z in zip(times, values)}
    compared, worst = 0, 0.0
    with open(motion_path, newline="") as f:
        for row in csv.DictReader(f):
            t = float(row["time_s"])
            k = round(t / step)
            if k in by_time and abs(by_time[k][0] - t) < 1e-6:
                mean = next(m for a, b, m in segments if a <= t <= b)
                worst = max(worst, abs(float(row["wave_m"]) - (by_time[k][1] - mean)))
                compared += 1
    print(f"compared {compared} instants, largest |wave_m - (record - mean)| = {worst:.3g} m")
    if compared == 0:
        sys.exit("check_elevation_roundtrip: no instant of the motion file is on the record's grid")
    if worst > TOLERANCE_M:
        sys.exit(f"check_elevation_roundtrip: the motion differs from the record by more than {TOLERANCE_M} m")
    return 0


if __name__ == "__main__":
    sys.exit(main())
