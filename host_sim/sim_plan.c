/* Floor-plan parser: a small XML tokenizer of our own (line-tracked, no XML library) that
 * reads the CubiCasa5K model.svg structure described in sim_plan.h, then the solid geometry
 * (walls minus door openings).
 *
 * Why our own tokenizer: the files come from outside, every error must name its line, and
 * the subset we need (elements, attributes, comments, declarations) is small. Entities are
 * not decoded: the attributes we read (class, points) never need them.
 *
 * `transform` attributes (matrix, translate, scale, rotate, skewX, skewY) on any element are
 * composed down the tree and applied to polygon points before the metric scale. */
#include "sim_plan.h"
#include "hal_host_file.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Limits on what we accept from a file ("absurd sizes"). */
#define PLAN_MAX_FILE_BYTES (64L * 1024 * 1024)
#define PLAN_MAX_DEPTH 256
#define PLAN_MAX_COORD_M 10000.0 /* |coordinate| in metres */
#define PLAN_MAX_EXTENT_M 2000.0 /* bounding box side in metres */
#define PLAN_MIN_EXTENT_M 0.05
#define PLAN_MAX_SCALE 100.0
#define PLAN_MAX_ITEMS 1000000 /* walls, rooms, openings each */
/* Area below this (m^2) is degenerate; a 1 cm x 1 cm square is 1e-4. */
#define PLAN_MIN_AREA_M2 1e-8
/* Wall pieces shorter than this (metres) along the wall are not kept. */
#define PLAN_MIN_PIECE_M 1e-4
/* An opening this close to a wall (metres) is not isolated: a door drawn across a gap in a
 * wall touches the wall ends, and transforms leave rounding far below a millimetre. */
#define PLAN_TOUCH_M 1e-3
/* A door cuts a wall it is not nested in when their overlap reaches across at least this
 * fraction of the wall's thickness (doors are drawn as thick as their wall, or a little
 * thinner; one grazing a perpendicular wall reaches across a sliver of it). */
#define PLAN_CROSS_FRACTION 0.5

/* ---- small geometry helpers (exported, see sim_plan.h) ------------------------------- */

double sim_poly_signed_area(const sim_poly_t *poly)
{
    double a = 0.0;
    for (int i = 0; i < poly->n; i++) {
        const sim_vec2_t *p = &poly->p[i], *q = &poly->p[(i + 1) % poly->n];
        a += p->x * q->y - q->x * p->y;
    }
    return 0.5 * a;
}

int sim_poly_contains(const sim_poly_t *poly, double x, double y)
{
    /* Even-odd ray crossing; points exactly on an edge may go either way. */
    int in = 0;
    for (int i = 0, j = poly->n - 1; i < poly->n; j = i++) {
        const sim_vec2_t *a = &poly->p[i], *b = &poly->p[j];
        if ((a->y > y) != (b->y > y)) {
            double xc = a->x + (y - a->y) * (b->x - a->x) / (b->y - a->y);
            if (x < xc)
                in = !in;
        }
    }
    return in;
}

int sim_poly_is_rect(const sim_poly_t *poly)
{
    if (poly->n != 4)
        return 0;
    for (int i = 0; i < 4; i++) {
        const sim_vec2_t *a = &poly->p[(i + 3) % 4], *b = &poly->p[i], *c = &poly->p[(i + 1) % 4];
        double ux = a->x - b->x, uy = a->y - b->y, vx = c->x - b->x, vy = c->y - b->y;
        double lu = hypot(ux, uy), lv = hypot(vx, vy);
        if (lu <= 0.0 || lv <= 0.0)
            return 0;
        if (fabs(ux * vx + uy * vy) > 1e-6 * lu * lv)
            return 0;
    }
    return 1;
}

/* ---- errors ---------------------------------------------------------------------------- */

typedef struct {
    const char *name;
    char *err;
    size_t errlen;
} errctx_t;

__attribute__((format(printf, 3, 4)))
static int fail(const errctx_t *e, int line, const char *fmt, ...)
{
    if (e->err != NULL && e->errlen > 0) {
        int k = snprintf(e->err, e->errlen, "%s:%d: ", e->name, line);
        if (k >= 0 && (size_t)k < e->errlen) {
            va_list ap;
            va_start(ap, fmt);
            vsnprintf(e->err + k, e->errlen - (size_t)k, fmt, ap);
            va_end(ap);
        }
    }
    return -EINVAL;
}

static int is_space_c(char c)
{
    return c == ' ' || c == '\t' || c == '\r' || c == '\n';
}

/* ---- growable arrays ------------------------------------------------------------------ */

static int grow(void **arr, int *cap, int need, size_t elem)
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

/* ---- points ---------------------------------------------------------------------------- */

/* Parses a points attribute into metres. `line` is where the value starts; newlines inside
 * the value advance it so a bad number is reported on its own line. */
static int parse_points(const errctx_t *e, const char *v, size_t len, int line, double scale,
                        const double *m, sim_poly_t *out)
{
    double coords[2 * SIM_POLY_MAX_POINTS + 2];
    int nc = 0, count = 0;
    int first_line = line;
    size_t i = 0;
    while (i < len) {
        char c = v[i];
        if (c == '\n') {
            line++;
            i++;
            continue;
        }
        if (c == ' ' || c == '\t' || c == '\r' || c == ',') {
            i++;
            continue;
        }
        /* One number: copy the token (bounded) so strtod cannot run past the value. */
        size_t j = i;
        while (j < len && v[j] != ' ' && v[j] != '\t' && v[j] != '\r' && v[j] != '\n' && v[j] != ',')
            j++;
        char tok[64];
        size_t tl = j - i;
        if (tl >= sizeof tok)
            return fail(e, line, "bad number '%.20s...' in points", v + i);
        memcpy(tok, v + i, tl);
        tok[tl] = '\0';
        char *end = NULL;
        errno = 0;
        double d = strtod(tok, &end);
        if (end == tok || *end != '\0' || errno == ERANGE || !isfinite(d))
            return fail(e, line, "bad number '%s' in points", tok);
        count++;
        if (count > 2 * SIM_POLY_MAX_POINTS)
            return fail(e, first_line, "too many points in polygon (more than %d)", SIM_POLY_MAX_POINTS);
        coords[nc++] = d;
        i = j;
    }
    if (nc % 2 != 0)
        return fail(e, first_line, "odd number of coordinates (%d) in points", nc);
    /* Scale, drop consecutive repeats and a closing repeat of the first point. */
    out->n = 0;
    for (int k = 0; k < nc; k += 2) {
        double px = m[0] * coords[k] + m[2] * coords[k + 1] + m[4];
        double py = m[1] * coords[k] + m[3] * coords[k + 1] + m[5];
        double x = px * scale, y = py * scale;
        if (fabs(x) > PLAN_MAX_COORD_M || fabs(y) > PLAN_MAX_COORD_M)
            return fail(e, first_line, "coordinate (%g, %g) is %g m from the origin, absurd for a floor plan",
                        coords[k], coords[k + 1], fmax(fabs(x), fabs(y)));
        if (out->n > 0 && out->p[out->n - 1].x == x && out->p[out->n - 1].y == y)
            continue;
        out->p[out->n].x = x;
        out->p[out->n].y = y;
        out->n++;
    }
    while (out->n > 1 && out->p[0].x == out->p[out->n - 1].x && out->p[0].y == out->p[out->n - 1].y)
        out->n--;
    if (out->n < 3)
        return fail(e, first_line, "degenerate polygon: %d distinct point%s, at least 3 needed", out->n,
                    out->n == 1 ? "" : "s");
    if (fabs(sim_poly_signed_area(out)) < PLAN_MIN_AREA_M2)
        return fail(e, first_line, "degenerate polygon: zero area");
    return 0;
}

