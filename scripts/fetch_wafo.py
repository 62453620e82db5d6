#!/usr/bin/env python3
"""Fetch two measured wave records from the WAFO toolbox and convert them to elevation CSVs.

    python3 scripts/fetch_wafo.py [--out DIR] [--wheel-dir DIR] [--force]

Downloads the PyPI package py3wafo 0.4.0 (a wheel, i.e. a zip) with `pip download --no-deps`,
extracts `wafo/data/gfaks89.dat` and `wafo/data/sea.dat` and writes, in --out (default
data/wafo/, git-ignored):

- gfaks89.csv: Gullfaks C platform, North Sea, 24 Dec 1989, 17:00-21:20; EMI laser, 2.5 Hz,
  Hm0 6.8 m, Tp 10.5 s, water depth 218 m.
- sea.csv: the WAT 1.1 test record, 4 Hz, Hm0 1.9 m (device and site unknown).
- LICENSE-WAFO.txt: the licence text found in the wheel, and the data's own terms.

Each CSV has the header `time_s,wave_m` (time in seconds, elevation in metres, positive up).

The gap: gfaks89.dat holds 3000 NaN rows (20:00-20:20, record time 10800-11999.6 s). They are
KEPT OUT: the CSV has no row for them, so its time jumps from 10799.6 s to 12000.0 s. Nothing is
interpolated. `shipcast simulate --elevation` treats such a jump as a gap and simulates each
NaN-free segment on its own.

Licence: the WAFO code is GPL-3 (LICENSE.txt in the wheel's dist-info, wafo/license.py), but
the data files' own documentation (wafo/data/info.py) says "This dataset is for non-commercial
use only". So the records and the CSVs made from them are never committed: this script fetches
them on each machine.

Only the Python standard library is used. Idempotent: existing, complete outputs are kept
unless --force. Exit status 0 on success, 1 with a one-line message otherwise (for example
when PyPI cannot be reached).
"""

import argparse
import glob
import hashlib
import math
import os
import subprocess
import sys
import tempfile
import zipfile

PACKAGE = "py3wafo==0.4.0"
# The one wheel py3wafo 0.4.0 has on PyPI (py3wafo-0.4.0-py3-none-any.whl). Whatever pip or
# --wheel-dir hands over (a mirror, a find-links folder) must be that file.
WHEEL_SHA256 = "1383469f3d2ab3ec44041c562e97e8c23f638c1fe60ffaff1ca29b2faedd81e8"
# The repository root: the records go under its data/wafo, which .gitignore covers, wherever
# the script is run from.
REPO_ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RECORDS = {
    # output name: (member in the wheel, expected sample interval [s])
    "gfaks89.csv": ("wafo/data/gfaks89.dat", 0.4),
    "sea.csv": ("wafo/data/sea.dat", 0.25),
}
LICENSE_MEMBERS = ("wafo/license.py", "py3wafo-0.4.0.dist-info/licenses/LICENSE.txt")
DATA_TERMS = (
    "The WAFO data files gfaks89.dat and sea.dat come from the PyPI package py3wafo 0.4.0\n"
    "(wafo/data/). wafo/data/info.py says of gfaks89: 'This dataset is for non-commercial use\n"
    "only.' (prepared and made available by Dr. S. Haver, STATOIL, Norway). Treat both records\n"
    "as non-commercial: never commit them or files derived from them.\n"
)


def fail(message):
    print(f"fetch_wafo: {message}", file=sys.stderr)
    sys.exit(1)


def find_or_download_wheel(wheel_dir):
    pattern = os.path.join(wheel_dir, "py3wafo-0.4.0-*.whl")
    found = sorted(glob.glob(pattern))
    if found:
        return found[0]
    os.makedirs(wheel_dir, exist_ok=True)
    cmd = [sys.executable, "-m", "pip", "download", "--no-deps", "--only-binary", ":all:",
           "--quiet", PACKAGE, "-d", wheel_dir]
    try:
        result = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    except (OSError, subprocess.TimeoutExpired) as e:
        fail(f"cannot run pip download ({e}); are you offline?")
    found = sorted(glob.glob(pattern))
    if result.returncode != 0 or not found:
        last = (result.stderr.strip().splitlines() or ["no output"])[-1]
        fail(f"pip download {PACKAGE} failed (offline or PyPI unreachable?): {last}")
    return found[0]


