#!/usr/bin/python3
"""A fleet with robot 0 on an emulated board, hardware in the loop (`make hil BOARD=...`).

    tools/board/hil_fleet.py --board B --qemu CMD --elf board_robot.elf --host-sim HOST_SIM [options]

What it does, in order:
  0. the board alone against a world that stops answering (SIGSTOP): it must end within 60 s,
     exit 1 and say the link is down (OUT/world-stops/);
  1. asks the board's image (board_robot --help, under QEMU) for its pool and chunk sizes, so that
     the host robots keep what the board keeps (`host_sim run --pool-samples`) and chunk their
     states as it does (`--chunk-bytes`: a chunk's DATAGRAM frame fits one Ethernet frame);
  2. the HIL fleet, in OUT/hil/: `host_sim hil --fleet-lcm URL` serves robot 0's world to the
     board and bridges its datagrams to the fleet's LCM (udpm on loopback); robot 0 is
     board_robot.elf under QEMU (-icount shift=0,sleep=on: one instruction is 1 ns of the
     board's time, and an idle board waits in real time, as the fleet's peers do) with its
     Ethernet (-nic socket) on the world; robots 1 .. N-1 are `host_sim run` processes. The
     board's lines are shown as they come, the host robots' rounds every 15 s;
  3. the reference, in OUT/reference/: the same fleet, robot 0 a host process too;
  4. robot 0's final validation loss in both (`host_sim maps --valset` of its final.bnn, on the
     same validation set) and their relative difference against --rtol, and how many of its
     checkpoints (every round's and final.bnn) are the host robot's byte for byte: OUT/summary.md,
     the last line, and the exit status.
Every wait is bounded (--time-limit for each fleet); Ctrl-C or a failure stops every process.
Exit status: 0 the fleets finished and robot 0 agrees; 1 a robot failed or robot 0 does not agree;
2 bad options; 130 interrupted.
"""
import argparse
import os
import random
import re
import shlex
import signal
import subprocess
import sys
import threading
import time

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "tools"))
from fleet_common import DEFAULT_PATHS, DEFAULT_PLAN  # noqa: E402
from fleet_machine import check_machine  # noqa: E402
from fleet_robots import Robot, _die_with_parent, stop_all  # noqa: E402

SIZES_RE = re.compile(r"--pool-samples (\d+) --chunk-bytes (\d+)")
PORT_RE = re.compile(r" on [a-z]+ 127\.0\.0\.1:(\d+)$", re.M)
RESULT_RE = re.compile(r"^result (\S+) (.*)$", re.M)
PROCS = []  # every process started, stopped on the way out
# The fleet's resend period (and so its repeats: RoundCompletes every quarter of it, beacons every
# one). The board takes at most 16 datagrams per RT tick, and while it trains its time runs at
# QEMU's speed, a fifth of real time here: at the host's 50 ms its peers' repeats alone filled
# the link, its requests came back as resends behind them, and rounds slowed from 6 to 15 s of
# the board's time in 8 rounds. 1 s leaves the link to the states.
RESEND_MS = 1000
# A board whose world stopped answering ends within this: its 10 exchanges in a row unanswered
# (5 TICKs of 200 ms each: 10 s of the link's time), and QEMU's slack on a busy machine.
WORLD_STOPS_S = 60


def say(msg):
    print(f"hil-fleet: {msg}", flush=True)


def fail(msg, code=1):
    print(f"hil-fleet: {msg}", file=sys.stderr, flush=True)
    raise SystemExit(code)


