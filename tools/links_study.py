#!/usr/bin/python3
"""DiNNO over bad and cheap links, in the in-process fleet: partitions, a robot away, links that
deliver a state with probability p, and the compressed exchanges; the original rule (one dual
per robot, no rejoin) against the new one (one dual per link, rejoin), same seeds.

usage: tools/links_study.py [--robots 16] [--rounds 400] [--cut-from 100] [--cut-rounds 200]
                            [--codec-robots 4] [--codec-rounds 1500] [--out results/links]
                            [--docs docs/faults] [--only NAME ...] [--plots-only] [--bin HOST_SIM]

Every run is a real `host_sim fleet --inproc` on the bundled apartment plan with the tours of
`host_sim paths gen` (one start room per robot), every robot a neighbour of every other (full
graph) so that what moves the figures is the links alone. A run whose folder holds a
summary.txt is not run again: the study resumes where it was stopped. Writes, in --docs:
links.csv (one row per run: the final validation loss and consensus error, and for the cuts
the consensus error 10 rounds after the heal against the lossless run's at that round),
links_cut.png (consensus error against rounds: lossless, the 8/8 cut, one robot away; both
rules), links_success.png (validation loss and consensus error at 50 %, 5 % and 1 % link
success; both rules) and links_bytes.png (validation loss against the bytes each robot sent:
fp32, int8, int8-ef, int4-ef; --codec-robots robots, --codec-rounds rounds). Needs numpy and
matplotlib. About 50 minutes on 2 cores of a Zen 4 (16 robots: 0.4 s a round).
"""
import argparse
import csv
import math
import os
import subprocess
import sys

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.realpath(__file__)))
PLAN = os.path.join(ROOT, "host_sim/plans/apartment.svg")
OLD = ["--dual-rule", "node", "--rejoin-gap", "0"]  # DiNNO as it was: one dual per robot
NEW = []                                             # the defaults: one dual per link, rejoin


def fail(msg):
    raise SystemExit(f"links_study: {msg}")


def run(cmd, log=None):
    print("+", " ".join(cmd), flush=True)
    with open(log, "w") if log else open(os.devnull, "w") as f:
        r = subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT)
    if r.returncode != 0:
        fail(f"{' '.join(cmd)} exited {r.returncode}" + (f" (see {log})" if log else ""))


