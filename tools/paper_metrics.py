#!/usr/bin/python3
"""Uncertainty and map-quality metrics of one BNN occupancy map (the paper's numbers).

    tools/paper_metrics.py --maps DIR [--dist M] [--json OUT.json] SAMPLES...

Reads DIR (written by `host_sim maps`): map_mean.npy, map_std.npy (float32 H x W, MC mean and
standard deviation of the occupancy probability), map_truth.npy (uint8 H x W: 0 free, 1 wall,
255 unknown, excluded from every metric), map_meta.json (res, xmin, ymin, xmax, ymax, width,
height; row 0 is the top row: cell (r, c) has its centre at x = xmin + (c + 0.5) res,
y = ymax - (r + 0.5) res), and the robots' training samples (tools/samples.py format; points
with occ > 0.5 are lidar hits, all points are lidar points). Prints one "name value" line:
  auc_std_unobserved    ROC AUC of the MC std as a score for "unobserved" (cell centre farther
                        than --dist metres from every lidar point): does the std flag them?
  unobserved_fraction   fraction of the known cells that are unobserved
  spearman_std_kde      Spearman correlation of the std with a Gaussian KDE of the lidar hits
  mse, wall_iou, ece    MSE of the mean vs the 0/1 truth, IoU of the walls (mean > 0.5),
                        expected calibration error (15 equal-width bins)
  n_cells, n_points, n_hits, std_mean_observed, std_mean_unobserved
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


def load_map(maps_dir):
    """Load and check mean, std, truth and meta of a maps folder, with the cell centres in metres."""
    meta = _meta(os.path.join(maps_dir, "map_meta.json"))
    shape = (meta["height"], meta["width"])
    out = {"meta": meta}
    for key, name, dtype in GRIDS:
        path = os.path.join(maps_dir, name)
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
        out[key] = a
    for key, hi in (("mean", 1.0), ("std", np.inf)):
        if not (np.isfinite(out[key]).all() and (out[key] >= 0).all() and (out[key] <= hi).all()):
            raise MetricsError(f"{os.path.join(maps_dir, f'map_{key}.npy')}: a value is not finite or "
                               f"outside [0, {hi}]")
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


def unobserved_mask(cell_xy, points_xy, dist):
    """True for cells whose centre is farther than dist metres from every lidar point."""
    from scipy.spatial import cKDTree
    cell_xy = np.asarray(cell_xy, dtype=np.float64).reshape(-1, 2)
    points_xy = np.asarray(points_xy, dtype=np.float64).reshape(-1, 2)
    if len(points_xy) == 0:
        return np.ones(len(cell_xy), dtype=bool)
    d, _ = cKDTree(points_xy).query(cell_xy, k=1)
    return d > dist


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


def _spearman_kde(std, hits_xy, cells):
    """Spearman of the std with the hits' KDE; NaN when there is no KDE (fewer than 3 hits, degenerate)."""
    if not cells.size:
        return float("nan")
    try:
        return spearman(std, kde_density(hits_xy, cells))
    except MetricsError:
        return float("nan")


def compute(maps_dir, sample_files, dist=0.5):
    """Every metric of the map in maps_dir against the lidar points of sample_files (known cells only)."""
    m = load_map(maps_dir)
    all_xy, hits_xy = load_points(sample_files)
    known = (m["truth"] != UNKNOWN).ravel()
    cells = m["cell_xy"][known]
    std = m["std"].astype(np.float64).ravel()[known]
    unobs = unobserved_mask(cells, all_xy, dist)
    mse, iou = map_errors(m["mean"], m["truth"])
    return {
        "auc_std_unobserved": roc_auc(std, unobs),
        "unobserved_fraction": _mean_or_nan(unobs.astype(np.float64)),
        "spearman_std_kde": _spearman_kde(std, hits_xy, cells),
        "mse": mse,
        "wall_iou": iou,
        "ece": ece(m["mean"], m["truth"]),
        "n_cells": int(known.sum()),
        "n_points": int(len(all_xy)),
        "n_hits": int(len(hits_xy)),
        "std_mean_observed": _mean_or_nan(std[~unobs]),
        "std_mean_unobserved": _mean_or_nan(std[unobs]),
    }


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
    ap.add_argument("--json", metavar="OUT.json", help="also write the metrics as JSON")
    ap.add_argument("samples", nargs="+", metavar="SAMPLES", help="host_sim sample files the robots trained on")
    args = ap.parse_args(argv)
    try:
        r = compute(args.maps, args.samples, args.dist)
        if args.json:
            write_json(args.json, dict(r, dist=args.dist))
    except MetricsError as e:
        print(f"paper_metrics.py: {e}", file=sys.stderr)
        return 1
    for k, v in r.items():
        print(f"{k} {v}" if isinstance(v, int) else f"{k} {v:.6g}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
