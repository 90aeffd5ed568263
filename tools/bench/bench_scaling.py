#!/usr/bin/python3
"""How the cost of a fleet grows with its size: N host_sim processes on this machine, over LCM
multicast (lcm; lcm-groups: a multicast group per sender and per robot, --lcm-groups on) and over
ZeroMQ/TCP (zmq: the full mesh; zmq-proxy: every robot through one host_sim zmq-proxy, whose own
memory is not in the fleet's RSS) and over shared memory (shm: --transport shm, its segment's
pages counted where the others' socket buffers are), offline, keyed, `small` preset
(docs/scaling.md).

    tools/bench/bench_scaling.py [--bin build/release-host-small/bin/host_sim] [--robots 7,16,32,64]
                                 [--transports lcm,lcm-groups,zmq,zmq-proxy,shm] [--rounds 100] [--rounds-for 128:20,...]
                                 [--csv docs/scaling.csv] [--plot docs/scaling.png]
                                 [--mem-margin-gb 2] [--progress-s 60]

Robot i drives tour robot_<i mod 7> of the default plan (the plan has 8 rooms; the cost is the
point, not the map: from 8 robots on several share a spot, and from 34 on each keeps the 32
nearest, ties by id). Per fleet: the median wall time of a round (traffic.csv, rounds 2 .. R-2,
all robots), bytes sent and received per round (the state bytes a robot keeps, and every byte
its network delivered), CPU seconds and peak RSS per process (summary.txt), and the static
memory of one image (profile.csv). Prints a `BENCH fleet_round_ms_<transport>_<preset>_<N>proc`
line per fleet and a table; a run that fails stops the sweep (exit 1). Fleets already measured
in --results are read again, not rerun (a run without run.json, with a "failed" entry or with
a robot's summary.txt missing is run again), and rows of --csv for fleets not in this sweep are
kept, so a table grows one size at a time.

Memory: before a fleet starts, its need is estimated as N x the peak RSS per process (the
fleet's sampled peak sum over its N when known, else the largest process's) of the
largest smaller fleet measured (this sweep, --csv or --results; the same transport first),
extrapolated linearly in N when two smaller fleets are known (the receive queue grows with the
fleet), else N x 120 MB; plus the kernel's socket buffers (not in any process's RSS) of that
fleet scaled by (N/N')^2, at most the kernel's udp_mem/tcp_mem limit. The sweep stops (exit 1)
before starting a fleet whose need exceeds MemAvailable minus --mem-margin-gb. RSS counts the
shared libraries' pages in every process (libLLVM through libOSMesa: ~42 MB, shared), so the
estimate is on the safe side. While a fleet runs, the launcher's progress lines pass through
and every --progress-s seconds without one a line says the elapsed time, the fleet's summed RSS
and its socket buffers. The CSV records the peak RSS per process (max and median, summary.txt),
the bytes the network delivered per robot and round (summary.txt "network:"; rx_unwanted and
the bytes that arrived in all, unwanted senders and own echoes included, when
that line has the field), the peaks the bench sampled (summed RSS, socket buffers), and what the
fleet lost (run.json: states given up, peer timeouts, full-queue drops; a line warns when any is
not zero: then the round times are those of a lossy fleet).
"""
import argparse
import csv
import json
import os
import re
import shutil
import statistics
import select
import subprocess
import sys
import threading
import time

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
PATHS = os.path.join(ROOT, "host_sim/plans/apartment")
FIELDS = ["transport", "robots", "rounds", "round_ms", "sent_per_robot_B", "received_per_robot_B",
          "received_total_MB", "net_received_per_robot_B", "cpu_s_per_process", "cpu_ms_per_round_per_process",
          "rss_MB_max", "static_MB_per_image", "wall_s"]
# Added later: old rows without them are kept (empty cells).
NEW_FIELDS = ["rss_MB_median", "net_rx_unwanted_per_robot", "fleet_rss_MB_peak", "sock_MB_peak",
              "states_given_up", "peer_timeouts", "queue_drops", "net_arrived_per_robot_B", "mem_used_MB_peak"]
