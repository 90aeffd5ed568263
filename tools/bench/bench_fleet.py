#!/usr/bin/python3
"""Benchmarks of the multi-process fleet (`make bench`): real host_sim processes over LCM udpm.

    tools/bench/bench_fleet.py --bin build/release-host-small/bin/host_sim --preset small [--scaling]

Prints `BENCH <name> <value> <unit>` lines:
  fleet_round_ms_<preset>_<N>proc       median wall time of a DiNNO round, N processes, a keyed
                                        fleet as tools/fleet runs it (7 always; 14 and 28 with
                                        --scaling: the 7 tours reused)
  fleet_round_ms_<preset>_7proc_unkeyed the same 7 processes without the key (--no-key), run right
                                        after: what the datagram MAC costs a round
  fleet_round_ms_zmq_<preset>_7proc     the same 7 processes over ZeroMQ/TCP (--transport zmq) instead
                                        of LCM multicast, keyed
  fleet_round_compute_ms_<preset>_7     the same 7 models trained in ONE process on 2 threads
                                        (`host_sim fleet --inproc --threads 2`): the round's training compute
  fleet_round_overhead_ms_<preset>_7proc  the difference: what the processes, the network and the
                                        protocol add to a round (its share of the round, in %, and
                                        over the compute, in %: the figure the 10 % goal is about)
  image_bytes_<preset>                  static memory of one robot's image (its profile.csv: the
                                        three cores' state, their links and the fleet exchange)
  bytes_per_round_per_agent_<preset>_<fp32|int8>  state bytes each robot sends per round
Offline mode, strategy kl, disk graph 6 m, seed 1; validation only at the end. A round's wall time
comes from each robot's traffic.csv (start of round k to start of k+1), rounds 2 .. R-2 (the first
waits for the slowest tour, the last lingers), median over robots and rounds.
"""
import argparse
import csv
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
PLAN = os.path.join(ROOT, "host_sim/plans/apartment.svg")
PATHS = os.path.join(ROOT, "host_sim/plans/apartment")


def bench(name, value, unit):
    print(f"BENCH {name} {value:.6g} {unit}", flush=True)


def run(cmd, **kw):
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, **kw)
    if r.returncode != 0:
        sys.exit(f"bench_fleet: {' '.join(cmd)} failed:\n{r.stdout[-3000:]}")
    return r.stdout


def fleet(hs, n, rounds, paths, out, encoding="fp32", keyed=True, transport="lcm"):
    """n processes through the launcher; returns (median round ms, mean bytes sent per round)."""
    name = f"n{n}-{encoding}-{transport}" + ("" if keyed else "-unkeyed")
    run([os.path.join(ROOT, "tools/fleet"), "--bin", hs, "--robots", str(n), "--rounds", str(rounds),
         "--paths", paths, "--results", out, "--name", name, "--encoding", encoding, "--transport", transport,
         "--val-every", str(rounds), "--val-poses", "1", "--no-report"] + ([] if keyed else ["--no-key"]))
    walls, sent = [], []
    for i in range(n):
        with open(os.path.join(out, name, f"robot_{i}", "traffic.csv")) as f:
            rows = list(csv.DictReader(f))
        walls += [float(r["wall_ms"]) for r in rows[2:-2]]
        sent += [float(r["bytes_sent"]) for r in rows]
    return statistics.median(walls), statistics.mean(sent)


IMAGE_PARTS = ("rt_state", "rt_links", "ai_state", "ai_links", "gp_state", "gp_links", "gp_fleet")


def image_bytes(run_dir):
    """The image's static bytes from a robot's profile.csv (`mem,<part>,<bytes>` rows)."""
    with open(os.path.join(run_dir, "robot_0", "profile.csv")) as f:
        mem = {r[1]: int(r[2]) for r in csv.reader(f) if len(r) == 3 and r[0] == "mem"}
    missing = [k for k in IMAGE_PARTS if k not in mem]
    if missing:
        sys.exit(f"bench_fleet: {run_dir}/robot_0/profile.csv lacks {', '.join(missing)}")
    return sum(mem[k] for k in IMAGE_PARTS)