def scenarios(a):
    """(name, robots, rounds, extra options) of every run."""
    half = ".".join(str(i) for i in range(a.robots // 2))
    other = ".".join(str(i) for i in range(a.robots // 2, a.robots))
    until = a.cut_from + a.cut_rounds
    cut = ["--link-faults", f"partition={half}/{other},from={a.cut_from},until={until}"]
    away = ["--link-faults", f"away=0,from={a.cut_from},until={until}"]
    out = [("lossless", a.robots, a.rounds, [])]
    for rule, opts in (("old", OLD), ("new", NEW)):
        out += [(f"cut-{rule}", a.robots, a.rounds, cut + opts), (f"away-{rule}", a.robots, a.rounds, away + opts)]
        for p in ("0.5", "0.05", "0.01"):
            out.append((f"p{p}-{rule}", a.robots, a.rounds, ["--link-success", p] + opts))
    for codec in ("fp32", "int8", "int8-ef", "int4-ef"):
        out.append((f"codec-{codec}", a.codec_robots, a.codec_rounds, ["--encoding", codec]))
    # No fault at all, robots moving in and out of reach (the disk graph of tools/fleet): what the
    # new rule changes for a lossless run whose neighbours come and go.
    out += [(f"disk-{rule}", a.robots, a.rounds, ["--graph", "disk"] + opts) for rule, opts in (("old", OLD), ("new", NEW))]
    return out


def make_data(a, hs, robots):
    d = os.path.join(a.out, f"data{robots}")
    if os.path.exists(os.path.join(d, "valset.samples")):
        return d
    os.makedirs(d, exist_ok=True)
    run([hs, "paths", "gen", "--plan", PLAN, "--robots", str(robots), "--seed", str(a.seed), "--out",
         f"{d}/paths"])
    for i in range(robots):
        run([hs, "scan", "--plan", PLAN, "--path", f"{d}/paths/robot_{i}.csv", "--robot", str(i), "--seed",
             str(a.seed), "--out", f"{d}/samples/robot_{i}.samples", "-q"])
    run([hs, "valset", "--plan", PLAN, "--poses", str(a.val_poses), "--seed", str(a.seed), "--out",
         f"{d}/valset.samples"])
    return d


def fleet(a, hs, name, robots, rounds, extra):
    out = os.path.join(a.out, name)
    if os.path.exists(os.path.join(out, "summary.txt")):
        return out
    d = make_data(a, hs, robots)
    run([hs, "fleet", "--inproc", "--plan", PLAN, "--paths", f"{d}/paths", "--robots", str(robots),
         "--rounds", str(rounds), *([] if "--graph" in extra else ["--graph", "full"]), "--seed", str(a.seed), "--threads", "2",
         "--samples", f"{d}/samples", "--valset", f"{d}/valset.samples", "--metrics-every", "1",
         "--val-stride", str(a.val_stride), "--mc", "2", "--val-mc", "2", "--out", out, *extra],
        log=out + ".log")
    return out


def load(out):
    """Per round: mean validation loss over the agents (NaN between val rows), largest consensus
    error, mean neighbours; and the state bytes per round of one robot (summary.txt)."""
    rows = {}
    with open(os.path.join(out, "metrics.csv"), encoding="utf-8") as f:
        for r in csv.DictReader(f):
            rows.setdefault(int(r["round"]), []).append(r)
    k = np.array(sorted(rows))
    val = np.array([np.mean([float(r["val_loss"]) for r in rows[i]]) for i in k])
    cons = np.array([max(float(r["consensus_error"]) for r in rows[i]) for i in k])
    nb = np.array([np.mean([float(r["neighbours"]) for r in rows[i]]) for i in k])
    state_bytes = math.nan
    with open(os.path.join(out, "summary.txt"), encoding="utf-8") as f:
        for line in f:
            if line.startswith("state bytes per round and robot:"):
                state_bytes = float(line.split(":")[1].split()[0])
    return {"round": k, "val": val, "cons": cons, "nb": nb, "state_bytes": state_bytes}


def last_finite(x):
    x = x[np.isfinite(x)]
    return float(x[-1]) if len(x) else math.nan


def table(a, runs):
    ref = runs["lossless"]
    heal = a.cut_from + a.cut_rounds
    rows = []
    for name, m in runs.items():
        # the encodings are compared with fp32 of the same (smaller) fleet
        base = runs.get("codec-fp32", ref) if name.startswith("codec") else ref
        row = {"run": name, "final_val_loss": last_finite(m["val"]), "final_consensus_error": last_finite(m["cons"]),
               "val_vs_lossless": last_finite(m["val"]) / last_finite(base["val"]),
               "consensus_vs_lossless": last_finite(m["cons"]) / last_finite(base["cons"]),
               "mean_neighbours": float(np.mean(m["nb"])), "state_bytes": m["state_bytes"]}
        if name.startswith(("cut", "away")):
            for after in (1, 5, 10, 50):
                k = heal + after
                if k in set(m["round"].tolist()) and k in set(ref["round"].tolist()):
                    e = m["cons"][m["round"] == k][0]
                    row[f"heal+{after}_vs_lossless"] = e / ref["cons"][ref["round"] == k][0]
            row["rounds_to_1.1x"] = rounds_to(m, ref, heal, 1.1)
        rows.append(row)
    keys = []
    for r in rows:
        keys += [k for k in r if k not in keys]
    path = os.path.join(a.docs, "links.csv")
    with open(path, "w", encoding="utf-8", newline="") as f:
        w = csv.DictWriter(f, fieldnames=keys)
        w.writeheader()
        for r in rows:
            w.writerow({k: (f"{v:.4g}" if isinstance(v, float) else v) for k, v in r.items()})
    print(f"wrote {path}")
    for r in rows:
        print("  " + ", ".join(f"{k}={v:.4g}" if isinstance(v, float) else f"{k}={v}" for k, v in r.items()))


def rounds_to(m, ref, heal, factor):
    """Rounds after the heal until the consensus error stays within factor x the lossless run's."""
    common = [k for k in m["round"].tolist() if k >= heal and k in set(ref["round"].tolist())]
    ratio = {k: m["cons"][m["round"] == k][0] / ref["cons"][ref["round"] == k][0] for k in common}
    for k in common:
        if all(ratio[j] <= factor for j in common if j >= k):
            return float(k - heal)
    return math.nan


def plots(a, runs):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    heal0, heal1 = a.cut_from, a.cut_from + a.cut_rounds
    styles = {"old": dict(ls="--", lw=1.2), "new": dict(ls="-", lw=1.4)}
    fig, axes = plt.subplots(1, 2, figsize=(11, 4), sharey=True)
    for ax, what, title in ((axes[0], "cut", f"{a.robots // 2}/{a.robots // 2} cut"), (axes[1], "away", "robot 0 away")):
        ax.semilogy(runs["lossless"]["round"], runs["lossless"]["cons"], color="k", lw=1, label="lossless")
        for rule, colour in (("old", "tab:red"), ("new", "tab:blue")):
            m = runs.get(f"{what}-{rule}")
            if m is not None:
                ax.semilogy(m["round"], m["cons"], color=colour, **styles[rule],
                            label=f"{'one dual per robot' if rule == 'old' else 'one dual per link + rejoin'}")
        ax.axvspan(heal0, heal1, color="0.9", zorder=0)
        ax.set_title(f"{title}, rounds {heal0}-{heal1}")
        ax.set_xlabel("round")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("consensus error (largest over the robots)")
    axes[0].legend(loc="upper left", fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(a.docs, "links_cut.png"), dpi=110)
    plt.close(fig)

    fig, axes = plt.subplots(2, 3, figsize=(13, 6.5), sharex=True)
    for c, p in enumerate(("0.5", "0.05", "0.01")):
        for rule, colour in (("old", "tab:red"), ("new", "tab:blue")):
            m = runs.get(f"p{p}-{rule}")
            if m is None:
                continue
            ok = np.isfinite(m["val"])
            axes[0][c].plot(m["round"][ok], m["val"][ok], color=colour, **styles[rule], label=rule)
            axes[1][c].semilogy(m["round"], m["cons"], color=colour, **styles[rule])
        ref = runs["lossless"]
        ok = np.isfinite(ref["val"])
        axes[0][c].plot(ref["round"][ok], ref["val"][ok], color="k", lw=1, label="lossless")
        axes[1][c].semilogy(ref["round"], ref["cons"], color="k", lw=1)
        axes[0][c].set_title(f"links deliver {float(p) * 100:g} % of rounds")
        axes[1][c].set_xlabel("round")
        for ax in (axes[0][c], axes[1][c]):
            ax.grid(alpha=0.3)
    axes[0][0].set_ylabel("validation loss (BCE, mean over robots)")
    axes[1][0].set_ylabel("consensus error (largest)")
    axes[0][0].legend(["one dual per robot", "one dual per link + rejoin", "lossless"], fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(a.docs, "links_success.png"), dpi=110)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(6.5, 4))
    for codec, colour in (("fp32", "k"), ("int8", "tab:orange"), ("int8-ef", "tab:blue"), ("int4-ef", "tab:green")):
        m = runs.get(f"codec-{codec}")
        if m is None:
            continue
        ok = np.isfinite(m["val"])
        mb = (m["round"][ok] + 1) * m["state_bytes"] / 1e6
        ax.plot(mb, m["val"][ok], color=colour, label=codec)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("MB sent per robot")
    ax.set_ylabel("validation loss (BCE, mean over robots)")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(a.docs, "links_bytes.png"), dpi=110)
    plt.close(fig)
    print(f"wrote {a.docs}/links_cut.png, links_success.png, links_bytes.png")


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--robots", type=int, default=16)
    p.add_argument("--rounds", type=int, default=400)
    p.add_argument("--cut-from", type=int, default=100)
    p.add_argument("--cut-rounds", type=int, default=200)
    p.add_argument("--codec-robots", type=int, default=4)
    p.add_argument("--codec-rounds", type=int, default=1500)
    p.add_argument("--val-stride", type=int, default=25)
    p.add_argument("--val-poses", type=int, default=200)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--out", default=os.path.join(ROOT, "results/links"))
    p.add_argument("--docs", default=os.path.join(ROOT, "docs/faults"))
    p.add_argument("--only", nargs="*", help="run only these (names as in links.csv)")
    p.add_argument("--plots-only", action="store_true", help="no runs: the table and the figures of what exists")
    p.add_argument("--bin", default=os.path.join(ROOT, "build/bin/host_sim"))
    a = p.parse_args()
    if a.robots < 2 or a.robots % 2 or a.cut_from + a.cut_rounds >= a.rounds:
        fail("--robots must be even (>= 2) and the cut must end before the last round")
    if not os.access(a.bin, os.X_OK):
        fail(f"{a.bin} is not built (make)")
    os.makedirs(a.docs, exist_ok=True)
    runs = {}
    for name, robots, rounds, extra in scenarios(a):
        if a.only and name not in a.only and not a.plots_only:
            continue
        if not a.plots_only:
            fleet(a, a.bin, name, robots, rounds, extra)
        out = os.path.join(a.out, name)
        if os.path.exists(os.path.join(out, "summary.txt")):
            runs[name] = load(out)
    if "lossless" not in runs:
        fail("the lossless run is missing (it is every figure's reference)")
    table(a, runs)
    plots(a, runs)


if __name__ == "__main__":
    main()
