#!/usr/bin/python3
"""REPORT.md of the paper's experiments from the finished runs of tools/experiments.py.

    tools/paper_report.py OUT [--quick]

Reads OUT/runs/*/done.json (what each run was), metrics.csv, maps/ and paper_metrics.json
(a coverage run's paper_metrics_robot<i>.json too, and its log.txt for the posterior's mixing);
writes into OUT: REPORT.md, the figures (PNG, axes in metres, colour bars) and the CSVs every
number of the report comes from (runs.csv, kl_table.csv, curves.csv, coverage.csv). Runs not finished yet
are listed as missing; the report is whole for what exists. Exit 1 on unreadable input.
Needs Debian's python3-numpy, python3-scipy and python3-matplotlib.
"""
import argparse
import csv
import json
import math
import os
import sys

import numpy as np

TOOLS = os.path.dirname(os.path.realpath(__file__))
ROOT = os.path.dirname(TOOLS)
sys.path.insert(0, TOOLS)
import paper_metrics  # noqa: E402
from palette import robot_colour  # noqa: E402

STRATEGIES = ("uniform", "separate", "kl")
MODES = (("val_mean", "mean weights"), ("val_sample", "1 sampled pass"), ("val_mc", "MC-50 predictive mean"))
PAPER_GAIN = (12.0, 30.0)


class ReportError(Exception):
    pass


def read_csv(path):
    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


def num(v):
    try:
        x = float(v)
    except (TypeError, ValueError):
        return math.nan
    return x


def load_runs(out):
    runs = []
    base = os.path.join(out, "runs")
    for name in sorted(os.listdir(base)) if os.path.isdir(base) else []:
        d = os.path.join(base, name)
        f = os.path.join(d, "done.json")
        if name.startswith(".") or not os.path.isfile(f):
            continue
        try:
            with open(f, encoding="utf-8") as fh:
                done = json.load(fh)
        except (OSError, ValueError) as e:
            raise ReportError(f"{f}: {e}")
        run = {"name": name, "dir": d, "tags": done.get("tags", {}), "seconds": done.get("seconds", math.nan)}
        pm = os.path.join(d, "paper_metrics.json")
        run["pm"] = {}
        if os.path.isfile(pm):
            with open(pm, encoding="utf-8") as fh:
                run["pm"] = {k: (math.nan if v is None else v) for k, v in json.load(fh).items()}
        run["pm_own"] = {}  # a coverage run's robots' own maps: robot -> paper_metrics of maps_robot<i>
        for i in run["tags"].get("own", ()) if run["tags"].get("kind") == "coverage" else ():
            f = os.path.join(d, f"paper_metrics_robot{i}.json")
            if os.path.isfile(f):
                with open(f, encoding="utf-8") as fh:
                    run["pm_own"][i] = {k: (math.nan if v is None else v) for k, v in json.load(fh).items()}
        if run["tags"].get("kind") in ("kl_table", "single", "coverage"):
            run.update(fleet_figures(d))
            if run["tags"].get("kind") == "coverage":
                run["post_mixing"] = posterior_mixing(os.path.join(d, "log.txt"))
                obs = posterior_observations(os.path.join(d, "log.txt")) + [math.nan] * (1 + len(run["pm_own"]))
                # robot i's posterior against the fleet's: 1 when the mixing gave it the fleet's sum
                run["post_share"] = {i: obs[1 + k] / obs[0] for k, i in enumerate(run["tags"].get("own", ()))}
        elif run["tags"].get("kind") == "online":
            run.update(online_figures(d))
        runs.append(run)
    return runs


def fleet_figures(d):
    """Per metrics row: the mean over agents; final and best of each validation mode."""
    rows = read_csv(os.path.join(d, "metrics.csv"))
    by_round = {}
    for r in rows:
        by_round.setdefault(int(r["round"]), []).append(r)
    rounds = sorted(by_round)
    curve = {}
    for col in ("val_mean", "val_sample", "val_mc", "occ_mse", "occ_iou", "consensus_error", "sigma_mean"):
        curve[col] = np.array([np.mean([num(x[col]) for x in by_round[k]]) if col != "consensus_error"
                               else np.max([num(x[col]) for x in by_round[k]]) for k in rounds])
    res = {"rounds": np.array(rounds), "curve": curve}
    last = {k: float(v[-1]) for k, v in curve.items()}
    for col, _ in MODES:
        v = curve[col][1:] if len(rounds) > 1 else curve[col]   # round 0 is the untrained start
        fin = v[np.isfinite(v)]
        last[col + "_best"] = float(fin.min()) if fin.size > 1 or (col != "val_mc" and fin.size) else math.nan
    cons = os.path.join(d, "maps", "consensus.csv")
    last["consensus_val"] = math.nan
    if os.path.isfile(cons):
        for r in read_csv(cons):
            if r["model"] == "consensus":
                last["consensus_val"] = num(r["val_loss"])
    res["final"] = last
    return res


