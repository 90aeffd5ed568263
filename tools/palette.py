"""One colour per robot, the same in every figure (the C side is host_sim/maps/sim_palette.h;
tests/tools/test_palette.py checks that the two tables agree).

Robot i has ROBOT_RGB[i % len(ROBOT_RGB)]: matplotlib's "tab10" in its order.

    from palette import robot_colour      # (tools/ on sys.path)
    ax.plot(x, y, color=robot_colour(i))
"""

ROBOT_RGB = (
    (31, 119, 180),   # 0 blue
    (255, 127, 14),   # 1 orange
    (44, 160, 44),    # 2 green
    (214, 39, 40),    # 3 red
    (148, 103, 189),  # 4 purple
    (140, 86, 75),    # 5 brown
    (227, 119, 194),  # 6 pink
    (127, 127, 127),  # 7 grey
    (188, 189, 34),   # 8 olive
    (23, 190, 207),   # 9 cyan
)


def robot_rgb(i):
    """Robot i's colour as 8-bit (r, g, b)."""
    return ROBOT_RGB[abs(int(i)) % len(ROBOT_RGB)]


def robot_colour(i):
    """Robot i's colour as matplotlib takes it: (r, g, b) in [0, 1]."""
    return tuple(c / 255.0 for c in robot_rgb(i))


# One colour map per quantity, the same in every figure tools/fleet_report.py draws (the pictures
# at the top of a run's folder and the ones it redraws in maps/): a quantity never changes colours
# from one picture to the next. tests/tools/test_palette.py checks fleet_report.py names no colour
# map of its own.
QUANTITY_CMAP = {
    "occupancy": "gray_r",   # P(occupied): white free, black walls, as map.pgm shows it
    "std": "viridis",        # MC standard deviation of P(occupied)
    "epistemic": "magma",    # share of the prior variance left (1 = nothing observed there)
    "hits": "inferno",       # lidar hits per square metre
}

# The map.yaml occupied threshold drawn as a contour on the occupancy maps: a gold line with a
# black edge, visible on white and black cells and unlike every robot colour above.
THRESHOLD_COLOUR = "#ffd000"


def quantity_cmap(quantity):
    """The matplotlib colour map name of a quantity (a key of QUANTITY_CMAP)."""
    return QUANTITY_CMAP[quantity]