/* ---- transforms ------------------------------------------------------------------------- */

/* Affine matrices in SVG order (a b c d e f): x' = a x + c y + e, y' = b x + d y + f. */
static const double IDENTITY[6] = {1, 0, 0, 1, 0, 0};

/* r = p * o (apply o first). r may alias neither. */
static void mat_mul(const double *p, const double *o, double *r)
{
    r[0] = p[0] * o[0] + p[2] * o[1];
    r[1] = p[1] * o[0] + p[3] * o[1];
    r[2] = p[0] * o[2] + p[2] * o[3];
    r[3] = p[1] * o[2] + p[3] * o[3];
    r[4] = p[0] * o[4] + p[2] * o[5] + p[4];
    r[5] = p[1] * o[4] + p[3] * o[5] + p[5];
}

/* Parses an SVG transform list (matrix, translate, scale, rotate, skewX, skewY) into m. */
static int parse_transform(const errctx_t *e, const char *v, size_t len, int line, double *m)
{
    memcpy(m, IDENTITY, sizeof IDENTITY);
    size_t i = 0;
    for (;;) {
        while (i < len && (is_space_c(v[i]) || v[i] == ','))
            i++;
        if (i >= len)
            break;
        size_t ns = i;
        while (i < len && ((v[i] >= 'a' && v[i] <= 'z') || (v[i] >= 'A' && v[i] <= 'Z')))
            i++;
        size_t nl = i - ns;
        while (i < len && is_space_c(v[i]))
            i++;
        if (nl == 0 || i >= len || v[i] != '(')
            return fail(e, line, "bad transform '%.*s'", (int)(len > 60 ? 60 : len), v);
        i++;
        double a[6];
        int na = 0;
        for (;;) {
            while (i < len && (is_space_c(v[i]) || v[i] == ','))
                i++;
            if (i < len && v[i] == ')') {
                i++;
                break;
            }
            char tok[64];
            size_t j = i;
            while (j < len && !is_space_c(v[j]) && v[j] != ',' && v[j] != ')')
                j++;
            if (j == i || j - i >= sizeof tok || na == 6)
                return fail(e, line, "bad transform '%.*s'", (int)(len > 60 ? 60 : len), v);
            memcpy(tok, v + i, j - i);
            tok[j - i] = '\0';
            char *end = NULL;
            double d = strtod(tok, &end);
            if (end == tok || *end != '\0' || !isfinite(d))
                return fail(e, line, "bad number '%s' in transform", tok);
            a[na++] = d;
            i = j;
            if (i >= len)
                return fail(e, line, "unclosed '(' in transform");
        }
        double t[6];
        const char *n = v + ns;
#define IS(w) (nl == strlen(w) && memcmp(n, w, nl) == 0)
        if (IS("matrix") && na == 6) {
            memcpy(t, a, sizeof t);
        } else if (IS("translate") && (na == 1 || na == 2)) {
            double tt[6] = {1, 0, 0, 1, a[0], na == 2 ? a[1] : 0};
            memcpy(t, tt, sizeof t);
        } else if (IS("scale") && (na == 1 || na == 2)) {
            double tt[6] = {a[0], 0, 0, na == 2 ? a[1] : a[0], 0, 0};
            memcpy(t, tt, sizeof t);
        } else if (IS("rotate") && (na == 1 || na == 3)) {
            double rad = a[0] * 3.14159265358979323846 / 180.0, c = cos(rad), sn = sin(rad);
            double cx = na == 3 ? a[1] : 0, cy = na == 3 ? a[2] : 0;
            /* translate(cx, cy) rotate(a) translate(-cx, -cy) */
            double tt[6] = {c, sn, -sn, c, cx - c * cx + sn * cy, cy - sn * cx - c * cy};
            memcpy(t, tt, sizeof t);
        } else if ((IS("skewX") || IS("skewY")) && na == 1) {
            double k = tan(a[0] * 3.14159265358979323846 / 180.0);
            double tt[6] = {1, IS("skewY") ? k : 0, IS("skewX") ? k : 0, 1, 0, 0};
            memcpy(t, tt, sizeof t);
        } else {
            return fail(e, line, "bad transform '%.*s' (unknown function or wrong argument count)", (int)nl, n);
        }
#undef IS
        double r[6];
        mat_mul(m, t, r);
        memcpy(m, r, sizeof r);
    }
    double det = m[0] * m[3] - m[1] * m[2];
    for (int k = 0; k < 6; k++)
        if (!isfinite(m[k]))
            return fail(e, line, "transform out of range");
    if (fabs(det) < 1e-12)
        return fail(e, line, "degenerate transform (zero determinant)");
    return 0;
}

/* ---- the tokenizer and the structure reader --------------------------------------------- */

typedef enum { FR_OTHER = 0, FR_WALL, FR_DOOR, FR_WINDOW, FR_SPACE } frame_kind_t;

typedef struct {
    const char *name; /* element name in the text (not terminated) */
    size_t name_len;
    int line;
    frame_kind_t kind;
    int index;   /* index into walls/openings/rooms for semantic frames */
    int has_poly;
    double m[6]; /* transform from this element's coordinates to the document's */
} frame_t;

typedef struct {
    const char *s;
    size_t n, pos;
    int line;
    errctx_t e;
    double scale;
    sim_plan_t *plan;
    int cap_walls, cap_open, cap_rooms;
    frame_t stack[PLAN_MAX_DEPTH];
    int depth;
    int root_seen, root_closed;
    int root_line;
} reader_t;

static int is_name_char(char c)
{
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
           c == '-' || c == '.' || c == ':';
}

static int is_space(char c)
{
    return c == ' ' || c == '\t' || c == '\r' || c == '\n';
}

static void skip_space(reader_t *r)
{
    while (r->pos < r->n && is_space(r->s[r->pos])) {
        if (r->s[r->pos] == '\n')
            r->line++;
        r->pos++;
    }
}

/* Advances past `term`, counting lines; -1 if the text ends first. */
static int skip_past(reader_t *r, const char *term)
{
    size_t tl = strlen(term);
    while (r->pos + tl <= r->n) {
        if (memcmp(r->s + r->pos, term, tl) == 0) {
            r->pos += tl;
            return 0;
        }
        if (r->s[r->pos] == '\n')
            r->line++;
        r->pos++;
    }
    while (r->pos < r->n) {
        if (r->s[r->pos] == '\n')
            r->line++;
        r->pos++;
    }
    return -1;
}

