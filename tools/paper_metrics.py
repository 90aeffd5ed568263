#!/usr/bin/python3
"""Uncertainty and map-quality metrics of one BNN occupancy map (the paper's numbers).

    tools/paper_metrics.py --maps DIR [--dist M] [--seen-dist M] [--json OUT.json] [--markdown] SAMPLES...

Reads DIR (written by `host_sim maps`): map_mean.npy, map_std.npy (float32 H x W, MC mean and
standard deviation of the occupancy probability), map_truth.npy (uint8 H x W: 0 free, 1 wall,
255 unknown, excluded from every metric), map_meta.json (res, xmin, ymin, xmax, ymax, width,
height; row 0 is the top row: cell (r, c) has its centre at x = xmin + (c + 0.5) res,
y = ymax - (r + 0.5) res), optionally map_epistemic.npy (float32 H x W, same grid: the share of
the prior variance of the model's Bayesian linear read-out left after the data, in (0, 1],
1 = nothing observed there; older maps folders lack it, and every epistemic key is then left
out), and the robots' training samples (tools/samples.py format; points with occ > 0.5 are lidar
hits, all points are lidar points). Only the known cells (truth != 255) are scored.

Seen and unseen cells. A known cell is SEEN when its centre is within --seen-dist (SEEN_DIST =
0.15 m) of a lidar sample point of any robot, UNSEEN otherwise. Why 0.15 m: host_sim places
samples along every beam from the robot to the hit at most 3.5 m / 25 = 0.14 m apart, so every
point of a ray is within 0.07 m of a sample, and the centre of a 0.1 m cell the ray crosses is
within half its diagonal, 0.0707 m, of the ray's points inside it: within 0.07 + 0.0707 =
0.141 m < 0.15 m of a sample. A cell some ray crossed is seen; a seen cell is at most 0.15 m
from where a ray went (on a finer grid a few cells beside a ray are seen too).

The uncertainty scores, side by side (larger = less known):
  std         the MC-50 standard deviation of the occupancy (map_std.npy)
  epistemic   map_epistemic.npy, when the maps folder has it
  dist        the distance from the cell centre to the nearest sample point: the non-Bayesian
              reference, which separates unseen from seen perfectly by construction (AUC 1)

Prints one "name value" line per metric:
  auc_std_unobserved    ROC AUC of the MC std as a score for "unobserved" (cell centre farther
                        than --dist, 0.5 m, from every lidar point): does the std flag them?
                        (the paper's rows; kept as it was)
  unobserved_fraction   fraction of the known cells that are unobserved (--dist)
  spearman_std_kde      Spearman correlation of the std with a Gaussian KDE of the lidar hits
  seen_fraction         fraction of the known cells that are seen (--seen-dist)
  auc_seen_<score>      ROC AUC of the score for unseen (positive) vs seen cells: 1 = every
                        unseen cell scores above every seen one, 0.5 = chance
  ause_<score>          area under the sparsification error: sort the cells by the score,
                        largest first; for f = 0, 0.01, .., 0.99 remove the top fraction f and
                        take the mean |mean - truth| of the rest; subtract the same curve with
                        the cells sorted by that error itself (the oracle); the trapezoid area
                        of the difference over those f (the range [0, 0.99], 99 intervals).
                        0 = the score orders the cells as their errors do; lower is better.
                        Cells of equal score count as removed in a random order (their errors
                        are averaged within the tie), so the figure does not depend on the
                        cells' order in the grid
  spearman_kde_<score>  Spearman correlation of the score with the KDE of the lidar hits
                        (negative = less uncertain where the data are dense)
  <score>_mean_seen, <score>_mean_unseen   mean of the std and the epistemic score over the
                        seen and the unseen cells
  mse, brier            mean (mean - truth)^2 of the MC mean vs the 0/1 truth (the Brier score
                        of the map as a probability of a wall; the same number under two names)
  wall_iou, ece         IoU of the walls (mean > 0.5), expected calibration error (15 equal-
                        width bins)
  n_cells, n_points, n_hits, std_mean_observed, std_mean_unobserved
The KDE uses at most 20000 hits (a fixed random subset). --markdown prints instead the table
"score | AUC unseen/seen | AUSE | Spearman vs KDE" (tools/fleet_report.py puts it in summary.md;
as a module: markdown_table(metrics)).
--json OUT.json writes the same numbers (NaN as null) to a temporary file beside it, renamed.
A malformed input stops with a one-line reason naming the file and exit status 1.
Needs Debian's python3-numpy and python3-scipy.
"""
import argparse
import json
import math
import os
import sys
import tempfile

