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
  - what the fleet lost, summed over the robots' summary.txt and traffic.csv (which the stand-in
    writes in host_sim's formats, FAKE_LOSSES giving one robot losses): said in the line "all N
    robots finished", the last line, run.json and summary.md, zero or not; --strict exits 3 when
    any is non-zero (or a total is only a lower bound: a restarted robot's queue drops), else 0;
  - --restart-failed with --mode online is refused (exit 2): an online robot cannot resume.
  - a run owns its folder: a second launch with the same --name moves the earlier run aside to
    NAME.prev-<date-time> and says so, the new run's robots start once there (a restarted one
    resumes inside the new folder); --extra --resume keeps the folder;
  - bad set-ups refused at once with exit 2 and one line, no traceback: --plan of another plan
    without --paths, --results that cannot be written, more robots than tours in --paths;
  - more robots than the default tours without --paths: `host_sim paths gen` makes them in the
    run's folder (one line says so) and robot i drives RUN/tours/robot_<i>.csv; up to 1024;
  - --tour-rooms own: `host_sim paths gen --rooms own` makes the tours in the run's folder even
    when the shipped ones are enough, on another plan too; run.json says own; with --paths it is
    refused (exit 2), as is a value other than all or own;
  - a ZeroMQ fleet's ports skip a port another process listens on (the next free block).
  - the launcher's defaults are the binary's (`host_sim defaults`, which the stand-in answers
    with today's values): one without the command is refused at once, exit 2, one line; --help
    still works and says where the defaults come from.
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

# What the stand-in says to `host_sim defaults` (today's values; test_defaults.py checks the
# launcher against the real binary's).
DEFAULTS = """seed=1
strategy=kl
radius_m=6
encoding=fp32
pool=cdr
rounds_per_comm=1
mc=50
resend_ms=50
peer_timeout_s=10
lcm_url=udpm://239.255.76.67:7667?ttl=0&recv_buf_size=33554432
max_fleet=1024
max_rounds=100000
fleet_robots=7
fleet_rounds=1500
fleet_mode=offline
fleet_val_poses=200
fleet_val_checks=50
fleet_map_res_m=0.05"""

# The stand-in for `host_sim run`: FAKE_DIE="robot:round" makes that robot kill itself after
# printing that round, unless it was started with --resume (FAKE_DIE_ALWAYS=1: then too).
FAKE = r'''
import os, signal, sys, time
args = sys.argv[1:]
if args[:1] == ["defaults"]:  # what the launcher reads (the values of today's build)
    if os.environ.get("FAKE_NO_DEFAULTS"):  # a build from before the command
        print("host_sim: unknown command 'defaults'", file=sys.stderr)
        sys.exit(2)
    print(DEFAULTS)
    sys.exit(0)
if args[:1] == ["run"] and "--help" in args:  # the launcher's checks of the robots' options
    if args[1:] == ["--help"]:  # the option table, as host_sim prints it (a few rows)
        print("usage: host_sim run ...\n\noptions:\n  --resume                 offline: continue\n"
              "  --rounds N               DiNNO rounds in all\n  --keep-ckpt K            round checkpoints kept")
        sys.exit(0)
    with open(os.environ.get("FAKE_DRY_LOG", os.devnull), "a") as f:  # what was checked
        f.write(" ".join(args) + "\n")
    if os.environ.get("FAKE_RUN_REFUSE"):  # host_sim run's reason for a bad value
        print("host_sim run: " + os.environ["FAKE_RUN_REFUSE"], file=sys.stderr)
        sys.exit(2)
    sys.exit(0)
if args[:2] == ["paths", "check"]:  # the tours against the plan
    sys.exit(0)
if args[:1] == ["maps"] and os.environ.get("FAKE_MAPS_SLEEP") and "--help" not in args:
    print("maps: started", flush=True)  # a consensus map that takes its time (Ctrl-C during it)
    os.makedirs(args[args.index("--out") + 1], exist_ok=True)
    time.sleep(float(os.environ["FAKE_MAPS_SLEEP"]))
    sys.exit(0)
if args[:1] in (["maps"], ["render"], ["coverage"]):  # the consensus map, the scene, the fleet's coverage:
    sys.exit(0)                                        # nothing to check here
if args[:1] == ["key"]:  # host_sim key new|check FILE
    if args[1] == "new":
        fd = os.open(args[2], os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
        os.write(fd, b"0" * 64 + b"\n")
        os.close(fd)
    sys.exit(0 if os.path.exists(args[2]) else 1)
opt = lambda name: args[args.index(name) + 1]
if args[:2] == ["paths", "gen"]:  # host_sim paths gen ... --out DIR: a tour per robot
    if os.environ.get("FAKE_PATHS_FAIL"):
        print("host_sim paths gen: plan.svg: " + os.environ["FAKE_PATHS_FAIL"], file=sys.stderr)
        sys.exit(1)
    os.makedirs(opt("--out"), exist_ok=True)
    with open(os.path.join(opt("--out"), "gen.txt"), "w") as f:
        f.write(" ".join(args) + "\n")
    for i in range(int(opt("--robots"))):
        with open(os.path.join(opt("--out"), f"robot_{i}.csv"), "w") as f:
            f.write("x_m,y_m\n1,1\n2,1\n")
    sys.exit(0)
if args[:1] == ["zmq-proxy"]:  # the forwarder: runs until SIGTERM; FAKE_PROXY_DIE: exits 1 at once
    print(f"zmq-proxy: publishers to tcp://127.0.0.1:{opt('--port')}", flush=True)
    if os.environ.get("FAKE_PROXY_DIE"):
        sys.exit(1)

    def stopped(sig, frame):
        print("zmq-proxy: stopped by SIGTERM", flush=True)
        sys.exit(0)
    signal.signal(signal.SIGTERM, stopped)
    while True:
        time.sleep(1)
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
# What a finished robot writes: traffic.csv and summary.txt in host_sim's exact formats, its
# losses in the last round (FAKE_LOSSES="robot:states:timeouts:drops" for one robot, else none).
loss = os.environ.get("FAKE_LOSSES")
lr, ls, lt, ld = (int(x) for x in loss.split(":")) if loss else (-1, 0, 0, 0)
ls, lt, ld = (ls, lt, ld) if me == lr else (0, 0, 0)
n = int(opt("--fleet"))
# Written whole, then renamed: host_sim writes traffic.csv's header when it starts, so a robot
# the launcher stops (another robot died) never leaves it empty, as a half-written file here did.
with open(os.path.join(out, "traffic.csv.part"), "w") as f:
    f.write("round,wall_ms,wait_ms,bytes_sent,bytes_received,chunks_sent,chunks_received,chunks_resent,"
            "chunks_requested,duplicates,stale,timeouts,rejoins,crc_failures,invalid,chunks_recovered,chunks_lost,"
            "states_missed,rounds_skipped,beacons_sent,peer_restarts,old_incarnation\n")
    for k in range(rounds):
        t, m = (lt, ls) if k == rounds - 1 else (0, 0)
        f.write(f"{k},1.0,0.1,100,100,1,1,0,0,0,0,{t},0,0,0,0,0,{m},0,0,0,0\n")
os.replace(os.path.join(out, "traffic.csv.part"), os.path.join(out, "traffic.csv"))
with open(os.path.join(out, "summary.txt"), "w") as f:
    f.write("seed: 1\npreset: small (33601 parameters)\nincarnation: 1\n")
    if resume:
        f.write(f"resumed: from round_{first - 2:04d}.bnn (round {first - 2}), rounds {first - 1} .. {rounds - 1} "
                "run by this start\n")
    if n > 1:
        f.write(f"fleet: {n} robots (this is robot {me}, fleet id 1), fp32 states, radius 6 m\n"
                "losses: 0 chunks requested again, 0 re-sent; 0 duplicates, 0 stale, 0 invalid, 0 CRC failures; "
                f"{lt} peer timeouts, 0 rejoins; 0 own echoes\n"
                "faults survived: 0 chunks lost (never received), 0 recovered by a request; "
                f"{ls} peer states gone without, 0 rounds cut short by a later round, 0 rounds skipped to catch up; "
                "0 peer restarts seen, 0 messages of an earlier incarnation dropped\n"
                "waiting for peers: 1.00 s wall in all (0.10 ms per round); "
                f"network queue drops {ld} (queue full {ld}, buffer too small 0); malformed datagrams dropped 0; "
                "sends refused 0\n")
sys.exit(0)
'''


def launch(tmp, extra, env_extra, name, robots=3):
    fake = write_fake(tmp)
    env = dict(os.environ, **env_extra)
    cmd = ["/usr/bin/python3", FLEET, "--bin", fake, "--robots", str(robots), "--rounds", "10", "--results", tmp,
           "--name", name, "--force", "--val-poses", "1", "--fleet-id", str(60000 + os.getpid() % 5000)] + extra
    res = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env,
                         timeout=TIMEOUT)
    return res.returncode, res.stdout, os.path.join(tmp, name)


