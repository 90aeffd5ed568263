#!/usr/bin/python3
"""Tests of tools/fleet_report.py's section "What the fleet knows": present, with the MC std and the
epistemic map side by side and tools/paper_metrics.py's table, when maps/ has map_epistemic.npy;
skipped cleanly (named under "Not in this report") when it does not; a malformed epistemic map
stops the report before summary.md is written. The run folder is synthetic: a 10 x 8 grid of
0.5 m and one robot's train.samples in the exact tools/samples.py format; the epistemic map is
fabricated from the distance to the samples (test data only, not a result).
Also what the fleet lost (tools/fleet_losses.py, the section "What the fleet lost"), on robot
folders fabricated in host_sim's formats: zero and non-zero totals, a robot resumed after a death
(traffic.csv's carried rows plus summary.txt's last start; its earlier queue drops uncounted), a
robot that wrote no summary.txt (traffic.csv only: at least), a robot alone (nothing exchanged).

    python3 tests/tools/test_fleet_report.py      prints "N passed, M failed", exit 1 on failure

Needs Debian's python3 with numpy, scipy and matplotlib (run again with /usr/bin/python3 when the
python3 found first lacks numpy).
"""
import os
import shutil
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.realpath(__file__)))
import samples_file  # noqa: E402
from minitest import check, main, need_numpy, test  # noqa: E402

np = need_numpy("test_fleet_report")

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.realpath(__file__))))
TOOL = os.path.join(ROOT, "tools", "fleet_report.py")
sys.path.insert(0, os.path.join(ROOT, "tools"))
import fleet_losses  # noqa: E402
H, W, RES = 8, 10, 0.5
BOX = (0.0, 0.0, W * RES, H * RES)
SECTION = "## What the fleet knows"


def write_samples(path, xy_m, occ, box):
    samples_file.write_samples(path, xy_m, occ, box, b"scan fleet_report test")


def synthetic_run(d):
    """RUN_DIR with maps/ (walls on the top row and the left column; the right column outside) and
    robot_0/train.samples: one point per cell centre of columns 0..4, hits on the walls."""
    run = os.path.join(d, "run")
    m = os.path.join(run, "maps")
    os.makedirs(m)
    os.makedirs(os.path.join(run, "robot_0"))
    truth = np.zeros((H, W), np.uint8)
    truth[0, :] = 1
    truth[:, 0] = 1
    truth[:, W - 1] = 255
    rng = np.random.default_rng(3)
    mean = np.clip(truth + rng.normal(0, 0.1, (H, W)), 0, 1).astype(np.float32)
    std = (np.where(np.arange(W)[None, :] < 5, 0.05, 0.3) * np.ones((H, 1))).astype(np.float32)
    np.save(os.path.join(m, "map_mean.npy"), mean)
    np.save(os.path.join(m, "map_std.npy"), std)
    np.save(os.path.join(m, "map_truth.npy"), truth)
    with open(os.path.join(m, "map_meta.json"), "w") as f:
        f.write('{"res": 0.5, "xmin": 0, "ymin": 0, "xmax": 5, "ymax": 4, "width": 10, "height": 8, '
                '"mc": 50, "seed": 1, "std_max": 0.3, "models": 1}\n')
    rows, cols = np.mgrid[0:H, 0:5]
    xy = np.column_stack([(cols.ravel() + 0.5) * RES, BOX[3] - (rows.ravel() + 0.5) * RES])
    write_samples(os.path.join(run, "robot_0", "train.samples"), xy,
                  truth[rows.ravel(), cols.ravel()].astype(np.float64), BOX)
    return run


def add_epistemic(run):
    """Fabricated: 1 - exp(-(distance to the nearest sample / 0.5 m)^2), floored at 0.01."""
    xc = (np.arange(W) + 0.5) * RES
    dist = np.maximum(xc - 2.25, 0.0)[None, :] * np.ones((H, 1))
    e = np.maximum(1 - np.exp(-(dist / 0.5) ** 2), 0.01).astype(np.float32)
    np.save(os.path.join(run, "maps", "map_epistemic.npy"), e)


def report(run):
    p = subprocess.run([sys.executable, TOOL, run, "--quiet"], capture_output=True, text=True, timeout=120)
    return p.returncode, p.stderr


def summary(run):
    with open(os.path.join(run, "summary.md"), encoding="utf-8") as f:
        return f.read()


