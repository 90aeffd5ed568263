#!/usr/bin/python3
"""Tests of the exploration figures (tools/explore_figures.py) and of the comparison's measures
(tools/explore_compare.py) on a small synthetic run folder: coverage.bin in host_sim's format
(host_sim/world/sim_coverage.h, CRC and all), robot_<i>/explore.csv, coverage.csv files and
summary.txt lines as host_sim writes them, run.json. Test data only; no host_sim is run.

    python3 tests/tools/test_explore_tools.py      prints "N passed, M failed", exit 1 on failure
"""
import json
import math
import os
import struct
import subprocess
import sys
import tempfile
import zlib

sys.path.insert(0, os.path.dirname(os.path.realpath(__file__)))
from minitest import check, main, need_numpy, test  # noqa: E402

need_numpy("test_explore_tools")
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.realpath(__file__))))
FIGURES = os.path.join(ROOT, "tools", "explore_figures.py")
sys.path.insert(0, os.path.join(ROOT, "tools"))
import explore_compare  # noqa: E402

EXPLORE_HEADER = ("sim_time_s,x_m,y_m,heading_rad,distance_m,goal_seq,goal_x_m,goal_y_m,goals_reached,"
                  "goals_failed,stuck_events,plans,plan_failures,avoid_stops,finished,belief_unknown_mean,"
                  "belief_unknown_max\n")
W, H, RES, T_END = 40, 30, 0.1, 20.0


def coverage_bin(path, t_end=T_END, damage=False, header_t_end=None):
    """A 4 x 3 m box: walls on the border, free inside, the cells seen at a time growing with x
    (the last columns never)."""
    cells = []
    for r in range(H):
        for c in range(W):
            if r in (0, H - 1) or c in (0, W - 1):
                cells.append(-1.0)
            elif c > 34:
                cells.append(math.inf)
            else:
                cells.append(min(t_end, c * 0.5))
    data = struct.pack(f"<{W * H}f", *cells)
    n_free = sum(1 for v in cells if v != -1.0)
    head = struct.pack("<8sIIIIddddQ", b"FSCOVBIN", 1, W, H, zlib.crc32(data) & 0xFFFFFFFF, RES, 0.0, 0.0,
                       t_end if header_t_end is None else header_t_end, n_free)
    if damage:
        data = data[:-4] + struct.pack("<f", 1.0)
    with open(path, "wb") as f:
        f.write(head + data)
    return n_free


def coverage_csv(path, robots, rows):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w") as f:
        f.write("sim_time_s,robot_seconds,coverage\n")
        for t, c in rows:
            f.write(f"{t:.3f},{robots * t:.3f},{c:.6f}\n")


def run_folder(d, robots=2):
    run = os.path.join(d, "explore-frontier-2robots-seed1")
    os.makedirs(run)
    coverage_bin(os.path.join(run, "coverage.bin"))
    with open(os.path.join(run, "run.json"), "w") as f:
        json.dump({"robots": robots, "seed": 1, "plan": "no/such/plan.svg",
                   "explore": {"policy": "frontier", "time_s": T_END}}, f)
    coverage_csv(os.path.join(run, "coverage.csv"), robots, [(t, min(0.9, 0.1 + 0.04 * t)) for t in range(21)])
    for i in range(robots):
        rd = os.path.join(run, f"robot_{i}")
        coverage_csv(os.path.join(rd, "coverage.csv"), 1, [(t, min(0.6, 0.05 + 0.03 * t)) for t in range(21)])
        with open(os.path.join(rd, "explore.csv"), "w") as f:
            f.write(EXPLORE_HEADER)
            for t in range(1, 21):
                goal = ("nan", "nan") if t < 3 else (f"{3.5:.3f}", f"{1.0 + i:.3f}")
                f.write(f"{t:.1f},{0.3 + 0.15 * t:.4f},{0.5 + i + 0.02 * t:.4f},0.0,{0.15 * t:.3f},"
                        f"{1 if t >= 3 else 0},{goal[0]},{goal[1]},0,0,0,1,0,0,0,0.5,200\n")
    return run


