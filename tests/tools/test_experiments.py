#!/usr/bin/python3
"""Tests of tools/experiments.py's campaign: runs are done once (done.json names the command),
a failed run leaves nothing that looks finished and its dependants are skipped, a changed
command runs again, and a fresh results folder resumes from the archive. The runs here are
small shell commands; `make experiments QUICK=1` (in .ci/run) runs the real programs.

    python3 tests/tools/test_experiments.py      prints "N passed, M failed", exit 1 on failure
"""
import contextlib
import io
import json
import os
import shutil
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.realpath(__file__)))
from minitest import check, main, test  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.realpath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "tools"))
import experiments  # noqa: E402


def sh(script):
    return ["/bin/sh", "-c", script]


def campaign(runs, out, archive=None):
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        c = experiments.Campaign(runs, out, 2, archive)
        rc = c.go()
    return c, rc


def kl_run(name, script, needs=()):
    tags = {"kind": "kl_table", "row": "w_rho", "reading": "1", "strategy": "uniform", "seed": 1}
    return experiments.Run(name, [sh(script)], tags, needs=needs)


@test
def runs_once_and_resume():
    d = tempfile.mkdtemp()
    try:
        count = os.path.join(d, "count")
        runs = [experiments.Run("data-s1", [sh("echo data > {RUN}/samples.txt")], {"kind": "data", "seed": 1}),
                kl_run("a", f"echo 1 >> {count}; cat {{OUT}}/runs/data-s1/samples.txt > {{RUN}}/metrics.csv",
                       needs=["data-s1"])]
        c, rc = campaign(runs, d)
        check(rc == 0 and c.done == 2, f"first pass: rc {rc}, done {c.done}")
        with open(os.path.join(d, "runs", "a", "metrics.csv")) as f:
            check(f.read() == "data\n", "the run read its dependency's output")
        done = json.load(open(os.path.join(d, "runs", "a", "done.json")))
        check(done["key"] == runs[1].key() and done["cmds"][0][2].find(".partial") < 0,
              "done.json names the command with the final folder")
        c, rc = campaign(runs, d)
        check(rc == 0 and c.done == 0, "nothing is run twice")
        check(open(count).read() == "1\n", "run a ran once")
        runs[1] = kl_run("a", f"echo 2 >> {count}; echo new > {{RUN}}/metrics.csv", needs=["data-s1"])
        c, rc = campaign(runs, d)
        check(c.done == 1 and open(count).read() == "1\n2\n", "a changed command runs again")
    finally:
        shutil.rmtree(d)


@test
def failure_leaves_nothing_finished():
    d = tempfile.mkdtemp()
    try:
        runs = [kl_run("bad", "echo half > {RUN}/metrics.csv; exit 3"),
                kl_run("after", "echo x > {RUN}/metrics.csv", needs=["bad"]),
                kl_run("other", "echo y > {RUN}/metrics.csv")]
        c, rc = campaign(runs, d)
        check(rc == 1, f"exit status {rc}")
        check(not os.path.exists(os.path.join(d, "runs", "bad")), "no final folder for a failed run")
        log = open(os.path.join(d, "runs", ".bad.partial", "log.txt")).read()
        check("exit status 3" in log, "the log says why")
        check(not os.path.exists(os.path.join(d, "runs", "after")), "a dependant of a failed run is skipped")
        check(os.path.isfile(os.path.join(d, "runs", "other", "done.json")), "an independent run still ran")
    finally:
        shutil.rmtree(d)


@test
def archive_restores_on_a_fresh_folder():
    d = tempfile.mkdtemp()
    try:
        out1, out2, arc = (os.path.join(d, x) for x in ("out1", "out2", "archive"))
        runs = [kl_run("a", "echo 0.5 > {RUN}/metrics.csv; echo big > {RUN}/model.bnn")]
        c, rc = campaign(runs, out1, arc)
        check(rc == 0, "first campaign")
        kept = os.path.join(arc, "runs", "a")
        check(os.path.isfile(os.path.join(kept, "metrics.csv")) and os.path.isfile(os.path.join(kept, "done.json")),
              "metrics and record archived")
        check(not os.path.exists(os.path.join(kept, "model.bnn")), "models are not archived")
        c, rc = campaign(runs, out2, arc)
        check(rc == 0 and c.done == 0, "restored, not rerun")
        check(os.path.isfile(os.path.join(out2, "runs", "a", "metrics.csv")), "restored into the fresh folder")
    finally:
        shutil.rmtree(d)