ALL_FIELDS = FIELDS + NEW_FIELDS
DEFAULT_RSS_MB = 120.0  # per process, when no smaller fleet was measured
# What tools/fleet is given for each transport: lcm-groups is LCM with per-sender groups and
# inboxes (--lcm-groups: each robot joins its neighbours' groups only).
TRANSPORT_ARGS = {"lcm": ["--transport", "lcm", "--lcm-groups", "off"],
                  "lcm-groups": ["--transport", "lcm", "--lcm-groups", "on"],
                  "zmq": ["--transport", "zmq", "--zmq-proxy", "off"],
                  "zmq-proxy": ["--transport", "zmq", "--zmq-proxy", "on"],
                  "shm": ["--transport", "shm"]}


def meminfo_mb(key):
    with open("/proc/meminfo") as f:
        for line in f:
            if line.startswith(key + ":"):
                return int(line.split()[1]) / 1024.0
    return 0.0


def sock_limit_mb(transport):
    """The kernel's hard limit on the memory of all UDP (LCM) or TCP (ZeroMQ) socket buffers, or
    /dev/shm's size (shm)."""
    if transport == "shm":
        try:
            st = os.statvfs("/dev/shm")
            return st.f_blocks * st.f_frsize / 1e6
        except OSError:
            return float("inf")
    path = "/proc/sys/net/ipv4/" + ("udp_mem" if transport.startswith("lcm") else "tcp_mem")
    try:
        with open(path) as f:
            return int(f.read().split()[2]) * os.sysconf("SC_PAGE_SIZE") / 1e6
    except (OSError, ValueError, IndexError):
        return float("inf")


def fleet_pids(run_dir):
    """The `host_sim run` processes writing into run_dir."""
    mark = (os.path.abspath(run_dir) + "/robot_").encode()
    pids = []
    for p in os.listdir("/proc"):
        if not p.isdigit():
            continue
        try:
            with open(f"/proc/{p}/cmdline", "rb") as f:
                cl = f.read().split(b"\0")
        except OSError:
            continue
        if len(cl) > 2 and cl[1] == b"run" and cl[0].endswith(b"host_sim") and any(mark in x for x in cl):
            pids.append(p)
    return pids


class Monitor(threading.Thread):
    """Samples a running fleet every `every` s: summed VmRSS, the bytes queued in its sockets
    (the kernel's buffers, charged to no process's RSS) or held in its shared-memory segment
    (--transport shm) and how far the machine's MemAvailable
    fell since the start; keeps the peaks. The fall is what the fleet costs the machine: summed
    RSS counts the pages the processes share (libraries, code) once per process."""

    def __init__(self, run_dir, every=2.0):
        super().__init__(daemon=True)
        self.run_dir, self.every = run_dir, every
        self.stop = threading.Event()
        self.procs = self.rss_mb = self.sock_mb = 0
        self.rss_peak_mb = self.sock_peak_mb = self.used_peak_mb = 0.0
        self.avail0_mb = meminfo_mb("MemAvailable")

    def sample(self):
        queued = {}
        for fn in ("/proc/net/udp", "/proc/net/udp6", "/proc/net/tcp", "/proc/net/tcp6"):
            try:
                with open(fn) as f:
                    for line in f.readlines()[1:]:
                        x = line.split()
                        tx, rx = x[4].split(":")
                        queued[x[9]] = int(tx, 16) + int(rx, 16)
            except (OSError, IndexError, ValueError):
                pass
        rss = sock = 0
        pids = fleet_pids(self.run_dir)
        for p in pids:
            try:
                with open(f"/proc/{p}/status") as f:
                    m = re.search(r"^VmRSS:\s+(\d+) kB", f.read(), re.M)
                rss += int(m.group(1)) * 1024 if m else 0
                for fd in os.listdir(f"/proc/{p}/fd"):
                    t = os.readlink(f"/proc/{p}/fd/{fd}")
                    if t.startswith("socket:["):
                        sock += queued.get(t[8:-1], 0)
            except OSError:
                pass
        try:  # --transport shm: its segment is the buffers (tmpfs pages, in no process's RSS)
            for fn in os.listdir("/dev/shm"):
                if fn.startswith("fleetsim."):
                    sock += os.stat(os.path.join("/dev/shm", fn)).st_blocks * 512
        except OSError:
            pass
        self.procs, self.rss_mb, self.sock_mb = len(pids), rss / 1e6, sock / 1e6
        self.rss_peak_mb = max(self.rss_peak_mb, self.rss_mb)
        self.sock_peak_mb = max(self.sock_peak_mb, self.sock_mb)
        self.used_peak_mb = max(self.used_peak_mb, self.avail0_mb - meminfo_mb("MemAvailable"))

    def run(self):
        while not self.stop.wait(self.every):
            self.sample()


