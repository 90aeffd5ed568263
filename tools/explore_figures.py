#!/usr/bin/python3
"""The figures of one exploration run (`host_sim run --explore`, `tools/fleet --explore`), written
into its folder:

  explore.gif              the fleet exploring, a frame every few simulated seconds (--frames, about
                           60): the plan's walls (coverage.bin's not-free cells), the free space
                           seen so far (coverage.bin's first-seen times), each robot's trail,
                           position and current goal (robot_<i>/explore.csv); beside it, per DiNNO
                           round, the consensus map of the robots' round_NNNN.bnn checkpoints
                           (`host_sim maps`, rendered once per round in a temporary folder): its
                           occupancy (MC mean) and its uncertainty (the epistemic share of the
                           prior variance left when the checkpoints carry a posterior, else the MC
                           standard deviation). A round's map is shown from the simulated time
                           its row in robot_0/metrics.csv gives (a checkpoint with no row: from
                           the end of the run).
  explore_first_frame.png  the GIF's first frame (for a README)
  explore_coverage.png     coverage of the fleet (coverage.csv) and of each robot alone
                           (robot_<i>/coverage.csv) against robot-seconds and against simulated time

    tools/explore_figures.py RUN_DIR [--plan P] [--bin host_sim] [--no-maps] [--frames N] [--mc K]

--plan defaults to run.json's plan, --bin to run.json's host_sim (else build/bin/host_sim); both
are needed for the map panels only (--no-maps, or no round checkpoints: the exploration panel
alone). Prints one line per file written; a missing or invalid input stops it with one line on
stderr and exit 1. Each file is written whole or not at all (fleet_io.write_atomic).
"""
import argparse
import math
import os
import shutil
import struct
import sys
import tempfile
import zlib

TOOLS_DIR = os.path.dirname(os.path.realpath(__file__))
sys.path.insert(0, TOOLS_DIR)
from fleet_io import ReportError, load_npy, resolve_tour, round_map, write_atomic  # noqa: E402
from fleet_report import read_csv, read_json_object  # noqa: E402  (the report's checked readers)
from fleet_figures import checkpoint_rounds, colour_limits, draw_coverage, pick_evenly, save_fig  # noqa: E402
from palette import quantity_cmap, robot_colour  # noqa: E402
sys.path.pop(0)

PROG = "explore_figures"
COVERAGE_MAGIC = b"FSCOVBIN"      # host_sim/world/sim_coverage.h
COVERAGE_VERSION = 1
COVERAGE_HEADER = struct.Struct("<8sIIIIddddQ")  # magic, version, w, h, crc32, res, ox, oy, t_end, free
COVERAGE_NOT_FREE = -1.0
COVERAGE_NEED = ("sim_time_s", "robot_seconds", "coverage")
EXPLORE_NEED = ("sim_time_s", "x_m", "y_m", "goal_x_m", "goal_y_m")
MAX_MAP_ROUNDS = 40               # rounds rendered at most (evenly picked beyond)
GIF_DPI = 80
GIF_MAX_BYTES = 5 << 20

# Exploration panel colours (RGB in [0, 1]): unlike every robot colour (tools/palette.py).
WALL_RGB = (0.12, 0.12, 0.12)
OUTSIDE_RGB = (0.62, 0.62, 0.62)
UNSEEN_RGB = (0.84, 0.84, 0.84)
SEEN_RGB = (1.0, 1.0, 1.0)


# ---- reading ---------------------------------------------------------------------------------

