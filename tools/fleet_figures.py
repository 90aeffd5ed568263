"""The figures of tools/fleet_report.py's report of one fleet run, drawn with matplotlib from its Run:
map_mean.png, map_std.png, map_single.png (and host_sim's maps/map_*.png drawn again), map_rounds.png
(the map at kept checkpoint rounds, made by `host_sim maps`), kde.png, val_loss.png, traffic.png.
Each written whole or not at all (fleet_io.write_atomic); colours from tools/palette.py.
"""
import glob
import math
import os
import re
import sys

sys.path.insert(0, os.path.dirname(os.path.realpath(__file__)))
from palette import robot_colour, quantity_cmap, THRESHOLD_COLOUR  # noqa: E402  (one colour per robot, one colour map per quantity)
from fleet_io import MAP_KINDS, load_npy, resolve_tour, round_map, write_atomic, yaml_scalars  # noqa: E402
sys.path.pop(0)

HITS_BIN_M = 0.1          # kde.png's bins (m)


# ---- figures ---------------------------------------------------------------------------------

def save_fig(plt, fig, path):
    try:
        write_atomic(path, lambda f: fig.savefig(f, format="png", dpi=110))
    finally:
        plt.close(fig)


# What each map shows: (colour map quantity, colour bar label, title).
MAP_LABELS = {
    "mean": ("occupancy", "P(occupied) (probability)", "occupancy: mean of {passes}"),
    "std": ("std", "MC std of P(occupied) (probability)", "uncertainty: standard deviation of {passes}"),
    "single": ("occupancy", "P(occupied) (probability)",
               "one stochastic pass (a single draw of the weights; the mean uses {passes})"),
    "epistemic": ("epistemic", "share of the prior variance left (fraction; 1 = nothing observed)",
                  "what the fleet has not seen: epistemic share of the prior variance"),
}


def legend_outside(ax, n_items, below=0.11, **kw):
    """A legend below the axes (below: its top under the axes' bottom, in axes heights, clear of
    the x label), never over the map (kw: more ax.legend options)."""
    ncol = max(1, min(n_items, 4))
    return ax.legend(loc="upper center", bbox_to_anchor=(0.5, -below), ncol=ncol, fontsize=8,
                     frameon=False, **kw)


def draw_tours(ax, run):
    """The robots' tours (start: a dot) in their colours; returns the number of legend entries."""
    for i, t in sorted(run.tours.items()):
        c = robot_colour(i)
        ax.plot(t[:, 0], t[:, 1], "-", lw=1.2, color=c, alpha=0.9, label=f"robot {i}")
        ax.plot(t[0, 0], t[0, 1], "o", ms=4, color=c)
    return len(run.tours)


def colour_limits(np, a):
    """(0, top) of a map's colour scale: 0 to the largest finite value, so a map whose values are
    all small (a short run's occupancy peaks far below 1) is not drawn blank; (0, 1) when the map
    has no positive finite value."""
    fin = a[np.isfinite(a)]
    top = float(fin.max()) if fin.size else 0.0
    return 0.0, (top if top > 0 else 1.0)


def occupied_thresh(run):
    """maps/map.yaml's occupied_thresh (the cut above which nav2 takes a cell for a wall), or None."""
    v = yaml_scalars(run.p("maps", "map.yaml")).get("occupied_thresh")
    try:
        v = float(v)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) and 0.0 < v < 1.0 else None


def cell_centres(np, a, box):
    """x (W,) and y (H,) of the cell centres of a grid drawn over box, row 0 the top (largest y)."""
    x0, y0, x1, y1 = box
    h, w = a.shape
    return (x0 + (np.arange(w) + 0.5) * (x1 - x0) / w, y1 - (np.arange(h) + 0.5) * (y1 - y0) / h)


def draw_threshold(np, ax, a, box, thr):
    """The contour of the occupancy a at thr (map.yaml's occupied_thresh): the cells inside are
    the ones a navigation stack reads as walls. Returns (ContourSet or None, legend handle, cells above)."""
    from matplotlib import patheffects
    from matplotlib.lines import Line2D
    fx = [patheffects.withStroke(linewidth=2.6, foreground="black")]
    fin = a[np.isfinite(a)]
    above = int((fin > thr).sum())
    label = f"map.yaml occupied_thresh {thr:.3g}"
    handle = Line2D([], [], color=THRESHOLD_COLOUR, lw=1.4, path_effects=fx, label=label)
    if above == 0 or above == fin.size:
        handle.set_label(label + (" (no cell above)" if above == 0 else " (every cell above)"))
        return None, handle, above
    xs, ys = cell_centres(np, a, box)
    cs = ax.contour(xs, ys, np.where(np.isfinite(a), a, 0.0), levels=[thr], colors=[THRESHOLD_COLOUR],
                    linewidths=1.4)
    for c in cs.collections:
        c.set_path_effects(fx)
    return cs, handle, above


