#!/usr/bin/python3
"""Tests of tools/fleet as a newcomer meets it:
  - every bad option is refused before anything is written or moved: exit 2, one line
    "tools/fleet: error: ... (see tools/fleet --help)", and the results folder exactly as it was
    (an earlier run in RESULTS/NAME not moved aside, no key, no summary): the robots' options as
    `host_sim run` parses them (--rounds out of range, --net-faults, --extra's unknown options or
    missing values or options the launcher sets), --key-file (`host_sim key check`), tours of
    another plan (`host_sim paths check`), --map-res (`host_sim maps`), --lcm-url, argparse's own
    errors; a --results folder that does not exist is not made. With the real host_sim (its
    checks are the point), no robot starts;
  - --extra "--keep-ckpt 3" (a value starting with '-', space form) works as --extra=...;
  - Ctrl-C (SIGINT to the launcher) during the consensus map and during the rounds: exit 130, one
    line "fleet: interrupted during <step>; kept: ...", no failure said, no empty maps/;
  - --version: git describe of the repository, or the VERSION file of a tree without git;
  - the progress line: one line for the last round (not two), the summary's words; run.json's
    paths relative;
  - --record on a keyed fleet (the default) with the real host_sim: the traffic table counts the
    state chunks, every fleet message keyed, every tag valid under the run's key (skipped, said,
    where multicast or lcm-logger is missing);
  - --explore with the real host_sim over udpm: goal claims taken between real processes, the
    same trajectories and models on two runs of one seed; exploring, the rounds default to five
    per simulated second of --explore-time, at most host_sim's largest --rounds.
The stand-in for host_sim is tests/tools/test_fleet.py's.

    python3 tests/tools/test_fleet_launcher.py      prints "N passed, M failed", exit 1 on failure
"""
import csv
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.realpath(__file__)))
import minitest  # noqa: E402
from minitest import check, main, test  # noqa: E402

_n = len(minitest.TESTS)
import test_fleet  # noqa: E402  (its stand-in and launch(); its own tests are not run here)
del minitest.TESTS[_n:]

ROOT = test_fleet.ROOT
FLEET = test_fleet.FLEET
HOST_SIM = os.path.join(ROOT, "build", "release-host-small", "bin", "host_sim")
TIMEOUT = 60


def snapshot(d):
    """Every path under d with its size and mtime (None when d does not exist)."""
    if not os.path.exists(d):
        return None
    out = {}
    for base, dirs, files in os.walk(d):
        for n in dirs + files:
            p = os.path.join(base, n)
            st = os.lstat(p)
            out[os.path.relpath(p, d)] = (st.st_size, st.st_mtime_ns, st.st_mode)
    return out


def fleet(args, env=None, timeout=TIMEOUT):
    res = subprocess.run(["/usr/bin/python3", FLEET] + args, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         text=True, timeout=timeout, env=dict(os.environ, **(env or {})), cwd=ROOT)
    return res.returncode, res.stdout, res.stderr