@test
def section_skipped_without_epistemic():
    d = tempfile.mkdtemp(prefix="frtest.")
    try:
        run = synthetic_run(d)
        rc, err = report(run)
        check(rc == 0 and err == "", f"exit {rc}: {err}")
        s = summary(run)
        check(SECTION not in s and "AUC unseen/seen" not in s, "section without map_epistemic.npy")
        check("maps/map_epistemic.npy is missing" in s, "named under Not in this report")
        check("![map_std](map_std.png)" in s, "the other figures as before")
    finally:
        shutil.rmtree(d)


@test
def section_with_epistemic():
    d = tempfile.mkdtemp(prefix="frtest.")
    try:
        run = synthetic_run(d)
        add_epistemic(run)
        rc, err = report(run)
        check(rc == 0 and err == "", f"exit {rc}: {err}")
        s = summary(run)
        check(SECTION in s and s.index(SECTION) < s.index("## Figures"), "section before the figures")
        sec = s[s.index(SECTION):s.index("## Figures")]
        # the report draws maps/map_std.png and maps/map_epistemic.png itself (host_sim's are redrawn)
        check("| ![map_std](maps/map_std.png) | ![map_epistemic](maps/map_epistemic.png) |" in sec, sec)
        for name in ("map_mean.png", "map_std.png", "map_epistemic.png"):
            check(os.path.getsize(os.path.join(run, "maps", name)) > 1000, f"maps/{name} not drawn")
        check("| score | AUC unseen/seen | AUSE | Spearman vs KDE |" in sec, sec)
        table = sec[sec.index("| score |"):].split("\n\n")[0].splitlines()
        rows = table[2:]
        check(len(rows) == 3 and rows[0].startswith("| MC-50 std |") and rows[1].startswith("| epistemic")
              and rows[2].startswith("| distance"), sec)
        check(rows[1].split("|")[2].strip() == "1" and rows[2].split("|")[2].strip() == "1",
              f"AUC 1 for the epistemic and the distance: {rows}")
        check("within 0.15 m" in sec and "of the 72 cells" in sec and "55.6 %" in sec, sec)
        check("maps/map_epistemic.npy is missing" not in s, "not named missing")
        # with the epistemic object of map_meta.json
        meta = os.path.join(run, "maps", "map_meta.json")
        text = open(meta).read().rstrip().rstrip("}") + ', "epistemic": {"method": "test", "robots": 1}}\n'
        with open(meta, "w") as f:
            f.write(text)
        rc, err = report(run)
        check(rc == 0, err)
        sec = summary(run)
        check("| ![map_std](maps/map_std.png) | ![map_epistemic](maps/map_epistemic.png) |" in sec, sec)
        check("method test, robots 1" in sec, sec)
    finally:
        shutil.rmtree(d)


@test
def malformed_epistemic_stops():
    d = tempfile.mkdtemp(prefix="frtest.")
    try:
        run = synthetic_run(d)
        np.save(os.path.join(run, "maps", "map_epistemic.npy"), np.full((H, W), 2.0, np.float32))
        rc, err = report(run)
        check(rc == 1 and "map_epistemic.npy" in err and len(err.strip().splitlines()) == 1, f"{rc} {err}")
        check(not os.path.exists(os.path.join(run, "summary.md")), "no output before the inputs are checked")
        # no training samples: the section is skipped, named
        np.save(os.path.join(run, "maps", "map_epistemic.npy"), np.full((H, W), 0.5, np.float32))
        os.unlink(os.path.join(run, "robot_0", "train.samples"))
        rc, err = report(run)
        check(rc == 0 and SECTION not in summary(run) and "no scores of the epistemic map" in summary(run), err)
    finally:
        shutil.rmtree(d)


TRAFFIC_HEADER = ("round,wall_ms,wait_ms,bytes_sent,bytes_received,chunks_sent,chunks_received,chunks_resent,"
                  "chunks_requested,duplicates,stale,timeouts,rejoins,crc_failures,invalid,chunks_recovered,"
                  "chunks_lost,states_missed,rounds_skipped,beacons_sent,peer_restarts,old_incarnation\n")