def posterior_mixing(log):
    """host_sim fleet's line on the epistemic posteriors' consensus: (posterior rounds, nan), or
    (nan, nan) when the log lacks it (the second figure was how far apart the robots stayed, which
    the posterior rounds, exact over every robot, no longer print)."""
    try:
        with open(log, encoding="utf-8") as f:
            for line in f:
                if line.startswith("epistemic:") and "posterior round" in line:
                    words = line.replace("(", " ").replace(")", " ").replace(";", " ").replace(",", " ").split()
                    return (num(words[words.index("posterior") - 1]), math.nan)
    except OSError:
        pass
    return (math.nan, math.nan)


def posterior_observations(log):
    """The observations of the posterior of every `host_sim maps` of a run's log, in order (for a
    coverage run: the consensus map's, then each own map's)."""
    obs = []
    try:
        with open(log, encoding="utf-8") as f:
            for line in f:
                if line.startswith("epistemic: the posterior of") and " observations)" in line:
                    obs.append(num(line.split(" observations)")[0].split()[-1]))
    except OSError:
        pass
    return obs


def online_figures(d):
    """The fleet's robots: validation loss after every communication round (mean over robots)."""
    per = []
    i = 0
    while os.path.isfile(os.path.join(d, "fleet", f"robot_{i}", "metrics.csv")):
        rows = read_csv(os.path.join(d, "fleet", f"robot_{i}", "metrics.csv"))
        per.append({int(r["round"]): num(r["val_loss"]) for r in rows if math.isfinite(num(r["val_loss"]))})
        i += 1
    rounds = sorted(set().union(*per)) if per else []
    val = np.array([np.nanmean([p.get(k, math.nan) for p in per]) for k in rounds]) if rounds else np.array([])
    cons = math.nan
    c = os.path.join(d, "fleet", "maps", "consensus.csv")
    if os.path.isfile(c):
        for r in read_csv(c):
            if r["model"] == "consensus":
                cons = num(r["val_loss"])
    return {"rounds": np.array(rounds), "val": val, "final": {"val_mean": float(val[-1]) if val.size else math.nan,
                                                                "consensus_val": cons}}


# ---- the KL table ---------------------------------------------------------------------------
def uniform_for(run, table):
    """The uniform run a strategy is compared with: same seed, preset and kl_weight."""
    t = run["tags"]
    row = t["row"]
    base_row = row if row.startswith("kl_weight") or row == "network" else "baseline"
    for r in table:
        u = r["tags"]
        if u["strategy"] == "uniform" and u["seed"] == t["seed"] and u["row"] == base_row:
            return r
    return None


def kl_table(runs):
    table = [r for r in runs if r["tags"].get("kind") == "kl_table"]
    groups = {}
    for r in table:
        t = r["tags"]
        groups.setdefault((t["row"], t["reading"], t["strategy"]), []).append(r)
    rows_first = ["baseline", "rho_pred_grad", "kl_form", "kl_reduce", "w_rho", "kl_weight_5e-3", "kl_weight_5e-1",
                  "network"]
    def reading_key(k):
        if k[0] == "w_rho":
            return (0, float(k[1]), "")
        return (0 if "defaults" in k[1] else 1, 0.0, k[1])

    order = sorted(groups, key=lambda k: (rows_first.index(k[0]) if k[0] in rows_first else 99, reading_key(k),
                                          STRATEGIES.index(k[2])))
    rows = []
    for k in order:
        rel = {}
        for col, _ in MODES:
            for suffix in ("", "_best"):
                vals = []
                for r in groups[k]:
                    u = uniform_for(r, table)
                    if u is None:
                        continue
                    a, b = r["final"][col + suffix], u["final"][col + suffix]
                    if math.isfinite(a) and math.isfinite(b) and b > 0:
                        vals.append(100.0 * (a - b) / b)
                rel[col + suffix] = vals
        absval = [r["final"]["val_mean"] for r in groups[k]]
        sig = [r["final"]["sigma_mean"] for r in groups[k]]
        rows.append({"row": k[0], "reading": k[1], "strategy": k[2], "seeds": len(groups[k]), "rel": rel,
                     "abs": absval, "sigma": sig, "runs": groups[k]})
    return rows


def pm(vals):
    v = [x for x in vals if math.isfinite(x)]
    if not v:
        return "-"
    if len(v) == 1:
        return f"{v[0]:+.1f} %"
    return f"{np.mean(v):+.1f} ± {np.std(v, ddof=1):.1f} %"


def fmt(x, d=4):
    return "-" if x is None or not math.isfinite(x) else f"{x:.{d}g}"


# ---- figures ----------------------------------------------------------------------------------
def extent(meta):
    return [meta["xmin"], meta["xmax"], meta["ymin"], meta["ymax"]]


def tour(i):
    p = os.path.join(ROOT, "host_sim", "plans", "apartment", f"robot_{i}.csv")
    xy = np.loadtxt(p, delimiter=",", skiprows=1, ndmin=2)
    return xy[:, 0], xy[:, 1]


