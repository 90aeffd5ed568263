#!/usr/bin/python3
"""Tests of tools/paper_metrics.py: each metric on synthetic data with known answers, and the CLI
on a synthetic maps folder with sample files in the exact tools/samples.py format.

    python3 tests/tools/test_paper_metrics.py      prints "N passed, M failed", exit 1 on failure

Needs Debian's python3 with numpy and scipy: when the python3 found first lacks numpy, the test
runs itself again with /usr/bin/python3.
"""
import importlib.util
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile


sys.path.insert(0, os.path.dirname(os.path.realpath(__file__)))
import samples_file  # noqa: E402
from minitest import check, main, need_numpy, test  # noqa: E402

np = need_numpy("test_paper_metrics")

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.realpath(__file__))))
TOOL = os.path.join(ROOT, "tools", "paper_metrics.py")
_spec = importlib.util.spec_from_file_location("paper_metrics", TOOL)
pm = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(pm)


def run(cmd, cwd=ROOT):
    p = subprocess.run([sys.executable, TOOL] + cmd, cwd=cwd, capture_output=True, text=True, timeout=60)
    return p.returncode, p.stdout, p.stderr


def close(a, b, tol=1e-9):
    return abs(a - b) <= tol


# ---- synthetic inputs ------------------------------------------------------------------------

def write_samples(path, xy_m, occ, box):
    samples_file.write_samples(path, xy_m, occ, box, b"scan paper_metrics test")


H, W, RES = 8, 10, 0.5
BOX = (0.0, 0.0, W * RES, H * RES)


def synthetic_maps(d):
    """A 10 x 8 grid of 0.5 m: walls on the top row and the left column, the right column unknown,
    mean = truth (a perfect map), std 0.05 on columns 0..4 and 0.3 on columns 5..9. Two sample
    files hold one point per cell centre of columns 0..4 (hits on the walls). Returns their paths."""
    m = os.path.join(d, "maps")
    os.makedirs(m)
    truth = np.zeros((H, W), np.uint8)
    truth[0, :] = 1
    truth[:, 0] = 1
    truth[:, W - 1] = 255
    mean = np.where(truth == 255, 0.5, truth).astype(np.float32)
    std = np.where(np.arange(W)[None, :] < 5, 0.05, 0.3) * np.ones((H, 1))
    np.save(os.path.join(m, "map_mean.npy"), mean)
    np.save(os.path.join(m, "map_std.npy"), std.astype(np.float32))
    np.save(os.path.join(m, "map_truth.npy"), truth)
    np.save(os.path.join(m, "map_single.npy"), mean)
    with open(os.path.join(m, "map_meta.json"), "w") as f:
        f.write('{"res": 0.5, "xmin": 0, "ymin": 0, "xmax": 5, "ymax": 4, "width": 10, "height": 8, '
                '"mc": 50, "seed": 1, "std_max": 0.3, "models": 2}\n')
    rows, cols = np.mgrid[0:H, 0:5]
    xy = np.column_stack([(cols.ravel() + 0.5) * RES, BOX[3] - (rows.ravel() + 0.5) * RES])
    occ = truth[rows.ravel(), cols.ravel()].astype(np.float64)
    files = [os.path.join(d, "a.samples"), os.path.join(d, "b.samples")]
    write_samples(files[0], xy[::2], occ[::2], BOX)
    write_samples(files[1], xy[1::2], occ[1::2], BOX)
    return m, files


def parse(out):
    return {l.split()[0]: float(l.split()[1]) for l in out.splitlines()}


# ---- the metrics -----------------------------------------------------------------------------