def write_fake(tmp):
    """The stand-in for host_sim in tmp; its path."""
    fake = os.path.join(tmp, "host_sim")
    with open(fake, "w") as f:
        f.write(f"#!{sys.executable}\nDEFAULTS = {DEFAULTS!r}\n" + FAKE)
    os.chmod(fake, 0o755)
    return fake


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
        # A keyed fleet by default: the run's own key (0600), and the restart keeps key and run id.
        key = os.path.join(run_dir, "fleet.key")
        check(f"--key-file {key} --run-id " in starts[0] and os.stat(key).st_mode & 0o777 == 0o600,
              f"robot 1 was not started keyed with {key} (0600): {starts[0]}")
        check(run_json(run_dir).get("keyed") is True, "run.json says the fleet was keyed")
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
        # The queue drops of the start that died are written nowhere: the totals say "at least".
        gaps = info.get("losses_uncounted")
        check(info.get("queue_drops") == 0 and len(gaps) == 1 and gaps[0].startswith("robot_1: the datagrams "
              "dropped by full queues of the start(s) before its --resume at round 4"), f"run.json: {gaps}")
        check("robots finished in " in out and ": at least 0 states given up, 0 peer timeouts, 0 datagrams dropped "
              "by full queues: not all of it could be counted" in out, out)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def last_line(out):
    return out.strip().splitlines()[-1]


