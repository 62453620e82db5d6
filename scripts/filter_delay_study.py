#!/usr/bin/env python3
"""What a minimum-phase anti-alias filter gains in real lead time and costs in error.

Issue 11 item 7. Standard library only (the study machine has no numpy).

The study that chose the predictor's filter: the evaluation (`shipcast eval`) decimates 8 Hz ->
2 Hz with the causal linear-phase FIR of crates/series/src/fir.rs `design_lowpass(4)` (17 taps,
delay exactly 8 input samples = 1.0 s); the predictor service now uses the minimum-phase twin this
study derives (`[predictor] filter = "minimum"`). This script

1. reproduces those taps with the Rust formula and prints them;
2. derives the minimum-phase filter with the same magnitude response (real-cepstrum folding on a
   zero-padded DFT), truncates it to 17 taps, and reports its group delay at the motion
   frequencies and its pass-band error and stop-band attenuation next to the original's;
3. for each motion CSV (8 Hz, header with `heave_m`): filters the heave causally with each filter,
   decimates to 2 Hz exactly like crates/series/src/decimator.rs (output j uses inputs 4j ..= 4j+16, its
   newest input is 4j+16), and for real leads L after the newest input fits a linear predictor of
   the last P decimated values for the RAW heave at newest-input time + L (least squares on the
   first TRAIN decimated values, Cholesky), scored at every later origin as RMS error / std of the
   raw heave there;
4. also scores "the same step k": a target k * 0.5 s after the decimated value's nominal time,
   which is the filter's delay before the newest input, to show what the delay costs.

Usage: scripts/filter_delay_study.py [--ridge=REL] MOTION.csv [MOTION.csv ...]
  --ridge=REL  ridge added to the normal equations, relative to their mean diagonal (default 1e-9)
"""

import cmath
import csv
import math
import operator
import sys

RATE_HZ = 8.0
FACTOR = 4
KAISER_BETA = 4.0
P = 100  # decimated values the predictor sees
TRAIN = 5000  # decimated values whose targets train it
LEADS_S = (5.0, 10.0, 20.0)
STEPS_K = (10, 20, 40)  # nominal 5, 10, 20 s at 2 Hz
NFFT = 1024
MOTION_BAND_HZ = (0.05, 0.1, 0.15, 0.2)
# Relative ridge on the normal equations, only so that Cholesky survives band-limited records
# (a record interpolated from 1 Hz leaves the 0.5-1 Hz band of the 2 Hz series empty).
RIDGE_REL = 1e-9


class StudyError(Exception):
    """A one-line problem with an input file."""


# ---------------------------------------------------------------- filter design


def bessel_i0(x):
    """Power series of I0, as in crates/series/src/fir.rs."""
    total, term, half = 1.0, 1.0, x / 2.0
    for k in range(1, 100):
        term *= (half / k) ** 2
        total += term
        if term < 1e-17 * total:
            break
    return total


def design_lowpass(factor):
    """The taps of crates/series/src/fir.rs `design_lowpass`, oldest-input weight first."""
    delay = 2 * factor
    cutoff = 0.5 / factor
    norm = bessel_i0(KAISER_BETA)
    taps = []
    for n in range(2 * delay + 1):
        m = n - delay
        if m == 0:
            sinc = 2.0 * cutoff
        else:
            sinc = math.sin(2.0 * math.pi * cutoff * m) / (math.pi * m)
        r = m / delay
        window = bessel_i0(KAISER_BETA * math.sqrt(max(1.0 - r * r, 0.0))) / norm
        taps.append(sinc * window)
    total = sum(taps)
    return [t / total for t in taps]