@test
def roc_auc_vs_pairwise_count():
    rng = np.random.default_rng(1)
    for trial in range(30):
        n = int(rng.integers(2, 40))
        s = rng.integers(0, 5, n).astype(float) if trial % 2 else rng.random(n)  # ties in half
        y = rng.random(n) < 0.4
        pos, neg = s[y], s[~y]
        if len(pos) == 0 or len(neg) == 0:
            check(math.isnan(pm.roc_auc(s, y)), "one class: NaN")
            continue
        want = sum((p > q) + 0.5 * (p == q) for p in pos for q in neg) / (len(pos) * len(neg))
        check(close(pm.roc_auc(s, y), want, 1e-12), f"trial {trial}: {pm.roc_auc(s, y)} != {want}")
    check(pm.roc_auc([1, 2, 3, 4], [0, 0, 1, 1]) == 1.0 and pm.roc_auc([4, 3, 2, 1], [0, 0, 1, 1]) == 0.0,
          "perfect / reversed")
    check(pm.roc_auc([2, 2, 2], [1, 0, 1]) == 0.5, "all tied")
    check(math.isnan(pm.roc_auc([1, 2], [1, 1])) and math.isnan(pm.roc_auc([1, 2], [0, 0])), "empty class")


@test
def spearman_known():
    check(close(pm.spearman([1, 2, 3, 4], [1, 4, 9, 16]), 1.0), "monotone")
    check(close(pm.spearman([1, 2, 3, 4], [5, 3, 2, 0]), -1.0), "reversed")
    # d = ranks (1,2,3,4,5) vs (2,1,4,3,5): sum d^2 = 4, rho = 1 - 6*4/(5*24) = 0.8
    check(close(pm.spearman([1, 2, 3, 4, 5], [20, 10, 40, 30, 50]), 0.8), "hand value")
    check(math.isnan(pm.spearman([1, 1, 1], [1, 2, 3])) and math.isnan(pm.spearman([1, 2, 3], [0, 0, 0])),
          "constant")


@test
def ece_calibrated_and_miscalibrated():
    # perfectly calibrated: in each bin of 15, p = k/15 + 1/30 (the bin centre) and a matching wall fraction
    prob, truth = [], []
    for k in range(15):
        p = (k + 0.5) / 15
        n = 30
        walls = round(p * n)  # (k + 0.5) * 2 = 2k + 1: exact
        prob += [p] * n
        truth += [1] * walls + [0] * (n - walls)
    check(close(pm.ece(np.array(prob), np.array(truth, np.uint8)), 0.0, 1e-12), "calibrated")
    # 10 cells at 0.9 with 5 walls (gap 0.4), 10 at 0.1 with no wall (gap 0.1): 0.5*0.4 + 0.5*0.1
    prob = np.array([0.9] * 10 + [0.1] * 10 + [0.7] * 5)
    truth = np.array([1] * 5 + [0] * 5 + [0] * 10 + [255] * 5, np.uint8)
    check(close(pm.ece(prob, truth), 0.25, 1e-12), f"miscalibrated: {pm.ece(prob, truth)}")
    # 2 bins, [0, .5) and [.5, 1] (p = 1.0 in the last): {0, .25} with walls {0, 1}: |.125 - .5|;
    # {1, .5} with walls {1, 1}: |.75 - 1|
    check(close(pm.ece(np.array([1.0, 0.5, 0.0, 0.25]), np.array([1, 1, 0, 1], np.uint8), bins=2),
                0.5 * 0.375 + 0.5 * 0.25), "edges")
    check(math.isnan(pm.ece(np.array([0.3]), np.array([255], np.uint8))), "no known cell")


@test
def map_errors_known():
    mean = np.array([[0.9, 0.2, 0.6], [0.5, 0.0, 0.3]])
    truth = np.array([[1, 0, 0], [1, 255, 1]], np.uint8)
    mse, iou = pm.map_errors(mean, truth)
    want = (0.01 + 0.04 + 0.36 + 0.25 + 0.49) / 5
    # walls predicted (> 0.5): (0,0), (0,2); walls: (0,0), (1,0), (1,2): 1 / 4
    check(close(mse, want) and close(iou, 0.25), f"{mse} {iou}")
    mse, iou = pm.map_errors(np.zeros((2, 2)), np.zeros((2, 2), np.uint8))
    check(mse == 0.0 and math.isnan(iou), "no wall anywhere: IoU NaN")


