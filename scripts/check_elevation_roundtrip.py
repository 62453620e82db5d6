#!/usr/bin/env python3
"""Check that `shipcast simulate --elevation REC --speed-kn 0` reproduces the record.

    python3 scripts/check_elevation_roundtrip.py data/wafo/gfaks89.csv MOTION.csv

At zero speed the motion CSV's `wave_m`, at the instants where its time grid meets the record's,
must equal the record minus its segment's mean. Prints the number of instants compared and the
largest difference [m]. Standard library only.
"""

import csv
import sys


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__.strip().splitlines()[2].strip())
    record_path, motion_path = sys.argv[1], sys.argv[2]
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


if __name__ == "__main__":
    main()