def parse_args():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__)
    p.add_argument("--board", required=True, help="the board's name (results/board-<name>/)")
    p.add_argument("--qemu", required=True, help="the board's QEMU command without -icount (the board's "
                                                 "BOARD_QEMU); -icount shift=0,sleep=on is added")
    p.add_argument("--elf", required=True, help="board_robot.elf built for the board")
    p.add_argument("--host-sim", required=True, help="host_sim built with the board's preset and math "
                                                     "(LA_BACKEND=ref FP_CONTRACT=off)")
    p.add_argument("--robots", type=int, default=3, help="robots in the fleet, 2 .. 7 (default 3)")
    p.add_argument("--rounds", type=int, default=30, help="DiNNO rounds, offline (default 30)")
    p.add_argument("--post-rounds", type=int, default=3, help="then the posterior's rounds (default 3)")
    p.add_argument("--seed", type=int, default=1, help="the run seed (default 1)")
    p.add_argument("--plan", default=DEFAULT_PLAN, help="floor plan (default the apartment)")
    p.add_argument("--paths", default=DEFAULT_PATHS, help="folder of robot_<i>.csv tours (default the plan's)")
    p.add_argument("--out", default=None, help="results folder (default results/board-<board>/hil-fleet)")
    p.add_argument("--rtol", type=float, default=1e-4, help="robot 0's validation loss, board against host "
                                                           "(default 1e-4, relative)")
    p.add_argument("--time-limit", type=float, default=3600.0, help="wall seconds for each fleet (default 3600)")
    p.add_argument("--no-reference", action="store_true", help="the HIL fleet alone, no comparison")
    a = p.parse_args()
    if not 2 <= a.robots <= 7:
        p.error("--robots must be 2 .. 7")
    if not 1 <= a.rounds <= 100000 or not 0 <= a.post_rounds <= 1000 or not 0 <= a.seed < 2 ** 32:
        p.error("--rounds 1 .. 100000, --post-rounds 0 .. 1000, --seed 0 .. 2^32 - 1")
    if not (a.rtol > 0 and a.time_limit > 0):
        p.error("--rtol and --time-limit must be positive")
    for f in [a.elf, a.host_sim, a.plan] + [tour(a, i) for i in range(a.robots)]:
        if not os.path.isfile(f):
            p.error(f"{f}: no such file")
    a.out = a.out or os.path.join(ROOT, "results", f"board-{a.board}", "hil-fleet")
    return a


def tour(a, i):
    return os.path.join(a.paths, f"robot_{i}.csv")


def qemu_cmd(a, board_args, extra=()):
    """The board's QEMU running board_robot with these arguments (on the semihosting command line,
    which cannot carry commas or spaces)."""
    for x in board_args:
        if "," in x or " " in x:
            fail(f"'{x}': the semihosting command line cannot carry commas or spaces", 2)
    return shlex.split(a.qemu) + ["-icount", "shift=0,sleep=on", "-monitor", "none"] + list(extra) + [
        "-semihosting-config", "enable=on,target=native," + ",".join("arg=" + x for x in ["board_robot"] + board_args),
        "-kernel", a.elf]


def board_sizes(a):
    r = subprocess.run(qemu_cmd(a, ["--help"]), stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                       timeout=60)
    m = SIZES_RE.search(r.stdout)
    if r.returncode != 0 or not m:
        fail(f"board_robot --help under QEMU said nothing of its sizes (exit {r.returncode}):\n{r.stdout[-800:]}")
    return int(m.group(1)), int(m.group(2))


def fleet_options(a, url, fleet_id, sizes):
    """What every host robot gets, as tools/fleet gives it, and the board's sizes."""
    return ["--offline", "--rounds", str(a.rounds), "--post-rounds", str(a.post_rounds), "--seed", str(a.seed),
            "--fleet", str(a.robots), "--fleet-id", str(fleet_id), "--transport", "lcm", "--lcm-url", url,
            "--pool-samples", str(sizes[0]), "--chunk-bytes", str(sizes[1]),
            # the board drives its tour at real-time pace and trains slower than the host: its
            # peers wait for it (it speaks while it trains, so a dead board still costs one wait)
            "--peer-timeout", "120", "--join-timeout", str(int(a.time_limit)),
            "--resend-ms", str(RESEND_MS), "--quiet", "--no-maps"]


def host_robot(a, i, run_dir, opts):
    cmd = [a.host_sim, "run", "--plan", a.plan, "--path", tour(a, i), "--out", os.path.join(run_dir, f"robot_{i}"),
           "--id", str(i)] + opts
    r = Robot(i, cmd, os.path.join(run_dir, f"robot_{i}"))
    r.start()
    PROCS.append(r.proc)
    return r