@test
def lossless_fleet_says_so():
    """A fleet whose robots lost nothing: the totals (zeros) in the line "all N robots finished",
    in the last line and in run.json; --strict exits 0; summary.md says it was lossless."""
    tmp = tempfile.mkdtemp()
    try:
        rc, out, run_dir = launch(tmp, ["--strict"], {}, "lossless")
        check(rc == 0, f"launcher exit {rc}:\n{out}")
        zeros = "0 states given up, 0 peer timeouts, 0 datagrams dropped by full queues"
        fin = [l for l in out.splitlines() if l.startswith("fleet: all 3 robots finished in ")]
        check(len(fin) == 1 and fin[0].endswith(f" s: {zeros}"), f"no finished line with the zeros:\n{out}")
        check(last_line(out).startswith("fleet: done in ") and last_line(out).endswith(f"/summary.md; {zeros}"),
              f"last line: {last_line(out)}")
        info = run_json(run_dir)
        check([info.get(k) for k in ("states_given_up", "peer_timeouts", "queue_drops")] == [0, 0, 0] and
              info.get("losses_uncounted") == [], f"run.json: {info}")
        with open(os.path.join(run_dir, "summary.md")) as f:
            md = f.read()
        check("**A lossless run: over its 3 robots, no neighbour state was given up, no peer timed out and no "
              "datagram was dropped by a full receive queue.**" in md, md)
        check("| states_given_up |" not in md, "the totals are not repeated as settings")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


