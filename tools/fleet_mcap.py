#!/usr/bin/python3
"""A fleet run (tools/fleet's RESULTS/NAME/) or one `host_sim run` folder as an MCAP log with
Foxglove's protobuf schemas, for Foxglove Studio (docs/foxglove.md).

    tools/fleet_mcap.py RUN_DIR [--out FILE] [--host-sim BIN] [--plan FILE.svg]

Writes RUN_DIR/run.mcap (or FILE). Channels (frame "map": the plan's metres, x east, y north):
  /robot_<i>/tour       foxglove.SceneUpdate   the robot's waypoint tour (a line strip), at t = 0
  /robot_<i>/pose       foxglove.PoseInFrame   the pose the robot's RT core stamped each scan with
  /tf                   foxglove.FrameTransform  map -> robot_<i>, the same poses
  /robot_<i>/scan       foxglove.PointCloud    each scan's labelled samples (x, y, z = 0, occ:
                                               1 = lidar hit, 0 = free point along the beam)
  /robot_<i>/val_loss   JSON                   per round: val_loss, train_loss, bce, kl,
                                               neighbours, disagreement (metrics.csv)
  /robot_<i>/traffic    JSON                   per round: every column of traffic.csv (fleet only)
  /map/occupancy        foxglove.Grid          the consensus map's MC mean occupancy (field occupancy)
  /map/std              foxglove.Grid          its MC standard deviation (field std)
  /map/epistemic        foxglove.Grid          the share of the prior variance left (field epistemic)

Time: every stamp is SIMULATED time (seconds since the robot's start, as metrics.csv's
sim_time_s), in nanoseconds; wall time appears nowhere. A round's messages carry that robot's
sim_time_s of the round. The maps of round k are stamped with the largest sim_time_s of round k
over the robots (the round is complete when the last robot has it); the final maps with the
largest `simulated:` time of the robots' summary.txt.

Where the data comes from, and what is not in a run folder:
  - Scans and poses: train.samples holds the pool the robot trained on, records (x, y, occ)
    only: no pose, no time. While the pool kept every sample in order (pool cdr, never full,
    no ring drops) the records are whole scans of B beams x K points (host_sim's defaults
    20 x 25), and a beam's K points lie at d (k + 1) / K from the sensor, so the scan's origin
    is 2 p_0 - p_1 of any beam and the heading is beam 0's direction (the lidar's angle_min is
    0): that is the pose the RT core used (its estimate, not the world's true pose, which no
    file keeps). The exporter checks this geometry on every beam and uses it only when it
    holds; scan s is stamped s / 10 Hz (the RT core's scan rate; samples carry no time).
    Otherwise (dr pool, a full pool, dropped beams) it writes the pool as one point cloud at the
    first round's time and no poses, and says so.
  - The tour is the waypoint CSV (summary.txt's `path:` line), the plan the robot followed.
  - Maps per round: a run folder keeps only the models' checkpoints (round_NNNN.bnn: the newest
    few and every 100th) and the final models. With --host-sim (tools/fleet passes its own) the
    exporter maps the consensus of the robots' checkpoints of every round that all robots kept
    and that has a metrics row (`host_sim maps`, the run's --mc and cell size); post-rounds
    (the epistemic posterior's consensus after the last round) have no metrics row and no time,
    and are left out. The final maps are maps/*.npy of tools/fleet (or made from final.bnn).
    Without --host-sim only the final maps are written (and none for a lone host_sim run).
  - val_loss is nan in rounds without validation (--val-every): those rows are left out.
Exit status 0, 1 on an unreadable run folder, 2 when the Python packages are missing (the
message names the install command).
"""
import argparse
import csv
import glob
import json
import math
import os
import re
import shutil
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PYENV = os.path.join(ROOT, "build", "pyenv", "bin", "python3")
INSTALL = "tools/install-deps.sh (it makes build/pyenv with tools/requirements-mcap.txt)"
SCAN_HZ = 10.0        # the RT core's scan rate (firmware default; samples carry no time)
BEAMS, POINTS = 20, 25  # host_sim run's samples per scan: beams x points per beam


