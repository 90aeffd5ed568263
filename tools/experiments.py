#!/usr/bin/python3
"""The paper's experiments (section 6) and the KL question, as one resumable driver.

    tools/experiments.py [--quick] [--out DIR] [--jobs N] [--only TEXT] [--list] [--report-only]

`make experiments` runs it (`make experiments QUICK=1` with --quick). Every experiment is a list
of runs of the real programs (`host_sim scan/valset/fleet --inproc/maps`, `tools/fleet` for the
online fleet of 7 processes over LCM, `tools/paper_metrics.py`), one folder each under
DIR/runs/<name>/. A run is done when DIR/runs/<name>/done.json exists and names the same
command: finished runs are never redone, so an interrupted driver resumes where it stopped.
A run works in DIR/runs/.<name>.partial/ and is renamed only when whole, so a killed run leaves
nothing that looks finished. At the end tools/paper_report.py writes DIR/REPORT.md with the
figures and CSVs.

Finished runs are also copied, without models and samples, into the archive (docs/paper by
default, a folder of the repository), and restored from there: a campaign resumes on a fresh
clone, and the report can be rebuilt from the archive alone (--report-only).

The runs (full: 3 seeds, 1500 rounds, 100 validation poses, 50 MC passes; --quick: one seed,
60 rounds, 20 poses, 10 passes, the single robot and the online fleet on `small`, the `paper`
network only in its 8-round row; 21 runs: one reading of each choice, one prior weight, each
online pool once):
  data-s<S>          7 tours scanned in the ODE world (seed S) and a validation set
  kl-table           uniform / separate / kl, each reading of the open choices one at a time
                     (kl form, reduction, W_rho, literal Algorithm 2, kl_weight, network), seeds
  single             one robot alone (section 6.1) at kl_weight 1e-4, 5e-3, 5e-1 (`paper` preset)
  online             the 7-robot fleet over LCM, online (section 6.2): CDR 8/18/25, DR 18
  data-cov-<P>-s<S>  partial coverage: 3 tours of `host_sim paths gen --rooms own` (each robot sweeps
                     only its start room, seed S) on plan P (apartment, or gen7: `host_sim plan gen
                     --seed 7 --rooms 12`), scanned, and a validation set of that plan
  coverage           those 3 robots (`kl`, disk graph, 300 rounds; 60 --quick): the consensus map of
                     the 3 models and robot 0's own map, each scored by tools/paper_metrics.py
The seven-agent comparison (6.3) and the decentralised map are the kl-table's `paper` runs.
Exit status: 0 all done, 1 a run failed (the others still ran), 2 bad options, 130 interrupted.
"""
import argparse
import concurrent.futures
import hashlib
import json
import os
import shutil
import subprocess
import sys
import threading
import time

ROOT = os.path.dirname(os.path.dirname(os.path.realpath(__file__)))
PLAN = "host_sim/plans/apartment.svg"
PATHS = "host_sim/plans/apartment"
ROBOTS = 7
RADIUS = 6.0


class Settings:
    """The sizes of one campaign: the full one or --quick."""

    def __init__(self, quick):
        self.quick = quick
        self.seeds = [1] if quick else [1, 2, 3]
        self.rounds_small = 60 if quick else 1500
        self.rounds_paper = 8 if quick else 1500
        self.val_poses = 20 if quick else 100
        self.mc = 10 if quick else 50
        self.single_rounds = 60 if quick else 1500
        self.online_rpc = 1 if quick else 10    # DiNNO rounds per communication round
        self.big = "small" if quick else "paper"  # the preset of the paper's own experiments
        self.coverage_rounds = 60 if quick else 300
        # --quick keeps one run of each kind the report draws (the pipeline, not the answers):
        # the KL table's baseline and one reading of each kind of choice, one prior weight, the
        # online fleet with each pool once. 21 runs instead of 41 (CI runs it on 2 cores).
        self.readings = READINGS if not quick else [r for r in READINGS if r[1] in ("defaults", "reverse", "0.1")]
        self.kl_weights = KL_WEIGHTS if not quick else KL_WEIGHTS[-1:]
        self.klw_readings = KLW_READINGS if not quick else [r for r in KLW_READINGS if not r[1]]
        self.online = ONLINE if not quick else [o for o in ONLINE if o in (("cdr", 8), ("dr", 18))]