def inproc_round_ms(hs, rounds, out):
    """Wall time per round of the same fleet in one process (2 threads), from two run lengths."""
    samples = os.path.join(out, "samples")
    os.makedirs(samples, exist_ok=True)
    for i in range(7):
        run([hs, "scan", "--plan", PLAN, "--path", os.path.join(PATHS, f"robot_{i}.csv"), "--robot", str(i),
             "--seed", "1", "--out", os.path.join(samples, f"robot_{i}.samples"), "-q"])
    run([hs, "valset", "--plan", PLAN, "--poses", "1", "--seed", "1", "--out", os.path.join(out, "val.samples")])
    times = []
    for r in (max(2, rounds // 10), rounds):
        t0 = time.time()
        run([hs, "fleet", "--inproc", "--plan", PLAN, "--paths", PATHS, "--robots", "7", "--rounds", str(r),
             "--strategy", "kl", "--graph", "disk", "--radius", "6", "--seed", "1", "--threads", "2",
             "--metrics-every", str(r), "--samples", samples, "--valset", os.path.join(out, "val.samples"),
             "--out", os.path.join(out, f"inproc{r}"), "--mc", "1", "--map-res", "0.5"])
        times.append((r, time.time() - t0))
    (r1, t1), (r2, t2) = times
    return (t2 - t1) / (r2 - r1) * 1e3


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--bin", required=True, help="host_sim of the preset")
    p.add_argument("--preset", required=True)
    p.add_argument("--rounds", type=int, default=0, help="rounds per run (default: 200 small, 40 paper)")
    p.add_argument("--scaling", action="store_true", help="also 14 and 28 processes")
    a = p.parse_args()
    rounds = a.rounds or (200 if a.preset == "small" else 40)
    tmp = tempfile.mkdtemp(prefix="bench_fleet_")
    try:
        ms7, bytes32 = fleet(a.bin, 7, rounds, PATHS, tmp)
        bench(f"fleet_round_ms_{a.preset}_7proc", ms7, "ms")
        ms7u, _ = fleet(a.bin, 7, rounds, PATHS, tmp, keyed=False)
        bench(f"fleet_round_ms_{a.preset}_7proc_unkeyed", ms7u, "ms")
        bench(f"fleet_round_keyed_cost_{a.preset}_7proc", 100.0 * (ms7 - ms7u) / ms7u, "%")
        ms7z, _ = fleet(a.bin, 7, rounds, PATHS, tmp, transport="zmq")
        bench(f"fleet_round_ms_zmq_{a.preset}_7proc", ms7z, "ms")
        comp = inproc_round_ms(a.bin, rounds, tmp)
        bench(f"fleet_round_compute_ms_{a.preset}_7", comp, "ms")
        bench(f"fleet_round_overhead_ms_{a.preset}_7proc", ms7 - comp, "ms")
        bench(f"fleet_round_overhead_share_{a.preset}_7proc", 100.0 * (ms7 - comp) / ms7, "%")
        bench(f"fleet_round_overhead_over_compute_{a.preset}_7proc", 100.0 * (ms7 - comp) / comp, "%")
        bench(f"image_bytes_{a.preset}", image_bytes(os.path.join(tmp, "n7-fp32-lcm")), "B")
        bench(f"bytes_per_round_per_agent_{a.preset}_fp32", bytes32, "B")
        _, bytes8 = fleet(a.bin, 7, max(10, rounds // 4), PATHS, tmp, "int8")
        bench(f"bytes_per_round_per_agent_{a.preset}_int8", bytes8, "B")
        if a.scaling:
            for n in (14, 28):
                # The default plan has 8 rooms: robots i and i + 7 share a tour (the cost is the point).
                tours = os.path.join(tmp, f"tours{n}")
                os.makedirs(tours)
                for i in range(n):
                    shutil.copy(os.path.join(PATHS, f"robot_{i % 7}.csv"), os.path.join(tours, f"robot_{i}.csv"))
                ms, _ = fleet(a.bin, n, max(20, rounds // (n // 7)), tours, tmp)
                bench(f"fleet_round_ms_{a.preset}_{n}proc", ms, "ms")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
