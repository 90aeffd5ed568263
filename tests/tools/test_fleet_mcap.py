#!/usr/bin/python3
"""Tests of tools/fleet_mcap.py (the MCAP log of a run, docs/foxglove.md) on a real tiny fleet:
`tools/fleet --mcap` with the real host_sim (HOST_SIM, default the small release build), two
robots over ZeroMQ on this host, 4 offline rounds on short tours. run.mcap is read back with
mcap's reader and every message decoded with protobuf from the schema the file carries:
  - every channel is there with its schema (Foxglove's protobuf ones, JSON for the scalars) and
    its count: a pose, a /tf transform and a scan per scan of each robot (train.samples' scans),
    one tour each, a val_loss and a traffic message per round, the three grids at every kept
    checkpoint round plus the final;
  - log times: monotonic per channel, within [0, the run's simulated time], equal to the
    message's own timestamp; the rounds' messages carry metrics.csv's sim_time_s;
  - the grids have the maps' cells (maps/*.npy, rows flipped to y up) and the scans the pool's
    samples, every one;
  - the same exporter on one robot's folder (a host_sim run) alone.
Skips (not fails) only when the Python packages cannot be had (tools/install-deps.sh makes
build/pyenv; this test re-runs itself with that python).

    python3 tests/tools/test_fleet_mcap.py   prints "N passed, M failed", exit 1 on failure
"""
import csv
import json
import os
import shutil
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.realpath(__file__)))
from minitest import check, main, test  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.realpath(__file__))))
HOST_SIM = os.environ.get("HOST_SIM", os.path.join(ROOT, "build/release-host-small/bin/host_sim"))
PYENV = os.path.join(ROOT, "build", "pyenv")
ROUNDS = 4


def packages():
    """True with mcap and the schemas importable (after re-running under build/pyenv's python,
    trying tools/install-deps.sh once to make it)."""
    try:
        import mcap.reader  # noqa: F401
        import foxglove_schemas_protobuf  # noqa: F401
        import google.protobuf  # noqa: F401
        import numpy  # noqa: F401
        return True
    except ImportError:
        pass
    py = os.path.join(PYENV, "bin", "python3")
    if os.path.realpath(sys.prefix) == os.path.realpath(PYENV):
        return False
    if not os.path.exists(py):
        subprocess.run([os.path.join(ROOT, "tools", "install-deps.sh")], stdout=subprocess.DEVNULL,
                       stderr=subprocess.DEVNULL, timeout=600)
    if os.path.exists(py):
        os.execv(py, [py, os.path.abspath(__file__)] + sys.argv[1:])
    return False


def read_mcap(path):
    """{topic: (schema name, schema encoding, [(log_time, publish_time, decoded message)])}."""
    from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
    from mcap.reader import make_reader
    out, classes = {}, {}
    with open(path, "rb") as f:
        r = make_reader(f)
        for schema, channel, msg in r.iter_messages(log_time_order=False):
            if schema.encoding == "protobuf":
                if schema.id not in classes:
                    fds = descriptor_pb2.FileDescriptorSet.FromString(schema.data)
                    pool = descriptor_pool.DescriptorPool()
                    for fd in fds.file:
                        pool.Add(fd)
                    classes[schema.id] = message_factory.GetMessageClass(pool.FindMessageTypeByName(schema.name))
                value = classes[schema.id].FromString(msg.data)
            else:
                check(schema.encoding == "jsonschema" and channel.message_encoding == "json",
                      f"{channel.topic}: schema encoding {schema.encoding}")
                json.loads(schema.data)
                value = json.loads(msg.data)
            e = out.setdefault(channel.topic, (schema.name, schema.encoding, []))
            e[2].append((msg.log_time, msg.publish_time, value))
        summary = r.get_summary()
        check(summary is not None and summary.statistics.message_count == sum(len(v[2]) for v in out.values()),
              "summary statistics disagree with the messages")
    return out


def rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def short_tours(tmp):
    """Two short tours (the first waypoints of the apartment's) so the robots drive seconds."""
    d = os.path.join(tmp, "tours")
    os.makedirs(d)
    for i in range(2):
        with open(os.path.join(ROOT, f"host_sim/plans/apartment/robot_{i}.csv")) as f:
            lines = f.read().splitlines()
        with open(os.path.join(d, f"robot_{i}.csv"), "w") as f:
            f.write("\n".join(lines[:4]) + "\n")  # the header and 3 waypoints
    return d