@test
def archive_keeps_the_epistemic_map():
    d = tempfile.mkdtemp()
    try:
        out, arc = os.path.join(d, "out"), os.path.join(d, "archive")
        tags = {"kind": "single", "kl_weight": "5e-3", "seed": 1}
        # two drawn runs, one with map_epistemic.npy and one written before it existed (test files, not results)
        runs = [experiments.Run("with", [sh("mkdir -p {RUN}/maps; echo m > {RUN}/maps/map_mean.npy; "
                                           "echo e > {RUN}/maps/map_epistemic.npy")], dict(tags)),
                experiments.Run("without", [sh("mkdir -p {RUN}/maps; echo m > {RUN}/maps/map_mean.npy")],
                                dict(tags, kl_weight="5e-1"))]
        c, rc = campaign(runs, out, arc)
        check(rc == 0, "campaign")
        check(os.path.isfile(os.path.join(arc, "runs", "with", "maps", "map_epistemic.npy")), "epistemic map kept")
        check(os.path.isfile(os.path.join(arc, "runs", "without", "maps", "map_mean.npy")) and
              not os.path.exists(os.path.join(arc, "runs", "without", "maps", "map_epistemic.npy")),
              "a run without it is archived as before")
    finally:
        shutil.rmtree(d)


@test
def paper_report_epistemic_columns():
    try:
        import numpy  # noqa: F401  (tools/paper_report.py needs it)
    except ImportError:
        return
    import paper_report
    new = ("auc_seen_std", "auc_seen_epistemic", "ause_std", "ause_epistemic", "spearman_kde_epistemic", "brier")
    keys = [c[0] for c in paper_report.METRIC_COLS]
    for k in new:
        check(k in paper_report.RUNS_COLS and k in keys, f"{k}: a column of runs.csv and of the tables")
    check(keys.index("auc_std_unobserved") == 0, "the paper's AUC first, as before")
    check(paper_report.fmt(None, 3) == "-" and paper_report.fmt(float("nan"), 3) == "-", "missing: '-'")
    d = tempfile.mkdtemp()
    try:
        runs = [{"name": "old", "tags": {"kind": "single"}, "seconds": 1.0, "pm": {"mse": 0.1}},
                {"name": "new", "tags": {"kind": "single"}, "seconds": 1.0,
                 "pm": {"mse": 0.1, "brier": 0.1, "auc_seen_epistemic": 0.97, "ause_epistemic": float("nan")}}]
        paper_report.write_csvs(d, runs, [])
        with open(os.path.join(d, "runs.csv"), encoding="utf-8") as f:
            import csv
            rows = list(csv.DictReader(f))
        check(rows[0]["auc_seen_epistemic"] == "" and rows[0]["brier"] == "", f"{rows[0]}")
        check(rows[1]["auc_seen_epistemic"] == "0.97" and rows[1]["ause_epistemic"] == "-", f"{rows[1]}")
    finally:
        shutil.rmtree(d)


@test
def campaign_definitions():
    class A:
        bin_small, bin_paper = "s", "p"
    for quick in (True, False):
        runs = experiments.all_runs(experiments.Settings(quick), A())
        names = [r.name for r in runs]
        check(len(names) == len(set(names)), "unique folders")
        strategies = {(r.tags.get("row"), r.tags.get("strategy")) for r in runs if r.tags["kind"] == "kl_table"}
        rows = ("baseline", "network", "kl_weight_5e-1") + (() if quick else ("kl_weight_5e-3",))
        for row in rows:
            check((row, "uniform") in strategies and (row, "kl") in strategies, f"{row}: uniform and kl")
        # --quick keeps a reading of each kind of choice the report has a table for
        every = {r.tags["row"] for r in runs if r.tags["kind"] == "kl_table"}
        check({"baseline", "kl_form", "w_rho", "network"} <= every, f"rows {every}")
        check(len(runs) == (21 if quick else 107), f"{len(runs)} runs")
        kinds = {r.tags["kind"] for r in runs}
        check(kinds == {"data", "single", "kl_table", "online", "coverage"}, f"kinds {kinds}")
        seeds = {r.tags["seed"] for r in runs}
        check(len(seeds) == (1 if quick else 3), f"seeds {seeds}")



def opt(cmd, name):
    """The value after option NAME in a command (None without it)."""
    return cmd[cmd.index(name) + 1] if name in cmd else None