def read_coverage_bin(np, path):
    """coverage.bin (host_sim/world/sim_coverage.h), checked as host_sim reads it. Returns a dict:
    first_seen (h, w) float32 with rows growing with y, res, origin (x, y), t_end, n_free."""
    try:
        with open(path, "rb") as f:
            b = f.read()
    except OSError as e:
        raise ReportError(f"{path}: {e.strerror or e}")
    if len(b) < COVERAGE_HEADER.size:
        raise ReportError(f"{path}: {len(b)} bytes, shorter than the {COVERAGE_HEADER.size}-byte header")
    magic, ver, w, h, crc, res, ox, oy, t_end, n_free = COVERAGE_HEADER.unpack_from(b)
    if magic != COVERAGE_MAGIC:
        raise ReportError(f"{path}: not a coverage file (magic {magic!r})")
    if ver != COVERAGE_VERSION:
        raise ReportError(f"{path}: version {ver}, this tool reads {COVERAGE_VERSION}")
    if w < 1 or h < 1:
        raise ReportError(f"{path}: {w} x {h} cells")
    if len(b) != COVERAGE_HEADER.size + 4 * w * h:
        raise ReportError(f"{path}: {len(b)} bytes, expected {COVERAGE_HEADER.size + 4 * w * h} for {w} x {h} cells")
    cells = b[COVERAGE_HEADER.size:]
    if zlib.crc32(cells) & 0xFFFFFFFF != crc:
        raise ReportError(f"{path}: CRC mismatch (the cells are damaged)")
    if not (math.isfinite(res) and res > 0 and math.isfinite(ox) and math.isfinite(oy)
            and math.isfinite(t_end) and t_end >= 0):
        raise ReportError(f"{path}: bad header (res {res}, origin ({ox}, {oy}), t_end {t_end})")
    a = np.frombuffer(cells, dtype="<f4").reshape(h, w).astype(np.float32)
    if np.isnan(a).any():
        raise ReportError(f"{path}: a NaN first-seen time")
    free = a != COVERAGE_NOT_FREE
    if (a[free] < 0).any():
        raise ReportError(f"{path}: a negative first-seen time other than -1 (not free)")
    fin = a[free & np.isfinite(a)]
    if fin.size and float(fin.max()) > t_end:
        raise ReportError(f"{path}: a cell first seen after t_end {t_end:g} s")
    if int(free.sum()) != n_free:
        raise ReportError(f"{path}: {int(free.sum())} free cells, the header says {n_free}")
    return {"first_seen": a, "res": res, "origin": (ox, oy), "t_end": t_end, "n_free": n_free, "w": w, "h": h}


def read_coverage_csv(np, path):
    """coverage.csv: {column: array}, coverage in [0, 1] never falling, time rising."""
    c = {k: np.asarray(v, dtype=float) for k, v in read_csv(path, COVERAGE_NEED).items()}
    v = c["coverage"]
    if v.size == 0:
        raise ReportError(f"{path}: no rows")
    if not (np.all(np.isfinite(v)) and v.min() >= 0 and v.max() <= 1):
        raise ReportError(f"{path}: a coverage outside [0, 1]")
    if np.any(np.diff(v) < 0) or np.any(np.diff(c["sim_time_s"]) <= 0):
        raise ReportError(f"{path}: coverage falls or time does not rise")
    return c


def read_explore_csv(np, path):
    c = {k: np.asarray(v, dtype=float) for k, v in read_csv(path, EXPLORE_NEED).items()}
    if c["sim_time_s"].size == 0:
        raise ReportError(f"{path}: no rows")
    t = c["sim_time_s"]
    if not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
        raise ReportError(f"{path}: sim_time_s is not finite and rising")
    if not (np.all(np.isfinite(c["x_m"])) and np.all(np.isfinite(c["y_m"]))):
        raise ReportError(f"{path}: a position that is not finite")
    return c


class ExploreRun:
    """The inputs of the figures, read and checked."""

    def __init__(self, np, run_dir, plan=None, host_sim=None):
        self.np, self.dir = np, run_dir
        if not os.path.isdir(run_dir):
            raise ReportError(f"{run_dir}: not a directory")
        self.settings = read_json_object(self.p("run.json"))
        n = self.settings.get("robots")
        if not isinstance(n, int) or isinstance(n, bool) or n < 1:
            raise ReportError(f"{self.p('run.json')}: \"robots\" is not a count >= 1")
        self.robots = list(range(n))
        e = self.settings.get("explore")
        self.policy = e.get("policy") if isinstance(e, dict) else None
        self.time_s = e.get("time_s") if isinstance(e, dict) else None
        self.cov = read_coverage_bin(np, self.p("coverage.bin"))
        self.coverage = read_coverage_csv(np, self.p("coverage.csv")) if os.path.isfile(self.p("coverage.csv")) else None
        self.robot_coverage, self.explore = {}, {}
        for i in self.robots:
            f = self.p(f"robot_{i}", "explore.csv")
            if not os.path.isfile(f):
                raise ReportError(f"{f}: missing (run.json has {n} robots; is this an exploration run?)")
            self.explore[i] = read_explore_csv(np, f)
            f = self.p(f"robot_{i}", "coverage.csv")
            if os.path.isfile(f):
                self.robot_coverage[i] = read_coverage_csv(np, f)
        self.plan = plan if plan is not None else self.settings.get("plan")
        self.host_sim = host_sim if host_sim is not None else self.settings.get("host_sim")

    def p(self, *parts):
        return os.path.join(self.dir, *parts)

    def round_times(self):
        """{round: simulated time of its end} from robot_0/metrics.csv (an empty dict without)."""
        f = self.p("robot_0", "metrics.csv")
        if not os.path.isfile(f):
            return {}
        m = read_csv(f, ("round", "sim_time_s"))
        return {int(r): t for r, t in zip(m["round"], m["sim_time_s"]) if math.isfinite(t)}


