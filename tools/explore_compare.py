#!/usr/bin/python3
"""Exploration policies against each other and against today's fixed tours, in the same harness
(tools/fleet) with the same seeds, plan by plan:

    tools/explore_compare.py [--plans apartment,office64,gen] [--seeds 1,2,3] [--robots 3]
        [--policies uncertainty,uncertainty-own,uncertainty-posterior,coordinated,frontier,tours] [--explore-time S] [--rounds R]
        [--bin host_sim] [--results DIR] [--csv OUT.csv] [--fleet tools/fleet] [--no-fence]

Each run is `tools/fleet ... --no-report --results DIR --name <plan>-<policy>-<N>robots-seed<S>`:
an exploration policy with --explore --explore-policy P --explore-time S, "tours" the fixed tours
(--mode online, no --explore; on a plan other than the apartment the tours are made first with
`host_sim paths gen --plan P --robots N --seed S` into DIR/tours/). Plans: apartment and office64
(host_sim/plans/), gen (`host_sim plan gen --seed --gen-seed --rooms --gen-rooms` into DIR/plans/),
or a path to an SVG. Resumable: a run whose folder already has a coverage.csv with rows and every
robot's summary.txt, made with the same settings (run.json: robots, seed, plan, policy, exploration
time, rounds), is not run again; one made with others is run again (tools/fleet moves it aside).
One progress line per run.

Writes (DIR by default):
  OUT.csv (--csv, default DIR/explore_compare.csv): a row per run: plan, policy, seed, robots,
      coverage_final (the fleet's coverage.csv, last row), robot_seconds_to_90 and _95 (linear
      between the rows around the first crossing; empty when never reached), distance_m_mean
      (robots' "distance (true pose)" of summary.txt), visited_share_mean (each robot's own
      coverage, robot_<i>/coverage.csv last row, averaged), stuck_events, collisions,
      goals_failed (summed over the robots; empty for the tours, which have none)
  explore_compare_<plan>.png: coverage against robot-seconds, the mean over the seeds with a
      min..max band, one line per policy (up to the shortest of the policy's runs)
  explore_compare.md: per plan and policy the mean robot-seconds to 90 % and 95 %, and the
      difference of uncertainty against coordinated in robot-seconds to 95 % (a run that never
      reached it counted at its whole budget, robots x exploration time, and said so)
A run that fails is reported (its log's last lines) and the others go on; exit 1 then.
"""
import argparse
import math
import os
import re
import subprocess
import sys
import time

TOOLS_DIR = os.path.dirname(os.path.realpath(__file__))
ROOT = os.path.dirname(TOOLS_DIR)
sys.path.insert(0, TOOLS_DIR)
from fleet_io import ReportError, write_atomic  # noqa: E402
from fleet_report import read_csv  # noqa: E402
from fleet_figures import save_fig  # noqa: E402
sys.path.pop(0)

PROG = "explore_compare"
# "uncertainty-own": the uncertainty policy with each robot's own posterior (--explore-own-posterior),
# the ablation of the fleet's shared one.
# "uncertainty-posterior": the uncertainty policy with the posterior's layer first and the counts of where the
# rays went only when it has nothing left (--explore-posterior-first), the ablation of the two from the start.
EXPLORE_POLICIES = ("uncertainty", "uncertainty-own", "uncertainty-posterior", "coordinated", "frontier")
POLICIES = EXPLORE_POLICIES + ("tours",)
PLANS = {"apartment": "host_sim/plans/apartment.svg", "office64": "host_sim/plans/office64.svg"}
THRESHOLDS = (0.90, 0.95)
CSV_COLUMNS = ("plan", "policy", "seed", "robots", "coverage_final", "robot_seconds_to_90", "robot_seconds_to_95",
               "distance_m_mean", "visited_share_mean", "stuck_events", "collisions", "goals_failed")
# One colour and line per policy (not the robots' colours of tools/palette.py: these are policies).
POLICY_STYLE = {
    "uncertainty": ("#7b2cbf", "-"),
    "uncertainty-own": ("#c77dff", ":"),
    "uncertainty-posterior": ("#2ca02c", "-"),
    "coordinated": ("#1f77b4", "-"),
    "frontier": ("#e67e22", "-."),
    "tours": ("#444444", "--"),
}


# ---- measures --------------------------------------------------------------------------------