def panel(fig, ax, arr, meta, title, kind, vmax=None):
    if kind == "std":
        im = ax.imshow(arr, extent=extent(meta), origin="upper", cmap="viridis", vmin=0,
                       vmax=vmax or max(float(np.nanmax(arr)), 1e-6), interpolation="nearest")
        fig.colorbar(im, ax=ax, label="MC std", shrink=0.8)
    elif kind == "kde":
        im = ax.imshow(arr, extent=extent(meta), origin="upper", cmap="magma", interpolation="nearest")
        fig.colorbar(im, ax=ax, label="density (1/m²)", shrink=0.8)
    else:
        im = ax.imshow(arr, extent=extent(meta), origin="upper", cmap="gray_r", vmin=0, vmax=1,
                       interpolation="nearest")
        fig.colorbar(im, ax=ax, label="P(occupied)", shrink=0.8)
    ax.set_title(title, fontsize=9)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")


def save(fig, out, name):
    fig.savefig(os.path.join(out, name), dpi=90)
    import matplotlib.pyplot as plt
    plt.close(fig)
    return name


def fig_single(plt, runs, out):
    made = []
    singles = sorted([r for r in runs if r["tags"].get("kind") == "single"], key=lambda r: float(r["tags"]["kl_weight"]))
    if not singles:
        return made
    first = [r for r in singles if r["tags"]["kl_weight"] == "1e-4"] or singles[:1]
    m = paper_metrics.load_map(os.path.join(first[0]["dir"], "maps"))
    single = np.load(os.path.join(first[0]["dir"], "maps", "map_single.npy"))
    fig, axs = plt.subplots(1, 3, figsize=(16, 4.2), constrained_layout=True)
    tx, ty = tour(0)
    for ax, (arr, title, kind) in zip(axs, ((single, "one forward pass", "mean"),
                                            (m["mean"], "mean of 50 passes", "mean"),
                                            (m["std"], "standard deviation of 50 passes", "std"))):
        panel(fig, ax, arr, m["meta"], title, kind)
        ax.plot(tx, ty, "-", color=robot_colour(0), lw=1.2, label="robot 0's path")
    axs[0].legend(loc="lower right", fontsize=8)
    fig.suptitle(f"Single agent (robot 0 alone, kl_weight {first[0]['tags']['kl_weight']}, "
                 f"preset {first[0]['tags']['preset']})")
    made.append(save(fig, out, "single_agent.png"))
    fig, axs = plt.subplots(2, len(singles), figsize=(5.3 * len(singles), 7.5), constrained_layout=True, squeeze=False)
    for j, r in enumerate(singles):
        mm = paper_metrics.load_map(os.path.join(r["dir"], "maps"))
        panel(fig, axs[0][j], mm["mean"], mm["meta"], f"mean, kl_weight {r['tags']['kl_weight']}", "mean")
        panel(fig, axs[1][j], mm["std"], mm["meta"], f"std, kl_weight {r['tags']['kl_weight']}", "std")
    made.append(save(fig, out, "kl_weight_maps.png"))
    return made


def fig_online(plt, runs, out):
    online = sorted([r for r in runs if r["tags"].get("kind") == "online"],
                    key=lambda r: (r["tags"]["pool"], r["tags"]["comm_rounds"]))
    if not online:
        return []
    fig, ax = plt.subplots(figsize=(8, 4.5), constrained_layout=True)
    for r in online:
        t = r["tags"]
        ax.plot(r["rounds"] / t["rounds_per_comm"], r["val"], marker=".", label=f"{t['pool'].upper()}, {t['comm_rounds']} CR")
    ax.set_xlabel("communication round")
    ax.set_ylabel("validation loss (BCE, mean over 7 robots)")
    ax.set_yscale("log")
    ax.legend()
    ax.set_title("Online learning, 7 robots over LCM")
    made = [save(fig, out, "online_val_loss.png")]
    fig, axs = plt.subplots(2, len(online), figsize=(5.0 * len(online), 7.0), constrained_layout=True, squeeze=False)
    for j, r in enumerate(online):
        t = r["tags"]
        mm = paper_metrics.load_map(os.path.join(r["dir"], "fleet", "maps"))
        panel(fig, axs[0][j], mm["mean"], mm["meta"], f"mean, {t['pool'].upper()} {t['comm_rounds']} CR", "mean")
        panel(fig, axs[1][j], mm["std"], mm["meta"], f"std, {t['pool'].upper()} {t['comm_rounds']} CR", "std")
    made.append(save(fig, out, "online_maps.png"))
    return made


