/* Floor plans (sim_plan.h): the API, errors, and what is left once the tree is read (the
 * bounding box and its sanity). The parser's parts and why they are apart: sim_plan_int.h. */
#include "sim_plan_int.h"
#include "hal_host_file.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- errors and arrays ---------------------------------------------------------------------- */

/* How much of an id a message quotes: what a record keeps. */
#define ID_SHOWN (SIM_PLAN_ID_MAX - 1)

/* Formats the reason after the k bytes already in err (nothing when they filled it). */
static void put_reason(char *err, size_t errlen, int k, const char *fmt, va_list ap)
{
    if (k >= 0 && (size_t)k < errlen)
        vsnprintf(err + k, errlen - (size_t)k, fmt, ap);
}

int sim_plan_fail(const sim_plan_errctx_t *e, sim_plan_loc_t at, const sim_plan_elem_t *el, const char *fmt, ...)
{
    if (e->err != NULL && e->errlen > 0) {
        int k = snprintf(e->err, e->errlen, "%s:%d:%d: ", e->name, at.line, at.col);
        if (k >= 0 && (size_t)k < e->errlen && el != NULL && el->id != NULL) {
            int j = snprintf(e->err + k, e->errlen - (size_t)k, "%.*s id=\"%.*s\": ", (int)el->name_len, el->name,
                             (int)(el->id_len < ID_SHOWN ? el->id_len : ID_SHOWN), el->id);
            k = j < 0 ? -1 : k + j;
        }
        va_list ap;
        va_start(ap, fmt);
        put_reason(e->err, e->errlen, k, fmt, ap);
        va_end(ap);
    }
    return -EINVAL;
}

void sim_plan_copy_id(char id[SIM_PLAN_ID_MAX], const sim_plan_elem_t *el)
{
    size_t n = el->id == NULL ? 0 : el->id_len < ID_SHOWN ? el->id_len : ID_SHOWN;
    if (n > 0)
        memcpy(id, el->id, n);
    id[n] = '\0';
}

/* A fault that is not at a place in the text (the file, the arguments): "NAME: reason". */
__attribute__((format(printf, 4, 5)))
static int fail_file(char *err, size_t errlen, const char *name, const char *fmt, ...)
{
    if (err != NULL && errlen > 0) {
        va_list ap;
        va_start(ap, fmt);
        put_reason(err, errlen, snprintf(err, errlen, "%s: ", name), fmt, ap);
        va_end(ap);
    }
    return -EINVAL;
}

int sim_plan_grow(void **arr, int *cap, int need, size_t elem)
{
    if (need <= *cap)
        return 0;
    int nc = *cap ? *cap * 2 : 16;
    while (nc < need)
        nc *= 2;
    void *p = realloc(*arr, (size_t)nc * elem);
    if (p == NULL)
        return -ENOMEM;
    *arr = p;
    *cap = nc;
    return 0;
}

/* ---- the plan once read --------------------------------------------------------------------- */

static int finish_plan(sim_plan_reader_t *r)
{
    sim_plan_t *p = r->plan;
    if (p->n_walls == 0)
        return sim_plan_fail(&r->e, r->root_at, NULL,
                             "no walls: the plan has no <g class=\"Wall\"> group with a polygon");
    /* Over railings too: a balcony bounded by railings only lies outside the walls' box. */
    p->min.x = p->min.y = INFINITY;
    p->max.x = p->max.y = -INFINITY;
    for (int w = 0; w < p->n_walls + p->n_railings; w++) {
        const sim_poly_t *o = w < p->n_walls ? &p->walls[w].outline : &p->railings[w - p->n_walls].outline;
        for (int k = 0; k < o->n; k++) {
            p->min.x = fmin(p->min.x, o->p[k].x);
            p->min.y = fmin(p->min.y, o->p[k].y);
            p->max.x = fmax(p->max.x, o->p[k].x);
            p->max.y = fmax(p->max.y, o->p[k].y);
        }
    }
    double wx = p->max.x - p->min.x, wy = p->max.y - p->min.y;
    const sim_plan_loc_t w0 = {p->walls[0].line, p->walls[0].col};
    if (wx > PLAN_MAX_EXTENT_M || wy > PLAN_MAX_EXTENT_M)
        return sim_plan_fail(&r->e, w0, NULL, "absurd plan size %.1f x %.1f m (more than %.0f m; wrong scale?)",
                             wx, wy, PLAN_MAX_EXTENT_M);
    if (wx < PLAN_MIN_EXTENT_M || wy < PLAN_MIN_EXTENT_M)
        return sim_plan_fail(&r->e, w0, NULL, "absurd plan size %.3f x %.3f m (less than %.2f m; wrong scale?)",
                             wx, wy, PLAN_MIN_EXTENT_M);

    return sim_plan_build_solids(p);
}

/* ---- API ------------------------------------------------------------------------------- */

void sim_plan_free(sim_plan_t *plan)
{
    if (plan == NULL)
        return;
    free(plan->walls);
    free(plan->openings);
    free(plan->rooms);
    free(plan->railings);
    free(plan->solids);
    memset(plan, 0, sizeof *plan);
}

int sim_plan_warnings(const sim_plan_t *plan, const char *name, FILE *out)
{
    if (plan == NULL)
        return 0;
    int n = 0;
    for (int i = 0; i < plan->n_openings; i++) {
        const sim_opening_t *o = &plan->openings[i];
        if (!o->isolated)
            continue;
        n++;
        if (out != NULL)
            fprintf(out, "%s:%d:%d: warning: %s%s%s%s overlaps no wall, it cuts nothing\n", name ? name : "<memory>",
                    o->line, o->col, o->kind == SIM_OPENING_DOOR ? "Door" : "Window", o->id[0] ? " id=\"" : "",
                    o->id, o->id[0] ? "\"" : "");
    }
    return n;
}

