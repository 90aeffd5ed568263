"""What a fleet run lost, summed over its robots: the neighbour states a round went on without,
the peer timeouts and the datagrams dropped by full receive queues. A run with any of these is
not a lossless run; with a state given up or a peer timed out its models are not the ones the
in-process fleet (the reference) makes. tools/fleet prints the totals in its last line,
--strict fails on any of them, and tools/fleet_report.py states them at the top of summary.md.

Read from each robot_<i>/ as `host_sim run` writes it (host_sim/app/cmd_run.c):
  summary.txt   "losses: ... N peer timeouts, ..."           the protocol's `timeouts`
                "faults survived: ... N peer states gone without, ..."   its `states_missed`
                "waiting for peers: ... network queue drops N (queue full M, ...)"
                                                             hal net stats `rx_dropped_full`
                "... receiver queue overflows on the way N ..."
                                                             `tx_overflows` (ZeroMQ's
                                                             high-water mark at the sender)
                "resumed: from ... (round c), rounds S .. E run by this start"
                "fleet: ..."                                 absent for a robot alone
  traffic.csv   per round: `states_missed`, `timeouts`
summary.txt counts the last start of the process, its start-up and posterior rounds included;
traffic.csv carries the rows of the rounds before a --resume over from the starts that died.
So a robot's figure is summary.txt's plus traffic.csv's rows of rounds < S. The queue drops of
a start that died are written nowhere: they are missing from the totals, and said so.
ZeroMQ's queues (a sender's, the proxy's) drop past their high-water marks without a word, so
what is counted there is each overflow, one lost datagram or more: the queue drops are then a
lower bound. A fleet through a ZeroMQ proxy adds the proxy's overflows, from the last line of
the run's zmq_proxy.log (host_sim zmq-proxy's final counts).
Besides: the UDP datagrams the kernel dropped for a full receive buffer while an LCM fleet ran
(UdpRcvbufErrors of /proc/net/snmp, written by tools/fleet to kernel_udp_drops.txt). Where a
robot receives inline, with no receiver thread (hal/host/hal_host_net_rx.c), that buffer is its
queue. The count is the whole machine's, any program's, so it is said (and in run.json) but not
part of the lossless verdict: another program's drop must not fail a --strict fleet.
"""
import csv
import os
import re

from fleet_common import fail

KEYS = ("states_given_up", "peer_timeouts", "queue_drops")  # also run.json's keys
WORDS = {"states_given_up": "states given up", "peer_timeouts": "peer timeouts",
         "queue_drops": "datagrams dropped by full queues"}
SUMMARY_RE = {
    "states_given_up": re.compile(r"^faults survived:.*?\b(\d+) peer states gone without\b", re.M),
    "peer_timeouts": re.compile(r"^losses:.*?\b(\d+) peer timeouts\b", re.M),
    "queue_drops": re.compile(r"^waiting for peers:.*?network queue drops \d+ \(queue full (\d+)\b", re.M),
}
TX_FULL_RE = re.compile(r"^waiting for peers:.*?; receiver queue overflows on the way (\d+)\b", re.M)  # older: absent
PROXY_RE = re.compile(r"^zmq-proxy: .*? forwarded, (\d+) subscriber queue overflows\b", re.M)
TRAFFIC_COL = {"states_given_up": "states_missed", "peer_timeouts": "timeouts"}  # queue drops: not per round
RESUMED_RE = re.compile(r"^resumed: from \S+ \(round \d+\), rounds (\d+) \.\.", re.M)
FLEET_RE = re.compile(r"^fleet: \d+ robots", re.M)


def read_summary(path):
    try:
        with open(path, encoding="utf-8", errors="replace") as f:
            return f.read()
    except OSError:
        return None


def traffic_sums(path, before=None):
    """{key: sum of its traffic.csv column} over the rows (of rounds < before, when given); None
    when the file is missing or unreadable, a key left out when its column is."""
    try:
        with open(path, newline="", encoding="utf-8", errors="replace") as f:
            rows = list(csv.DictReader(f))
    except (OSError, csv.Error):
        return None
    out = {}
    for key, col in TRAFFIC_COL.items():
        try:
            out[key] = sum(int(float(r[col])) for r in rows
                           if before is None or int(float(r["round"])) < before)
        except (KeyError, TypeError, ValueError):
            pass  # an older or damaged file: the figure is not known from it
    return out