@test
def losses_are_said_and_strict_fails():
    """One robot gave up 5 states, timed a peer out and dropped 1234 datagrams: the finished line
    says so and that the models are not a lossless run's; exit 0 without --strict; with it exit 3
    after run.json and summary.md are written, the message naming the totals."""
    tmp = tempfile.mkdtemp()
    try:
        lossy = {"FAKE_LOSSES": "2:5:1:1234"}
        said = ("5 states given up, 1 peer timeouts, 1,234 datagrams dropped by full queues: the models are NOT "
                "those of a lossless run (nor the in-process reference's)")
        rc, out, run_dir = launch(tmp, ["--no-report"], lossy, "lossy")
        check(rc == 0 and "fleet: all 3 robots finished in " in out and f" s: {said}" in out, f"exit {rc}:\n{out}")
        info = run_json(run_dir)
        check([info.get(k) for k in ("states_given_up", "peer_timeouts", "queue_drops")] == [5, 1, 1234],
              f"run.json: {info}")
        rc, out, run_dir = launch(tmp, ["--strict"], lossy, "lossy-strict")
        check(rc == 3, f"--strict: exit {rc}, not 3:\n{out}")
        check(last_line(out) == f"fleet: --strict: {said}", f"last line: {last_line(out)}")
        check(f"summary.md; {said}" in out, f"the done line names the totals:\n{out}")
        check(run_json(run_dir).get("queue_drops") == 1234, "run.json written before the exit")
        with open(os.path.join(run_dir, "summary.md")) as f:
            md = f.read()
        check("**5 states given up, 1 peer timeouts, 1,234 datagrams dropped by full queues (over 3 robots): the "
              "models are NOT those of a lossless run (nor the in-process reference's).**" in md, md)
        check(os.path.islink(os.path.join(tmp, "latest")), "the run finished as usual: latest points at it")
        # --no-report: the same exit status
        rc, out, _ = launch(tmp, ["--strict", "--no-report"], {"FAKE_LOSSES": "0:0:0:7"}, "drops-only")
        # Queue drops alone: re-sent, no state given up, so the models are not said to differ; --strict
        # still fails (the run was not lossless).
        check(rc == 3 and last_line(out).startswith("fleet: --strict: 0 states given up, 0 peer timeouts, 7 "
                                                    "datagrams dropped by full queues: not a lossless run: a busy "
                                                    "CPU let receive queues overflow; no state was given up") and
              "NOT" not in last_line(out), f"exit {rc}:\n{out}")
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
        check(os.path.exists(os.path.join(run_dir, "summary.md")), f"no summary.md; the launcher said:\n{out}")
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


def starts(run_dir, i):
    with open(os.path.join(run_dir, f"robot_{i}", "starts.txt")) as f:
        return f.read().splitlines()