def map_figure(plt, run, kind, a, tours=True):
    """The figure of one map (kind a key of MAP_LABELS) in metres: colours 0..max (the scale and
    its range in the colour bar), the map.yaml occupied threshold as a contour on the MC mean, the
    tours and the legend below the map. Returns (fig, info): info has "clim" and "contour"."""
    np = run.np
    x0, y0, x1, y1, unit = run.map_box()
    mc = run.meta.get("mc") if run.meta else None
    passes = f"{mc} MC passes" if mc is not None else "the MC passes (count unknown)"
    quantity, label, title = MAP_LABELS[kind]
    vmin, vmax = colour_limits(np, a)
    aspect = (y1 - y0) / (x1 - x0)
    fig, ax = plt.subplots(figsize=(8, max(3.0, 6.4 * aspect) + 1.5), constrained_layout=True)
    if kind == "epistemic":
        # Spans decades (a seen cell keeps 1e-5 of its prior variance, an unseen one 1): a log
        # scale from the smallest positive value (or host_sim's PNG floor) to the largest.
        from matplotlib.colors import LogNorm
        pos = a[np.isfinite(a) & (a > 0)]
        e = (run.meta or {}).get("epistemic")
        floor = e.get("png_floor") if isinstance(e, dict) else None
        floor = floor if isinstance(floor, (int, float)) and not isinstance(floor, bool) and floor > 0 else 1e-6
        vmin = max(floor, float(pos.min())) if pos.size else floor
        vmax = max(vmax, vmin * 10)
        norm, scale = LogNorm(vmin=vmin, vmax=vmax), f"log scale, {vmin:.3g} to the largest value {vmax:.3g}"
    else:
        norm, scale = None, f"colours 0 to the map's largest value {vmax:.3g}"
    im = ax.imshow(a, extent=[x0, x1, y0, y1], origin="upper", cmap=quantity_cmap(quantity), norm=norm,
                   vmin=None if norm else vmin, vmax=None if norm else vmax, interpolation="nearest")
    cb = fig.colorbar(im, ax=ax, shrink=0.85)
    cb.set_label(f"{label}\n{scale}")
    handles, info = [], {"clim": (vmin, vmax), "contour": None}
    thr = occupied_thresh(run) if kind == "mean" else None
    if thr is not None:
        info["contour"], h, above = draw_threshold(np, ax, a, (x0, y0, x1, y1), thr)
        handles.append(h)
        title += f"\ngold line: occupied_thresh {thr:.3g} (map.yaml); {above:,} cells above it are walls for nav2"
        cb.ax.axhline(thr, color=THRESHOLD_COLOUR, lw=2) if thr <= vmax else None
    n = draw_tours(ax, run) if tours and unit == "m" else 0
    if n or handles:
        h0, l0 = ax.get_legend_handles_labels()
        legend_outside(ax, n + len(handles), handles=h0 + handles, labels=l0 + [h.get_label() for h in handles])
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_xlabel(f"x ({unit})")
    ax.set_ylabel(f"y ({unit})")
    ax.set_title(title.format(passes=passes), fontsize=10)
    return fig, info


def fig_maps(plt, run, out):
    """map_<kind>.png at the top of the run's folder (with the tours) and the same pictures
    without the tours over host_sim's maps/map_mean.png, map_std.png, map_epistemic.png: one
    colour map per quantity (tools/palette.py), axes in metres, a colour bar with its unit."""
    made = []
    for kind in MAP_KINDS:
        a = run.maps.get(kind)
        if a is None:
            continue
        fig, _ = map_figure(plt, run, kind, a)
        name = f"map_{kind}.png"
        save_fig(plt, fig, os.path.join(out, name))
        made.append(name)
    if os.path.isdir(run.p("maps")):
        for kind in ("mean", "std", "epistemic"):
            a = run.maps.get(kind) if kind != "epistemic" else run.epistemic
            if a is None:
                continue
            fig, _ = map_figure(plt, run, kind, a, tours=False)
            save_fig(plt, fig, run.p("maps", f"map_{kind}.png"))
            run.redrawn.append(f"maps/map_{kind}.png")
    return made