def time_to_coverage(xs, cov, thr):
    """The x (robot-seconds) at which coverage first reaches thr, linear between the two rows
    around the crossing (the first row when it is already there); None when never reached."""
    prev = None
    for x, c in zip(xs, cov):
        if c >= thr:
            if prev is None or prev[1] >= thr:
                return float(x)
            x0, c0 = prev
            return float(x0 + (thr - c0) * (x - x0) / (c - c0))
        prev = (x, c)
    return None


def read_coverage(path):
    """(robot_seconds, sim_time_s, coverage) lists of a coverage.csv, checked: rows, coverage in
    [0, 1] never falling."""
    c = read_csv(path, ("sim_time_s", "robot_seconds", "coverage"))
    v = c["coverage"]
    if not v:
        raise ReportError(f"{path}: no rows")
    if any(not (0 <= x <= 1) for x in v) or any(b < a for a, b in zip(v, v[1:])):
        raise ReportError(f"{path}: coverage outside [0, 1] or falling")
    return c["robot_seconds"], c["sim_time_s"], v


SUMMARY_RE = {
    "distance": re.compile(r"^distance \(true pose\): ([0-9.eE+-]+) m;.*collisions: (\d+)", re.M),
    "explore": re.compile(r"^explore: .*?(\d+) goals \((\d+) reached, (\d+) given up\).*?(\d+) stuck events", re.M),
    "coverage": re.compile(r"^coverage: ", re.M),
}


def read_summary(path):
    """{distance, collisions, goals_failed, stuck_events} of a robot's summary.txt (None: not said)."""
    try:
        with open(path) as f:
            text = f.read()
    except OSError as e:
        raise ReportError(f"{path}: {e.strerror or e}")
    out = {"distance": None, "collisions": None, "goals_failed": None, "stuck_events": None}
    m = SUMMARY_RE["distance"].search(text)
    if m:
        out["distance"], out["collisions"] = float(m.group(1)), int(m.group(2))
    m = SUMMARY_RE["explore"].search(text)
    if m:
        out["goals_failed"], out["stuck_events"] = int(m.group(3)), int(m.group(4))
    return out


def finished(run_dir, robots):
    """A run already done: coverage.csv with rows and every robot's summary.txt with its coverage line."""
    try:
        with open(os.path.join(run_dir, "coverage.csv")) as f:
            if len([ln for ln in f if ln.strip()]) < 2:
                return False
        for i in range(robots):
            with open(os.path.join(run_dir, f"robot_{i}", "summary.txt")) as f:
                if not SUMMARY_RE["coverage"].search(f.read()):
                    return False
    except OSError:
        return False
    return True


def settings_differ(run_dir, plan, policy, seed, a):
    """Why a finished run's run.json does not match this comparison's settings (None: it does)."""
    import json
    try:
        with open(os.path.join(run_dir, "run.json")) as f:
            s = json.load(f)
    except (OSError, ValueError):
        return "no readable run.json"
    e = s.get("explore") if isinstance(s, dict) else None
    pol, own, post_first = explore_policy(policy)
    # a run.json without "fence" is of a launcher before the keep-in fence: unfenced; an uncertainty
    # run's without "posterior_first" of a launcher before the counts from the start: posterior first
    # unless "counts" (the frontier policies read no belief)
    want = {"robots": a.robots, "seed": seed, "plan": os.path.basename(plan),
            "explore": None if policy == "tours" else (pol, float(a.explore_time), own, post_first, not a.no_fence)}
    got = {"robots": s.get("robots"), "seed": s.get("seed"), "plan": os.path.basename(str(s.get("plan"))),
           "explore": (e.get("policy"), float(e.get("time_s", -1)), bool(e.get("own_posterior")),
                       e.get("policy") == "uncertainty" and bool(e.get("posterior_first", not e.get("counts"))),
                       bool(e.get("fence", False))) if isinstance(e, dict) else None}
    if a.rounds is not None:
        want["rounds"], got["rounds"] = a.rounds, s.get("rounds")
    bad = [k for k in want if want[k] != got[k]]
    return ", ".join(f"{k} {got[k]} not {want[k]}" for k in bad) or None