@test
def rerun_moves_earlier_run_aside():
    tmp = tempfile.mkdtemp()
    try:
        rc, out, run_dir = launch(tmp, ["--no-report"], {}, "fleet")
        check(rc == 0, f"first launch exit {rc}:\n{out}")
        with open(os.path.join(run_dir, "robot_0", "old-only.txt"), "w") as f:
            f.write("from the first run\n")
        os.symlink("fleet", os.path.join(tmp, "latest"))  # as a finished run with its report leaves it
        # The second run (other rounds) with a robot that dies and is restarted with --resume.
        rc, out, run_dir = launch(tmp, ["--no-report", "--rounds", "6", "--restart-failed", "1"],
                                  {"FAKE_DIE": "1:3"}, "fleet")
        check(rc == 0, f"second launch exit {rc}:\n{out}")
        prev = [d for d in os.listdir(tmp) if d.startswith("fleet.prev-")]
        check(len(prev) == 1, f"one earlier run moved aside: {os.listdir(tmp)}")
        want = f"fleet: {run_dir} holds an earlier run; moved to {os.path.join(tmp, prev[0])}"
        check(want in out.splitlines(), f"no line '{want}' in:\n{out}")
        check(len(prev[0]) == len("fleet.prev-20261124-170102") and prev[0][11:19].isdigit() and
              prev[0][19] == "-" and prev[0][20:].isdigit(), f"the name {prev[0]}")
        old = os.path.join(tmp, prev[0])
        check(os.readlink(os.path.join(tmp, "latest")) == prev[0], "latest follows the earlier finished run")
        check(os.path.isfile(os.path.join(old, "robot_0", "old-only.txt")) and
              not os.path.exists(os.path.join(run_dir, "robot_0", "old-only.txt")), "the old files moved, all")
        check(run_json(old)["rounds"] == 10 and run_json(run_dir)["rounds"] == 6, "each run.json its own run")
        for i in range(3):
            check(len(starts(old, i)) == 1, f"earlier run: robot {i} started once")
        check(len(starts(run_dir, 0)) == 1 and len(starts(run_dir, 2)) == 1, "new run: robots started once")
        s1 = starts(run_dir, 1)
        check(len(s1) == 2 and s1[1] == s1[0] + " --resume" and f"--out {run_dir}/robot_1" in s1[1],
              f"the restarted robot resumed in the new run's folder: {s1}")
        # --extra --resume: the robots resume in the run's folder, which is kept.
        rc, out, run_dir = launch(tmp, ["--no-report", "--rounds", "6", "--extra=--resume"], {}, "fleet")
        check(rc == 0 and "holds an earlier run; kept" in out, f"resume launch exit {rc}:\n{out}")
        check(len([d for d in os.listdir(tmp) if d.startswith("fleet.prev-")]) == 1, "nothing moved")
        check(len(starts(run_dir, 0)) == 2, "robot 0 resumed in the same folder")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def refused(tmp, extra, name="bad"):
    rc, out, run_dir = launch(tmp, extra, {}, name)
    check(rc == 2, f"exit {rc}, not 2:\n{out}")
    check("Traceback" not in out and len(out.strip().splitlines()) == 1 and out.startswith("tools/fleet: error: ")
          and out.rstrip().endswith("(see tools/fleet --help)"), f"not one line:\n{out}")
    check(not os.path.exists(run_dir), "no run folder made")
    return out


@test
def plan_without_paths_refused():
    tmp = tempfile.mkdtemp()
    try:
        other = os.path.join(tmp, "other.svg")
        shutil.copy(os.path.join(ROOT, "host_sim/plans/apartment.svg"), other)
        out = refused(tmp, ["--plan", other])
        check(f"--plan {other} needs its own tours: give --paths DIR" in out and "host_sim paths gen --plan" in out,
              out)
        # the default plan, named: its default tours are taken
        rc, out, _ = launch(tmp, ["--no-report", "--plan", os.path.join(ROOT, "host_sim/plans/apartment.svg")],
                            {}, "default-plan")
        check(rc == 0, f"default plan: exit {rc}:\n{out}")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


@test
def unwritable_results_refused():
    tmp = tempfile.mkdtemp()
    try:
        afile = os.path.join(tmp, "a-file")
        open(afile, "w").close()
        out = refused(tmp, ["--results", os.path.join(afile, "x")])
        check(f"--results {afile}/x" in out and "Not a directory" in out, out)
        ro = os.path.join(tmp, "read-only")
        os.mkdir(ro, 0o555)
        os.chmod(ro, 0o555)
        if not os.access(ro, os.W_OK):
            out = refused(tmp, ["--results", ro])
        elif shutil.which("setpriv") and subprocess.run(
                ["setpriv", "--reuid=65534", "--regid=65534", "--clear-groups", "test", "-r", FLEET]).returncode == 0:
            # root writes anyway: the launcher runs as nobody instead (when nobody can read it:
            # a clone in a 0700 folder, as mktemp -d makes, cannot be)
            os.chmod(tmp, 0o755)
            sh_fake = os.path.join(tmp, "host_sim.sh")  # one nobody can run: /bin/sh's, only `defaults`
            with open(sh_fake, "w") as f:
                f.write(f"#!/bin/sh\ncat <<'EOF'\n{DEFAULTS}\nEOF\n")
            os.chmod(sh_fake, 0o755)
            res = subprocess.run(["setpriv", "--reuid=65534", "--regid=65534", "--clear-groups", "/usr/bin/python3",
                                  FLEET, "--bin", sh_fake, "--force", "--results", ro],
                                 stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=TIMEOUT)
            out = res.stdout
            check(res.returncode == 2 and len(out.strip().splitlines()) == 1,
                  f"as nobody: exit {res.returncode}:\n{out}")
        else:
            out = f"--results {ro} Permission denied (root, and no user but root can run the launcher here: not tested)"
        check(f"--results {ro}" in out and "Permission denied" in out, out)
    finally:
        for d, _, _ in os.walk(tmp):
            os.chmod(d, 0o755)
        shutil.rmtree(tmp, ignore_errors=True)