def figures(*args):
    p = subprocess.run([sys.executable, FIGURES] + list(args), capture_output=True, text=True, timeout=120)
    return p.returncode, p.stdout, p.stderr


@test
def figures_written():
    with tempfile.TemporaryDirectory() as d:
        run = run_folder(d)
        rc, out, err = figures(run, "--no-maps", "--frames", "5")
        check(rc == 0, f"exit {rc}: {err}")
        names = ("explore.gif", "explore_first_frame.png", "explore_coverage.png")
        lines = [ln for ln in out.splitlines() if ln.strip()]
        check(len(lines) == 3, f"one line per file: {out!r}")
        for name, line in zip(names, lines):
            p = os.path.join(run, name)
            check(os.path.isfile(p) and os.path.getsize(p) > 1000, f"{name} not written")
            check(p in line, f"{name} not named in {line!r}")
        from PIL import Image
        with Image.open(os.path.join(run, "explore.gif")) as im:
            check(im.format == "GIF" and 4 <= im.n_frames <= 7, f"{im.format}, {im.n_frames} frames")
        with Image.open(os.path.join(run, "explore_first_frame.png")) as im:
            check(im.format == "PNG", im.format)
        check(not [f for f in os.listdir(run) if f.startswith(".fleet_report.")], "a temporary file left behind")


@test
def no_checkpoints_no_map_panels():
    """Without --no-maps and without round checkpoints the exploration panel is drawn alone (a note)."""
    with tempfile.TemporaryDirectory() as d:
        run = run_folder(d)
        rc, out, err = figures(run, "--frames", "3")
        check(rc == 0, f"exit {rc}: {err}")
        check("no round checkpoints" in err, err)
        check("no map panels" in out, out)


@test
def bad_input_exits_1_with_a_message():
    with tempfile.TemporaryDirectory() as d:
        run = run_folder(d)
        cases = []
        rc, _, err = figures(os.path.join(d, "nope"), "--no-maps")
        cases.append((rc, err, "not a directory"))
        coverage_bin(os.path.join(run, "coverage.bin"), damage=True)
        rc, _, err = figures(run, "--no-maps")
        cases.append((rc, err, "CRC mismatch"))
        coverage_bin(os.path.join(run, "coverage.bin"))
        os.remove(os.path.join(run, "robot_1", "explore.csv"))
        rc, _, err = figures(run, "--no-maps")
        cases.append((rc, err, "robot_1/explore.csv: missing"))
        rc, _, err = figures(run, "--frames", "1")
        cases.append((rc, err, "--frames must be"))
        for rc, err, want in cases:
            check(rc == 1, f"{want}: exit {rc}")
            check(want in err and "Traceback" not in err, f"{want}: {err!r}")


@test
def bad_coverage_values_refused():
    with tempfile.TemporaryDirectory() as d:
        run = run_folder(d)
        coverage_bin(os.path.join(run, "coverage.bin"), header_t_end=5.0)  # cells seen after t_end
        rc, _, err = figures(run, "--no-maps")
        check(rc == 1 and "after t_end" in err and "Traceback" not in err, f"exit {rc}: {err!r}")


@test
def time_to_coverage():
    f = explore_compare.time_to_coverage
    xs, cov = [0, 3, 6, 9], [0.5, 0.8, 0.94, 0.96]
    check(abs(f(xs, cov, 0.95) - 7.5) < 1e-9, f"{f(xs, cov, 0.95)}")
    check(abs(f(xs, cov, 0.90) - (3 + 0.1 * 3 / 0.14)) < 1e-9, f"{f(xs, cov, 0.90)}")
    check(f(xs, cov, 0.5) == 0.0, "reached at the first row")
    check(f(xs, cov, 0.97) is None, "never reached")
    check(f(xs, [0.5, 0.95, 0.95, 0.96], 0.95) == 3.0, "reached exactly at a row")


