#!/usr/bin/env python3
"""MCA training (the paper's rule, docs/contracts.md section 4) in numpy/LAPACK, timed.

Run by `cargo bench --bench mca_vs_numpy`, which writes the training series and shipcast's own
prediction matrix to files, times shipcast's fit in the same run and prints both times and their
ratio. It can also be run alone:

    python3 benches/mca_vs_numpy.py SERIES.txt --order 800 --horizon 50 --shift 10 --energy 0.015

Needs numpy. Without it on the default python3:

    python3 -m venv target/tmp/numpy-venv && target/tmp/numpy-venv/bin/pip install numpy

(the cargo bench uses target/tmp/numpy-venv/bin/python when it exists, or the interpreter named
by SHIPCAST_NUMPY_PYTHON).

The fit gives the same prediction map as crates/predict/src/mca.rs by the textbook route:
windows of `order` values every `shift` values, R = X X^T, the full eigh of R, the minor
components by the energy rule (at least `horizon` of them), P = -(B2^T B2)^-1 B2^T B1.
shipcast takes another route to the same map (crates/predict/src/mca_spectrum.rs): with fewer
windows than `order` (421 for order 800 on 5000 points) the spectrum comes from a QR of the
windows and a 421 x 421 eigenproblem, since R has rank 421 at most. The comparison is of the
two ways to the same result, which the reference-matrix check confirms, not of one
eigensolver against another. Prints one JSON line: median and minimum fit time [ms], the number of
minor components, and, when a reference matrix is given, the largest difference to it relative
to its largest entry.
"""

import argparse
import json
import statistics
import sys
import time

try:
    import numpy as np
except ImportError:
    sys.exit(
        "numpy is missing: python3 -m venv target/tmp/numpy-venv && "
        "target/tmp/numpy-venv/bin/pip install numpy"
    )


def fit(x, order, horizon, shift, energy):
    """The prediction matrix P (horizon x (order - horizon)) and the number of minor components."""
    windows = np.lib.stride_tricks.sliding_window_view(x, order)[::shift]
    # A contiguous copy, as shipcast builds X; numpy then multiplies X^T X with one BLAS call.
    xw = np.ascontiguousarray(windows)
    r = xw.T @ xw
    values, vectors = np.linalg.eigh(r, UPLO="L")
    budget = energy * values.sum()
    cumulative = np.cumsum(values)
    k = int(np.searchsorted(cumulative, budget, side="right"))
    k = min(max(k, horizon), order)
    minor = vectors[:, :k]
    n1 = order - horizon
    past, future = minor[:n1], minor[n1:]
    gram = future @ future.T
    rhs = -(future @ past.T)
    return np.linalg.solve(gram, rhs), k


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("series", help="training series, one value per line")
    parser.add_argument("--order", type=int, default=800)
    parser.add_argument("--horizon", type=int, default=50)
    parser.add_argument("--shift", type=int, default=10)
    parser.add_argument("--energy", type=float, default=0.015)
    parser.add_argument("--repeats", type=int, default=15)
    parser.add_argument(
        "--reference", help="a prediction matrix to compare with (row-major, one value per line)"
    )
    args = parser.parse_args()
    x = np.loadtxt(args.series)
    p, k = fit(x, args.order, args.horizon, args.shift, args.energy)  # warm-up
    times = []
    for _ in range(args.repeats):
        start = time.perf_counter()
        p, k = fit(x, args.order, args.horizon, args.shift, args.energy)
        times.append(time.perf_counter() - start)
    result = {
        "numpy": np.__version__,
        "median_ms": 1e3 * statistics.median(times),
        "min_ms": 1e3 * min(times),
        "repeats": args.repeats,
        "minor_components": k,
    }
    if args.reference:
        reference = np.loadtxt(args.reference).reshape(p.shape)
        scale = np.abs(reference).max()
        result["max_relative_difference"] = float(np.abs(p - reference).max() / scale)
    print(json.dumps(result))


if __name__ == "__main__":
    main()