def robot_folder(run, i, rounds=None, summary=None, resumed_at=0, fleet=3):
    """robot_<i>/ as host_sim run writes it: traffic.csv with rows {round: (timeouts, states_missed)}
    (None: no file) and summary.txt with (states_missed, timeouts, rx_dropped_full) of its last
    start (None: no file), "resumed: ..." when resumed_at > 0, the fleet lines when fleet > 1."""
    d = os.path.join(run, f"robot_{i}")
    os.makedirs(d, exist_ok=True)
    if rounds is not None:
        with open(os.path.join(d, "traffic.csv"), "w") as f:
            f.write(TRAFFIC_HEADER)
            for r, (t, m) in sorted(rounds.items()):
                f.write(f"{r},53.160,0.844,35685,107055,1,3,0,1,0,0,{t},0,0,0,1,0,{m},0,0,0,0\n")
    if summary is None:
        return
    states, timeouts, full = summary
    L = ["seed: 1", "preset: small (33601 parameters)", "incarnation: 1"]
    if resumed_at:
        L.append(f"resumed: from round_{resumed_at - 1:04d}.bnn (round {resumed_at - 1}), rounds {resumed_at} .. 39 "
                 "run by this start")
    if fleet > 1:
        L += [f"fleet: {fleet} robots (this is robot {i}, fleet id 25852), int8-ef states, radius 6 m",
              "nearest: at most 32 neighbour states per round; 23 chunks of peers beyond the radius or the nearest "
              "only placed their sender, 9 states given up for a nearer peer's",
              "losses: 1 chunks requested again, 0 re-sent; 0 duplicates, 16 stale, 0 invalid, 0 CRC failures; "
              f"{timeouts} peer timeouts, 0 rejoins; 246 own echoes",
              "faults survived: 0 chunks lost (never received), 1 recovered by a request; "
              f"{states} peer states gone without, 0 rounds cut short by a later round, 0 rounds skipped to catch "
              "up; 0 peer restarts seen, 0 messages of an earlier incarnation dropped",
              "waiting for peers: 7.70 s wall in all (192.59 ms per round); network queue drops "
              f"{full + 3} (queue full {full}, buffer too small 3); malformed datagrams dropped 0; sends refused 0"]
    L.append("process: 5.36 s CPU (user 4.95, system 0.41), peak RSS 85.6 MB")
    with open(os.path.join(d, "summary.txt"), "w") as f:
        f.write("\n".join(L) + "\n")


def losses(run, n=3):
    return fleet_losses.fleet_losses(run, range(n))


@test
def losses_zero():
    d = tempfile.mkdtemp(prefix="frtest.")
    try:
        run = synthetic_run(d)
        for i in range(3):
            robot_folder(run, i, {0: (0, 0), 1: (0, 0)}, (0, 0, 0))
        totals, gaps = losses(run)
        check(totals == {"states_given_up": 0, "peer_timeouts": 0, "queue_drops": 0} and gaps == [],
              f"{totals} {gaps}")
        check(fleet_losses.lossless(totals, gaps), "lossless")
        rc, err = report(run)
        check(rc == 0, err)
        s = summary(run)
        check("## What the fleet lost" in s and s.index("## What the fleet lost") < s.index("## Final figures"),
              "near the top")
        check("**A lossless run: over its 3 robots, no neighbour state was given up" in s, s)
    finally:
        shutil.rmtree(d)


@test
def losses_nonzero():
    """'states given up for a nearer peer's' (the nearest rule, not a loss) is not taken for one."""
    d = tempfile.mkdtemp(prefix="frtest.")
    try:
        run = synthetic_run(d)
        robot_folder(run, 0, {0: (0, 0), 1: (2, 3)}, (3, 2, 0))
        robot_folder(run, 1, {0: (0, 0), 1: (0, 1)}, (1, 0, 1500))
        robot_folder(run, 2, {0: (0, 0), 1: (0, 0)}, (0, 0, 0))
        totals, gaps = losses(run)
        check(totals == {"states_given_up": 4, "peer_timeouts": 2, "queue_drops": 1500} and gaps == [],
              f"{totals} {gaps}")
        check(fleet_losses.totals_text(totals, gaps) == "4 states given up, 2 peer timeouts, 1,500 datagrams "
              "dropped by full queues", fleet_losses.totals_text(totals, gaps))
        check(not fleet_losses.lossless(totals, gaps) and "NOT those of a lossless run" in
              fleet_losses.verdict(totals, gaps), "not lossless")
        drops = {"states_given_up": 0, "peer_timeouts": 0, "queue_drops": 7}  # re-sent: the states came whole
        check(not fleet_losses.lossless(drops, []) and "NOT" not in fleet_losses.verdict(drops, []) and
              "no state was given up" in fleet_losses.verdict(drops, []), fleet_losses.verdict(drops, []))
        rc, err = report(run)
        check(rc == 0, err)
        check("**4 states given up, 2 peer timeouts, 1,500 datagrams dropped by full queues (over 3 robots): the "
              "models are NOT those of a lossless run (nor the in-process reference's).**" in summary(run),
              summary(run))
    finally:
        shutil.rmtree(d)


