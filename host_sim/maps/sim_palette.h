/* One colour per robot, the same in every figure: the paths PNG (host_sim paths --png), the
 * map PNGs (host_sim run/fleet/maps), the 3D scene (host_sim render) and the Python plots
 * (tools/palette.py holds the same table; tests/tools/test_palette.py checks that the two
 * agree, so a robot keeps its colour from the scene to its tour on the map to its loss curve).
 *
 * The colours are matplotlib's "tab10" in its order, because the Python plots used it already
 * and it stays readable on white (free), black (walls) and the viridis/magma colour maps.
 * Robot k has colour k % SIM_PALETTE_N. */
#ifndef SIM_PALETTE_H
#define SIM_PALETTE_H

#include <stdint.h>

#define SIM_PALETTE_N 10

/* RGB of robot k (k >= 0; negative k is taken as its absolute value), 8 bits per channel. */
static inline const uint8_t *sim_palette_rgb(int k)
{
    /* palette-begin: tests/tools/test_palette.py reads the rows between these markers. */
    static const uint8_t rgb[SIM_PALETTE_N][3] = {
        {31, 119, 180},  /* 0 blue */
        {255, 127, 14},  /* 1 orange */
        {44, 160, 44},   /* 2 green */
        {214, 39, 40},   /* 3 red */
        {148, 103, 189}, /* 4 purple */
        {140, 86, 75},   /* 5 brown */
        {227, 119, 194}, /* 6 pink */
        {127, 127, 127}, /* 7 grey */
        {188, 189, 34},  /* 8 olive */
        {23, 190, 207},  /* 9 cyan */
    };
    /* palette-end */
    const int i = k < 0 ? -(k % SIM_PALETTE_N) : k % SIM_PALETTE_N;
    return rgb[i];
}

/* The lidar sweep of the 3D scene (host_sim render): neutral greys, unlike every robot colour
 * above, so the sweep is not taken for a robot's (robot 3's red was). A ray that hit a wall is
 * dark grey, one that reached the range light grey; the hits are black dots. tests/sim/test_render.c
 * checks they stay apart from the robot colours. */
#define SIM_LIDAR_HIT_RGB 64, 64, 64
#define SIM_LIDAR_MISS_RGB 176, 176, 176
#define SIM_LIDAR_DOT_RGB 0, 0, 0

#endif /* SIM_PALETTE_H */