@test
def unobserved_mask_distances():
    cells = np.array([[0.4, 0.0], [0.6, 0.0], [0.0, -0.3], [3.0, 3.0], [2.0, 2.35]])
    pts = np.array([[0.0, 0.0], [2.0, 2.0]])
    got = pm.unobserved_mask(cells, pts, 0.5)
    check(got.tolist() == [False, True, False, True, False], f"{got}")
    check(pm.unobserved_mask(cells, pts, 0.2).tolist() == [True, True, True, True, True], "dist 0.2")
    check(pm.unobserved_mask(cells, np.zeros((0, 2)), 0.5).all(), "no points: all unobserved")


@test
def kde_density_and_subsampling():
    from scipy.stats import gaussian_kde
    rng = np.random.default_rng(5)
    hits = rng.normal(size=(50, 2))
    cells = rng.uniform(-2, 2, size=(30, 2))
    check(np.allclose(pm.kde_density(hits, cells), gaussian_kde(hits.T)(cells.T), rtol=1e-12), "full")
    a = pm.kde_density(hits, cells, max_points=20, seed=3)
    idx = np.sort(np.random.default_rng(3).choice(50, 20, replace=False))
    check(np.allclose(a, gaussian_kde(hits[idx].T)(cells.T), rtol=1e-12), "subsample")
    check(np.array_equal(a, pm.kde_density(hits, cells, max_points=20, seed=3)), "deterministic")
    check(not np.allclose(a, pm.kde_density(hits, cells, max_points=20, seed=4)), "seed matters")
    try:
        pm.kde_density(hits[:2], cells)
        check(False, "2 hits accepted")
    except pm.MetricsError as e:
        check("too few" in str(e), str(e))


@test
def load_map_grid_convention():
    d = tempfile.mkdtemp(prefix="pmtest.")
    try:
        m, files = synthetic_maps(d)
        g = pm.load_map(m)
        check(g["cell_xy"].shape == (H * W, 2), "cell_xy shape")
        check(np.allclose(g["cell_xy"][0], [0.25, 3.75]), f"top-left cell {g['cell_xy'][0]}")
        r, c = 6, 3
        check(np.allclose(g["cell_xy"][r * W + c], [(c + 0.5) * RES, 4 - (r + 0.5) * RES]), "cell (6, 3)")
        check(np.allclose(g["xc"], (np.arange(W) + 0.5) * RES) and np.allclose(g["yc"], 4 - (np.arange(H) + 0.5) * RES),
              "xc, yc")
        all_xy, hits = pm.load_points(files)
        check(all_xy.shape == (40, 2) and hits.shape == (12, 2), f"{all_xy.shape} {hits.shape}")
        check(np.allclose(np.sort(hits[:, 1])[-5:], 3.75, atol=1e-6), "hits on the top row in metres")
    finally:
        shutil.rmtree(d)


