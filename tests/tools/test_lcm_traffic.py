#!/usr/bin/python3
"""Tests of tools/lcm_traffic.py (a synthetic lcm-logger log with the exact byte layouts of
firmware/msg/*.lcm) and tools/fleet_report.py (a synthetic two-robot RUN_DIR).

    python3 tests/tools/test_lcm_traffic.py      prints "N passed, M failed", exit 1 on failure

Needs Debian's python3 with numpy, scipy, matplotlib for the fleet_report part: when the
python3 found first lacks numpy, the test runs itself again with /usr/bin/python3.
"""
import json
import os
import shutil
import struct
import subprocess
import sys
import tempfile
import zlib


sys.path.insert(0, os.path.dirname(os.path.realpath(__file__)))
from minitest import check, main, need_numpy, test  # noqa: E402

np = need_numpy("test_lcm_traffic")

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.realpath(__file__))))
TRAFFIC = os.path.join(ROOT, "tools", "lcm_traffic.py")
REPORT = os.path.join(ROOT, "tools", "fleet_report.py")
ENV = dict(os.environ, MPLBACKEND="Agg")

SYNC = struct.pack(">I", 0xEDA1DA01)
FP_STATE = 0xDF65602B2D04BF15
FP_DONE = 0x4BAED42FB1823BC9  # with the next round's position (0x9EC25DAEB3A35535 before)
FP_REQUEST = 0x1A0EE5130E4FFF0D


def run(cmd, cwd=ROOT):
    p = subprocess.run([sys.executable] + cmd, cwd=cwd, env=ENV, capture_output=True, text=True, timeout=60)
    return p.returncode, p.stdout, p.stderr


# ---- LCM log ---------------------------------------------------------------------------------

def event(num, utime, channel, data):
    ch = channel.encode()
    return SYNC + struct.pack(">qqii", num, utime, len(ch), len(data)) + ch + data


def state_chunk(sender, rnd, chunk, n_chunks, payload, state_bytes=1000, encoding=0, crc=0x12345678,
                x=1.5, y=-2.25, incarnation=1, n_bytes=None):
    n = len(payload) if n_bytes is None else n_bytes
    head = struct.pack(">Qiiiiibiddii", FP_STATE, sender, rnd, chunk, n_chunks, state_bytes, encoding,
                       crc, x, y, incarnation, n)
    assert len(head) == 57
    return head + payload


def done(sender, rnd, next_xy=None):
    has = next_xy is not None
    x, y = next_xy if has else (0.0, 0.0)
    return struct.pack(">Qiiibdd", FP_DONE, sender, rnd, 1, 1 if has else 0, x, y)


def request(requester, target, rnd, chunks):
    return struct.pack(">Qiiiibddi", FP_REQUEST, requester, target, rnd, 1, 1, 0.5, -2.0, len(chunks)) + \
        struct.pack(f">{len(chunks)}i", *chunks)


