#!/usr/bin/python3
"""Human-readable report of one multi-process fleet run: figures and summary.md in RUN_DIR.

    tools/fleet_report.py RUN_DIR [--quiet]

Reads (every file optional: a missing one skips its figure and is named in summary.md):
  run.json                      every setting of the run (all keys shown, none required); "deaths"
                                and "failed": the robots that died, at which round, how, whether
                                tools/fleet restarted them (shown first, in their own section)
  robot_<i>/metrics.csv         per DiNNO round: round,...,train_loss,...,val_loss,...
  robot_<i>/traffic.csv         per round: round,...,bytes_sent,...,chunks_resent,
                                chunks_requested,...,timeouts,...
  robot_<i>/train.samples       the samples the robot trained on (tools/samples.py format)
  robot_<i>/summary.txt         with traffic.csv, what the fleet lost (tools/fleet_losses.py): states
                                given up, peer timeouts, datagrams dropped by full receive queues,
                                stated at the top of summary.md
  maps/map_mean.npy, map_std.npy, map_single.npy, map_meta.json, consensus.csv,
  maps/map.pgm + map.yaml       (ROS map_server: its thresholds, and from map_meta.json how the map
                                scores as nav2 reads it), scene.png
  maps/map_epistemic.npy, map_epistemic.png, map_std.png, map_truth.npy   when the maps folder
                                has map_epistemic.npy (older ones do not: the section is skipped),
                                the section "What the fleet knows": the two maps side by side and
                                tools/paper_metrics.py's scores of them against every robot's
                                robot_<i>/train.samples (seen cells, AUC, AUSE, Spearman vs KDE)
Writes into RUN_DIR (each file whole or not at all: a temporary file beside it, renamed):
  map_mean.png, map_std.png, map_single.png   the maps in metres with the robots' tours, colours
                                0 to the map's largest value (a short run's occupancy peaks far
                                below 1), map.yaml's occupied_thresh as a contour on the mean, the
                                legend below the map; one colour map per quantity (tools/palette.py)
  maps/map_mean.png, map_std.png, map_epistemic.png   host_sim's pictures drawn again the same
                                way (no tours): axes in metres, colour bar with its unit, title
  map_rounds.png                the map as it forms: the consensus MC mean at --strip N kept
                                checkpoint rounds (robot_<i>/round_NNNN.bnn that every robot kept;
                                host_sim run --keep-ckpt-every M keeps every M-th), evenly spaced,
                                each made by `host_sim maps` into maps/rounds/round_NNNN/ (kept, made
                                again only when a checkpoint is newer)
  kde.png                       the lidar hits (occ > 0.5) of all robots per m² (2-D histogram)
  val_loss.png                  validation loss per robot and round
  traffic.png                   fleet bytes sent per round; chunks requested and re-sent
  summary.md                    settings, final figures, the images
Tour files named in run.json "paths" are read relative to the current directory, to the
project root (RUN_DIR/../.., or this tool's ../) or to RUN_DIR; a tour not found is skipped.
A malformed input stops the report with a one-line reason (FILE:LINE where it applies) and
exit status 1, before any output is written. Needs Debian's python3-numpy, -scipy, -matplotlib.
"""
import argparse
import csv
import glob
import io
import json
import math
import os
import re
import subprocess
import sys
import tempfile

TOOLS_DIR = os.path.dirname(os.path.realpath(__file__))
sys.path.insert(0, TOOLS_DIR)
from palette import robot_colour, quantity_cmap, THRESHOLD_COLOUR  # noqa: E402  (one colour per robot, one colour map per quantity)
import fleet_losses  # noqa: E402  (the same totals as tools/fleet's last line)
sys.path.pop(0)
TMP_PREFIX = ".fleet_report."
HITS_BIN_M = 0.1          # kde.png's bins (m)
STRIP_ROUNDS = 4          # map_rounds.png's panels

METRICS_NEED = ("round", "train_loss", "val_loss")
TRAFFIC_NEED = ("round", "bytes_sent", "chunks_requested", "chunks_resent", "timeouts")
CONSENSUS_NEED = ("model", "val_loss", "consensus_error")
MAP_KINDS = ("mean", "std", "single")


class ReportError(Exception):
    """A malformed input or an output that cannot be written: one line, exit 1."""


# ---- reading ---------------------------------------------------------------------------------

def read_text(path):
    try:
        with open(path, encoding="utf-8-sig") as f:
            return f.read()
    except UnicodeDecodeError:
        raise ReportError(f"{path}: not UTF-8 text")
    except OSError as e:
        raise ReportError(f"{path}: {e.strerror or e}")