import numpy as np

TOOLS_DIR = os.path.dirname(os.path.realpath(__file__))
sys.path.insert(0, TOOLS_DIR)
import samples  # noqa: E402  (tools/samples.py)

META_KEYS = ("res", "xmin", "ymin", "xmax", "ymax", "width", "height")
GRIDS = (("mean", "map_mean.npy", np.float32), ("std", "map_std.npy", np.float32),
         ("truth", "map_truth.npy", np.uint8))
UNKNOWN = 255
SEEN_DIST = 0.15      # metres: see the module's docstring
EPISTEMIC = "map_epistemic.npy"
EPISTEMIC_SLACK = 1e-4  # a share of the prior variance may exceed 1 by this much (float rounding)
AUSE_STEPS = 100
SCORES = ("std", "epistemic", "dist")


class MetricsError(Exception):
    """A malformed input or an unwritable output: one line, exit 1."""


def _meta(path):
    """Read map_meta.json and check the grid keys, so the cell centres are right."""
    if not os.path.isfile(path):
        raise MetricsError(f"{path}: missing (host_sim maps writes it)")
    try:
        with open(path, encoding="utf-8") as f:
            meta = json.load(f)
    except (OSError, UnicodeDecodeError, ValueError) as e:
        raise MetricsError(f"{path}: not readable JSON ({str(e).splitlines()[0]})")
    if not isinstance(meta, dict):
        raise MetricsError(f"{path}: expected a JSON object")
    for k in META_KEYS:
        v = meta.get(k)
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise MetricsError(f"{path}: \"{k}\" must be a finite number, got {v!r}")
    for k in ("width", "height"):
        if not isinstance(meta[k], int) or meta[k] < 1:
            raise MetricsError(f"{path}: \"{k}\" must be a whole number >= 1, got {meta[k]!r}")
    if meta["res"] <= 0:
        raise MetricsError(f"{path}: \"res\" must be > 0, got {meta['res']!r}")
    for lo, hi, n in (("xmin", "xmax", "width"), ("ymin", "ymax", "height")):
        want = meta[lo] + meta[n] * meta["res"]
        if abs(meta[hi] - want) > 1e-6 * max(1.0, abs(want)):
            raise MetricsError(f"{path}: {hi} {meta[hi]} != {lo} + {n} * res = {want}")
    return meta


def _grid(path, shape, dtype):
    """One .npy grid of a maps folder, checked for its shape and dtype."""
    if not os.path.isfile(path):
        raise MetricsError(f"{path}: missing (host_sim maps writes it)")
    try:
        a = np.load(path, allow_pickle=False)
    except (OSError, ValueError, EOFError) as e:
        raise MetricsError(f"{path}: not a readable .npy array ({str(e).splitlines()[0]})")
    if not isinstance(a, np.ndarray) or a.shape != shape:
        raise MetricsError(f"{path}: shape {getattr(a, 'shape', '?')}, map_meta.json says "
                           f"{shape} (height, width)")
    if a.dtype != dtype:
        raise MetricsError(f"{path}: dtype {a.dtype}, expected {np.dtype(dtype).name}")
    return a


def load_map(maps_dir):
    """Load and check mean, std, truth and meta of a maps folder, with the cell centres in metres;
    "epistemic" too when the folder has map_epistemic.npy (None otherwise)."""
    meta = _meta(os.path.join(maps_dir, "map_meta.json"))
    shape = (meta["height"], meta["width"])
    out = {"meta": meta}
    for key, name, dtype in GRIDS:
        out[key] = _grid(os.path.join(maps_dir, name), shape, dtype)
    for key, hi in (("mean", 1.0), ("std", np.inf)):
        if not (np.isfinite(out[key]).all() and (out[key] >= 0).all() and (out[key] <= hi).all()):
            raise MetricsError(f"{os.path.join(maps_dir, f'map_{key}.npy')}: a value is not finite or "
                               f"outside [0, {hi}]")
    out["epistemic"] = None
    path = os.path.join(maps_dir, EPISTEMIC)
    if os.path.exists(path):
        e = _grid(path, shape, np.float32)
        if not (np.isfinite(e).all() and (e >= 0).all() and (e <= 1 + EPISTEMIC_SLACK).all()):
            raise MetricsError(f"{path}: a value is not finite or outside (0, 1]")
        out["epistemic"] = e
    bad = ~np.isin(out["truth"], (0, 1, UNKNOWN))
    if bad.any():
        r, c = np.argwhere(bad)[0]
        raise MetricsError(f"{os.path.join(maps_dir, 'map_truth.npy')}: cell ({r}, {c}) is "
                           f"{out['truth'][r, c]}, expected 0, 1 or {UNKNOWN}")
    res = float(meta["res"])
    out["xc"] = meta["xmin"] + (np.arange(shape[1]) + 0.5) * res
    out["yc"] = meta["ymax"] - (np.arange(shape[0]) + 0.5) * res
    X, Y = np.meshgrid(out["xc"], out["yc"])
    out["cell_xy"] = np.column_stack([X.ravel(), Y.ravel()])  # row-major, like mean.ravel()
    return out