def synthetic_log(path):
    """Chunks of two senders, one duplicate, a request, a done, telemetry, another channel,
    two malformed messages, a 13-byte garbage gap (with a false sync word) and a truncated
    last event. Time span 1.0 s .. 3.5 s."""
    ev = []
    t0 = 1_700_000_000_000_000
    ev.append(event(0, t0 + 1_000_000, "fleetsim/0/state", state_chunk(0, 0, 0, 2, b"a" * 100)))
    ev.append(event(1, t0 + 1_100_000, "fleetsim/0/state", state_chunk(0, 0, 1, 2, b"b" * 50)))
    ev.append(event(2, t0 + 1_200_000, "fleetsim/0/state", state_chunk(1, 0, 0, 1, b"c" * 80)))
    ev.append(event(3, t0 + 1_300_000, "fleetsim/0/state", state_chunk(0, 0, 1, 2, b"b" * 50)))  # again
    ev.append(b"junk" + SYNC + b"\xff" * 5)  # 13 bytes of garbage, a false sync word inside
    ev.append(event(4, t0 + 1_400_000, "fleetsim/0/request", request(1, 0, 0, [1])))
    ev.append(event(5, t0 + 1_500_000, "fleetsim/0/done", done(0, 0)))
    ev.append(event(6, t0 + 1_600_000, "fleetsim/telemetry/1", b"telemetry!"))
    ev.append(event(7, t0 + 1_700_000, "SOMETHING_ELSE", b"xyz"))
    # malformed: n_bytes says 10, 5 bytes follow; a RoundComplete on the state channel
    ev.append(event(8, t0 + 1_800_000, "fleetsim/0/state", state_chunk(1, 1, 0, 1, b"12345", n_bytes=10)))
    ev.append(event(9, t0 + 1_900_000, "fleetsim/0/state", done(1, 1)))
    ev.append(event(10, t0 + 3_500_000, "fleetsim/0/state", state_chunk(1, 1, 0, 1, b"d" * 20)))
    tail = event(11, t0 + 3_600_000, "fleetsim/0/done", done(1, 1))
    ev.append(tail[:-5])  # truncated last event
    with open(path, "wb") as f:
        f.write(b"".join(ev))
    return len(tail) - 5


def read_csv(path):
    with open(path) as f:
        lines = [l.strip().split(",") for l in f if l.strip()]
    return lines[0], lines[1:]


@test
def lcm_traffic_counts():
    d = tempfile.mkdtemp(prefix="lcmtest.")
    try:
        log = os.path.join(d, "fleet.lcmlog")
        tail = synthetic_log(log)
        csv = os.path.join(d, "out", "traffic.csv")
        rc, out, err = run([TRAFFIC, log, "--csv", csv])
        check(rc == 0, f"exit {rc}: {err}")
        header, rows = read_csv(csv)
        umask = os.umask(0)
        os.umask(umask)
        mode = os.stat(csv).st_mode & 0o777
        check(mode == 0o666 & ~umask, f"the CSV is {oct(mode)}, not {oct(0o666 & ~umask)} like every other output")
        check(header == ["fleet", "round", "agent", "chunks_sent", "state_bytes", "chunks_resent",
                         "requests_sent", "chunks_requested", "done_sent", "keyed_messages"], f"header {header}")
        got = {(r[0], r[1], r[2]): [int(x) for x in r[3:]] for r in rows}
        want = {
            ("0", "0", "0"): [3, 200, 1, 0, 0, 1, 0],
            ("0", "0", "1"): [1, 80, 0, 1, 1, 0, 0],
            ("0", "1", "1"): [1, 20, 0, 0, 0, 0, 0],
            ("0", "total", "0"): [3, 200, 1, 0, 0, 1, 0],
            ("0", "total", "1"): [2, 100, 0, 1, 1, 0, 0],
            ("all", "total", "all"): [5, 300, 1, 1, 1, 1, 0],
        }
        check(got == want, f"table\n{got}\n!=\n{want}")
        check("time span: 2.500 s" in out, "time span:\n" + out)
        check("13 bytes skipped" in out and "1 gap(s)" in out, "gap:\n" + out)
        check(f"truncated last event: {tail} bytes ignored" in out, "tail:\n" + out)
        check("2 malformed" in out and "n_bytes disagrees" in out and "does not match the channel" in out,
              "malformed:\n" + out)
        check("1 telemetry, 1 other" in out and "1: 1 (10 B)" in out, "telemetry/other:\n" + out)
        # the same table on stdout: the row of agent 0, round 0
        check(any(l.split() == ["0", "0", "0", "3", "200", "1", "0", "0", "1", "0"] for l in out.splitlines()),
              "stdout row:\n" + out)
        check("unkeyed fleet: none of the 7 fleet messages carried a tag trailer" in out, "unkeyed:\n" + out)
        # --prefix other/: nothing is a fleet message any more, but the log is still valid
        rc, out, err = run([TRAFFIC, log, "--prefix", "other/"])
        check(rc == 0 and "no fleet message" in out, f"prefix: {rc} {out} {err}")
    finally:
        shutil.rmtree(d)