/* Local name (after any namespace prefix) equals `want`. */
static int name_is(const char *name, size_t len, const char *want)
{
    const char *colon = memchr(name, ':', len);
    if (colon != NULL) {
        len -= (size_t)(colon + 1 - name);
        name = colon + 1;
    }
    return strlen(want) == len && memcmp(name, want, len) == 0;
}

typedef struct {
    const char *v;
    size_t len;
    int line;
    int present;
} attr_t;

/* First whitespace-separated token of a class attribute into buf; returns its length.
 * `rest` gets the second token (may be empty). */
static void class_tokens(const attr_t *cls, char *first, size_t flen, char *second, size_t slen)
{
    first[0] = second[0] = '\0';
    if (!cls->present)
        return;
    size_t i = 0;
    char *dst[2] = {first, second};
    size_t cap[2] = {flen, slen};
    for (int t = 0; t < 2; t++) {
        while (i < cls->len && is_space(cls->v[i]))
            i++;
        size_t j = i;
        while (j < cls->len && !is_space(cls->v[j]))
            j++;
        size_t l = j - i;
        if (l >= cap[t])
            l = cap[t] - 1;
        memcpy(dst[t], cls->v + i, l);
        dst[t][l] = '\0';
        i = j;
    }
}

static int innermost_semantic(const reader_t *r)
{
    for (int d = r->depth - 1; d >= 0; d--)
        if (r->stack[d].kind != FR_OTHER)
            return d;
    return -1;
}

static int innermost_wall(const reader_t *r)
{
    for (int d = r->depth - 1; d >= 0; d--)
        if (r->stack[d].kind == FR_WALL)
            return d;
    return -1;
}

/* A <g> opened: decide what it is from its class and allocate its record. */
static int open_group(reader_t *r, frame_t *f, const attr_t *cls)
{
    char first[32], second[SIM_ROOM_TYPE_MAX];
    class_tokens(cls, first, sizeof first, second, sizeof second);
    sim_plan_t *p = r->plan;
    int rc;
    if (strcmp(first, "Wall") == 0) {
        if (p->n_walls >= PLAN_MAX_ITEMS)
            return fail(&r->e, f->line, "too many walls (more than %d)", PLAN_MAX_ITEMS);
        if ((rc = grow((void **)&p->walls, &r->cap_walls, p->n_walls + 1, sizeof *p->walls)) != 0)
            return rc;
        memset(&p->walls[p->n_walls], 0, sizeof p->walls[0]);
        p->walls[p->n_walls].line = f->line;
        f->kind = FR_WALL;
        f->index = p->n_walls++;
    } else if (strcmp(first, "Door") == 0 || strcmp(first, "Window") == 0) {
        /* Anywhere in the tree, as CubiCasa5K's loader reads them: nested in the wall it
         * opens, or a sibling drawn across or over walls (finish_plan finds which). */
        int w = innermost_wall(r);
        if (p->n_openings >= PLAN_MAX_ITEMS)
            return fail(&r->e, f->line, "too many openings (more than %d)", PLAN_MAX_ITEMS);
        if ((rc = grow((void **)&p->openings, &r->cap_open, p->n_openings + 1, sizeof *p->openings)) != 0)
            return rc;
        sim_opening_t *o = &p->openings[p->n_openings];
        memset(o, 0, sizeof *o);
        o->kind = first[0] == 'D' ? SIM_OPENING_DOOR : SIM_OPENING_WINDOW;
        o->wall = w >= 0 ? r->stack[w].index : -1;
        o->line = f->line;
        f->kind = first[0] == 'D' ? FR_DOOR : FR_WINDOW;
        f->index = p->n_openings++;
    } else if (strcmp(first, "Space") == 0) {
        if (p->n_rooms >= PLAN_MAX_ITEMS)
            return fail(&r->e, f->line, "too many rooms (more than %d)", PLAN_MAX_ITEMS);
        if ((rc = grow((void **)&p->rooms, &r->cap_rooms, p->n_rooms + 1, sizeof *p->rooms)) != 0)
            return rc;
        sim_room_t *rm = &p->rooms[p->n_rooms];
        memset(rm, 0, sizeof *rm);
        snprintf(rm->type, sizeof rm->type, "%s", second[0] ? second : "Undefined");
        rm->line = f->line;
        f->kind = FR_SPACE;
        f->index = p->n_rooms++;
    }
    return 0;
}

/* A <polygon> seen: it is the outline of the innermost semantic group, if that has none yet. */
static int take_polygon(reader_t *r, int tag_line, const attr_t *points, const double *m)
{
    int d = innermost_semantic(r);
    if (d < 0 || r->stack[d].has_poly)
        return 0;
    frame_t *f = &r->stack[d];
    if (!points->present)
        return fail(&r->e, tag_line, "polygon without a points attribute");
    sim_poly_t *dst;
    int *line;
    switch (f->kind) {
    case FR_WALL:
        dst = &r->plan->walls[f->index].outline;
        line = &r->plan->walls[f->index].line;
        break;
    case FR_SPACE:
        dst = &r->plan->rooms[f->index].outline;
        line = &r->plan->rooms[f->index].line;
        break;
    default:
        dst = &r->plan->openings[f->index].outline;
        line = &r->plan->openings[f->index].line;
        break;
    }
    int rc = parse_points(&r->e, points->v, points->len, points->line, r->scale, m, dst);
    if (rc != 0)
        return rc;
    *line = tag_line;
    f->has_poly = 1;
    return 0;
}

static const char *kind_name(frame_kind_t k)
{
    switch (k) {
    case FR_WALL: return "Wall";
    case FR_DOOR: return "Door";
    case FR_WINDOW: return "Window";
    case FR_SPACE: return "Space";
    default: return "group";
    }
}

static int close_frame(reader_t *r)
{
    frame_t *f = &r->stack[r->depth - 1];
    if (f->kind != FR_OTHER && !f->has_poly)
        return fail(&r->e, f->line, "%s group has no polygon", kind_name(f->kind));
    r->depth--;
    if (r->depth == 0)
        r->root_closed = 1;
    return 0;
}