@test
def seen_definition():
    # a cell 0.1 m from a sample point is seen, 0.2 m is not; the boundary is SEEN_DIST = 0.15 m
    check(pm.SEEN_DIST == 0.15, f"SEEN_DIST {pm.SEEN_DIST}")
    check(0.14 / 2 + 0.1 * math.sqrt(2) / 2 < pm.SEEN_DIST, "a crossed 0.1 m cell is within SEEN_DIST")
    pts = np.array([[1.0, 1.0]])
    cells = np.array([[1.1, 1.0], [1.2, 1.0], [1.0, 0.9], [1.0, 0.8], [1.1, 1.1], [1.0, 1.149], [1.0, 1.151]])
    got = pm.seen_mask(cells, pts)
    check(got.tolist() == [True, False, True, False, True, True, False], f"{got}")
    check(not pm.seen_mask(cells, np.zeros((0, 2))).any(), "no points: nothing seen")
    check(pm.seen_mask(cells, pts, 0.25).all(), "seen_dist 0.25")
    # a tiny 0.1 m grid, 3 x 3 cells over [0, 0.3]^2, one point at the centre of cell (1, 0)
    d = tempfile.mkdtemp(prefix="pmtest.")
    try:
        m = os.path.join(d, "maps")
        os.makedirs(m)
        np.save(os.path.join(m, "map_mean.npy"), np.full((3, 3), 0.2, np.float32))
        np.save(os.path.join(m, "map_std.npy"), np.full((3, 3), 0.1, np.float32))
        np.save(os.path.join(m, "map_truth.npy"), np.zeros((3, 3), np.uint8))
        with open(os.path.join(m, "map_meta.json"), "w") as f:
            f.write('{"res": 0.1, "xmin": 0, "ymin": 0, "xmax": 0.3, "ymax": 0.3, "width": 3, "height": 3}\n')
        s = os.path.join(d, "a.samples")
        write_samples(s, [[0.05, 0.15]], [1.0], (0.0, 0.0, 0.3, 0.3))
        r = pm.compute(m, [s])
        # seen: (1, 0) itself (0 m), (0, 0), (2, 0), (1, 1) (0.1 m), (0, 1), (2, 1) (0.141 m); not column 2 (0.2 m)
        check(close(r["seen_fraction"], 6 / 9), f"seen_fraction {r['seen_fraction']}")
        check(r["auc_seen_dist"] == 1.0, f"auc_seen_dist {r['auc_seen_dist']}")
    finally:
        shutil.rmtree(d)


@test
def sparsification_and_ause():
    # errors 3, 2, 1, 0 in the score's order: removing 0, 1, 2, 3 of 4 cells leaves means 1.5, 1, .5, 0
    check(np.allclose(pm.sparsification([4, 3, 2, 1], [3, 2, 1, 0], steps=4), [1.5, 1.0, 0.5, 0.0]), "hand curve")
    # reversed order: 1.5, 2, 2.5, 3; gap 0, 1, 2, 3 over f = 0, .25, .5, .75: trapezoid .125 + .375 + .625
    check(close(pm.ause([1, 2, 3, 4], [3, 2, 1, 0], steps=4), 1.125), f"{pm.ause([1, 2, 3, 4], [3, 2, 1, 0], steps=4)}")
    rng = np.random.default_rng(7)
    err = rng.random(500)
    check(pm.ause(err, err) == 0.0, "the oracle ordering gives 0")
    check(close(pm.ause(2 * err + 1, err), 0.0, 1e-15), "any increasing function of the error gives 0")
    a = pm.ause(rng.random(500), err)
    check(a > 0.05, f"a random ordering gives > 0: {a}")
    check(pm.ause(-err, err) > a, "the reversed ordering is worse than a random one")
    # ties: a constant score keeps the mean error at every f (the expected value of a random order)
    check(np.allclose(pm.sparsification(np.zeros(500), err), err.mean()), "ties averaged")
    perm = rng.permutation(500)
    s = rng.integers(0, 5, 500).astype(float)
    check(close(pm.ause(s, err), pm.ause(s[perm], err[perm]), 1e-12), "ties: independent of the cells' order")
    check(pm.ause(s, err) >= 0, "never below the oracle")
    check(math.isnan(pm.ause([], [])), "no cell: NaN")


def add_epistemic(m):
    """A fabricated map_epistemic.npy for the synthetic maps: 0.1 where the samples are (columns
    0..4), 1 beyond (test data only, not a result)."""
    e = np.where(np.arange(W)[None, :] < 5, 0.1, 1.0) * np.ones((H, 1))
    np.save(os.path.join(m, "map_epistemic.npy"), e.astype(np.float32))


NEW_KEYS = ("auc_seen_{}", "ause_{}", "spearman_kde_{}")