def read_json_object(path):
    text = read_text(path)
    try:
        obj = json.loads(text)
    except ValueError as e:
        raise ReportError(f"{path}:{getattr(e, 'lineno', '?')}: not valid JSON ({getattr(e, 'msg', e)})")
    if not isinstance(obj, dict):
        raise ReportError(f"{path}: expected a JSON object, got {type(obj).__name__}")
    return obj


def read_csv(path, need, text_cols=()):
    """Numeric CSV with a header: {column: list of float} (text_cols kept as str).
    Columns in `need` must exist; every row must have as many fields as the header."""
    text = read_text(path)
    reader = csv.reader(io.StringIO(text, newline=""), strict=True)
    try:
        rows = [(reader.line_num, r) for r in reader]
    except csv.Error as e:
        raise ReportError(f"{path}:{reader.line_num}: {e}")
    if not rows or not any(x.strip() for x in rows[0][1]):
        raise ReportError(f"{path}:1: no header line")
    header = [h.strip() for h in rows[0][1]]
    if len(set(header)) != len(header):
        raise ReportError(f"{path}:1: repeated column name")
    for c in need:
        if c not in header:
            raise ReportError(f"{path}:1: no column '{c}' (has {','.join(header)})")
    cols = {h: [] for h in header}
    for n, row in rows[1:]:
        if not row or (len(row) == 1 and not row[0].strip()):
            continue
        fields = [x.strip() for x in row]
        if len(fields) != len(header):
            raise ReportError(f"{path}:{n}: {len(fields)} fields, expected {len(header)}")
        for h, v in zip(header, fields):
            if h in text_cols:
                cols[h].append(v)
                continue
            try:
                cols[h].append(float(v))
            except ValueError:
                raise ReportError(f"{path}:{n}: column '{h}': '{v}' is not a number")
    if "round" in cols:
        for k, r in enumerate(cols["round"]):
            if not (math.isfinite(r) and r == int(r) and r >= 0):
                raise ReportError(f"{path}: row {k + 1}: round '{r}' is not a whole number >= 0")
    return cols


def load_npy(np, path):
    try:
        a = np.load(path, allow_pickle=False)
    except (OSError, ValueError, EOFError) as e:
        raise ReportError(f"{path}: not a readable .npy array ({e})")
    if not isinstance(a, np.ndarray) or a.ndim != 2 or a.shape[0] < 1 or a.shape[1] < 1:
        raise ReportError(f"{path}: expected a 2-D (H, W) grid, got shape {getattr(a, 'shape', '?')}")
    if a.dtype.kind not in "fiu":
        raise ReportError(f"{path}: expected a numeric grid, got dtype {a.dtype}")
    return a.astype(np.float64)


def read_tour(path):
    """Waypoints of a tour CSV (header x_m,y_m, then one x,y per line): list of (x, y)."""
    pts = []
    first = True
    for n, line in enumerate(read_text(path).splitlines(), start=1):
        s = line.strip()
        if not s or s.startswith("#"):
            continue
        f = [x.strip() for x in s.split(",")]
        try:
            if len(f) < 2:
                raise ValueError
            x, y = float(f[0]), float(f[1])
        except ValueError:
            if first:
                first = False
                continue  # the header line (x_m,y_m)
            raise ReportError(f"{path}:{n}: not an x,y waypoint: '{s}'")
        first = False
        if not (math.isfinite(x) and math.isfinite(y)):
            raise ReportError(f"{path}:{n}: waypoint not finite: '{s}'")
        pts.append((x, y))
    return pts


def resolve_tour(p, run_dir):
    if os.path.isabs(p):
        return p if os.path.isfile(p) else None
    for base in (os.getcwd(), os.path.join(run_dir, "..", ".."), os.path.dirname(TOOLS_DIR), run_dir):
        q = os.path.normpath(os.path.join(base, p))
        if os.path.isfile(q):
            return q
    return None


def load_samples(path):
    sys.path.insert(0, TOOLS_DIR)
    try:
        import samples
    finally:
        sys.path.pop(0)
    try:
        return samples.load(path), samples.to_metres
    except samples.SamplesError as e:
        raise ReportError(str(e))
    except OSError as e:
        raise ReportError(f"{path}: {e.strerror or e}")