def robot_losses(robot_dir):
    """({key: count} of one robot's folder, [what could not be counted]). A key missing from the
    dict is not known; a count may be a lower bound, then the list says why."""
    name = os.path.basename(os.path.normpath(robot_dir))
    text = read_summary(os.path.join(robot_dir, "summary.txt"))
    traffic = os.path.join(robot_dir, "traffic.csv")
    if text is None:
        # The robot did not finish: traffic.csv's rows are all there is (queue drops: nothing).
        got = traffic_sums(traffic) or {}
        return got, [f"{name}: no summary.txt" + (", counted from traffic.csv (at least)" if got else "")]
    if not FLEET_RE.search(text):
        return {k: 0 for k in KEYS}, []  # a robot alone exchanges nothing
    m = RESUMED_RE.search(text)
    start = int(m.group(1)) if m else 0
    earlier = traffic_sums(traffic, before=start) if start else {}
    got, gaps = {}, []
    for key, rx in SUMMARY_RE.items():
        m = rx.search(text)
        if m is None:
            gaps.append(f"{name}: summary.txt has no {WORDS[key]} (an older host_sim?)")
        elif key not in TRAFFIC_COL and start:
            got[key] = int(m.group(1))
            gaps.append(f"{name}: the {WORDS[key]} of the start(s) before its --resume at round {start} "
                        "are not written anywhere (at least)")
        elif key in TRAFFIC_COL and start and (earlier is None or key not in earlier):
            got[key] = int(m.group(1))
            gaps.append(f"{name}: no traffic.csv rows for the {WORDS[key]} before its --resume at round "
                        f"{start} (at least)")
        else:
            got[key] = int(m.group(1)) + (earlier.get(key, 0) if start else 0)
    m = TX_FULL_RE.search(text)
    if m is not None and "queue_drops" in got:
        got["queue_drops"] += int(m.group(1))  # its sends' overflows on the way (one copy or more each)
    return got, gaps


def proxy_drops(run_dir):
    """(the overflows of the run's ZeroMQ proxy at its subscribers' queues, or None, [gaps]); (0, [])
    for a run without a proxy."""
    path = os.path.join(run_dir, "zmq_proxy.log")
    if not os.path.exists(path):
        return 0, []
    found = PROXY_RE.findall(read_summary(path) or "")
    if not found:
        return None, ["zmq_proxy.log: no count of the proxy's overflows (it never said its counts)"]
    return int(found[-1]), []


def kernel_udp_drops(path="/proc/net/snmp"):
    """UdpRcvbufErrors of the machine so far, or None (not Linux, unreadable)."""
    try:
        with open(path, encoding="ascii", errors="replace") as f:
            rows = [line.split() for line in f if line.startswith("Udp:")]
        return int(rows[1][rows[0].index("RcvbufErrors")])
    except (OSError, IndexError, ValueError):
        return None


def note_kernel_drops(run_dir, before):
    """kernel_udp_drops.txt, "BEFORE AFTER", when both counts are known (before: kernel_udp_drops()
    at the launch, None for a fleet not over LCM)."""
    after = kernel_udp_drops()
    if before is not None and after is not None:
        with open(os.path.join(run_dir, "kernel_udp_drops.txt"), "w", encoding="ascii") as f:
            f.write(f"{before} {after}\n")


def kernel_drops(run_dir):
    """The run's kernel receive-buffer drops (kernel_udp_drops.txt: "BEFORE AFTER"), 0 when the
    launcher did not count them."""
    try:
        with open(os.path.join(run_dir, "kernel_udp_drops.txt"), encoding="ascii") as f:
            before, after = (int(v) for v in f.read().split())
    except (OSError, ValueError):
        return 0
    return max(0, after - before)


def fleet_losses(run_dir, robots):
    """{key: total over the folders robot_<i> of i in robots, None when no robot says}, [gaps]."""
    totals, gaps = {k: 0 for k in KEYS}, []
    known = {k: False for k in KEYS}
    for i in robots:
        got, g = robot_losses(os.path.join(run_dir, f"robot_{i}"))
        gaps += g
        for k in KEYS:
            if k in got:
                totals[k] += got[k]
                known[k] = True
    lost, g = proxy_drops(run_dir)
    gaps += g
    totals["queue_drops"] += lost or 0
    return {k: (totals[k] if known[k] else None) for k in KEYS}, gaps