def keyed(data, run_id=0x7CCB52F6AA0FFAF4):
    """data as a keyed fleet member sends it (hal/host/hal_host_auth.c): the message, then the
    48-byte trailer run id (8 bytes, big-endian) | nonce (24) | tag (16). The tag here is not a
    real one: without --key-file the tool strips and counts trailers, it does not check them."""
    return data + struct.pack(">Q", run_id) + bytes(range(24)) + b"\xa5" * 16


@test
def lcm_traffic_keyed():
    """A keyed fleet's datagrams (the default of tools/fleet): each message ends with the 48-byte
    trailer, which is stripped before decoding; the state chunks, requests and RoundCompletes are
    counted as in an unkeyed log, the CSV's keyed_messages column and the summary say they were
    keyed, with the run id. A tag of another key fails --key-file's check (libsodium)."""
    d = tempfile.mkdtemp(prefix="lcmtest.")
    try:
        log = os.path.join(d, "keyed.lcmlog")
        t0 = 1_700_000_000_000_000
        ev = [event(0, t0, "fleetsim/7/state", keyed(state_chunk(0, 0, 0, 2, b"a" * 100))),
              event(1, t0 + 10, "fleetsim/7/state", keyed(state_chunk(0, 0, 1, 2, b"b" * 60))),
              event(2, t0 + 20, "fleetsim/7/state", keyed(state_chunk(1, 0, 0, 1, b"c" * 80))),
              event(3, t0 + 30, "fleetsim/7/request", keyed(request(1, 0, 0, [1]))),
              event(4, t0 + 40, "fleetsim/7/done", keyed(done(0, 0))),
              event(5, t0 + 50, "fleetsim/7/done", keyed(done(1, 0, (2.0, -1.0))))]
        with open(log, "wb") as f:
            f.write(b"".join(ev))
        csv = os.path.join(d, "traffic.csv")
        rc, out, err = run([TRAFFIC, log, "--csv", csv, "--totals-only"])
        check(rc == 0, f"exit {rc}: {err}")
        check("3 state chunks, 2 RoundComplete, 1 chunk requests" in out and "0 malformed" in out, out)
        check("keyed fleet: 6 of 6 fleet messages carried the 48-byte tag trailer" in out and
              "run id 7ccb52f6aa0ffaf4 (6)" in out and "tags not checked" in out, out)
        header, rows = read_csv(csv)
        got = {(r[0], r[1], r[2]): [int(x) for x in r[3:]] for r in rows}
        check(got[("all", "total", "all")] == [3, 240, 0, 1, 1, 2, 6], f"totals {got}")
        check(got[("7", "0", "1")] == [1, 80, 0, 1, 1, 1, 3], f"robot 1 {got}")
        # A key that did not make the tags: every keyed message is refused as a bad tag.
        key = os.path.join(d, "other.key")
        with open(key, "w") as f:
            f.write("ab" * 32 + "\n")
        rc, out, err = run([TRAFFIC, log, "--totals-only", "--key-file", key])
        check(rc == 0 and "6 malformed" in out and "bad tag" in out, f"exit {rc}: {out} {err}")
        rc, out, err = run([TRAFFIC, log, "--key-file", log])
        check(rc == 1 and "not a fleet key" in err and len(err.strip().splitlines()) == 1, f"exit {rc}: {err}")
    finally:
        shutil.rmtree(d)