class Run:
    """Everything read from RUN_DIR, validated; `notes` lists what is missing."""

    def __init__(self, np, run_dir):
        self.np = np
        self.dir = run_dir
        self.notes = []
        self.settings = None
        self.robots = []
        self.metrics = {}
        self.traffic = {}
        self.hits = {}        # robot -> (x, y) arrays of the lidar hits in metres
        self.sample_box = None
        self.maps = {}
        self.meta = None
        self.consensus = None
        self.tours = {}       # robot -> array (n, 2)
        self.has_ros_map = False
        self.scene = False
        self.knows = None     # paper_metrics.compute of maps/ when it has map_epistemic.npy
        self.train_samples = []
        self.epistemic = None  # maps/map_epistemic.npy, redrawn as maps/map_epistemic.png
        self.redrawn = []      # the maps/*.png this report drew over host_sim's
        self.strip = None      # [(round, mean map)] of the strip "the map as it forms"

    def p(self, *parts):
        return os.path.join(self.dir, *parts)

    def note(self, text):
        self.notes.append(text)

    def load(self):
        np = self.np
        if os.path.isfile(self.p("run.json")):
            self.settings = read_json_object(self.p("run.json"))
        else:
            self.note("run.json is missing: no settings table")
        s = self.settings or {}
        n = s.get("robots")
        if n is not None and (isinstance(n, bool) or not isinstance(n, int) or n < 0):
            raise ReportError(f"{self.p('run.json')}: \"robots\" must be a whole number >= 0, got {n!r}")
        found = set()
        for d in glob.glob(self.p("robot_*")):
            m = re.fullmatch(r"robot_(\d+)", os.path.basename(d))
            if m and os.path.isdir(d):
                found.add(int(m.group(1)))
        self.robots = sorted(set(range(n or 0)) | found)
        if not self.robots:
            self.note("no robot_<i>/ folder: no per-robot figures")

        for i in self.robots:
            rd = f"robot_{i}"
            f = self.p(rd, "metrics.csv")
            if os.path.isfile(f):
                self.metrics[i] = {k: np.asarray(v) for k, v in read_csv(f, METRICS_NEED).items()}
            else:
                self.note(f"{rd}/metrics.csv is missing")
            f = self.p(rd, "traffic.csv")
            if os.path.isfile(f):
                self.traffic[i] = {k: np.asarray(v) for k, v in read_csv(f, TRAFFIC_NEED).items()}
            else:
                self.note(f"{rd}/traffic.csv is missing")
            f = self.p(rd, "train.samples")
            if os.path.isfile(f):
                self.train_samples.append(f)
                (h, a), to_metres = load_samples(f)
                x, y = to_metres(h, a)
                hit = a["occ"] > 0.5
                self.hits[i] = (x[hit], y[hit])
                b = (h["min_x"], h["min_y"], h["max_x"], h["max_y"])
                if self.sample_box is None:
                    self.sample_box = b
                else:
                    sb = self.sample_box
                    self.sample_box = (min(sb[0], b[0]), min(sb[1], b[1]), max(sb[2], b[2]), max(sb[3], b[3]))
            else:
                self.note(f"{rd}/train.samples is missing")

        self.load_maps()
        self.load_knowledge()

        paths = s.get("paths")
        if paths is not None:
            if not isinstance(paths, list) or not all(isinstance(q, str) for q in paths):
                raise ReportError(f"{self.p('run.json')}: \"paths\" must be a list of file names")
            for i, q in enumerate(paths):
                f = resolve_tour(q, self.dir)
                if f is None:
                    continue  # a tour that is not here is skipped silently
                t = read_tour(f)
                if t:
                    self.tours[i] = np.asarray(t, dtype=float)

        self.has_ros_map = os.path.isfile(self.p("maps", "map.pgm")) and os.path.isfile(self.p("maps", "map.yaml"))
        if not self.has_ros_map:
            self.note("maps/map.pgm or maps/map.yaml is missing: no ROS map")
        self.scene = os.path.isfile(self.p("scene.png"))
        if not self.scene:
            self.note("scene.png is missing: no rendering of the plan")

    def load_maps(self):
        np = self.np
        f = self.p("maps", "map_meta.json")
        if os.path.isfile(f):
            self.meta = read_json_object(f)
            box = []
            for k in ("xmin", "ymin", "xmax", "ymax"):
                v = self.meta.get(k)
                if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                    raise ReportError(f"{f}: \"{k}\" must be a finite number, got {v!r}")
                box.append(float(v))
            if not (box[0] < box[2] and box[1] < box[3]):
                raise ReportError(f"{f}: empty box x {box[0]}..{box[2]}, y {box[1]}..{box[3]}")
            for k in ("width", "height"):
                v = self.meta.get(k)
                if v is not None and (isinstance(v, bool) or not isinstance(v, int) or v < 1):
                    raise ReportError(f"{f}: \"{k}\" must be a whole number >= 1, got {v!r}")
        for kind in MAP_KINDS:
            g = self.p("maps", f"map_{kind}.npy")
            if not os.path.isfile(g):
                self.note(f"maps/map_{kind}.npy is missing: no map_{kind}.png")
                continue
            a = load_npy(np, g)
            if self.meta is not None:
                w, h = self.meta.get("width"), self.meta.get("height")
                if (h is not None and a.shape[0] != h) or (w is not None and a.shape[1] != w):
                    raise ReportError(f"{g}: shape {a.shape} disagrees with map_meta.json "
                                      f"(height {h}, width {w})")
            for other, b in self.maps.items():
                if b.shape != a.shape:
                    raise ReportError(f"{g}: shape {a.shape} differs from map_{other}.npy {b.shape}")
            self.maps[kind] = a
        g = self.p("maps", "map_epistemic.npy")
        if os.path.isfile(g):
            a = load_npy(np, g)
            if self.maps and a.shape != next(iter(self.maps.values())).shape:
                raise ReportError(f"{g}: shape {a.shape} differs from the other maps")
            self.epistemic = a
        if self.maps and self.meta is None:
            self.note("maps/map_meta.json is missing: map axes " +
                      ("from the samples' plan box" if self.sample_box else "in grid cells"))
        f = self.p("maps", "consensus.csv")
        if os.path.isfile(f):
            c = read_csv(f, CONSENSUS_NEED, text_cols=("model", "file"))
            self.consensus = [dict(zip(c.keys(), vals)) for vals in zip(*c.values())]
        else:
            self.note("maps/consensus.csv is missing: no consensus errors")

    def load_knowledge(self):
        """tools/paper_metrics.py's scores of the MC std, the epistemic map and the distance to the
        samples (the section "What the fleet knows"), when maps/ has map_epistemic.npy. A malformed
        map stops the report; a missing ground truth or no training samples skip the section."""
        f = self.p("maps", "map_epistemic.npy")
        if not os.path.isfile(f):
            self.note("maps/map_epistemic.npy is missing: no section \"What the fleet knows\"")
            return
        if not os.path.isfile(self.p("maps", "map_truth.npy")):
            self.note("maps/map_truth.npy is missing: no scores of the epistemic map")
            return
        if not self.train_samples:
            self.note("no robot_<i>/train.samples: no scores of the epistemic map")
            return
        sys.path.insert(0, TOOLS_DIR)
        try:
            import paper_metrics
        finally:
            sys.path.pop(0)
        try:
            self.knows = paper_metrics.compute(self.p("maps"), self.train_samples)
        except paper_metrics.MetricsError as e:
            raise ReportError(str(e))
        self.knows_table = paper_metrics.markdown_table(self.knows)
        self.seen_dist = paper_metrics.SEEN_DIST

    def map_box(self):
        """(xmin, ymin, xmax, ymax, unit) of the map grid."""
        if self.meta is not None:
            m = self.meta
            return float(m["xmin"]), float(m["ymin"]), float(m["xmax"]), float(m["ymax"]), "m"
        if self.sample_box is not None:
            return self.sample_box + ("m",)
        a = next(iter(self.maps.values()))
        return 0.0, 0.0, float(a.shape[1]), float(a.shape[0]), "cells"

    def plan_box(self):
        if self.meta is not None:
            return self.map_box()[:4]
        return self.sample_box