def fig_strategies(plt, runs, out, preset, row, name):
    sel = [r for r in runs if r["tags"].get("kind") == "kl_table" and r["tags"]["row"] == row
           and r["tags"]["preset"] == preset]
    if not sel:
        return []
    fig, ax = plt.subplots(figsize=(8, 4.5), constrained_layout=True)
    for st, colour in zip(STRATEGIES, ("tab:blue", "tab:orange", "tab:green")):
        rs = [r for r in sel if r["tags"]["strategy"] == st]
        if not rs:
            continue
        n = min(len(r["rounds"]) for r in rs)
        x = rs[0]["rounds"][1:n]
        ys = np.array([r["curve"]["val_mean"][1:n] for r in rs])
        label = f"{st} ({' '.join(rs[0]['tags']['args']) or 'defaults'}), {len(rs)} seed(s)"
        ax.plot(x, ys.mean(axis=0), color=colour, label=label)
        if len(rs) > 1:
            ax.fill_between(x, ys.min(axis=0), ys.max(axis=0), color=colour, alpha=0.2)
    ax.set_yscale("log")
    ax.set_xlabel("DiNNO round")
    ax.set_ylabel("validation loss (BCE, mean weights, mean over 7 agents)")
    ax.set_title(f"Seven agents, three strategies (preset {preset}; band: min-max over seeds)")
    ax.legend(fontsize=8)
    return [save(fig, out, name)]


def fig_decentralised(plt, runs, out):
    sel = [r for r in runs if r["tags"].get("kind") == "kl_table" and r["tags"]["strategy"] == "kl"
           and r["tags"]["row"] == "network"]
    sel = sel or [r for r in runs if r["tags"].get("kind") == "kl_table" and r["tags"]["strategy"] == "kl"
                  and r["tags"]["row"] == "baseline"]
    if not sel:
        return []
    r = sorted(sel, key=lambda x: x["tags"]["seed"])[0]
    m = paper_metrics.load_map(os.path.join(r["dir"], "maps"))
    data = os.path.join(os.path.dirname(r["dir"]), f"data-s{r['tags']['seed']}", "samples")
    files = sorted(os.path.join(data, f) for f in os.listdir(data)) if os.path.isdir(data) else []
    fig, axs = plt.subplots(1, 3 if files else 2, figsize=(16 if files else 11, 4.2), constrained_layout=True)
    panel(fig, axs[0], m["mean"], m["meta"], "consensus model: mean of 50 passes", "mean")
    panel(fig, axs[1], m["std"], m["meta"], "consensus model: standard deviation", "std")
    if files:  # the samples are not archived: the KDE needs the data run
        _, hits = paper_metrics.load_points(files)
        dens = paper_metrics.kde_density(hits, m["cell_xy"]).reshape(m["mean"].shape)
        panel(fig, axs[2], dens, m["meta"], f"Gaussian KDE of the {len(hits)} lidar hits trained on", "kde")
    fig.suptitle(f"Decentralised result: kl strategy, preset {r['tags']['preset']}, seed {r['tags']['seed']}")
    return [save(fig, out, "decentralised.png")]


# ---- the report ------------------------------------------------------------------------------------
# runs.csv's columns; those of paper_metrics.json a run lacks (the epistemic ones before host_sim maps
# wrote map_epistemic.npy) are left empty
RUNS_COLS = ["name", "kind", "row", "reading", "strategy", "preset", "seed", "kl_weight", "pool", "comm_rounds",
             "rounds", "seconds", "val_mean", "val_sample", "val_mc", "val_mean_best", "val_sample_best", "val_mc_best",
             "consensus_val", "occ_mse", "occ_iou", "consensus_error", "sigma_mean", "auc_std_unobserved",
             "unobserved_fraction", "spearman_std_kde", "mse", "wall_iou", "ece", "seen_fraction", "auc_seen_std",
             "auc_seen_epistemic", "ause_std", "ause_epistemic", "spearman_kde_epistemic", "brier"]
# The tables' metric columns (paper_metrics.json key, heading, digits); a missing or NaN value is '-'.
METRIC_COLS = (("auc_std_unobserved", "AUC std / unseen", 3), ("spearman_std_kde", "Spearman std ~ KDE", 3),
               ("auc_seen_std", "AUC std / seen", 3), ("auc_seen_epistemic", "AUC epistemic / seen", 3),
               ("ause_std", "AUSE std", 3), ("ause_epistemic", "AUSE epistemic", 3),
               ("spearman_kde_epistemic", "Spearman epistemic ~ KDE", 3),
               ("mse", "MSE", 3), ("brier", "Brier", 3), ("wall_iou", "wall IoU", 3), ("ece", "ECE", 3))


# The partial-coverage table: (paper_metrics.json key, heading, digits).
COVERAGE_COLS = (("seen_fraction", "seen fraction", 3), ("auc_seen_std", "AUC unseen/seen: MC-50 std", 3),
                 ("auc_seen_epistemic", "AUC unseen/seen: epistemic", 3),
                 ("auc_seen_dist", "AUC unseen/seen: distance (reference)", 3), ("ause_std", "AUSE std", 3),
                 ("ause_epistemic", "AUSE epistemic", 3), ("spearman_kde_std", "Spearman std ~ KDE", 3),
                 ("spearman_kde_epistemic", "Spearman epistemic ~ KDE", 3), ("ece", "ECE", 3), ("brier", "Brier", 3))