def load_points(sample_files):
    """All lidar points and the lidar hits (occ > 0.5) of the sample files, in metres."""
    xs, ys, occ = [], [], []
    for p in sample_files:
        try:
            h, a = samples.load(p)
        except samples.SamplesError as e:
            raise MetricsError(str(e))
        except OSError as e:
            raise MetricsError(f"{p}: {e.strerror or e}")
        x, y = samples.to_metres(h, a)
        xs.append(x)
        ys.append(y)
        occ.append(a["occ"] > 0.5)
    if not xs:
        return np.zeros((0, 2)), np.zeros((0, 2))
    xy = np.column_stack([np.concatenate(xs), np.concatenate(ys)])
    return xy, xy[np.concatenate(occ)]


def nearest_distance(cell_xy, points_xy):
    """Distance in metres from each cell centre to the nearest lidar point (inf when there is none)."""
    from scipy.spatial import cKDTree
    cell_xy = np.asarray(cell_xy, dtype=np.float64).reshape(-1, 2)
    points_xy = np.asarray(points_xy, dtype=np.float64).reshape(-1, 2)
    if len(points_xy) == 0:
        return np.full(len(cell_xy), np.inf)
    d, _ = cKDTree(points_xy).query(cell_xy, k=1)
    return d


def unobserved_mask(cell_xy, points_xy, dist):
    """True for cells whose centre is farther than dist metres from every lidar point."""
    return nearest_distance(cell_xy, points_xy) > dist


def seen_mask(cell_xy, points_xy, seen_dist=SEEN_DIST):
    """True for the seen cells: the centre within seen_dist metres of a lidar sample point
    (SEEN_DIST, 0.15 m: a cell a ray crossed; the module's docstring says why)."""
    return nearest_distance(cell_xy, points_xy) <= seen_dist


def sparsification(score, error, steps=AUSE_STEPS):
    """The sparsification curve: for f = k / steps, k = 0 .. steps - 1, the mean error of the cells
    left once the fraction f with the largest score is removed (floor(f n) cells). Cells of equal
    score are removed in a random order: their errors are replaced by the mean of the tie, the
    expected value of that order."""
    score = np.asarray(score, dtype=np.float64).ravel()
    error = np.asarray(error, dtype=np.float64).ravel()
    n = score.size
    if n == 0:
        return np.full(steps, np.nan)
    order = np.argsort(-score, kind="stable")
    s, e = score[order], error[order]
    starts = np.flatnonzero(np.r_[True, s[1:] != s[:-1]])
    sums = np.add.reduceat(e, starts)
    counts = np.diff(np.r_[starts, n])
    e = np.repeat(sums / counts, counts)
    removed = np.r_[0.0, np.cumsum(e)]
    k = (np.arange(steps, dtype=np.int64) * n) // steps   # floor(f n) < n: a cell is always left
    return (removed[n] - removed[k]) / (n - k)


def ause(score, error, steps=AUSE_STEPS):
    """Area under the sparsification error: sparsification(score) minus the oracle's (the cells
    ordered by the error itself), trapezoid area over f = 0 .. (steps - 1) / steps. 0 when the
    score orders the cells like their errors, > 0 otherwise; NaN without cells."""
    error = np.asarray(error, dtype=np.float64).ravel()
    if error.size == 0:
        return float("nan")
    gap = sparsification(score, error, steps) - sparsification(error, error, steps)
    f = np.arange(steps) / steps
    return float(np.sum((gap[1:] + gap[:-1]) * 0.5 * np.diff(f)))