@test
def coverage_group():
    class A:
        bin_small, bin_paper = "s", "p"
    for quick in (True, False):
        s = experiments.Settings(quick)
        runs = experiments.all_runs(s, A())
        by = {r.name: r for r in runs}
        cov = [r for r in runs if r.tags["kind"] == "coverage"]
        check(len(cov) == 2 * len(s.seeds), f"2 plans x seeds: {[r.name for r in cov]}")
        check({r.tags["plan"] for r in cov} == {"apartment", "gen7"}, "the default plan and a generated one")
        check(s.coverage_rounds == (60 if quick else 300), f"rounds {s.coverage_rounds}")
        for r in cov:
            t = r.tags
            check(len(r.needs) == 1 and r.needs[0] in by, f"{r.name}: needs its data run")
            data = by[r.needs[0]]
            check(data.tags == {"kind": "data", "seed": t["seed"], "plan": t["plan"]}, f"{data.name}: {data.tags}")
            dcmds = data.cmds
            gen = [c for c in dcmds if c[1:3] == ["plan", "gen"]]
            plan = "{RUN}/plan.svg" if t["plan"] == "gen7" else experiments.PLAN
            if t["plan"] == "gen7":
                check(len(gen) == 1 and opt(gen[0], "--seed") == "7" and opt(gen[0], "--rooms") == "12" and
                      opt(gen[0], "--out") == plan, f"plan gen {gen}")
            else:
                check(not gen, "the default plan is not generated")
            paths = [c for c in dcmds if c[1:3] == ["paths", "gen"]]
            check(len(paths) == 1 and opt(paths[0], "--rooms") == "own" and opt(paths[0], "--robots") == "3" and
                  opt(paths[0], "--seed") == str(t["seed"]) and opt(paths[0], "--plan") == plan and
                  opt(paths[0], "--out") == "{RUN}/paths", f"paths gen {paths}")
            scans = [c for c in dcmds if c[1] == "scan"]
            check(len(scans) == 3 and all(opt(c, "--path") == f"{{RUN}}/paths/robot_{i}.csv" and
                                          opt(c, "--robot") == str(i) and opt(c, "--plan") == plan and
                                          opt(c, "--seed") == str(t["seed"]) for i, c in enumerate(scans)),
                  "3 scans of the own-room tours")
            val = [c for c in dcmds if c[1] == "valset"]
            check(len(val) == 1 and opt(val[0], "--plan") == plan and opt(val[0], "--poses") == str(s.val_poses),
                  "a validation set of the same plan")
            d = f"{{OUT}}/runs/{data.name}"
            rplan = f"{d}/plan.svg" if t["plan"] == "gen7" else experiments.PLAN
            fleet, maps, metrics, own_maps, own_metrics = r.cmds
            check(fleet[:3] == ["s", "fleet", "--inproc"], "the small preset's in-process fleet")
            for o, v in (("--plan", rplan), ("--paths", f"{d}/paths"), ("--robots", "3"), ("--strategy", "kl"),
                         ("--graph", "disk"), ("--radius", str(experiments.RADIUS)), ("--seed", str(t["seed"])),
                         ("--rounds", str(s.coverage_rounds)), ("--samples", f"{d}/samples"),
                         ("--valset", f"{d}/valset.samples"), ("--mc", str(s.mc)), ("--out", "{RUN}")):
                check(opt(fleet, o) == v, f"{r.name}: fleet {o} {opt(fleet, o)} != {v}")
            samples = [f"{d}/samples/robot_{i}.samples" for i in range(3)]
            check(maps[1] == "maps" and opt(maps, "--plan") == rplan and opt(maps, "--out") == "{RUN}/maps" and
                  maps[-3:] == [f"{{RUN}}/models/robot_{i}.bnn" for i in range(3)], f"consensus maps {maps}")
            check(own_maps[1] == "maps" and opt(own_maps, "--out") == "{RUN}/maps_robot0" and
                  own_maps[-1] == "{RUN}/models/robot_0.bnn" and own_maps[-2] == f"{d}/valset.samples" and
                  opt(own_maps, "--plan") == rplan and opt(own_maps, "--seed") == str(t["seed"]),
                  f"robot 0's own map: {own_maps}")
            check(metrics[1] == "tools/paper_metrics.py" and opt(metrics, "--maps") == "{RUN}/maps" and
                  opt(metrics, "--json") == "{RUN}/paper_metrics.json" and metrics[-3:] == samples, f"{metrics}")
            check(opt(own_metrics, "--maps") == "{RUN}/maps_robot0" and own_metrics[-3:] == samples and
                  opt(own_metrics, "--json") == "{RUN}/paper_metrics_robot0.json", f"{own_metrics}")
    with contextlib.redirect_stdout(io.StringIO()) as f:
        rc = experiments.main(["--only", "coverage", "--list", "--out", tempfile.gettempdir() + "/no-such-campaign"])
    names = [line.split()[1] for line in f.getvalue().splitlines()]
    check(rc == 0 and len(names) == 12 and all(n.startswith(("coverage-", "data-cov-")) for n in names),
          f"--only coverage selects the 6 runs and their data: {names}")


