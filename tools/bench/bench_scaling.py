#!/usr/bin/python3
"""How the cost of a fleet grows with its size: N host_sim processes on this machine, over LCM
multicast and over ZeroMQ/TCP, offline, keyed, `small` preset (docs/scaling.md).

    tools/bench/bench_scaling.py [--bin build/release-host-small/bin/host_sim] [--robots 7,16,32,64]
                                 [--transports lcm,zmq] [--rounds 100] [--rounds-for 128:20,...]
                                 [--csv docs/scaling.csv] [--plot docs/scaling.png]

Robot i drives tour robot_<i mod 7> of the default plan (the plan has 8 rooms; the cost is the
point, not the map: from 8 robots on several share a spot, and from 34 on each keeps the 32
nearest, ties by id). Per fleet: the median wall time of a round (traffic.csv, rounds 2 .. R-2,
all robots), bytes sent and received per round (the state bytes a robot keeps, and every byte
its network delivered), CPU seconds and peak RSS per process (summary.txt), and the static
memory of one image (profile.csv). Prints a `BENCH fleet_round_ms_<transport>_<preset>_<N>proc`
line per fleet and a table; a run that fails stops the sweep (exit 1). Fleets already measured
in --results are read again, not rerun, and rows of --csv for fleets not in this sweep are
kept, so a table grows one size at a time.
"""
import argparse
import csv
import os
import re
import shutil
import statistics
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
PATHS = os.path.join(ROOT, "host_sim/plans/apartment")
FIELDS = ["transport", "robots", "rounds", "round_ms", "sent_per_robot_B", "received_per_robot_B",
          "received_total_MB", "net_received_per_robot_B", "cpu_s_per_process", "cpu_ms_per_round_per_process",
          "rss_MB_max", "static_MB_per_image", "wall_s"]


def tours(out, n):
    d = os.path.join(out, f"tours{n}")
    if not os.path.isdir(d):
        os.makedirs(d)
        for i in range(n):
            shutil.copy(os.path.join(PATHS, f"robot_{i % 7}.csv"), os.path.join(d, f"robot_{i}.csv"))
    return d


def measure(a, transport, n, rounds, preset):
    name = f"{transport}-{n}-r{rounds}"
    run_dir = os.path.join(a.results, name)
    t0 = time.time()
    if not os.path.exists(os.path.join(run_dir, "run.json")):
        cmd = [os.path.join(ROOT, "tools/fleet"), "--bin", a.bin, "--robots", str(n), "--rounds", str(rounds),
               "--paths", tours(a.results, n), "--results", a.results, "--name", name, "--transport", transport,
               "--val-every", str(rounds), "--val-poses", "1", "--peer-timeout", "60", "--no-report"]
        print(f"bench_scaling: {transport}, {n} robots, {rounds} rounds ...", flush=True)
        r = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        if r.returncode != 0:
            sys.exit(f"bench_scaling: {' '.join(cmd)} failed:\n{r.stdout[-3000:]}")
    wall = time.time() - t0
    walls, sent, recv, net, cpu, rss = [], [], [], [], [], []
    static = 0
    for i in range(n):
        rd = os.path.join(run_dir, f"robot_{i}")
        with open(os.path.join(rd, "traffic.csv")) as f:
            rows = list(csv.DictReader(f))
        walls += [float(x["wall_ms"]) for x in rows[2:-2]]
        sent.append(statistics.mean(float(x["bytes_sent"]) for x in rows))
        recv.append(statistics.mean(float(x["bytes_received"]) for x in rows))
        with open(os.path.join(rd, "summary.txt")) as f:
            text = f.read()
        m = re.search(r"^process: (\S+) s CPU .*peak RSS (\S+) MB", text, re.M)
        mn = re.search(r"^network: (\S+) B received per round", text, re.M)
        if m is None or mn is None:
            sys.exit(f"bench_scaling: {rd}/summary.txt has no 'process:' or 'network:' line (an older host_sim?)")
        net.append(float(mn.group(1)))
        cpu.append(float(m.group(1)))
        rss.append(float(m.group(2)))
        if i == 0:
            with open(os.path.join(rd, "profile.csv")) as f:
                top = ("rt_state", "rt_links", "ai_state", "ai_links", "gp_state", "gp_links", "gp_fleet")  # the rest nests
                static = sum(int(r[2]) for r in csv.reader(f) if r and r[0] == "mem" and r[1] in top)
    row = {"transport": transport, "robots": n, "rounds": rounds, "round_ms": statistics.median(walls),
           "sent_per_robot_B": statistics.mean(sent), "received_per_robot_B": statistics.mean(recv),
           "received_total_MB": sum(recv) / 1e6, "net_received_per_robot_B": statistics.mean(net),
           "cpu_s_per_process": statistics.mean(cpu),
           "cpu_ms_per_round_per_process": 1000.0 * statistics.mean(cpu) / rounds, "rss_MB_max": max(rss),
           "static_MB_per_image": static / 1e6, "wall_s": wall}
    print(f"BENCH fleet_round_ms_{transport}_{preset}_{n}proc {row['round_ms']:.6g} ms", flush=True)
    return row