def check_wheel(wheel):
    """The wheel must be PyPI's, byte for byte."""
    digest = hashlib.sha256()
    try:
        with open(wheel, "rb") as f:
            for block in iter(lambda: f.read(1 << 20), b""):
                digest.update(block)
    except OSError as e:
        fail(f"cannot read {wheel}: {e}")
    if digest.hexdigest() != WHEEL_SHA256:
        fail(f"{wheel} is not PyPI's py3wafo 0.4.0 wheel (sha256 {digest.hexdigest()}, "
             f"expected {WHEEL_SHA256})")


def convert(text, member, expected_dt):
    """Rows of (time, elevation) without the NaN rows; checks the layout on the way."""
    rows = []
    dropped = 0
    previous = None
    for number, line in enumerate(text.splitlines(), start=1):
        fields = line.split()
        if not fields:
            continue
        if len(fields) != 2:
            fail(f"{member} line {number}: {len(fields)} fields, expected 2")
        try:
            t, z = float(fields[0]), float(fields[1])
        except ValueError:
            fail(f"{member} line {number}: not a number: {line.strip()!r}")
        if not math.isfinite(t):
            fail(f"{member} line {number}: non-finite time")
        if previous is not None and not abs(t - previous - expected_dt) < 1e-6 * max(1.0, t):
            fail(f"{member} line {number}: time step {t - previous} s, expected {expected_dt} s")
        previous = t
        if math.isnan(z):
            dropped += 1
            continue
        if not math.isfinite(z):
            fail(f"{member} line {number}: non-finite elevation")
        rows.append((fields[0], fields[1]))
    return rows, dropped


def write_csv(path, rows):
    tmp = path + ".tmp"
    with open(tmp, "w", encoding="ascii", newline="\n") as f:
        f.write("time_s,wave_m\n")
        for t, z in rows:
            # Shortest round-trip text of the parsed value: nothing is rounded.
            f.write(f"{float(t)!r},{float(z)!r}\n")
    os.replace(tmp, path)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", default=os.path.join(REPO_ROOT, "data", "wafo"),
                        help="output folder (default: the repository's data/wafo, git-ignored)")
    parser.add_argument("--wheel-dir", help="folder holding or receiving the wheel (default: a temporary folder)")
    parser.add_argument("--force", action="store_true", help="rewrite existing outputs")
    args = parser.parse_args()

    outputs = [os.path.join(args.out, name) for name in RECORDS] + [os.path.join(args.out, "LICENSE-WAFO.txt")]
    if not args.force and all(os.path.isfile(p) and os.path.getsize(p) > 0 for p in outputs):
        print(f"fetch_wafo: {args.out} already holds {', '.join(RECORDS)} (use --force to rewrite)")
        return
    with tempfile.TemporaryDirectory() as tmp:
        wheel = find_or_download_wheel(args.wheel_dir or tmp)
        check_wheel(wheel)
        # Made only now: a download that failed leaves no empty folder behind.
        os.makedirs(args.out, exist_ok=True)
        try:
            archive = zipfile.ZipFile(wheel)
        except (OSError, zipfile.BadZipFile) as e:
            fail(f"{wheel} is not a readable wheel: {e}")
        with archive:
            names = set(archive.namelist())
            for name, (member, dt) in RECORDS.items():
                if member not in names:
                    fail(f"{wheel} has no {member}")
                rows, dropped = convert(archive.read(member).decode("ascii"), member, dt)
                path = os.path.join(args.out, name)
                write_csv(path, rows)
                gap = f", {dropped} NaN rows left out (a {dropped * dt:.0f} s time jump)" if dropped else ""
                print(f"fetch_wafo: wrote {path}: {len(rows)} rows at {1 / dt:g} Hz{gap}")
            missing = [m for m in LICENSE_MEMBERS if m not in names]
            if missing:
                fail(f"{wheel} has no {', '.join(missing)}: the licence cannot be kept")
            with open(os.path.join(args.out, "LICENSE-WAFO.txt"), "w", encoding="utf-8") as f:
                f.write(DATA_TERMS)
                for member in LICENSE_MEMBERS:
                    if member in names:
                        f.write(f"\n===== {member} (from {os.path.basename(wheel)}) =====\n")
                        f.write(archive.read(member).decode("utf-8", errors="replace"))


if __name__ == "__main__":
    main()