def fig_hits(plt, run, out):
    """kde.png: where the lidar hits the robots trained on are, as a 2-D histogram in HITS_BIN_M
    bins (every hit counted, none drawn at random), in hits per square metre on a log scale."""
    np = run.np
    from matplotlib.colors import LogNorm
    if not run.hits:
        run.note("kde.png: no robot_<i>/train.samples")
        return None
    xs = np.concatenate([h[0] for h in run.hits.values()])
    ys = np.concatenate([h[1] for h in run.hits.values()])
    n = xs.size
    if n < 1:
        run.note("kde.png: no lidar hit in the training samples")
        return None
    box = run.plan_box() or (float(xs.min()), float(ys.min()), float(xs.max()), float(ys.max()))
    x0, y0, x1, y1 = box
    if not (x1 > x0 and y1 > y0):
        run.note("kde.png: the lidar hits span an empty box")
        return None
    nx, ny = max(1, int(round((x1 - x0) / HITS_BIN_M))), max(1, int(round((y1 - y0) / HITS_BIN_M)))
    counts, _, _ = np.histogram2d(xs, ys, bins=(nx, ny), range=((x0, x1), (y0, y1)))
    area = ((x1 - x0) / nx) * ((y1 - y0) / ny)
    dens = counts.T / area  # rows y up, as origin="lower" draws them
    shown = np.ma.masked_where(dens <= 0, dens)
    w, h = x1 - x0, y1 - y0
    fig, ax = plt.subplots(figsize=(8, max(3.0, 6.4 * h / w) + 0.8), constrained_layout=True)
    cmap = plt.get_cmap(quantity_cmap("hits")).copy()
    cmap.set_bad("white")
    top = float(dens.max())
    im = ax.imshow(shown, extent=[x0, x1, y0, y1], origin="lower", cmap=cmap, interpolation="nearest",
                   norm=LogNorm(vmin=1.0 / area, vmax=max(top, 1.0 / area * 1.01)))
    fig.colorbar(im, ax=ax, shrink=0.85,
                 label=f"lidar hits per m² (log scale; {HITS_BIN_M:g} m bins; white: none)")
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(f"where the lidar hits the robots trained on are: {n:,} hits of {len(run.hits)} robots",
                 fontsize=10)
    save_fig(plt, fig, os.path.join(out, "kde.png"))
    return "kde.png"


def fig_val_loss(plt, run, out):
    np = run.np
    if not run.metrics:
        run.note("val_loss.png: no robot_<i>/metrics.csv")
        return None
    fig, ax = plt.subplots(figsize=(7, 4.6), constrained_layout=True)
    lo, hi, lines = math.inf, -math.inf, 0
    for i, m in sorted(run.metrics.items()):
        r, v = m["round"], m["val_loss"]
        ok = np.isfinite(v)
        if not ok.any():
            continue
        ax.plot(r[ok], v[ok], "-", lw=1.2, color=robot_colour(i), label=f"robot {i}",
                marker="." if ok.sum() < 30 else None)
        lo, hi, lines = min(lo, float(v[ok].min())), max(hi, float(v[ok].max())), lines + 1
    if lines == 0:
        plt.close(fig)
        run.note("val_loss.png: no finite validation loss in any metrics.csv")
        return None
    if lo > 0 and hi / lo > 10:
        ax.set_yscale("log")
    ax.set_xlabel("DiNNO round (count)")
    ax.set_ylabel("validation loss (binary cross-entropy, nats per point)")
    ax.set_title("validation loss per robot")
    ax.grid(alpha=0.3)
    legend_outside(ax, lines, below=0.15)
    save_fig(plt, fig, os.path.join(out, "val_loss.png"))
    return "val_loss.png"


COVERAGE_X = {
    "sim_time_s": ("simulated time (s)", "s"),
    "robot_seconds": ("robot-seconds (robots x simulated seconds)", "robot-s"),
}


def draw_coverage(ax, fleet, robots, x="sim_time_s"):
    """Share of the free space seen (coverage.csv columns) against x (a key of COVERAGE_X): each
    robot alone (robots: {i: columns}) in its colour, the fleet's union (fleet, or None) in black.
    Returns the number of lines drawn (legend entries)."""
    xlabel, unit = COVERAGE_X[x]
    lines = 0
    for i, c in sorted(robots.items()):
        ax.plot(c[x], c["coverage"], "-", lw=1.0, color=robot_colour(i), label=f"robot {i} alone")
        lines += 1
    if fleet is not None:
        ax.plot(fleet[x], fleet["coverage"], "-", lw=2.2, color="black",
                label=f"fleet (union): {float(fleet['coverage'][-1]):.3f} at {float(fleet[x][-1]):.0f} {unit}")
        lines += 1
    ax.set_ylim(0, 1)
    ax.set_xlabel(xlabel)
    ax.set_ylabel("coverage (share of free cells seen, 0.1 m grid)")
    ax.grid(alpha=0.3)
    return lines