def measured(run_dir, n):
    """A finished fleet: run.json without a failure, and every robot's summary."""
    try:
        with open(os.path.join(run_dir, "run.json")) as f:
            info = json.load(f)
    except (OSError, ValueError):
        return False
    return "failed" not in info and not info.get("deaths") and \
        all(os.path.exists(os.path.join(run_dir, f"robot_{i}", "summary.txt")) for i in range(n))


def _positive(x):
    try:
        v = float(x)
    except (TypeError, ValueError):
        return None
    return v if v > 0 else None


def per_process(n, used, fleet_peak, largest, sock):
    """(MB per process, socket buffers MB to add or None) of a fleet of n, by known_fleets' order:
    the machine's fall (used, which counts the sockets), the summed RSS (fleet_peak), the
    largest process."""
    used, fleet_peak = _positive(used), _positive(fleet_peak)
    if used is not None:
        return used / n, None
    if fleet_peak is not None:
        return fleet_peak / n, sock
    return largest, sock


def known_fleets(a):
    """(transport, N) -> (peak memory per process MB, socket buffers peak MB or None) of the
    fleets measured so far: --csv's rows and --results' finished runs. Per process: how far the
    machine's MemAvailable fell at the fleet's peak, over N, when the bench sampled it (shared
    pages once, socket buffers included: at 64 and 128 robots the summed RSS was 1.3x it); else
    the fleet's summed RSS at its sampled peak over N (the processes do not all peak at once: at
    128 robots N x the largest peak was 1.4x the sampled sum); else the largest."""
    known = {}
    if a.csv and os.path.exists(a.csv):
        with open(a.csv) as f:
            for r in csv.DictReader(f):
                try:
                    sock = float(r["sock_MB_peak"]) if r.get("sock_MB_peak") else None
                    n = int(r["robots"])
                    known[(r["transport"], n)] = per_process(n, r.get("mem_used_MB_peak"), r.get("fleet_rss_MB_peak"),
                                                             float(r["rss_MB_max"]), sock)
                except (KeyError, ValueError):
                    pass
    if os.path.isdir(a.results):
        for d in os.listdir(a.results):
            m = re.fullmatch(r"(lcm-groups|lcm|zmq-proxy|zmq|shm)-(\d+)-r\d+", d)
            if not m or not measured(os.path.join(a.results, d), int(m.group(2))):
                continue
            rss = []
            for i in range(int(m.group(2))):
                with open(os.path.join(a.results, d, f"robot_{i}", "summary.txt")) as f:
                    mm = re.search(r"peak RSS (\S+) MB", f.read())
                if mm:
                    rss.append(float(mm.group(1)))
            sock = fleet_peak = used = None
            try:
                with open(os.path.join(a.results, d, "bench_mem.json")) as f:
                    mem = json.load(f)
                sock, fleet_peak, used = mem.get("sock_MB_peak"), mem.get("fleet_rss_MB_peak"), \
                    mem.get("mem_used_MB_peak")
            except (OSError, ValueError, AttributeError):
                pass
            key = (m.group(1), int(m.group(2)))
            if sock is None:
                sock = known.get(key, (0, None))[1]
            per, sock = per_process(key[1], used, fleet_peak, max(rss) if rss else None, sock)
            if per is not None and (key not in known or per > known[key][0]):
                known[key] = (per, sock)
    return known


