#!/usr/bin/env python3
"""Replay the deck's landing decisions over long records and print their reliability with the
evidence each bin really holds (docs/decisions.md, "Measured").

Neighbouring calls judge overlapping windows and mostly share their outcome, so a bin's calls
are not independent trials: replay counts `episodes` (calls at least MOT apart), and an honest
bin's observed frequency strays from its stated probability by up to 1.96 sqrt(p (1 - p) /
episodes) by chance (95 %). A bin is flagged `off` when it has at least 50 calls and is more
than 5 points from its statement (issue 13's bar), and `beyond chance` when it is also outside
that interval. Under each table: the chance that an honest forecaster making the same statements
over the same episodes passes that bar on the record, and how much longer a record would let it
pass with probability 0.9 (binomial over episodes taken as independent; they are not quite, so
both figures flatter the bar).

Records: three realisations (seeds 1-3) of the simulated paper sea over 4 hours each, then the
three pooled, and, when `python3 scripts/fetch_wafo.py` has fetched it, the whole Gullfaks C
record (4.3 h of measured North Sea waves with a 20-minute gap). Each is replayed with the
default 25 s horizon (MOT 10 s) and with a 40 s horizon (`[predictor] horizon = 80`: MOT 10 s
and 30 s).

Then a deck that has run before (`[deck] statements_file`): the verified statements that seed
1's replay leaves behind are where the replays of seeds 2-6 and of Gullfaks C start from (each
from its own copy of seed 1's file), per horizon, with seeds 2-6 pooled. Seeds 4-6 are not
replayed elsewhere: they are the out-of-sample check of keeping statements across runs, and are
replayed here fresh too, so the fresh and carried tables of seeds 2-6 pool the same 20 hours.

Run from the repository root after `cargo build --release`; about 17 minutes on 2 cores. Python
standard library only.
"""
import argparse
import json
import math
import os
import shutil
import subprocess
import sys

# The repository's release build, wherever the script is run from (SHIPCAST_BIN: another).
BIN = os.environ.get("SHIPCAST_BIN", os.path.join(
    os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "target", "release", "shipcast"))

PAPER_SEEDS = [1, 2, 3]

RECORDS = [
    (f"paper sea, 4 h, seed {seed}",
     ["--scenario", "paper", "--duration", "14400", "--seed", str(seed)])
    for seed in PAPER_SEEDS
] + [
    ("Gullfaks C measured waves (North Sea 1989), whole record, 0 kn",
     ["--elevation", "data/wafo/gfaks89.csv", "--heading-deg", "165", "--speed-kn", "0"]),
]

HORIZONS = [("25 s horizon", None), ("40 s horizon", 80)]

CARRY_SEEDS = [2, 3, 4, 5, 6]


def run(args):
    try:
        out = subprocess.run([BIN] + args, capture_output=True, text=True)
    except OSError as e:
        sys.exit(f"decisions_study: cannot run {BIN} ({e.strerror}): build it with "
                 "`cargo build --release`, or set SHIPCAST_BIN")
    if out.returncode != 0:
        sys.exit(f"decisions_study: shipcast {' '.join(args)} failed: {out.stderr.strip()}")
    return out.stdout


def write_config(path, horizon, statements=None):
    with open(path, "w") as f:
        if horizon:
            f.write(f"[predictor]\nhorizon = {horizon}\n")
        if statements:
            # TOML basic string: the path as JSON writes it is a valid one.
            f.write(f"[deck]\nstatements_file = {json.dumps(statements)}\n")
    return path


def paper_record(work, seed):
    """The 4-hour paper-sea record of `seed`: the main tables' for seeds 1-3, made here for
    the others."""
    if seed in PAPER_SEEDS:
        return os.path.join(work, f"record{PAPER_SEEDS.index(seed) + 1}.csv")
    path = os.path.join(work, f"paper_seed{seed}.csv")
    run(["simulate", "--scenario", "paper", "--duration", "14400", "--seed", str(seed),
         "--rate", "8", "--out", path])
    return path