def run_row(run_dir, plan, policy, seed, robots):
    """The CSV row of one finished run (a dict of CSV_COLUMNS)."""
    rs, _, cov = read_coverage(os.path.join(run_dir, "coverage.csv"))
    row = {"plan": plan, "policy": policy, "seed": seed, "robots": robots, "coverage_final": cov[-1]}
    for thr in THRESHOLDS:
        row[f"robot_seconds_to_{round(thr * 100)}"] = time_to_coverage(rs, cov, thr)
    dist, share, stuck, coll, failed = [], [], [], [], []
    for i in range(robots):
        d = os.path.join(run_dir, f"robot_{i}")
        s = read_summary(os.path.join(d, "summary.txt"))
        f = os.path.join(d, "coverage.csv")
        if os.path.isfile(f):
            share.append(read_coverage(f)[2][-1])
        for v, k in ((dist, "distance"), (stuck, "stuck_events"), (coll, "collisions"), (failed, "goals_failed")):
            if s[k] is not None:
                v.append(s[k])
    row["distance_m_mean"] = sum(dist) / len(dist) if dist else None
    row["visited_share_mean"] = sum(share) / len(share) if share else None
    row["stuck_events"] = sum(stuck) if stuck else None
    row["collisions"] = sum(coll) if coll else None
    row["goals_failed"] = sum(failed) if failed else None
    return row


def csv_text(rows):
    def cell(v):
        if v is None:
            return ""
        if isinstance(v, float):
            return f"{v:.6g}"
        return str(v)
    return ",".join(CSV_COLUMNS) + "\n" + "".join(",".join(cell(r[c]) for c in CSV_COLUMNS) + "\n" for r in rows)


# ---- running ---------------------------------------------------------------------------------

# Every child has a bound: making a plan or tours takes seconds, a fleet run minutes (office64's
# 600 s with 3 robots: 20 s here); one that passes it is stopped and counted as failed.
STEP_TIMEOUT_S = 600
RUN_TIMEOUT_S = float(os.environ.get("EXPLORE_COMPARE_RUN_TIMEOUT_S", "7200"))


def sh(cmd, log=None, timeout=STEP_TIMEOUT_S):
    """Runs cmd (a list); its output into log (a path) or captured. (returncode, output tail);
    past timeout seconds the child is stopped: (124, a line saying so)."""
    late = f"stopped after {timeout:g} s: {' '.join(cmd)}"
    if log:
        with open(log, "w") as f:
            try:
                p = subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT, timeout=timeout)
            except subprocess.TimeoutExpired:
                return 124, late
        with open(log) as f:
            tail = f.read().splitlines()[-8:]
        return p.returncode, "\n".join(tail)
    try:
        p = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        return 124, late
    return p.returncode, (p.stdout + p.stderr).strip()


def plan_file(a, name):
    """The SVG of a --plans entry (gen: made once into RESULTS/plans/)."""
    if name in PLANS:
        return os.path.join(ROOT, PLANS[name])
    if name == "gen":
        out = os.path.join(a.results, "plans", f"gen-seed{a.gen_seed}-rooms{a.gen_rooms}.svg")
        if not os.path.isfile(out):
            os.makedirs(os.path.dirname(out), exist_ok=True)
            rc, text = sh([a.bin, "plan", "gen", "--seed", str(a.gen_seed), "--rooms", str(a.gen_rooms), "--out", out])
            if rc != 0:
                raise ReportError(f"host_sim plan gen failed: {text.splitlines()[-1] if text else rc}")
        return out
    if name.endswith(".svg") and os.path.isfile(name):
        return os.path.abspath(name)
    raise ReportError(f"--plans: '{name}' is not apartment, office64, gen or an SVG file")


def plan_label(name):
    return os.path.splitext(os.path.basename(name))[0] if name.endswith(".svg") else name


def tours_dir(a, label, plan, seed):
    """--paths for the tours on a plan other than the apartment (None: tools/fleet's defaults)."""
    if label == "apartment":
        return None
    out = os.path.join(a.results, "tours", f"{label}-{a.robots}robots-seed{seed}")
    if not all(os.path.isfile(os.path.join(out, f"robot_{i}.csv")) for i in range(a.robots)):
        rc, text = sh([a.bin, "paths", "gen", "--plan", plan, "--robots", str(a.robots), "--seed", str(seed),
                       "--out", out])
        if rc != 0:
            raise ReportError(f"host_sim paths gen on {plan} failed: {text.splitlines()[-1] if text else rc}")
    return out