@test
def binary_without_defaults_refused():
    """The launcher's defaults are the binary's: one without `host_sim defaults` (an older build)
    is refused at once, exit 2, one line that says so; --help still works (it says where the
    defaults come from)."""
    tmp = tempfile.mkdtemp()
    try:
        rc, out, run_dir = launch(tmp, ["--no-report"], {"FAKE_NO_DEFAULTS": "1"}, "old")
        check(rc == 2 and len(out.strip().splitlines()) == 1 and "has no `defaults` command" in out and
              "rebuild (make)" in out and not os.path.exists(run_dir), f"exit {rc}:\n{out}")
        res = subprocess.run(["/usr/bin/python3", FLEET, "--bin", os.path.join(tmp, "nothing"), "--help"],
                             stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=TIMEOUT)
        check(res.returncode == 0 and "fleet_rounds" in res.stdout and "gives none: build it" in res.stdout, res.stdout)
        # the defaults read are passed on: radius, peer timeout, resend period, validation poses
        rc, out, run_dir = launch(tmp, ["--no-report", "--resend-ms", "50"], {}, "defaults")
        start = starts(run_dir, 0)[0]
        check(rc == 0 and "--radius 6.0 " in start and "--peer-timeout 10.0 " in start and
              "--encoding fp32 " in start and "--strategy kl " in start, f"exit {rc}: {start}\n{out}")
        check(run_json(run_dir)["map_res_m"] == 0.05, "run.json: the consensus map's grid")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


@test
def more_robots_than_tours_refused():
    tmp = tempfile.mkdtemp()
    try:
        out = refused(tmp, ["--robots", "9", "--paths", os.path.join(ROOT, "host_sim/plans/apartment")])
        check("has 7 tours (robot_0.csv .. robot_6.csv) for --robots 9" in out and
              "--robots 9 --seed 1 --out NEWDIR" in out and "share the rooms" in out, out)
        rc, out, run_dir = launch(tmp, ["--no-report"], {}, "too-many", robots=1025)
        check(rc == 2 and "--robots must be 1 .. 1024" in out and not os.path.exists(run_dir), f"exit {rc}:\n{out}")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


