/* Coverage grid: see sim_coverage.h. */
#include "sim_coverage.h"

#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "common/crc32.h"
#include "hal_host_file.h"
#include "common/le_bytes.h"

static const char cov_magic[8] = {'F', 'S', 'C', 'O', 'V', 'B', 'I', 'N'};

int sim_coverage_from_grid(sim_coverage_t *c, const sim_grid_t *g)
{
    if (c == NULL)
        return -EINVAL;
    memset(c, 0, sizeof *c);
    if (g == NULL || g->cells == NULL || g->w < 1 || g->h < 1 || g->w > SIM_GRID_MAX_SIDE ||
        g->h > SIM_GRID_MAX_SIDE || !(g->res > 0) || !isfinite(g->res) || !isfinite(g->origin.x) ||
        !isfinite(g->origin.y))
        return -EINVAL;
    const size_t n = (size_t)g->w * (size_t)g->h;
    c->first_seen = malloc(n * sizeof *c->first_seen);
    if (c->first_seen == NULL)
        return -ENOMEM;
    c->w = g->w;
    c->h = g->h;
    c->res = g->res;
    c->origin = g->origin;
    for (size_t i = 0; i < n; i++) {
        const int free_cell = g->cells[i] == SIM_CELL_FREE;
        c->first_seen[i] = free_cell ? INFINITY : SIM_COVERAGE_NOT_FREE;
        c->n_free += (uint64_t)free_cell;
    }
    return 0;
}

int sim_coverage_from_plan(sim_coverage_t *c, const sim_plan_t *plan, double res_m)
{
    if (c == NULL)
        return -EINVAL;
    memset(c, 0, sizeof *c);
    sim_grid_t g;
    int rc = sim_grid_from_plan(plan, res_m, &g);
    if (rc < 0)
        return rc;
    rc = sim_coverage_from_grid(c, &g);
    sim_grid_free(&g);
    return rc;
}

void sim_coverage_free(sim_coverage_t *c)
{
    if (c == NULL)
        return;
    free(c->first_seen);
    memset(c, 0, sizeof *c);
}

/* The smallest float >= t: times are stored as float32, rounded up so a cell never counts as
 * seen before the scan that saw it, and every comparison with a double time rounds it alike. */
static float up_f(double t)
{
    float f = (float)t;
    if ((double)f < t)
        f = nextafterf(f, INFINITY);
    return f;
}

static inline void mark(sim_coverage_t *c, long col, long row, float t)
{
    if (col < 0 || row < 0 || col >= c->w || row >= c->h)
        return;
    float *v = &c->first_seen[(size_t)row * (size_t)c->w + (size_t)col];
    if (t < *v) /* NOT_FREE (-1) is below any time: walls are never marked */
        *v = t;
}

/* Amanatides-Woo: every cell the segment (x0, y0) -> (x1, y1) (grid units) crosses, in order.
 * The step count is the Manhattan distance between the end cells, so the walk ends even when
 * rounding makes it leave the exact line; cells off the grid are skipped, not clipped, which
 * costs nothing for the short rays of a lidar. */
static void trace(sim_coverage_t *c, double x0, double y0, double x1, double y1, float t)
{
    long cx = (long)floor(x0), cy = (long)floor(y0);
    const long ex = (long)floor(x1), ey = (long)floor(y1);
    const double dx = x1 - x0, dy = y1 - y0;
    const int sx = dx > 0 ? 1 : dx < 0 ? -1 : 0;
    const int sy = dy > 0 ? 1 : dy < 0 ? -1 : 0;
    const double tdx = sx != 0 ? fabs(1.0 / dx) : INFINITY;
    const double tdy = sy != 0 ? fabs(1.0 / dy) : INFINITY;
    double tmx = sx > 0 ? ((double)cx + 1.0 - x0) * tdx : sx < 0 ? (x0 - (double)cx) * tdx : INFINITY;
    double tmy = sy > 0 ? ((double)cy + 1.0 - y0) * tdy : sy < 0 ? (y0 - (double)cy) * tdy : INFINITY;
    const long n = labs(ex - cx) + labs(ey - cy);
    mark(c, cx, cy, t);
    for (long i = 0; i < n; i++) {
        if (tmx < tmy) {
            cx += sx;
            tmx += tdx;
        } else {
            cy += sy;
            tmy += tdy;
        }
        mark(c, cx, cy, t);
    }
}