# ---- writing ---------------------------------------------------------------------------------

def clear_stale_temps(run_dir):
    """Removes the temporary files a killed report left behind (only this tool's own)."""
    for f in glob.glob(os.path.join(run_dir, TMP_PREFIX + "*.tmp")):
        try:
            os.unlink(f)
        except OSError:
            pass


def write_atomic(path, writer):
    """Calls writer(file object) on a temporary file beside path, then renames it over path."""
    d = os.path.dirname(os.path.abspath(path))
    try:
        fd, tmp = tempfile.mkstemp(dir=d, prefix=TMP_PREFIX + os.path.basename(path) + ".", suffix=".tmp")
    except OSError as e:
        raise ReportError(f"{path}: {e.strerror or e}")
    try:
        with os.fdopen(fd, "wb") as f:
            writer(f)
            f.flush()
            os.fsync(f.fileno())
        if os.path.isdir(path):
            raise ReportError(f"{path}: Is a directory")
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp's 0600 would make the report private
        os.replace(tmp, path)
    except OSError as e:
        _unlink(tmp)
        raise ReportError(f"{path}: {e.strerror or e}")
    except BaseException:
        _unlink(tmp)
        raise


def _unlink(p):
    try:
        os.unlink(p)
    except OSError:
        pass


def save_fig(plt, fig, path):
    try:
        write_atomic(path, lambda f: fig.savefig(f, format="png", dpi=110))
    finally:
        plt.close(fig)