def fleet_cmd(a, label, plan, policy, seed, name):
    cmd = [a.fleet, "--bin", a.bin, "--plan", plan, "--robots", str(a.robots), "--seed", str(seed),
           "--no-report", "--results", a.results, "--name", name]
    if a.rounds is not None:
        cmd += ["--rounds", str(a.rounds)]
    if policy == "tours":
        cmd += ["--mode", "online"]
        paths = tours_dir(a, label, plan, seed)
        if paths:
            cmd += ["--paths", paths]
    else:
        pol, own, post_first = explore_policy(policy)
        cmd += ["--explore", "--explore-policy", pol, "--explore-time", f"{a.explore_time:g}"]
        if own:
            cmd += ["--explore-own-posterior"]
        if post_first:
            cmd += ["--explore-posterior-first"]
        if a.no_fence:
            cmd += ["--explore-no-fence"]
    return cmd


def explore_policy(policy):
    """(tools/fleet's --explore-policy, --explore-own-posterior, --explore-posterior-first) of one of
    EXPLORE_POLICIES."""
    for suffix, own, post_first in (("-own", True, False), ("-posterior", False, True)):
        if policy.endswith(suffix):
            return policy[:-len(suffix)], own, post_first
    return policy, False, False


# ---- figures and table -----------------------------------------------------------------------

def versus_coordinated(name, u, c, budget_rs):
    """The line of explore_compare.md comparing policy `name`'s runs u with coordinated's c. A run
    that never reached 95 % counts at its whole budget (budget_rs robot-seconds), said so: a
    policy that stalls short of 95 % is not left out of its own mean."""
    if not u or not c:
        return f"{name} vs coordinated: not both run on this plan."
    tu = [r["robot_seconds_to_95"] for r in u]
    tc = [r["robot_seconds_to_95"] for r in c]
    reached_u, reached_c = sum(t is not None for t in tu), sum(t is not None for t in tc)
    mu = sum(budget_rs if t is None else t for t in tu) / len(tu)
    mc = sum(budget_rs if t is None else t for t in tc) / len(tc)
    d = 100.0 * (mu - mc) / mc if mc > 0 else float("nan")
    said = (f"{name} vs coordinated, robot-seconds to 95 %: {mu:.0f} vs {mc:.0f}, {d:+.1f} % "
            f"({name + ' faster' if d < 0 else name + ' slower' if d > 0 else 'the same'})")
    if reached_u == len(tu) and reached_c == len(tc):
        return said + "."
    return (said + f"; a run that never reached 95 % counted at its whole budget, {budget_rs:.0f} robot-s "
            f"(reached: {name} {reached_u}/{len(tu)}, coordinated {reached_c}/{len(tc)}).")


def curves(np, a, label, policy):
    """[(robot_seconds array, coverage array)] of the policy's finished runs on the plan."""
    out = []
    for seed in a.seeds:
        f = os.path.join(a.results, run_name(label, policy, a.robots, seed), "coverage.csv")
        if os.path.isfile(f):
            rs, _, cov = read_coverage(f)
            out.append((np.asarray(rs, dtype=float), np.asarray(cov, dtype=float)))
    return out


def fig_plan(np, plt, a, label):
    fig, ax = plt.subplots(figsize=(7.5, 4.8), constrained_layout=True)
    lines = 0
    for policy in a.policies:
        cs = curves(np, a, label, policy)
        if not cs:
            continue
        end = min(float(x[-1]) for x, _ in cs)
        grid = np.linspace(0.0, end, 400)
        ys = np.array([np.interp(grid, x, c) for x, c in cs])
        colour, ls = POLICY_STYLE.get(policy, ("black", "-"))
        ax.plot(grid, ys.mean(axis=0), ls, lw=1.8, color=colour,
                label=f"{policy} (mean of {len(cs)} seed{'s' if len(cs) > 1 else ''})")
        if len(cs) > 1:
            ax.fill_between(grid, ys.min(axis=0), ys.max(axis=0), color=colour, alpha=0.18, lw=0)
        lines += 1
    if not lines:
        plt.close(fig)
        return None
    for thr in THRESHOLDS:
        ax.axhline(thr, color="0.5", lw=0.8, ls=":")
    ax.set_ylim(0, 1)
    ax.set_xlim(left=0)
    ax.set_xlabel("robot-seconds (robots x simulated seconds)")
    ax.set_ylabel("fleet coverage (share of free cells seen, 0.1 m grid)")
    ax.set_title(f"{label}: coverage against robot-seconds, {a.robots} robots, seeds "
                 f"{','.join(map(str, a.seeds))}\n(line: mean over seeds, band: min..max; dotted: 90 %, 95 %)",
                 fontsize=10)
    ax.grid(alpha=0.3)
    ax.legend(loc="lower right", fontsize=8)
    path = os.path.join(a.results, f"explore_compare_{label}.png")
    save_fig(plt, fig, path)
    return path