@test
def lcm_traffic_errors():
    d = tempfile.mkdtemp(prefix="lcmtest.")
    try:
        rc, out, err = run([TRAFFIC, "--help"])
        check(rc == 0 and "LOGFILE" in out, "--help")
        rc, out, err = run([TRAFFIC, os.path.join(d, "missing.lcmlog")])
        check(rc == 1 and "No such file" in err and len(err.strip().splitlines()) == 1, f"missing: {err}")
        junk = os.path.join(d, "junk")
        with open(junk, "wb") as f:
            f.write(b"not a log at all" * 100)
        rc, out, err = run([TRAFFIC, junk])
        check(rc == 1 and "no valid LCM event" in err, f"junk: {rc} {err}")
        empty = os.path.join(d, "empty")
        open(empty, "wb").close()
        rc, out, err = run([TRAFFIC, empty])
        check(rc == 1 and "empty" in err, f"empty: {rc} {err}")
        rc, out, err = run([TRAFFIC, d])
        check(rc == 1 and "directory" in err, f"dir: {rc} {err}")
        # a negative data length is corrupt framing, not an event: skipped up to the next one
        log = os.path.join(d, "neg.lcmlog")
        with open(log, "wb") as f:
            f.write(SYNC + struct.pack(">qqii", 0, 5, 3, -7) + b"abc")
            f.write(event(1, 10, "fleetsim/0/done", done(2, 4)))
        rc, out, err = run([TRAFFIC, log, "--totals-only"])
        check(rc == 0 and "31 bytes skipped" in out and "1 RoundComplete" in out, f"neg: {rc} {out} {err}")
    finally:
        shutil.rmtree(d)


# ---- fleet_report ----------------------------------------------------------------------------

def write_samples(path, xy_occ, box=(0.0, 0.0, 12.0, 9.0), seed=1):
    """A samples file as host_sim/sim_samples.h specifies (x, y normalised to [-1, 1])."""
    recs = np.asarray(xy_occ, dtype="<f4").tobytes()
    count = len(xy_occ)
    h = bytearray(208)
    h[0:8] = b"FSSAMPLE"
    struct.pack_into("<IIIIQ", h, 8, 1, 208, 12, 0, count)
    struct.pack_into("<4d", h, 32, *box)
    struct.pack_into("<Q", h, 64, seed)
    src = b"scan synthetic test"
    h[72:72 + len(src)] = src
    struct.pack_into("<I", h, 204, zlib.crc32(bytes(h[:204])))
    with open(path, "wb") as f:
        f.write(bytes(h) + recs + struct.pack("<I", zlib.crc32(recs)))