def fmt(v, digits=4):
    if v is None:
        return "n/a"
    if isinstance(v, float):
        if not math.isfinite(v):
            return "n/a" if math.isnan(v) else str(v)
        if v != 0 and (abs(v) >= 1e5 or abs(v) < 1e-3):
            return f"{v:.{digits - 1}e}"
        return f"{v:.{digits}g}"
    return str(v)


def md_cell(v):
    if isinstance(v, (list, tuple)):
        s = ", ".join(str(x) for x in v) if all(not isinstance(x, (dict, list)) for x in v) else json.dumps(v)
    elif isinstance(v, dict):
        s = json.dumps(v, sort_keys=True)
    elif isinstance(v, float):
        s = repr(v)
    elif v is None:
        s = "null"
    else:
        s = str(v)
    return s.replace("\\", "\\\\").replace("|", "\\|").replace("\n", " ").replace("\r", " ")


# ---- figures ---------------------------------------------------------------------------------

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
        npy = os.path.join(out, "map_mean.npy")
        fresh = os.path.isfile(npy) and os.path.getmtime(npy) >= max(os.path.getmtime(m) for m in models)
        if not fresh:
            cmd = [exe, "maps", "--plan", plan, "--out", out, "--res", str(res), "--mc", str(mc),
                   "--seed", str(seed)] + models
            try:
                p = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
            except (OSError, subprocess.TimeoutExpired) as e:
                run.note(f"map_rounds.png: host_sim maps of round {r} did not run ({e})")
                return
            if p.returncode != 0 or not os.path.isfile(npy):
                why = (p.stderr or p.stdout).strip().splitlines()
                run.note(f"map_rounds.png: host_sim maps of round {r} failed (exit {p.returncode}"
                         + (f": {why[-1]}" if why else "") + ")")
                return
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


# ---- summary.md ------------------------------------------------------------------------------

def last_finite(np, v):
    ok = np.flatnonzero(np.isfinite(v))
    return (float(v[ok[-1]]), int(ok[-1])) if ok.size else (None, None)


DEATH_KEYS = ("deaths", "failed")
LOSS_KEYS = fleet_losses.KEYS + ("losses_uncounted",)  # run.json's copy of losses_section's figures


def death_line(d):
    """One robot's death as tools/fleet recorded it in run.json."""
    if not isinstance(d, dict):
        return f"- {md_cell(d)}"
    why = md_cell(d.get("how", "?"))
    if d.get("error"):
        why += f": `{md_cell(d['error'])}`"
    after = (f"restarted with --resume (restart {md_cell(d.get('restart'))})" if d.get("restarted")
             else "not restarted")
    return f"- robot {md_cell(d.get('robot', '?'))} died at round {md_cell(d.get('round', '?'))} ({why}); {after}"


def deaths_section(s):
    """The robots that died during the run (run.json "deaths"; "failed": the one that stopped
    the fleet), first thing in the report: the figures below are partial then."""
    deaths, failed = s.get("deaths") or [], s.get("failed")
    if not deaths and not failed:
        return []
    L = []
    if isinstance(failed, dict):
        L += [f"**The fleet failed: robot {md_cell(failed.get('robot', '?'))} died at round "
              f"{md_cell(failed.get('round', '?'))} ({md_cell(failed.get('how', '?'))}); the other robots were "
              "stopped, so no robot has a final model and there are no maps.**", ""]
    if not isinstance(deaths, list):
        deaths = [deaths]
    L += ["## Robots that died", ""] + [death_line(d) for d in deaths] + [""]
    return L


def losses_section(run):
    """What the fleet lost, summed over the robots, in plain words, before anything else: with a
    state given up or a peer timed out the models are not those of a lossless run, so they cannot
    be compared with the in-process reference."""
    if not run.robots:
        return []
    totals, gaps = fleet_losses.fleet_losses(run.dir, run.robots)
    n = len(run.robots)
    if fleet_losses.lossless(totals, gaps):
        head = (f"**A lossless run: over its {n} robots, no neighbour state was given up, no peer timed out and "
                "no datagram was dropped by a full receive queue.**")
    else:
        head = (f"**{fleet_losses.totals_text(totals, gaps)} (over {n} robots): "
                f"{fleet_losses.verdict(totals, gaps)}.**")
    L = ["## What the fleet lost", "", head, "",
         "- states given up: a round went on without a neighbour's state (the protocol's `states_missed`: "
         "summary.txt's \"peer states gone without\"); that robot's model then learned without it",
         "- peer timeouts: a peer was silent for longer than the peer timeout and left a round",
         "- datagrams dropped by full queues: a robot read its receive queue too late (a busy CPU) and the "
         "queue was full (`rx_dropped_full`: summary.txt's \"queue full\"); the robot asks for them again, "
         "only a state given up changes a model"]
    L += [f"- not counted whole: {md_cell(g)}" for g in gaps[:10]]
    if len(gaps) > 10:
        L.append(f"- ... and {len(gaps) - 10} more robot folders like these")
    return L + [""]


