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
  coverage.png                  share of the free space seen against simulated time: the fleet's
                                union (coverage.csv) and each robot alone (robot_<i>/coverage.csv)
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
import sys

TOOLS_DIR = os.path.dirname(os.path.realpath(__file__))
sys.path.insert(0, TOOLS_DIR)
import fleet_losses  # noqa: E402  (the same totals as tools/fleet's last line)
from fleet_io import (MAP_KINDS, ReportError, clear_stale_temps, load_npy,  # noqa: E402  (shared with fleet_figures)
                      resolve_tour, write_atomic, yaml_scalars)
from fleet_figures import (fig_coverage, fig_hits, fig_maps, fig_strip, fig_traffic, fig_val_loss,  # noqa: E402  (the figures)
                           make_strip, strip_note)
sys.path.pop(0)
STRIP_ROUNDS = 4          # map_rounds.png's panels

METRICS_NEED = ("round", "train_loss", "val_loss")
TRAFFIC_NEED = ("round", "bytes_sent", "chunks_requested", "chunks_resent", "timeouts")
COVERAGE_NEED = ("sim_time_s", "robot_seconds", "coverage")
CONSENSUS_NEED = ("model", "val_loss", "consensus_error")


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
        self.coverage = None   # coverage.csv (the fleet's union, host_sim coverage merge)
        self.robot_coverage = {}  # robot -> its robot_<i>/coverage.csv

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

        self.load_coverage()
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

    def load_coverage(self):
        """coverage.csv of the fleet and of each robot: share of the free space seen, in [0, 1],
        never falling, against simulated time (host_sim/world/sim_coverage.h)."""
        np = self.np

        def one(rel):
            f = self.p(rel)
            if not os.path.isfile(f):
                return None
            c = {k: np.asarray(v) for k, v in read_csv(f, COVERAGE_NEED).items()}
            v = c["coverage"]
            if v.size == 0:
                raise ReportError(f"{f}: no rows")
            if not (np.all(np.isfinite(v)) and v.min() >= 0 and v.max() <= 1):
                raise ReportError(f"{f}: a coverage outside [0, 1]")
            if np.any(np.diff(v) < 0) or np.any(np.diff(c["sim_time_s"]) <= 0):
                raise ReportError(f"{f}: coverage falls or time does not rise")
            return c

        self.coverage = one("coverage.csv")
        if self.coverage is None:
            self.note("coverage.csv is missing (host_sim coverage merge): no fleet coverage")
        for i in self.robots:
            c = one(os.path.join(f"robot_{i}", "coverage.csv"))
            if c is not None:
                self.robot_coverage[i] = c

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


# ---- formatting ------------------------------------------------------------------------------

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
    if isinstance(failed, dict) and "service" in failed:
        L += [f"**The fleet failed: {md_cell(failed['service'])} exited ({md_cell(failed.get('how', '?'))}) while "
              f"the robots ran (its log: `{md_cell(failed.get('log', '?'))}`); the robots were stopped, so no robot "
              "has a final model and there are no maps.**", ""]
    elif isinstance(failed, dict):
        L += [f"**The fleet failed: robot {md_cell(failed.get('robot', '?'))} died at round "
              f"{md_cell(failed.get('round', '?'))} ({md_cell(failed.get('how', '?'))}); the other robots were "
              "stopped, so no robot has a final model and there are no maps.**", ""]
    if not isinstance(deaths, list):
        deaths = [deaths]
    if deaths:
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
    if run.coverage is not None:
        c = run.coverage
        each = ", ".join(f"robot {i} {float(r['coverage'][-1]):.3f}" for i, r in sorted(run.robot_coverage.items()))
        L.append(f"- coverage: {float(c['coverage'][-1]):.3f} of the free space seen by some lidar ray at "
                 f"{float(c['sim_time_s'][-1]):.1f} s simulated ({float(c['robot_seconds'][-1]):.0f} robot-seconds; "
                 f"coverage.csv, 0.1 m grid)" + (f"; alone: {each}" if each else ""))
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
        "coverage.png": "coverage: share of the free space seen against simulated time",
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
        for f in (fig_hits, fig_val_loss, fig_traffic, fig_coverage):
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