@test
def bad_options_touch_nothing():
    if not os.access(HOST_SIM, os.X_OK):
        raise AssertionError(f"{HOST_SIM} not built (make)")
    tmp = tempfile.mkdtemp()
    try:
        results = os.path.join(tmp, "results")
        earlier = os.path.join(results, "custom")
        os.makedirs(os.path.join(earlier, "robot_0"))
        with open(os.path.join(earlier, "run.json"), "w") as f:
            f.write("{}\n")
        key644 = os.path.join(tmp, "README.md")
        shutil.copy(os.path.join(ROOT, "README.md"), key644)
        os.chmod(key644, 0o644)
        tours = os.path.join(tmp, "tours")  # tours of another plan: far outside the apartment's rooms
        os.makedirs(tours)
        for i in range(2):
            with open(os.path.join(tours, f"robot_{i}.csv"), "w") as f:
                f.write("x_m,y_m\n100.0,100.0\n101.0,100.0\n")
        cases = [
            (["--key-file", key644], "--key-file: "),
            (["--key-file", os.path.join(tmp, "none.key")], "no such file"),
            (["--rounds", "99999999999"], "--rounds: '99999999999' is not an integer in [1, 100000]"),
            (["--net-faults", "drop=2"], "--net-faults: drop=2: a probability"),
            (["--net-faults", "bogus=1"], "--net-faults: "),
            (["--extra=--bogus"], "host_sim run has no option --bogus"),
            (["--extra", "--bogus"], "host_sim run has no option --bogus"),
            (["--extra", "--keep-ckpt"], "--keep-ckpt needs a value"),
            (["--extra", "--keep-ckpt x"], "--keep-ckpt: 'x' is not an integer"),
            (["--extra", "--rounds 3"], "the launcher sets --rounds"),
            (["--extra", "--resume", "--mode", "online"], "--extra=--resume needs --mode offline"),
            (["--paths", tours], f"--paths {tours}: not tours of --plan"),
            (["--explore", "--paths", tours], "--explore drives no tours"),
            (["--explore", "--mode", "offline"], "--explore learns online"),
            (["--explore", "--explore-time", "0"], "--explore-time must be"),
            (["--explore", "--extra", "--explore-time 5"], "the launcher sets --explore-time"),
            (["--explore-own-posterior"], "--explore-own-posterior is an option of --explore"),
            (["--explore", "--extra", "--explore-own-posterior"], "the launcher sets --explore-own-posterior"),
            (["--explore-posterior-first"],
             "--explore-posterior-first is an option of --explore with --explore-policy uncertainty"),
            (["--explore", "--explore-policy", "frontier", "--explore-posterior-first"],
             "--explore-posterior-first is an option of --explore with --explore-policy uncertainty"),
            (["--explore", "--extra", "--explore-posterior-first"], "the launcher sets --explore-posterior-first"),
            (["--explore-no-fence"], "--explore-no-fence is an option of --explore"),
            (["--explore", "--extra", "--explore-no-fence"], "the launcher sets --explore-no-fence"),
            (["--map-res", "0"], "--map-res: "),
            (["--fleet-id", "99999999"], "--fleet-id: "),
            (["--lcm-url", "xx"], "--lcm-url xx: not an LCM multicast URL"),
            (["--bogus"], "unrecognized arguments: --bogus"),
            (["--robots", "two"], "argument --robots: invalid int value"),
        ]
        before = snapshot(results)
        for extra, want in cases:
            rc, out, err = fleet(["--bin", HOST_SIM, "--robots", "2", "--rounds", "5", "--results", results,
                                  "--name", "custom"] + extra)
            said = f"{extra}: exit {rc}\nstdout:\n{out}\nstderr:\n{err}"
            check(rc == 2, said)
            check(out == "" and len(err.strip().splitlines()) == 1 and
                  err.startswith("tools/fleet: error: ") and err.rstrip().endswith("(see tools/fleet --help)") and
                  "Traceback" not in err, f"not one line: {said}")
            check(want in err, f"no '{want}': {said}")
            check(snapshot(results) == before, f"{extra}: the results folder changed: {sorted(snapshot(results))}")
        # A --results that does not exist yet is not made for a run refused.
        fresh = os.path.join(tmp, "fresh")
        rc, out, err = fleet(["--bin", HOST_SIM, "--results", fresh, "--net-faults", "drop=2"])
        check(rc == 2 and not os.path.exists(fresh), f"exit {rc}, {fresh} made: {err}")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


@test
def extra_value_may_start_with_a_dash():
    tmp = tempfile.mkdtemp()
    try:
        dry = os.path.join(tmp, "dry.log")
        rc, out, run_dir = test_fleet.launch(tmp, ["--no-report", "--extra", "--keep-ckpt 3"], {"FAKE_DRY_LOG": dry},
                                             "extra", robots=2)
        check(rc == 0, f"exit {rc}:\n{out}")
        for i in range(2):
            s = test_fleet.starts(run_dir, i)[0]
            check(s.endswith(" --keep-ckpt 3"), f"robot {i} started as {s}")
        with open(dry) as f:
            checked = f.read().splitlines()
        check(len(checked) == 1 and checked[0].startswith("run ") and checked[0].endswith("--keep-ckpt 3 --help") and
              "--rounds 10 " in checked[0], f"the robots' options were checked as {checked}")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def launch_bg(tmp, extra, env_extra, name, robots=2):
    fake = test_fleet.write_fake(tmp)
    cmd = ["/usr/bin/python3", FLEET, "--bin", fake, "--robots", str(robots), "--results", tmp, "--name", name,
           "--force", "--val-poses", "1", "--fleet-id", str(61000 + os.getpid() % 4000)] + extra
    return subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=dict(os.environ, **env_extra)), os.path.join(tmp, name)