def carried(work, fresh_main):
    """Replays that start from the statements seed 1's replay left behind, beside fresh-deck
    replays of the same records: `fresh_main[label]` holds the main tables' seeds 1-3, and
    the seeds beyond them are replayed fresh here, so both columns pool the same 20 hours."""
    gfaks = RECORDS[-1][1]
    gfaks_path = os.path.join(work, f"record{len(RECORDS)}.csv")
    targets = [(f"paper sea, 4 h, seed {seed}", paper_record(work, seed))
               for seed in CARRY_SEEDS]
    if os.path.exists(gfaks[gfaks.index("--elevation") + 1]) and os.path.exists(gfaks_path):
        targets.append((RECORDS[-1][0], gfaks_path))
    for label, horizon in HORIZONS:
        tag = horizon or "default"
        first = os.path.join(work, f"statements_seed1_{tag}.json")
        if os.path.exists(first):
            os.remove(first)
        decisions(paper_record(work, 1), write_config(
            os.path.join(work, f"carry_seed1_{tag}.toml"), horizon, first))
        fresh = [r for seed, r in zip(PAPER_SEEDS, fresh_main[label]) if seed in CARRY_SEEDS]
        for seed in CARRY_SEEDS:
            if seed in PAPER_SEEDS:
                continue
            config = (write_config(os.path.join(work, f"fresh_{tag}.toml"), horizon)
                      if horizon else None)
            fresh.append(replay_tables(f"paper sea, 4 h, seed {seed}, {label}, fresh deck",
                                       paper_record(work, seed), config))
        pooled_tables(f"paper sea, seeds {CARRY_SEEDS[0]}-{CARRY_SEEDS[-1]} pooled "
                      f"({4 * len(CARRY_SEEDS)} h), {label}, fresh deck", fresh)
        paper = []
        for i, (name, path) in enumerate(targets):
            own = os.path.join(work, f"statements_from_seed1_{tag}_{i}.json")
            shutil.copyfile(first, own)
            config = write_config(os.path.join(work, f"carry_{tag}_{i}.toml"), horizon, own)
            reports = replay_tables(f"{name}, {label}, starting from seed 1's statements",
                                    path, config)
            if name.startswith("paper"):
                paper.append(reports)
        pooled_tables(f"paper sea, seeds {CARRY_SEEDS[0]}-{CARRY_SEEDS[-1]} pooled "
                      f"({4 * len(CARRY_SEEDS)} h), {label}, each starting from seed 1's "
                      "statements", paper)


def decisions(path, config):
    args = ["replay", "--input", path, "--json"]
    if config:
        args += ["--config", config]
    rows = [json.loads(line) for line in run(args).splitlines() if line.strip()]
    return [r["decisions"] for r in rows if "decisions" in r]


def replay_tables(title, path, config):
    """A section: its title, then the table of each MOT that replaying `path` scores. Returns
    the reports, for pooling."""
    print(f"\n## {title}")
    reports = decisions(path, config)
    for d in reports:
        table(d)
    return reports


def pooled_tables(title, runs):
    """A section: its title, then one table per MOT with `runs` (each the reports of one
    record) pooled."""
    print(f"\n## {title}")
    for per_mot in zip(*runs):
        table(pooled(list(per_mot)))


def half_width(p, episodes):
    return 1.96 * math.sqrt(max(p * (1.0 - p), 1e-12) / max(episodes, 1))


def within_chance(p, episodes, tol=0.05):
    """P(|k / episodes - p| <= tol) for k ~ Binomial(episodes, p): how often an honest bin of
    that many independent episodes lands within `tol` of its statement."""
    p = min(max(p, 1e-12), 1.0 - 1e-12)
    log_n = math.lgamma(episodes + 1)
    total = 0.0
    # Only the k near p * episodes can qualify (one more each side for rounding); the test
    # below decides which do.
    first = max(0, math.floor((p - tol) * episodes) - 1)
    last = min(episodes, math.ceil((p + tol) * episodes) + 1)
    for k in range(first, last + 1):
        if abs(k / episodes - p) <= tol + 1e-12:
            total += math.exp(log_n - math.lgamma(k + 1) - math.lgamma(episodes - k + 1)
                              + k * math.log(p) + (episodes - k) * math.log(1.0 - p))
    return min(total, 1.0)


def honest_pass_chance(bins, scale=1.0):
    """The chance that an honest forecaster, stating these bins' probabilities on a record
    `scale` times as long (as many times the episodes), has every bin of at least 50 calls
    within 5 points: issue 13's bar. Episodes are taken as independent, which they are not
    quite (wave groups span several), so the true chance is lower still."""
    chance = 1.0
    for b in bins:
        if b["count"] * scale >= 50 and b["episodes"]:
            chance *= within_chance(b["stated"], max(1, round(b["episodes"] * scale)))
    return chance