def coverage_rows(runs):
    """Per plan, the consensus map and each robot's own map: (plan, map, runs, [metrics per run])."""
    cov = sorted([r for r in runs if r["tags"].get("kind") == "coverage"],
                 key=lambda r: (r["tags"]["plan"] != "apartment", r["tags"]["plan"], r["tags"]["seed"]))
    plans = []
    for r in cov:
        if r["tags"]["plan"] not in plans:
            plans.append(r["tags"]["plan"])
    rows = []
    for plan in plans:
        rs = [r for r in cov if r["tags"]["plan"] == plan]
        rows.append((plan, "consensus", rs, [r["pm"] for r in rs]))
        for i in sorted({i for r in rs for i in r["pm_own"]}):
            rows.append((plan, f"robot {i}'s own", rs, [r["pm_own"].get(i, {}) for r in rs]))
    return rows


def own_share(run, what):
    """A row's posterior observations over the fleet's: 1 for the consensus map, robot i's share for its own."""
    if what == "consensus":
        return 1.0
    return run.get("post_share", {}).get(int(what.split()[1].rstrip("'s")), math.nan)


def mean_sd(v, d):
    """'-', the one value, or mean ± sample standard deviation (the tables' form)."""
    v = [x for x in v if x is not None and math.isfinite(x)]
    return "-" if not v else fmt(v[0], d) if len(v) == 1 else f"{np.mean(v):.{d}g} ± {np.std(v, ddof=1):.1g}"


