#!/usr/bin/env python3
"""Re-derive the lift's statements offline from `shipcast relative --calls-csv` and ask where
their honesty is lost: one step at a time, one axis at a time, the whole window, with and
without the errors' regression on the mean (docs/two_ships.md, "On a measured sea").

The ensemble is replayed as `decision::ensemble` builds it, approximately: the members are the
calls issued at least --delay-s (the forecast horizon: a forecast is verified when its last step
has passed) and at most --ring-s before, one in --stride, at least 150 of them; a call's
standardised error path u = (actual - mean) / sigma and mean z = mean / sigma per axis and step;
per axis and step the least-squares slope c of u on z (clamped to +-1); a member holds when
|mean + sigma (c z_now + u_m - c z_m)| stays within the limit; the statement is
(held + 1) / (members + 2). The service's members also include forecasts from before --skip-s,
which the file does not hold, so the replay starts --ring-s into it; the "replay vs service"
line says how close it comes to the statements the service made.

Usage (after `shipcast relative ... --calls-csv calls.csv`):
    python3 scripts/lift_window_diagnosis.py calls.csv [--every 7]
Python standard library only; about 3 minutes on 20000 calls at --every 7, 20 at --every 1.
"""
import argparse
import bisect
import csv
import statistics
import sys

AXES = ("x", "y", "z")


def load(path):
    with open(path, newline="") as f:
        reader = csv.reader(f)
        header = next(reader, None)
        if header is None:
            sys.exit(f"lift_window_diagnosis: {path} is empty")
        col = {name: i for i, name in enumerate(header)}
        window = (len(header) - 6) // 9
        calls = []
        for line, row in enumerate(reader, start=2):
            if len(row) != len(header):
                sys.exit(f"lift_window_diagnosis: {path}: line {line}: {len(row)} cells, "
                         f"the header has {len(header)}")
            v = lambda name: float(row[col[name]])
            mean = [[v(f"mean_{a}_{k}") for k in range(1, window + 1)] for a in AXES]
            sigma = [[v(f"sigma_{a}_{k}") for k in range(1, window + 1)] for a in AXES]
            actual = [[v(f"actual_{a}_{k}") for k in range(1, window + 1)] for a in AXES]
            u = [[(actual[a][k] - mean[a][k]) / sigma[a][k] if sigma[a][k] > 0 else 0.0
                  for k in range(window)] for a in range(3)]
            z = [[mean[a][k] / sigma[a][k] if sigma[a][k] > 0 else 0.0
                  for k in range(window)] for a in range(3)]
            raw = row[col["uncorrected"]]
            calls.append(dict(t=v("time_s"), raw=float(raw) if raw else None, mean=mean,
                              sigma=sigma, actual=actual, u=u, z=z))
    return calls, window


def slope(members, a, k):
    zz = sum(m["z"][a][k] ** 2 for m in members)
    uz = sum(m["u"][a][k] * m["z"][a][k] for m in members)
    return max(-1.0, min(1.0, uz / zz)) if zz > 1e-6 else 0.0


def statement(call, members, axes, steps, limits, regress):
    c = {(a, k): slope(members, a, k) if regress else 0.0 for a in axes for k in steps}
    held = 0
    for m in members:
        held += all(
            abs(call["mean"][a][k] + call["sigma"][a][k]
                * (c[a, k] * call["z"][a][k] + m["u"][a][k] - c[a, k] * m["z"][a][k]))
            <= limits[a]
            for a in axes for k in steps)
    return (held + 1) / (len(members) + 2)


def amplitude_factors(call, limits):
    """Per axis, the least-squares factor b of the true displacement on the mean over the
    window (clamped to 0..2) and the rest of the error, (actual - b mean) / sigma."""
    factors, rests = [], []
    for a in range(3):
        m, x, s = call["mean"][a], call["actual"][a], call["sigma"][a]
        mm = sum(v * v for v in m)
        b = max(0.0, min(2.0, sum(p * q for p, q in zip(m, x)) / mm)) if mm > 1e-9 else 1.0
        factors.append(b)
        rests.append([(x[k] - b * m[k]) / s[k] if s[k] > 0 else 0.0 for k in range(len(m))])
    return factors, rests


