#!/usr/bin/python3
"""One colour per robot in every figure: the C palette (host_sim/maps/sim_palette.h, used by the
paths PNG, the map PNGs and the 3D scene) and the Python one (tools/palette.py, used by
tools/fleet_figures.py (the figures of tools/fleet_report.py), tools/plot_partition.py,
tools/paper_report.py) must be the same table, and the Python plots must take their robot colours
from it.

    python3 tests/tools/test_palette.py      prints "N passed, M failed", exit 1 on failure
"""
import glob
import os
import re
import sys

sys.path.insert(0, os.path.dirname(os.path.realpath(__file__)))
from minitest import check, main, need_numpy, test  # noqa: E402

need_numpy("test_palette")

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.realpath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "tools"))
import palette  # noqa: E402


def c_palette():
    """The rows between the palette-begin and palette-end markers of sim_palette.h."""
    with open(os.path.join(ROOT, "host_sim", "maps", "sim_palette.h")) as f:
        text = f.read()
    m = re.search(r"palette-begin(.*?)palette-end", text, re.S)
    check(m is not None, "sim_palette.h: no palette-begin/palette-end markers")
    rows = re.findall(r"\{\s*(\d+)\s*,\s*(\d+)\s*,\s*(\d+)\s*\}", m.group(1))
    n = re.search(r"#define\s+SIM_PALETTE_N\s+(\d+)", text)
    check(n is not None and int(n.group(1)) == len(rows), "SIM_PALETTE_N is not the number of rows")
    return tuple(tuple(int(v) for v in r) for r in rows)


@test
def c_and_python_tables_agree():
    c = c_palette()
    check(len(c) >= 7, f"only {len(c)} colours in sim_palette.h (the default fleet has 7 robots)")
    check(c == tuple(palette.ROBOT_RGB), f"sim_palette.h {c} != tools/palette.py {palette.ROBOT_RGB}")
    check(len(set(c)) == len(c), "two robots share a colour")


@test
def robot_colour_wraps_and_is_matplotlib_ready():
    n = len(palette.ROBOT_RGB)
    for i in range(2 * n):
        rgb = palette.robot_rgb(i)
        check(rgb == palette.ROBOT_RGB[i % n], f"robot {i}: {rgb}")
        col = palette.robot_colour(i)
        check(all(0.0 <= v <= 1.0 for v in col) and tuple(round(v * 255) for v in col) == rgb, f"robot {i}: {col}")
    # The C side takes a negative k as its absolute value; so does Python.
    check(palette.robot_rgb(-3) == palette.robot_rgb(3), "negative robot index")


@test
def python_plots_take_robot_colours_from_the_palette():
    """No tool picks robot colours from a colour map of its own (the way the figures drifted)."""
    for p in sorted(glob.glob(os.path.join(ROOT, "tools", "*.py"))):
        with open(p) as f:
            text = f.read()
        check('get_cmap("tab10")' not in text and "get_cmap('tab10')" not in text,
              f"{os.path.basename(p)}: a colour map of its own for the robots; use palette.robot_colour")
    for name in ("fleet_figures.py", "plot_partition.py", "paper_report.py"):
        with open(os.path.join(ROOT, "tools", name)) as f:
            check("from palette import robot_colour" in f.read(), f"{name} does not use tools/palette.py")


@test
def fleet_report_tours_in_robot_colours():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np
    import fleet_figures

    class Run:
        tours = {i: np.array([[0.0, float(i)], [1.0, float(i)]]) for i in range(3)}

    fig, ax = plt.subplots()
    fleet_figures.draw_tours(ax, Run())
    lines = [l for l in ax.get_lines() if l.get_label().startswith("robot ")]
    check(len(lines) == 3, f"{len(lines)} tour lines")
    for line in lines:
        i = int(line.get_label().split()[1])
        got = tuple(round(v * 255) for v in matplotlib.colors.to_rgb(line.get_color()))
        check(got == palette.robot_rgb(i), f"robot {i}'s tour drawn in {got}, not {palette.robot_rgb(i)}")
    plt.close(fig)


@test
def one_colour_map_per_quantity():
    """fleet_report.py and fleet_figures.py (its figures) take every colour map from
    palette.QUANTITY_CMAP (none of their own), and no two quantities share one."""
    for tool in ("fleet_report.py", "fleet_figures.py"):
        with open(os.path.join(ROOT, "tools", tool)) as f:
            text = f.read()
        for name in set(palette.QUANTITY_CMAP.values()) | {"magma", "viridis", "gray_r", "inferno", "gray"}:
            check(f'"{name}"' not in text and f"'{name}'" not in text, f"{tool} names colour map {name}")
    check(len(set(palette.QUANTITY_CMAP.values())) == len(palette.QUANTITY_CMAP), "two quantities share a map")
    import matplotlib
    for q, name in palette.QUANTITY_CMAP.items():
        check(name in matplotlib.colormaps, f"{q}: {name} is no matplotlib colour map")
    check(tuple(round(v * 255) for v in matplotlib.colors.to_rgb(palette.THRESHOLD_COLOUR)) not in palette.ROBOT_RGB,
          "the threshold contour in a robot's colour")


if __name__ == "__main__":
    sys.exit(main())
