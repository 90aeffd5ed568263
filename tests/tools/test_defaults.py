#!/usr/bin/python3
"""Tests that every program states the same defaults, against the built host_sim:
  - `host_sim defaults` prints every key tools/fleet reads, once, as key=value;
  - tools/fleet's parsed defaults are the binary's (radius, rounds, seed, timings, map grid...),
    and the stand-in of tests/tools/test_fleet.py says what the binary says;
  - `host_sim fleet --inproc` and `host_sim run` show the same default for every option they
    share (their --help prints each default from the struct the parse starts from), and those
    are `host_sim defaults`'s: the in-process reference with no options is the process fleet;
  - `host_sim maps --res` is the launchers' fleet map grid;
  - tools/run-fleet.sh --help shows the binary's values.

    python3 tests/tools/test_defaults.py      (HOST_SIM=path, else the release build's host_sim)
"""
import ast
import importlib.machinery
import importlib.util
import os
import re
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.realpath(__file__)))
from minitest import check, main, test  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.realpath(__file__))))
HOST_SIM = os.environ.get("HOST_SIM", os.path.join(ROOT, "build/release-host-small/bin/host_sim"))


def load(name, path):
    """A Python file without the .py ending (tools/fleet) as a module."""
    loader = importlib.machinery.SourceFileLoader(name, path)
    spec = importlib.util.spec_from_loader(name, loader)
    mod = importlib.util.module_from_spec(spec)
    loader.exec_module(mod)
    return mod


def host(*args):
    res = subprocess.run([HOST_SIM] + list(args), stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                         timeout=60)
    check(res.returncode == 0, f"host_sim {' '.join(args)}: exit {res.returncode}\n{res.stdout}")
    return res.stdout


def defaults():
    lines = host("defaults").splitlines()
    keys = [l.split("=", 1)[0] for l in lines]
    check(all("=" in l for l in lines) and len(keys) == len(set(keys)), f"not one key=value per key:\n{lines}")
    return dict(l.split("=", 1) for l in lines)


def help_defaults(cmd):
    """{option: its default as --help shows it} of `host_sim CMD --help` (the option list: an
    entry starts with "  -", its help wraps onto deeper-indented lines)."""
    entries, cur = [], None
    for line in host(cmd, "--help").splitlines():
        if line.startswith("  -"):
            cur = [line.strip()]
            entries.append(cur)
        elif cur is not None and line.startswith("    "):
            cur.append(line.strip())
        else:
            cur = None
    out = {}
    for e in entries:
        text = " ".join(e)
        m = re.search(r"\((default (.*)|required)\)$", text)
        out[text.split()[0].rstrip(",")] = None if m is None or m.group(2) is None else m.group(2)
    return out


@test
def launcher_reads_the_binary():
    fleet = load("fleet_launcher", os.path.join(ROOT, "tools", "fleet"))
    d = defaults()
    missing = [k for k in fleet.DEFAULT_KEYS if k not in d]
    check(not missing, f"host_sim defaults lacks {missing}")
    argv = sys.argv
    try:
        sys.argv = ["tools/fleet", "--bin", HOST_SIM]
        a = fleet.parse()
    finally:
        sys.argv = argv
    want = {"robots": "fleet_robots", "rounds": "fleet_rounds", "seed": "seed", "mode": "fleet_mode",
            "rounds_per_comm": "rounds_per_comm", "pool": "pool", "strategy": "strategy", "radius": "radius_m",
            "encoding": "encoding", "lcm_url": "lcm_url", "val_poses": "fleet_val_poses",
            "peer_timeout": "peer_timeout_s", "mc": "mc", "map_res": "fleet_map_res_m"}
    for opt, key in want.items():
        got = getattr(a, opt)
        check(got == type(got)(d[key]), f"tools/fleet --{opt.replace('_', '-')} {got!r}, host_sim defaults {key}={d[key]}")
    check(a.resend_ms >= float(d["resend_ms"]), f"tools/fleet --resend-ms {a.resend_ms} below {d['resend_ms']}")
    # test_fleet.py's stand-in answers as this binary does
    with open(os.path.join(ROOT, "tests", "tools", "test_fleet.py")) as f:  # read, not imported: its tests
        tree = ast.parse(f.read())                                          # would join these
    text = next(ast.literal_eval(n.value) for n in tree.body if isinstance(n, ast.Assign) and
                any(isinstance(t, ast.Name) and t.id == "DEFAULTS" for t in n.targets))
    fake = dict(l.split("=", 1) for l in text.splitlines())
    differ = {k: (v, d.get(k)) for k, v in fake.items() if d.get(k) != v}
    check(not differ, f"test_fleet.py's stand-in says other defaults (stand-in, binary): {differ}")


@test
def inproc_equals_run():
    run, inproc, d = help_defaults("run"), help_defaults("fleet"), defaults()
    shared = [o for o in inproc if o in run and inproc[o] is not None and run[o] is not None]
    for o in ("--radius", "--map-res", "--mc", "--val-poses", "--strategy", "--rho0", "--scale"):
        check(o in shared, f"{o} is not an option of both with a default: {sorted(shared)}")
    differ = {o: (inproc[o], run[o]) for o in shared if inproc[o] != run[o]}
    check(not differ, f"fleet --inproc and run show other defaults (inproc, run): {differ}")
    for o, key in (("--radius", "radius_m"), ("--map-res", "map_res_m"), ("--mc", "mc"), ("--val-poses", "val_poses"),
                   ("--strategy", "strategy"), ("--rounds", "run_rounds"), ("--peer-timeout", "peer_timeout_s"),
                   ("--join-timeout", "join_timeout_s"), ("--resend-ms", "resend_ms"), ("--encoding", "encoding"),
                   ("--pool", "pool"), ("--seed", "seed"), ("--rho0", "rho0")):
        check(run[o] == d[key], f"host_sim run {o} (default {run[o]}), host_sim defaults {key}={d[key]}")
    check(inproc["--occ-res"] == d["occ_res_m"], "fleet --occ-res")
    check(help_defaults("maps")["--res"] == d["fleet_map_res_m"], "host_sim maps --res is the fleet's map grid")


@test
def run_fleet_help_shows_the_binary():
    d = defaults()
    bin_dir = os.path.join(ROOT, "build", "bin")
    res = subprocess.run([os.path.join(ROOT, "tools", "run-fleet.sh"), "--help"], cwd=ROOT, stdout=subprocess.PIPE,
                         stderr=subprocess.STDOUT, text=True, timeout=60)
    check(res.returncode == 0 and "Why 6 m" in res.stdout, res.stdout)
    if os.path.realpath(os.path.join(bin_dir, "host_sim")) == os.path.realpath(HOST_SIM):
        check(f"ROUNDS {d['fleet_rounds']}, SEED {d['seed']}, RADIUS {d['radius_m']} m" in res.stdout, res.stdout)


@test
def unknown_argument_refused():
    res = subprocess.run([HOST_SIM, "defaults", "--json"], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                         text=True, timeout=60)
    check(res.returncode == 2 and "--json" in res.stdout, f"exit {res.returncode}: {res.stdout}")


if __name__ == "__main__":
    if not os.access(HOST_SIM, os.X_OK):
        print(f"test_defaults: {HOST_SIM} not found: build first (make)", file=sys.stderr)
        sys.exit(1)
    sys.exit(main())