def knowledge_section(run, figures):
    """"What the fleet knows": maps/map_epistemic.png next to maps/map_std.png and the scores of
    tools/paper_metrics.py; nothing when the maps folder has no map_epistemic.npy."""
    k = run.knows
    if k is None:
        return []
    std_png = ("maps/map_std.png" if os.path.isfile(run.p("maps", "map_std.png")) else
               "map_std.png" if "map_std.png" in figures else None)
    epi_png = "maps/map_epistemic.png" if os.path.isfile(run.p("maps", "map_epistemic.png")) else None
    L = ["## What the fleet knows", "",
         "How to read it: the MC std (left) is where the model is unsure of the value, highest on the walls, "
         "whose occupancy changes within a cell (aleatoric); the epistemic map (right) is where no robot "
         "gathered data (the share of the prior variance of the read-out left after the data: 1 = nothing "
         "observed there).", "",
         "| MC-50 std | epistemic |", "|---|---|",
         "| " + (f"![map_std]({std_png})" if std_png else "(no map_std.png)") + " | " +
         (f"![map_epistemic]({epi_png})" if epi_png else "(maps/map_epistemic.png is missing)") + " |", ""]
    L += run.knows_table + [""]
    pct = 100 * k["seen_fraction"] if math.isfinite(k["seen_fraction"]) else math.nan
    L += [f"- seen: a cell whose centre is within {run.seen_dist:g} m of a training sample of any robot: "
          f"{fmt(pct, 3)} % of the {k['n_cells']:,} cells inside the building "
          f"({k['n_points']:,} samples of {len(run.train_samples)} robot(s))",
          "- AUC: the score for the unseen against the seen cells (1 = every unseen cell above every seen one, "
          "0.5 = chance); AUSE: area under the sparsification error of |mean - truth| (0 = the score orders "
          "the cells like their errors; lower is better); Spearman: the score against the KDE of the lidar "
          "hits (negative = less uncertain where the data are dense); the distance to the nearest sample is "
          "the non-Bayesian reference (AUC 1 by construction)",
          f"- the MC mean: Brier {fmt(k['brier'])}, ECE {fmt(k['ece'])}, wall IoU {fmt(k['wall_iou'])}"]
    means = [f"{name} {fmt(k[f'{name}_mean_seen'], 3)} seen / {fmt(k[f'{name}_mean_unseen'], 3)} unseen"
             for name in ("std", "epistemic") if f"{name}_mean_seen" in k]
    if means:
        L.append("- mean " + ", ".join(means))
    e = (run.meta or {}).get("epistemic")
    if isinstance(e, dict) and e:
        L.append("- epistemic map (map_meta.json): " + ", ".join(f"{md_cell(a)} {md_cell(b)}" for a, b in e.items()))
    return L + [""]