def mean_or_none(v):
    return sum(v) / len(v) if v else None


def markdown(a, rows, labels):
    def f0(v):
        return "-" if v is None else f"{v:.0f}"
    L = ["# Exploration policies and fixed tours compared", "",
         f"{a.robots} robots, seeds {','.join(map(str, a.seeds))}, exploration {a.explore_time:g} s simulated"
         + (f", {a.rounds} rounds" if a.rounds is not None else "") + "; coverage: share of the free cells "
         "(0.1 m grid) some lidar ray has seen (the fleet's union, coverage.csv). Robot-seconds to a "
         "coverage: the mean over the seeds that reached it (k/n: k of the n runs did).", ""]
    for label in labels:
        L += [f"## {label}", "",
              "| policy | runs | final coverage (mean) | robot-s to 90 % | robot-s to 95 % | distance per robot (m) "
              "| own coverage per robot | stuck events | collisions | goals given up |",
              "|---|---|---|---|---|---|---|---|---|---|"]
        by = {}
        for policy in a.policies:
            rs = [r for r in rows if r["plan"] == label and r["policy"] == policy]
            if not rs:
                continue
            cells = [policy, str(len(rs)), f"{mean_or_none([r['coverage_final'] for r in rs]):.3f}"]
            for thr in (90, 95):
                got = [r[f"robot_seconds_to_{thr}"] for r in rs if r[f"robot_seconds_to_{thr}"] is not None]
                cells.append(f"{f0(mean_or_none(got))} ({len(got)}/{len(rs)})")
            for k, fmt in (("distance_m_mean", "{:.1f}"), ("visited_share_mean", "{:.3f}")):
                v = mean_or_none([r[k] for r in rs if r[k] is not None])
                cells.append("-" if v is None else fmt.format(v))
            for k in ("stuck_events", "collisions", "goals_failed"):
                v = [r[k] for r in rs if r[k] is not None]
                cells.append(str(sum(v)) if v else "-")
            L.append("| " + " | ".join(cells) + " |")
            by[policy] = rs
        L.append("")
        for name in ("uncertainty", "uncertainty-posterior"):
            L.append(versus_coordinated(name, by.get(name), by.get("coordinated"), a.robots * a.explore_time))
        if os.path.isfile(os.path.join(a.results, f"explore_compare_{label}.png")):
            L += ["", f"![{label}](explore_compare_{label}.png)"]
        L.append("")
    return "\n".join(L)


# ---- main ------------------------------------------------------------------------------------

def run_name(label, policy, robots, seed):
    return f"{label}-{policy}-{robots}robots-seed{seed}"


class Parser(argparse.ArgumentParser):
    def error(self, message):
        self.print_usage(sys.stderr)
        print(f"{PROG}: {message}", file=sys.stderr)
        sys.exit(1)


def int_list(s):
    try:
        v = [int(x) for x in s.split(",") if x.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"'{s}' is not a comma-separated list of integers")
    if not v:
        raise argparse.ArgumentTypeError("empty list")
    return v