@test
def epistemic_keys_with_and_without_the_file():
    d = tempfile.mkdtemp(prefix="pmtest.")
    try:
        m, files = synthetic_maps(d)
        out_json = os.path.join(d, "m.json")
        rc, out, err = run(["--maps", m, "--json", out_json] + files)
        check(rc == 0 and err == "", f"exit {rc}: {err}")
        r = parse(out)
        for score in ("std", "dist"):
            for k in NEW_KEYS:
                check(k.format(score) in r, f"{k.format(score)} missing:\n{out}")
        check(not any("epistemic" in k for k in r), f"epistemic keys without map_epistemic.npy:\n{out}")
        check(r["brier"] == r["mse"] == 0.0, "brier = mse")
        check("auc_std_unobserved" in r and "spearman_std_kde" in r, "the old keys are kept")
        # columns 0..4 hold a point at every cell centre: seen; columns 5..8 are 0.5 m or more away
        check(close(r["seen_fraction"], 40 / 72, 1e-6), out)
        check(r["auc_seen_std"] == 1.0 and r["auc_seen_dist"] == 1.0, out)
        check(r["spearman_kde_std"] == r["spearman_std_kde"], "the same Spearman under both names")
        check(r["ause_std"] == 0.0, "a perfect map: every error 0, AUSE 0")
        j = json.load(open(out_json))
        check(j["seen_dist"] == 0.15 and "auc_seen_epistemic" not in j, f"{j}")
        rc, md, err = run(["--maps", m, "--markdown"] + files)
        check(rc == 0 and md.startswith("| score | AUC unseen/seen | AUSE | Spearman vs KDE |"), md)
        check(len(md.strip().splitlines()) == 4 and "epistemic" not in md, md)

        add_epistemic(m)
        rc, out, err = run(["--maps", m, "--json", out_json] + files)
        check(rc == 0 and err == "", f"exit {rc}: {err}")
        r2 = parse(out)
        for k in NEW_KEYS:
            check(k.format("epistemic") in r2, f"{k.format('epistemic')} missing:\n{out}")
        check(r2["auc_seen_epistemic"] == 1.0, out)
        check(close(r2["epistemic_mean_seen"], 0.1, 1e-6) and r2["epistemic_mean_unseen"] == 1.0, out)
        check(all(r2[k] == v for k, v in r.items()), "the other keys do not change")
        check(json.load(open(out_json))["auc_seen_epistemic"] == 1.0, "JSON")
        rc, md, err = run(["--maps", m, "--markdown"] + files)
        check(rc == 0 and len(md.strip().splitlines()) == 5 and "| epistemic" in md, md)
        # a malformed epistemic map stops with one line
        for bad, want in ((np.full((H, W), 1.5, np.float32), "outside (0, 1]"),
                          (np.full((W, H), 0.5, np.float32), "shape"),
                          (np.full((H, W), 0.5, np.float64), "dtype")):
            np.save(os.path.join(m, "map_epistemic.npy"), bad)
            rc, out, err = run(["--maps", m] + files)
            check(rc == 1 and "map_epistemic.npy" in err and want in err and "Traceback" not in err, f"{rc} {err}")
    finally:
        shutil.rmtree(d)


@test
def markdown_table_rows():
    r = {"auc_seen_std": 0.7, "ause_std": 0.05, "spearman_kde_std": float("nan"),
         "auc_seen_dist": 1.0, "ause_dist": 0.04, "spearman_kde_dist": -0.7}
    L = pm.markdown_table(r)
    check(len(L) == 4 and L[2] == "| MC-50 std | 0.7 | 0.05 | - |", f"{L}")
    check(L[3].startswith("| distance") and L[3].endswith("| 1 | 0.04 | -0.7 |"), f"{L}")


# ---- the CLI ---------------------------------------------------------------------------------