/* Reads one start tag after '<' (r->pos at the name). */
static int read_start_tag(reader_t *r, int tag_line)
{
    size_t ns = r->pos;
    while (r->pos < r->n && is_name_char(r->s[r->pos]))
        r->pos++;
    size_t nl = r->pos - ns;
    const char *name = r->s + ns;
    if (nl == 0)
        return fail(&r->e, tag_line, "malformed tag: '<' not followed by an element name");
    attr_t cls = {0}, pts = {0}, tfm = {0};
    int self_close = 0;
    for (;;) {
        skip_space(r);
        if (r->pos >= r->n)
            return fail(&r->e, tag_line, "unclosed tag <%.*s>: the file ends inside it", (int)nl, name);
        char c = r->s[r->pos];
        if (c == '>') {
            r->pos++;
            break;
        }
        if (c == '/') {
            if (r->pos + 1 < r->n && r->s[r->pos + 1] == '>') {
                r->pos += 2;
                self_close = 1;
                break;
            }
            return fail(&r->e, r->line, "malformed tag <%.*s>: '/' not followed by '>'", (int)nl, name);
        }
        if (!is_name_char(c))
            return fail(&r->e, r->line, "malformed tag <%.*s>: unexpected character '%c'", (int)nl, name, c);
        size_t as = r->pos;
        while (r->pos < r->n && is_name_char(r->s[r->pos]))
            r->pos++;
        size_t al = r->pos - as;
        int aline = r->line;
        skip_space(r);
        if (r->pos >= r->n || r->s[r->pos] != '=')
            return fail(&r->e, aline, "attribute '%.*s' of <%.*s> has no value", (int)al, r->s + as,
                        (int)nl, name);
        r->pos++;
        skip_space(r);
        if (r->pos >= r->n)
            return fail(&r->e, tag_line, "unclosed tag <%.*s>: the file ends inside it", (int)nl, name);
        char q = r->s[r->pos];
        if (q != '"' && q != '\'')
            return fail(&r->e, r->line, "value of attribute '%.*s' is not quoted", (int)al, r->s + as);
        int qline = r->line;
        r->pos++;
        size_t vs = r->pos;
        while (r->pos < r->n && r->s[r->pos] != q) {
            if (r->s[r->pos] == '\n')
                r->line++;
            r->pos++;
        }
        if (r->pos >= r->n)
            return fail(&r->e, qline, "unclosed quote: value of attribute '%.*s' never ends", (int)al,
                        r->s + as);
        attr_t a = {r->s + vs, r->pos - vs, qline, 1};
        r->pos++;
        if (al == 5 && memcmp(r->s + as, "class", 5) == 0 && !cls.present)
            cls = a;
        else if (al == 6 && memcmp(r->s + as, "points", 6) == 0 && !pts.present)
            pts = a;
        else if (al == 9 && memcmp(r->s + as, "transform", 9) == 0 && !tfm.present)
            tfm = a;
    }

    /* The root must be <svg>; nothing may follow it. */
    if (!r->root_seen) {
        if (!name_is(name, nl, "svg"))
            return fail(&r->e, tag_line, "not an SVG file: the root element is <%.*s>, not <svg>", (int)nl, name);
        r->root_seen = 1;
        r->root_line = tag_line;
    } else if (r->root_closed) {
        return fail(&r->e, tag_line, "element <%.*s> after the end of the <svg> root", (int)nl, name);
    }

    /* This element's transform: its parent's composed with its own attribute. */
    double m[6];
    const double *parent = r->depth > 0 ? r->stack[r->depth - 1].m : IDENTITY;
    if (tfm.present) {
        double own[6];
        int rc = parse_transform(&r->e, tfm.v, tfm.len, tfm.line, own);
        if (rc != 0)
            return rc;
        mat_mul(parent, own, m);
    } else {
        memcpy(m, parent, sizeof m);
    }
    if (name_is(name, nl, "polygon")) {
        int rc = take_polygon(r, tag_line, &pts, m);
        if (rc != 0)
            return rc;
    }
    if (r->depth >= PLAN_MAX_DEPTH)
        return fail(&r->e, tag_line, "elements nested deeper than %d", PLAN_MAX_DEPTH);
    frame_t *f = &r->stack[r->depth++];
    memset(f, 0, sizeof *f);
    f->name = name;
    f->name_len = nl;
    f->line = tag_line;
    memcpy(f->m, m, sizeof m);
    if (name_is(name, nl, "g")) {
        int rc = open_group(r, f, &cls);
        if (rc != 0)
            return rc;
    }
    if (self_close)
        return close_frame(r);
    return 0;
}

static int read_end_tag(reader_t *r, int tag_line)
{
    size_t ns = r->pos;
    while (r->pos < r->n && is_name_char(r->s[r->pos]))
        r->pos++;
    size_t nl = r->pos - ns;
    const char *name = r->s + ns;
    skip_space(r);
    if (r->pos >= r->n)
        return fail(&r->e, tag_line, "unclosed tag </%.*s>: the file ends inside it", (int)nl, name);
    if (nl == 0 || r->s[r->pos] != '>')
        return fail(&r->e, tag_line, "malformed end tag </%.*s", (int)nl, name);
    r->pos++;
    if (r->depth == 0)
        return fail(&r->e, tag_line, "end tag </%.*s> without a matching start tag", (int)nl, name);
    frame_t *f = &r->stack[r->depth - 1];
    if (f->name_len != nl || memcmp(f->name, name, nl) != 0) {
        /* A stray end tag is reported where it is; one that closes an outer element means
         * the innermost open element lacks its end tag. */
        int open_somewhere = 0;
        for (int d = 0; d < r->depth - 1; d++)
            if (r->stack[d].name_len == nl && memcmp(r->stack[d].name, name, nl) == 0)
                open_somewhere = 1;
        if (!open_somewhere)
            return fail(&r->e, tag_line, "end tag </%.*s> matches no open element (innermost open: <%.*s> of line %d)",
                        (int)nl, name, (int)f->name_len, f->name, f->line);
        return fail(&r->e, f->line, "<%.*s> is never closed (found </%.*s> at line %d)", (int)f->name_len,
                    f->name, (int)nl, name, tag_line);
    }
    return close_frame(r);
}

static int read_document(reader_t *r)
{
    while (r->pos < r->n) {
        char c = r->s[r->pos];
        if (c == '\n') {
            r->line++;
            r->pos++;
            continue;
        }
        if (c != '<') {
            if (c == '\0')
                return fail(&r->e, r->line, "NUL byte in the file: not a text SVG file");
            r->pos++; /* character data: ignored */
            continue;
        }
        int tag_line = r->line;
        const char *t = r->s + r->pos;
        size_t left = r->n - r->pos;
        if (left >= 4 && memcmp(t, "<!--", 4) == 0) {
            r->pos += 4;
            if (skip_past(r, "-->") != 0)
                return fail(&r->e, tag_line, "unclosed comment: '<!--' without '-->'");
        } else if (left >= 9 && memcmp(t, "<![CDATA[", 9) == 0) {
            r->pos += 9;
            if (skip_past(r, "]]>") != 0)
                return fail(&r->e, tag_line, "unclosed CDATA section");
        } else if (left >= 2 && memcmp(t, "<?", 2) == 0) {
            r->pos += 2;
            if (skip_past(r, "?>") != 0)
                return fail(&r->e, tag_line, "unclosed processing instruction: '<?' without '?>'");
        } else if (left >= 2 && memcmp(t, "<!", 2) == 0) {
            /* <!DOCTYPE ...> possibly with an internal subset [ ... ]. */
            r->pos += 2;
            int bracket = 0, done = 0;
            while (r->pos < r->n && !done) {
                char d = r->s[r->pos++];
                if (d == '\n')
                    r->line++;
                else if (d == '[')
                    bracket++;
                else if (d == ']' && bracket > 0)
                    bracket--;
                else if (d == '>' && bracket == 0)
                    done = 1;
            }
            if (!done)
                return fail(&r->e, tag_line, "unclosed declaration '<!'");
        } else if (left >= 2 && t[1] == '/') {
            r->pos += 2;
            int rc = read_end_tag(r, tag_line);
            if (rc != 0)
                return rc;
        } else {
            r->pos += 1;
            int rc = read_start_tag(r, tag_line);
            if (rc != 0)
                return rc;
        }
    }
    if (!r->root_seen)
        return fail(&r->e, r->line, "not an SVG file: no <svg> root element");
    if (r->depth > 0) {
        /* Report the innermost unclosed element: that is where a closing tag is missing. */
        frame_t *f = &r->stack[r->depth - 1];
        return fail(&r->e, f->line, "<%.*s> is never closed (the file ends at line %d)", (int)f->name_len,
                    f->name, r->line);
    }
    return 0;
}

