#!/usr/bin/python3
"""A fleet through a partition: each robot's disagreement and neighbours per round.

usage: tools/plot_partition.py [--out FILE.png] [--from T1 --until T2] [--reference RUN_DIR] RUN_DIR

RUN_DIR is a process fleet's run folder (tools/fleet: RESULTS/<run>/) with robot_<i>/metrics.csv
(round,...,neighbours,disagreement,wall_s). The partition window is read from robot_0/summary.txt
("network faults injected (...partition=A/B,from=T1,until=T2...)"), or given with --from/--until:
seconds of each robot's network clock, which its metrics.csv column wall_s follows. The rounds
the robots ran inside the window are shaded. Top: `disagreement` (the relative distance of the
robot's model to the mean of the neighbours' states it trained with; none with no neighbour),
log scale; bottom: `neighbours`. Lines break where a robot skipped rounds to catch up. With
--reference (an unpartitioned run of the same settings) its robot 0 is drawn dashed. Prints, per
robot, the rounds it ran alone and its mean disagreement before the window, inside it (rounds
with a neighbour), in its first 10 rounds with a neighbour after it (just after the heal) and
in the last 10 % of the rounds. Needs numpy and matplotlib (Debian python3-numpy,
python3-matplotlib).

docs/faults/partition.png was made by these commands (3 robots, 800 rounds, every peer a
neighbour, peer timeout 1 s, robot 0 cut off from robots 1 and 2 from 4 s to 8 s; run with
`--bin build-crash/release-host-small/bin/host_sim --results /tmp/cx/results` added to both
tools/fleet commands, the results folder given accordingly here):

    tools/fleet --robots 3 --rounds 800 --radius 0 --peer-timeout 1 \\
        --net-faults partition=0/1.2,from=4,until=8 --name partition2 --no-report
    tools/fleet --robots 3 --rounds 800 --radius 0 --peer-timeout 1 --name unpartitioned --no-report
    tools/plot_partition.py --reference results/unpartitioned --out docs/faults/partition.png \\
        results/partition2
"""
import argparse
import glob
import math
import os
import re
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.realpath(__file__)))
from palette import robot_colour  # noqa: E402  (one colour per robot in every figure)


def fail(msg):
    raise SystemExit(f"plot_partition: {msg}")


def load_robot(path):
    """metrics.csv of one robot: dict of numpy arrays round, neighbours, disagreement, wall_s."""
    try:
        with open(path, encoding="utf-8") as f:
            header = f.readline().strip().split(",")
            rows = [line.strip().split(",") for line in f if line.strip()]
    except OSError as e:
        fail(f"cannot read {path}: {e.strerror}")
    cols = ("round", "neighbours", "disagreement", "wall_s")
    for need in cols:
        if need not in header:
            fail(f"{path}: no column '{need}' (has {','.join(header)}); a run of `host_sim run --fleet` is needed")
    idx = [header.index(c) for c in cols]
    out = {c: [] for c in cols}
    for n, r in enumerate(rows, start=2):
        if len(r) != len(header):
            fail(f"{path}:{n}: {len(r)} fields, expected {len(header)}")
        try:
            for c, i in zip(cols, idx):
                out[c].append(float(r[i]))
        except ValueError:
            fail(f"{path}:{n}: bad number")
    if not rows:
        fail(f"{path}: no rows")
    return {c: np.array(v) for c, v in out.items()}


def load_run(run_dir):
    files = sorted(glob.glob(os.path.join(run_dir, "robot_*", "metrics.csv")),
                   key=lambda p: int(re.sub(r"\D", "", os.path.basename(os.path.dirname(p))) or 0))
    if not files:
        fail(f"{run_dir}: no robot_<i>/metrics.csv")
    return [(int(re.sub(r"\D", "", os.path.basename(os.path.dirname(p)))), load_robot(p)) for p in files]


def window_from_summary(run_dir):
    """(T1, T2, spec) of the partition named in robot_0/summary.txt, or None."""
    path = os.path.join(run_dir, "robot_0", "summary.txt")
    try:
        with open(path, encoding="utf-8") as f:
            text = f.read()
    except OSError:
        return None
    m = re.search(r"network faults injected \(([^)]*)\)", text)
    if not m or "partition=" not in m.group(1):
        return None
    spec = m.group(1)
    kv = dict(p.split("=", 1) for p in spec.split(",") if "=" in p)
    t1 = float(kv.get("from", 0.0))
    t2 = float(kv.get("until", math.inf))
    return t1, t2, kv["partition"]


def with_gaps(x, y):
    """x, y with a NaN point after each jump of x (rounds skipped), so that lines break there."""
    jumps = np.nonzero(np.diff(x) > 1)[0]
    return np.insert(x, jumps + 1, x[jumps] + 1), np.insert(y.astype(float), jumps + 1, np.nan)