def fft(x, inverse=False):
    """Radix-2 FFT of a complex list whose length is a power of two."""
    n = len(x)
    if n == 1:
        return list(x)
    even = fft(x[0::2], inverse)
    odd = fft(x[1::2], inverse)
    sign = 1.0 if inverse else -1.0
    out = [0j] * n
    for k in range(n // 2):
        t = cmath.exp(sign * 2j * math.pi * k / n) * odd[k]
        out[k] = even[k] + t
        out[k + n // 2] = even[k] - t
    return out


def ifft(x):
    n = len(x)
    return [v / n for v in fft(x, inverse=True)]


def minimum_phase(taps, nfft=NFFT, floor_rel=1e-6):
    """Minimum-phase filter with |H| of `taps`, by folding the real cepstrum.

    log|H| is floored at `floor_rel` of its peak because the linear-phase filter has zeros on the
    unit circle (log 0). The result is truncated to len(taps) and renormalised to unit DC gain.
    """
    spectrum = fft([complex(t) for t in taps] + [0j] * (nfft - len(taps)))
    peak = max(abs(v) for v in spectrum)
    log_mag = [complex(math.log(max(abs(v), floor_rel * peak))) for v in spectrum]
    cep = [v.real for v in ifft(log_mag)]
    folded = [0.0] * nfft
    folded[0] = cep[0]
    for n in range(1, nfft // 2):
        folded[n] = 2.0 * cep[n]
    folded[nfft // 2] = cep[nfft // 2]
    h_full = [v.real for v in ifft([cmath.exp(v) for v in fft([complex(c) for c in folded])])]
    h = h_full[: len(taps)]
    total = sum(h)
    return [t / total for t in h], h_full


def response(taps, f):
    """Complex response at `f` cycles per input sample."""
    w = 2.0 * math.pi * f
    return sum(h * cmath.exp(-1j * w * n) for n, h in enumerate(taps))


def group_delay_samples(taps, f):
    """-d(phase)/d(omega) = Re( sum n h[n] e^{-jwn} / sum h[n] e^{-jwn} )."""
    w = 2.0 * math.pi * f
    num = sum(n * h * cmath.exp(-1j * w * n) for n, h in enumerate(taps))
    return (num / response(taps, f)).real


def band_figures(taps):
    """(largest |H|-1 over 0..0.3 Hz, largest |H| in dB over 0.85 x 2 Hz .. 4 Hz)."""
    out_rate = 1.0 / FACTOR
    grid = [0.5 * i / 4000 for i in range(4001)]
    pass_err = max(abs(abs(response(taps, f)) - 1.0) for f in grid if f <= 0.15 * out_rate)
    stop = max(abs(response(taps, f)) for f in grid if f >= 0.85 * out_rate)
    return pass_err, 20.0 * math.log10(stop)


# ---------------------------------------------------------------- data and prediction


def read_heave(path):
    try:
        with open(path, newline="") as handle:
            rows = csv.reader(handle)
            header = next(rows, None)
            if header is None:
                raise StudyError(f"{path}: empty file")
            try:
                t_col, h_col = header.index("time_s"), header.index("heave_m")
            except ValueError:
                raise StudyError(f"{path}: header lacks time_s or heave_m") from None
            times, heave = [], []
            for line_no, row in enumerate(rows, start=2):
                try:
                    t, h = float(row[t_col]), float(row[h_col])
                except (IndexError, ValueError):
                    raise StudyError(f"{path}:{line_no}: bad time_s/heave_m field") from None
                if not (math.isfinite(t) and math.isfinite(h)):
                    raise StudyError(f"{path}:{line_no}: non-finite value")
                times.append(t)
                heave.append(h)
    except OSError as err:
        raise StudyError(f"{path}: {err.strerror}") from None
    except (UnicodeDecodeError, csv.Error) as err:
        raise StudyError(f"{path}: not a readable CSV ({err})") from None
    if len(heave) < 2:
        raise StudyError(f"{path}: fewer than two samples")
    dt = (times[-1] - times[0]) / (len(times) - 1)
    if abs(dt * RATE_HZ - 1.0) > 1e-6:
        raise StudyError(f"{path}: sample interval {dt:.6f} s, expected {1 / RATE_HZ} s (8 Hz)")
    return heave


def decimate(x, taps):
    """Output j = sum_i taps[i] * x[4j + 16 - i] (taps[0] weighs the newest input)."""
    n_taps = len(taps)
    rev = taps[::-1]  # oldest-input weight first, like the Rust ring buffer
    out = []
    for start in range(0, len(x) - n_taps + 1, FACTOR):
        out.append(sum(map(operator.mul, rev, x[start : start + n_taps])))
    return out


def newest_input(j, n_taps):
    return FACTOR * j + n_taps - 1


def cholesky_solve(a, b):
    n = len(b)
    low = [[0.0] * n for _ in range(n)]
    for i in range(n):
        for j in range(i + 1):
            s = a[i][j] - sum(map(operator.mul, low[i][:j], low[j][:j]))
            if i == j:
                if s <= 0.0:
                    raise StudyError("normal equations not positive definite")
                low[i][i] = math.sqrt(s)
            else:
                low[i][j] = s / low[j][j]
    y = [0.0] * n
    for i in range(n):
        y[i] = (b[i] - sum(map(operator.mul, low[i][:i], y[:i]))) / low[i][i]
    x = [0.0] * n
    for i in reversed(range(n)):
        x[i] = (y[i] - sum(low[k][i] * x[k] for k in range(i + 1, n))) / low[i][i]
    return x


class Predictor:
    """Linear maps from the last P decimated values (demeaned) to raw heave at chosen offsets."""

    def __init__(self, raw, taps):
        self.raw = raw
        self.n_taps = len(taps)
        self.mean = sum(raw[: newest_input(TRAIN, self.n_taps)]) / newest_input(TRAIN, self.n_taps)
        self.dec = [v - self.mean for v in decimate(raw, taps)]
        if len(self.dec) < TRAIN + P:
            raise StudyError(
                f"record too short: {len(self.dec)} decimated values, need {TRAIN + P}"
            )

    def score(self, offset):
        """Fit on origins whose target lies within the first TRAIN decimated values' inputs,
        score at every origin j >= TRAIN with a target inside the record. `offset` is in input
        samples after the newest input. Returns (rms / std, number of test origins)."""
        raw, dec = self.raw, self.dec
        train_end_input = newest_input(TRAIN, self.n_taps)
        origins = [
            j
            for j in range(P - 1, TRAIN)
            if 0 <= newest_input(j, self.n_taps) + offset < train_end_input
        ]
        lagged = [[dec[j - lag] for j in origins] for lag in range(P)]
        target = [raw[newest_input(j, self.n_taps) + offset] - self.mean for j in origins]
        gram = [[0.0] * P for _ in range(P)]
        for i in range(P):
            for k in range(i + 1):
                gram[i][k] = gram[k][i] = sum(map(operator.mul, lagged[i], lagged[k]))
        ridge = RIDGE_REL * sum(gram[i][i] for i in range(P)) / P
        for i in range(P):
            gram[i][i] += ridge
        rhs = [sum(map(operator.mul, lagged[i], target)) for i in range(P)]
        weights = cholesky_solve(gram, rhs)
        errors, truths = [], []
        for j in range(TRAIN, len(dec)):
            idx = newest_input(j, self.n_taps) + offset
            if idx >= len(raw):
                break
            history = dec[j - P + 1 : j + 1][::-1]  # lag 0 first
            guess = sum(map(operator.mul, weights, history))
            truth = raw[idx] - self.mean
            errors.append(guess - truth)
            truths.append(truth)
        n = len(errors)
        rms = math.sqrt(sum(e * e for e in errors) / n)
        mu = sum(truths) / n
        std = math.sqrt(sum((t - mu) ** 2 for t in truths) / n)
        return rms / std, n


# ---------------------------------------------------------------- main


def main(args):
    global RIDGE_REL
    paths = []
    for arg in args:
        if arg.startswith("--ridge="):
            try:
                RIDGE_REL = float(arg.split("=", 1)[1])
            except ValueError:
                raise StudyError(f"bad --ridge value: {arg}") from None
            if not (math.isfinite(RIDGE_REL) and RIDGE_REL >= 0.0):
                raise StudyError(f"--ridge must be finite and >= 0: {arg}")
        else:
            paths.append(arg)
    if not paths:
        usage = "usage: filter_delay_study.py [--ridge=REL] MOTION.csv [MOTION.csv ...]"
        print(usage, file=sys.stderr)
        return 2
    linear = design_lowpass(FACTOR)
    minph, minph_full = minimum_phase(linear)
    tail = math.sqrt(sum(v * v for v in minph_full[len(linear) :]) / sum(v * v for v in minph_full))

    print("# Anti-alias filters, 8 Hz -> 2 Hz (taps: weight of the newest input first)")
    print("n  linear_phase          minimum_phase")
    for n, (a, b) in enumerate(zip(linear, minph)):
        print(f"{n:2d} {a: .15f} {b: .15f}")
    print(f"min-phase energy beyond tap 17 before truncation: {100 * tail:.3f} % (RMS ratio)")
    grid = [0.5 * i / 4000 for i in range(4001)]
    mag_diff = max(abs(abs(response(linear, f)) - abs(response(minph, f))) for f in grid)
    print(f"largest ||H_min| - |H_lin|| over 0..4 Hz after truncation: {mag_diff:.2e}")
    print()
    print("filter         group delay (s) at " + " ".join(f"{f:.2f}Hz" for f in MOTION_BAND_HZ)
          + "   pass err 0-0.3Hz   stop band >=1.7Hz")
    delays = {}
    for name, taps in (("linear-phase", linear), ("min-phase", minph)):
        gd = [group_delay_samples(taps, f / RATE_HZ) / RATE_HZ for f in MOTION_BAND_HZ]
        delays[name] = gd
        pass_err, stop_db = band_figures(taps)
        print(f"{name:14s} " + "        ".join(f"{d:.3f}" for d in gd).rjust(34)
              + f"   {100 * pass_err:.3f} %            {stop_db:.2f} dB")
    # Nominal delay a min-phase pipeline would label its outputs with: the group delay at
    # 0.1 Hz (mid motion band), rounded to whole input samples.
    mp_delay_samples = round(group_delay_samples(minph, 0.1 / RATE_HZ))
    lp_delay_samples = 2 * FACTOR
    print(f"nominal delay: linear-phase {lp_delay_samples} samples"
          f" = {lp_delay_samples / RATE_HZ} s,"
          f" min-phase {mp_delay_samples} samples = {mp_delay_samples / RATE_HZ} s")
    print()

    for path in paths:
        try:
            report_record(path, read_heave(path), linear, minph, lp_delay_samples, mp_delay_samples)
        except StudyError as err:
            msg = str(err)
            raise StudyError(msg if msg.startswith(path) else f"{path}: {msg}") from None
    return 0


def report_record(path, raw, linear, minph, lp_delay_samples, mp_delay_samples):
    """Print both tables for one record."""
    lp = Predictor(raw, linear)
    mp = Predictor(raw, minph)
    print(f"# {path}: {len(raw)} samples, {len(lp.dec)} decimated, P={P},"
          f" train on first {TRAIN}, relative ridge {RIDGE_REL:g}")
    print("Same REAL lead after the newest sample (error / std of raw heave):")
    print("| real lead | linear-phase | min-phase | test origins |")
    print("|---|---|---|---|")
    for lead in LEADS_S:
        off = round(lead * RATE_HZ)
        e_lp, n = lp.score(off)
        e_mp, _ = mp.score(off)
        print(f"| {lead:.0f} s | {e_lp:.4f} | {e_mp:.4f} | {n} |")
    print("Same STEP k after the decimated value's nominal time (real lead = k*0.5 s - delay):")
    print("| step k (k*0.5 s) | linear-phase: real lead, error | min-phase: real lead, error |")
    print("|---|---|---|")
    for k in STEPS_K:
        nominal = k * FACTOR
        off_lp = nominal - lp_delay_samples
        off_mp = nominal - mp_delay_samples
        e_lp, _ = lp.score(off_lp)
        e_mp, _ = mp.score(off_mp)
        print(f"| {k} ({k / 2:.0f} s) | {off_lp / RATE_HZ:.3f} s, {e_lp:.4f} |"
              f" {off_mp / RATE_HZ:.3f} s, {e_mp:.4f} |")
    print()
    sys.stdout.flush()


if __name__ == "__main__":
    if any(a in ("-h", "--help") for a in sys.argv[1:]):
        print(__doc__)
        sys.exit(0)
    try:
        sys.exit(main(sys.argv[1:]))
    except StudyError as err:
        print(f"error: {err}", file=sys.stderr)
        sys.exit(1)