def start_world(a, run_dir, url):
    """Robot 0's world (host_sim hil on Ethernet frames), bridged to the fleet on `url` (None:
    no fleet); waits until it listens: (its process, its port)."""
    os.makedirs(run_dir, exist_ok=True)
    log = open(os.path.join(run_dir, "world.txt"), "w")
    w = subprocess.Popen([a.host_sim, "hil", "--plan", a.plan, "--path", tour(a, 0), "--robot", "0", "--seed",
                          str(a.seed), "--link", "ether", "--listen", "127.0.0.1:0", "--idle-timeout", "120"] +
                         (["--fleet-lcm", url] if url else []), stdout=log, stderr=subprocess.STDOUT,
                         preexec_fn=_die_with_parent)
    PROCS.append(w)
    path = os.path.join(run_dir, "world.txt")
    for _ in range(300):  # 30 s at most
        m = PORT_RE.search(open(path).read())
        if m:
            return w, int(m.group(1))
        if w.poll() is not None:
            fail(f"host_sim hil ended before it listened:\n{open(path).read()[-800:]}")
        time.sleep(0.1)
    fail(f"host_sim hil did not listen within 30 s (see {path})")


def stop_world(w):
    """SIGINT: it prints its last line and exits 130; gone within 10 s or killed."""
    w.send_signal(signal.SIGINT)
    try:
        w.wait(10)
    except subprocess.TimeoutExpired:
        w.kill()
        w.wait()
        return "killed 10 s after it was asked to stop"
    return None if w.returncode in (0, 130) else f"exit status {w.returncode}"


WORLD_T_RE = re.compile(r"^hil: t=\s*([0-9.]+) s", re.M)


def world_time(world_log):
    """The simulated time of robot 0's world, from its last progress line, or None."""
    try:
        found = WORLD_T_RE.findall(open(world_log).read())
    except OSError:
        return None
    return float(found[-1]) if found else None


def watch(robots, board, limit_s, what, world_log=None, world=None):
    """Waits for every robot (the board's process among them, as `board`), showing the host
    robots' rounds (and robot 0's world's time) every 15 s; a robot that fails, robot 0's world
    (`world`) ending before the board did, or the deadline stops them all."""
    deadline = time.time() + limit_s
    next_line = time.time() + 15
    while True:
        procs = [r.proc for r in robots] + ([board] if board else [])
        for r in robots:
            if r.proc.poll() not in (None, 0):
                fail(f"{what}: robot {r.i} failed: {r.why()}")
        if board is not None and board.poll() not in (None, 0):
            fail(f"{what}: robot 0 (the board) failed: exit status {board.returncode}")
        # Without its world the board would wait in lockstep, its clock standing still.
        if world is not None and board is not None and board.poll() is None and world.poll() is not None:
            fail(f"{what}: robot 0's world (host_sim hil) ended before the board finished: exit status "
                 f"{world.returncode} (see {world_log})")
        if all(p.poll() is not None for p in procs):
            return
        if time.time() > deadline:
            fail(f"{what}: not finished within --time-limit {limit_s:g} s: stopped")
        if time.time() >= next_line:
            t = world_time(world_log) if world_log else None
            say(f"{what}: " + (f"robot 0's world at t={t:.0f} s, " if t is not None else "") +
                ", ".join(f"robot {r.i} round {r.round}/{r.rounds or '?'}" for r in robots))
            next_line += 15
        time.sleep(0.5)


def run_hil_fleet(a, sizes):
    run_dir = os.path.join(a.out, "hil")
    url, fleet_id = lcm_url(), random.randrange(1, 1000000)
    world, port = start_world(a, run_dir, url)
    say(f"HIL fleet of {a.robots}: robot 0's world on ether 127.0.0.1:{port}, the fleet on {url}")
    opts = fleet_options(a, url, fleet_id, sizes)
    robots = [host_robot(a, i, run_dir, opts) for i in range(1, a.robots)]
    out0 = os.path.join(run_dir, "robot_0")
    os.makedirs(out0, exist_ok=True)
    args = ["--connect", "eth0", "--tour", tour(a, 0), "--out", out0, "--robot", "0", "--fleet", str(a.robots),
            "--fleet-id", str(fleet_id), "--rounds", str(a.rounds), "--post-rounds", str(a.post_rounds),
            "--seed", str(a.seed), "--peer-timeout", "120", "--join-timeout", str(int(a.time_limit)),
            "--resend-ms", str(RESEND_MS), "--ckpt-every", "1"]
    cmd = qemu_cmd(a, args, ["-nic", f"socket,udp=127.0.0.1:{port},localaddr=127.0.0.1:0"])
    say("robot 0: " + " ".join(cmd))
    log = open(os.path.join(out0, "board.txt"), "w")
    board = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, bufsize=1,
                             preexec_fn=_die_with_parent)
    PROCS.append(board)

    def show():
        for line in board.stdout:
            log.write(line)
            log.flush()
            if not line.startswith("result "):
                print(f"robot 0 (board): {line.rstrip()}", flush=True)
    reader = threading.Thread(target=show, daemon=True)
    reader.start()
    watch(robots, board, a.time_limit, "HIL fleet", os.path.join(run_dir, "world.txt"), world)
    reader.join(5)
    why = stop_world(world)
    if why:
        fail(f"HIL fleet: host_sim hil: {why}")
    results = dict(RESULT_RE.findall(open(os.path.join(out0, "board.txt")).read()))
    return os.path.join(out0, "final.bnn"), results


