#!/usr/bin/python3
"""tools/bench/bench_scaling.py's memory estimate for the next fleet: per process, how far the
machine's MemAvailable fell at a measured fleet's peak (shared pages once, socket buffers in),
before the fleet's summed RSS (which counts the shared pages once per process) and the largest
process.

    python3 tests/tools/test_bench_memory.py      prints "N passed, M failed", exit 1 on failure
"""
import csv
import importlib.util
import os
import sys
import tempfile
import types

sys.path.insert(0, os.path.dirname(os.path.realpath(__file__)))
from minitest import check, main, test  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.realpath(__file__))))
spec = importlib.util.spec_from_file_location("bench_scaling", os.path.join(ROOT, "tools/bench/bench_scaling.py"))
bench = importlib.util.module_from_spec(spec)
spec.loader.exec_module(bench)


def table(path, rows):
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=bench.ALL_FIELDS)
        w.writeheader()
        for r in rows:
            w.writerow({k: r.get(k, "") for k in bench.ALL_FIELDS})


@test
def the_machines_fall_is_used_before_summed_rss():
    with tempfile.TemporaryDirectory() as d:
        p = os.path.join(d, "t.csv")
        table(p, [{"transport": "lcm", "robots": 64, "rss_MB_max": 63, "fleet_rss_MB_peak": 3221.2,
                   "sock_MB_peak": 0.7, "mem_used_MB_peak": 2463.2},
                  {"transport": "lcm", "robots": 128, "rss_MB_max": 75, "fleet_rss_MB_peak": 7761.2,
                   "sock_MB_peak": 474.1, "mem_used_MB_peak": 5941.2}])
        a = types.SimpleNamespace(csv=p, results=os.path.join(d, "none"))
        known = bench.known_fleets(a)
        check(abs(known[("lcm", 128)][0] - 5941.2 / 128) < 1e-9, known)
        check(known[("lcm", 128)][1] is None, "the fall counts the socket buffers: not added again")
        need, how = bench.memory_need(a, "lcm", 256)
        per = 5941.2 / 128 + (5941.2 / 128 - 2463.2 / 64) / 64 * 128  # the rise from 64 to 128, on
        check(abs(need - 256 * per) < 1e-6, (need, how))


@test
def a_row_without_the_fall_keeps_the_summed_rss_and_the_sockets():
    with tempfile.TemporaryDirectory() as d:
        p = os.path.join(d, "t.csv")
        table(p, [{"transport": "lcm", "robots": 64, "rss_MB_max": 63, "fleet_rss_MB_peak": 3200, "sock_MB_peak": 10},
                  {"transport": "zmq", "robots": 64, "rss_MB_max": 70}])
        known = bench.known_fleets(types.SimpleNamespace(csv=p, results=os.path.join(d, "none")))
        check(known[("lcm", 64)] == (50.0, 10.0), known)
        check(known[("zmq", 64)] == (70.0, None), known)


if __name__ == "__main__":
    main()