/* ---- solids ------------------------------------------------------------------------------ */

static int push_solid(sim_plan_t *p, int *cap, const sim_poly_t *poly, int is_rect)
{
    int rc = grow((void **)&p->solids, cap, p->n_solids + 1, sizeof *p->solids);
    if (rc != 0)
        return rc;
    sim_solid_t *s = &p->solids[p->n_solids++];
    memset(s, 0, sizeof *s);
    s->outline = *poly;
    s->is_rect = is_rect;
    return 0;
}

typedef struct {
    double a, b;
} interval_t;

static int cmp_interval(const void *x, const void *y)
{
    const interval_t *p = x, *q = y;
    return (p->a > q->a) - (p->a < q->a);
}

/* Convex (all turns the same way; collinear points allowed). */
static int poly_is_convex(const sim_poly_t *o)
{
    int sign = 0;
    for (int i = 0; i < o->n; i++) {
        const sim_vec2_t *a = &o->p[i], *b = &o->p[(i + 1) % o->n], *c = &o->p[(i + 2) % o->n];
        double cr = (b->x - a->x) * (c->y - b->y) - (b->y - a->y) * (c->x - b->x);
        int sg = (cr > 1e-12) - (cr < -1e-12);
        if (sg != 0) {
            if (sign != 0 && sg != sign)
                return 0;
            sign = sg;
        }
    }
    return 1;
}

#define CLIP_MAX (SIM_POLY_MAX_POINTS + 4)
/* Room for a door clipped by every edge of a wall: a non-convex door gains a point per
 * crossing, so the slack is generous; running out only means "does not cross". */
#define XCLIP_MAX (4 * SIM_POLY_MAX_POINTS)

/* Sutherland-Hodgman against one half-plane: keeps points with s * (t(p) - lim) <= 0, where
 * t(p) = (p - c0) . u. Returns the output count (at most cap; points beyond are dropped). */
static int clip_half(const sim_vec2_t *in, int n, sim_vec2_t c0, double ux, double uy, double lim, double sgn,
                     sim_vec2_t *out, int cap)
{
    int m = 0;
    for (int i = 0; i < n; i++) {
        sim_vec2_t a = in[i], b = in[(i + 1) % n];
        double da = sgn * ((a.x - c0.x) * ux + (a.y - c0.y) * uy - lim);
        double db = sgn * ((b.x - c0.x) * ux + (b.y - c0.y) * uy - lim);
        if (da <= 0 && m < cap)
            out[m++] = a;
        if (((da < 0 && db > 0) || (da > 0 && db < 0)) && m < cap) {
            double t = da / (da - db);
            out[m].x = a.x + t * (b.x - a.x);
            out[m].y = a.y + t * (b.y - a.y);
            m++;
        }
    }
    return m;
}

/* The part of convex `in` with lo <= t <= hi: 1 when it is a proper polygon, 0 when empty
 * or degenerate, -1 when it has more than SIM_POLY_MAX_POINTS points. */
static int clip_slab(const sim_poly_t *in, sim_vec2_t c0, double ux, double uy, double lo, double hi, sim_poly_t *out)
{
    sim_vec2_t t1[CLIP_MAX], t2[CLIP_MAX];
    int n = clip_half(in->p, in->n, c0, ux, uy, lo, -1.0, t1, CLIP_MAX);
    n = clip_half(t1, n, c0, ux, uy, hi, 1.0, t2, CLIP_MAX);
    int m = 0;
    for (int i = 0; i < n; i++) {
        if (m > 0 && fabs(t2[i].x - out->p[m - 1].x) < 1e-12 && fabs(t2[i].y - out->p[m - 1].y) < 1e-12)
            continue;
        if (m >= SIM_POLY_MAX_POINTS)
            return -1;
        out->p[m++] = t2[i];
    }
    while (m > 1 && fabs(out->p[0].x - out->p[m - 1].x) < 1e-12 && fabs(out->p[0].y - out->p[m - 1].y) < 1e-12)
        m--;
    out->n = m;
    return m >= 3 && fabs(sim_poly_signed_area(out)) >= PLAN_MIN_AREA_M2;
}

/* A convex wall's frame for door cutting: origin c0 (its first point), unit long axis u (the
 * direction of its longest edge), its extent [tmin, tmax] along u and [nmin, nmax] across. */
typedef struct {
    sim_vec2_t c0;
    double ux, uy;
    double tmin, tmax, nmin, nmax;
} wall_axis_t;

static void wall_axis(const sim_poly_t *o, wall_axis_t *ax)
{
    ax->c0 = o->p[0];
    ax->ux = ax->uy = 0;
    double best = -1;
    for (int k = 0; k < o->n; k++) {
        double ex = o->p[(k + 1) % o->n].x - o->p[k].x, ey = o->p[(k + 1) % o->n].y - o->p[k].y;
        double l = hypot(ex, ey);
        if (l > best) {
            best = l;
            ax->ux = ex / l;
            ax->uy = ey / l;
        }
    }
    ax->tmin = ax->nmin = INFINITY;
    ax->tmax = ax->nmax = -INFINITY;
    for (int k = 0; k < o->n; k++) {
        double dx = o->p[k].x - ax->c0.x, dy = o->p[k].y - ax->c0.y;
        double t = dx * ax->ux + dy * ax->uy, s = dy * ax->ux - dx * ax->uy;
        ax->tmin = fmin(ax->tmin, t);
        ax->tmax = fmax(ax->tmax, t);
        ax->nmin = fmin(ax->nmin, s);
        ax->nmax = fmax(ax->nmax, s);
    }
}

/* The interval a door removes from a wall: its projection on the long axis, clamped to the
 * wall. 0 when that is empty (the door is beside the wall, not along it). */
static int door_interval(const wall_axis_t *ax, const sim_poly_t *dp, interval_t *cut)
{
    double lo = INFINITY, hi = -INFINITY;
    for (int k = 0; k < dp->n; k++) {
        double t = (dp->p[k].x - ax->c0.x) * ax->ux + (dp->p[k].y - ax->c0.y) * ax->uy;
        lo = fmin(lo, t);
        hi = fmax(hi, t);
    }
    lo = fmax(lo, ax->tmin);
    hi = fmin(hi, ax->tmax);
    if (hi <= lo)
        return 0;
    cut->a = lo;
    cut->b = hi;
    return 1;
}

