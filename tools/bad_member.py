#!/usr/bin/python3
"""A member that goes bad: the in-process fleet with one robot sending bad states every round,
with the screen (dinno.h, --screen-radius) and without it, against the clean run.

    tools/bad_member.py [--bin build/release-host-small/bin/host_sim] [--rounds 1500] [--out results/bad_member]
                        [--csv docs/faults/bad_member.csv]

Runs, each in OUT/<name>/ (skipped when its summary.txt exists, so a stopped sweep resumes):
    clean                 every robot honest (screen on, the default)
    clean-noscreen        every robot honest, --screen-radius 0 (what the screen costs)
    silent                robot --bad sends nothing: what the others can reach without its data
    <attack>[-noscreen]   robot --bad (default 3) sends scale=1000, flip or random states
The robots' samples and the validation set are made once (OUT/samples, OUT/valset.samples) as
`make run-inproc` makes them. Prints a table and writes the CSV: the honest members' final
validation loss and consensus error, their ratios to the clean run's, the states left out and
the largest honest neighbour distance. Exit 1 when a run fails.
"""
import argparse
import csv
import os
import re
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PLAN = os.path.join(ROOT, "host_sim/plans/apartment.svg")
PATHS = os.path.join(ROOT, "host_sim/plans/apartment")
ROBOTS = 7
ATTACKS = ("scale=1000", "flip", "random")


def run(cmd, log):
    with open(log, "w") as f:
        res = subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT)
    if res.returncode != 0:
        sys.exit(f"bad_member: {' '.join(cmd)} failed ({res.returncode}); see {log}")


def figures(summary):
    text = open(summary).read()
    m = re.search(r"^screen: radius \S+ x \|\|theta\|\|: (\d+) neighbour states left out; largest honest neighbour "
                  r"distance (\S+)", text, re.M)
    h = re.search(r"honest members: final val_loss \(mean\) (\S+), consensus_error \(max\) (\S+)", text)
    if h is None:  # all honest: every member counts
        v = re.search(r"^final val_loss \(mean over models\): (\S+)", text, re.M)
        c = re.search(r"^final consensus_error \(max\): (\S+)", text, re.M)
        val, cons = float(v.group(1)), float(c.group(1))
    else:
        val, cons = float(h.group(1)), float(h.group(2))
    return {"val_loss": val, "consensus_error": cons, "excluded": int(m.group(1)), "honest_dist_max": float(m.group(2))}


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--bin", default=os.path.join(ROOT, "build/release-host-small/bin/host_sim"))
    p.add_argument("--rounds", type=int, default=1500)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--bad", type=int, default=3, help="the bad robot (default 3)")
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--out", default=os.path.join(ROOT, "results/bad_member"))
    p.add_argument("--csv", default=None, help="also write the table here")
    a = p.parse_args()
    if not os.access(a.bin, os.X_OK):
        sys.exit(f"bad_member: {a.bin} not found: build first (make)")
    if a.rounds < 1 or not 0 <= a.bad < ROBOTS:
        sys.exit(f"bad_member: --rounds must be >= 1 and --bad 0..{ROBOTS - 1}")
    os.makedirs(os.path.join(a.out, "samples"), exist_ok=True)
    samples, valset = os.path.join(a.out, "samples"), os.path.join(a.out, "valset.samples")
    for i in range(ROBOTS):
        f = os.path.join(samples, f"robot_{i}.samples")
        if not os.path.exists(f):
            run([a.bin, "scan", "--plan", PLAN, "--path", os.path.join(PATHS, f"robot_{i}.csv"), "--robot", str(i),
                 "--seed", str(a.seed), "--out", f, "-q"], os.path.join(a.out, "scan.log"))
    if not os.path.exists(valset):
        run([a.bin, "valset", "--plan", PLAN, "--poses", "500", "--seed", str(a.seed), "--out", valset],
            os.path.join(a.out, "valset.log"))
    runs = [("clean", None, True), ("clean-noscreen", None, False), ("silent", "silent", True)]
    runs += [(k.split("=")[0] + s, k, on) for k in ATTACKS for s, on in (("", True), ("-noscreen", False))]
    rows = {}
    for name, attack, screen in runs:
        d = os.path.join(a.out, name)
        summary = os.path.join(d, "summary.txt")
        if not os.path.exists(summary):
            t0 = time.time()
            print(f"bad_member: {name} ({a.rounds} rounds) ...", flush=True)
            os.makedirs(d, exist_ok=True)
            run([a.bin, "fleet", "--inproc", "--plan", PLAN, "--paths", PATHS, "--robots", str(ROBOTS), "--rounds",
                 str(a.rounds), "--strategy", "kl", "--graph", "disk", "--radius", "6", "--seed", str(a.seed),
                 "--threads", str(a.threads), "--metrics-every", str(max(1, a.rounds // 20)), "--samples", samples,
                 "--valset", valset, "--out", d, "--mc", "2"] +
                ([] if screen else ["--screen-radius", "0"]) +
                ([] if attack is None else ["--bad-member", f"{a.bad}:{attack}"]),
                os.path.join(d, "log.txt"))
            print(f"bad_member: {name} done in {time.time() - t0:.0f} s", flush=True)
        rows[name] = dict(figures(summary), name=name, attack=attack or "none", screen=int(screen))
    base = rows["clean"]
    head = ["name", "attack", "screen", "val_loss", "val_ratio", "consensus_error", "consensus_ratio", "excluded",
            "honest_dist_max"]
    table = []
    for name, _, _ in runs:
        r = rows[name]
        r["val_ratio"] = r["val_loss"] / base["val_loss"]
        r["consensus_ratio"] = r["consensus_error"] / base["consensus_error"]
        table.append(r)
    print(f"{'run':<20} {'val loss':>9} {'x clean':>8} {'consensus':>10} {'x clean':>8} {'left out':>9} "
          f"{'honest dist':>11}")
    for r in table:
        print(f"{r['name']:<20} {r['val_loss']:>9.5f} {r['val_ratio']:>8.3f} {r['consensus_error']:>10.6f} "
              f"{r['consensus_ratio']:>8.2f} {r['excluded']:>9} {r['honest_dist_max']:>11.4f}")
    if a.csv:
        with open(a.csv, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=head, extrasaction="ignore", lineterminator="\n")
            w.writeheader()
            for r in table:
                w.writerow({k: (f"{r[k]:.6g}" if isinstance(r[k], float) else r[k]) for k in head})
        print(f"bad_member: table in {a.csv}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