def transplanted(call, members, limits):
    """Each member's own amplitude factor and the rest of its error put on the call."""
    held = 0
    for m in members:
        b, r = m["amplitude"]
        held += all(abs(b[a] * call["mean"][a][k] + call["sigma"][a][k] * r[a][k]) <= limits[a]
                    for a in range(3) for k in range(len(r[a])))
    return (held + 1) / (len(members) + 2)


def table(name, pairs):
    print(f"{name} ({len(pairs)} calls): stated / observed (calls) per bin")
    cells = []
    for b in range(10):
        sel = [(p, h) for p, h in pairs if min(int(p * 10), 9) == b]
        if len(sel) >= 20:
            stated = statistics.mean(p for p, _ in sel)
            observed = statistics.mean(h for _, h in sel)
            flag = " *" if abs(observed - stated) > 0.05 and len(sel) >= 50 else ""
            cells.append(f"{stated:.3f}/{observed:.3f} ({len(sel)}){flag}")
    print("  " + "; ".join(cells))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("calls", help="the CSV of `shipcast relative --calls-csv`")
    ap.add_argument("--every", type=int, default=7, help="judge one call in N (default 7)")
    ap.add_argument("--delay-s", type=float, default=25.0, help="forecast horizon [s]")
    ap.add_argument("--ring-s", type=float, default=1200.0, help="ensemble span [s]")
    ap.add_argument("--stride", type=int, default=4, help="one verified forecast kept in N")
    ap.add_argument("--limits", default="1,1,1", help="x,y,z limits [m] (default 1,1,1)")
    args = ap.parse_args()
    limits = [float(x) for x in args.limits.split(",")]
    calls, window = load(args.calls)
    times = [c["t"] for c in calls]
    all_axes, all_steps = (0, 1, 2), range(window)
    variants = {
        "window, all axes (the service's rule)": (all_axes, all_steps, True),
        "window, all axes, no regression on the mean": (all_axes, all_steps, False),
        "window, x alone": ((0,), all_steps, True),
        "window, z alone": ((2,), all_steps, True),
        f"z at step {window // 2} alone": ((2,), (window // 2 - 1,), True),
        f"z at step {window} alone": ((2,), (window - 1,), True),
        f"z over steps 1-{window // 2}": ((2,), range(window // 2), True),
        f"z over steps {window // 2 + 1}-{window}": ((2,), range(window // 2, window), True),
    }
    transplant = "window, all axes, each member's own amplitude factor put on the call"
    for call in calls:
        call["amplitude"] = amplitude_factors(call, limits)
    results = {name: [] for name in list(variants) + [transplant]}
    replay_vs_service = []
    for i in range(0, len(calls), args.every):
        call = calls[i]
        hi = bisect.bisect_right(times, call["t"] - args.delay_s)
        lo = bisect.bisect_left(times, call["t"] - args.delay_s - args.ring_s)
        members = calls[lo:hi:args.stride]
        if len(members) < 150 or call["t"] - times[0] < args.ring_s + args.delay_s:
            continue
        for name, (axes, steps, regress) in variants.items():
            p = statement(call, members, axes, steps, limits, regress)
            held = all(abs(call["actual"][a][k]) <= limits[a] for a in axes for k in steps)
            results[name].append((p, held))
            if name.endswith("(the service's rule)") and call["raw"] is not None:
                replay_vs_service.append(abs(p - call["raw"]))
        held = all(abs(call["actual"][a][k]) <= limits[a] for a in all_axes for k in all_steps)
        results[transplant].append((transplanted(call, members, limits), held))
    if replay_vs_service:
        print(f"replay vs service: mean |difference| {statistics.mean(replay_vs_service):.4f} "
              f"over {len(replay_vs_service)} calls\n")
    for name, pairs in results.items():
        table(name, pairs)


if __name__ == "__main__":
    main()
