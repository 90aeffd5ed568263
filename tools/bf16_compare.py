#!/usr/bin/env python3
"""Compare two `make run-inproc` results folders (fp32 and bf16 builds of the same job):
validation loss (mean over the robots), consensus error (max) and occupancy IoU per logged
round, and the final figures.

    tools/bf16_compare.py FP32_DIR BF16_DIR [--csv OUT]

Each folder is a RESULTS of tools/run-fleet.sh (metrics.csv). Prints one line per logged
round and a verdict: the final validation loss within 1 % of fp32's and the final consensus
error no more than fp32's x 1.5. Exit 0 when both hold, 1 otherwise, 2 on bad input."""
import argparse
import csv
import math
import sys


def per_round(path):
    rounds = {}
    with open(path, newline="") as f:
        for row in csv.DictReader(f):
            r = int(row["round"])
            d = rounds.setdefault(r, {"val": [], "cons": [], "iou": []})
            d["val"].append(float(row["val_loss"]))
            d["cons"].append(float(row["consensus_error"]))
            d["iou"].append(float(row["occ_iou"]))
    return {r: {"val": sum(d["val"]) / len(d["val"]), "cons": max(d["cons"]),
                "iou": sum(d["iou"]) / len(d["iou"])} for r, d in rounds.items()}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("fp32")
    ap.add_argument("bf16")
    ap.add_argument("--csv", help="write the per-round comparison here")
    a = ap.parse_args()
    try:
        f, b = per_round(a.fp32 + "/metrics.csv"), per_round(a.bf16 + "/metrics.csv")
    except (OSError, KeyError, ValueError) as e:
        print(f"bf16_compare: {e}", file=sys.stderr)
        return 2
    common = sorted(set(f) & set(b))
    if not common:
        print("bf16_compare: no round in common", file=sys.stderr)
        return 2
    rows = []
    for r in common:
        rel = 100.0 * (b[r]["val"] - f[r]["val"]) / f[r]["val"]
        rows.append([r, f"{f[r]['val']:.5f}", f"{b[r]['val']:.5f}", f"{rel:+.2f}",
                     f"{f[r]['cons']:.3g}", f"{b[r]['cons']:.3g}", f"{f[r]['iou']:.4f}",
                     f"{b[r]['iou']:.4f}"])
    head = ["round", "val_loss_fp32", "val_loss_bf16", "val_loss_diff_pct",
            "consensus_err_fp32", "consensus_err_bf16", "occ_iou_fp32", "occ_iou_bf16"]
    if a.csv:
        with open(a.csv, "w", newline="") as out:
            w = csv.writer(out)
            w.writerow(head)
            w.writerows(rows)
    print(" ".join(f"{h:>18}" for h in head))
    for row in rows:
        print(" ".join(f"{str(c):>18}" for c in row))
    last = common[-1]
    rel = abs(b[last]["val"] - f[last]["val"]) / f[last]["val"]
    cons_ok = b[last]["cons"] <= 1.5 * f[last]["cons"] or math.isclose(b[last]["cons"], f[last]["cons"])
    ok = rel <= 0.01 and cons_ok
    print(f"round {last}: val_loss bf16 {b[last]['val']:.5f} vs fp32 {f[last]['val']:.5f} "
          f"({100 * rel:.2f} % apart, limit 1 %); consensus error {b[last]['cons']:.3g} vs "
          f"{f[last]['cons']:.3g}: {'OK' if ok else 'NOT OK'}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