def mean(v):
    v = v[np.isfinite(v)]
    return float(v.mean()) if len(v) else math.nan


def figures(m, t1, t2, rounds):
    """Mean disagreement before, inside, just after and at the end; the rounds with no neighbour."""
    w, d = m["wall_s"], m["disagreement"]
    inside = (w >= t1) & (w <= t2)
    before = mean(d[(w < t1) & (m["round"] > 0)])
    during = mean(d[inside])
    healed = d[(w > t2) & np.isfinite(d)]
    after = mean(healed[:10])
    tail = mean(d[m["round"] >= 0.9 * rounds])
    alone = m["round"][m["neighbours"] == 0]
    return before, during, after, tail, alone


def fmt(x):
    return "-" if not math.isfinite(x) else f"{x:.2g}"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("run", help="run folder with robot_<i>/metrics.csv")
    ap.add_argument("--out", default=None, help="output PNG (default RUN/partition.png)")
    ap.add_argument("--from", dest="t1", type=float, default=None, help="start of the partition (s)")
    ap.add_argument("--until", dest="t2", type=float, default=None, help="end of the partition (s)")
    ap.add_argument("--reference", default=None, help="an unpartitioned run of the same settings")
    ap.add_argument("--title", default=None)
    a = ap.parse_args()
    robots = load_run(a.run)
    found = window_from_summary(a.run)
    spec = found[2] if found else None
    t1 = a.t1 if a.t1 is not None else (found[0] if found else None)
    t2 = a.t2 if a.t2 is not None else (found[1] if found else None)
    if t1 is None or t2 is None:
        fail(f"{a.run}: no partition in robot_0/summary.txt; give --from and --until")
    if not t2 > t1:
        fail(f"the partition must end after it starts (from {t1} until {t2})")
    rounds = max(int(m["round"].max()) + 1 for _, m in robots)
    ref = load_run(a.reference) if a.reference else None

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(7.2, 5.4), dpi=100, sharex=True,
                                   gridspec_kw={"height_ratios": [2.2, 1]})
    shade = []
    for i, m in robots:
        r = m["round"][(m["wall_s"] >= t1) & (m["wall_s"] <= t2)]
        if len(r):
            shade.append((r.min(), r.max()))
    if shade:
        lo, hi = min(s[0] for s in shade), max(s[1] for s in shade)
        for ax in (ax1, ax2):
            ax.axvspan(lo, hi, color="0.85", lw=0, zorder=0)
        ax1.text((lo + hi) / 2, 0.98, f"partitioned\n({t1:g} s to {t2:g} s)", transform=ax1.get_xaxis_transform(),
                 ha="center", va="top", fontsize=8, color="0.3")
    print(f"partition {spec or '?'} from {t1:g} s until {t2:g} s; {rounds} rounds")
    print("robot  rounds-alone  disagreement: before  during  after-heal  last-10%")
    for n, (i, m) in enumerate(robots):
        d = np.where(m["neighbours"] > 0, m["disagreement"], np.nan)
        line, = ax1.plot(*with_gaps(m["round"], d), lw=1.0, color=robot_colour(i), label=f"robot {i}")
        ax2.step(*with_gaps(m["round"], m["neighbours"] + 0.06 * (n - (len(robots) - 1) / 2)), where="post",
                 lw=1.0, color=line.get_color(), label=f"robot {i}")
        before, during, after, tail, alone = figures(m, t1, t2, rounds)
        span = f"{len(alone)} ({alone.min():.0f}..{alone.max():.0f})" if len(alone) else "0"
        print(f"{i:5d}  {span:>12}  {fmt(before):>20}  {fmt(during):>6}  {fmt(after):>10}  {fmt(tail):>8}")
    if ref:
        i, m = ref[0]
        ax1.plot(m["round"], np.where(m["neighbours"] > 0, m["disagreement"], np.nan), "--", color="0.4", lw=0.9,
                 label=f"robot {i}, no partition")
        print(f"reference {a.reference}: robot {i}'s disagreement in the last 10 % of the rounds "
              f"{fmt(mean(m['disagreement'][m['round'] >= 0.9 * rounds]))}")
    ax1.set_yscale("log")
    ax1.set_ylabel("disagreement\n(|theta - neighbours' mean| / |mean|)")
    ax1.grid(alpha=0.3)
    ax1.legend(fontsize=8, loc="lower right")
    ax2.set_ylabel("neighbours")
    ax2.set_xlabel("round")
    ax2.set_yticks(range(0, max(int(m["neighbours"].max()) for _, m in robots) + 1))
    ax2.grid(alpha=0.3)
    ax1.set_title(a.title or f"{len(robots)} robots, partition {spec or ''} from {t1:g} s to {t2:g} s", fontsize=10)
    fig.tight_layout()
    out = a.out or os.path.join(a.run, "partition.png")
    fig.savefig(out)
    print(f"plot_partition: wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