def check_world_stops(a):
    """The board alone against a world that stops answering (host_sim hil stopped with SIGSTOP,
    as a frozen host: no port-unreachable reaches the board) must end on its own, exit 1 and say
    the link is down, within WORLD_STOPS_S of the stop. Returns the seconds it took."""
    run_dir = os.path.join(a.out, "world-stops")
    world, port = start_world(a, run_dir, None)
    out0 = os.path.join(run_dir, "robot_0")
    os.makedirs(out0, exist_ok=True)
    log_path = os.path.join(out0, "board.txt")
    cmd = qemu_cmd(a, ["--connect", "eth0", "--tour", tour(a, 0), "--out", out0, "--rounds", "1", "--seed",
                       str(a.seed)], ["-nic", f"socket,udp=127.0.0.1:{port},localaddr=127.0.0.1:0"])
    with open(log_path, "w") as log:
        board = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, preexec_fn=_die_with_parent)
    PROCS.append(board)
    deadline = time.time() + 60
    while "board_robot: board " not in open(log_path).read():
        if board.poll() is not None or time.time() > deadline:
            fail(f"world stops: the board did not reach its world (see {log_path})")
        time.sleep(0.2)
    time.sleep(2)  # driving
    world.send_signal(signal.SIGSTOP)
    stopped = time.time()
    try:
        board.wait(WORLD_STOPS_S)
    except subprocess.TimeoutExpired:
        fail(f"world stops: the board still ran {WORLD_STOPS_S} s after its world stopped answering: it hangs "
             f"(see {log_path})")
    finally:
        world.kill()
        world.wait()
    took = time.time() - stopped
    text = open(log_path).read()
    if board.returncode != 1 or "the link is down" not in text:
        fail(f"world stops: the board exited {board.returncode} {took:.0f} s after its world stopped, without "
             f"saying the link is down (see {log_path})")
    return took


def run_reference(a, sizes):
    run_dir = os.path.join(a.out, "reference")
    url, fleet_id = lcm_url(), random.randrange(1, 1000000)
    say(f"reference fleet of {a.robots} host processes on {url}")
    opts = fleet_options(a, url, fleet_id, sizes)
    robots = [host_robot(a, i, run_dir, opts) for i in range(a.robots)]
    watch(robots, None, a.time_limit, "reference")
    return os.path.join(run_dir, "robot_0", "final.bnn")


def lcm_url():
    """A multicast port of its own per fleet (not tools/fleet's 7667): two fleets never mix."""
    return f"udpm://239.255.76.67:{random.randrange(7700, 7900)}?ttl=0"


def identical_checkpoints(board_dir, host_dir):
    """How many of the board's checkpoints (round_*.bnn, final.bnn) are the host robot's byte
    for byte, and how many it wrote."""
    names = sorted(n for n in os.listdir(board_dir) if n.endswith(".bnn"))
    same = 0
    for n in names:
        h = os.path.join(host_dir, n)
        if os.path.isfile(h):
            with open(os.path.join(board_dir, n), "rb") as fb, open(h, "rb") as fh:
                same += fb.read() == fh.read()
    return same, len(names)


def val_loss(a, model, where):
    """robot 0's final model's validation loss (BCE, mean weights) on the shared validation set."""
    out = os.path.join(a.out, where)
    r = subprocess.run([a.host_sim, "maps", "--plan", a.plan, "--out", out, "--valset",
                        os.path.join(a.out, "val.samples"), "--mc", "2", model],
                       stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=600)
    if r.returncode != 0:
        fail(f"host_sim maps of {model} failed:\n{r.stdout[-800:]}")
    for line in open(os.path.join(out, "consensus.csv")):
        f = line.strip().split(",")
        if f[0] == "0":
            return float(f[2])
    fail(f"{out}/consensus.csv has no row for the model")