/* The doors that cut each wall, as linked lists over the door indices: `first`/`next` for
 * the doors nested in the wall's group, `xfirst` over (xdoor, xnext) pairs for the other
 * doors that cross it (a door may cross several walls, hence pairs). */
typedef struct {
    int *first, *next;
    int *xfirst, *xdoor, *xnext;
    int n_pairs, cap_xdoor, cap_xnext;
} door_links_t;

/* Walls minus door openings. A convex wall (rectangles, and the trapezoids CubiCasa5K draws
 * at mitred corners) is cut along its long axis, the direction of its longest edge: each door
 * removes the interval of its projection onto that axis, across the full wall thickness, and
 * the wall is clipped to the slabs that remain. Non-convex walls are kept whole even when they
 * hold a door (limitation: an L-shaped wall polygon with a door stays closed). */
static int build_solids(sim_plan_t *p, const door_links_t *dl, const unsigned char *convex, const wall_axis_t *axes)
{
    int cap = 0;
    interval_t *cuts = NULL;
    int cap_cuts = 0;
    int rc = 0;
    for (int w = 0; w < p->n_walls && rc == 0; w++) {
        const sim_poly_t *o = &p->walls[w].outline;
        if ((dl->first[w] < 0 && dl->xfirst[w] < 0) || !convex[w]) {
            rc = push_solid(p, &cap, o, sim_poly_is_rect(o));
            continue;
        }
        const wall_axis_t *ax = &axes[w];
        int nc = 0;
        /* Nested doors first, then the crossing ones: the order does not matter (the cuts are
         * sorted and merged), the nested ones alone give exactly the cuts of old. */
        for (int d = dl->first[w], x = dl->xfirst[w]; rc == 0 && (d >= 0 || x >= 0);) {
            int door;
            if (d >= 0) {
                door = d;
                d = dl->next[d];
            } else {
                door = dl->xdoor[x];
                x = dl->xnext[x];
            }
            interval_t cut;
            if (!door_interval(ax, &p->openings[door].outline, &cut))
                continue; /* the door does not overlap this wall along its axis */
            if ((rc = grow((void **)&cuts, &cap_cuts, nc + 1, sizeof *cuts)) != 0)
                break;
            cuts[nc++] = cut;
        }
        if (rc != 0)
            break;
        if (nc > 1) /* cuts is still NULL when no door overlaps the wall: qsort wants an array */
            qsort(cuts, (size_t)nc, sizeof *cuts, cmp_interval);
        /* Clip every piece first: if one is too big for a polygon, keep the wall whole. */
        int first_piece = p->n_solids, overflow = 0;
        double t = ax->tmin;
        for (int k = 0; k <= nc && rc == 0 && !overflow; k++) {
            double end = k < nc ? cuts[k].a : ax->tmax;
            sim_poly_t piece;
            int got = end - t > PLAN_MIN_PIECE_M ? clip_slab(o, ax->c0, ax->ux, ax->uy, t, end, &piece) : 0;
            if (got < 0)
                overflow = 1;
            else if (got > 0)
                rc = push_solid(p, &cap, &piece, sim_poly_is_rect(&piece));
            if (k < nc)
                t = fmax(t, cuts[k].b);
        }
        if (rc == 0 && overflow) {
            p->n_solids = first_piece;
            rc = push_solid(p, &cap, o, sim_poly_is_rect(o));
        }
    }
    free(cuts);
    return rc;
}

/* ---- openings against walls ------------------------------------------------------------- */

typedef struct {
    double x0, y0, x1, y1;
} box_t;

static box_t poly_box(const sim_poly_t *o)
{
    box_t b = {INFINITY, INFINITY, -INFINITY, -INFINITY};
    for (int k = 0; k < o->n; k++) {
        b.x0 = fmin(b.x0, o->p[k].x);
        b.y0 = fmin(b.y0, o->p[k].y);
        b.x1 = fmax(b.x1, o->p[k].x);
        b.y1 = fmax(b.y1, o->p[k].y);
    }
    return b;
}

/* 1 when door dp crosses convex wall o: their overlap has positive area and reaches across
 * at least PLAN_CROSS_FRACTION of the wall's thickness. The thickness test is what keeps a
 * door in one wall from punching a hole in a perpendicular wall whose face it grazes. */
static int door_crosses(const sim_poly_t *o, const wall_axis_t *ax, const sim_poly_t *dp)
{
    sim_vec2_t a[XCLIP_MAX], b[XCLIP_MAX];
    int n = dp->n;
    memcpy(a, dp->p, (size_t)n * sizeof *a);
    /* Outward normal of each edge: the interior is on the left of an edge of a polygon with
     * positive signed area, on the right otherwise. */
    double side = sim_poly_signed_area(o) > 0 ? 1.0 : -1.0;
    for (int k = 0; k < o->n && n > 0; k++) {
        sim_vec2_t e0 = o->p[k], e1 = o->p[(k + 1) % o->n];
        double ex = e1.x - e0.x, ey = e1.y - e0.y, l = hypot(ex, ey);
        if (!(l > 0))
            continue;
        n = clip_half(a, n, e0, side * ey / l, -side * ex / l, 0.0, 1.0, b, XCLIP_MAX);
        if (n >= XCLIP_MAX)
            return 0; /* ran out of room: treated as not crossing, the wall stays closed */
        memcpy(a, b, (size_t)n * sizeof *a);
    }
    if (n < 3)
        return 0;
    double area = 0.0, smin = INFINITY, smax = -INFINITY;
    for (int i = 0; i < n; i++) {
        const sim_vec2_t *p = &a[i], *q = &a[(i + 1) % n];
        area += p->x * q->y - q->x * p->y;
        double s = (p->y - ax->c0.y) * ax->ux - (p->x - ax->c0.x) * ax->uy;
        smin = fmin(smin, s);
        smax = fmax(smax, s);
    }
    return fabs(0.5 * area) >= PLAN_MIN_AREA_M2 && smax - smin >= PLAN_CROSS_FRACTION * (ax->nmax - ax->nmin);
}

static double seg_point_dist(sim_vec2_t a, sim_vec2_t b, sim_vec2_t p)
{
    double ex = b.x - a.x, ey = b.y - a.y, l2 = ex * ex + ey * ey;
    double t = l2 > 0 ? ((p.x - a.x) * ex + (p.y - a.y) * ey) / l2 : 0.0;
    t = fmax(0.0, fmin(1.0, t));
    return hypot(a.x + t * ex - p.x, a.y + t * ey - p.y);
}

static double orient(sim_vec2_t a, sim_vec2_t b, sim_vec2_t c)
{
    return (b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x);
}

/* 1 when polygons a and b overlap or come within tol of each other: two edges cross or pass
 * within tol, or (no edge near any other) one polygon lies inside the other. */