def interrupt_at(p, line_start, limit=20.0):
    """Reads p's stdout until a line starts with line_start, then SIGINT to p (the launcher only,
    as `kill -INT`); (exit status, stdout, stderr, seconds from the signal to the exit)."""
    seen = []
    deadline = time.time() + limit
    for line in p.stdout:
        seen.append(line)
        if line.startswith(line_start) or time.time() > deadline:
            break
    time.sleep(0.3)
    t = time.time()
    p.send_signal(signal.SIGINT)
    try:
        out, err = p.communicate(timeout=20)
    except subprocess.TimeoutExpired:
        p.kill()
        out, err = p.communicate()
    return p.returncode, "".join(seen) + out, err, time.time() - t


@test
def interrupt_during_post_processing():
    tmp = tempfile.mkdtemp()
    try:
        p, run_dir = launch_bg(tmp, ["--rounds", "5"], {"FAKE_MAPS_SLEEP": "60"}, "int-maps")
        rc, out, err, took = interrupt_at(p, "fleet: consensus map ...")
        said = f"exit {rc}\nstdout:\n{out}\nstderr:\n{err}"
        check("fleet: consensus map ..." in out, f"never reached the consensus map: {said}")
        check(rc == 130 and took < 10, f"not 130 at once ({took:.1f} s): {said}")
        lines = err.strip().splitlines()
        check(len(lines) == 1 and lines[0].startswith("fleet: interrupted during the consensus map; kept: "),
              f"not one line: {said}")
        check("the robots' folders (robot_0 .. robot_1)" in lines[0] and "run.json" in lines[0] and
              "fleet.key" in lines[0], f"kept: {lines[0]}")
        check("failed" not in out + err and "Traceback" not in err, f"a failure said: {said}")
        check(not os.path.exists(os.path.join(run_dir, "maps")) and "maps/" not in lines[0],
              f"the empty maps/ kept: {os.listdir(run_dir)}")
        check(os.path.isfile(os.path.join(run_dir, "run.json")), "run.json kept")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


@test
def post_step_bounded():
    """A step after the rounds that hangs is stopped at its bound, with one message naming it,
    exit 1, and the robots' results kept."""
    tmp = tempfile.mkdtemp()
    try:
        p, run_dir = launch_bg(tmp, ["--rounds", "5"], {"FAKE_MAPS_SLEEP": "60", "FLEETSIM_POST_STEP_TIMEOUT_S": "2"},
                               "post-bound")
        t = time.time()
        try:
            out, err = p.communicate(timeout=40)
        except subprocess.TimeoutExpired:
            p.kill()
            out, err = p.communicate()
        took = time.time() - t
        said = f"exit {p.returncode} after {took:.1f} s\nstdout:\n{out}\nstderr:\n{err}"
        check(p.returncode == 1 and took < 30, f"not stopped at its bound: {said}")
        check("consensus map took longer than 2 s and was stopped" in out + err, f"no message naming the step: {said}")
        check("Traceback" not in err, f"a traceback: {said}")
        check(os.path.isfile(os.path.join(run_dir, "robot_0", "summary.txt")), "the robots' results kept")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