def memory_need(a, transport, n):
    """(MB the fleet is expected to need, how it was estimated)."""
    known = known_fleets(a)
    smaller = sorted(k for k in known if k[1] < n and k[0] == transport) or \
        sorted((k for k in known if k[1] < n), key=lambda k: (k[1], known[k][0]))
    if not smaller:
        return n * DEFAULT_RSS_MB, f"{n} x {DEFAULT_RSS_MB:.0f} MB (no smaller fleet measured)"
    k1 = smaller[-1]
    per = known[k1][0]
    how = f"{n} x {per:.1f} MB (per process at the peak of {k1[0]} {k1[1]} robots)"
    two = [k for k in smaller if k[0] == k1[0] and k[1] < k1[1]]
    if two:
        k0 = two[-1]
        slope = (known[k1][0] - known[k0][0]) / (k1[1] - k0[1])
        if slope > 0:
            per = known[k1][0] + slope * (n - k1[1])
            how = (f"{n} x {per:.1f} MB (per process at the peak {known[k1][0]:.1f} MB at {k1[1]} robots, "
                   f"+{slope:.2f} MB per robot as from {k0[1]} robots)")
    need = n * per
    if known[k1][1]:
        sock = min(known[k1][1] * (n / k1[1]) ** 2, sock_limit_mb(transport))
        need += sock
        how += f" + {sock:.0f} MB of socket buffers ({known[k1][1]:.0f} MB at {k1[1]} robots x (N/N')^2, kernel limit)"
    return need, how


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
    mem = {}
    if not measured(run_dir, n):
        need, how = memory_need(a, transport, n)
        avail = meminfo_mb("MemAvailable")
        margin = a.mem_margin_gb * 1024.0
        print(f"bench_scaling: {transport}, {n} robots: memory need about {need / 1024:.1f} GB = {how}; "
              f"MemAvailable {avail / 1024:.1f} GB", flush=True)
        if need > avail - margin:
            sys.exit(f"bench_scaling: refusing to start {n} robots over {transport}: they would need about "
                     f"{need / 1024:.1f} GB ({how}), more than MemAvailable {avail / 1024:.1f} GB minus the "
                     f"{a.mem_margin_gb:g} GB margin (--mem-margin-gb). Free memory, run a smaller fleet first "
                     f"(its measured RSS replaces the estimate), or lower the per-process peak RSS.")
        cmd = [os.path.join(ROOT, "tools/fleet"), "--bin", a.bin, "--robots", str(n), "--rounds", str(rounds),
               "--paths", tours(a.results, n), "--results", a.results, "--name", name] + TRANSPORT_ARGS[transport] + [
               "--val-every", str(rounds), "--val-poses", "1", "--peer-timeout", "60", "--no-report"]
        print(f"bench_scaling: {transport}, {n} robots, {rounds} rounds ...", flush=True)
        mem = run_fleet(a, cmd, run_dir, f"{transport} {n} robots")
        with open(os.path.join(run_dir, "bench_mem.json"), "w") as f:
            json.dump(mem, f)
    else:
        try:
            with open(os.path.join(run_dir, "bench_mem.json")) as f:
                mem = json.load(f)
        except (OSError, ValueError):
            pass  # measured before the bench sampled memory
    wall = time.time() - t0
    lost = {}
    try:  # the launcher's own wall time: also right for a fleet measured before and read again
        with open(os.path.join(run_dir, "run.json")) as f:
            info = json.load(f)
        wall = float(info["wall_s"])
        lost = {k: info[k] for k in ("states_given_up", "peer_timeouts", "queue_drops") if isinstance(info.get(k), int)}
    except (OSError, ValueError, KeyError, TypeError):
        pass
    if any(lost.values()):
        print(f"bench_scaling: {transport}, {n} robots: the fleet lost data ({lost}): its round times are those "
              f"of a lossy fleet", flush=True)
    walls, sent, recv, net, cpu, rss, unwanted, arrived = [], [], [], [], [], [], [], []
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
        line = text[mn.start():text.find("\n", mn.start())]
        mu = re.search(r"([0-9]+) datagrams of senders not asked for", line)
        if mu:
            unwanted.append(float(mu.group(1)))
        ma = re.search(r"([0-9.]+) B arrived per round in all", line)
        if ma:
            arrived.append(float(ma.group(1)))
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
           "static_MB_per_image": static / 1e6, "wall_s": wall, "rss_MB_median": statistics.median(rss),
           "net_rx_unwanted_per_robot": statistics.mean(unwanted) if len(unwanted) == n else "",
           "fleet_rss_MB_peak": mem.get("fleet_rss_MB_peak", ""), "sock_MB_peak": mem.get("sock_MB_peak", ""),
           "states_given_up": lost.get("states_given_up", ""), "peer_timeouts": lost.get("peer_timeouts", ""),
           "queue_drops": lost.get("queue_drops", ""),
           "net_arrived_per_robot_B": statistics.mean(arrived) if len(arrived) == n else "",
           "mem_used_MB_peak": mem.get("mem_used_MB_peak", "")}
    print(f"BENCH fleet_round_ms_{transport}_{preset}_{n}proc {row['round_ms']:.6g} ms", flush=True)
    return row