def synthetic_run(d, robots=2, rounds=12):
    rng = np.random.default_rng(3)
    with open(os.path.join(d, "run.json"), "w") as f:
        json.dump({"robots": robots, "seed": 1, "rounds": rounds, "mode": "offline", "strategy": "kl",
                   "radius_m": 6.0, "encoding": "fp32", "preset": "small",
                   "plan": "host_sim/plans/apartment.svg",
                   "paths": ["host_sim/plans/apartment/robot_0.csv", "no/such/tour.csv"],
                   "transport": "lcm", "lcm_url": "udpm://239.255.76.67:7667?ttl=0",
                   "version": "v0-test|pipe", "wall_s": 12.5, "started": "2024-01-01T00:00:00Z",
                   "host": "testhost"}, f)
    for i in range(robots):
        rd = os.path.join(d, f"robot_{i}")
        os.makedirs(rd)
        with open(os.path.join(rd, "metrics.csv"), "w") as f:
            f.write("round,sim_time_s,distance_m,progress_m,pool_fill,pool_capacity,ring_drops,train_loss,"
                    "bce,val_loss,kl,neighbours,disagreement,wall_s\n")
            for k in range(rounds):
                val = f"{0.7 * 0.8 ** k + 0.01 * i:.6f}" if k % 3 == 0 else "nan"
                f.write(f"{k},{0.1 * k:.1f},{0.2 * k:.2f},{0.2 * k:.2f},{100 * k},4096,0,{0.6 * 0.85 ** k:.6f},"
                        f"0.5,{val},0.001,{1 if k else 0},{'nan' if k == 0 else '0.01'},{0.05 * k:.2f}\n")
        with open(os.path.join(rd, "traffic.csv"), "w") as f:
            f.write("round,wall_ms,wait_ms,bytes_sent,bytes_received,chunks_sent,chunks_received,chunks_resent,"
                    "chunks_requested,duplicates,stale,timeouts,rejoins,crc_failures,invalid\n")
            for k in range(rounds):
                f.write(f"{k},5.0,1.0,{134404 + 100 * i},{134404},3,3,{k % 2},{k % 3 == 1:d},0,0,0,0,0,0\n")
        n = 600
        xy = rng.uniform(-1, 1, size=(n, 2))
        occ = (rng.random(n) < 0.4).astype(float)
        write_samples(os.path.join(rd, "train.samples"), np.column_stack([xy, occ]))
    m = os.path.join(d, "maps")
    os.makedirs(m)
    H, W = 18, 24
    yy, xx = np.mgrid[0:H, 0:W]
    mean = (((xx % 8) == 0) | ((yy % 6) == 0)).astype(np.float32) * 0.9 + 0.05
    np.save(os.path.join(m, "map_mean.npy"), mean)
    np.save(os.path.join(m, "map_std.npy"), (0.2 * rng.random((H, W))).astype(np.float32))
    np.save(os.path.join(m, "map_single.npy"), np.clip(mean + 0.1 * rng.standard_normal((H, W)), 0, 1).astype(np.float32))
    with open(os.path.join(m, "map_meta.json"), "w") as f:
        json.dump({"res": 0.5, "xmin": 0.0, "ymin": 0.0, "xmax": 12.0, "ymax": 9.0, "width": W, "height": H,
                   "mc": 50, "seed": 1, "std_max": 0.25, "models": robots, "occupied_thresh": 0.3431,
                   "free_thresh": 0.3392, "thresholds": "valset", "nav2_occupied": 70, "nav2_free": 340,
                   "nav2_unknown": 22, "nav2_wall_iou": 0.7712, "nav2_free_truly_free": 0.9851}, f)
    with open(os.path.join(m, "consensus.csv"), "w") as f:
        f.write("model,file,val_loss,consensus_error\n")
        for i in range(robots):
            f.write(f"{i},\"robot_{i}/final,\"\"x\"\".bnn\",{0.08 + 0.001 * i},{1e-4 * (i + 1)}\n")  # quoted
        f.write("consensus,consensus.ckpt,0.0777,0\n")
    with open(os.path.join(m, "map.pgm"), "wb") as f:
        f.write(b"P5\n24 18\n255\n" + bytes(H * W))
    with open(os.path.join(m, "map.yaml"), "w") as f:
        f.write("image: map.pgm\nmode: trinary\nresolution: 0.5\norigin: [0.0, 0.0, 0.0]\nnegate: 0\n"
                "# occupied_thresh and free_thresh chosen on the validation set\n"
                "occupied_thresh: 0.3431\nfree_thresh: 0.3392\n")


PNGS = ["map_mean.png", "map_std.png", "map_single.png", "kde.png", "val_loss.png", "traffic.png"]


def is_png(path):
    with open(path, "rb") as f:
        return f.read(8) == b"\x89PNG\r\n\x1a\n"


