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
