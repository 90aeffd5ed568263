#!/usr/bin/python3
"""Loss curves of one or more fleet runs (host_sim fleet --inproc ... --out DIR).

usage: tools/plot_metrics.py [--out FILE.png] [--column val_loss] [--label NAME ...] RUN_DIR...

Each RUN_DIR holds a metrics.csv (round,agent,train_loss,val_loss,kl_loss,consensus_error,
occ_mse,occ_iou,...). For every run the chosen column is averaged over the agents at each
logged round and drawn as one line, with a band from the best to the worst agent. Prints the
final value of every run. Needs numpy and matplotlib (Debian python3-numpy, python3-matplotlib).
"""
import argparse
import os
import sys

import numpy as np


def load(run_dir, column):
    path = os.path.join(run_dir, "metrics.csv")
    try:
        with open(path, encoding="utf-8") as f:
            header = f.readline().strip().split(",")
            rows = [line.strip().split(",") for line in f if line.strip()]
    except OSError as e:
        raise SystemExit(f"plot_metrics: cannot read {path}: {e.strerror}")
    for need in ("round", "agent", column):
        if need not in header:
            raise SystemExit(f"plot_metrics: {path}: no column '{need}' (has {','.join(header)})")
    ir, ic = header.index("round"), header.index(column)
    data = {}
    for n, r in enumerate(rows, start=2):
        if len(r) != len(header):
            raise SystemExit(f"plot_metrics: {path}:{n}: {len(r)} fields, expected {len(header)}")
        try:
            k, v = int(r[ir]), float(r[ic])
        except ValueError:
            raise SystemExit(f"plot_metrics: {path}:{n}: bad number")
        data.setdefault(k, []).append(v)
    if not data:
        raise SystemExit(f"plot_metrics: {path}: no rows")
    ks = np.array(sorted(data))
    vals = [np.array(data[k]) for k in ks]
    return ks, np.array([v.mean() for v in vals]), np.array([v.min() for v in vals]), np.array([v.max() for v in vals])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("runs", nargs="+", help="run directories with metrics.csv")
    ap.add_argument("--out", default="val_loss.png", help="output PNG (default val_loss.png)")
    ap.add_argument("--column", default="val_loss", help="metrics.csv column (default val_loss)")
    ap.add_argument("--label", action="append", help="legend label per run (default: directory name)")
    ap.add_argument("--log", action="store_true", help="logarithmic y axis")
    ap.add_argument("--skip-first", action="store_true", help="do not draw round 0 (the untrained model)")
    ap.add_argument("--title", default=None)
    a = ap.parse_args()
    if a.label and len(a.label) != len(a.runs):
        raise SystemExit("plot_metrics: give one --label per run")
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 3.8), dpi=100)
    for i, run in enumerate(a.runs):
        ks, mean, lo, hi = load(run, a.column)
        if a.skip_first and len(ks) > 1 and ks[0] == 0:
            ks, mean, lo, hi = ks[1:], mean[1:], lo[1:], hi[1:]
        name = a.label[i] if a.label else os.path.basename(os.path.normpath(run))
        line, = ax.plot(ks, mean, label=name, lw=1.4)
        if np.any(hi > lo):
            ax.fill_between(ks, lo, hi, color=line.get_color(), alpha=0.15, lw=0)
        print(f"{name}: final {a.column} {mean[-1]:.5f} (agents {lo[-1]:.5f} .. {hi[-1]:.5f}) at round {ks[-1]}")
    ax.set_xlabel("round")
    ax.set_ylabel(a.column + " (mean over agents; band: min..max)")
    if a.log:
        ax.set_yscale("log")
    if a.title:
        ax.set_title(a.title)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(a.out)
    print(f"plot_metrics: wrote {a.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