def plot(rows, out):
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("bench_scaling: no plot (python3-matplotlib is missing)")
        return
    fig, ax = plt.subplots(1, 2, figsize=(10, 4))
    for t, mark in (("lcm", "o-"), ("zmq", "s-")):
        rs = [r for r in rows if r["transport"] == t]
        if not rs:
            continue
        n = [r["robots"] for r in rs]
        ax[0].loglog(n, [r["round_ms"] for r in rs], mark, label=f"{t}: round wall time")
        ax[0].loglog(n, [r["cpu_ms_per_round_per_process"] for r in rs], mark, alpha=0.5,
                     label=f"{t}: CPU per process and round")
        ax[1].loglog(n, [r["net_received_per_robot_B"] / 1e6 for r in rs], mark,
                     label=f"{t}: delivered to each robot")
        ax[1].loglog(n, [r["received_per_robot_B"] / 1e6 for r in rs], mark, alpha=0.5,
                     label=f"{t}: states each robot keeps")
    n = sorted({r["robots"] for r in rows})
    ax[1].loglog(n, [0.134404 * (k - 1) for k in n], "k:", label="every peer's state (N - 1) x 134 KB")
    ax[1].loglog(n, [0.134404 * min(k - 1, 32) for k in n], "k--", alpha=0.5, label="the 32 nearest (neighbour slots)")
    ax[0].set(xlabel="robots (processes on 2 cores)", ylabel="ms", title="time per DiNNO round")
    ax[1].set(xlabel="robots", ylabel="MB per round", title="state bytes each robot receives")
    for x in ax:
        x.grid(True, which="both", alpha=0.3)
        x.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print(f"bench_scaling: plot in {out}")


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--bin", default=os.path.join(ROOT, "build/release-host-small/bin/host_sim"))
    p.add_argument("--robots", default="7,16,32,64", help="fleet sizes, comma-separated (default 7,16,32,64)")
    p.add_argument("--transports", default="lcm,zmq")
    p.add_argument("--rounds", type=int, default=100)
    p.add_argument("--rounds-for", default="", help="fewer rounds for large fleets: N:R,... (e.g. 128:20)")
    p.add_argument("--results", default=os.path.join(ROOT, "results/scaling"))
    p.add_argument("--csv", default=None)
    p.add_argument("--plot", default=None)
    a = p.parse_args()
    try:
        sizes = [int(x) for x in a.robots.split(",")]
    except ValueError:
        p.error("--robots wants sizes like 7,16,32")
    try:
        rounds_for = {int(k): int(v) for k, v in (x.split(":") for x in a.rounds_for.split(",") if x)}
    except ValueError:
        p.error("--rounds-for wants N:R pairs like 128:20")
    transports = a.transports.split(",")
    if not all(t in ("lcm", "zmq") for t in transports) or min([a.rounds] + list(rounds_for.values())) < 5 or \
            not all(1 < n <= 1024 for n in sizes):
        p.error("--transports lcm,zmq; --rounds (and --rounds-for) >= 5; --robots 2 .. 1024")
    if not os.access(a.bin, os.X_OK):
        sys.exit(f"bench_scaling: {a.bin} not found: build first (make)")
    os.makedirs(a.results, exist_ok=True)
    r = subprocess.run([a.bin, "run", "--help"], stdout=subprocess.PIPE, text=True)
    m = re.search(r"BNN preset '(\w+)'", r.stdout)
    preset = m.group(1) if m else "unknown"  # the build's preset, as host_sim says it
    rows = [measure(a, t, n, rounds_for.get(n, a.rounds), preset) for t in transports for n in sizes]
    if a.csv and os.path.exists(a.csv):  # the sizes measured before and not now stay in the table
        with open(a.csv) as f:
            done = {(r["transport"], r["robots"]) for r in rows}
            old = [r for r in csv.DictReader(f) if (r["transport"], int(r["robots"])) not in done
                   and all(r.get(k) for k in FIELDS)]
        for r in old:
            rows.append({k: (r[k] if k == "transport" else int(r[k]) if k in ("robots", "rounds") else float(r[k]))
                         for k in FIELDS})
        rows.sort(key=lambda r: (r["transport"], r["robots"]))
    print(f"{'transport':>9} {'N':>4} {'round ms':>9} {'net/robot MB':>12} {'kept/robot MB':>13} {'CPU ms/round':>12} "
          f"{'RSS MB':>7} {'static MB':>9}")
    for r in rows:
        print(f"{r['transport']:>9} {r['robots']:>4} {r['round_ms']:>9.1f} {r['net_received_per_robot_B'] / 1e6:>12.2f} "
              f"{r['received_per_robot_B'] / 1e6:>13.2f} "
              f"{r['cpu_ms_per_round_per_process']:>12.1f} {r['rss_MB_max']:>7.1f} {r['static_MB_per_image']:>9.1f}")
    if a.csv:
        with open(a.csv, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=FIELDS, lineterminator="\n")
            w.writeheader()
            for r in rows:
                w.writerow({k: (f"{r[k]:.6g}" if isinstance(r[k], float) else r[k]) for k in FIELDS})
        print(f"bench_scaling: table in {a.csv}")
    if a.plot:
        plot(rows, a.plot)
    return 0


if __name__ == "__main__":
    sys.exit(main())