@test
def coverage_archive_and_report():
    d = tempfile.mkdtemp()
    try:
        out, arc = os.path.join(d, "out"), os.path.join(d, "archive")
        tags = {"kind": "coverage", "plan": "gen7", "seed": 1, "rounds": 3, "own": [0]}
        runs = [experiments.Run("coverage-gen7-s1", [sh(
            "mkdir -p {RUN}/maps {RUN}/maps_robot0 {RUN}/models; echo m > {RUN}/models/robot_0.bnn; "
            "echo c > {RUN}/maps/consensus.csv; echo c > {RUN}/maps_robot0/consensus.csv; "
            "echo m > {RUN}/maps_robot0/map_mean.npy; echo '{}' > {RUN}/paper_metrics.json; "
            "echo '{}' > {RUN}/paper_metrics_robot0.json")], tags)]
        c, rc = campaign(runs, out, arc)
        kept = os.path.join(arc, "runs", "coverage-gen7-s1")
        check(rc == 0 and all(os.path.isfile(os.path.join(kept, f)) for f in (
            "paper_metrics.json", "paper_metrics_robot0.json", "maps/consensus.csv", "maps_robot0/consensus.csv")),
            "the consensus map's and robot 0's scores are archived")
        check(not os.path.exists(os.path.join(kept, "models")) and
              not os.path.exists(os.path.join(kept, "maps_robot0", "map_mean.npy")), "no models, no map arrays")
    finally:
        shutil.rmtree(d)
    try:
        import numpy  # noqa: F401
    except ImportError:
        return
    import paper_report
    d = tempfile.mkdtemp()
    try:
        log = os.path.join(d, "log.txt")
        with open(log, "w", encoding="utf-8") as f:
            f.write("agent 0: 1 samples\nepistemic: 3 model(s), 3 posterior round(s) (every robot the fleet's "
                    "posterior); agent 0: x/map_epistemic.png\n")
        pm = paper_report.posterior_mixing(log)
        check(pm[0] == 3.0 and pm[1] != pm[1], f"{pm}")
        check(all(x != x for x in paper_report.posterior_mixing(os.path.join(d, "none"))), "no log: nan")
        with open(log, "a", encoding="utf-8") as f:
            f.write("epistemic: the posterior of 3 model(s) (3 robots' data, 934000 observations); 77.9 % known\n"
                    "epistemic: the posterior of 1 model(s) (3 robots' data, 866250 observations); 53.3 % known\n")
        check(paper_report.posterior_observations(log) == [934000.0, 866250.0], "the maps' posteriors, in order")
        check(paper_report.own_share({"post_share": {0: 0.5}}, "robot 0's own") == 0.5 and
              paper_report.own_share({}, "consensus") == 1.0, "robot 0's share of the fleet's observations")

        def run(plan, seed, auc, own_auc):
            return {"name": f"coverage-{plan}-s{seed}", "seconds": 1.0, "post_mixing": (33.0, 1e-6),
                    "tags": {"kind": "coverage", "plan": plan, "seed": seed, "rounds": 3, "own": [0]},
                    "final": {"consensus_error": 0.001}, "pm": {"auc_seen_epistemic": auc, "seen_fraction": 0.5},
                    "pm_own": {0: {"auc_seen_epistemic": own_auc, "seen_fraction": 0.5}}}
        runs = [run("gen7", 1, 0.9, 0.7), run("apartment", 2, 0.8, 0.6), run("apartment", 1, 0.6, 0.4)]
        rows = paper_report.coverage_rows(runs)
        want = [("apartment", "consensus", 2), ("apartment", "robot 0's own", 2), ("gen7", "consensus", 1),
                ("gen7", "robot 0's own", 1)]
        check([(p, m, len(rs)) for p, m, rs, _ in rows] == want,
              f"rows per plan, consensus then robot 0: {[(p, m) for p, m, _, _ in rows]}")
        check(paper_report.mean_sd([x["auc_seen_epistemic"] for x in rows[0][3]], 3) == "0.7 ± 0.1",
              f"{paper_report.mean_sd([x['auc_seen_epistemic'] for x in rows[0][3]], 3)}")
        check(paper_report.mean_sd([0.5], 3) == "0.5" and paper_report.mean_sd([float("nan")], 3) == "-", "one, none")
        paper_report.write_csvs(d, runs, [])
        import csv
        with open(os.path.join(d, "coverage.csv"), encoding="utf-8") as f:
            rows = list(csv.DictReader(f))
        check(len(rows) == 6 and rows[2]["map"] == "robot 0's own" and rows[2]["auc_seen_epistemic"] == "0.4" and
              rows[2]["seed"] == "1" and rows[0]["post_rounds"] == "33", f"{rows[:3]}")
    finally:
        shutil.rmtree(d)


if __name__ == "__main__":
    sys.exit(main())