@test
def losses_of_a_resumed_robot():
    """Robot 1 died and resumed at round 20: traffic.csv's rows of rounds < 20 (carried over from
    the start that died) add to summary.txt's figures of its last start; its earlier queue drops
    are written nowhere, so the totals are a lower bound and say so."""
    d = tempfile.mkdtemp(prefix="frtest.")
    try:
        run = synthetic_run(d)
        robot_folder(run, 0, {5: (1, 1), 25: (0, 0)}, (1, 1, 0))
        # rows 5 and 19 from the dead start, 25 from this one (its 2 states are in summary.txt)
        robot_folder(run, 1, {5: (1, 4), 19: (0, 1), 25: (0, 2)}, (2, 0, 10), resumed_at=20)
        totals, gaps = losses(run, 2)
        check(totals == {"states_given_up": 1 + 4 + 1 + 2, "peer_timeouts": 1 + 1, "queue_drops": 10},
              f"{totals}")
        check(len(gaps) == 1 and gaps[0].startswith("robot_1: the datagrams dropped by full queues of the start(s) "
                                                    "before its --resume at round 20"), f"{gaps}")
        check(not fleet_losses.lossless(totals, gaps) and
              fleet_losses.totals_text(totals, gaps).startswith("at least 8 states given up"), "at least")
        # the same robot without non-zero figures: still not known to be lossless
        robot_folder(run, 1, {5: (0, 0), 25: (0, 0)}, (0, 0, 0), resumed_at=20)
        robot_folder(run, 0, {5: (0, 0)}, (0, 0, 0))
        totals, gaps = losses(run, 2)
        check(not fleet_losses.lossless(totals, gaps) and "not known to be lossless" in
              fleet_losses.verdict(totals, gaps), f"{totals} {gaps}")
    finally:
        shutil.rmtree(d)


@test
def losses_without_summary_or_alone():
    d = tempfile.mkdtemp(prefix="frtest.")
    try:
        run = synthetic_run(d)
        robot_folder(run, 0, {0: (1, 2), 1: (0, 3)}, None)  # stopped before its summary.txt
        totals, gaps = losses(run, 1)
        check(totals == {"states_given_up": 5, "peer_timeouts": 1, "queue_drops": None} and
              gaps == ["robot_0: no summary.txt, counted from traffic.csv (at least)"], f"{totals} {gaps}")
        check(fleet_losses.totals_text(totals, gaps) == "at least 5 states given up, 1 peer timeouts, datagrams "
              "dropped by full queues: not known", fleet_losses.totals_text(totals, gaps))
        rc, err = report(run)
        check(rc == 0 and "- not counted whole: robot_0: no summary.txt" in summary(run), err)
        shutil.rmtree(os.path.join(run, "robot_0"))
        robot_folder(run, 0, None, (0, 0, 0), fleet=1)  # a fleet of one: no fleet lines, nothing exchanged
        totals, gaps = losses(run, 1)
        check(fleet_losses.lossless(totals, gaps), f"{totals} {gaps}")
    finally:
        shutil.rmtree(d)


# ---- figures: colour scales that fit the data, the occupied threshold, the strip -------------

def short_run_maps(run, peak=0.19, thresh=0.1):
    """The MC mean of a short run: every value far below 1 (peak), and map.yaml's occupied_thresh."""
    m = os.path.join(run, "maps")
    mean = np.load(os.path.join(m, "map_mean.npy")) * np.float32(peak)
    np.save(os.path.join(m, "map_mean.npy"), mean.astype(np.float32))
    np.save(os.path.join(m, "map_single.npy"), (mean * 0.9).astype(np.float32))
    with open(os.path.join(m, "map.yaml"), "w") as f:
        f.write(f"image: map.pgm\nmode: trinary\nresolution: 0.5\norigin: [0, 0, 0.0]\nnegate: 0\n"
                f"occupied_thresh: {thresh}\nfree_thresh: 0.05\n")
    return mean