# ---- the per-round consensus maps ------------------------------------------------------------

def round_maps(run, tmp, mc, seed, note):
    """[(time_s, round, occupancy, uncertainty, kind)] sorted by time, kind "epistemic" or "std",
    rendered by `host_sim maps` into tmp; [] (and a note) when they cannot be made."""
    np = run.np
    rounds = checkpoint_rounds(run)
    if not rounds:
        note("no round checkpoints (robot_<i>/round_NNNN.bnn) kept by every robot: no map panels")
        return [], None
    plan = resolve_tour(run.plan, run.dir) if isinstance(run.plan, str) else None
    if plan is None:
        raise ReportError(f"plan {run.plan!r} not found (--plan; needed for the map panels, or --no-maps)")
    exe = None
    for cand in ([run.host_sim] if isinstance(run.host_sim, str) else []) + ["build/bin/host_sim"]:
        q = resolve_tour(cand, run.dir)
        if q is not None and os.access(q, os.X_OK):
            exe = q
            break
    if exe is None:
        raise ReportError("no host_sim binary for the map panels (--bin, run.json's host_sim, build/bin/host_sim; "
                          "or --no-maps)")
    if len(rounds) > MAX_MAP_ROUNDS:
        rounds = pick_evenly(rounds, MAX_MAP_ROUNDS)
    times = run.round_times()
    t_end = run.cov["t_end"]
    out, meta = [], None
    for r in rounds:
        d = os.path.join(tmp, f"round_{r:04d}")
        models = [run.p(f"robot_{i}", f"round_{r:04d}.bnn") for i in run.robots]
        why = round_map(exe, plan, models, d, run.cov["res"], mc, seed)
        if why is not None:
            raise ReportError(f"host_sim maps of round {r} {why}")
        occ = load_npy(np, os.path.join(d, "map_mean.npy"))
        epi = os.path.join(d, "map_epistemic.npy")
        unc, kind = (load_npy(np, epi), "epistemic") if os.path.isfile(epi) else \
            (load_npy(np, os.path.join(d, "map_std.npy")), "std")
        if meta is None:
            meta = read_json_object(os.path.join(d, "map_meta.json"))
            truth = os.path.join(d, "map_truth.npy")
            meta["truth"] = np.load(truth, allow_pickle=False) if os.path.isfile(truth) else None
        out.append((min(times.get(r, t_end), t_end), r, occ, unc, kind))
    kinds = {k for *_, k in out}
    if len(kinds) > 1:  # some rounds carry a posterior, some not: one quantity for every frame
        out = [(t, r, o, load_npy(np, os.path.join(tmp, f"round_{r:04d}", "map_std.npy")), "std")
               for t, r, o, _, _ in out]
    out.sort(key=lambda x: (x[0], x[1]))
    return out, meta


# ---- figures ---------------------------------------------------------------------------------

def frame_times(np, t_end, frames):
    """About `frames` simulated times from 0 to t_end, a whole number of seconds apart, t_end last."""
    step = max(1.0, round(t_end / max(1, frames)))
    ts = list(np.arange(0.0, t_end, step))
    if not ts or ts[-1] < t_end:
        ts.append(t_end)
    return ts


def background(np, run, truth):
    """(h, w, 3) float colours of the classes that do not change: walls/outside; free cells are
    filled per frame. truth: host_sim maps' map_truth.npy (row 0 the top) or None."""
    fs = run.cov["first_seen"]
    rgb = np.empty(fs.shape + (3,), dtype=np.float32)
    rgb[:] = UNSEEN_RGB
    rgb[fs == COVERAGE_NOT_FREE] = WALL_RGB
    if truth is not None and truth.shape == fs.shape:
        rgb[np.flipud(truth) == 255] = OUTSIDE_RGB  # outside the building: not a wall
    return rgb