@test
def interrupt_during_rounds():
    tmp = tempfile.mkdtemp()
    try:
        p, run_dir = launch_bg(tmp, ["--rounds", "400", "--no-report"], {}, "int-rounds")
        rc, out, err, took = interrupt_at(p, "[")  # the first progress line
        said = f"exit {rc}\nstdout:\n{out}\nstderr:\n{err}"
        lines = err.strip().splitlines()
        check(rc == 130 and len(lines) == 1 and
              lines[0].startswith("fleet: interrupted during the rounds (stopped all 2 robots); kept: the robots' "
                                  "folders (robot_0 .. robot_1; partial: a robot writes its final files when it "
                                  "finishes)"), said)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


@test
def version_says_the_commit():
    rc, out, err = fleet(["--version", "--bin", "/nonexistent/host_sim"])
    git = subprocess.run(["git", "-C", ROOT, "describe", "--always", "--dirty"], stdout=subprocess.PIPE, text=True)
    want = git.stdout.strip() if git.returncode == 0 else None
    check(rc == 0 and out.startswith("tools/fleet ") and len(out.strip().splitlines()) == 1, f"exit {rc}: {out} {err}")
    if want:
        check(out.strip() == f"tools/fleet {want}", f"{out!r}, git describe says {want!r}")
    tmp = tempfile.mkdtemp()  # a tree that is not a git clone: its VERSION file, else 'unknown'
    try:
        os.makedirs(os.path.join(tmp, "tools"))
        for f in ("fleet", "fleet_losses.py", "fleet_common.py", "fleet_checks.py", "fleet_machine.py",
                  "fleet_robots.py"):
            shutil.copy(os.path.join(ROOT, "tools", f), os.path.join(tmp, "tools", f))
        res = subprocess.run(["/usr/bin/python3", os.path.join(tmp, "tools", "fleet"), "--version"],
                             stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=TIMEOUT, cwd=tmp)
        check(res.returncode == 0 and res.stdout.startswith("tools/fleet unknown"), res.stdout)
        with open(os.path.join(tmp, "VERSION"), "w") as f:
            f.write("1.4.2\n")
        res = subprocess.run(["/usr/bin/python3", os.path.join(tmp, "tools", "fleet"), "--version"],
                             stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=TIMEOUT, cwd=tmp)
        check(res.returncode == 0 and res.stdout.strip() == "tools/fleet 1.4.2", res.stdout)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


@test
def progress_and_run_json():
    tmp = tempfile.mkdtemp()
    try:
        rc, out, run_dir = test_fleet.launch(tmp, ["--no-report"], {}, "progress", robots=2)
        check(rc == 0, f"exit {rc}:\n{out}")
        last = [l for l in out.splitlines() if "round 10/10" in l]
        check(len(last) == 1, f"the last round's progress line {len(last)} times:\n{out}")
        check(last[0].endswith("0 chunks lost, 0 re-sent") and "MB/s" in last[0], last[0])
        info = test_fleet.run_json(run_dir)
        for k in ("plan", "host_sim", "key_file"):
            check(not os.path.isabs(info[k]), f"run.json {k}: {info[k]}")
        check(info["key_file"] == "fleet.key" and not any(os.path.isabs(q) for q in info["paths"]),
              f"run.json: {info['key_file']} {info['paths']}")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


@test
def record_keyed_fleet():
    """A real 2-robot keyed fleet, 3 rounds, recorded: the table counts its state chunks."""
    if not os.access(HOST_SIM, os.X_OK):
        raise AssertionError(f"{HOST_SIM} not built (make)")
    if shutil.which("lcm-logger") is None:
        print("  (record_keyed_fleet: no lcm-logger: not tested)")
        return
    tmp = tempfile.mkdtemp()
    try:
        rc, out, err = fleet(["--bin", HOST_SIM, "--robots", "2", "--rounds", "3", "--val-poses", "1", "--record",
                              "--no-report", "--results", tmp, "--name", "rec"], timeout=120)
        if rc == 1 and "multicast does not work" in err:
            print("  (record_keyed_fleet: no UDP multicast on this host: not tested)")
            return
        said = f"exit {rc}\nstdout:\n{out}\nstderr:\n{err}"
        check(rc == 0, said)
        run_dir = os.path.join(tmp, "rec")
        with open(os.path.join(run_dir, "lcm_traffic.csv")) as f:
            rows = list(csv.DictReader(f))
        total = [r for r in rows if r["fleet"] == "all"]
        check(len(total) == 1, f"no totals row: {rows}")
        t = total[0]
        chunks, done, req = int(t["chunks_sent"]), int(t["done_sent"]), int(t["requests_sent"])
        check(chunks >= 2 * 3 and int(t["state_bytes"]) > 0, f"state chunks not counted: {t}\n{said}")
        check(int(t["keyed_messages"]) == chunks + done + req, f"not every message keyed: {t}")
        check(" 0 malformed" in out and "keyed fleet: " in out and "valid" in out and
              "tags checked with fleet.key" in out, said)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