def fig_coverage(plt, run, out):
    """Share of the free space seen (coverage.csv) against simulated time: the fleet's union and
    each robot alone, in its colour."""
    if run.coverage is None and not run.robot_coverage:
        return None
    fig, ax = plt.subplots(figsize=(7, 4.6), constrained_layout=True)
    lines = draw_coverage(ax, run.coverage, run.robot_coverage)
    ax.set_title("coverage: free space seen by some lidar ray")
    legend_outside(ax, lines, below=0.15)
    save_fig(plt, fig, os.path.join(out, "coverage.png"))
    return "coverage.png"


def per_round_sum(np, tables, col):
    """Rounds (sorted) and the sum of `col` over the robots at each round."""
    rounds = np.unique(np.concatenate([t["round"] for t in tables])).astype(np.int64)
    total = np.zeros(rounds.size)
    for t in tables:
        v = t[col]
        ok = np.isfinite(v)
        idx = np.searchsorted(rounds, t["round"][ok].astype(np.int64))
        np.add.at(total, idx, v[ok])
    return rounds, total


def fig_traffic(plt, run, out):
    from matplotlib.ticker import MaxNLocator
    np = run.np
    tables = [t for _, t in sorted(run.traffic.items()) if t["round"].size]
    if not tables:
        run.note("traffic.png: no robot_<i>/traffic.csv with rows")
        return None
    rounds, sent = per_round_sum(np, tables, "bytes_sent")
    _, req = per_round_sum(np, tables, "chunks_requested")
    _, res = per_round_sum(np, tables, "chunks_resent")
    _, tmo = per_round_sum(np, tables, "timeouts")
    scale, unit = 1.0, "B"
    for s, u in ((1e9, "GB"), (1e6, "MB"), (1e3, "kB")):
        if sent.max() >= 10 * s:
            scale, unit = s, u
            break
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(7, 6), sharex=True, constrained_layout=True)
    a1.plot(rounds, sent / scale, "-", lw=1.0, color="tab:blue")
    a1.set_ylabel(f"bytes sent per round ({unit})")
    a1.set_ylim(bottom=0, top=max(1.0, float(sent.max()) / scale) * 1.08)
    a1.set_title(f"fleet traffic per round (sum over {len(tables)} robots)")
    a1.grid(alpha=0.3)
    same = bool(np.array_equal(req, res))
    a2.plot(rounds, req, "-", lw=2.4, color="tab:red", alpha=0.55,
            label="chunks requested (lost)" + (": the same as re-sent in every round" if same else ""))
    a2.plot(rounds, res, "--", lw=1.1, color="black", marker="x", ms=4, markevery=[int(k) for k in np.flatnonzero(res)],
            label="chunks re-sent" + (": on the requested line" if same else ""))
    if tmo.any():
        a2.plot(rounds, tmo, ":", lw=1.0, color="0.3", label="timeouts")
    a2.set_xlabel("DiNNO round (count)")
    a2.set_ylabel("chunks per round (count)")
    a2.set_ylim(bottom=0)
    a2.yaxis.set_major_locator(MaxNLocator(integer=True))
    a2.grid(alpha=0.3)
    legend_outside(a2, 1, below=0.2)
    save_fig(plt, fig, os.path.join(out, "traffic.png"))
    return "traffic.png"


def checkpoint_rounds(run):
    """The rounds of the checkpoints every robot kept (robot_<i>/round_NNNN.bnn), sorted."""
    common = None
    for i in run.robots:
        r = set()
        for f in glob.glob(run.p(f"robot_{i}", "round_*.bnn")):
            m = re.fullmatch(r"round_(\d+)\.bnn", os.path.basename(f))
            if m:
                r.add(int(m.group(1)))
        common = r if common is None else common & r
    return sorted(common or ())


def pick_evenly(rounds, n):
    """At most n of the sorted rounds, nearest to n values evenly spaced from the first to the last."""
    if len(rounds) <= n or n < 2:
        return list(rounds[-n:]) if n >= 1 else []
    lo, hi = rounds[0], rounds[-1]
    out = []
    for k in range(n):
        want = lo + k * (hi - lo) / (n - 1)
        best = min((r for r in rounds if r not in out), key=lambda r: (abs(r - want), r))
        out.append(best)
    return sorted(out)


def resolve_file(p, run_dir):
    """A file named in run.json (relative to the current directory, the project root, RUN_DIR)."""
    return resolve_tour(p, run_dir)