static int polys_near(const sim_poly_t *a, const sim_poly_t *b, double tol)
{
    for (int i = 0; i < a->n; i++) {
        sim_vec2_t a0 = a->p[i], a1 = a->p[(i + 1) % a->n];
        for (int j = 0; j < b->n; j++) {
            sim_vec2_t b0 = b->p[j], b1 = b->p[(j + 1) % b->n];
            double o1 = orient(a0, a1, b0), o2 = orient(a0, a1, b1);
            double o3 = orient(b0, b1, a0), o4 = orient(b0, b1, a1);
            if (((o1 < 0 && o2 > 0) || (o1 > 0 && o2 < 0)) && ((o3 < 0 && o4 > 0) || (o3 > 0 && o4 < 0)))
                return 1;
            if (seg_point_dist(a0, a1, b0) <= tol || seg_point_dist(a0, a1, b1) <= tol ||
                seg_point_dist(b0, b1, a0) <= tol || seg_point_dist(b0, b1, a1) <= tol)
                return 1;
        }
    }
    return sim_poly_contains(a, b->p[0].x, b->p[0].y) || sim_poly_contains(b, a->p[0].x, a->p[0].y);
}

/* Walls bucketed on a uniform grid over the plan (compressed rows: the walls of cell c are
 * idx[start[c] .. start[c + 1] - 1]), so that an opening is tested against the walls near
 * it only: linear in the plan's size for real plans, however long some walls are. */
typedef struct {
    double x0, y0, cw, ch;
    int gx, gy;
    int *start, *idx;
} wall_grid_t;

/* Cells covered by box b grown by tol, clamped to the grid (openings may lie outside it). */
static void grid_range(const wall_grid_t *g, box_t b, double tol, int *c0, int *c1, int *r0, int *r1)
{
    double f[4] = {floor((b.x0 - tol - g->x0) / g->cw), floor((b.x1 + tol - g->x0) / g->cw),
                   floor((b.y0 - tol - g->y0) / g->ch), floor((b.y1 + tol - g->y0) / g->ch)};
    int lim[4] = {g->gx - 1, g->gx - 1, g->gy - 1, g->gy - 1}, out[4];
    for (int k = 0; k < 4; k++)
        out[k] = (int)fmax(0.0, fmin((double)lim[k], f[k])); /* clamp as doubles: no int overflow */
    *c0 = out[0];
    *c1 = out[1];
    *r0 = out[2];
    *r1 = out[3];
}

static int wall_grid_build(const sim_plan_t *p, const box_t *wb, double tol, wall_grid_t *g)
{
    int nw = p->n_walls;
    double wx = p->max.x - p->min.x, wy = p->max.y - p->min.y;
    /* About one cell per wall; a plan of long overlapping walls would register each in many
     * cells, so the grid is coarsened until the registrations fit a budget (1 x 1 always does). */
    double cs = sqrt(wx * wy / nw);
    int gx = (int)fmax(1.0, fmin(1024.0, ceil(wx / cs))), gy = (int)fmax(1.0, fmin(1024.0, ceil(wy / cs)));
    const long long budget = 16LL * nw + 65536;
    long long total;
    for (;;) {
        g->x0 = p->min.x;
        g->y0 = p->min.y;
        g->gx = gx;
        g->gy = gy;
        g->cw = wx / gx;
        g->ch = wy / gy;
        total = 0;
        for (int w = 0; w < nw; w++) {
            int c0, c1, r0, r1;
            grid_range(g, wb[w], tol, &c0, &c1, &r0, &r1);
            total += (long long)(c1 - c0 + 1) * (r1 - r0 + 1);
        }
        if (total <= budget || (gx == 1 && gy == 1))
            break;
        gx = (gx + 1) / 2;
        gy = (gy + 1) / 2;
    }
    size_t ncell = (size_t)gx * (size_t)gy;
    g->start = calloc(ncell + 1, sizeof *g->start);
    g->idx = malloc((size_t)total * sizeof *g->idx);
    if (g->start == NULL || g->idx == NULL)
        return -ENOMEM;
    for (int pass = 0; pass < 2; pass++) {
        for (int w = 0; w < nw; w++) {
            int c0, c1, r0, r1;
            grid_range(g, wb[w], tol, &c0, &c1, &r0, &r1);
            for (int r = r0; r <= r1; r++)
                for (int c = c0; c <= c1; c++) {
                    size_t cell = (size_t)r * (size_t)gx + (size_t)c;
                    if (pass == 0)
                        g->start[cell + 1]++;
                    else
                        g->idx[g->start[cell]++] = w;
                }
        }
        if (pass == 0) {
            for (size_t c = 0; c < ncell; c++)
                g->start[c + 1] += g->start[c];
        } else {
            /* The fill advanced each start to the next cell's: shift back. */
            for (size_t c = ncell; c > 0; c--)
                g->start[c] = g->start[c - 1];
            g->start[0] = 0;
        }
    }
    return 0;
}

/* For every opening: flags it isolated when it is near no wall, and links each door to the
 * convex walls it crosses other than the one it is nested in. */
static int link_openings(sim_plan_t *p, const unsigned char *convex, const wall_axis_t *axes, door_links_t *dl)
{
    int nw = p->n_walls;
    const double tol = PLAN_TOUCH_M;
    box_t *wb = malloc((size_t)nw * sizeof *wb);
    int *seen = malloc((size_t)nw * sizeof *seen); /* last opening that looked at each wall */
    wall_grid_t g = {0};
    int rc = wb != NULL && seen != NULL ? 0 : -ENOMEM;
    if (rc == 0) {
        for (int w = 0; w < nw; w++) {
            wb[w] = poly_box(&p->walls[w].outline);
            seen[w] = -1;
        }
        rc = wall_grid_build(p, wb, tol, &g);
    }
    for (int d = 0; d < p->n_openings && rc == 0; d++) {
        sim_opening_t *op = &p->openings[d];
        box_t ob = poly_box(&op->outline);
        int c0, c1, r0, r1, near = 0;
        grid_range(&g, ob, tol, &c0, &c1, &r0, &r1);
        for (int r = r0; r <= r1 && rc == 0; r++)
            for (int c = c0; c <= c1 && rc == 0; c++) {
                size_t cell = (size_t)r * (size_t)g.gx + (size_t)c;
                for (int k = g.start[cell]; k < g.start[cell + 1] && rc == 0; k++) {
                    int w = g.idx[k];
                    if (seen[w] == d)
                        continue;
                    seen[w] = d;
                    if (wb[w].x1 < ob.x0 - tol || wb[w].x0 > ob.x1 + tol || wb[w].y0 > ob.y1 + tol ||
                        wb[w].y1 < ob.y0 - tol)
                        continue;
                    const sim_poly_t *wo = &p->walls[w].outline;
                    if (!near)
                        near = polys_near(&op->outline, wo, tol);
                    if (op->kind != SIM_OPENING_DOOR || w == op->wall || !convex[w] ||
                        !door_crosses(wo, &axes[w], &op->outline))
                        continue;
                    if ((rc = grow((void **)&dl->xdoor, &dl->cap_xdoor, dl->n_pairs + 1, sizeof *dl->xdoor)) != 0 ||
                        (rc = grow((void **)&dl->xnext, &dl->cap_xnext, dl->n_pairs + 1, sizeof *dl->xnext)) != 0)
                        break;
                    dl->xdoor[dl->n_pairs] = d;
                    dl->xnext[dl->n_pairs] = dl->xfirst[w];
                    dl->xfirst[w] = dl->n_pairs++;
                }
            }
        op->isolated = !near;
    }
    free(wb);
    free(seen);
    free(g.start);
    free(g.idx);
    return rc;
}