def draw_frames(plt, run, maps, meta, frames):
    """The frames as PIL images (RGB), and the simulated times they show."""
    np = run.np
    from PIL import Image
    from matplotlib.colors import LogNorm
    from matplotlib.lines import Line2D
    cov = run.cov
    fs = cov["first_seen"]
    ox, oy = cov["origin"]
    ext = [ox, ox + cov["w"] * cov["res"], oy, oy + cov["h"] * cov["res"]]
    t_last = max(cov["t_end"], max(float(e["sim_time_s"][-1]) for e in run.explore.values()))
    ts = frame_times(np, t_last, frames)
    bg = background(np, run, meta.get("truth") if meta else None)
    free = fs != COVERAGE_NOT_FREE
    aspect = (ext[3] - ext[2]) / (ext[1] - ext[0])
    if maps:
        fig = plt.figure(figsize=(10.5, max(4.2, 5.2 * aspect + 1.4)))
        gs = fig.add_gridspec(2, 2, width_ratios=[1.7, 1.0], left=0.06, right=0.95, bottom=0.14, top=0.88,
                              wspace=0.18, hspace=0.3)
        ax = fig.add_subplot(gs[:, 0])
        am, au = fig.add_subplot(gs[0, 1]), fig.add_subplot(gs[1, 1])
    else:
        fig = plt.figure(figsize=(7.0, max(4.0, 6.0 * aspect + 1.2)))
        ax = fig.add_axes([0.1, 0.16, 0.85, 0.72])
        am = au = None
    img = ax.imshow(bg, extent=ext, origin="lower", interpolation="nearest")
    trails, dots, goals, links = {}, {}, {}, {}
    for i in run.robots:
        c = robot_colour(i)
        trails[i], = ax.plot([], [], "-", lw=1.1, color=c, alpha=0.85)
        dots[i], = ax.plot([], [], "o", ms=6, color=c, mec="black", mew=0.6)
        links[i], = ax.plot([], [], ":", lw=1.0, color=c)
        goals[i], = ax.plot([], [], "X", ms=7, color=c, mec="black", mew=0.6)
    ax.set_xlim(ext[0], ext[1])
    ax.set_ylim(ext[2], ext[3])
    ax.set_xlabel("x (m)", fontsize=8)
    ax.set_ylabel("y (m)", fontsize=8)
    ax.tick_params(labelsize=7)
    handles = [Line2D([], [], color=robot_colour(i), marker="o", lw=1.1, label=f"robot {i}") for i in run.robots]
    handles += [Line2D([], [], ls="", marker="X", color="0.4", mec="black", label="its goal"),
                Line2D([], [], ls="", marker="s", color=SEEN_RGB, mec="0.5", label="seen"),
                Line2D([], [], ls="", marker="s", color=UNSEEN_RGB, mec="0.5", label="not seen yet"),
                Line2D([], [], ls="", marker="s", color=WALL_RGB, label="wall")]
    if (bg == np.asarray(OUTSIDE_RGB, dtype=np.float32)).all(axis=2).any():
        handles.append(Line2D([], [], ls="", marker="s", color=OUTSIDE_RGB, label="outside the plan's rooms"))
    fig.legend(handles=handles, loc="lower center", ncol=min(len(handles), 8), fontsize=8, frameon=False,
               handlelength=1.6, columnspacing=1.2)
    title = ax.set_title("", fontsize=9)
    mimg = uimg = None
    if maps:
        mext = [meta["xmin"], meta["xmax"], meta["ymin"], meta["ymax"]]
        top = max(colour_limits(np, o)[1] for _, _, o, _, _ in maps)
        blank = np.full_like(maps[0][2], np.nan)
        mimg = am.imshow(blank, extent=mext, origin="upper", cmap=quantity_cmap("occupancy"), vmin=0, vmax=top,
                         interpolation="nearest")
        kind = maps[0][4]
        if kind == "epistemic":
            e = meta.get("epistemic")
            floor = e.get("png_floor") if isinstance(e, dict) else None
            floor = floor if isinstance(floor, (int, float)) and floor > 0 else 1e-6
            uimg = au.imshow(blank, extent=mext, origin="upper", cmap=quantity_cmap("epistemic"),
                             norm=LogNorm(vmin=floor, vmax=1.0), interpolation="nearest")
            ulabel = "prior variance left\n(log; 1 = unseen)"
        else:
            utop = max(colour_limits(np, u)[1] for _, _, _, u, _ in maps)
            uimg = au.imshow(blank, extent=mext, origin="upper", cmap=quantity_cmap("std"), vmin=0, vmax=utop,
                             interpolation="nearest")
            ulabel = "MC std of P(occupied)"
        fig.colorbar(mimg, ax=am, shrink=0.9).set_label("P(occupied)", fontsize=7)
        fig.colorbar(uimg, ax=au, shrink=0.9).set_label(ulabel, fontsize=7)
        for a in (am, au):
            a.tick_params(labelsize=6)
            a.set_xlim(mext[0], mext[1])
            a.set_ylim(mext[2], mext[3])
        mtitle = am.set_title("", fontsize=8)
        utitle = au.set_title("", fontsize=8)
    sup = fig.suptitle("", fontsize=10)
    policy = run.policy or "?"
    n_free = max(1, cov["n_free"])
    images = []
    for t in ts:
        rgb = bg.copy()
        seen = free & (fs <= t)
        rgb[seen] = SEEN_RGB
        img.set_data(rgb)
        for i, e in run.explore.items():
            k = max(0, int(np.searchsorted(e["sim_time_s"], t, side="right")) - 1)
            x, y = e["x_m"][:k + 1], e["y_m"][:k + 1]
            trails[i].set_data(x, y)
            dots[i].set_data([x[-1]], [y[-1]])
            gx, gy = e["goal_x_m"][k], e["goal_y_m"][k]
            if math.isfinite(gx) and math.isfinite(gy) and e["sim_time_s"][k] <= t + 1e-9:
                goals[i].set_data([gx], [gy])
                links[i].set_data([x[-1], gx], [y[-1], gy])
            else:
                goals[i].set_data([], [])
                links[i].set_data([], [])
        share = int(seen.sum()) / n_free
        sup.set_text(f"exploration ({policy}), {len(run.robots)} robots: t = {t:.0f} s simulated, "
                     f"{len(run.robots) * t:.0f} robot-s")
        title.set_text(f"free space seen: {100 * share:.1f} %")
        if maps:
            cur = [m for m in maps if m[0] <= t + 1e-9]
            if cur:
                _, r, o, u, kind = cur[-1]
                mimg.set_data(o)
                uimg.set_data(np.where(u > 0, u, np.nan) if kind == "epistemic" else u)
                mtitle.set_text(f"consensus map, round {r}: occupancy")
                utitle.set_text(f"round {r}: " + ("what the fleet has not seen" if kind == "epistemic"
                                                  else "uncertainty (MC std)"))
            else:
                mimg.set_data(np.full_like(maps[0][2], np.nan))
                uimg.set_data(np.full_like(maps[0][2], np.nan))
                mtitle.set_text("consensus map: no round yet")
                utitle.set_text(f"first round at {maps[0][0]:.0f} s")
        fig.canvas.draw()
        a = np.asarray(fig.canvas.buffer_rgba())[:, :, :3]
        images.append(Image.fromarray(a.copy()))
    plt.close(fig)
    return images, ts