def make_strip(run, n, host_sim=None):
    """The consensus MC mean map at n kept checkpoint rounds, evenly spaced: `host_sim maps` on
    every robot's robot_<i>/round_NNNN.bnn, into maps/rounds/round_NNNN/ (kept; made again only
    when a checkpoint is newer). Sets run.strip to [(round, map_mean)]; a missing piece is a note."""
    np = run.np
    if n < 1 or not run.robots:
        return
    rounds = checkpoint_rounds(run)
    if not rounds:
        run.note("map_rounds.png: no round checkpoint (robot_<i>/round_NNNN.bnn) kept by every robot")
        return
    s = run.settings or {}
    plan = resolve_file(s["plan"], run.dir) if isinstance(s.get("plan"), str) else None
    if plan is None:
        run.note("map_rounds.png: run.json names no plan that is here (host_sim maps needs it)")
        return
    exe = host_sim
    if exe is None:
        for cand in ([s["host_sim"]] if isinstance(s.get("host_sim"), str) else []) + ["build/bin/host_sim"]:
            exe = resolve_file(cand, run.dir)
            if exe is not None:
                break
    if exe is None or not os.access(exe, os.X_OK):
        run.note("map_rounds.png: no host_sim binary (run.json \"host_sim\", build/bin/host_sim or --host-sim)")
        return
    meta = run.meta or {}
    res = meta.get("res") or s.get("map_res_m") or 0.05
    mc, seed = meta.get("mc") or s.get("mc") or 50, meta.get("seed") or s.get("seed") or 1
    strip = []
    for r in pick_evenly(rounds, n):
        models = [run.p(f"robot_{i}", f"round_{r:04d}.bnn") for i in run.robots]
        out = run.p("maps", "rounds", f"round_{r:04d}")
        why = round_map(exe, plan, models, out, res, mc, seed)
        if why is not None:
            run.note(f"map_rounds.png: host_sim maps of round {r} {why}")
            return
        npy = os.path.join(out, "map_mean.npy")
        strip.append((r, load_npy(np, npy)))
    run.strip = strip
    run.strip_rounds = rounds


def strip_note(run):
    """What the strip shows and, when the kept checkpoints cover little of the run, how to keep more."""
    got = [r for r, _ in run.strip]
    kept = run.strip_rounds
    text = (f"Checkpoint rounds {', '.join(str(r) for r in got)} of the {len(kept)} every robot kept "
            f"({kept[0]}..{kept[-1]}); each map is `host_sim maps` of the robots' round_NNNN.bnn, in "
            "maps/rounds/.")
    rounds = (run.settings or {}).get("rounds")
    if isinstance(rounds, int) and not isinstance(rounds, bool) and rounds > 0 and kept[-1] - kept[0] < rounds / 2:
        text += (f" They cover little of the run's {rounds} rounds: `host_sim run --keep-ckpt-every M` keeps "
                 f"every M-th round (tools/fleet --extra=\"--keep-ckpt-every {max(1, rounds // 4)}\").")
    return text


def fig_strip(plt, run, out):
    """map_rounds.png: the consensus MC mean at a few rounds, one colour scale (0 to the largest
    value of all of them), so the map is seen forming."""
    if not run.strip:
        return None
    np = run.np
    x0, y0, x1, y1, unit = run.map_box()
    top = max(colour_limits(np, a)[1] for _, a in run.strip)
    k = len(run.strip)
    aspect = (y1 - y0) / (x1 - x0)
    fig, axes = plt.subplots(1, k, figsize=(3.4 * k + 1.2, 3.4 * aspect + 1.4), constrained_layout=True,
                             squeeze=False)
    for ax, (r, a) in zip(axes[0], run.strip):
        im = ax.imshow(a, extent=[x0, x1, y0, y1], origin="upper", cmap=quantity_cmap("occupancy"), vmin=0.0,
                       vmax=top, interpolation="nearest")
        ax.set_title(f"checkpoint round_{r:04d}", fontsize=9)
        ax.set_xlabel(f"x ({unit})", fontsize=8)
        ax.tick_params(labelsize=7)
    axes[0][0].set_ylabel(f"y ({unit})", fontsize=8)
    fig.colorbar(im, ax=list(axes[0]), shrink=0.9,
                 label=f"P(occupied) (probability)\ncolours 0 to the largest value {top:.3g}")
    fig.suptitle("the consensus map as it forms: MC mean of the robots' checkpoints (host_sim maps)", fontsize=10)
    save_fig(plt, fig, os.path.join(out, "map_rounds.png"))
    return "map_rounds.png"