def summary(run, figures):
    np = run.np
    L = [f"# Fleet run report: {os.path.basename(os.path.abspath(run.dir))}", ""]
    s = run.settings
    if s is not None:
        L += deaths_section(s)
    L += losses_section(run)
    if s is not None:
        L += ["## Settings", "", "| setting | value |", "|---|---|"]
        L += [f"| {md_cell(k)} | {md_cell(v)} |" for k, v in s.items() if k not in DEATH_KEYS + LOSS_KEYS]
        L.append("")

    L += ["## Final figures", ""]
    cons = {}
    cons_model = None
    for row in run.consensus or []:
        if row["model"] == "consensus":
            cons_model = row
        else:
            cons[row["model"]] = row
    if run.robots:
        L += ["| robot | last round | final val loss (round) | final train loss | bytes sent per round "
              "| chunks requested | chunks re-sent | timeouts | model val loss | consensus error |",
              "|---|---|---|---|---|---|---|---|---|---|"]
        for i in run.robots:
            m, t = run.metrics.get(i), run.traffic.get(i)
            last_round = val = train = None
            vr = None
            if m is not None and m["round"].size:
                last_round = int(m["round"][-1])
                val, k = last_finite(np, m["val_loss"])
                vr = int(m["round"][k]) if k is not None else None
                train, _ = last_finite(np, m["train_loss"])
            bpr = req = res = tmo = None
            if t is not None and t["round"].size:
                b = t["bytes_sent"][np.isfinite(t["bytes_sent"])]
                bpr = float(b.mean()) if b.size else None
                req, res, tmo = (int(np.nansum(t[c])) for c in ("chunks_requested", "chunks_resent", "timeouts"))
            c = cons.get(str(i))
            L.append(f"| {i} | {fmt(last_round)} | {fmt(val)}" + (f" ({vr})" if vr is not None else "") +
                     f" | {fmt(train)} | {'n/a' if bpr is None else f'{bpr:,.0f}'} | {fmt(req)} | {fmt(res)} | {fmt(tmo)} | "
                     f"{fmt(c['val_loss']) if c else 'n/a'} | {fmt(c['consensus_error']) if c else 'n/a'} |")
        L.append("")
    if run.traffic:
        cols = ["bytes_sent", "bytes_received", "chunks_sent", "chunks_received", "chunks_resent",
                "chunks_requested", "duplicates", "stale", "timeouts", "rejoins", "crc_failures", "invalid"]
        tot = []
        for c in cols:
            vals = [t[c] for t in run.traffic.values() if c in t]
            if vals:
                tot.append((c, int(sum(float(np.nansum(v)) for v in vals))))
        t = dict(tot)
        sent = np.concatenate([v["bytes_sent"] for v in run.traffic.values()])
        sent = sent[np.isfinite(sent)]
        per_round = f"{sent.mean():,.0f}" if sent.size else "n/a"
        L += [f"- total chunks requested {t['chunks_requested']:,}, re-sent {t['chunks_resent']:,}, "
              f"timeouts {t['timeouts']:,}; bytes sent per round and robot {per_round} (mean)",
              "- fleet traffic, summed over robots and rounds: " + ", ".join(f"{c} {v:,}" for c, v in tot)]
    extra = [row for k, row in cons.items() if not (k.isdigit() and int(k) in run.robots)]
    for row in extra:
        L.append(f"- model {row['model']}: val loss {fmt(row['val_loss'])}, "
                 f"consensus error {fmt(row['consensus_error'])}")
    if cons_model is not None:
        L.append(f"- consensus model: val loss {fmt(cons_model['val_loss'])}"
                 + (f", consensus error {fmt(cons_model['consensus_error'])}"
                    if math.isfinite(cons_model["consensus_error"]) else ""))
    elif run.consensus is not None:
        L.append("- consensus model: no `consensus` row in maps/consensus.csv")
    if s is not None and "wall_s" in s:
        L.append(f"- wall time: {md_cell(s['wall_s'])} s (run.json)")
    else:
        walls = [float(m["wall_s"][-1]) for m in run.metrics.values()
                 if "wall_s" in m and m["wall_s"].size and math.isfinite(m["wall_s"][-1])]
        L.append(f"- wall time: not in run.json; largest last `wall_s` of metrics.csv: {fmt(max(walls))} s"
                 if walls else "- wall time: not recorded")
    if run.meta is not None:
        meta = ", ".join(f"{k} {fmt(run.meta[k], 3) if isinstance(run.meta[k], float) else md_cell(run.meta[k])}" for k in ("res", "width", "height", "mc", "seed", "std_max", "models")
                         if k in run.meta)
        L.append(f"- maps: {meta}")
    L.append("")
    L += knowledge_section(run, figures)

    L += ["## Figures", ""]
    captions = {
        "scene.png": "the plan (OSMesa rendering)",
        "map_mean.png": "occupancy: MC mean, the robots' tours and map.yaml's occupied threshold on top",
        "map_std.png": "uncertainty: MC standard deviation",
        "map_single.png": "one stochastic pass: P(occupied) of a single draw of the weights",
        "map_rounds.png": "the map as it forms: the consensus MC mean at kept checkpoint rounds",
        "kde.png": "where the lidar hits the robots trained on are (hits per m²)",
        "val_loss.png": "validation loss per robot",
        "traffic.png": "fleet traffic per round",
    }
    shown = (["scene.png"] if run.scene else []) + figures
    for name in shown:
        L += [f"### {captions.get(name, name)}", "", f"![{name[:-4]}]({name})", ""]
        if name == "map_rounds.png":
            L += [strip_note(run), ""]
    if not shown:
        L += ["(none: see below)", ""]
    if run.has_ros_map:
        L += ["## ROS map", "",
              "`maps/map.pgm` + `maps/map.yaml`: load with ROS map_server: "
              "`ros2 run nav2_map_server map_server --ros-args -p yaml_filename:=maps/map.yaml`", ""]
        L += ros_map_lines(run)
    if run.notes:
        L += ["## Not in this report", ""] + [f"- {n}" for n in run.notes] + [""]
    return "\n".join(L)


