/* Waypoint files: CSV read (validated, FILE:LINE errors) and write (contract in sim_paths.h). */
#include "sim_paths.h"
#include "sim_paths_util.h"
#include "hal_host_file.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- CSV ---------------------------------------------------------------------------------- */

int sim_path_write_csv(const sim_path_t *path, const char *file, char *err, size_t errlen)
{
    if (path == NULL || file == NULL || path->n < 2)
        return sim_paths_errf(err, errlen, "%s: a path needs at least 2 waypoints", file ? file : "(null)");
    hal_host_file_t out;
    int rc = hal_host_file_begin(&out, file);
    if (rc == 0) {
        FILE *f = hal_host_file_stream(&out);
        fprintf(f, "x_m,y_m\n");
        for (int i = 0; i < path->n; i++)
            fprintf(f, "%.3f,%.3f\n", path->p[i].x, path->p[i].y);
        rc = hal_host_file_commit(&out);
        if (rc < 0)
            hal_host_file_abort(&out);
    }
    if (rc < 0) {
        sim_paths_errf(err, errlen, "%s: %s", file, hal_host_file_strerror(rc));
        return rc;
    }
    return 0;
}

static int parse_num(const char *s, size_t len, double *out)
{
    while (len > 0 && (*s == ' ' || *s == '\t')) {
        s++;
        len--;
    }
    while (len > 0 && (s[len - 1] == ' ' || s[len - 1] == '\t'))
        len--;
    char tok[64];
    if (len == 0 || len >= sizeof tok)
        return -1;
    memcpy(tok, s, len);
    tok[len] = '\0';
    char *end = NULL;
    errno = 0;
    double d = strtod(tok, &end);
    if (end == tok || *end != '\0' || errno == ERANGE || !isfinite(d))
        return -1;
    *out = d;
    return 0;
}

int sim_path_parse_csv(const char *text, const char *name, const sim_plan_t *plan, sim_path_t *path, char *err,
                       size_t errlen)
{
    if (err != NULL && errlen > 0)
        err[0] = '\0';
    if (path == NULL)
        return -EINVAL;
    sim_path_init(path);
    if (name == NULL)
        name = "<memory>";
    int line_cap = 0;
    if (text == NULL || plan == NULL)
        return sim_paths_errf(err, errlen, "%s: no text or no plan", name);
    int cap = 0, line = 0, header = 0, rc = 0;
    const char *s = text;
    while (*s != '\0' && rc == 0) {
        line++;
        const char *e = strchr(s, '\n');
        size_t len = e ? (size_t)(e - s) : strlen(s);
        const char *next = e ? e + 1 : s + len;
        if (len > 0 && s[len - 1] == '\r')
            len--;
        size_t k = 0;
        while (k < len && (s[k] == ' ' || s[k] == '\t'))
            k++;
        if (k == len || s[k] == '#') {
            s = next;
            continue;
        }
        if (!header) {
            if (len - k != 7 || memcmp(s + k, "x_m,y_m", 7) != 0) {
                rc = sim_paths_errf(err, errlen, "%s:%d: expected the header 'x_m,y_m', found '%.*s'", name, line,
                          (int)(len > 40 ? 40 : len), s);
                break;
            }
            header = 1;
            s = next;
            continue;
        }
        const char *comma = memchr(s, ',', len);
        double x, y;
        if (comma == NULL) {
            rc = sim_paths_errf(err, errlen, "%s:%d: expected 'x,y', found '%.*s'", name, line, (int)(len > 40 ? 40 : len), s);
            break;
        }
        size_t lx = (size_t)(comma - s);
        if (memchr(comma + 1, ',', len - lx - 1) != NULL) {
            rc = sim_paths_errf(err, errlen, "%s:%d: more than 2 fields", name, line);
            break;
        }
        if (parse_num(s, lx, &x) != 0 || parse_num(comma + 1, len - lx - 1, &y) != 0) {
            rc = sim_paths_errf(err, errlen, "%s:%d: bad number in '%.*s'", name, line, (int)(len > 40 ? 40 : len), s);
            break;
        }
        int cls = sim_plan_classify_point(plan, x, y);
        if (cls != SIM_CELL_FREE) {
            rc = sim_paths_errf(err, errlen, "%s:%d: waypoint (%g, %g) is %s", name, line, x, y,
                      cls == SIM_CELL_WALL ? "inside a wall" : "outside the plan's rooms");
            break;
        }
        const int before = path->n;
        rc = sim_paths_push(path, &cap, x, y);
        if (rc == 0 && path->n > before) {
            if (path->n > line_cap) {
                int *nl = realloc(path->line, (size_t)cap * sizeof *nl);
                if (nl == NULL)
                    rc = -ENOMEM;
                else
                    path->line = nl, line_cap = cap;
            }
            if (rc == 0)
                path->line[path->n - 1] = line;
        }
        if (rc == -E2BIG)
            sim_paths_errf(err, errlen, "%s:%d: more than %d waypoints", name, line, SIM_PATH_MAX_POINTS);
        else if (rc == -ENOMEM)
            sim_paths_errf(err, errlen, "%s:%d: out of memory", name, line);
        /* push_point folds an exact repeat of the previous point: still counts as a line. */
        s = next;
    }
    if (rc == 0 && !header)
        rc = sim_paths_errf(err, errlen, "%s:%d: empty file: expected the header 'x_m,y_m'", name, line > 0 ? line : 1);
    if (rc == 0 && path->n < 2)
        rc = sim_paths_errf(err, errlen, "%s:%d: %d distinct waypoint%s, at least 2 needed", name, line, path->n,
                  path->n == 1 ? "" : "s");
    /* Free waypoints are not enough: a segment between two of them may cross a wall. */
    int seg = -1;
    if (rc == 0 && sim_path_first_tight_segment(plan, path, 1e-9, &seg, NULL))
        rc = sim_paths_errf(err, errlen, "%s:%d: the segment (%g, %g) -> (%g, %g) crosses a wall", name,
                  path->line[seg + 1], path->p[seg].x, path->p[seg].y, path->p[seg + 1].x, path->p[seg + 1].y);
    if (rc != 0)
        sim_path_free(path);
    return rc;
}

int sim_path_read_csv(const char *file, const sim_plan_t *plan, sim_path_t *path, char *err, size_t errlen)
{
    if (path == NULL)
        return -EINVAL;
    sim_path_init(path);
    if (file == NULL)
        return sim_paths_errf(err, errlen, "(null): no file name");
    FILE *f = NULL;
    int orc = hal_host_file_open_read(file, &f);
    if (orc < 0) {
        sim_paths_errf(err, errlen, "%s: cannot open: %s", file, strerror(-orc));
        return orc;
    }
    /* Waypoint files are small: cap at 16 MB. */
    const size_t max = 16u << 20;
    char *buf = malloc(max + 1);
    if (buf == NULL) {
        fclose(f);
        return -ENOMEM;
    }
    size_t n = fread(buf, 1, max + 1, f);
    int bad = ferror(f);
    fclose(f);
    int rc;
    if (bad) {
        rc = sim_paths_errf(err, errlen, "%s: read error", file);
    } else if (n > max) {
        rc = sim_paths_errf(err, errlen, "%s: file larger than %zu bytes", file, max);
    } else if (memchr(buf, '\0', n) != NULL) {
        rc = sim_paths_errf(err, errlen, "%s: NUL byte: not a text file", file);
    } else {
        buf[n] = '\0';
        rc = sim_path_parse_csv(buf, file, plan, path, err, errlen);
    }
    free(buf);
    return rc;
}