def pooled(reports):
    """The same station and MOT over several records, as one report: counts and episodes
    added, the stated and observed frequencies weighted by calls."""
    first = reports[0]
    bins = []
    for i, b in enumerate(first["reliability"]):
        parts = [r["reliability"][i] for r in reports]
        count = sum(p["count"] for p in parts)
        weigh = lambda key: (sum(p[key] * p["count"] for p in parts if p["count"]) / count
                             if count else float("nan"))
        bins.append({"p_lo": b["p_lo"], "p_hi": b["p_hi"], "count": count,
                     "episodes": sum(p["episodes"] for p in parts),
                     "stated": weigh("stated"), "observed": weigh("observed")})
    calls = sum(r["calls"] for r in reports)
    mean = lambda key: (sum(r[key] * r["calls"] for r in reports if r["calls"]) / calls
                        if calls else None)
    go = sum(r["go_calls"] for r in reports)
    false_go = (sum(r["false_go_rate"] * r["go_calls"] for r in reports if r["go_calls"]) / go
                if go else None)
    return {"mot_s": first["mot_s"], "calls": calls, "brier": mean("brier"),
            "brier_climatology": mean("brier_climatology"), "go_calls": go,
            "false_go_rate": false_go, "reliability": bins}


def table(d):
    fmt = lambda x: "-" if x is None or x != x else f"{x:.3f}"
    print(f"\n### MOT {d['mot_s']:.0f} s: {d['calls']} calls, Brier {fmt(d['brier'])} "
          f"(stating the base rate: {fmt(d['brier_climatology'])}), go calls {d['go_calls']}, "
          f"false go {fmt(d['false_go_rate'])}\n")
    if not d["calls"]:
        print("No calls: the horizon is shorter than the minimum operation time.")
        return 0, 0
    print("| stated | calls | episodes | mean stated | observed | 95 % by chance | verdict |")
    print("|---|---|---|---|---|---|---|")
    off = beyond = 0
    for b in d["reliability"]:
        if not b["count"]:
            continue
        miss = abs(b["observed"] - b["stated"])
        hw = half_width(b["stated"], b["episodes"])
        verdict = ""
        if b["count"] >= 50 and miss > 0.05:
            off += 1
            verdict = "off"
            if miss > hw:
                beyond += 1
                verdict = "off, beyond chance"
        print(f"| {b['p_lo']:.1f}-{b['p_hi']:.1f} | {b['count']} | {b['episodes']} | "
              f"{b['stated']:.3f} | {b['observed']:.3f} | +-{hw:.3f} | {verdict} |")
    print(f"\n{off} bins with at least 50 calls more than 5 points off, {beyond} of them beyond "
          "chance.")
    chance = honest_pass_chance(d["reliability"])
    longer = next((f for f in range(1, 201) if honest_pass_chance(d["reliability"], f) >= 0.9),
                  None)
    print(f"An honest forecaster with these statements and episodes would have every such bin "
          f"within 5 points with probability {chance:.2f}; "
          + (f"{longer} times this record would give it 0.9." if longer
             else "not even 200 times this record would give it 0.9."))
    return off, beyond


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--work", default=os.path.join("target", "decisions-study"))
    a = ap.parse_args()
    os.makedirs(a.work, exist_ok=True)
    config = write_config(os.path.join(a.work, "horizon80.toml"), 80)
    paper = {label: [] for label, _ in HORIZONS}
    for i, (name, sim) in enumerate(RECORDS):
        if "--elevation" in sim and not os.path.exists(sim[sim.index("--elevation") + 1]):
            print(f"\n## {name}: skipped (run python3 scripts/fetch_wafo.py first)")
            continue
        path = os.path.join(a.work, f"record{i + 1}.csv")
        run(["simulate"] + sim + ["--rate", "8", "--out", path])
        for label, horizon in HORIZONS:
            reports = replay_tables(f"{name}, {label}", path, config if horizon else None)
            if i < len(PAPER_SEEDS):
                paper[label].append(reports)
        if i == len(PAPER_SEEDS) - 1:
            for label, _ in HORIZONS:
                pooled_tables(f"paper sea, seeds {PAPER_SEEDS[0]}-{PAPER_SEEDS[-1]} pooled "
                              f"({4 * len(PAPER_SEEDS)} h), {label}", paper[label])
    print("\n# A deck that has run before: each replay starts from the verified statements "
          "of seed 1's")
    carried(a.work, paper)


if __name__ == "__main__":
    main()