int sim_coverage_add_scan(sim_coverage_t *c, double t_s, double x, double y, double theta,
                          const hal_lidar_scan_t *scan)
{
    if (c == NULL || c->first_seen == NULL || scan == NULL || !isfinite(t_s) || t_s < 0 || !isfinite(x) ||
        !isfinite(y) || !isfinite(theta) || scan->count == 0 || scan->count > HAL_LIDAR_MAX_BEAMS ||
        !isfinite(scan->angle_min_rad) || !isfinite(scan->angle_step_rad) || !(scan->range_max_m > 0) ||
        scan->range_max_m > SIM_COVERAGE_MAX_RANGE_M || !(scan->range_min_m >= 0))
        return -EINVAL;
    const float t = up_f(t_s);
    const double gx = (x - c->origin.x) / c->res, gy = (y - c->origin.y) / c->res;
    /* Cell indices are longs: a sensor absurdly far from the grid is a caller's error, not a ray. */
    if (fabs(gx) > 1e9 || fabs(gy) > 1e9 || (double)scan->range_max_m / c->res > 1e9)
        return -EINVAL;
    for (uint32_t i = 0; i < scan->count; i++) {
        const double r = (double)scan->ranges_m[i];
        double len;
        if (isnan(r) || r < (double)scan->range_min_m)
            continue; /* dropout or too close: how far the beam went is unknown */
        len = r <= (double)scan->range_max_m ? r : (double)scan->range_max_m; /* +inf: free to range_max */
        const double a = theta + (double)scan->angle_min_rad + (double)i * (double)scan->angle_step_rad;
        trace(c, gx, gy, gx + cos(a) * len / c->res, gy + sin(a) * len / c->res, t);
    }
    if (t_s > c->t_end)
        c->t_end = t_s;
    return 0;
}

uint64_t sim_coverage_seen(const sim_coverage_t *c, double t_s)
{
    uint64_t n = 0;
    const float tf = up_f(t_s);
    const size_t cells = (size_t)c->w * (size_t)c->h;
    for (size_t i = 0; i < cells; i++) {
        const float v = c->first_seen[i];
        n += (uint64_t)(v >= 0 && v <= tf);
    }
    return n;
}

double sim_coverage_at(const sim_coverage_t *c, double t_s)
{
    if (c == NULL || c->n_free == 0)
        return 0.0;
    return (double)sim_coverage_seen(c, t_s) / (double)c->n_free;
}

int sim_coverage_merge(sim_coverage_t *dst, const sim_coverage_t *src)
{
    if (dst == NULL || src == NULL || dst->first_seen == NULL || src->first_seen == NULL || dst->w != src->w ||
        dst->h != src->h || dst->res != src->res || dst->origin.x != src->origin.x ||
        dst->origin.y != src->origin.y || dst->n_free != src->n_free)
        return -EINVAL;
    const size_t n = (size_t)dst->w * (size_t)dst->h;
    for (size_t i = 0; i < n; i++) /* the same free cells: checked whole before anything changes */
        if ((dst->first_seen[i] < 0) != (src->first_seen[i] < 0))
            return -EINVAL;
    for (size_t i = 0; i < n; i++)
        if (src->first_seen[i] < dst->first_seen[i])
            dst->first_seen[i] = src->first_seen[i];
    if (src->t_end > dst->t_end)
        dst->t_end = src->t_end;
    return 0;
}

int sim_coverage_encode(const sim_coverage_t *c, uint8_t **buf, size_t *len)
{
    if (c == NULL || c->first_seen == NULL || buf == NULL || len == NULL)
        return -EINVAL;
    const size_t n = (size_t)c->w * (size_t)c->h;
    const size_t total = SIM_COVERAGE_HEADER_BYTES + 4 * n;
    uint8_t *b = calloc(1, total);
    if (b == NULL)
        return -ENOMEM;
    for (size_t i = 0; i < n; i++) {
        uint32_t v;
        memcpy(&v, &c->first_seen[i], sizeof v);
        le_put_u32(b + SIM_COVERAGE_HEADER_BYTES + 4 * i, v);
    }
    memcpy(b, cov_magic, sizeof cov_magic);
    le_put_u32(b + 8, SIM_COVERAGE_VERSION);
    le_put_u32(b + 12, (uint32_t)c->w);
    le_put_u32(b + 16, (uint32_t)c->h);
    le_put_u32(b + 20, crc32_ieee(b + SIM_COVERAGE_HEADER_BYTES, 4 * n));
    le_put_f64(b + 24, c->res);
    le_put_f64(b + 32, c->origin.x);
    le_put_f64(b + 40, c->origin.y);
    le_put_f64(b + 48, c->t_end);
    le_put_u64(b + 56, c->n_free);
    *buf = b;
    *len = total;
    return 0;
}