def yaml_scalars(path):
    """The `key: value` lines of a flat YAML file (comments skipped), as strings; {} when unreadable."""
    out = {}
    try:
        with open(path, encoding="utf-8", errors="replace") as f:
            for line in f:
                m = re.match(r"^([A-Za-z_]+):\s*(.*?)\s*$", line)
                if m:
                    out[m.group(1)] = m.group(2)
    except OSError:
        pass
    return out


def ros_map_lines(run):
    """The thresholds of maps/map.yaml and, from map_meta.json (host_sim maps writes them), the map as
    nav2 reads it against the ground truth."""
    y = yaml_scalars(run.p("maps", "map.yaml"))
    meta = run.meta or {}
    L = []
    if "occupied_thresh" in y and "free_thresh" in y:
        how = {"valset": "chosen on the validation set for this model (best F1 of the lidar hits; of the free "
                         "points below it)",
               "default": "ROS map_server's defaults: no validation set was given"}.get(meta.get("thresholds"), "")
        L.append(f"- thresholds (mode {y.get('mode', 'trinary')}): occupied_thresh {y['occupied_thresh']}, "
                 f"free_thresh {y['free_thresh']}" + (f", {how}" if how else ""))
    keys = ("nav2_occupied", "nav2_free", "nav2_unknown", "nav2_wall_iou", "nav2_free_truly_free")
    if all(isinstance(meta.get(k), (int, float)) and not isinstance(meta.get(k), bool) for k in keys):
        L.append(f"- as nav2 reads it: {meta['nav2_occupied']} occupied, {meta['nav2_free']} free, "
                 f"{meta['nav2_unknown']} unknown cells; against the plan's ground truth: wall IoU "
                 f"{meta['nav2_wall_iou']:.3f}, {100 * meta['nav2_free_truly_free']:.1f} % of the free cells truly free")
        if meta["nav2_occupied"] == 0:
            L.append("- **no cell is occupied: the map has no walls for a navigation stack**")
    return L + ([""] if L else [])


# ---- main ------------------------------------------------------------------------------------

def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 epilog=__doc__.split("\n\n", 1)[1],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("run_dir", metavar="RUN_DIR", help="folder of one fleet run")
    ap.add_argument("-q", "--quiet", action="store_true", help="print nothing but errors")
    ap.add_argument("--strip", type=int, default=STRIP_ROUNDS, metavar="N",
                    help=f"map_rounds.png: the map at N kept checkpoint rounds, evenly spaced (0: none; "
                         f"default {STRIP_ROUNDS})")
    ap.add_argument("--host-sim", metavar="BIN", help="the host_sim that makes the strip's maps "
                    "(default: run.json's \"host_sim\", else build/bin/host_sim)")
    a = ap.parse_args(argv)
    try:
        if not os.path.isdir(a.run_dir):
            raise ReportError(f"{a.run_dir}: " + ("Not a directory" if os.path.exists(a.run_dir)
                                                  else "No such file or directory"))
        if not os.access(a.run_dir, os.W_OK):
            raise ReportError(f"{a.run_dir}: Permission denied (outputs go there)")
        try:
            import numpy as np
            import matplotlib
            matplotlib.use("Agg")
            import matplotlib.pyplot as plt
            import scipy.stats  # noqa: F401
        except ImportError as e:
            raise ReportError(f"needs numpy, scipy and matplotlib (Debian python3-numpy, python3-scipy, "
                              f"python3-matplotlib; run with /usr/bin/python3): {e}")
        clear_stale_temps(a.run_dir)
        run = Run(np, a.run_dir)
        run.load()  # every input validated before any output is written
        figures = fig_maps(plt, run, a.run_dir)
        make_strip(run, a.strip, a.host_sim)
        name = fig_strip(plt, run, a.run_dir)
        if name:
            figures.insert(1 if figures[:1] == ["map_mean.png"] else 0, name)
        for f in (fig_hits, fig_val_loss, fig_traffic):
            name = f(plt, run, a.run_dir)
            if name:
                figures.append(name)
        text = summary(run, figures)
        write_atomic(os.path.join(a.run_dir, "summary.md"), lambda f: f.write(text.encode("utf-8")))
    except ReportError as e:
        print(f"fleet_report: {e}", file=sys.stderr)
        return 1
    if not a.quiet:
        for f in figures + run.redrawn:
            print(f"fleet_report: wrote {os.path.join(a.run_dir, f)}")
        print(f"fleet_report: wrote {os.path.join(a.run_dir, 'summary.md')}"
              + (f" ({len(run.notes)} item(s) missing, listed there)" if run.notes else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
