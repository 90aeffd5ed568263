#!/usr/bin/python3
"""Tests of the coverage in tools/fleet_report.py (and tools/fleet_figures.py's coverage.png): a run
folder with the fleet's coverage.csv (host_sim coverage merge) and each robot's gets the final
coverage in summary.md and the figure; a coverage.csv that is not a share of the free space that
only rises stops the report with a one-line reason before summary.md is written; a folder without
one names it under "Not in this report". The files are fabricated in host_sim's format
(sim_time_s,robot_seconds,coverage), test data only.

    python3 tests/tools/test_fleet_coverage.py      prints "N passed, M failed", exit 1 on failure
"""
import os
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.realpath(__file__)))
from minitest import check, main, need_numpy, test  # noqa: E402

need_numpy("test_fleet_coverage")
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.realpath(__file__))))
TOOL = os.path.join(ROOT, "tools", "fleet_report.py")
HEADER = "sim_time_s,robot_seconds,coverage\n"


def write(path, rows, robots=1):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w") as f:
        f.write(HEADER)
        for t, c in rows:
            f.write(f"{t:.3f},{robots * t:.3f},{c:.6f}\n")


def run_folder(d, fleet_rows):
    run = os.path.join(d, "run")
    write(os.path.join(run, "robot_0", "coverage.csv"), [(0, 0.1), (1, 0.3), (2, 0.5), (2.5, 0.5)])
    write(os.path.join(run, "robot_1", "coverage.csv"), [(0, 0.05), (1, 0.2), (2, 0.4), (2.5, 0.45)])
    if fleet_rows is not None:
        write(os.path.join(run, "coverage.csv"), fleet_rows, robots=2)
    return run


def report(run):
    p = subprocess.run([sys.executable, TOOL, run, "--quiet"], capture_output=True, text=True, timeout=120)
    return p.returncode, p.stderr


def summary(run):
    with open(os.path.join(run, "summary.md")) as f:
        return f.read()


@test
def coverage_line_and_figure():
    with tempfile.TemporaryDirectory() as d:
        run = run_folder(d, [(0, 0.12), (1, 0.4), (2, 0.7), (2.5, 0.75)])
        rc, err = report(run)
        check(rc == 0 and err == "", f"exit {rc}: {err}")
        s = summary(run)
        check("- coverage: 0.750 of the free space seen by some lidar ray at 2.5 s simulated (5 robot-seconds"
              in s, s)
        check("alone: robot 0 0.500, robot 1 0.450" in s, s)
        check("![coverage](coverage.png)" in s, "figure in summary.md")
        check(os.path.getsize(os.path.join(run, "coverage.png")) > 1000, "coverage.png drawn")


@test
def missing_fleet_coverage_is_noted():
    with tempfile.TemporaryDirectory() as d:
        run = run_folder(d, None)
        rc, err = report(run)
        check(rc == 0, err)
        s = summary(run)
        check("coverage.csv is missing" in s and "- coverage:" not in s, s)
        check(os.path.isfile(os.path.join(run, "coverage.png")), "the robots' curves still drawn")


@test
def bad_coverage_stops():
    for rows, why in (([(0, 0.2), (1, 1.5)], "outside [0, 1]"), ([(0, 0.5), (1, 0.4)], "falls"),
                      ([(1, 0.1), (1, 0.2)], "time does not rise")):
        with tempfile.TemporaryDirectory() as d:
            run = run_folder(d, rows)
            rc, err = report(run)
            check(rc == 1 and why in err and len(err.strip().splitlines()) == 1, f"{rows}: {rc} {err}")
            check(not os.path.exists(os.path.join(run, "summary.md")), "no output before the inputs are checked")


if __name__ == "__main__":
    sys.exit(main())