def main():
    a = parse_args()
    random.seed(os.getpid() ^ int(time.time()))
    check_machine(False, "239.255.76.67", 7700)
    os.makedirs(a.out, exist_ok=True)
    took = check_world_stops(a)
    say(f"world stops: the board ended {took:.0f} s after its world stopped answering, saying the link is down")
    sizes = board_sizes(a)
    say(f"board {a.board}: pool of {sizes[0]} samples, chunks of {sizes[1]} bytes; {a.robots} robots, "
        f"{a.rounds} rounds offline + {a.post_rounds} posterior rounds, seed {a.seed}; results in {a.out}")
    t0 = time.time()
    board_model, results = run_hil_fleet(a, sizes)
    hil_s = time.time() - t0
    if results.get("completed") != "1" or not os.path.isfile(board_model):
        fail("the board did not finish its rounds (see board.txt)")
    say(f"HIL fleet finished in {hil_s:.0f} s: the board's RT core missed {results.get('rt_deadline_misses')} "
        f"deadlines in {results.get('rt_ticks')} ticks; its release to wheel command at most "
        f"{results.get('release_to_command_max_us')} us (sensors to command {results.get('sense_to_command_max_us')} us)")
    if a.no_reference:
        return 0
    t0 = time.time()
    host_model = run_reference(a, sizes)
    ref_s = time.time() - t0
    r = subprocess.run([a.host_sim, "valset", "--plan", a.plan, "--out", os.path.join(a.out, "val.samples"),
                        "--poses", "200", "--seed", str(a.seed)], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                       text=True, timeout=600)
    if r.returncode != 0:
        fail(f"host_sim valset failed:\n{r.stdout[-800:]}")
    vb, vh = val_loss(a, board_model, "val-board"), val_loss(a, host_model, "val-host")
    rel = abs(vb - vh) / abs(vh)
    ok = rel <= a.rtol
    same, ckpts = identical_checkpoints(os.path.dirname(board_model), os.path.dirname(host_model))
    keys = ["rt_ticks", "rt_deadline_misses", "rt_late_ticks", "release_to_command_mean_us",
            "release_to_command_max_us", "sense_to_command_mean_us", "sense_to_command_max_us",
            "link_round_trip_mean_us", "link_errors", "ring_drops", "states_missed", "peer_timeouts",
            "chunks_resent", "stack_RT_bytes", "stack_GP_bytes", "stack_AI_bytes", "board_time_s"]
    with open(os.path.join(a.out, "summary.md"), "w") as f:
        f.write(f"# HIL fleet on {a.board}\n\n{a.robots} robots, {a.rounds} rounds offline + {a.post_rounds} "
                f"posterior rounds, seed {a.seed}; robot 0 on the board (QEMU), the others host processes.\n\n"
                f"| robot 0's final validation loss | value |\n|---|---:|\n| on the board | {vb:.6f} |\n"
                f"| as a host process | {vh:.6f} |\n| relative difference | {rel:.2e} (tolerance {a.rtol:g}) |\n"
                f"| checkpoints byte for byte the host's | {same} of {ckpts} |\n\n"
                f"Wall time: HIL fleet {hil_s:.0f} s, reference {ref_s:.0f} s.\n\n| the board's figure | value |\n"
                f"|---|---|\n" + "".join(f"| {k} | {results.get(k, '-')} |\n" for k in keys))
    say(f"robot 0's final validation loss: {vb:.6f} on the board, {vh:.6f} as a host process: relative "
        f"difference {rel:.1e} ({'within' if ok else 'BEYOND'} {a.rtol:g}); {same} of its {ckpts} checkpoints byte "
        f"for byte the host's; {os.path.join(a.out, 'summary.md')}")
    return 0 if ok else 1


if __name__ == "__main__":
    code = 1
    try:
        code = main()
    except KeyboardInterrupt:
        print("hil-fleet: interrupted", file=sys.stderr)
        code = 130
    except SystemExit as e:
        code = e.code if isinstance(e.code, int) else 1
    finally:
        stop_all([], PROCS)
    sys.exit(code)