def run_fleet(a, cmd, run_dir, what):
    """Runs tools/fleet: its lines pass through as they come (it prints its progress every 5 % of
    the rounds when not on a terminal), and after --progress-s seconds without one a line of our
    own. Exits on failure with the end of its output. Returns the memory peaks sampled."""
    mon = Monitor(run_dir)
    mon.start()
    t0 = last = time.time()
    tail, partial, latest = "", "", ""
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    try:
        while True:
            ready, _, _ = select.select([p.stdout], [], [], 1.0)
            if ready:
                chunk = os.read(p.stdout.fileno(), 65536).decode(errors="replace")
                if not chunk:
                    break
                tail = (tail + chunk)[-4000:]
                partial += chunk
                *lines, partial = re.split(r"[\r\n]", partial)
                for line in lines:
                    if line.strip():
                        latest = line.strip()
                        print(f"  {latest}", flush=True)
                        last = time.time()
            if a.progress_s > 0 and time.time() - last >= a.progress_s:
                last = time.time()
                el = last - t0
                print(f"bench_scaling: {what}: {f'{el:.0f} s' if el < 120 else f'{el / 60:.1f} min'}; {mon.procs} processes, "
                      f"RSS {mon.rss_mb / 1024:.1f} GB in all (peak {mon.rss_peak_mb / 1024:.1f}), socket buffers or segment "
                      f"{mon.sock_mb:.0f} MB (peak {mon.sock_peak_mb:.0f}); MemAvailable "
                      f"{meminfo_mb('MemAvailable') / 1024:.1f} GB; last: {latest or '-'}", flush=True)
    except KeyboardInterrupt:
        p.terminate()  # tools/fleet stops its robots on SIGTERM/SIGINT
        p.wait()
        raise
    finally:
        rc = p.wait()
        mon.stop.set()
        mon.join()
    if rc != 0:
        sys.exit(f"bench_scaling: {' '.join(cmd)} failed (exit {rc}):\n{tail[-3000:]}")
    return {"fleet_rss_MB_peak": round(mon.rss_peak_mb, 1), "sock_MB_peak": round(mon.sock_peak_mb, 1),
            "mem_used_MB_peak": round(mon.used_peak_mb, 1)}


def plot(rows, out):
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("bench_scaling: no plot (python3-matplotlib is missing)")
        return
    fig, ax = plt.subplots(1, 2, figsize=(10, 4))
    for t, mark in (("lcm", "o-"), ("lcm-groups", "^-"), ("zmq", "s-"), ("zmq-proxy", "D-"), ("shm", "v-")):
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