@test
def more_robots_than_default_tours_made():
    tmp = tempfile.mkdtemp()
    try:
        rc, out, run_dir = launch(tmp, ["--no-report", "--seed", "5"], {}, "nine", robots=9)
        check(rc == 0, f"exit {rc}:\n{out}")
        tours = os.path.join(run_dir, "tours")
        lines = [l for l in out.splitlines() if "making 9" in l]
        check(len(lines) == 1 and lines[0].startswith("fleet: the default tours cover 7 robots: making 9 with "
                                                      "`host_sim paths gen --plan ") and
              f"--robots 9 --seed 5 --out {tours}`" in lines[0], f"no progress line in:\n{out}")
        with open(os.path.join(tours, "gen.txt")) as f:
            gen = f.read().split()
        check(gen[:2] == ["paths", "gen"] and gen[gen.index("--robots") + 1] == "9" and
              gen[gen.index("--seed") + 1] == "5" and gen[gen.index("--plan") + 1].endswith("apartment.svg"),
              f"paths gen was run as {gen}")
        for i in range(9):
            s = starts(run_dir, i)
            check(len(s) == 1 and f"--path {tours}/robot_{i}.csv " in s[0] and "--fleet 9 " in s[0],
                  f"robot {i} was started as {s}")
            # 9 robots validate every ceil(9 / 8) = 2 rounds by default (7: every round, below)
            check("--val-every 2 " in s[0], f"robot {i} was started as {s}")
        check("validation every 2 rounds" in out, f"the launch line does not say the validation's cadence:\n{out}")
        check(run_json(run_dir)["paths"][8].endswith("tours/robot_8.csv"), "run.json names the made tours")
        # paths gen refuses: the launcher stops with its reason, before any robot starts.
        why = "room 3 (Hall) gets 200 robots, but only 99 distinct start cells keep 0.2 m clearance"
        rc, out, run_dir = launch(tmp, ["--no-report"], {"FAKE_PATHS_FAIL": why}, "refused", robots=300)
        check(rc == 1 and "fleet: cannot make the tours (" in out and why in out and
              not os.path.exists(os.path.join(run_dir, "robot_0")), f"exit {rc}:\n{out}")
        # The shipped tours when they are enough: no paths gen.
        rc, out, run_dir = launch(tmp, ["--no-report"], {}, "seven", robots=7)
        check(rc == 0 and "making" not in out and not os.path.exists(os.path.join(run_dir, "tours")) and
              "--path " + os.path.join(ROOT, "host_sim/plans/apartment/robot_6.csv") in starts(run_dir, 6)[0] and
              "--val-every 1 " in starts(run_dir, 6)[0] and "validation every round" in out,
              f"exit {rc}:\n{out}")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


@test
def own_tours_made():
    tmp = tempfile.mkdtemp()
    try:
        other = os.path.join(tmp, "other.svg")
        shutil.copy(os.path.join(ROOT, "host_sim/plans/apartment.svg"), other)
        for name, plan in (("own", []), ("own-other", ["--plan", other])):
            rc, out, run_dir = launch(tmp, ["--no-report", "--tour-rooms", "own"] + plan, {}, name)
            check(rc == 0, f"{name}: exit {rc}:\n{out}")
            tours = os.path.join(run_dir, "tours")
            lines = [l for l in out.splitlines() if "making 3 tours" in l]
            check(len(lines) == 1 and lines[0].startswith("fleet: --tour-rooms own: each robot sweeps only its start "
                                                          "room; making 3 tours with `host_sim paths gen --plan ") and
                  f"--robots 3 --seed 1 --rooms own --out {tours}`" in lines[0], f"{name}: no progress line in:\n{out}")
            with open(os.path.join(tours, "gen.txt")) as f:
                gen = f.read().split()
            want_plan = other if plan else os.path.join(ROOT, "host_sim/plans/apartment.svg")
            check(gen[:2] == ["paths", "gen"] and gen[gen.index("--rooms") + 1] == "own" and
                  gen[gen.index("--plan") + 1] == want_plan,
                  f"{name}: paths gen was run as {gen}")
            for i in range(3):
                check(f"--path {tours}/robot_{i}.csv " in starts(run_dir, i)[0], f"{name}: robot {i}")
            check(run_json(run_dir)["tour_rooms"] == "own", f"{name}: run.json")
        rc, out, run_dir = launch(tmp, ["--no-report"], {}, "all")
        check(rc == 0 and run_json(run_dir)["tour_rooms"] == "all" and "making" not in out, f"exit {rc}:\n{out}")
        rc, out, run_dir = launch(tmp, ["--no-report", "--tour-rooms", "own", "--paths",
                                        os.path.join(ROOT, "host_sim/plans/apartment")], {}, "own-paths")
        check(rc == 2 and "--tour-rooms own makes the tours" in out and not os.path.exists(run_dir),
              f"exit {rc}:\n{out}")
        rc, out, run_dir = launch(tmp, ["--no-report", "--tour-rooms", "some"], {}, "own-bad")
        check(rc == 2 and "invalid choice: 'some'" in out and not os.path.exists(run_dir), f"exit {rc}:\n{out}")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


