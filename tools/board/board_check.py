#!/usr/bin/python3
"""Compares a board image's run with the host build of the same program (make run-board):
the loss, BCE and KL of every round and the final figures must agree within a float
tolerance, and the one-pass uncertainty of every inference point (`post <i> p <p> unknown
<u>`, the share of prior variance left) within its own: it is a difference of float dot
products over D = S + 1 features through a float L^-1, so it keeps fewer digits than the
losses. The two builds run the same code on other instruction
sets and C libraries (sinf, expf, logf differ in their last bits), so they agree closely,
not bit for bit.

    tools/board/board_check.py BOARD_RUN.txt HOST_RUN.txt [--rtol 1e-4] [--rtol-post 1e-3]

Exit 0 when they agree, 1 when they do not or a run is incomplete, 2 on bad arguments."""
import argparse
import math
import re
import sys

ROUND = re.compile(r"^round (\d+) loss (\S+) bce (\S+) kl (\S+)")
RESULT = re.compile(r"^result (\w+) (\S+)")
POST = re.compile(r"^post (\d+) p (\S+) unknown (\S+)")
COMPARED = ("loss_final", "bce_final", "bce_all_mean_weights", "sigma_mean_mc")
COMPARED_POST = ("unknown_mean_post",)  # at --rtol-post, with every point's share


def parse_text_post(text):
    """({round: (loss, bce, kl)}, {result key: value string}, {point: (p, unknown)}) of a
    board_train output."""
    rounds, results, post = {}, {}, {}
    for line in text.splitlines():
        m = ROUND.match(line)
        if m:
            rounds[int(m.group(1))] = tuple(float(v) for v in m.group(2, 3, 4))
        m = RESULT.match(line)
        if m:
            results[m.group(1)] = m.group(2)
        m = POST.match(line)
        if m:
            post[int(m.group(1))] = (float(m.group(2)), float(m.group(3)))
    return rounds, results, post


def parse_text(text):
    """({round: (loss, bce, kl)}, {result key: value string}) of a board_train output."""
    return parse_text_post(text)[:2]


def parse(path):
    with open(path, encoding="utf-8", errors="replace") as f:
        return parse_text_post(f.read())


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("board")
    ap.add_argument("host")
    ap.add_argument("--rtol", type=float, default=1e-4, help="relative tolerance (default 1e-4)")
    ap.add_argument("--rtol-post", type=float, default=1e-3,
                    help="relative tolerance of the one-pass uncertainty (default 1e-3)")
    a = ap.parse_args(argv)
    try:
        (br, bres, bp), (hr, hres, hp) = parse(a.board), parse(a.host)
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
    if sorted(bp) != sorted(hp):
        problems.append(f"one-pass uncertainty points differ: board {len(bp)}, host {len(hp)}")
    worst, worst_post = 0.0, 0.0

    def close(x, y, what, rtol=None):
        nonlocal worst, worst_post
        if not (math.isfinite(x) and math.isfinite(y)):
            problems.append(f"{what}: not finite (board {x}, host {y})")
            return
        rel = abs(x - y) / max(abs(y), 1e-6)
        if rtol is None:
            worst = max(worst, rel)
        else:
            worst_post = max(worst_post, rel)
        if rel > (a.rtol if rtol is None else rtol):
            problems.append(f"{what}: board {x:.6g}, host {y:.6g} (relative {rel:.1e})")

    for k in sorted(set(br) & set(hr)):
        for name, x, y in zip(("loss", "bce", "kl"), br[k], hr[k]):
            close(x, y, f"round {k} {name}")
    for key in COMPARED:
        if key in bres and key in hres:
            close(float(bres[key]), float(hres[key]), key)
    for key in COMPARED_POST:
        if key in bres and key in hres:
            close(float(bres[key]), float(hres[key]), key, a.rtol_post)
    for i in sorted(set(bp) & set(hp)):
        close(bp[i][1], hp[i][1], f"point {i} unknown", a.rtol_post)
    if problems:
        for p in problems:
            print(f"board_check: {p}", file=sys.stderr)
        print(f"board_check: {a.board} and {a.host} DISAGREE", file=sys.stderr)
        return 1
    print(f"board_check: {len(br)} rounds, final loss {bres['loss_final']} on the board, "
          f"{hres['loss_final']} on the host; largest relative difference {worst:.1e} "
          f"(tolerance {a.rtol:.0e})"
          + (f"; one-pass uncertainty of {len(bp)} points, mean {bres.get('unknown_mean_post', '-')}, "
             f"largest relative difference {worst_post:.1e} (tolerance {a.rtol_post:.0e})" if bp else "")
          + ": agree")
    return 0


if __name__ == "__main__":
    sys.exit(main())