@test
def run_row_from_a_synthetic_run():
    with tempfile.TemporaryDirectory() as d:
        run = os.path.join(d, "apartment-frontier-2robots-seed1")
        coverage_csv(os.path.join(run, "coverage.csv"), 2, [(0, 0.4), (10, 0.8), (20, 0.9), (30, 1.0)])
        for i, (dist, coll, failed, stuck, own) in enumerate(((10.0, 1, 2, 3, 0.5), (20.0, 0, 1, 0, 0.7))):
            rd = os.path.join(run, f"robot_{i}")
            coverage_csv(os.path.join(rd, "coverage.csv"), 1, [(0, 0.1), (30, own)])
            with open(os.path.join(rd, "summary.txt"), "w") as f:
                f.write(f"distance (true pose): {dist:.2f} m; odometry: {dist + 1:.2f} m; collisions: {coll}\n"
                        "coverage: 0.5 of free space at 30.0 s (1 robot, 0.10 m grid, 5 of 10 free cells seen)\n"
                        f"explore: policy frontier, 30 s budget; 7 goals (4 reached, {failed} given up); 15 plans "
                        f"(0 failed); {stuck} stuck events; 0 avoidance stops\n")
        check(explore_compare.finished(run, 2), "a finished run not seen as finished")
        check(not explore_compare.finished(run, 3), "a missing robot's summary not noticed")
        r = explore_compare.run_row(run, "apartment", "frontier", 1, 2)
        check(r["coverage_final"] == 1.0, r)
        check(abs(r["robot_seconds_to_90"] - 40.0) < 1e-9 and abs(r["robot_seconds_to_95"] - 50.0) < 1e-9, r)
        check(r["distance_m_mean"] == 15.0 and abs(r["visited_share_mean"] - 0.6) < 1e-9, r)
        check((r["stuck_events"], r["collisions"], r["goals_failed"]) == (3, 1, 3), r)
        with open(os.path.join(run, "run.json"), "w") as f:
            json.dump({"robots": 2, "seed": 1, "rounds": 6, "plan": "host_sim/plans/apartment.svg",
                       "explore": {"policy": "frontier", "time_s": 30.0, "fence": True}}, f)

        class A:
            robots, explore_time, rounds, no_fence = 2, 30.0, 6, False
        differ = explore_compare.settings_differ
        check(differ(run, "/x/apartment.svg", "frontier", 1, A) is None, "the same settings taken for others")
        A.explore_time = 60.0
        check("explore" in (differ(run, "/x/apartment.svg", "frontier", 1, A) or ""), "another time not seen")
        check(differ(run, "/x/apartment.svg", "tours", 1, A) is not None, "an exploration run taken for the tours")
        # the ablation: the uncertainty policy with each robot's own posterior is another run
        A.explore_time = 30.0
        with open(os.path.join(run, "run.json"), "w") as f:
            json.dump({"robots": 2, "seed": 1, "rounds": 6, "plan": "host_sim/plans/apartment.svg",
                       "explore": {"policy": "uncertainty", "time_s": 30.0, "own_posterior": True,
                                   "posterior_first": False, "fence": True}}, f)
        check(differ(run, "/x/apartment.svg", "uncertainty-own", 1, A) is None, "the ablation's run not recognised")
        check(differ(run, "/x/apartment.svg", "uncertainty", 1, A) is not None, "the ablation taken for the policy")
        A.fleet, A.bin, A.results = "fleet", "host_sim", d
        cmd = explore_compare.fleet_cmd(A, "apartment", "/x/apartment.svg", "uncertainty-own", 1, "n")
        check(cmd[cmd.index("--explore-policy") + 1] == "uncertainty" and "--explore-own-posterior" in cmd, cmd)
        cmd = explore_compare.fleet_cmd(A, "apartment", "/x/apartment.svg", "uncertainty", 1, "n")
        check("--explore-own-posterior" not in cmd and "--explore-posterior-first" not in cmd and
              "--explore-no-fence" not in cmd, cmd)
        # the ablation without the keep-in fence: another run, and a run.json of before the fence
        # (no "fence") is one without it
        A.no_fence = True
        check("--explore-no-fence" in explore_compare.fleet_cmd(A, "apartment", "/x/apartment.svg", "uncertainty", 1,
                                                               "n"), "--no-fence not passed on")
        check(differ(run, "/x/apartment.svg", "uncertainty-own", 1, A) is not None, "a fenced run taken unfenced")
        with open(os.path.join(run, "run.json"), "w") as f:
            json.dump({"robots": 2, "seed": 1, "rounds": 6, "plan": "host_sim/plans/apartment.svg",
                       "explore": {"policy": "uncertainty", "time_s": 30.0, "own_posterior": True,
                                   "posterior_first": False}}, f)
        check(differ(run, "/x/apartment.svg", "uncertainty-own", 1, A) is None, "a run of before the fence not unfenced")
        A.no_fence = False
        check(differ(run, "/x/apartment.svg", "uncertainty-own", 1, A) is not None, "an unfenced run taken fenced")
        # the posterior first is another run too, and so is a run.json of before the counts from the
        # start without "counts" (the posterior first then)
        for explore in ({"posterior_first": True}, {}):
            with open(os.path.join(run, "run.json"), "w") as f:
                json.dump({"robots": 2, "seed": 1, "rounds": 6, "plan": "host_sim/plans/apartment.svg",
                           "explore": dict({"policy": "uncertainty", "time_s": 30.0, "own_posterior": False,
                                            "fence": True}, **explore)}, f)
            check(differ(run, "/x/apartment.svg", "uncertainty-posterior", 1, A) is None,
                  f"the posterior-first run not recognised ({explore})")
            check(differ(run, "/x/apartment.svg", "uncertainty", 1, A) is not None,
                  f"the posterior-first run taken for the policy ({explore})")
        cmd = explore_compare.fleet_cmd(A, "apartment", "/x/apartment.svg", "uncertainty-posterior", 1, "n")
        check(cmd[cmd.index("--explore-policy") + 1] == "uncertainty" and "--explore-posterior-first" in cmd and
              "--explore-own-posterior" not in cmd, cmd)
        text = explore_compare.csv_text([r])
        check(text.splitlines()[0] == ",".join(explore_compare.CSV_COLUMNS), text)
        check(text.splitlines()[1].startswith("apartment,frontier,1,2,1,40,50,15,0.6,3,1,3"), text)


@test
def versus_coordinated_counts_a_stalled_run_at_its_budget():
    def runs(*t95):
        return [{"robot_seconds_to_95": t} for t in t95]
    said = explore_compare.versus_coordinated("uncertainty", runs(100.0, 200.0), runs(150.0, 250.0), 450.0)
    check(said == "uncertainty vs coordinated, robot-seconds to 95 %: 150 vs 200, -25.0 % (uncertainty faster).",
          said)
    # the stall of 123, 134 and a third run short of 95 %: (123 + 134 + 450) / 3 = 235.7 against 200
    said = explore_compare.versus_coordinated("uncertainty", runs(123.0, 134.0, None), runs(200.0, 190.0, 210.0),
                                              450.0)
    check(said.startswith("uncertainty vs coordinated, robot-seconds to 95 %: 236 vs 200, +17.8 % "
                          "(uncertainty slower); a run that never reached 95 % counted at its whole budget, "
                          "450 robot-s (reached: uncertainty 2/3, coordinated 3/3)."), said)
    check(explore_compare.versus_coordinated("uncertainty", [], runs(1.0), 450.0) ==
          "uncertainty vs coordinated: not both run on this plan.", "no runs")


if __name__ == "__main__":
    sys.exit(main())