def load_run(run):
    import fleet_report
    r = fleet_report.Run(np, run)
    r.load()
    return fleet_report, r


@test
def map_colours_fit_the_data_and_threshold_contour():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import fleet_figures
    d = tempfile.mkdtemp(prefix="frtest.")
    try:
        run = synthetic_run(d)
        mean = short_run_maps(run)
        _, r = load_run(run)
        fig, info = fleet_figures.map_figure(plt, r, "mean", r.maps["mean"])
        ax = fig.axes[0]
        lo, hi = ax.images[0].get_clim()
        check(lo == 0.0 and abs(hi - float(mean.max())) < 1e-6 and hi < 0.25, f"colours {lo}..{hi}, max {mean.max()}")
        check(info["clim"] == (lo, hi), f"{info}")
        cs = info["contour"]
        check(cs is not None and list(cs.levels) == [0.1], "occupied_thresh contour")
        check(any(len(p.vertices) > 1 for c in cs.collections for p in c.get_paths()), "contour drawn")
        leg = ax.get_legend()
        check(leg is not None and any("occupied_thresh 0.1" in t.get_text() for t in leg.get_texts()), "legend")
        # outside the map: the legend's box is below the axes
        fig.canvas.draw()
        lb, ab = leg.get_window_extent(), ax.get_window_extent()
        check(lb.y1 <= ab.y0, f"legend {lb} over the axes {ab}")
        cb = fig.axes[1].get_ylabel()
        check("P(occupied)" in cb and f"{float(mean.max()):.3g}" in cb, cb)
        plt.close(fig)
        # the single pass: the quantity in the colour bar, "one stochastic pass" in the title only
        fig, info = fleet_figures.map_figure(plt, r, "single", r.maps["single"])
        check(fig.axes[1].get_ylabel().startswith("P(occupied)") and "stochastic" not in fig.axes[1].get_ylabel()
              and "one stochastic pass" in fig.axes[0].get_title() and info["contour"] is None, "map_single")
        plt.close(fig)
        # the std's colours fit too; a threshold no cell reaches draws no contour
        fig, info = fleet_figures.map_figure(plt, r, "std", r.maps["std"])
        check(info["clim"] == (0.0, float(np.load(os.path.join(run, "maps", "map_std.npy")).max())), f"{info}")
        plt.close(fig)
        short_run_maps(run, peak=1.0, thresh=0.99)
        _, r = load_run(run)
        fig, info = fleet_figures.map_figure(plt, r, "mean", np.zeros((H, W)))
        check(info["contour"] is None and info["clim"] == (0.0, 1.0), f"{info}")
        plt.close(fig)
    finally:
        shutil.rmtree(d)


@test
def figures_written_with_units():
    """Every figure file written (the maps/ ones redrawn), one colour map per quantity."""
    d = tempfile.mkdtemp(prefix="frtest.")
    try:
        run = synthetic_run(d)
        add_epistemic(run)
        short_run_maps(run)
        with open(os.path.join(run, "maps", "map_meta.json")) as f:
            meta = f.read().replace('"std_max": 0.3', '"std_max": 0.17980554699897766')
        with open(os.path.join(run, "maps", "map_meta.json"), "w") as f:
            f.write(meta)
        rc, err = report(run)
        check(rc == 0 and err == "", f"exit {rc}: {err}")
        for name in ("map_mean.png", "map_std.png", "map_single.png", "kde.png", "maps/map_mean.png",
                     "maps/map_std.png", "maps/map_epistemic.png"):
            f = os.path.join(run, name)
            check(os.path.isfile(f) and os.path.getsize(f) > 1000, f"{name} not written")
        s = summary(run)
        check("std_max 0.18," in s and "0.1798055" not in s, "std_max to 3 significant digits")
        check("no round checkpoint" in s, "the strip's absence named")
    finally:
        shutil.rmtree(d)


