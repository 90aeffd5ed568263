#!/usr/bin/python3
"""Compares a board image's run with the host build of the same program (make run-board):
the loss, BCE and KL of every round and the final figures must agree within a float
tolerance. The two builds run the same code on other instruction sets and C libraries
(sinf, expf, logf differ in their last bits), so they agree closely, not bit for bit.

    tools/board/board_check.py BOARD_RUN.txt HOST_RUN.txt [--rtol 1e-4]

Exit 0 when they agree, 1 when they do not or a run is incomplete, 2 on bad arguments."""
import argparse
import math
import re
import sys

ROUND = re.compile(r"^round (\d+) loss (\S+) bce (\S+) kl (\S+)")
RESULT = re.compile(r"^result (\w+) (\S+)")
COMPARED = ("loss_final", "bce_final", "bce_all_mean_weights", "sigma_mean_mc")


def parse_text(text):
    """({round: (loss, bce, kl)}, {result key: value string}) of a board_train output."""
    rounds, results = {}, {}
    for line in text.splitlines():
        m = ROUND.match(line)
        if m:
            rounds[int(m.group(1))] = tuple(float(v) for v in m.group(2, 3, 4))
        m = RESULT.match(line)
        if m:
            results[m.group(1)] = m.group(2)
    return rounds, results


def parse(path):
    with open(path, encoding="utf-8", errors="replace") as f:
        return parse_text(f.read())


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("board")
    ap.add_argument("host")
    ap.add_argument("--rtol", type=float, default=1e-4, help="relative tolerance (default 1e-4)")
    a = ap.parse_args(argv)
    try:
        (br, bres), (hr, hres) = parse(a.board), parse(a.host)
    except OSError as e:
        print(f"board_check: {e}", file=sys.stderr)
        return 1
    problems = []
    if not hr or "loss_final" not in hres:
        problems.append(f"{a.host}: no complete run")
    if not br or "loss_final" not in bres:
        problems.append(f"{a.board}: no complete run")
    if sorted(br) != sorted(hr):
        problems.append(f"rounds differ: board {len(br)}, host {len(hr)}")
    worst = 0.0

    def close(x, y, what):
        nonlocal worst
        if not (math.isfinite(x) and math.isfinite(y)):
            problems.append(f"{what}: not finite (board {x}, host {y})")
            return
        rel = abs(x - y) / max(abs(y), 1e-6)
        worst = max(worst, rel)
        if rel > a.rtol:
            problems.append(f"{what}: board {x:.6f}, host {y:.6f} (relative {rel:.1e})")

    for k in sorted(set(br) & set(hr)):
        for name, x, y in zip(("loss", "bce", "kl"), br[k], hr[k]):
            close(x, y, f"round {k} {name}")
    for key in COMPARED:
        if key in bres and key in hres:
            close(float(bres[key]), float(hres[key]), key)
    if problems:
        for p in problems:
            print(f"board_check: {p}", file=sys.stderr)
        print(f"board_check: {a.board} and {a.host} DISAGREE", file=sys.stderr)
        return 1
    print(f"board_check: {len(br)} rounds, final loss {bres['loss_final']} on the board, "
          f"{hres['loss_final']} on the host; largest relative difference {worst:.1e} "
          f"(tolerance {a.rtol:.0e}): agree")
    return 0


if __name__ == "__main__":
    sys.exit(main())