/* The header's checks, shared by decode and by read (which sizes its buffer from them). */
static int check_header(const uint8_t *b, size_t len, size_t *cells, const char **why)
{
    if (len < SIM_COVERAGE_HEADER_BYTES)
        return *why = "truncated: shorter than the 64-byte header", -EINVAL;
    if (memcmp(b, cov_magic, sizeof cov_magic) != 0)
        return *why = "not a coverage file (bad magic)", -EINVAL;
    if (le_get_u32(b + 8) != SIM_COVERAGE_VERSION)
        return *why = "unsupported coverage file version", -EINVAL;
    const uint32_t w = le_get_u32(b + 12), h = le_get_u32(b + 16);
    if (w < 1 || h < 1 || w > SIM_GRID_MAX_SIDE || h > SIM_GRID_MAX_SIDE)
        return *why = "bad grid dimensions", -EINVAL;
    const double res = le_get_f64(b + 24), ox = le_get_f64(b + 32), oy = le_get_f64(b + 40), t_end = le_get_f64(b + 48);
    if (!isfinite(res) || !(res > 0) || !isfinite(ox) || !isfinite(oy))
        return *why = "bad resolution or origin", -EINVAL;
    if (!isfinite(t_end) || t_end < 0)
        return *why = "bad end time", -EINVAL;
    if (le_get_u64(b + 56) > (uint64_t)w * h)
        return *why = "more free cells than cells", -EINVAL;
    *cells = (size_t)w * (size_t)h;
    return 0;
}

int sim_coverage_decode(sim_coverage_t *c, const uint8_t *b, size_t len, const char **why)
{
    const char *dummy;
    if (why == NULL)
        why = &dummy;
    if (c == NULL || b == NULL)
        return *why = "no buffer", -EINVAL;
    memset(c, 0, sizeof *c);
    size_t n = 0;
    int rc = check_header(b, len, &n, why);
    if (rc < 0)
        return rc;
    if (len != SIM_COVERAGE_HEADER_BYTES + 4 * n)
        return *why = len < SIM_COVERAGE_HEADER_BYTES + 4 * n ? "truncated: fewer cells than its dimensions"
                                                              : "trailing bytes after the cells",
               -EINVAL;
    const uint8_t *cells = b + SIM_COVERAGE_HEADER_BYTES;
    if (crc32_ieee(cells, 4 * n) != le_get_u32(b + 20))
        return *why = "CRC mismatch: the cells are corrupt", -EINVAL;
    const double t_end = le_get_f64(b + 48);
    const float t_max = up_f(t_end);
    float *fs = malloc(n * sizeof *fs);
    if (fs == NULL)
        return *why = "out of memory", -ENOMEM;
    uint64_t n_free = 0;
    for (size_t i = 0; i < n; i++) {
        const uint32_t u = le_get_u32(cells + 4 * i);
        float v;
        memcpy(&v, &u, sizeof v);
        if (isnan(v) || (v < 0 && v != SIM_COVERAGE_NOT_FREE) || (isfinite(v) && v > t_max)) {
            free(fs);
            return *why = isnan(v) ? "a cell is NaN" : "a cell time is out of range", -EINVAL;
        }
        n_free += (uint64_t)(v >= 0);
        fs[i] = v;
    }
    if (n_free != le_get_u64(b + 56)) {
        free(fs);
        return *why = "free-cell count does not match the cells", -EINVAL;
    }
    c->w = (int)le_get_u32(b + 12);
    c->h = (int)le_get_u32(b + 16);
    c->res = le_get_f64(b + 24);
    c->origin = (sim_vec2_t){le_get_f64(b + 32), le_get_f64(b + 40)};
    c->t_end = t_end;
    c->n_free = n_free;
    c->first_seen = fs;
    return 0;
}