def _import_packages():
    """numpy, mcap and the Foxglove protobuf schemas; re-runs this script with build/pyenv's
    python when this one lacks them; exits 2 with the install command otherwise."""
    try:
        import numpy  # noqa: F401
        import mcap.writer  # noqa: F401
        import foxglove_schemas_protobuf  # noqa: F401
        import google.protobuf  # noqa: F401
    except ImportError as e:
        if os.path.exists(PYENV) and os.path.realpath(sys.prefix) != os.path.realpath(os.path.join(ROOT, "build", "pyenv")):
            os.execv(PYENV, [PYENV, os.path.abspath(__file__)] + sys.argv[1:])
        print(f"fleet_mcap: needs the Python packages mcap, foxglove-schemas-protobuf, protobuf "
              f"({e.name} missing): run {INSTALL}", file=sys.stderr)
        sys.exit(2)


class RunError(Exception):
    pass


def say(msg):
    print(f"fleet_mcap: {msg}")


def read_csv(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def num(v):
    try:
        return float(v)
    except (TypeError, ValueError):
        return math.nan


def ns(t_s):
    return int(round(t_s * 1e9))


def file_descriptor_set(msg_class):
    """The FileDescriptorSet of msg_class's file and every file it imports (MCAP's protobuf
    schema data)."""
    from google.protobuf.descriptor_pb2 import FileDescriptorSet
    fds, seen = FileDescriptorSet(), set()

    def add(fd):
        if fd.name in seen:
            return
        seen.add(fd.name)
        for dep in fd.dependencies:
            add(dep)
        fd.CopyToProto(fds.file.add())
    add(msg_class.DESCRIPTOR.file)
    return fds.SerializeToString()


class Log:
    """Channels registered on first use: protobuf (Foxglove) or JSON."""

    def __init__(self, path):
        from mcap.writer import Writer
        self.f = open(path, "wb")
        self.w = Writer(self.f)
        self.w.start(profile="", library="fleetsim tools/fleet_mcap.py")
        self.schemas, self.channels, self.seq = {}, {}, {}
        self.counts = {}

    def _channel(self, topic, schema_name, encoding, schema_data, msg_encoding):
        if topic not in self.channels:
            if schema_name not in self.schemas:
                self.schemas[schema_name] = self.w.register_schema(schema_name, encoding, schema_data)
            self.channels[topic] = self.w.register_channel(topic, msg_encoding, self.schemas[schema_name])
            self.seq[topic] = 0
        return self.channels[topic]

    def _write(self, topic, cid, t_ns, data):
        self.w.add_message(cid, log_time=t_ns, data=data, publish_time=t_ns, sequence=self.seq[topic])
        self.seq[topic] += 1
        self.counts[topic] = self.counts.get(topic, 0) + 1

    def proto(self, topic, msg, t_ns):
        name = msg.DESCRIPTOR.full_name
        cid = self._channel(topic, name, "protobuf", file_descriptor_set(type(msg)), "protobuf")
        self._write(topic, cid, t_ns, msg.SerializeToString())

    def json(self, topic, schema_name, obj, t_ns):
        props = {k: {"type": "number" if isinstance(v, (int, float)) else "string"} for k, v in obj.items()}
        schema = json.dumps({"type": "object", "title": schema_name, "properties": props}).encode()
        cid = self._channel(topic, schema_name, "jsonschema", schema, "json")
        self._write(topic, cid, t_ns, json.dumps(obj).encode())

    def close(self):
        self.w.finish()
        self.f.close()


def stamp(msg, t_ns):
    msg.timestamp.seconds, msg.timestamp.nanos = divmod(t_ns, 1_000_000_000)


def robots_of(run_dir):
    """[(index, folder)]: robot_<i>/ of a fleet run, or the folder itself (a host_sim run)."""
    dirs = sorted(glob.glob(os.path.join(run_dir, "robot_*")), key=lambda d: int(re.sub(r"\D", "", os.path.basename(d)) or 0))
    out = [(int(re.sub(r"\D", "", os.path.basename(d))), d) for d in dirs if os.path.isfile(os.path.join(d, "metrics.csv"))]
    if out:
        return out
    if os.path.isfile(os.path.join(run_dir, "metrics.csv")):
        i = 0
        s = os.path.join(run_dir, "summary.txt")
        if os.path.exists(s):
            m = re.search(r"this is robot (\d+)", open(s).read())
            i = int(m.group(1)) if m else 0
        return [(i, run_dir)]
    raise RunError(f"{run_dir}: neither robot_<i>/metrics.csv nor metrics.csv (not a fleet or host_sim run folder)")


def summary_field(rdir, pattern):
    s = os.path.join(rdir, "summary.txt")
    if not os.path.exists(s):
        return None
    m = re.search(pattern, open(s).read(), re.M)
    return m.group(1) if m else None


def resolve(p, run_dir):
    for c in (p, os.path.join(ROOT, p), os.path.join(run_dir, p)):
        if c and os.path.exists(c):
            return c
    return None


def tour(log, i, rdir, run_json, run_dir):
    from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate
    from foxglove_schemas_protobuf.LinePrimitive_pb2 import LinePrimitive
    path = summary_field(rdir, r"^path: (.+?) \(\d+ waypoints")
    if path is None and run_json.get("paths") and i < len(run_json["paths"]):
        path = run_json["paths"][i]
    path = resolve(path, run_dir) if path else None
    if path is None:
        say(f"robot {i}: no tour (summary.txt names no readable path CSV): /robot_{i}/tour left out")
        return
    pts = [(float(r["x_m"]), float(r["y_m"])) for r in read_csv(path)]
    u = SceneUpdate()
    e = u.entities.add()
    stamp(e, 0)
    e.frame_id, e.id = "map", f"tour_{i}"
    ln = e.lines.add()
    ln.type = LinePrimitive.LINE_STRIP
    ln.thickness, ln.scale_invariant = 3.0, True
    ln.pose.orientation.w = 1.0
    c = [(0.12, 0.47, 0.71), (1.0, 0.5, 0.05), (0.17, 0.63, 0.17), (0.84, 0.15, 0.16),
         (0.58, 0.4, 0.74), (0.55, 0.34, 0.29), (0.89, 0.47, 0.76), (0.5, 0.5, 0.5)][i % 8]
    ln.color.r, ln.color.g, ln.color.b, ln.color.a = c[0], c[1], c[2], 1.0
    for x, y in pts:
        p = ln.points.add()
        p.x, p.y = x, y
    log.proto(f"/robot_{i}/tour", u, 0)


def split_scans(header, arr):
    """(origins N x 2, headings N, [(x, y, occ) of each scan]) when the pool is whole scans in
    order, else None. A beam is a run of up to POINTS records p_k = o + (k + 1) (p_0 - o) (a
    beam without a hit loses its points past the plan's box, so it may be shorter; only a full
    beam's last point may be a hit); a scan is the beams of one origin in increasing angle
    order. Every record must fall in a beam of a scan, or None."""
    import numpy as np
    import samples
    n = len(arr)
    if n < 2:
        return None
    x, y = samples.to_metres(header, arr)
    occ = arr["occ"]
    tol = 1e-3  # metres: float32 records over a box of a few tens of metres are good to ~1e-5
    step = 2 * math.pi / BEAMS
    scans, i = [], 0  # scans: [start, end, ox, oy, first beam angle, last slot]
    while i < n:
        if i + 1 >= n:
            return None
        ox, oy = 2 * x[i] - x[i + 1], 2 * y[i] - y[i + 1]
        dx, dy = x[i] - ox, y[i] - oy
        m = min(POINTS, n - i)
        k = np.arange(1, m + 1)
        ok = (np.abs(x[i:i + m] - (ox + k * dx)) <= tol) & (np.abs(y[i:i + m] - (oy + k * dy)) <= tol)
        m = int(np.argmin(ok)) if not ok.all() else m
        if m < 2 or (occ[i:i + m - 1] != 0).any() or (m < POINTS and occ[i + m - 1] != 0):
            return None
        a = math.atan2(dy, dx)
        cur = scans[-1] if scans else None
        if cur is not None and abs(cur[2] - ox) <= tol and abs(cur[3] - oy) <= tol:
            slot = int(round(((a - cur[4]) % (2 * math.pi)) / step)) % BEAMS
            if slot > cur[5]:
                cur[1], cur[5] = i + m, slot
                i += m
                continue
        scans.append([i, i + m, ox, oy, a, 0])
        i += m
    origins = np.array([[s[2], s[3]] for s in scans])
    heading = np.empty(len(scans))
    prev = None
    for j, s in enumerate(scans):
        h = s[4]  # beam 0's direction; when beam 0 dropped out, the nearest of the slots to the last heading
        if prev is not None:
            h = min((s[4] - q * step for q in range(BEAMS)),
                    key=lambda v: abs((v - prev + math.pi) % (2 * math.pi) - math.pi))
        heading[j] = prev = math.atan2(math.sin(h), math.cos(h))
    clouds = [(x[s[0]:s[1]], y[s[0]:s[1]], occ[s[0]:s[1]]) for s in scans]
    return origins, heading, clouds


def point_cloud(t_ns, x, y, occ):
    import numpy as np
    from foxglove_schemas_protobuf.PointCloud_pb2 import PointCloud
    from foxglove_schemas_protobuf.PackedElementField_pb2 import PackedElementField
    pc = PointCloud()
    stamp(pc, t_ns)
    pc.frame_id = "map"
    pc.pose.orientation.w = 1.0
    pc.point_stride = 16
    for j, name in enumerate(("x", "y", "z", "occ")):
        f = pc.fields.add()
        f.name, f.offset, f.type = name, 4 * j, PackedElementField.FLOAT32
    pc.data = np.column_stack([x, y, np.zeros(len(x)), occ]).astype("<f4").tobytes()
    return pc


def scans_and_poses(log, i, rdir, metrics, tfs):
    import samples
    from foxglove_schemas_protobuf.PoseInFrame_pb2 import PoseInFrame
    from foxglove_schemas_protobuf.FrameTransform_pb2 import FrameTransform
    p = os.path.join(rdir, "train.samples")
    if not os.path.exists(p):
        say(f"robot {i}: no train.samples: /robot_{i}/scan and /robot_{i}/pose left out")
        return
    h, a = samples.load(p)
    last = metrics[-1] if metrics else {}
    in_order = (num(last.get("ring_drops")) == 0 and num(last.get("pool_fill")) < num(last.get("pool_capacity"))
                and ("offline" in h["source"] or summary_field(rdir, r"^pool: (\w+)") == "cdr"))
    sc = split_scans(h, a) if in_order else None
    if sc is None:
        t0 = num(metrics[0]["sim_time_s"]) if metrics else 0.0
        x, y = samples.to_metres(h, a)
        log.proto(f"/robot_{i}/scan", point_cloud(ns(t0), x, y, a["occ"]), ns(t0))
        say(f"robot {i}: the pool is not whole scans in order (dr pool, full pool, ring drops or dropped "
            f"beams): its {len(a)} samples as one cloud at round 0 (t {t0:.1f} s); no poses (no file has them)")
        return
    origins, heading, clouds = sc
    for s, ((ox, oy), th, (x, y, occ)) in enumerate(zip(origins, heading, clouds)):
        t = ns(s / SCAN_HZ)
        log.proto(f"/robot_{i}/scan", point_cloud(t, x, y, occ), t)
        q = (math.cos(th / 2), math.sin(th / 2))
        pose = PoseInFrame()
        stamp(pose, t)
        pose.frame_id = "map"
        pose.pose.position.x, pose.pose.position.y = float(ox), float(oy)
        pose.pose.orientation.w, pose.pose.orientation.z = q
        log.proto(f"/robot_{i}/pose", pose, t)
        tf = FrameTransform()
        stamp(tf, t)
        tf.parent_frame_id, tf.child_frame_id = "map", f"robot_{i}"
        tf.translation.x, tf.translation.y = float(ox), float(oy)
        tf.rotation.w, tf.rotation.z = q
        tfs.append((t, i, tf))  # written after every robot's, in time order


def scalars(log, i, rdir, metrics):
    for r in metrics:
        t = ns(num(r["sim_time_s"]))
        if math.isfinite(num(r["val_loss"])):
            log.json(f"/robot_{i}/val_loss", "fleetsim.ValLoss",
                     {k: (int(num(r[k])) if k in ("round", "neighbours") else num(r[k]))
                      for k in ("round", "sim_time_s", "val_loss", "train_loss", "bce", "kl", "neighbours",
                                "disagreement") if k in r}, t)
    tp = os.path.join(rdir, "traffic.csv")
    if not os.path.exists(tp):
        say(f"robot {i}: no traffic.csv (a robot alone): /robot_{i}/traffic left out")
        return
    times = {int(num(r["round"])): num(r["sim_time_s"]) for r in metrics}
    for r in read_csv(tp):
        k = int(num(r["round"]))
        if k not in times:
            continue
        obj = {c: (int(num(v)) if re.fullmatch(r"-?\d+", v or "") else num(v)) for c, v in r.items()}
        log.json(f"/robot_{i}/traffic", "fleetsim.Traffic", obj, ns(times[k]))


def grid(log, topic, field, arr, meta, t_ns):
    import numpy as np
    from foxglove_schemas_protobuf.Grid_pb2 import Grid
    from foxglove_schemas_protobuf.PackedElementField_pb2 import PackedElementField
    g = Grid()
    stamp(g, t_ns)
    g.frame_id = "map"
    g.pose.position.x, g.pose.position.y = float(meta["xmin"]), float(meta["ymin"])
    g.pose.orientation.w = 1.0
    h, w = arr.shape
    g.column_count = w
    g.cell_size.x = g.cell_size.y = float(meta["res"])
    g.cell_stride, g.row_stride = 4, 4 * w
    f = g.fields.add()
    f.name, f.offset, f.type = field, 0, PackedElementField.FLOAT32
    g.data = np.ascontiguousarray(arr[::-1]).astype("<f4").tobytes()  # .npy row 0 is the top; Grid's is y min
    log.proto(topic, g, t_ns)


def maps_from(log, mdir, t_ns):
    import numpy as np
    meta = json.load(open(os.path.join(mdir, "map_meta.json")))
    n = 0
    for topic, field, name in (("/map/occupancy", "occupancy", "map_mean.npy"), ("/map/std", "std", "map_std.npy"),
                               ("/map/epistemic", "epistemic", "map_epistemic.npy")):
        p = os.path.join(mdir, name)
        if os.path.exists(p):
            grid(log, topic, field, np.load(p), meta, t_ns)
            n += 1
    return n


def run_maps(host_sim, plan, models, out, run_json):
    """host_sim maps of models into out, with the run's grid, MC passes and seed; a map already
    there of the same models and settings (the report's strip, maps/rounds/) is used as it is."""
    from fleet_io import round_map
    why = round_map(host_sim, plan, models, out, run_json.get("map_res_m", 0.05), run_json.get("mc", 50),
                    run_json.get("seed", 1))
    if why is not None:
        raise RunError(f"host_sim maps of {len(models)} checkpoint(s) into {out} {why}")


def maps(log, run_dir, robots, metrics, run_json, host_sim, plan):
    per_round = {}
    for i, _ in robots:
        for r in metrics[i]:
            k = int(num(r["round"]))
            per_round[k] = max(per_round.get(k, 0.0), num(r["sim_time_s"]))
    final_t = max([num(summary_field(d, r"^simulated: ([\d.]+) s")) for _, d in robots] +
                  [max(per_round.values(), default=0.0)])
    if not math.isfinite(final_t):
        final_t = max(per_round.values(), default=0.0)
    plan = plan or (resolve(run_json["plan"], run_dir) if run_json.get("plan") else None)
    tmp = tempfile.mkdtemp(prefix="fleet_mcap_")
    try:
        if host_sim and plan:
            kept = None
            for _, d in robots:
                ks = {int(m.group(1)) for m in (re.search(r"round_(\d+)\.bnn$", f) for f in os.listdir(d)) if m}
                kept = ks if kept is None else kept & ks
            rounds = sorted(k for k in (kept or ()) if k in per_round)
            skipped = sorted((kept or set()) - set(rounds))
            for k in rounds:
                out = os.path.join(run_dir, "maps", "rounds", f"round_{k:04d}")
                run_maps(host_sim, plan, [os.path.join(d, f"round_{k:04d}.bnn") for _, d in robots], out, run_json)
                maps_from(log, out, ns(per_round[k]))
            say(f"maps of rounds {rounds or 'none'} (the checkpoints every robot kept)" +
                (f"; rounds {skipped} left out (post-rounds: no metrics row, no time)" if skipped else ""))
        elif not host_sim:
            say("maps: final only (no --host-sim to map the round checkpoints)")
        else:
            say("maps: final only (no plan: run.json names none and no --plan given)")
        mdir = os.path.join(run_dir, "maps")
        if os.path.exists(os.path.join(mdir, "map_meta.json")):
            maps_from(log, mdir, ns(final_t))
        elif host_sim and plan and all(os.path.exists(os.path.join(d, "final.bnn")) for _, d in robots):
            out = os.path.join(tmp, "final")
            run_maps(host_sim, plan, [os.path.join(d, "final.bnn") for _, d in robots], out, run_json)
            maps_from(log, out, ns(final_t))
        else:
            say("maps: no maps/ in the run folder (and no --host-sim and plan to make them): /map/* left out")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def export(run_dir, out, host_sim=None, plan=None):
    sys.path.insert(0, os.path.join(ROOT, "tools"))
    robots = robots_of(run_dir)
    rj = os.path.join(run_dir, "run.json")
    run_json = json.load(open(rj)) if os.path.exists(rj) else {}
    metrics = {i: read_csv(os.path.join(d, "metrics.csv")) for i, d in robots}
    log = Log(out + ".tmp")
    try:
        for i, d in robots:
            tour(log, i, d, run_json, run_dir)
        tfs = []
        for i, d in robots:
            scans_and_poses(log, i, d, metrics[i], tfs)
            scalars(log, i, d, metrics[i])
        for t, _, tf in sorted(tfs, key=lambda e: e[:2]):
            log.proto("/tf", tf, t)
        maps(log, run_dir, robots, metrics, run_json, host_sim, plan)
        log.close()
        os.replace(out + ".tmp", out)
    except BaseException:
        log.f.close()
        os.unlink(out + ".tmp")
        raise
    return log.counts


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("run_dir", help="a tools/fleet run folder or one host_sim run's --out folder")
    ap.add_argument("--out", help="MCAP file written (default RUN_DIR/run.mcap)")
    ap.add_argument("--host-sim", help="host_sim binary: maps of the round checkpoints (and the final maps "
                                       "of a lone host_sim run)")
    ap.add_argument("--plan", help="floor plan SVG for those maps (default: run.json's)")
    a = ap.parse_args(argv)
    _import_packages()
    out = a.out or os.path.join(a.run_dir, "run.mcap")
    try:
        counts = export(a.run_dir, out, a.host_sim, a.plan)
    except (RunError, OSError, KeyError, ValueError, ImportError) as e:
        print(f"fleet_mcap: {e}", file=sys.stderr)
        return 1
    say(f"wrote {out} ({os.path.getsize(out)} B): " +
        ", ".join(f"{t} {n}" for t, n in sorted(counts.items())))
    return 0


if __name__ == "__main__":
    sys.exit(main())