class Run:
    """One unit of work: commands run in order inside the run's folder; tags for the report."""

    def __init__(self, name, cmds, tags, needs=(), threads=1):
        self.name, self.cmds, self.tags, self.needs, self.threads = name, cmds, tags, list(needs), threads

    def cost(self):
        """Rough cost in units of one `small` fleet run, for the time estimate only."""
        t = self.tags
        if t["kind"] == "data":
            return 0.02
        if t["kind"] == "online":
            return 3.0 * t.get("rounds", 180) / 180
        if t["kind"] == "coverage":  # 3 robots instead of 7, and two more maps
            return 0.5 * t.get("rounds", 300) / 1500
        scale = 1.0 if t.get("preset") == "small" else 6.0
        return scale * (1.0 if t["kind"] == "kl_table" else 0.2) * t.get("rounds", 1500) / 1500

    def key(self):
        return hashlib.sha256(json.dumps([self.cmds, self.tags]).encode()).hexdigest()[:16]


def bins(args):
    return {"small": args.bin_small, "paper": args.bin_paper}


def data_run(s, seed, hs):
    """Training samples of the 7 tours and the validation set of one seed (preset-free)."""
    cmds = [[hs, "scan", "--plan", PLAN, "--path", f"{PATHS}/robot_{i}.csv", "--robot", str(i), "--seed",
             str(seed), "--out", f"{{RUN}}/samples/robot_{i}.samples", "-q"] for i in range(ROBOTS)]
    cmds.append([hs, "valset", "--plan", PLAN, "--poses", str(s.val_poses), "--seed", str(seed), "--out",
                 "{RUN}/valset.samples"])
    return Run(f"data-s{seed}", cmds, {"kind": "data", "seed": seed})


