#!/usr/bin/python3
"""Tests of tools/fleet_report.py's section "What the fleet knows": present, with the MC std and the
epistemic map side by side and tools/paper_metrics.py's table, when maps/ has map_epistemic.npy;
skipped cleanly (named under "Not in this report") when it does not; a malformed epistemic map
stops the report before summary.md is written. The run folder is synthetic: a 10 x 8 grid of
0.5 m and one robot's train.samples in the exact tools/samples.py format; the epistemic map is
fabricated from the distance to the samples (test data only, not a result).

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
        # maps/ has no PNGs here: the std is the report's own, the epistemic one is said missing
        check("![map_std](map_std.png)" in sec and "maps/map_epistemic.png is missing" in sec, sec)
        check("| score | AUC unseen/seen | AUSE | Spearman vs KDE |" in sec, sec)
        table = sec[sec.index("| score |"):].split("\n\n")[0].splitlines()
        rows = table[2:]
        check(len(rows) == 3 and rows[0].startswith("| MC-50 std |") and rows[1].startswith("| epistemic")
              and rows[2].startswith("| distance"), sec)
        check(rows[1].split("|")[2].strip() == "1" and rows[2].split("|")[2].strip() == "1",
              f"AUC 1 for the epistemic and the distance: {rows}")
        check("within 0.15 m" in sec and "of the 72 cells" in sec and "55.6 %" in sec, sec)
        check("maps/map_epistemic.npy is missing" not in s, "not named missing")
        # with host_sim's PNGs in maps/ and the epistemic object of map_meta.json
        for name in ("map_std.png", "map_epistemic.png"):
            shutil.copy(os.path.join(run, "map_std.png"), os.path.join(run, "maps", name))
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


if __name__ == "__main__":
    sys.exit(main())
