#!/usr/bin/python3
"""tools/fleet_losses.py run as a program (what tools/slurm/fleet.sbatch prints last): one line of
the totals over robot_0 .. robot_<N-1> and what they mean; --strict exits 3 on a lossy run, bad
arguments exit 2. The sums themselves are tested in test_fleet_report.py.

    python3 tests/tools/test_fleet_losses.py      prints "N passed, M failed", exit 1 on failure
"""
import os
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.realpath(__file__)))
from minitest import check, main, test  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.realpath(__file__))))
PROG = os.path.join(ROOT, "tools", "fleet_losses.py")


def robot(run, i, states, timeouts, full, overflows=None):
    """robot_<i>/summary.txt with the three lines fleet_losses.py reads, as host_sim run writes them
    (`overflows`: its ZeroMQ sends' receiver queue overflows; None: a host_sim that wrote none)."""
    d = os.path.join(run, f"robot_{i}")
    os.makedirs(d)
    with open(os.path.join(d, "summary.txt"), "w") as f:
        f.write(f"fleet: 2 robots (this is robot {i}, fleet id 1), fp32 states, radius 6 m\n"
                f"losses: 0 chunks requested again, 0 re-sent; 0 duplicates, 0 stale, 0 invalid, 0 CRC failures; "
                f"{timeouts} peer timeouts, 0 rejoins; 0 own echoes\n"
                f"faults survived: 0 chunks lost (never received), 0 recovered by a request; {states} peer states "
                "gone without, 0 rounds cut short by a later round, 0 rounds skipped to catch up\n"
                f"waiting for peers: 1.00 s wall in all (10.00 ms per round); network queue drops {full} "
                f"(queue full {full}, buffer too small 0); malformed datagrams dropped 0; sends refused 0" +
                ("" if overflows is None else f"; receiver queue overflows on the way {overflows} (copies dropped)") +
                "\n")


def run(*args):
    return subprocess.run([sys.executable, PROG, *args], capture_output=True, text=True, timeout=60)


@test
def lossless_fleet_one_line():
    with tempfile.TemporaryDirectory() as d:
        robot(d, 0, 0, 0, 0)
        robot(d, 1, 0, 0, 0)
        r = run(d, "2", "--strict")
        check(r.returncode == 0, f"exit {r.returncode}: {r.stderr}")
        check(r.stdout.strip() == "0 states given up, 0 peer timeouts, 0 datagrams dropped by full queues: "
              "a lossless run", repr(r.stdout))


@test
def kernel_drops_said_apart_from_the_verdict():
    """The machine's kernel receive-buffer drops over the run (kernel_udp_drops.txt, tools/fleet)
    are said and recorded, but a lossless fleet stays lossless: the count is any program's."""
    sys.path.insert(0, os.path.join(ROOT, "tools"))
    import fleet_losses
    with tempfile.TemporaryDirectory() as d:
        robot(d, 0, 0, 0, 0)
        robot(d, 1, 0, 0, 0)
        info = {}
        totals, gaps = fleet_losses.record(info, d, 2)
        check(info["kernel_udp_drops"] == 0 and fleet_losses.said(totals, gaps).endswith("dropped by full queues"),
              repr(info))
        with open(os.path.join(d, "kernel_udp_drops.txt"), "w") as f:
            f.write("1863 1866\n")
        totals, gaps = fleet_losses.record(info, d, 2)
        text = fleet_losses.said(totals, gaps)
        check(info["kernel_udp_drops"] == 3 and fleet_losses.lossless(totals, gaps), repr(info))
        check("full queues; the kernel dropped 3 UDP datagrams on this machine" in text, text)
        check(fleet_losses.strict_exit(True, totals, gaps) == 0, "--strict failed on the machine's drops")
        check(fleet_losses.kernel_udp_drops() is None or fleet_losses.kernel_udp_drops() >= 0, "snmp")


@test
def lossy_fleet_summed_and_strict_exits_3():
    with tempfile.TemporaryDirectory() as d:
        robot(d, 0, 2, 3, 0)
        robot(d, 1, 1, 0, 5)
        r = run(d, "2")
        check(r.returncode == 0, f"exit {r.returncode}")
        check(r.stdout.startswith("3 states given up, 3 peer timeouts, 5 datagrams dropped by full queues: "
                                  "the models are NOT"), repr(r.stdout))
        check(run(d, "2", "--strict").returncode == 3, "--strict on a lossy run: not exit 3")


@test
def zmq_overflows_counted_as_queue_drops():
    """A sender's overflows and the proxy's (the last of zmq_proxy.log's count lines) are queue
    drops; a proxy log without its counts makes the totals a lower bound, said."""
    with tempfile.TemporaryDirectory() as d:
        robot(d, 0, 0, 0, 1, overflows=2)
        robot(d, 1, 0, 0, 0, overflows=0)
        with open(os.path.join(d, "zmq_proxy.log"), "w") as f:
            for t, n in ((30, 4), (41, 7)):
                f.write(f"zmq-proxy: {t} s: 900 datagrams (5.0 MB) forwarded, {n} subscriber queue overflows "
                        "(copies dropped), 12 subscription changes\n")
        r = run(d, "2", "--strict")
        check(r.returncode == 3, f"exit {r.returncode}")
        check(r.stdout.startswith("0 states given up, 0 peer timeouts, 10 datagrams dropped by full queues: "
                                  "not a lossless run"), repr(r.stdout))
        with open(os.path.join(d, "zmq_proxy.log"), "w") as f:
            f.write("zmq-proxy: publishers to tcp://127.0.0.1:7700, subscribers to tcp://127.0.0.1:7701\n")
        r = run(d, "2")
        check(r.stdout.startswith("at least 0 states given up, 0 peer timeouts, 3 datagrams") and
              "zmq_proxy.log: no count" in r.stdout, repr(r.stdout))


@test
def missing_robot_said_and_bad_arguments_refused():
    with tempfile.TemporaryDirectory() as d:
        robot(d, 0, 0, 0, 0)
        r = run(d, "2", "--strict")
        check(r.returncode == 3 and "robot_1: no summary.txt" in r.stdout, repr(r.stdout))
        check(run(os.path.join(d, "nope"), "2").returncode == 2, "a missing folder: not exit 2")
        check(run(d, "0").returncode == 2, "N = 0: not exit 2")
        check(run(d, "x").returncode == 2, "N not a number: not exit 2")


if __name__ == "__main__":
    main()