int sim_plan_parse(const char *text, const char *name, double scale, sim_plan_t *plan, char *err,
                   size_t errlen)
{
    if (err != NULL && errlen > 0)
        err[0] = '\0';
    if (plan == NULL)
        return -EINVAL;
    memset(plan, 0, sizeof *plan);
    if (name == NULL)
        name = "<memory>";
    if (text == NULL)
        return fail_file(err, errlen, name, "no text");
    if (!(scale > 0.0))
        scale = SIM_PLAN_DEFAULT_SCALE;
    if (!isfinite(scale) || scale > PLAN_MAX_SCALE)
        return fail_file(err, errlen, name, "absurd scale %g metres per pixel", scale);
    sim_plan_reader_t *r = calloc(1, sizeof *r);
    if (r == NULL)
        return -ENOMEM;
    r->s = text;
    r->n = strlen(text);
    r->line = 1;
    r->e = (sim_plan_errctx_t){name, err, errlen};
    r->scale = scale;
    r->plan = plan;
    plan->scale = scale;
    int rc = sim_plan_read_document(r);
    if (rc == 0)
        rc = finish_plan(r);
    free(r);
    if (rc != 0) {
        if (rc == -ENOMEM)
            (void)fail_file(err, errlen, name, "out of memory");
        sim_plan_free(plan);
    }
    return rc;
}

/* Reads the whole file into *text (NUL-terminated): 0, or a negative code and err. */
static int read_file(const char *path, char **text, char *err, size_t errlen)
{
    *text = NULL;
    FILE *f = NULL;
    int rc = hal_host_file_open_read(path, &f);
    if (rc < 0) {
        (void)fail_file(err, errlen, path, "cannot open: %s", strerror(-rc));
        return rc;
    }
    size_t cap = 1 << 16, len = 0;
    char *buf = malloc(cap + 1);
    rc = buf ? 0 : -ENOMEM;
    while (rc == 0) {
        if (len == cap) {
            if ((long)cap >= PLAN_MAX_FILE_BYTES) {
                (void)fail_file(err, errlen, path, "absurd file size (more than %ld bytes)", PLAN_MAX_FILE_BYTES);
                rc = -EFBIG;
                break;
            }
            char *nb = realloc(buf, cap * 2 + 1);
            if (nb == NULL) {
                rc = -ENOMEM;
                break;
            }
            buf = nb;
            cap *= 2;
        }
        errno = 0;
        size_t k = fread(buf + len, 1, cap - len, f);
        len += k;
        if (k == 0) {
            if (ferror(f)) {
                (void)fail_file(err, errlen, path, "cannot read: %s", strerror(errno ? errno : EIO));
                rc = -EIO;
            }
            break;
        }
    }
    fclose(f);
    if (rc == -ENOMEM)
        (void)fail_file(err, errlen, path, "out of memory");
    if (rc == 0 && memchr(buf, '\0', len) != NULL) {
        /* Report the place of the NUL. */
        sim_plan_loc_t at = {1, 1};
        for (size_t i = 0; i < len && buf[i] != '\0'; i++) {
            at.col++;
            if (buf[i] == '\n')
                at = (sim_plan_loc_t){at.line + 1, 1};
        }
        sim_plan_errctx_t e = {path, err, errlen};
        rc = sim_plan_fail(&e, at, NULL, "NUL byte in the file: not a text SVG file");
    }
    if (rc != 0) {
        free(buf);
        return rc;
    }
    buf[len] = '\0';
    *text = buf;
    return 0;
}

int sim_plan_load(const char *path, double scale, sim_plan_t *plan, char *err, size_t errlen)
{
    if (err != NULL && errlen > 0)
        err[0] = '\0';
    if (plan == NULL)
        return -EINVAL;
    memset(plan, 0, sizeof *plan);
    if (path == NULL)
        return fail_file(err, errlen, "(null)", "no path");
    char *text;
    int rc = read_file(path, &text, err, errlen);
    if (rc != 0)
        return rc;
    rc = sim_plan_parse(text, path, scale, plan, err, errlen);
    if (rc == 0)
        (void)sim_plan_warnings(plan, path, stderr);
    free(text);
    return rc;
}

void sim_plan_normalise(const sim_plan_t *plan, double x_m, double y_m, float *xn, float *yn)
{
    double wx = plan->max.x - plan->min.x, wy = plan->max.y - plan->min.y;
    double a = wx > 0 ? 2.0 * (x_m - plan->min.x) / wx - 1.0 : 0.0;
    double b = wy > 0 ? 2.0 * (y_m - plan->min.y) / wy - 1.0 : 0.0;
    if (xn != NULL)
        *xn = (float)a;
    if (yn != NULL)
        *yn = (float)b;
}

void sim_plan_denormalise(const sim_plan_t *plan, float xn, float yn, double *x_m, double *y_m)
{
    double wx = plan->max.x - plan->min.x, wy = plan->max.y - plan->min.y;
    if (x_m != NULL)
        *x_m = plan->min.x + ((double)xn + 1.0) * 0.5 * wx;
    if (y_m != NULL)
        *y_m = plan->min.y + ((double)yn + 1.0) * 0.5 * wy;
}