def roc_auc(scores, labels):
    """ROC AUC of scores for the True class (Mann-Whitney U, ties as average ranks); NaN if a class is empty."""
    from scipy.stats import rankdata
    scores = np.asarray(scores, dtype=np.float64).ravel()
    labels = np.asarray(labels, dtype=bool).ravel()
    n1 = int(labels.sum())
    n0 = labels.size - n1
    if n1 == 0 or n0 == 0:
        return float("nan")
    u = rankdata(scores)[labels].sum() - n1 * (n1 + 1) / 2.0
    return float(u / (n1 * n0))


def spearman(a, b):
    """Spearman rank correlation of a and b; NaN for constant or too short input."""
    from scipy.stats import spearmanr
    a = np.asarray(a, dtype=np.float64).ravel()
    b = np.asarray(b, dtype=np.float64).ravel()
    if a.size < 2 or a.size != b.size or np.ptp(a) == 0 or np.ptp(b) == 0:
        return float("nan")
    return float(spearmanr(a, b)[0])


def kde_density(hits_xy, cell_xy, max_points=20000, seed=0):
    """Gaussian KDE (default bandwidth) of the lidar hits at the cells: where the data was dense."""
    from scipy.stats import gaussian_kde
    pts = np.asarray(hits_xy, dtype=np.float64).reshape(-1, 2)
    if len(pts) > max_points:
        pts = pts[np.sort(np.random.default_rng(seed).choice(len(pts), max_points, replace=False))]
    if len(pts) < 3:
        raise MetricsError(f"only {len(pts)} lidar hits in the samples, too few for a KDE")
    try:
        kde = gaussian_kde(pts.T)
    except (np.linalg.LinAlgError, ValueError) as e:
        raise MetricsError(f"no KDE of the lidar hits ({str(e).splitlines()[0]})")
    return kde(np.asarray(cell_xy, dtype=np.float64).reshape(-1, 2).T)


def map_errors(mean, truth):
    """MSE of the mean vs the 0/1 truth and wall IoU (mean > 0.5) on the known cells (truth != 255)."""
    mean, truth = np.asarray(mean, dtype=np.float64), np.asarray(truth)
    known = truth != UNKNOWN
    p, wall = mean[known], truth[known] == 1
    if p.size == 0:
        return float("nan"), float("nan")
    mse = float(np.mean((p - wall) ** 2))
    pred = p > 0.5
    union = int((pred | wall).sum())
    iou = float((pred & wall).sum() / union) if union else float("nan")
    return mse, iou


def ece(prob, truth, bins=15):
    """Expected calibration error on the known cells: sum over equal-width bins of |bin|/n |mean p - wall fraction|."""
    prob, truth = np.asarray(prob, dtype=np.float64), np.asarray(truth)
    known = truth != UNKNOWN
    p, wall = prob[known], (truth[known] == 1).astype(np.float64)
    if p.size == 0:
        return float("nan")
    idx = np.clip((p * bins).astype(np.int64), 0, bins - 1)
    sp = np.bincount(idx, weights=p, minlength=bins)
    sw = np.bincount(idx, weights=wall, minlength=bins)
    return float(np.abs(sp - sw).sum() / p.size)  # |bin|/n * |sp/|bin| - sw/|bin||


def _mean_or_nan(a):
    """The mean of a, NaN when a is empty (no warning)."""
    return float(a.mean()) if a.size else float("nan")


def _kde_or_none(hits_xy, cells):
    """The hits' KDE at the cells; None when there is none (no cell, fewer than 3 hits, degenerate)."""
    if not cells.size:
        return None
    try:
        return kde_density(hits_xy, cells)
    except MetricsError:
        return None


def _spearman_kde(score, kde):
    """Spearman of a score with the hits' KDE; NaN without a KDE."""
    return float("nan") if kde is None else spearman(score, kde)


