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
        for row in ("baseline", "network", "kl_weight_5e-3", "kl_weight_5e-1"):
            check((row, "uniform") in strategies and (row, "kl") in strategies, f"{row}: uniform and kl")
        kinds = {r.tags["kind"] for r in runs}
        check(kinds == {"data", "single", "kl_table", "online"}, f"kinds {kinds}")
        seeds = {r.tags["seed"] for r in runs}
        check(len(seeds) == (1 if quick else 3), f"seeds {seeds}")


if __name__ == "__main__":
    sys.exit(main())