@test
def fleet_report_full_and_without_maps():
    d = tempfile.mkdtemp(prefix="reporttest.")
    try:
        synthetic_run(d)
        rc, out, err = run([REPORT, d])
        check(rc == 0, f"exit {rc}: {err}")
        for p in PNGS:
            check(os.path.isfile(os.path.join(d, p)) and is_png(os.path.join(d, p)), f"{p} missing")
        s = open(os.path.join(d, "summary.md")).read()
        for want in ["# Fleet run report", "| strategy | kl |", "| lcm_url |", "v0-test\\|pipe",
                     "](map_mean.png)", "](kde.png)", "](val_loss.png)", "](traffic.png)", "](map_std.png)",
                     "0.0777", "| 0.081 | 2.000e-04 |", "nav2_map_server", "yaml_filename:=maps/map.yaml", "12.5 s",
                     "occupied_thresh 0.3431, free_thresh 0.3392, chosen on the validation set",
                     "70 occupied, 340 free, 22 unknown cells", "wall IoU 0.771, 98.5 % of the free cells truly free"]:
            check(want in s, f"summary.md lacks {want!r}:\n{s}")
        check("scene.png" in s and "](scene.png)" not in s, "scene.png should be named missing")
        check(not [f for f in os.listdir(d) if f.endswith(".tmp")], "temporary files left")
        # final val loss of robot 1: last finite (round 9) = 0.7*0.8**9 + 0.01
        check(f"{0.7 * 0.8 ** 9 + 0.01:.4g} (9)" in s, "final val loss:\n" + s)

        # the same run without maps/ and with a scene: succeeds, says what is missing
        e = tempfile.mkdtemp(prefix="reporttest.")
        try:
            shutil.rmtree(os.path.join(d, "maps"))
            for p in PNGS + ["summary.md"]:
                os.unlink(os.path.join(d, p))
            shutil.copy(os.path.join(ROOT, "docs", "scene.png"), os.path.join(d, "scene.png")) \
                if os.path.isfile(os.path.join(ROOT, "docs", "scene.png")) else open(os.path.join(d, "scene.png"), "wb").close()
            rc, out, err = run([REPORT, "--quiet", d])
            check(rc == 0 and out == "", f"no maps: exit {rc}: {err} {out}")
            for p in ["kde.png", "val_loss.png", "traffic.png"]:
                check(os.path.isfile(os.path.join(d, p)), f"{p} missing without maps")
            for p in ["map_mean.png", "map_std.png", "map_single.png"]:
                check(not os.path.exists(os.path.join(d, p)), f"{p} made without maps")
            s = open(os.path.join(d, "summary.md")).read()
            check("map_mean.npy is missing" in s and "consensus.csv is missing" in s and "](scene.png)" in s,
                  "summary without maps:\n" + s)
            # an empty run folder: nothing to draw, still a summary
            rc, out, err = run([REPORT, "-q", e])
            check(rc == 0 and os.path.isfile(os.path.join(e, "summary.md")), f"empty: {rc} {err}")
        finally:
            shutil.rmtree(e)
    finally:
        shutil.rmtree(d)


@test
def fleet_report_malformed():
    d = tempfile.mkdtemp(prefix="reporttest.")
    try:
        synthetic_run(d, robots=2, rounds=4)
        with open(os.path.join(d, "robot_1", "metrics.csv"), "a") as f:
            f.write("4,0.4,1,1\n")
        rc, out, err = run([REPORT, d])
        check(rc == 1 and "robot_1/metrics.csv:6:" in err and len(err.strip().splitlines()) == 1,
              f"short row: {rc} {err}")
        check(not os.path.exists(os.path.join(d, "summary.md")), "summary.md written after an error")
        synthetic_run(d2 := tempfile.mkdtemp(prefix="reporttest."), robots=1, rounds=3)
        try:
            with open(os.path.join(d2, "run.json"), "w") as f:
                f.write("{not json")
            rc, out, err = run([REPORT, d2])
            check(rc == 1 and "run.json" in err and len(err.strip().splitlines()) == 1, f"json: {rc} {err}")
            os.unlink(os.path.join(d2, "run.json"))
            with open(os.path.join(d2, "robot_0", "train.samples"), "r+b") as f:
                f.seek(220)
                f.write(b"\x01\x02")
            rc, out, err = run([REPORT, d2])
            check(rc == 1 and "CRC" in err, f"samples: {rc} {err}")
        finally:
            shutil.rmtree(d2)
        rc, out, err = run([REPORT, os.path.join(d, "nope")])
        check(rc == 1 and "No such file" in err, f"missing dir: {rc} {err}")
        rc, out, err = run([REPORT, "--help"])
        check(rc == 0 and "RUN_DIR" in out, "--help")
    finally:
        shutil.rmtree(d)


if __name__ == "__main__":
    sys.exit(main())