def fmt(v, width, digits=1):
    return f"{v:>{width}.{digits}f}" if isinstance(v, (int, float)) else f"{'-':>{width}}"


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
    p.add_argument("--mem-margin-gb", type=float, default=2.0,
                   help="memory kept free: a fleet whose estimated need exceeds MemAvailable minus this is "
                        "not started (default 2)")
    p.add_argument("--progress-s", type=float, default=60.0,
                   help="a progress line after this many seconds without one from tools/fleet (0: none; default 60)")
    a = p.parse_args()
    # Absolute: the memory monitor finds the fleet's processes by their --out under it.
    a.results = os.path.abspath(a.results)
    try:
        sizes = [int(x) for x in a.robots.split(",")]
    except ValueError:
        p.error("--robots wants sizes like 7,16,32")
    try:
        rounds_for = {int(k): int(v) for k, v in (x.split(":") for x in a.rounds_for.split(",") if x)}
    except ValueError:
        p.error("--rounds-for wants N:R pairs like 128:20")
    transports = a.transports.split(",")
    if not all(t in TRANSPORT_ARGS for t in transports) or min([a.rounds] + list(rounds_for.values())) < 5 or \
            not all(1 < n <= 1024 for n in sizes):
        p.error("--transports lcm,lcm-groups,zmq,zmq-proxy,shm; --rounds (and --rounds-for) >= 5; --robots 2 .. 1024")
    if not os.access(a.bin, os.X_OK):
        sys.exit(f"bench_scaling: {a.bin} not found: build first (make)")
    os.makedirs(a.results, exist_ok=True)
    r = subprocess.run([a.bin, "run", "--help"], stdout=subprocess.PIPE, text=True)
    m = re.search(r"BNN preset '(\w+)'", r.stdout)
    preset = m.group(1) if m else "unknown"  # the build's preset, as host_sim says it
    rows, stop = [], None
    for t in transports:
        for n in sizes:
            try:
                rows.append(measure(a, t, n, rounds_for.get(n, a.rounds), preset))
            except SystemExit as e:  # a fleet failed or would not fit: the table still gets what was measured
                stop = e
                break
        if stop is not None:
            break
    if a.csv and os.path.exists(a.csv):  # the sizes measured before and not now stay in the table
        with open(a.csv) as f:
            done = {(r["transport"], r["robots"]) for r in rows}
            old = [r for r in csv.DictReader(f) if (r["transport"], int(r["robots"])) not in done
                   and all(r.get(k) for k in FIELDS)]
        for r in old:
            rows.append({k: (r[k] if k == "transport" else int(r[k]) if k in ("robots", "rounds") else
                             float(r[k]) if r.get(k) else "") for k in ALL_FIELDS})
        rows.sort(key=lambda r: (r["transport"], r["robots"]))
    print(f"{'transport':>10} {'N':>4} {'round ms':>9} {'net/robot MB':>12} {'arrived MB':>10} {'kept/robot MB':>13} "
          f"{'CPU ms/round':>12} "
          f"{'RSS MB':>7} {'RSS med':>7} {'static MB':>9} {'sock MB':>7}")
    for r in rows:
        arrived_mb = r["net_arrived_per_robot_B"] / 1e6 if r.get("net_arrived_per_robot_B") != "" else ""
        print(f"{r['transport']:>10} {r['robots']:>4} {r['round_ms']:>9.1f} {r['net_received_per_robot_B'] / 1e6:>12.2f} "
              f"{fmt(arrived_mb, 10)} {r['received_per_robot_B'] / 1e6:>13.2f} "
              f"{r['cpu_ms_per_round_per_process']:>12.1f} {r['rss_MB_max']:>7.1f} {fmt(r['rss_MB_median'], 7)} "
              f"{r['static_MB_per_image']:>9.1f} {fmt(r['sock_MB_peak'], 7, 0)}")
    if a.csv:
        with open(a.csv, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=ALL_FIELDS, lineterminator="\n")
            w.writeheader()
            for r in rows:
                w.writerow({k: (f"{r[k]:.6g}" if isinstance(r[k], float) else r[k]) for k in ALL_FIELDS})
        print(f"bench_scaling: table in {a.csv}")
    if a.plot:
        plot(rows, a.plot)
    if stop is not None:
        raise stop
    return 0


if __name__ == "__main__":
    sys.exit(main())
