#!/usr/bin/python3
"""Tests of tools/fleet's handling of a robot that dies, with a stand-in for host_sim (a script
that prints host_sim's round lines, and dies by SIGKILL at a chosen round unless started with
--resume), so no robot trains and each test takes seconds:
  - --restart-failed 2: the dead robot is started again with the same command plus --resume,
    the launcher says so ("robot 1 died at round 4 (killed by signal SIGKILL); restarting it (1 of
    2) with --resume"), the fleet finishes with exit 0 and run.json lists the death;
  - without restarts: exit 1, the message names the robot, the round and the signal, and
    run.json ("failed", "deaths") and summary.md (tools/fleet_report.py) say the same;
  - a robot that dies again after its last restart fails the fleet;
  - --restart-failed with --mode online is refused (exit 2): an online robot cannot resume.
Every launcher runs under a timeout: a hang is a failure.

    python3 tests/tools/test_fleet.py      prints "N passed, M failed", exit 1 on failure
"""
import json
import os
import shutil
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.realpath(__file__)))
from minitest import check, main, test  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.realpath(__file__))))
FLEET = os.path.join(ROOT, "tools", "fleet")
TIMEOUT = 120

# The stand-in for `host_sim run`: FAKE_DIE="robot:round" makes that robot kill itself after
# printing that round, unless it was started with --resume (FAKE_DIE_ALWAYS=1: then too).
FAKE = r'''
import os, signal, sys, time
args = sys.argv[1:]
opt = lambda name: args[args.index(name) + 1]
out, me, rounds = opt("--out"), int(opt("--id")), int(opt("--rounds"))
resume = "--resume" in args
os.makedirs(out, exist_ok=True)
with open(os.path.join(out, "starts.txt"), "a") as f:
    f.write(" ".join(args) + "\n")
die = os.environ.get("FAKE_DIE", "")
die_robot, die_round = (int(x) for x in die.split(":")) if die else (-1, -1)
always = os.environ.get("FAKE_DIE_ALWAYS") == "1"
first = (die_round if always else die_round + 1) if resume and me == die_robot else 1
print("run: a stand-in robot", flush=True)
for k in range(first, rounds + 1):
    time.sleep(0.05)
    print(f"round {k:4d}/{rounds}  t 1.0 s  progress 1.00 m  pool 1  train 0.5  val 0.4  kl 1.00  nbrs 1  "
          f"dis 0.01  sent 100 B  lost 0  recovered 0  resent 0  wait 0.1 ms", flush=True)
    if me == die_robot and k == die_round and (always or not resume):
        print("host_sim run: about to die", file=sys.stderr, flush=True)
        os.kill(os.getpid(), signal.SIGKILL)
sys.exit(0)
'''


def launch(tmp, extra, env_extra, name):
    fake = os.path.join(tmp, "host_sim")
    with open(fake, "w") as f:
        f.write(f"#!{sys.executable}\n" + FAKE)
    os.chmod(fake, 0o755)
    env = dict(os.environ, **env_extra)
    cmd = ["/usr/bin/python3", FLEET, "--bin", fake, "--robots", "3", "--rounds", "10", "--results", tmp,
           "--name", name, "--force", "--val-poses", "1", "--fleet-id", str(60000 + os.getpid() % 5000)] + extra
    res = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env,
                         timeout=TIMEOUT)
    return res.returncode, res.stdout, os.path.join(tmp, name)


def run_json(run_dir):
    with open(os.path.join(run_dir, "run.json")) as f:
        return json.load(f)


@test
def restart_then_finish():
    tmp = tempfile.mkdtemp()
    try:
        rc, out, run_dir = launch(tmp, ["--restart-failed", "2", "--no-report"], {"FAKE_DIE": "1:4"}, "restart")
        check(rc == 0, f"launcher exit {rc}:\n{out}")
        want = "robot 1 died at round 4 (killed by signal SIGKILL); restarting it (1 of 2) with --resume"
        check(want in out, f"no '{want}' in:\n{out}")
        with open(os.path.join(run_dir, "robot_1", "starts.txt")) as f:
            starts = f.read().splitlines()
        check(len(starts) == 2 and not starts[0].endswith("--resume") and starts[1] == starts[0] + " --resume",
              f"robot 1 was started as {starts}")
        for i in (0, 2):
            with open(os.path.join(run_dir, f"robot_{i}", "starts.txt")) as f:
                check(len(f.read().splitlines()) == 1, f"robot {i} was started once")
        info = run_json(run_dir)
        d = info.get("deaths")
        check(isinstance(d, list) and len(d) == 1 and d[0]["robot"] == 1 and d[0]["round"] == 4 and
              d[0]["restarted"] is True and "SIGKILL" in d[0]["how"], f"run.json deaths: {d}")
        check("failed" not in info and info.get("restart_failed") == 2, "run.json: no failure, the setting")
        with open(os.path.join(run_dir, "robot_1", "stderr.log")) as f:
            check("about to die" in f.read(), "the dead robot's stderr is kept across the restart")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


@test
def death_without_restart_is_reported():
    tmp = tempfile.mkdtemp()
    try:
        rc, out, run_dir = launch(tmp, [], {"FAKE_DIE": "1:4"}, "died")
        check(rc == 1, f"launcher exit {rc}:\n{out}")
        check("robot 1 failed at round 4 (killed by signal SIGKILL" in out, f"message:\n{out}")
        info = run_json(run_dir)
        f = info.get("failed")
        check(isinstance(f, dict) and f["robot"] == 1 and f["round"] == 4 and "SIGKILL" in f["how"] and
              f["error"] == "host_sim run: about to die" and f["restarted"] is False, f"run.json failed: {f}")
        with open(os.path.join(run_dir, "summary.md")) as fh:
            md = fh.read()
        check("The fleet failed: robot 1 died at round 4 (killed by signal SIGKILL)" in md, f"summary.md:\n{md}")
        check("## Robots that died" in md and "not restarted" in md, "summary.md lists the death")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


@test
def restarts_run_out():
    tmp = tempfile.mkdtemp()
    try:
        rc, out, run_dir = launch(tmp, ["--restart-failed", "1", "--no-report"],
                                  {"FAKE_DIE": "2:3", "FAKE_DIE_ALWAYS": "1"}, "again")
        check(rc == 1, f"launcher exit {rc}:\n{out}")
        check("restarting it (1 of 1) with --resume" in out and "robot 2 failed at round 3" in out, out)
        d = run_json(run_dir)["deaths"]
        check([x["restarted"] for x in d] == [True, False], f"deaths: {d}")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


@test
def online_restarts_refused():
    tmp = tempfile.mkdtemp()
    try:
        rc, out, _ = launch(tmp, ["--restart-failed", "1", "--mode", "online"], {}, "online")
        check(rc == 2 and "--restart-failed needs --mode offline" in out, f"exit {rc}:\n{out}")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