def parse(argv):
    ap = Parser(prog="explore_compare.py", description=__doc__.split("\n\n")[0],
                formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__.split("\n\n", 1)[1])
    ap.add_argument("--plans", default="apartment,office64,gen", help="apartment, office64, gen or SVG files")
    ap.add_argument("--seeds", type=int_list, default=[1, 2, 3], help="the runs' seeds (default 1,2,3)")
    ap.add_argument("--robots", type=int, default=3, help="robots per run (default 3)")
    ap.add_argument("--policies", default=",".join(POLICIES), help=f"of {','.join(POLICIES)} (default all)")
    ap.add_argument("--explore-time", type=float, default=300.0, help="simulated seconds of exploration (default 300)")
    ap.add_argument("--rounds", type=int, default=None, help="DiNNO rounds (default: tools/fleet's)")
    ap.add_argument("--bin", default=os.path.join(ROOT, "build", "bin", "host_sim"), help="host_sim binary")
    ap.add_argument("--results", default=os.path.join(ROOT, "results", "explore_compare"), help="results folder")
    ap.add_argument("--csv", default=None, help="the table of runs (default RESULTS/explore_compare.csv)")
    ap.add_argument("--fleet", default=os.environ.get("EXPLORE_COMPARE_FLEET", os.path.join(ROOT, "tools", "fleet")),
                    help="the launcher (default $EXPLORE_COMPARE_FLEET, else tools/fleet)")
    ap.add_argument("--no-fence", action="store_true",
                    help="every exploring run without the keep-in fence (tools/fleet --explore-no-fence: the ablation)")
    ap.add_argument("--gen-seed", type=int, default=1, help="seed of the generated plan 'gen' (default 1)")
    ap.add_argument("--gen-rooms", type=int, default=8, help="rooms of the generated plan (default 8)")
    a = ap.parse_args(argv)
    a.policies = [p.strip() for p in a.policies.split(",") if p.strip()]
    bad = [p for p in a.policies if p not in POLICIES]
    if bad or not a.policies:
        ap.error(f"--policies: {','.join(bad) or 'none'} not of {','.join(POLICIES)}")
    a.plans = [p.strip() for p in a.plans.split(",") if p.strip()]
    if not a.plans:
        ap.error("--plans: none")
    if a.robots < 1:
        ap.error("--robots must be >= 1")
    if not (a.explore_time > 0 and math.isfinite(a.explore_time)):
        ap.error("--explore-time must be > 0")
    if not (os.path.isfile(a.bin) and os.access(a.bin, os.X_OK)):
        ap.error(f"--bin {a.bin}: not an executable (build it: make, or give --bin)")
    if not (os.path.isfile(a.fleet) and os.access(a.fleet, os.X_OK)):
        ap.error(f"--fleet {a.fleet}: not an executable")
    a.bin, a.fleet, a.results = os.path.abspath(a.bin), os.path.abspath(a.fleet), os.path.abspath(a.results)
    a.csv = a.csv or os.path.join(a.results, "explore_compare.csv")
    return a


def main(argv=None):
    a = parse(argv)
    try:
        import numpy as np
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as e:
        print(f"{PROG}: needs numpy and matplotlib (Debian python3-numpy python3-matplotlib): {e}", file=sys.stderr)
        return 1
    rows, failed, labels = [], 0, []
    try:
        for p in a.plans:  # every name checked before anything is made
            if p not in PLANS and p != "gen" and not (p.endswith(".svg") and os.path.isfile(p)):
                raise ReportError(f"--plans: '{p}' is not apartment, office64, gen or an SVG file")
        os.makedirs(a.results, exist_ok=True)
        plans = [(plan_label(p), plan_file(a, p)) for p in a.plans]
        total = len(plans) * len(a.policies) * len(a.seeds)
        k = 0
        for label, plan in plans:
            labels.append(label)
            for policy in a.policies:
                for seed in a.seeds:
                    k += 1
                    name = run_name(label, policy, a.robots, seed)
                    d = os.path.join(a.results, name)
                    head = f"[{k}/{total}] {label} {policy} seed {seed}:"
                    t0 = time.monotonic()
                    kept = finished(d, a.robots)
                    if kept:
                        why = settings_differ(d, plan, policy, seed, a)
                        if why:
                            print(f"{head} the run there has other settings ({why}): running it again", flush=True)
                            kept = False
                    if not kept:
                        cmd = fleet_cmd(a, label, plan, policy, seed, name)
                        log = os.path.join(a.results, name + ".log")
                        rc, tail = sh(cmd, log=log, timeout=RUN_TIMEOUT_S)
                        if rc != 0 or not finished(d, a.robots):
                            failed += 1
                            print(f"{head} FAILED (exit {rc}; {log}):\n  " + tail.replace("\n", "\n  "), flush=True)
                            continue
                    r = run_row(d, label, policy, seed, a.robots)
                    rows.append(r)
                    t95 = r["robot_seconds_to_95"]
                    print(f"{head} coverage {r['coverage_final']:.3f}, 95 % "
                          + (f"at {t95:.0f} robot-s" if t95 is not None else "not reached")
                          + (" (kept, not run again)" if kept else f" ({time.monotonic() - t0:.1f} s)"), flush=True)
        write_atomic(a.csv, lambda f: f.write(csv_text(rows).encode()))
        print(f"{PROG}: wrote {a.csv} ({len(rows)} runs)")
        for label in labels:
            p = fig_plan(np, plt, a, label)
            if p:
                print(f"{PROG}: wrote {p}")
        md = os.path.join(a.results, "explore_compare.md")
        write_atomic(md, lambda f: f.write(markdown(a, rows, labels).encode()))
        print(f"{PROG}: wrote {md}")
    except ReportError as e:
        print(f"{PROG}: {e}", file=sys.stderr)
        return 1
    if failed:
        print(f"{PROG}: {failed} run(s) failed (above)", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