@test
def zmq_proxy_started_and_watched():
    """--zmq-proxy on: the launcher starts `host_sim zmq-proxy` first, gives every robot
    --zmq-proxy 127.0.0.1:PORT instead of --peers, keeps the proxy's log and stops it at the end
    (SIGTERM); run.json says so. A proxy that exits while the robots run fails the run, naming
    it and its log, and run.json records it as what failed. Refused without --transport zmq."""
    tmp = tempfile.mkdtemp()
    try:
        rc, out, run_dir = launch(tmp, ["--no-report", "--transport", "zmq", "--zmq-proxy", "on"], {}, "proxy")
        check(rc == 0 and "through one proxy" in out, f"exit {rc}:\n{out}")
        for i in range(3):
            t = starts(run_dir, i)[0].split()
            check("--peers" not in t and t[t.index("--zmq-proxy") + 1].startswith("127.0.0.1:"), f"robot {i}: {t}")
        check(run_json(run_dir)["zmq_proxy"] is True, "run.json: zmq_proxy")
        with open(os.path.join(run_dir, "zmq_proxy.log")) as f:
            log = f.read()
        check("publishers to tcp://127.0.0.1:" in log and "stopped by SIGTERM" in log, f"zmq_proxy.log:\n{log}")
        rc, out, run_dir = launch(tmp, ["--no-report", "--transport", "zmq", "--zmq-proxy", "on", "--rounds", "100"],
                                  {"FAKE_PROXY_DIE": "1"}, "proxy-dies")
        check(rc == 1 and "the ZeroMQ proxy (host_sim zmq-proxy) exited with status 1 while the robots ran" in out
              and "zmq_proxy.log" in out, f"exit {rc}:\n{out}")
        failed = run_json(run_dir).get("failed") or {}  # the run is recorded all the same
        check(failed.get("service") == "the ZeroMQ proxy (host_sim zmq-proxy)" and failed.get("how") == "exit status 1"
              and failed.get("log", "").endswith("zmq_proxy.log"), f"run.json failed: {failed}")
        rc, out, run_dir = launch(tmp, ["--no-report", "--zmq-proxy", "on"], {}, "proxy-lcm")
        check(rc == 2 and "--zmq-proxy is for --transport zmq" in out, f"exit {rc}:\n{out}")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


@test
def zmq_ports_skip_a_busy_block():
    """A ZeroMQ fleet takes the first block of --robots ports nobody listens on: with a port of its
    default block held by another listener (as another fleet's robot would), the block starts
    after it; robot i binds the i-th port of the --peers list every robot gets."""
    import socket
    tmp = tempfile.mkdtemp()
    fid = 60000 + os.getpid() % 5000
    start = 7700 + 32 * (fid % 500)
    held = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    try:
        held.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        held.bind(("127.0.0.1", start + 2))
        held.listen()
        rc, out, run_dir = launch(tmp, ["--no-report", "--transport", "zmq"], {}, "zmq", robots=4)
        check(rc == 0, f"exit {rc}:\n{out}")
        s = starts(run_dir, 0)[0].split()
        peers = s[s.index("--peers") + 1].split(",")
        ports = [int(p.rsplit(":", 1)[1]) for p in peers]
        check(ports == list(range(start + 3, start + 7)), f"peers {peers}: not the block after the held port "
              f"{start + 2}")
        for i in range(1, 4):
            t = starts(run_dir, i)[0].split()
            check(t[t.index("--peers") + 1] == ",".join(peers), f"robot {i} got another peers list: {t}")
    finally:
        held.close()
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    sys.exit(main())