def check_log(log, run_dir, robots, fleet):
    import numpy as np
    sys.path.insert(0, os.path.join(ROOT, "tools"))
    import samples
    sim_end = max(float(open(os.path.join(d, "summary.txt")).read().split("simulated: ")[1].split(" s")[0])
                  for d in robots)
    want = {"/tf": ("foxglove.FrameTransform", "protobuf"), "/map/occupancy": ("foxglove.Grid", "protobuf"),
            "/map/std": ("foxglove.Grid", "protobuf"), "/map/epistemic": ("foxglove.Grid", "protobuf")}
    for i in range(len(robots)):
        want.update({f"/robot_{i}/pose": ("foxglove.PoseInFrame", "protobuf"),
                     f"/robot_{i}/scan": ("foxglove.PointCloud", "protobuf"),
                     f"/robot_{i}/tour": ("foxglove.SceneUpdate", "protobuf"),
                     f"/robot_{i}/val_loss": ("fleetsim.ValLoss", "jsonschema")})
        if fleet:
            want[f"/robot_{i}/traffic"] = ("fleetsim.Traffic", "jsonschema")
    check(set(log) == set(want), f"channels {sorted(log)}, want {sorted(want)}")
    for topic, (name, enc) in want.items():
        check(log[topic][:2] == (name, enc), f"{topic}: schema {log[topic][:2]}, want {(name, enc)}")
        times = [t for t, _, _ in log[topic][2]]
        check(times == sorted(times), f"{topic}: log times not monotonic")
        check(0 <= times[0] and times[-1] <= sim_end * 1e9 + 1, f"{topic}: times {times[0]}..{times[-1]} "
              f"outside the run's simulated 0..{sim_end} s")
        for t, pt, m in log[topic][2]:
            check(t == pt, f"{topic}: publish time {pt} != log time {t}")
            if enc == "protobuf" and name != "foxglove.SceneUpdate":
                ts = m.timestamp.seconds * 10**9 + m.timestamp.nanos
                check(ts == t, f"{topic}: timestamp {ts} != log time {t}")
    n_scans = 0
    for i, d in enumerate(robots):
        met = rows(os.path.join(d, "metrics.csv"))
        check(len(met) == ROUNDS, f"robot {i}: {len(met)} metrics rows")
        vl = log[f"/robot_{i}/val_loss"][2]
        check([m["round"] for _, _, m in vl] == list(range(ROUNDS)), f"robot {i}: val_loss rounds")
        check([t for t, _, _ in vl] == [round(float(r["sim_time_s"]) * 1e9) for r in met], f"robot {i}: val_loss times")
        check(all(abs(m["val_loss"] - float(r["val_loss"])) < 1e-9 for (_, _, m), r in zip(vl, met)), "val_loss values")
        if fleet:
            tr = log[f"/robot_{i}/traffic"][2]
            check(len(tr) == ROUNDS and tr[0][2]["bytes_sent"] > 0, f"robot {i}: traffic {tr[:1]}")
        h, a = samples.load(os.path.join(d, "train.samples"))
        scans = log[f"/robot_{i}/scan"][2]
        poses = log[f"/robot_{i}/pose"][2]
        check(len(scans) == len(poses) > 1, f"robot {i}: {len(scans)} scans, {len(poses)} poses")
        n_scans += len(scans)
        pts = np.concatenate([np.frombuffer(m.data, "<f4").reshape(-1, 4) for _, _, m in scans])
        x, y = samples.to_metres(h, a)
        check(len(pts) == len(a) and np.allclose(pts[:, 0], x, atol=1e-4) and np.allclose(pts[:, 1], y, atol=1e-4)
              and (pts[:, 3] == a["occ"]).all(), f"robot {i}: the scans are not the pool's samples")
        # scans come before the first round (offline: the tour first), 10 a simulated second
        check(scans[-1][0] < round(float(met[0]["sim_time_s"]) * 1e9), f"robot {i}: a scan after round 0")
        tour = log[f"/robot_{i}/tour"][2]
        check(len(tour) == 1 and len(tour[0][2].entities[0].lines[0].points) == 3, f"robot {i}: tour")
        p0 = poses[0][2].pose.position
        start = tour[0][2].entities[0].lines[0].points[0]
        check(abs(p0.x - start.x) < 0.3 and abs(p0.y - start.y) < 0.3, f"robot {i}: first pose {p0} far from {start}")
    check(len(log["/tf"][2]) == n_scans, "/tf: one transform per scan")
    grids = log["/map/occupancy"][2]
    if fleet:
        kept = sorted(int(f[6:10]) for f in os.listdir(robots[0]) if f.startswith("round_") and int(f[6:10]) < ROUNDS)
        check(len(grids) == len(kept) + 1, f"{len(grids)} occupancy grids, want {len(kept)} rounds + final")
        mean = np.load(os.path.join(run_dir, "maps", "map_mean.npy"))
        g = grids[-1][2]
        check(g.column_count == mean.shape[1] and len(g.data) == mean.size * 4, "final grid size")
        check((np.frombuffer(g.data, "<f4").reshape(mean.shape) == mean[::-1]).all(), "final grid cells")
        check(grids[-1][0] == round(sim_end * 1e9), "final maps at the run's end")
    for topic in ("/map/occupancy", "/map/std", "/map/epistemic"):
        check(len(log[topic][2]) == len(grids) >= 1, f"{topic}: {len(log[topic][2])} grids")