def write_csvs(out, runs, table):
    cols = RUNS_COLS
    with open(os.path.join(out, "runs.csv"), "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(cols)
        for r in runs:
            if r["tags"].get("kind") == "data":
                continue
            v = dict(r["tags"], name=r["name"], seconds=r["seconds"], **r.get("final", {}), **r["pm"])
            w.writerow([fmt(v.get(c), 6) if isinstance(v.get(c), float) else v.get(c, "") for c in cols])
    with open(os.path.join(out, "kl_table.csv"), "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(["row", "reading", "strategy", "seeds", "metric", "mean_rel_pct", "sd_rel_pct", "per_seed_rel_pct"])
        for t in table:
            for k, v in t["rel"].items():
                fin = [x for x in v if math.isfinite(x)]
                w.writerow([t["row"], t["reading"], t["strategy"], t["seeds"], k,
                            fmt(float(np.mean(fin)), 4) if fin else "", fmt(float(np.std(fin, ddof=1)), 4) if len(fin) > 1 else "",
                            " ".join(f"{x:.3f}" for x in fin)])
    with open(os.path.join(out, "curves.csv"), "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(["name", "round", "val_mean", "val_sample", "val_mc", "consensus_error", "sigma_mean"])
        for r in runs:
            if "curve" not in r:
                continue
            for i, k in enumerate(r["rounds"]):
                w.writerow([r["name"], int(k)] + [fmt(float(r["curve"][c][i]), 6) for c in
                                                  ("val_mean", "val_sample", "val_mc", "consensus_error", "sigma_mean")])
    rows = coverage_rows(runs)
    if rows:  # every number of the partial-coverage table, per run and map
        with open(os.path.join(out, "coverage.csv"), "w", newline="", encoding="utf-8") as f:
            w = csv.writer(f)
            w.writerow(["name", "plan", "seed", "map", "rounds", "consensus_error", "post_rounds",
                        "post_obs_over_fleet"] + [c[0] for c in COVERAGE_COLS])
            for plan, what, rs, pms in rows:
                for r, p in zip(rs, pms):
                    w.writerow([r["name"], plan, r["tags"]["seed"], what, r["tags"]["rounds"],
                                fmt(r["final"]["consensus_error"], 6), fmt(r["post_mixing"][0], 6),
                                fmt(own_share(r, what), 6)] +
                               [fmt(p.get(c[0], math.nan), 6) for c in COVERAGE_COLS])


def verdict(table):
    """Which readings give kl a 12-30 % lower validation loss than uniform (mean over seeds)."""
    hits, best = [], None
    for t in table:
        if t["strategy"] != "kl":
            continue
        for col, label in MODES:
            for suffix, what in (("", "final"), ("_best", "best")):
                v = [x for x in t["rel"][col + suffix] if math.isfinite(x)]
                if not v:
                    continue
                m = float(np.mean(v))
                if best is None or m < best[0]:
                    best = (m, t, label, what)
                if m <= -PAPER_GAIN[0]:
                    hits.append((m, t, label, what))
    return hits, best


def report(out, quick):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    runs = load_runs(out)
    table = kl_table(runs)
    write_csvs(out, runs, table)
    figs = []
    figs += fig_single(plt, runs, out)
    figs += fig_online(plt, runs, out)
    figs += fig_strategies(plt, runs, out, "paper", "network", "strategies_paper.png")
    figs += fig_strategies(plt, runs, out, "small", "baseline", "strategies_small.png")
    figs += fig_decentralised(plt, runs, out)
    L = []
    add = L.append
    add("# The paper's experiments, rerun" + (" (QUICK: reduced form, not the results)" if quick else ""))
    add("")
    add("Written by `tools/paper_report.py` from the runs of `tools/experiments.py`"
        f"{' --quick' if quick else ''} (`make experiments{' QUICK=1' if quick else ''}`). Every number below is in "
        "`runs.csv`, `kl_table.csv` and `curves.csv` beside this file; each run's folder keeps its commands "
        "(`done.json`), log, metrics and maps. Plan: `host_sim/plans/apartment.svg` (12 x 9 m, 8 rooms), 7 robots "
        "on their tours, disk graph 6 m, DiNNO rho0 0.3 x 1.0004^k, 5 Adam steps of 512 samples per round, "
        "lr 1e-3 -> 1e-4.")
    add("")
    kinds = {}
    for r in runs:
        k = r["tags"].get("kind", "?")
        kinds.setdefault(k, [0, 0.0])
        kinds[k][0] += 1
        kinds[k][1] += r["seconds"] if math.isfinite(r["seconds"]) else 0.0
    missing = []
    plan = os.path.join(out, "campaign.json")
    if os.path.isfile(plan):
        with open(plan, encoding="utf-8") as f:
            finished = {r["name"] for r in runs}
            missing = [r["name"] for r in json.load(f).get("runs", []) if r["name"] not in finished]
    if missing:
        add(f"**Not finished yet: {len(missing)} runs** (`make experiments` goes on with them; the tables and "
            "figures below use the runs that finished): " + ", ".join(f"`{m}`" for m in missing) + ".")
        add("")
    add("| experiment | runs finished | run time on this machine (sum of the runs' wall time) |")
    add("|---|---|---|")
    for k, (n, sec) in kinds.items():
        add(f"| {k} | {n} | {sec / 60:.1f} min |")
    add("")
    # KL table
    add("## The KL question: every reading, relative to `uniform`")
    add("")
    add("Δ = (L - L_uniform) / L_uniform per seed, then mean ± sample standard deviation over seeds; negative "
        "means lower (better) than `uniform` with the same seed, preset and kl_weight. Final: after the last round; "
        "best: the lowest value of the curve (the MC-50 curve is measured for the baseline runs only). Validation: "
        "the same validation set for every run of a seed. σ̄ is the mean softplus(ρ) of the final models "
        "(softplus(-3) = 0.0486 at the start).")
    add("")
    add("| row | reading | strategy | seeds | final, mean weights | final, 1 sample | final, MC-50 mean | best, mean "
        "weights | best, 1 sample | best, MC-50 | final loss (mean weights) | σ̄ |")
    add("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for t in table:
        rel = t["rel"]
        add(f"| {t['row']} | {t['reading']} | {t['strategy']} | {t['seeds']} | {pm(rel['val_mean'])} | "
            f"{pm(rel['val_sample'])} | {pm(rel['val_mc'])} | {pm(rel['val_mean_best'])} | "
            f"{pm(rel['val_sample_best'])} | {pm(rel['val_mc_best'])} | {fmt(float(np.mean(t['abs'])))} | "
            f"{fmt(float(np.mean(t['sigma'])), 3)} |")
    add("")
    hits, best = verdict(table)
    if hits:
        add("**Readings where `kl` is at least 12 % below `uniform`** (mean over seeds): " + "; ".join(
            f"{t['row']} = {t['reading']} ({label}, {what}): {m:+.1f} %" for m, t, label, what in hits) + ".")
    elif best:
        m, t, label, what = best
        add(f"**No reading gives `kl` a 12-30 % lower validation loss than `uniform`.** The largest gain measured is "
            f"{m:+.1f} % ({t['row']} = {t['reading']}, {label}, {what}). Why: `docs/dinno_strategies.md`.")
    add("")
    add("## The paper's experiments")
    add("")
    for f, caption in (("single_agent.png", "6.1 Single agent: one pass, 50-pass mean and standard deviation, the path"),
                       ("kl_weight_maps.png", "6.1 kl_weight 1e-4, 5e-3, 5e-1: mean (top) and standard deviation"),
                       ("online_val_loss.png", "6.2 Online learning: validation loss after every communication round"),
                       ("online_maps.png", "6.2 Online learning: mean (top) and standard deviation per configuration"),
                       ("strategies_paper.png", "6.3 Seven agents, three strategies, the paper's network"),
                       ("strategies_small.png", "6.3 The same with the `small` network"),
                       ("decentralised.png", "6.3 The decentralised result: consensus mean, std, KDE of the lidar hits")):
        if f in figs:
            add(f"**{caption}**")
            add("")
            add(f"![{f}]({f})")
            add("")
    add("## Claims and our numbers")
    add("")
    add("| paper | claim | ours |")
    add("|---|---|---|")
    singles = sorted([r for r in runs if r["tags"].get("kind") == "single"], key=lambda r: float(r["tags"]["kl_weight"]))
    for r in singles:
        p = r["pm"]
        add(f"| 6.1 | the std shows where the agent had no data (kl_weight {r['tags']['kl_weight']}) | ROC AUC of the std "
            f"for cells > 0.5 m from every lidar point: {fmt(p.get('auc_std_unobserved'), 3)} "
            f"({fmt(100 * p.get('unobserved_fraction', math.nan), 3)} % of the cells unobserved); mean std observed "
            f"{fmt(p.get('std_mean_observed'), 3)}, unobserved {fmt(p.get('std_mean_unobserved'), 3)}"
            + (f"; cells unseen (> 0.15 m) against seen: AUC std {fmt(p.get('auc_seen_std'), 3)}, epistemic map "
               f"{fmt(p.get('auc_seen_epistemic'), 3)}" if "auc_seen_std" in p else "") + " |")
    online = sorted([r for r in runs if r["tags"].get("kind") == "online"],
                    key=lambda r: (r["tags"]["pool"], r["tags"]["comm_rounds"]))
    if online:
        add("| 6.2 | more communication rounds map better; CDR steadier than DR | final validation loss (mean over "
            "robots): " + ", ".join(f"{r['tags']['pool'].upper()} {r['tags']['comm_rounds']}: "
                                   f"{fmt(r['final']['val_mean'])}" for r in online) + " |")
    for t in table:
        if t["row"] in ("baseline", "network") and t["strategy"] == "kl":
            add(f"| 6.3 | kl: 12-30 % lower validation loss ({t['row']}, preset {t['runs'][0]['tags']['preset']}) | "
                f"{pm(t['rel']['val_mean'])} (mean weights), {pm(t['rel']['val_sample'])} (1 sample), "
                f"{pm(t['rel']['val_mc'])} (MC-50) |")
    cons = [r for r in runs if r["tags"].get("kind") == "kl_table" and r["tags"]["row"] in ("baseline", "network")]
    if cons:
        ce = max(r["final"]["consensus_error"] for r in cons)
        add(f"| 6.3 | all agents reach one model | largest final consensus error {fmt(ce, 3)} "
            f"(‖θ_i − mean‖ / ‖mean‖) over {len(cons)} runs |")
    add("")
    add("## Numbers the paper does not give")
    add("")
    add("Scored on the 0.05 m grid of 50 MC passes (of the consensus model: the element-wise mean of the final "
        "models), on the cells inside the building. **AUC**: the std as a score for the cells farther than 0.5 m "
        "from every training point against the others (1 = the std ranks every unseen cell above every seen one, "
        "0.5 = no better than chance; '-' when the robots' points reach every cell). **Spearman**: the std against "
        "the Gaussian-KDE density of the lidar hits (negative = less uncertain where the data are dense). "
        "**AUC … / seen**: the std, or the epistemic map (the share of the prior variance of the read-out left "
        "after the data), as a score for the unseen cells against the seen ones, a cell being seen when its centre "
        "is within 0.15 m of a training point (a cell some ray crossed). **AUSE**: area under the sparsification "
        "error of |mean − truth| (remove the cells of largest score first, minus the same with the cells ordered by "
        "their error; 0 = ordered like the errors, lower is better). **MSE** (= **Brier**, the mean as a "
        "probability of a wall), **wall IoU** (mean > 0.5): against the ground truth. **ECE**: expected calibration "
        "error of the 50-pass mean, 15 bins. '-': not measured (maps written before `map_epistemic.npy`). Every "
        "run's figures: `runs.csv`.")
    add("")
    metric_cols = METRIC_COLS
    if singles:
        add("**Per kl_weight** (one robot alone, section 6.1 set-up):")
        add("")
        add("| kl_weight | " + " | ".join(c[1] for c in metric_cols) + " | unseen cells | std seen / unseen | σ̄ | "
            "final val loss: mean weights / 1 sample / MC-50 |")
        add("|---" * (len(metric_cols) + 5) + "|")
        for r in singles:
            p, f = r["pm"], r["final"]
            add(f"| {r['tags']['kl_weight']} | " + " | ".join(fmt(p.get(c[0]), c[2]) for c in metric_cols) +
                f" | {fmt(100 * p.get('unobserved_fraction', math.nan), 3)} % | "
                f"{fmt(p.get('std_mean_observed'), 3)} / {fmt(p.get('std_mean_unobserved'), 3)} | "
                f"{fmt(f['sigma_mean'], 3)} | {fmt(f['val_mean'], 3)} / {fmt(f['val_sample'], 3)} / "
                f"{fmt(f['val_mc'], 3)} |")
        add("")
    strat = [t for t in table if t["row"] in ("baseline", "network") or t["row"].startswith("kl_weight")]
    if strat:
        add("**Per strategy** (7 robots; mean ± standard deviation over seeds):")
        add("")
        add("| row | reading | strategy | preset | seeds | " + " | ".join(c[1] for c in metric_cols) + " |")
        add("|---" * (len(metric_cols) + 5) + "|")
        for t in strat:
            cells = []
            for c, _, d in metric_cols:
                v = [r["pm"].get(c, math.nan) for r in t["runs"]]
                v = [x for x in v if x is not None and math.isfinite(x)]
                cells.append("-" if not v else fmt(v[0], d) if len(v) == 1 else
                             f"{np.mean(v):.{d}g} ± {np.std(v, ddof=1):.1g}")
            add(f"| {t['row']} | {t['reading']} | {t['strategy']} | {t['runs'][0]['tags']['preset']} | {t['seeds']} | "
                + " | ".join(cells) + " |")
        add("")
    if online:
        add("**Online** (7 robots over LCM):")
        add("")
        add("| configuration | " + " | ".join(c[1] for c in metric_cols) + " | consensus val loss |")
        add("|---" * (len(metric_cols) + 2) + "|")
        for r in online:
            p = r["pm"]
            add(f"| {r['tags']['pool'].upper()} {r['tags']['comm_rounds']} CR | " +
                " | ".join(fmt(p.get(c[0]), c[2]) for c in metric_cols) + f" | {fmt(r['final']['consensus_val'])} |")
        add("")
    cov = coverage_rows(runs)
    if cov:
        first = cov[0][2][0]["tags"]
        add("## Partial coverage (3 robots, tours in their start rooms)")
        add("")
        add(f"3 robots, each touring only its start room (`host_sim paths gen --rooms own`, the tours' seed = the "
            f"run's seed, so the rooms seen change with it), `host_sim fleet --inproc`, strategy `kl`, disk graph "
            f"6 m, {first['rounds']} rounds, preset {first['preset']}; plans: `apartment` = "
            "`host_sim/plans/apartment.svg` (8 rooms), `gen7` = `host_sim plan gen --seed 7 --rooms 12`. "
            "**consensus**: `host_sim maps` over the 3 final models (the consensus model, the fleet's posterior "
            "summed from the checkpoints); **robot 0's own**: `host_sim maps` over robot 0's checkpoint alone "
            "(its model and the posterior it holds after the posterior rounds, which give every robot the "
            "fleet's). Both "
            "are scored by `tools/paper_metrics.py` against the 3 robots' training samples (seen: within 0.15 m "
            "of a sample point), as in the section above. Mean ± sample standard deviation over seeds; every "
            "number per run: `coverage.csv`. **Observations / fleet's** (own rows, per seed): the observations "
            "in robot 0's posterior over those of the fleet's (1 when robot 0 holds the fleet's posterior).")
        add("")
        add("| plan | map | seeds | " + " | ".join(c[1] for c in COVERAGE_COLS) +
            " | final consensus error | posterior: observations over the fleet's |")
        add("|---" * (len(COVERAGE_COLS) + 5) + "|")
        for plan, what, rs, pms in cov:
            cells = [mean_sd([p.get(c, math.nan) for p in pms], d) for c, _, d in COVERAGE_COLS]
            ce = mean_sd([r["final"]["consensus_error"] for r in rs], 3) if what == "consensus" else ""
            post = "" if what == "consensus" else ", ".join(fmt(own_share(r, what), 3) for r in rs)
            add(f"| {plan} | {what} | {len(pms)} | " + " | ".join(cells) + f" | {ce} | {post} |")
        add("")
        own = [(r, what) for row in cov if row[1] != "consensus" for r, what in ((x, row[1]) for x in row[2])]
        off = [r for r, what in own if math.isfinite(own_share(r, what)) and abs(own_share(r, what) - 1.0) > 1e-3]
        if off:
            add(f"**A robot's posterior was not the fleet's in {len(off)} of {len(own)} runs** (observations / "
                "fleet's ≠ 1): its own map then knows less, or more, than the fleet saw. The consensus map is "
                "not affected.")
            add("")
    with open(os.path.join(out, ".REPORT.md.tmp"), "w", encoding="utf-8") as f:
        f.write("\n".join(L))
    os.replace(os.path.join(out, ".REPORT.md.tmp"), os.path.join(out, "REPORT.md"))
    print(f"report: {os.path.join(out, 'REPORT.md')} ({len(runs)} runs, {len(figs)} figures)")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("out", help="the folder of tools/experiments.py (with runs/)")
    ap.add_argument("--quick", action="store_true", help="label the report as the reduced campaign")
    a = ap.parse_args(argv)
    if not os.path.isdir(os.path.join(a.out, "runs")):
        print(f"paper_report: {a.out}/runs: No such directory", file=sys.stderr)
        return 1
    try:
        report(a.out, a.quick)
    except (ReportError, paper_metrics.MetricsError, OSError, KeyError, ValueError) as e:
        print(f"paper_report: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
