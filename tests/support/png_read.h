/* Picture tests: read a PNG back as 8-bit RGB (libpng's simplified API) and find where a
 * colour landed, to check the picture convention (host_sim/maps/sim_figure.h: y up) and the robot
 * colours (host_sim/maps/sim_palette.h) of the PNG writers. Header-only: the tests that include it
 * link libpng already (host_sim's libraries need it). */
#ifndef TESTS_PNG_READ_H
#define TESTS_PNG_READ_H

#include <png.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

/* The PNG at path as w x h x 3 bytes (row 0 the top), malloc'd; NULL when unreadable. */
static inline uint8_t *tpng_read_rgb(const char *path, int *w, int *h)
{
    png_image img;
    memset(&img, 0, sizeof img);
    img.version = PNG_IMAGE_VERSION;
    if (!png_image_begin_read_from_file(&img, path))
        return NULL;
    img.format = PNG_FORMAT_RGB;
    uint8_t *rgb = malloc(PNG_IMAGE_SIZE(img));
    if (rgb == NULL || !png_image_finish_read(&img, NULL, rgb, 0, NULL)) {
        png_image_free(&img);
        free(rgb);
        return NULL;
    }
    *w = (int)img.width;
    *h = (int)img.height;
    return rgb;
}

/* Pixels of colour col (each channel within tol) and their mean column and row (fx, fy as
 * fractions of the width and height, 0 = left / top); returns the count (0: fx, fy unset). */
static inline long tpng_find(const uint8_t *rgb, int w, int h, const uint8_t col[3], int tol, double *fx,
                             double *fy)
{
    long n = 0;
    double sx = 0.0, sy = 0.0;
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            const uint8_t *p = rgb + 3 * ((size_t)y * (size_t)w + (size_t)x);
            if (abs(p[0] - col[0]) <= tol && abs(p[1] - col[1]) <= tol && abs(p[2] - col[2]) <= tol) {
                n++;
                sx += x + 0.5;
                sy += y + 0.5;
            }
        }
    if (n > 0) {
        *fx = sx / n / w;
        *fy = sy / n / h;
    }
    return n;
}

#endif /* TESTS_PNG_READ_H */