def fleet_cmds(s, b, data, rounds, robots, strategy, extra, mc_curve, seed, plan=PLAN, paths=PATHS):
    """host_sim fleet --inproc, then the consensus maps and the paper's map metrics."""
    every = max(1, rounds // (15 if mc_curve else 30))
    graph = ["--graph", "disk", "--radius", str(RADIUS)] if robots > 1 else ["--graph", "full"]
    fleet = [b, "fleet", "--inproc", "--plan", plan, "--paths", paths, "--robots", str(robots), "--rounds",
             str(rounds), "--strategy", strategy, *graph, "--seed", str(seed), "--threads", "1",
             "--metrics-every", str(every), "--samples", f"{data}/samples", "--valset", f"{data}/valset.samples",
             "--val-mc", str(s.mc), "--mc", str(s.mc), "--out", "{RUN}", *extra]
    if mc_curve:
        fleet += ["--val-mode", "mc"]
    models = [f"{{RUN}}/models/robot_{i}.bnn" for i in range(robots)]
    maps = [b, "maps", "--plan", plan, "--out", "{RUN}/maps", "--mc", str(s.mc), "--seed", str(seed),
            "--valset", f"{data}/valset.samples", *models]
    samples = [f"{data}/samples/robot_{i}.samples" for i in range(robots)]
    metrics = [sys.executable, "tools/paper_metrics.py", "--maps", "{RUN}/maps", "--json",
               "{RUN}/paper_metrics.json", *samples]
    return [fleet, maps, metrics]


# The KL table: (row, reading, the strategies it applies to, host_sim options). Each reading
# changes one thing from the baseline (today's defaults: kl form own, summed, both groups get
# the prediction gradient, W = 1, kl_weight 1e-4, preset small). `separate` at W_rho = 1 is
# `uniform` bit for bit (tests/dinno/test_dinno_node.c), so it runs once, to show it.
READINGS = [
    ("baseline", "defaults", ("uniform", "kl"), []),
    ("rho_pred_grad", "0", ("separate", "kl"), ["--rho-pred-grad", "0"]),  # Algorithm 2 read literally
    ("kl_form", "reverse", ("kl",), ["--kl-form", "reverse"]),
    ("kl_form", "full", ("kl",), ["--kl-form", "full"]),
    ("kl_reduce", "mean", ("kl",), ["--kl-reduce", "mean"]),
    ("w_rho", "0.01", ("separate", "kl"), ["--w-rho", "0.01"]),
    ("w_rho", "0.1", ("separate", "kl"), ["--w-rho", "0.1"]),
    ("w_rho", "10", ("separate", "kl"), ["--w-rho", "10"]),
]
KL_WEIGHTS = ("5e-3", "5e-1")
# The online fleet (section 6.2): (pool, communication rounds).
ONLINE = [("cdr", 8), ("cdr", 18), ("cdr", 25), ("dr", 18)]
# At those prior weights: the strategies and the KL forms again (sigma moves there).
KLW_READINGS = [("uniform", []), ("separate", ["--w-rho", "0.1"]), ("kl", []), ("kl", ["--w-rho", "0.1"]),
                ("kl", ["--kl-form", "reverse"]), ("kl", ["--kl-form", "full"])]


def label(extra):
    """'defaults', or the options without their dashes: 'kl-form reverse'."""
    return " ".join(a[2:] if a.startswith("--") else a for a in extra) or "defaults"


def slug(text):
    """A folder name from a label: letters, digits, '.', '-'; anything else one '_'."""
    out = "".join(c if c.isalnum() or c in ".-" else "_" for c in text.replace("--", ""))
    while "__" in out:
        out = out.replace("__", "_")
    return out


def kl_table_runs(s, args):
    b = bins(args)
    runs = []
    for seed in s.seeds:
        data = f"{{OUT}}/runs/data-s{seed}"

        def add(row, reading, strategy, extra, preset="small", mc_curve=False):
            rounds = s.rounds_paper if preset == "paper" else s.rounds_small
            name = slug(f"kl-{preset}-{row}-{reading}-{strategy}-s{seed}")
            tags = {"kind": "kl_table", "row": row, "reading": reading, "strategy": strategy, "seed": seed,
                    "preset": preset, "rounds": rounds, "args": extra}
            runs.append(Run(name, fleet_cmds(s, b[preset], data, rounds, ROBOTS, strategy, extra, mc_curve, seed),
                            tags, needs=[f"data-s{seed}"]))

        for row, reading, strategies, extra in s.readings:
            for st in strategies:
                add(row, reading, st, extra, mc_curve=(row == "baseline"))
        if seed == s.seeds[0]:
            add("baseline", "defaults", "separate", [])  # == uniform, shown once
        for w in s.kl_weights:
            for st, extra in s.klw_readings:
                add(f"kl_weight_{w}", label(extra), st, ["--kl-weight", w] + extra)
        for st, extra in (("uniform", []), ("separate", ["--w-rho", "0.1"]), ("kl", [])):
            add("network", "paper, " + label(extra), st, extra, preset="paper")
    return runs


def single_runs(s, args):
    """Section 6.1: robot 0 alone, the paper's network, three prior weights."""
    b = bins(args)[s.big]
    seed = s.seeds[0]
    data = f"{{OUT}}/runs/data-s{seed}"
    runs = []
    for w in ("1e-4", "5e-3", "5e-1"):
        tags = {"kind": "single", "kl_weight": w, "seed": seed, "preset": s.big, "rounds": s.single_rounds}
        runs.append(Run(f"single-{s.big}-klw{w}-s{seed}",
                        fleet_cmds(s, b, data, s.single_rounds, 1, "isolated", ["--kl-weight", w], False, seed),
                        tags, needs=[f"data-s{seed}"]))
    return runs


def online_runs(s, args):
    """Section 6.2: the 7-robot fleet over LCM (7 processes), online, CDR and DR."""
    b = bins(args)[s.big]
    seed = s.seeds[0]
    runs = []
    for pool, comm in s.online:
        rounds = comm * s.online_rpc
        name = f"online-{s.big}-{pool}{comm}-s{seed}"
        cmd = [sys.executable, "tools/fleet", "--bin", b, "--mode", "online", "--rounds", str(rounds),
               "--rounds-per-comm", str(s.online_rpc), "--pool", pool, "--seed", str(seed), "--robots", str(ROBOTS),
               "--val-every", str(s.online_rpc), "--val-poses", str(s.val_poses), "--mc", str(s.mc),
               "--results", "{RUN}", "--name", "fleet"]
        # The robots drive their whole tours: the lidar points of the tours are the data run's.
        metrics = [sys.executable, "tools/paper_metrics.py", "--maps", "{RUN}/fleet/maps", "--json",
                   "{RUN}/paper_metrics.json",
                   *[f"{{OUT}}/runs/data-s{seed}/samples/robot_{i}.samples" for i in range(ROBOTS)]]
        tags = {"kind": "online", "pool": pool, "comm_rounds": comm, "rounds_per_comm": s.online_rpc, "seed": seed,
                "preset": s.big, "rounds": rounds}
        runs.append(Run(name, [cmd, metrics], tags, needs=[f"data-s{seed}"], threads=2))
    return runs


# Partial coverage: (name, how the plan is made: None = the default plan, or host_sim plan gen's
# --seed and --rooms). The tours are made per seed, so the seen rooms change with it.
COVERAGE_ROBOTS = 3
COVERAGE_PLANS = (("apartment", None), ("gen7", (7, 12)))
COVERAGE_OWN = (0,)  # the robots whose own map is scored besides the consensus map


def coverage_data_run(s, plan_name, gen, seed, hs):
    """The plan (generated, or the default one), 3 own-room tours, their samples, a validation set."""
    cmds = []
    plan = PLAN
    if gen:
        plan = "{RUN}/plan.svg"
        cmds.append([hs, "plan", "gen", "--seed", str(gen[0]), "--rooms", str(gen[1]), "--out", plan])
    cmds.append([hs, "paths", "gen", "--plan", plan, "--robots", str(COVERAGE_ROBOTS), "--seed", str(seed),
                 "--rooms", "own", "--out", "{RUN}/paths", "--png", "{RUN}/paths.png"])
    cmds += [[hs, "scan", "--plan", plan, "--path", f"{{RUN}}/paths/robot_{i}.csv", "--robot", str(i), "--seed",
              str(seed), "--out", f"{{RUN}}/samples/robot_{i}.samples", "-q"] for i in range(COVERAGE_ROBOTS)]
    cmds.append([hs, "valset", "--plan", plan, "--poses", str(s.val_poses), "--seed", str(seed), "--out",
                 "{RUN}/valset.samples"])
    tags = {"kind": "data", "seed": seed, "plan": plan_name}
    return Run(f"data-cov-{plan_name}-s{seed}", cmds, tags)


def coverage_runs(s, args):
    """3 robots that each tour only their start room: the consensus map and robot 0's own one."""
    b = bins(args)["small"]
    runs = []
    for plan_name, gen in COVERAGE_PLANS:
        for seed in s.seeds:
            dname = f"data-cov-{plan_name}-s{seed}"
            data = f"{{OUT}}/runs/{dname}"
            plan = f"{data}/plan.svg" if gen else PLAN
            cmds = fleet_cmds(s, b, data, s.coverage_rounds, COVERAGE_ROBOTS, "kl", [], False, seed, plan=plan,
                              paths=f"{data}/paths")
            samples = [f"{data}/samples/robot_{i}.samples" for i in range(COVERAGE_ROBOTS)]
            for i in COVERAGE_OWN:  # robot i's checkpoint alone: its model and the fleet's posterior it holds
                cmds.append([b, "maps", "--plan", plan, "--out", f"{{RUN}}/maps_robot{i}", "--mc", str(s.mc),
                             "--seed", str(seed), "--valset", f"{data}/valset.samples",
                             f"{{RUN}}/models/robot_{i}.bnn"])
                cmds.append([sys.executable, "tools/paper_metrics.py", "--maps", f"{{RUN}}/maps_robot{i}", "--json",
                             f"{{RUN}}/paper_metrics_robot{i}.json", *samples])
            tags = {"kind": "coverage", "plan": plan_name, "plan_gen": list(gen) if gen else None, "seed": seed,
                    "preset": "small", "rounds": s.coverage_rounds, "robots": COVERAGE_ROBOTS, "strategy": "kl",
                    "own": list(COVERAGE_OWN)}
            runs.append(Run(f"coverage-{plan_name}-s{seed}", cmds, tags, needs=[dname]))
    return runs


def all_runs(s, args):
    b = bins(args)
    data = [data_run(s, seed, b["small"]) for seed in s.seeds]
    # Cheapest answers first: the single robot, the KL table on `small` (every seed), then the
    # `paper` network's runs, then the online fleet (which takes both cores).
    table = kl_table_runs(s, args)
    small = [r for r in table if r.tags["preset"] == "small"]
    paper = [r for r in table if r.tags["preset"] != "small"]
    cov_data = [coverage_data_run(s, p, gen, seed, b["small"]) for p, gen in COVERAGE_PLANS for seed in s.seeds]
    runs = data + single_runs(s, args) + small + paper + online_runs(s, args) + cov_data + coverage_runs(s, args)
    names = [r.name for r in runs]
    assert len(set(names)) == len(names), "two runs share a folder name"
    return runs


# ---- execution ------------------------------------------------------------------------------
# What a finished run keeps in the archive (a folder committed to the repository, so a later
# session resumes from it and the report can be rebuilt): its record, metrics and scores, and
# the map arrays of the runs the report draws. Models and samples are not kept: a data run is
# cheap and deterministic, so it is simply run again.
ARCHIVE_FILES = ("done.json", "log.txt", "metrics.csv", "summary.txt", "paper_metrics.json", "maps/consensus.csv",
                 "fleet/maps/consensus.csv", "fleet/summary.md", "fleet/run.json")
ARCHIVE_MAPS = ("map_mean.npy", "map_std.npy", "map_single.npy", "map_truth.npy", "map_meta.json",
                "map_epistemic.npy")  # kept when the maps folder has it (host_sim maps writes it now)


def drawn(run):
    """Whether the report draws this run's maps (so the archive keeps its arrays)."""
    t = run.tags
    return t["kind"] in ("single", "online") or (t["kind"] == "kl_table" and t["strategy"] == "kl" and
                                                 t["row"] in ("baseline", "network"))


HEARTBEAT_S = 60


class Campaign:
    def __init__(self, runs, out, jobs, archive=None):
        self.runs, self.out, self.jobs, self.archive = runs, out, jobs, archive
        self.lock = threading.Lock()
        self.done = self.failed = 0
        self.running = {}
        self.start = time.monotonic()
        self.cost_done = self.cost_todo = 0.0

    def folder(self, run):
        return os.path.join(self.out, "runs", run.name)

    def is_done(self, run):
        try:
            with open(os.path.join(self.folder(run), "done.json"), encoding="utf-8") as f:
                return json.load(f).get("key") == run.key()
        except (OSError, ValueError):
            return False

    def restore(self):
        """Finished runs of the archive (same command) that OUT lacks are copied into OUT."""
        n = 0
        for run in self.runs:
            src = os.path.join(self.archive, "runs", run.name)
            if self.is_done(run) or run.tags["kind"] == "data" or not os.path.isfile(os.path.join(src, "done.json")):
                continue
            try:
                with open(os.path.join(src, "done.json"), encoding="utf-8") as f:
                    if json.load(f).get("key") != run.key():
                        continue
            except (OSError, ValueError):
                continue
            shutil.rmtree(self.folder(run), ignore_errors=True)
            shutil.copytree(src, self.folder(run))
            n += 1
        return n

    def keep(self, run):
        """Copies what ARCHIVE_FILES names (and the drawn maps) of a finished run into the archive."""
        if not self.archive or run.tags["kind"] == "data":
            return
        src, dst = self.folder(run), os.path.join(self.archive, "runs", run.name)
        part = dst + ".partial"
        shutil.rmtree(part, ignore_errors=True)
        files = list(ARCHIVE_FILES)
        if run.tags["kind"] == "online":
            files += [f"fleet/robot_{i}/metrics.csv" for i in range(ROBOTS)]
        if run.tags["kind"] == "coverage":  # robot i's own map: its scores and its row of consensus.csv
            files += [f for i in run.tags.get("own", ()) for f in (f"paper_metrics_robot{i}.json",
                                                                    f"maps_robot{i}/consensus.csv")]
        if drawn(run):
            files += [f"{m}/{f}" for m in ("maps", "fleet/maps") for f in ARCHIVE_MAPS]
        for f in files:
            if os.path.isfile(os.path.join(src, f)):
                os.makedirs(os.path.dirname(os.path.join(part, f)), exist_ok=True)
                shutil.copy2(os.path.join(src, f), os.path.join(part, f))
        shutil.rmtree(dst, ignore_errors=True)
        os.rename(part, dst)

    def expand(self, cmd, run_dir):
        return [a.replace("{RUN}", run_dir).replace("{OUT}", self.out) for a in cmd]

    def progress(self, todo):
        with self.lock:
            n = self.done + self.failed
            width = 30
            fill = int(width * n / todo) if todo else width
            eta = ""
            if self.cost_done > 0 and n < todo:  # by the cost model: a paper run is not a small one
                per = (time.monotonic() - self.start) / self.cost_done
                eta = f", about {int(per * (self.cost_todo - self.cost_done) / 60) + 1} min left"
            line = (f"[{'#' * fill}{'.' * (width - fill)}] {n}/{todo} runs ({self.failed} failed), "
                    f"{int(time.monotonic() - self.start)} s{eta}; running: {', '.join(sorted(self.running)) or '-'}")
            print(line, flush=True)

    def execute(self, run, todo):
        final = self.folder(run)
        part = os.path.join(self.out, "runs", "." + run.name + ".partial")
        shutil.rmtree(part, ignore_errors=True)
        os.makedirs(part)
        with self.lock:
            self.running[run.name] = True
        self.progress(todo)
        t0 = time.monotonic()
        ok = True
        with open(os.path.join(part, "log.txt"), "w", encoding="utf-8") as log:
            for cmd in run.cmds:
                argv = self.expand(cmd, part)
                log.write("$ " + " ".join(argv) + "\n")
                log.flush()
                p = subprocess.run(argv, cwd=ROOT, stdout=log, stderr=subprocess.STDOUT,
                                   env=dict(os.environ, MPLBACKEND="Agg"))
                if p.returncode != 0:
                    log.write(f"exit status {p.returncode}\n")
                    ok = False
                    break
        spent = time.monotonic() - t0
        with self.lock:
            del self.running[run.name]
        if not ok:
            with self.lock:
                self.failed += 1
            print(f"FAILED {run.name}: see {part}/log.txt", file=sys.stderr, flush=True)
            self.progress(todo)
            return False
        fix_paths(part, final)
        with open(os.path.join(part, "done.json"), "w", encoding="utf-8") as f:
            json.dump({"key": run.key(), "name": run.name, "tags": run.tags, "seconds": round(spent, 1),
                       "cmds": [self.expand(c, final) for c in run.cmds]}, f, indent=1)
        shutil.rmtree(final, ignore_errors=True)
        os.rename(part, final)
        self.keep(run)
        with self.lock:
            self.done += 1
            self.cost_done += run.cost()
        self.progress(todo)
        return True

    def safe_execute(self, run, todo):
        try:
            return self.execute(run, todo)
        except OSError as e:
            with self.lock:
                self.running.pop(run.name, None)
                self.failed += 1
            print(f"FAILED {run.name}: {e}", file=sys.stderr, flush=True)
            return False

    def go(self):
        if self.archive:
            n = self.restore()
            if n:
                print(f"{n} finished runs restored from {self.archive}", flush=True)
        todo = [r for r in self.runs if not self.is_done(r)]
        self.cost_todo = sum(r.cost() for r in todo)
        print(f"{len(self.runs)} runs, {len(self.runs) - len(todo)} already done, {len(todo)} to run "
              f"({self.jobs} at a time) in {self.out}/runs", flush=True)
        if not todo:
            return 0
        names = {r.name for r in todo}
        finished = {r.name for r in self.runs if r.name not in names}
        broken = set()
        pending = list(todo)
        cores = self.jobs
        busy = {}
        with concurrent.futures.ThreadPoolExecutor(max_workers=self.jobs) as pool:
            while pending or busy:
                started = False
                for r in list(pending):
                    if any(n in broken for n in r.needs):
                        pending.remove(r)
                        broken.add(r.name)
                        print(f"SKIPPED {r.name}: needs {', '.join(r.needs)}", file=sys.stderr, flush=True)
                        continue
                    used = sum(x.threads for x in busy.values())
                    if all(n in finished for n in r.needs) and (not busy or used + r.threads <= cores):
                        pending.remove(r)
                        busy[pool.submit(self.safe_execute, r, len(todo))] = r
                        started = True
                if not busy:
                    if pending and not started:
                        return 1
                    continue
                doneset, _ = concurrent.futures.wait(list(busy), timeout=HEARTBEAT_S,
                                                     return_when=concurrent.futures.FIRST_COMPLETED)
                if not doneset:
                    self.progress(len(todo))  # a line a minute while long runs go on
                for fut in doneset:
                    r = busy.pop(fut)
                    (finished if fut.result() else broken).add(r.name)
        return 1 if broken else 0


def fix_paths(part, final):
    """A run's own text outputs name the folder it ran in: point them at its final name."""
    for dirpath, _, files in os.walk(part):
        for fn in files:
            if fn.endswith((".txt", ".json", ".md", ".csv")):
                p = os.path.join(dirpath, fn)
                try:
                    with open(p, encoding="utf-8") as f:
                        text = f.read()
                except (OSError, UnicodeDecodeError):
                    continue
                if part in text:
                    with open(p, "w", encoding="utf-8") as f:
                        f.write(text.replace(part, final))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="the reduced campaign (minutes): small preset, one seed")
    ap.add_argument("--out", help="results folder (default results/paper, results/paper-quick with --quick)")
    ap.add_argument("--jobs", type=int, default=max(1, min(2, os.cpu_count() or 1)),
                    help="runs at a time (default: 2, or 1 on one core); each fleet run uses one thread")
    ap.add_argument("--only", help="only the runs whose name contains TEXT (the report still reads them all)")
    ap.add_argument("--list", action="store_true", help="list the runs and whether each is done, then stop")
    ap.add_argument("--report-only", action="store_true", help="write REPORT.md from the finished runs")
    ap.add_argument("--archive", help="folder kept in the repository (default docs/paper; none with --quick): "
                    "finished runs are copied there as they end (records, metrics, scores, the drawn maps) and "
                    "restored from there, so a campaign resumes on a fresh clone; the report is copied there too")
    ap.add_argument("--bin-small", default="build/release-host-small/bin/host_sim", help="host_sim, preset small")
    ap.add_argument("--bin-paper", default="build/release-host-paper/bin/host_sim", help="host_sim, preset paper")
    args = ap.parse_args(argv)
    if args.jobs < 1:
        ap.error("--jobs must be >= 1")
    s = Settings(args.quick)
    out = os.path.abspath(args.out or os.path.join(ROOT, "results", "paper-quick" if args.quick else "paper"))
    runs = all_runs(s, args)
    if args.only:
        keep = {r.name for r in runs if args.only in r.name}
        if not keep:
            ap.error(f"--only {args.only}: no run's name contains it")
        needed = set(keep)
        for r in runs:
            if r.name in keep:
                needed.update(r.needs)
        runs = [r for r in runs if r.name in needed]
    archive = args.archive if args.archive is not None else (None if args.quick else os.path.join(ROOT, "docs", "paper"))
    archive = os.path.abspath(archive) if archive else None
    camp = Campaign(runs, out, args.jobs, archive)
    if args.list:
        for r in runs:
            print(f"{'done' if camp.is_done(r) else 'todo'}  {r.name}")
        return 0
    used = {c[0] for r in runs for c in r.cmds}  # only the programs of the runs selected (--only)
    for preset, b in bins(args).items():
        if args.report_only or b not in used:
            continue
        if (preset == "small" or s.big == "paper") and not os.access(os.path.join(ROOT, b), os.X_OK):
            print(f"experiments: {b}: not built (make PRESET={preset})", file=sys.stderr)
            return 2
    os.makedirs(os.path.join(out, "runs"), exist_ok=True)
    if not args.only:  # the whole campaign, so the report can say which runs are still missing
        with open(os.path.join(out, ".campaign.json.tmp"), "w", encoding="utf-8") as f:
            json.dump({"quick": s.quick, "runs": [{"name": r.name, "tags": r.tags} for r in runs]}, f, indent=1)
        os.replace(os.path.join(out, ".campaign.json.tmp"), os.path.join(out, "campaign.json"))
    if args.report_only and archive:
        camp.restore()
    try:
        rc = 0 if args.report_only else camp.go()
    except KeyboardInterrupt:
        print(f"\nexperiments: interrupted; the {camp.done} runs finished now are kept and the next "
              "`make experiments` goes on from there", file=sys.stderr)
        return 130
    report = [sys.executable, os.path.join(ROOT, "tools", "paper_report.py"), out] + (["--quick"] if args.quick else [])
    r = subprocess.run(report, cwd=ROOT, env=dict(os.environ, MPLBACKEND="Agg"))
    if r.returncode == 0 and archive:
        for f in os.listdir(out):
            if f.endswith((".md", ".csv", ".png")) or f == "campaign.json":
                shutil.copy2(os.path.join(out, f), os.path.join(archive, f))
    return rc or (1 if r.returncode else 0)


if __name__ == "__main__":
    sys.exit(main())