@test
def fleet_mcap_of_a_tiny_fleet():
    check(os.access(HOST_SIM, os.X_OK), f"no host_sim at {HOST_SIM} (make all)")
    with tempfile.TemporaryDirectory(prefix="test_fleet_mcap_") as tmp:
        cmd = ["/usr/bin/python3", os.path.join(ROOT, "tools", "fleet"), "--bin", HOST_SIM, "--robots", "2",
               "--rounds", str(ROUNDS), "--val-every", "1", "--paths", short_tours(tmp), "--transport", "zmq",
               "--results", tmp, "--name", "run", "--val-poses", "5", "--mc", "4", "--mcap"]
        res = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=600)
        check(res.returncode == 0, f"tools/fleet --mcap failed ({res.returncode}):\n{res.stdout}")
        run_dir = os.path.join(tmp, "run")
        path = os.path.join(run_dir, "run.mcap")
        check(os.path.getsize(path) > 0, "no run.mcap")
        robots = [os.path.join(run_dir, f"robot_{i}") for i in range(2)]
        check_log(read_mcap(path), run_dir, robots, fleet=True)

        # one host_sim run's folder alone (robot_1's, as a lone robot's: no traffic.csv): maps
        # from its checkpoints and final.bnn, the missing traffic said
        one = os.path.join(tmp, "one")
        shutil.copytree(robots[1], one)
        os.remove(os.path.join(one, "traffic.csv"))
        res = subprocess.run(["/usr/bin/python3", os.path.join(ROOT, "tools", "fleet_mcap.py"), one, "--host-sim",
                              HOST_SIM, "--plan", os.path.join(ROOT, "host_sim/plans/apartment.svg")],
                             stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=600)
        check(res.returncode == 0, f"fleet_mcap.py on one robot's folder failed:\n{res.stdout}")
        check("no traffic.csv" in res.stdout, f"the missing traffic not said:\n{res.stdout}")
        log = read_mcap(os.path.join(one, "run.mcap"))
        check(sorted(log) == sorted(["/tf", "/map/occupancy", "/map/std", "/map/epistemic"] +
                                    [f"/robot_1/{c}" for c in ("pose", "scan", "tour", "val_loss")]),
              f"one robot's channels: {sorted(log)}")


@test
def missing_packages_said_in_one_line():
    """A python without the packages and no build/pyenv to turn to: exit 2, one line naming the
    install command."""
    with tempfile.TemporaryDirectory(prefix="test_fleet_mcap_") as tmp:
        tools = os.path.join(tmp, "tools")
        os.makedirs(tools)
        shutil.copy(os.path.join(ROOT, "tools", "fleet_mcap.py"), tools)  # ROOT is tmp: no build/pyenv
        res = subprocess.run(["/usr/bin/python3", "-I", "-S", os.path.join(tools, "fleet_mcap.py"), tmp],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, timeout=60)
        check(res.returncode == 2 and len(res.stderr.strip().splitlines()) == 1 and
              "tools/install-deps.sh" in res.stderr, f"exit {res.returncode}: {res.stderr!r}")


if __name__ == "__main__":
    if not packages():
        print("test_fleet_mcap: SKIPPED: the Python packages mcap, foxglove-schemas-protobuf, protobuf are "
              "not installed and tools/install-deps.sh could not make build/pyenv (offline?)")
        print("[  SKIPPED ] 1 test(s).")
        sys.exit(0)
    sys.exit(main())
