#!/usr/bin/python3
"""Tests of tools/plot_partition.py on a synthetic 3-robot run folder: robot 0 cut off from
2 s to 3 s (rounds 40..60), robots 1 and 2 each other's only neighbour then and skipping rounds
61..69 after the heal.

    python3 tests/tools/test_plot_partition.py      prints "N passed, M failed", exit 1 on failure

Needs Debian's python3 with numpy and matplotlib: when the python3 found first lacks numpy, the
test runs itself again with /usr/bin/python3.
"""
import math
import os
import shutil
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.realpath(__file__)))
from minitest import check, main, need_numpy, test  # noqa: E402

need_numpy("test_plot_partition")

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.realpath(__file__))))
TOOL = os.path.join(ROOT, "tools", "plot_partition.py")
ENV = dict(os.environ, MPLBACKEND="Agg")
HEADER = ("round,sim_time_s,distance_m,progress_m,pool_fill,pool_capacity,ring_drops,train_loss,bce,val_loss,kl,"
          "neighbours,disagreement,wall_s")
FAULTS = "network faults injected (partition=0/1.2,from=2,until=3): 0 dropped, 120 partitioned, 0 duplicated\n"


def run(args):
    p = subprocess.run([sys.executable, TOOL] + args, cwd=ROOT, env=ENV, capture_output=True, text=True,
                       timeout=120)
    return p.returncode, p.stdout, p.stderr


def write_run(d, partitioned=True, summary=True, header=HEADER):
    """Rounds 0..99 at 0.05 s each; with the partition, robot 0 alone in rounds 40..60 and
    robots 1 and 2 skipping 61..69."""
    for i in range(3):
        rd = os.path.join(d, f"robot_{i}")
        os.makedirs(rd)
        rows = []
        for k in range(100):
            t = 0.05 * k
            inside = partitioned and 2.0 <= t <= 3.0
            if partitioned and i > 0 and 61 <= k <= 69:
                continue
            nb = (0 if i == 0 else 1) if inside else 2
            dis = math.nan if nb == 0 else (0.02 * math.exp(-(k - 60) / 5) if partitioned and k > 60 else 3e-4)
            rows.append(f"{k},{t:.3f},1,1,10,100,0,0.1,0.1,nan,1,{nb},{dis:.6g},{t:.3f}")
        with open(os.path.join(rd, "metrics.csv"), "w") as f:
            f.write(header + "\n" + "\n".join(rows) + "\n")
        if summary:
            with open(os.path.join(rd, "summary.txt"), "w") as f:
                f.write("seed: 3\n" + (FAULTS if partitioned else ""))


def is_png(path):
    with open(path, "rb") as f:
        return f.read(8) == b"\x89PNG\r\n\x1a\n"


@test
def plots_a_partitioned_run():
    d = tempfile.mkdtemp()
    try:
        write_run(d)
        rc, out, err = run([d])
        check(rc == 0, f"exit {rc}: {err}")
        check(is_png(os.path.join(d, "partition.png")), "partition.png not written into the run")
        check("partition 0/1.2 from 2 s until 3 s; 100 rounds" in out, out)
        rows = {line.split()[0]: line.split() for line in out.splitlines() if line[:5].strip().isdigit()}
        check(rows["0"][1:3] == ["21", "(40..60)"], f"robot 0 alone in rounds 40..60:\n{out}")
        check(rows["1"][1] == "0" and rows["2"][1] == "0", f"robots 1 and 2 never alone:\n{out}")
        # robot 0: 3e-4 before, nothing during (no neighbour), about 0.02 after the heal, small at the end
        check(rows["0"][3] == "0.0003" and rows["0"][4] == "-", f"robot 0 before/during:\n{out}")
        check(0.005 < float(rows["0"][5]) < 0.02 and float(rows["0"][6]) < 0.001, f"robot 0 after/tail:\n{out}")
    finally:
        shutil.rmtree(d)


@test
def reference_and_explicit_window():
    d, ref = tempfile.mkdtemp(), tempfile.mkdtemp()
    try:
        write_run(d, summary=False)
        write_run(ref, partitioned=False, summary=False)
        png = os.path.join(d, "out.png")
        rc, out, err = run([d, "--out", png])
        check(rc != 0 and "give --from and --until" in err, f"no window known: {rc} {err}")
        rc, out, err = run([d, "--from", "2", "--until", "3", "--reference", ref, "--out", png])
        check(rc == 0 and is_png(png), f"exit {rc}: {err}")
        check("robot 0's disagreement in the last 10 % of the rounds 0.0003" in out, out)
        rc, out, err = run([d, "--from", "3", "--until", "2"])
        check(rc != 0 and "must end after it starts" in err, f"reversed window: {rc} {err}")
    finally:
        shutil.rmtree(d)
        shutil.rmtree(ref)


@test
def bad_inputs_are_named():
    d = tempfile.mkdtemp()
    try:
        rc, out, err = run([d])
        check(rc != 0 and "no robot_<i>/metrics.csv" in err, f"empty folder: {rc} {err}")
        write_run(d, header=HEADER.replace("disagreement", "consensus"))
        rc, out, err = run([d])
        check(rc != 0 and "no column 'disagreement'" in err, f"missing column: {rc} {err}")
    finally:
        shutil.rmtree(d)


if __name__ == "__main__":
    sys.exit(main())