def write_gif(images, path, frame_ms=150, hold_ms=2000):
    """One palette for every frame (made from a few frames side by side), so that what did not
    change is the same bytes and Pillow stores each frame as its changed box only."""
    from PIL import Image
    picks = sorted({0, len(images) // 3, 2 * len(images) // 3, len(images) - 1})
    w, h = images[0].size
    sheet = Image.new("RGB", (w, h * len(picks)))
    for k, i in enumerate(picks):
        sheet.paste(images[i], (0, h * k))
    pal = sheet.quantize(colors=255, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE)
    frames = [im.quantize(palette=pal, dither=Image.Dither.NONE) for im in images]
    durations = [frame_ms] * len(frames)
    durations[-1] = hold_ms
    write_atomic(path, lambda f: frames[0].save(f, format="GIF", save_all=True, append_images=frames[1:],
                                                duration=durations, loop=0, optimize=False, disposal=1))


def fig_explore_coverage(plt, run, out):
    if run.coverage is None and not run.robot_coverage:
        raise ReportError(f"{run.p('coverage.csv')}: missing, and no robot_<i>/coverage.csv")
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 5.0))
    fig.subplots_adjust(left=0.07, right=0.98, top=0.86, bottom=0.22, wspace=0.22)
    n = draw_coverage(a1, run.coverage, run.robot_coverage, x="robot_seconds")
    draw_coverage(a2, run.coverage, run.robot_coverage, x="sim_time_s")
    a1.set_title("against robot-seconds (what the fleet spent)", fontsize=10)
    a2.set_title("against simulated time", fontsize=10)
    h, labels = a2.get_legend_handles_labels()
    fig.legend(h, labels, loc="lower center", ncol=min(n, 4), fontsize=8, frameon=False)
    fig.suptitle(f"coverage of the free space, exploration policy {run.policy or '?'}, {len(run.robots)} robots",
                 fontsize=11)
    name = os.path.join(out, "explore_coverage.png")
    save_fig(plt, fig, name)
    return name