@test
def cli_known_answers():
    d = tempfile.mkdtemp(prefix="pmtest.")
    try:
        m, files = synthetic_maps(d)
        out_json = os.path.join(d, "out", "metrics.json")
        os.makedirs(os.path.dirname(out_json))
        rc, out, err = run(["--maps", m, "--dist", "0.3", "--json", out_json] + files)
        check(rc == 0 and err == "", f"exit {rc}: {err}")
        r = parse(out)
        # 9 known columns x 8 rows; columns 5..8 are 0.5 m or more from the nearest point
        check(r["n_cells"] == 72 and r["n_points"] == 40 and r["n_hits"] == 12, out)
        check(close(r["unobserved_fraction"], 32 / 72, 1e-6), out)
        check(r["auc_std_unobserved"] == 1.0, out)
        check(close(r["std_mean_observed"], 0.05, 1e-6) and close(r["std_mean_unobserved"], 0.3, 1e-6), out)
        check(r["mse"] == 0.0 and r["wall_iou"] == 1.0 and r["ece"] == 0.0, out)
        check(-1.0 <= r["spearman_std_kde"] < 0, "std falls where the hits are dense:\n" + out)
        g = pm.load_map(m)
        known = (g["truth"] != 255).ravel()
        hits = pm.load_points(files)[1]
        want = pm.spearman(g["std"].ravel()[known], pm.kde_density(hits, g["cell_xy"][known]))
        check(close(r["spearman_std_kde"], want, 1e-5), f"spearman {r['spearman_std_kde']} != {want}")
        j = json.load(open(out_json))
        check(j["dist"] == 0.3 and j["n_cells"] == 72 and close(j["unobserved_fraction"], 32 / 72), f"{j}")
        check(os.listdir(os.path.dirname(out_json)) == ["metrics.json"], "temporary file left")
        # everything observed: the AUC and the unobserved std mean are NaN, null in the JSON
        rc, out, err = run(["--maps", m, "--dist", "10", "--json", out_json] + files)
        check(rc == 0 and "auc_std_unobserved nan" in out and "std_mean_unobserved nan" in out, f"{rc} {out} {err}")
        j = json.load(open(out_json))
        check(j["auc_std_unobserved"] is None and j["unobserved_fraction"] == 0.0, f"{j}")
    finally:
        shutil.rmtree(d)


@test
def cli_bad_inputs():
    d = tempfile.mkdtemp(prefix="pmtest.")
    try:
        m, files = synthetic_maps(d)

        def fails(want, args=None):
            rc, out, err = run(args or (["--maps", m] + files))
            check(rc == 1 and want in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err,
                  f"want exit 1 naming {want!r}: {rc} {err}")
            return err

        truth = os.path.join(m, "map_truth.npy")
        shutil.move(truth, truth + ".bak")
        check("missing" in fails("map_truth.npy"), "missing file")
        shutil.move(truth + ".bak", truth)
        std = os.path.join(m, "map_std.npy")
        good = np.load(std)
        np.save(std, good.T.copy())
        check("shape (10, 8)" in fails("map_std.npy"), "wrong shape")
        np.save(std, good.astype(np.float64))
        check("dtype float64" in fails("map_std.npy"), "wrong dtype")
        with open(std, "wb") as f:
            f.write(b"not numpy")
        fails("map_std.npy")
        np.save(std, good)
        t = np.load(truth)
        t[2, 3] = 7
        np.save(truth, t)
        check("cell (2, 3) is 7" in fails("map_truth.npy"), "bad truth value")
        t[2, 3] = 0
        np.save(truth, t)
        meta = os.path.join(m, "map_meta.json")
        good_meta = open(meta).read()
        with open(meta, "w") as f:
            f.write(good_meta.replace('"res": 0.5, ', ""))
        check('"res"' in fails("map_meta.json"), "missing key")
        with open(meta, "w") as f:
            f.write("{oops")
        fails("map_meta.json")
        with open(meta, "w") as f:
            f.write(good_meta)
        with open(files[0], "r+b") as f:
            f.seek(215)
            f.write(b"\x01\x02")
        check("CRC" in fails("a.samples"), "corrupted samples")
        fails("No such file", ["--maps", m, os.path.join(d, "none.samples")])
        fails("map_meta.json", ["--maps", os.path.join(d, "nope"), files[1]])
        rc, out, err = run(["--maps", m, "--dist", "-1", files[1]])
        check(rc == 2 and "--dist" in err, f"negative dist: {rc} {err}")
        rc, out, err = run(["--help"])
        check(rc == 0 and "--maps DIR" in out and "SAMPLES" in out and "auc_std_unobserved" in out, "--help")
    finally:
        shutil.rmtree(d)


if __name__ == "__main__":
    sys.exit(main())