@test
def strip_of_kept_checkpoints():
    """map_rounds.png from the rounds every robot kept, evenly spaced, each made by host_sim maps
    (here a stand-in that writes a map_mean.npy whose values are the round / 1000)."""
    import fleet_figures
    check(fleet_figures.pick_evenly([29, 59, 89, 113, 115, 117, 119], 4) == [29, 59, 89, 119],
          fleet_figures.pick_evenly([29, 59, 89, 113, 115, 117, 119], 4))
    check(fleet_figures.pick_evenly([5, 6], 4) == [5, 6] and fleet_figures.pick_evenly([1, 2, 3], 1) == [3], "few")
    d = tempfile.mkdtemp(prefix="frtest.")
    try:
        run = synthetic_run(d)
        os.makedirs(os.path.join(run, "robot_1"))
        for i, rounds in ((0, (9, 19, 29, 39, 41)), (1, (9, 19, 29, 39, 40, 41))):
            for k in rounds:
                open(os.path.join(run, f"robot_{i}", f"round_{k:04d}.bnn"), "wb").close()
        with open(os.path.join(run, "plan.svg"), "w") as f:
            f.write("<svg/>\n")
        with open(os.path.join(run, "run.json"), "w") as f:
            f.write('{"robots": 2, "plan": "plan.svg"}\n')
        fake = os.path.join(d, "host_sim")
        with open(fake, "w") as f:
            f.write(f"#!{sys.executable}\nimport os, re, sys\nimport numpy as np\n"
                    "a = sys.argv\nout = a[a.index('--out') + 1]\nos.makedirs(out, exist_ok=True)\n"
                    "k = int(re.search(r'round_(\\d+)', a[-1]).group(1))\n"
                    f"np.save(os.path.join(out, 'map_mean.npy'), np.full(({H}, {W}), k / 1000, np.float32))\n")
        os.chmod(fake, 0o755)
        check(fleet_figures.checkpoint_rounds(load_run(run)[1]) == [9, 19, 29, 39, 41], "common rounds")
        p = subprocess.run([sys.executable, TOOL, run, "--quiet", "--host-sim", fake], capture_output=True,
                           text=True, timeout=120)
        check(p.returncode == 0 and p.stderr == "", p.stderr)
        for k in (9, 19, 29, 41):
            a = np.load(os.path.join(run, "maps", "rounds", f"round_{k:04d}", "map_mean.npy"))
            check(abs(float(a[0, 0]) - k / 1000) < 1e-6, f"round {k}")
        check(not os.path.exists(os.path.join(run, "maps", "rounds", "round_0039")), "4 rounds only")
        check(os.path.getsize(os.path.join(run, "map_rounds.png")) > 1000 and
              "![map_rounds](map_rounds.png)" in summary(run), "map_rounds.png in summary.md")
        # a host_sim that fails: named, no strip, the rest of the report written
        shutil.rmtree(os.path.join(run, "maps", "rounds"))
        p = subprocess.run([sys.executable, TOOL, run, "--quiet", "--host-sim", "/bin/false"], capture_output=True,
                           text=True, timeout=120)
        check(p.returncode == 0 and "host_sim maps of round 9 failed" in summary(run), p.stderr)
    finally:
        shutil.rmtree(d)


@test
def traffic_requested_and_resent_both_visible():
    """Identical requested and re-sent counts: the legend says they coincide, both lines drawn
    (the re-sent one dashed, with markers where it is not 0)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import fleet_figures
    d = tempfile.mkdtemp(prefix="frtest.")
    try:
        class Run:
            pass
        r = Run()
        r.np = np
        r.note = lambda t: None
        z = np.zeros(4)
        r.traffic = {0: {"round": np.arange(4.0), "bytes_sent": np.full(4, 5000.0), "chunks_requested":
                         np.array([3.0, 0, 1, 0]), "chunks_resent": np.array([3.0, 0, 1, 0]), "timeouts": z}}
        shown = []
        real_save = fleet_figures.save_fig
        fleet_figures.save_fig = lambda plt_, fig, path: (shown.append(fig), real_save(plt_, fig, path))
        try:
            check(fleet_figures.fig_traffic(plt, r, d) == "traffic.png", "no traffic.png")
        finally:
            fleet_figures.save_fig = real_save
        ax = shown[0].axes[1]
        texts = [t.get_text() for t in ax.get_legend().get_texts()]
        check(any("the same as re-sent" in t for t in texts) and any("on the requested line" in t for t in texts), texts)
        lines = {l.get_label(): l for l in ax.get_lines()}
        check(len(lines) == 2 and len({l.get_linestyle() for l in lines.values()}) == 2, f"{lines}")
        check(ax.get_xlabel() and ax.get_ylabel().endswith("(count)"), "units")
        check(os.path.getsize(os.path.join(d, "traffic.png")) > 1000, "file")
    finally:
        shutil.rmtree(d)


if __name__ == "__main__":
    sys.exit(main())