# ---- main ------------------------------------------------------------------------------------

class Parser(argparse.ArgumentParser):
    def error(self, message):  # a bad command line is an invalid input: exit 1 like the others
        self.print_usage(sys.stderr)
        print(f"{PROG}: {message}", file=sys.stderr)
        sys.exit(1)


def human(n):
    return f"{n / 1e6:.2f} MB" if n >= 1e5 else f"{n / 1e3:.0f} kB"


def main(argv=None):
    ap = Parser(prog="explore_figures.py", description=__doc__.split("\n\n")[0],
                epilog=__doc__.split("\n\n", 1)[1], formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("run_dir", metavar="RUN_DIR", help="an exploration run's folder (run.json, coverage.bin, robot_<i>/)")
    ap.add_argument("--plan", help="the floor plan (default: run.json's plan)")
    ap.add_argument("--bin", help="host_sim for the map panels (default: run.json's host_sim, else build/bin/host_sim)")
    ap.add_argument("--no-maps", action="store_true", help="the exploration panel only (no host_sim maps)")
    ap.add_argument("--frames", type=int, default=60, help="about this many frames (default 60; 2 .. 400)")
    ap.add_argument("--mc", type=int, default=10, help="MC passes of each round's map (default 10)")
    ap.add_argument("--seed", type=int, default=1, help="the maps' seed (default 1)")
    a = ap.parse_args(argv)
    if not 2 <= a.frames <= 400:
        ap.error("--frames must be 2 .. 400")
    if a.mc < 1:
        ap.error("--mc must be >= 1")
    try:
        import numpy as np
    except ImportError:
        print(f"{PROG}: needs numpy (Debian python3-numpy; tools/install-deps.sh)", file=sys.stderr)
        return 1
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        import PIL  # noqa: F401
    except ImportError as e:
        print(f"{PROG}: needs matplotlib and Pillow (Debian python3-matplotlib python3-pil; "
              f"tools/install-deps.sh): {e}", file=sys.stderr)
        return 1
    try:
        run = ExploreRun(np, a.run_dir, plan=a.plan, host_sim=a.bin)
        maps, meta = [], None
        if not a.no_maps:
            tmp = tempfile.mkdtemp(prefix="explore_maps.")
            try:
                maps, meta = round_maps(run, tmp, a.mc, a.seed, lambda s: print(f"{PROG}: {s}", file=sys.stderr))
            finally:
                shutil.rmtree(tmp, ignore_errors=True)
        images, ts = draw_frames(plt, run, maps, meta, a.frames)
        gif = run.p("explore.gif")
        write_gif(images, gif)
        size = os.path.getsize(gif)
        print(f"{PROG}: wrote {gif} ({len(images)} frames, t = 0 .. {ts[-1]:g} s, {human(size)}"
              + (f", map panels from {len(maps)} rounds" if maps else ", no map panels") + ")")
        if size > GIF_MAX_BYTES:
            print(f"{PROG}: {gif} is larger than {human(GIF_MAX_BYTES)}: fewer --frames", file=sys.stderr)
        first = run.p("explore_first_frame.png")
        write_atomic(first, lambda f: images[0].save(f, format="PNG", optimize=True))
        print(f"{PROG}: wrote {first}")
        print(f"{PROG}: wrote {fig_explore_coverage(plt, run, run.dir)}")
    except ReportError as e:
        print(f"{PROG}: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