def lossless(totals, gaps):
    """True when every total is known, complete and zero."""
    return not gaps and all(totals[k] == 0 for k in KEYS)


def totals_text(totals, gaps=()):
    """"12 states given up, 0 peer timeouts, ..." ("not known" for a total no robot wrote; "at
    least" before the figures when some robot's could not be counted whole)."""
    parts = [f"{WORDS[k]}: not known" if totals[k] is None else f"{totals[k]:,} {WORDS[k]}" for k in KEYS]
    return ("at least " if gaps else "") + ", ".join(parts)


def verdict(totals, gaps):
    """What the totals mean for the models, in a few words. Queue drops alone cost re-sends, not
    states: a round that got every neighbour's state whole computes what a lossless one does
    (tests/fleet/test_fleet_procs.c: bit for bit with lost datagrams), so only then it is not said
    that the models differ."""
    if lossless(totals, gaps):
        return "a lossless run"
    if totals["states_given_up"] or totals["peer_timeouts"]:
        return "the models are NOT those of a lossless run (nor the in-process reference's)"
    if totals["queue_drops"]:
        return ("not a lossless run: a busy CPU let receive queues overflow; no state was given up (the "
                "datagrams were asked for again), so the models should still be the lossless run's")
    return "not all of it could be counted, so the run is not known to be lossless"


def record(info, run_dir, robots):
    """The fleet's totals into info (run.json: None for a total no robot wrote; losses_uncounted:
    why a total is only a lower bound; kernel_udp_drops: the machine's during the run). (totals,
    gaps), the kernel's count in totals too, under a key of its own (not in KEYS)."""
    totals, gaps = fleet_losses(run_dir, range(robots))
    info.update(totals)
    info["losses_uncounted"] = gaps
    totals["kernel_udp_drops"] = info["kernel_udp_drops"] = kernel_drops(run_dir)
    return totals, gaps


def said(totals, gaps):
    """The totals and, unless the run was lossless, what that means for the models; the kernel's
    drops on this machine when there were any."""
    text = totals_text(totals, gaps)
    text = text if lossless(totals, gaps) else f"{text}: {verdict(totals, gaps)}"
    k = totals.get("kernel_udp_drops") or 0
    return text + (f"; the kernel dropped {k:,} UDP datagrams on this machine for full receive buffers "
                   "during the run (any program's; asked for again if they were the fleet's)" if k else "")


def strict_exit(strict, totals, gaps):
    """0, or with `strict` (tools/fleet --strict) exit 3 naming the totals when the run was not
    lossless (the caller has written everything by then)."""
    if not strict or lossless(totals, gaps):
        return 0
    why = "".join(f"\n  {g}" for g in gaps[:5]) + (f"\n  ... and {len(gaps) - 5} more" if len(gaps) > 5 else "")
    fail(f"--strict: {said(totals, gaps)}{why}", 3)


def main(argv=None):
    """`tools/fleet_losses.py RUN_DIR N [--strict]`: one line of the totals of robot_0 ..
    robot_<N-1> in RUN_DIR and what they mean, for fleets not started by tools/fleet (SLURM,
    by hand). Exit 0; with --strict 3 when the run was not lossless; 2 on bad arguments."""
    import argparse
    import sys
    p = argparse.ArgumentParser(prog="fleet_losses.py", description=main.__doc__.split("\n")[0].strip("`: "))
    p.add_argument("run_dir", help="the folder holding robot_<i>/")
    p.add_argument("robots", type=int, help="how many robots (robot_0 .. robot_<N-1>)")
    p.add_argument("--strict", action="store_true", help="exit 3 when the run lost anything")
    a = p.parse_args(argv)
    if a.robots < 1 or not os.path.isdir(a.run_dir):
        print(f"fleet_losses.py: {a.run_dir}: no such folder" if a.robots >= 1 else
              "fleet_losses.py: N must be at least 1", file=sys.stderr)
        return 2
    totals, gaps = fleet_losses(a.run_dir, range(a.robots))
    print(f"{totals_text(totals, gaps)}: {verdict(totals, gaps)}")
    for g in gaps:
        print(f"  {g}")
    return 3 if a.strict and not lossless(totals, gaps) else 0


if __name__ == "__main__":
    raise SystemExit(main())