static int finish_plan(reader_t *r)
{
    sim_plan_t *p = r->plan;
    if (p->n_walls == 0)
        return fail(&r->e, r->root_line, "no walls: the plan has no <g class=\"Wall\"> group with a polygon");
    p->min.x = p->min.y = INFINITY;
    p->max.x = p->max.y = -INFINITY;
    for (int w = 0; w < p->n_walls; w++)
        for (int k = 0; k < p->walls[w].outline.n; k++) {
            const sim_vec2_t *v = &p->walls[w].outline.p[k];
            p->min.x = fmin(p->min.x, v->x);
            p->min.y = fmin(p->min.y, v->y);
            p->max.x = fmax(p->max.x, v->x);
            p->max.y = fmax(p->max.y, v->y);
        }
    double wx = p->max.x - p->min.x, wy = p->max.y - p->min.y;
    if (wx > PLAN_MAX_EXTENT_M || wy > PLAN_MAX_EXTENT_M)
        return fail(&r->e, p->walls[0].line, "absurd plan size %.1f x %.1f m (more than %.0f m; wrong scale?)",
                    wx, wy, PLAN_MAX_EXTENT_M);
    if (wx < PLAN_MIN_EXTENT_M || wy < PLAN_MIN_EXTENT_M)
        return fail(&r->e, p->walls[0].line, "absurd plan size %.3f x %.3f m (less than %.2f m; wrong scale?)",
                    wx, wy, PLAN_MIN_EXTENT_M);

    /* The doors cutting each wall (nested, then crossing), then the solids. */
    size_t nw = (size_t)p->n_walls, no = (size_t)(p->n_openings > 0 ? p->n_openings : 1);
    door_links_t dl = {0};
    dl.first = malloc(nw * sizeof *dl.first);
    dl.next = malloc(no * sizeof *dl.next);
    dl.xfirst = malloc(nw * sizeof *dl.xfirst);
    unsigned char *convex = malloc(nw);
    wall_axis_t *axes = malloc(nw * sizeof *axes);
    int rc = 0;
    if (dl.first == NULL || dl.next == NULL || dl.xfirst == NULL || convex == NULL || axes == NULL)
        rc = -ENOMEM;
    if (rc == 0) {
        for (int w = 0; w < p->n_walls; w++) {
            dl.first[w] = dl.xfirst[w] = -1;
            convex[w] = (unsigned char)poly_is_convex(&p->walls[w].outline);
            if (convex[w])
                wall_axis(&p->walls[w].outline, &axes[w]);
        }
        for (int d = p->n_openings - 1; d >= 0; d--) {
            dl.next[d] = -1;
            if (p->openings[d].kind != SIM_OPENING_DOOR || p->openings[d].wall < 0)
                continue;
            dl.next[d] = dl.first[p->openings[d].wall];
            dl.first[p->openings[d].wall] = d;
        }
        rc = link_openings(p, convex, axes, &dl);
    }
    if (rc == 0)
        rc = build_solids(p, &dl, convex, axes);
    free(dl.first);
    free(dl.next);
    free(dl.xfirst);
    free(dl.xdoor);
    free(dl.xnext);
    free(convex);
    free(axes);
    return rc;
}

/* ---- API ------------------------------------------------------------------------------- */

void sim_plan_free(sim_plan_t *plan)
{
    if (plan == NULL)
        return;
    free(plan->walls);
    free(plan->openings);
    free(plan->rooms);
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
            fprintf(out, "%s:%d: warning: %s overlaps no wall, it cuts nothing\n", name ? name : "<memory>",
                    o->line, o->kind == SIM_OPENING_DOOR ? "Door" : "Window");
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
    errctx_t e = {name, err, errlen};
    if (text == NULL)
        return fail(&e, 0, "no text");
    if (!(scale > 0.0))
        scale = SIM_PLAN_DEFAULT_SCALE;
    if (!isfinite(scale) || scale > PLAN_MAX_SCALE)
        return fail(&e, 0, "absurd scale %g metres per pixel", scale);
    reader_t *r = calloc(1, sizeof *r);
    if (r == NULL)
        return -ENOMEM;
    r->s = text;
    r->n = strlen(text);
    r->line = 1;
    r->e = e;
    r->scale = scale;
    r->plan = plan;
    plan->scale = scale;
    int rc = read_document(r);
    if (rc == 0)
        rc = finish_plan(r);
    free(r);
    if (rc != 0) {
        if (rc == -ENOMEM && err != NULL && errlen > 0)
            snprintf(err, errlen, "%s:0: out of memory", name);
        sim_plan_free(plan);
    }
    return rc;
}

int sim_plan_load(const char *path, double scale, sim_plan_t *plan, char *err, size_t errlen)
{
    if (err != NULL && errlen > 0)
        err[0] = '\0';
    if (plan == NULL)
        return -EINVAL;
    memset(plan, 0, sizeof *plan);
    if (path == NULL) {
        if (err != NULL && errlen > 0)
            snprintf(err, errlen, "(null):0: no path");
        return -EINVAL;
    }
    FILE *f = NULL;
    int orc = hal_host_file_open_read(path, &f);
    if (orc < 0) {
        if (err != NULL && errlen > 0)
            snprintf(err, errlen, "%s:0: %s", path, strerror(-orc));
        return orc;
    }
    size_t cap = 1 << 16, len = 0;
    char *buf = malloc(cap + 1);
    int rc = buf ? 0 : -ENOMEM;
    while (rc == 0) {
        if (len == cap) {
            if ((long)cap >= PLAN_MAX_FILE_BYTES) {
                if (err != NULL && errlen > 0)
                    snprintf(err, errlen, "%s:0: absurd file size (more than %ld bytes)", path,
                             PLAN_MAX_FILE_BYTES);
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
        size_t k = fread(buf + len, 1, cap - len, f);
        len += k;
        if (k == 0) {
            if (ferror(f)) {
                if (err != NULL && errlen > 0)
                    snprintf(err, errlen, "%s:0: read error", path);
                rc = -EIO;
            }
            break;
        }
    }
    fclose(f);
    if (rc == 0) {
        if (memchr(buf, '\0', len) != NULL) {
            /* Report the line of the NUL. */
            int line = 1;
            for (size_t i = 0; i < len && buf[i] != '\0'; i++)
                line += buf[i] == '\n';
            if (err != NULL && errlen > 0)
                snprintf(err, errlen, "%s:%d: NUL byte in the file: not a text SVG file", path, line);
            rc = -EINVAL;
        } else {
            buf[len] = '\0';
            rc = sim_plan_parse(buf, path, scale, plan, err, errlen);
            if (rc == 0)
                (void)sim_plan_warnings(plan, path, stderr);
        }
    } else if (rc == -ENOMEM && err != NULL && errlen > 0) {
        snprintf(err, errlen, "%s:0: out of memory", path);
    }
    free(buf);
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
