#!/usr/bin/python3
"""What faults cost the multi-process fleet (`make bench`, docs/faults.md): real host_sim processes
over LCM udpm, in a network namespace of their own whose kernel drops multicast datagrams at random
(iptables statistic match: this kernel has no netem).

    tools/bench/bench_faults.py [--bin build/release-host-small/bin/host_sim] [--robots 3,7]
                                [--drops 0,0.05,0.2,0.4] [--rounds 300] [--csv FILE]

For every fleet size and drop rate: the fleet's wall time (start of round 0 to the end of the last
round, from the robots' traffic.csv), the state bytes sent per round and robot, the chunks asked for
again, and whether the final models equal the lossless run's bit for bit (they must: loss delays,
it never changes what is trained on). The cost of a crash and restart is measured by
tests/faults/test_crash_procs.c and docs/faults.md, not here.

Prints `BENCH <name> <value> <unit>` lines:
  fleet_faults_wall_s_<N>proc_drop<P>          wall time of the run
  fleet_faults_slowdown_<N>proc_drop<P>        against the lossless run of the same size
  fleet_faults_bytes_per_round_<N>proc_drop<P> state bytes sent per round and robot
  fleet_faults_identical_<N>proc_drop<P>       1 when every final model equals the lossless run's
Needs root (network namespaces, iptables); without it says so and exits 0 having measured nothing.
"""
import argparse
import csv
import os
import shutil
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def bench(name, value, unit):
    print(f"BENCH {name} {value:.6g} {unit}", flush=True)


def sh(*cmd, check=True):
    r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    if check and r.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)}: {r.stdout.strip()}")
    return r


class Namespace:
    """A network namespace with loopback multicast, optionally dropping a share of it."""

    def __init__(self, drop):
        self.name = f"fsbench{os.getpid()}"
        self.drop = drop

    def __enter__(self):
        sh("ip", "netns", "add", self.name)
        try:
            sh("ip", "netns", "exec", self.name, "ip", "link", "set", "lo", "up")
            sh("ip", "netns", "exec", self.name, "ip", "route", "add", "224.0.0.0/4", "dev", "lo")
            if self.drop > 0:
                sh("ip", "netns", "exec", self.name, "iptables", "-A", "OUTPUT", "-d", "224.0.0.0/4", "-p", "udp",
                   "-m", "statistic", "--mode", "random", "--probability", str(self.drop), "-j", "DROP")
        except Exception:
            self.__exit__()
            raise
        return self

    def __exit__(self, *a):
        sh("ip", "netns", "del", self.name, check=False)

    def prefix(self):
        return ["ip", "netns", "exec", self.name]


def fleet_cmd(a, n, results, name, extra=()):
    return [os.path.join(ROOT, "tools/fleet"), "--bin", a.bin, "--robots", str(n), "--rounds", str(a.rounds),
            "--results", results, "--name", name, "--no-report", "--force", "--val-every", str(a.rounds),
            "--val-poses", "20", *extra]


def traffic(folder, n):
    rows = []
    for i in range(n):
        with open(os.path.join(folder, f"robot_{i}", "traffic.csv")) as f:
            rows.append(list(csv.DictReader(f)))
    return rows


def run_fleet(a, n, drop, results):
    name = f"n{n}_drop{drop}"
    with Namespace(drop) as ns:
        r = subprocess.run(ns.prefix() + fleet_cmd(a, n, results, name), stdout=subprocess.PIPE,
                           stderr=subprocess.STDOUT, text=True, timeout=a.timeout)
    if r.returncode != 0:
        raise RuntimeError(f"fleet of {n} at drop {drop} failed (exit {r.returncode}):\n{r.stdout[-2000:]}")
    folder = os.path.join(results, name)
    rows = traffic(folder, n)
    rounds_wall = max(sum(float(x["wall_ms"]) for x in robot) for robot in rows) / 1000.0
    sent = sum(int(x["bytes_sent"]) for robot in rows for x in robot) / (n * a.rounds)
    asked = sum(int(x["chunks_requested"]) for robot in rows for x in robot)
    return {"folder": folder, "wall": rounds_wall, "bytes": sent, "asked": asked}


def same_models(f1, f2, n):
    for i in range(n):
        with open(os.path.join(f1, f"robot_{i}", "final.bnn"), "rb") as x, \
                open(os.path.join(f2, f"robot_{i}", "final.bnn"), "rb") as y:
            if x.read() != y.read():
                return False
    return True


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--bin", default=os.path.join(ROOT, "build/release-host-small/bin/host_sim"))
    ap.add_argument("--robots", default="3,7")
    ap.add_argument("--drops", default="0,0.05,0.2,0.4")
    ap.add_argument("--rounds", type=int, default=300)
    ap.add_argument("--timeout", type=float, default=900, help="seconds one fleet may take before it counts as hung")
    ap.add_argument("--csv", help="also write the table here")
    a = ap.parse_args()
    if os.geteuid() != 0 or not shutil.which("iptables") or not shutil.which("ip"):
        print("bench_faults: skipped: needs root, ip and iptables (network namespaces, kernel drops)")
        return 0
    if not os.access(a.bin, os.X_OK):
        sys.exit(f"bench_faults: {a.bin}: not an executable (build with make first)")
    results = tempfile.mkdtemp(prefix="fleetsim-faults-")
    table = []
    try:
        for n in [int(x) for x in a.robots.split(",")]:
            ref = None
            for drop in [float(x) for x in a.drops.split(",")]:
                print(f"bench_faults: {n} robots, {a.rounds} rounds, {100 * drop:g} % of multicast dropped ...",
                      flush=True)
                r = run_fleet(a, n, drop, results)
                ref = ref or r
                ident = same_models(ref["folder"], r["folder"], n)
                tag = f"{n}proc_drop{int(round(100 * drop))}"
                bench(f"fleet_faults_wall_s_{tag}", r["wall"], "s")
                bench(f"fleet_faults_slowdown_{tag}", r["wall"] / ref["wall"], "x")
                bench(f"fleet_faults_bytes_per_round_{tag}", r["bytes"], "B")
                bench(f"fleet_faults_identical_{tag}", 1 if ident else 0, "bool")
                table.append([n, drop, round(r["wall"], 2), round(r["wall"] / ref["wall"], 2), int(r["bytes"]),
                              r["asked"], int(ident)])
    finally:
        shutil.rmtree(results, ignore_errors=True)
    if a.csv:
        with open(a.csv, "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(["robots", "drop", "wall_s", "slowdown", "bytes_per_round_per_robot", "chunks_asked_again",
                        "models_identical"])
            w.writerows(table)
    return 0


if __name__ == "__main__":
    sys.exit(main())