int sim_coverage_write(const sim_coverage_t *c, const char *path, char *err, size_t errlen)
{
    uint8_t *buf = NULL;
    size_t len = 0;
    int rc = sim_coverage_encode(c, &buf, &len);
    hal_host_file_t f;
    if (rc == 0 && (rc = hal_host_file_begin(&f, path)) == 0) {
        rc = hal_host_file_write(&f, buf, len);
        rc = rc == 0 ? hal_host_file_commit(&f) : rc;
        if (rc < 0)
            hal_host_file_abort(&f);
    }
    free(buf);
    if (rc < 0 && err != NULL && errlen > 0)
        snprintf(err, errlen, "%s: %s", path, hal_host_file_strerror(rc));
    return rc;
}

int sim_coverage_read(sim_coverage_t *c, const char *path, char *err, size_t errlen)
{
    char dummy[2];
    if (err == NULL || errlen == 0) {
        err = dummy;
        errlen = sizeof dummy;
    }
    if (c == NULL)
        return -EINVAL;
    memset(c, 0, sizeof *c);
    FILE *f = NULL;
    int rc = hal_host_file_open_read(path, &f);
    if (rc < 0) {
        snprintf(err, errlen, "%s: %s", path, hal_host_file_strerror(rc));
        return rc;
    }
    /* The header first: the buffer is sized from its checked dimensions and the file's size,
       never from an unchecked field. */
    uint8_t hdr[SIM_COVERAGE_HEADER_BYTES];
    const size_t got = fread(hdr, 1, sizeof hdr, f);
    const char *why = NULL;
    size_t n = 0;
    struct stat st;
    rc = check_header(hdr, got, &n, &why);
    if (rc == 0 && (fstat(fileno(f), &st) != 0 || st.st_size < 0))
        rc = -EIO, why = "cannot stat";
    if (rc == 0 && (uint64_t)st.st_size != SIM_COVERAGE_HEADER_BYTES + 4 * (uint64_t)n)
        rc = -EINVAL, why = (uint64_t)st.st_size < SIM_COVERAGE_HEADER_BYTES + 4 * (uint64_t)n
                                ? "truncated: fewer cells than its dimensions"
                                : "trailing bytes after the cells";
    uint8_t *buf = NULL;
    if (rc == 0 && (buf = malloc(SIM_COVERAGE_HEADER_BYTES + 4 * n)) == NULL)
        rc = -ENOMEM, why = "out of memory";
    if (rc == 0) {
        memcpy(buf, hdr, sizeof hdr);
        const size_t body = fread(buf + sizeof hdr, 1, 4 * n, f);
        rc = sim_coverage_decode(c, buf, sizeof hdr + body, &why);
    }
    free(buf);
    fclose(f);
    if (rc < 0)
        snprintf(err, errlen, "%s: %s", path, why ? why : "invalid coverage file");
    return rc;
}

static int cmp_float(const void *a, const void *b)
{
    const float x = *(const float *)a, y = *(const float *)b;
    return (x > y) - (x < y);
}

int sim_coverage_write_csv(const sim_coverage_t *c, int n_robots, double step_s, FILE *f)
{
    if (c == NULL || c->first_seen == NULL || f == NULL || n_robots < 1 || !(step_s > 0) || !isfinite(step_s))
        return -EINVAL;
    /* The seen times sorted once, then one sweep: a row costs nothing however many there are. */
    if (c->t_end / step_s > SIM_COVERAGE_CSV_MAX_ROWS)
        return -E2BIG;
    const size_t cells = (size_t)c->w * (size_t)c->h;
    size_t m = 0;
    float *seen = malloc((c->n_free > 0 ? (size_t)c->n_free : 1) * sizeof *seen);
    if (seen == NULL)
        return -ENOMEM;
    for (size_t i = 0; i < cells; i++)
        if (c->first_seen[i] >= 0 && isfinite(c->first_seen[i]))
            seen[m++] = c->first_seen[i];
    qsort(seen, m, sizeof *seen, cmp_float);
    fputs(SIM_COVERAGE_CSV_HEADER, f);
    size_t k = 0;
    const double denom = c->n_free > 0 ? (double)c->n_free : 1.0;
    for (uint64_t row = 0;; row++) {
        double t = (double)row * step_s;
        const int last = t >= c->t_end - 1e-9;
        if (last)
            t = c->t_end;
        while (k < m && seen[k] <= up_f(t))
            k++;
        fprintf(f, "%.3f,%.3f,%.6f\n", t, (double)n_robots * t, (double)k / denom);
        if (last)
            break;
    }
    free(seen);
    return ferror(f) ? -EIO : 0;
}