@test
def explore_fleet_claims_same_twice():
    """A real 2-robot exploring fleet over LCM udpm (keyed), twice with one seed: each robot takes
    its peer's goal claims, the same number in both runs (robot 1 starts after robot 0's first
    claim may have gone out), and both runs drive the same trajectories and train the same models."""
    if not os.access(HOST_SIM, os.X_OK):
        raise AssertionError(f"{HOST_SIM} not built (make)")
    tmp = tempfile.mkdtemp()
    try:
        runs = []
        for name in ("ex1", "ex2"):
            rc, out, err = fleet(["--bin", HOST_SIM, "--explore", "--explore-policy", "coordinated", "--robots", "2",
                                  "--rounds", "4", "--explore-time", "40", "--val-poses", "1", "--no-report",
                                  "--results", tmp, "--name", name], timeout=120)
            if rc == 1 and "multicast does not work" in err:
                print("  (explore_fleet_claims_same_twice: no UDP multicast on this host: not tested)")
                return
            said = f"exit {rc}\nstdout:\n{out}\nstderr:\n{err}"
            check(rc == 0 and "0 states given up" in out, said)
            runs.append(os.path.join(tmp, name))
        for i in range(2):
            taken_per_run = []
            for run in runs:
                with open(os.path.join(run, f"robot_{i}", "summary.txt")) as f:
                    summary = f.read()
                claims = [l for l in summary.splitlines() if l.startswith("claims: ")]
                check(len(claims) == 1, f"robot {i}: no claims line:\n{summary}")
                taken = int(claims[0].split(" received, ")[1].split(" taken")[0])
                check(taken >= 1 and "0 invalid" in claims[0], f"robot {i} took no claim: {claims[0]}")
                taken_per_run.append(taken)
            check(taken_per_run[0] == taken_per_run[1], f"robot {i} took {taken_per_run} claims in the two runs")
            with open(os.path.join(runs[0], f"robot_{i}", "summary.txt")) as f:
                summary = f.read()
            check("explore: policy coordinated" in summary and "belief from the fleet's posterior" in summary and
                  "collisions: 0" in summary, summary)
            for f in ("final.bnn", "explore.csv"):
                with open(os.path.join(runs[0], f"robot_{i}", f), "rb") as a, \
                        open(os.path.join(runs[1], f"robot_{i}", f), "rb") as b:
                    check(a.read() == b.read(), f"robot {i}'s {f} differs between two runs of one seed")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


@test
def explore_rounds_follow_the_exploration_time():
    import importlib.machinery
    import importlib.util
    loader = importlib.machinery.SourceFileLoader("fleet_launcher", FLEET)
    spec = importlib.util.spec_from_loader("fleet_launcher", loader)
    mod = importlib.util.module_from_spec(spec)
    loader.exec_module(mod)
    argv = sys.argv
    try:
        for extra, want in ((["--explore"], 1500), (["--explore", "--explore-time", "2"], 10),
                            (["--explore", "--explore-time", "1e5"], 100000),
                            (["--explore", "--rounds", "7"], 7), ([], 1500)):
            sys.argv = ["tools/fleet", "--bin", HOST_SIM] + extra
            a = mod.parse()
            check(a.rounds == want, f"{extra}: rounds {a.rounds}, not {want}")
    finally:
        sys.argv = argv


if __name__ == "__main__":
    sys.exit(main())