def compute(maps_dir, sample_files, dist=0.5, seen_dist=SEEN_DIST):
    """Every metric of the map in maps_dir against the lidar points of sample_files (known cells
    only); the epistemic keys only when maps_dir has map_epistemic.npy."""
    m = load_map(maps_dir)
    all_xy, hits_xy = load_points(sample_files)
    known = (m["truth"] != UNKNOWN).ravel()
    cells = m["cell_xy"][known]
    std = m["std"].astype(np.float64).ravel()[known]
    near = nearest_distance(cells, all_xy)
    unobs = near > dist
    seen = near <= seen_dist
    mse, iou = map_errors(m["mean"], m["truth"])
    error = np.abs(m["mean"].astype(np.float64).ravel()[known] - (m["truth"].ravel()[known] == 1))
    kde = _kde_or_none(hits_xy, cells)
    r = {
        "auc_std_unobserved": roc_auc(std, unobs),
        "unobserved_fraction": _mean_or_nan(unobs.astype(np.float64)),
        "spearman_std_kde": _spearman_kde(std, kde),
        "mse": mse,
        "wall_iou": iou,
        "ece": ece(m["mean"], m["truth"]),
        "n_cells": int(known.sum()),
        "n_points": int(len(all_xy)),
        "n_hits": int(len(hits_xy)),
        "std_mean_observed": _mean_or_nan(std[~unobs]),
        "std_mean_unobserved": _mean_or_nan(std[unobs]),
        "brier": mse,
        "seen_fraction": _mean_or_nan(seen.astype(np.float64)),
    }
    scores = {"std": std, "dist": near}
    if m["epistemic"] is not None:
        scores["epistemic"] = m["epistemic"].astype(np.float64).ravel()[known]
    for name in SCORES:
        if name not in scores:
            continue
        v = scores[name]
        r[f"auc_seen_{name}"] = roc_auc(v, ~seen)
        r[f"ause_{name}"] = ause(v, error)
        r[f"spearman_kde_{name}"] = _spearman_kde(v, kde)
    for name in ("std", "epistemic"):
        if name in scores:
            r[f"{name}_mean_seen"] = _mean_or_nan(scores[name][seen])
            r[f"{name}_mean_unseen"] = _mean_or_nan(scores[name][~seen])
    return r


SCORE_LABELS = {"std": "MC-50 std", "epistemic": "epistemic (read-out variance share)",
                "dist": "distance to nearest sample (reference)"}


def markdown_table(r, digits=3):
    """The scores side by side as a markdown table (lines): AUC unseen/seen, AUSE, Spearman vs KDE;
    a score without its keys (no map_epistemic.npy) has no row."""
    def f(v):
        return "-" if v is None or not math.isfinite(v) else f"{v:.{digits}g}"
    L = ["| score | AUC unseen/seen | AUSE | Spearman vs KDE |", "|---|---|---|---|"]
    for name in SCORES:
        if f"auc_seen_{name}" in r:
            L.append(f"| {SCORE_LABELS[name]} | {f(r[f'auc_seen_{name}'])} | {f(r[f'ause_{name}'])} | "
                     f"{f(r[f'spearman_kde_{name}'])} |")
    return L


def write_json(path, obj):
    """Write obj as JSON (NaN as null) whole or not at all: a temporary file beside path, renamed."""
    clean = {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in obj.items()}
    d = os.path.dirname(os.path.abspath(path))
    try:
        fd, tmp = tempfile.mkstemp(prefix=".paper_metrics.", suffix=".tmp", dir=d)
    except OSError as e:
        raise MetricsError(f"{path}: cannot write ({e.strerror or e})")
    try:
        with os.fdopen(fd, "w") as f:
            json.dump(clean, f, indent=1)
            f.write("\n")
        os.replace(tmp, path)
    except OSError as e:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise MetricsError(f"{path}: cannot write ({e.strerror or e})")


def _dist(s):
    """argparse type of --dist: a finite distance > 0 in metres."""
    v = float(s)
    if not (math.isfinite(v) and v > 0):
        raise argparse.ArgumentTypeError(f"must be a finite number > 0, got {s}")
    return v


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--maps", required=True, metavar="DIR", help="folder written by host_sim maps")
    ap.add_argument("--dist", type=_dist, default=0.5, metavar="M",
                    help="a cell is unobserved when no lidar point is within M metres (default 0.5)")
    ap.add_argument("--seen-dist", type=_dist, default=SEEN_DIST, metavar="M",
                    help=f"a cell is seen when a lidar point is within M metres (default {SEEN_DIST})")
    ap.add_argument("--json", metavar="OUT.json", help="also write the metrics as JSON")
    ap.add_argument("--markdown", action="store_true",
                    help="print the table score | AUC unseen/seen | AUSE | Spearman vs KDE instead")
    ap.add_argument("samples", nargs="+", metavar="SAMPLES", help="host_sim sample files the robots trained on")
    args = ap.parse_args(argv)
    try:
        r = compute(args.maps, args.samples, args.dist, args.seen_dist)
        if args.json:
            write_json(args.json, dict(r, dist=args.dist, seen_dist=args.seen_dist))
    except MetricsError as e:
        print(f"paper_metrics.py: {e}", file=sys.stderr)
        return 1
    if args.markdown:
        print("\n".join(markdown_table(r)))
        return 0
    for k, v in r.items():
        print(f"{k} {v}" if isinstance(v, int) else f"{k} {v:.6g}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
