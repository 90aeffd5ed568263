/* The XML tokenizer of the floor-plan parser (line- and column-tracked, no XML library) and
 * the attribute values it reads: points and transforms. What the groups mean is
 * sim_plan_elements.c's.
 *
 * Why our own tokenizer: the files come from outside, every error must name its place, and
 * the subset we need (elements, attributes, comments, declarations) is small. Entities are
 * not decoded: the attributes we read (class, points, transform) never need them.
 *
 * `transform` attributes (matrix, translate, scale, rotate, skewX, skewY) on any element are
 * composed down the tree and applied to polygon points before the metric scale. */
#include "sim_plan_int.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Where p, inside attribute value a, is. */
static sim_plan_loc_t loc_in(const sim_plan_attr_t *a, const char *p)
{
    sim_plan_loc_t at = a->at;
    const char *line_start = NULL;
    for (const char *q = a->v; q < p; q++)
        if (*q == '\n') {
            at.line++;
            line_start = q + 1;
        }
    at.col = line_start != NULL ? (int)(p - line_start) + 1 : a->at.col + (int)(p - a->v);
    return at;
}

/* ---- points ---------------------------------------------------------------------------- */

/* A bad number is reported where it is; what is wrong with the whole list, where it starts. */
int sim_plan_parse_points(const sim_plan_errctx_t *e, const sim_plan_attr_t *a, const sim_plan_elem_t *el,
                          double scale, const double *m, sim_poly_t *out)
{
    double coords[2 * SIM_POLY_MAX_POINTS + 2];
    int nc = 0, count = 0;
    const char *v = a->v;
    size_t len = a->len, i = 0;
    while (i < len) {
        char c = v[i];
        if (sim_plan_is_space(c) || c == ',') {
            i++;
            continue;
        }
        /* One number: copy the token (bounded) so strtod cannot run past the value. */
        size_t j = i;
        while (j < len && !sim_plan_is_space(v[j]) && v[j] != ',')
            j++;
        char tok[64];
        size_t tl = j - i;
        if (tl >= sizeof tok)
            return sim_plan_fail(e, loc_in(a, v + i), el, "bad number '%.20s...' in points", v + i);
        memcpy(tok, v + i, tl);
        tok[tl] = '\0';
        char *end = NULL;
        errno = 0;
        double d = strtod(tok, &end);
        if (end == tok || *end != '\0' || errno == ERANGE || !isfinite(d))
            return sim_plan_fail(e, loc_in(a, v + i), el, "bad number '%s' in points", tok);
        count++;
        if (count > 2 * SIM_POLY_MAX_POINTS)
            return sim_plan_fail(e, a->at, el, "too many points in polygon (more than %d)", SIM_POLY_MAX_POINTS);
        coords[nc++] = d;
        i = j;
    }
    if (nc % 2 != 0)
        return sim_plan_fail(e, a->at, el, "odd number of coordinates (%d) in points", nc);
    /* Scale, drop consecutive repeats and a closing repeat of the first point. */
    out->n = 0;
    for (int k = 0; k < nc; k += 2) {
        double px = m[0] * coords[k] + m[2] * coords[k + 1] + m[4];
        double py = m[1] * coords[k] + m[3] * coords[k + 1] + m[5];
        double x = px * scale, y = py * scale;
        if (fabs(x) > PLAN_MAX_COORD_M || fabs(y) > PLAN_MAX_COORD_M)
            return sim_plan_fail(e, a->at, el, "coordinate (%g, %g) is %g m from the origin, absurd for a floor plan",
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
        return sim_plan_fail(e, a->at, el, "degenerate polygon: %d distinct point%s, at least 3 needed", out->n,
                             out->n == 1 ? "" : "s");
    if (fabs(sim_poly_signed_area(out)) < PLAN_MIN_AREA_M2)
        return sim_plan_fail(e, a->at, el, "degenerate polygon: zero area");
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

/* Parses transform attribute ta of element el, an SVG transform list (matrix, translate, scale,
 * rotate, skewX, skewY), into m. */
static int parse_transform(const sim_plan_errctx_t *e, const sim_plan_attr_t *ta, const sim_plan_elem_t *el,
                           double *m)
{
    const char *v = ta->v;
    size_t len = ta->len;
    const sim_plan_loc_t at = ta->at; /* of the whole list, for what is wrong with it */
    memcpy(m, IDENTITY, sizeof IDENTITY);
    size_t i = 0;
    for (;;) {
        while (i < len && (sim_plan_is_space(v[i]) || v[i] == ','))
            i++;
        if (i >= len)
            break;
        size_t ns = i;
        while (i < len && ((v[i] >= 'a' && v[i] <= 'z') || (v[i] >= 'A' && v[i] <= 'Z')))
            i++;
        size_t nl = i - ns;
        while (i < len && sim_plan_is_space(v[i]))
            i++;
        if (nl == 0 || i >= len || v[i] != '(')
            return sim_plan_fail(e, at, el, "bad transform '%.*s'", (int)(len > 60 ? 60 : len), v);
        i++;
        double a[6];
        int na = 0;
        for (;;) {
            while (i < len && (sim_plan_is_space(v[i]) || v[i] == ','))
                i++;
            if (i < len && v[i] == ')') {
                i++;
                break;
            }
            char tok[64];
            size_t j = i;
            while (j < len && !sim_plan_is_space(v[j]) && v[j] != ',' && v[j] != ')')
                j++;
            if (j == i || j - i >= sizeof tok || na == 6)
                return sim_plan_fail(e, at, el, "bad transform '%.*s'", (int)(len > 60 ? 60 : len), v);
            memcpy(tok, v + i, j - i);
            tok[j - i] = '\0';
            char *end = NULL;
            double d = strtod(tok, &end);
            if (end == tok || *end != '\0' || !isfinite(d))
                return sim_plan_fail(e, loc_in(ta, v + i), el, "bad number '%s' in transform", tok);
            a[na++] = d;
            i = j;
            if (i >= len)
                return sim_plan_fail(e, at, el, "unclosed '(' in transform");
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
            return sim_plan_fail(e, at, el, "bad transform '%.*s' (unknown function or wrong argument count)",
                                 (int)nl, n);
        }
#undef IS
        double r[6];
        mat_mul(m, t, r);
        memcpy(m, r, sizeof r);
    }
    double det = m[0] * m[3] - m[1] * m[2];
    for (int k = 0; k < 6; k++)
        if (!isfinite(m[k]))
            return sim_plan_fail(e, at, el, "transform out of range");
    if (fabs(det) < 1e-12)
        return sim_plan_fail(e, at, el, "degenerate transform (zero determinant)");
    return 0;
}

/* ---- the tokenizer ------------------------------------------------------------------------ */

static int is_name_char(char c)
{
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
           c == '-' || c == '.' || c == ':';
}

static sim_plan_loc_t here(const sim_plan_reader_t *r)
{
    return (sim_plan_loc_t){r->line, (int)(r->pos - r->line_start) + 1};
}

/* Moves one character on, counting lines. */
static void advance(sim_plan_reader_t *r)
{
    if (r->s[r->pos] == '\n') {
        r->line++;
        r->line_start = r->pos + 1;
    }
    r->pos++;
}

static void skip_space(sim_plan_reader_t *r)
{
    while (r->pos < r->n && sim_plan_is_space(r->s[r->pos]))
        advance(r);
}

/* Advances past `term`, counting lines; -1 if the text ends first. */
static int skip_past(sim_plan_reader_t *r, const char *term)
{
    size_t tl = strlen(term);
    while (r->pos + tl <= r->n) {
        if (memcmp(r->s + r->pos, term, tl) == 0) {
            r->pos += tl;
            return 0;
        }
        advance(r);
    }
    while (r->pos < r->n)
        advance(r);
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

/* Closes the innermost element. */
static int close_frame(sim_plan_reader_t *r)
{
    int rc = sim_plan_close_group(r, &r->stack[r->depth - 1]);
    if (rc != 0)
        return rc;
    r->depth--;
    if (r->depth == 0)
        r->root_closed = 1;
    return 0;
}

/* Reads one start tag after '<' (r->pos at the name; the '<' at `at`). */
static int read_start_tag(sim_plan_reader_t *r, sim_plan_loc_t at)
{
    size_t ns = r->pos;
    while (r->pos < r->n && is_name_char(r->s[r->pos]))
        r->pos++;
    size_t nl = r->pos - ns;
    const char *name = r->s + ns;
    /* The element, for messages; its id once read (errors before that cannot name it). */
    sim_plan_elem_t el = {name, nl, NULL, 0};
    if (nl == 0)
        return sim_plan_fail(&r->e, at, NULL, "malformed tag: '<' not followed by an element name");
    sim_plan_attr_t cls = {0}, pts = {0}, tfm = {0}, id = {0};
    int self_close = 0;
    for (;;) {
        skip_space(r);
        if (r->pos >= r->n)
            return sim_plan_fail(&r->e, at, &el, "unclosed tag <%.*s>: the file ends inside it", (int)nl, name);
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
            return sim_plan_fail(&r->e, here(r), &el, "malformed tag <%.*s>: '/' not followed by '>'", (int)nl, name);
        }
        if (!is_name_char(c))
            return sim_plan_fail(&r->e, here(r), &el, "malformed tag <%.*s>: unexpected character '%c'", (int)nl,
                                 name, c);
        size_t as = r->pos;
        sim_plan_loc_t aat = here(r);
        while (r->pos < r->n && is_name_char(r->s[r->pos]))
            r->pos++;
        size_t al = r->pos - as;
        skip_space(r);
        if (r->pos >= r->n || r->s[r->pos] != '=')
            return sim_plan_fail(&r->e, aat, &el, "attribute '%.*s' of <%.*s> has no value", (int)al, r->s + as,
                                 (int)nl, name);
        r->pos++;
        skip_space(r);
        if (r->pos >= r->n)
            return sim_plan_fail(&r->e, at, &el, "unclosed tag <%.*s>: the file ends inside it", (int)nl, name);
        char q = r->s[r->pos];
        if (q != '"' && q != '\'')
            return sim_plan_fail(&r->e, here(r), &el, "value of attribute '%.*s' is not quoted", (int)al, r->s + as);
        sim_plan_loc_t qat = here(r);
        r->pos++;
        sim_plan_attr_t a = {r->s + r->pos, 0, here(r), 1};
        while (r->pos < r->n && r->s[r->pos] != q)
            advance(r);
        if (r->pos >= r->n)
            return sim_plan_fail(&r->e, qat, &el, "unclosed quote: value of attribute '%.*s' never ends", (int)al,
                                 r->s + as);
        a.len = (size_t)(r->s + r->pos - a.v);
        r->pos++;
        if (al == 5 && memcmp(r->s + as, "class", 5) == 0 && !cls.present)
            cls = a;
        else if (al == 6 && memcmp(r->s + as, "points", 6) == 0 && !pts.present)
            pts = a;
        else if (al == 9 && memcmp(r->s + as, "transform", 9) == 0 && !tfm.present)
            tfm = a;
        else if (al == 2 && memcmp(r->s + as, "id", 2) == 0 && !id.present) {
            id = a;
            el.id = a.v;
            el.id_len = a.len;
        }
    }

    /* The root must be <svg>; nothing may follow it. */
    if (!r->root_seen) {
        if (!name_is(name, nl, "svg"))
            return sim_plan_fail(&r->e, at, &el, "not an SVG file: the root element is <%.*s>, not <svg>", (int)nl,
                                 name);
        r->root_seen = 1;
        r->root_at = at;
    } else if (r->root_closed) {
        return sim_plan_fail(&r->e, at, &el, "element <%.*s> after the end of the <svg> root", (int)nl, name);
    }

    /* This element's transform: its parent's composed with its own attribute. */
    double m[6];
    const double *parent = r->depth > 0 ? r->stack[r->depth - 1].m : IDENTITY;
    if (tfm.present) {
        double own[6];
        int rc = parse_transform(&r->e, &tfm, &el, own);
        if (rc != 0)
            return rc;
        mat_mul(parent, own, m);
    } else {
        memcpy(m, parent, sizeof m);
    }
    if (name_is(name, nl, "polygon")) {
        int rc = sim_plan_take_polygon(r, &el, at, &pts, m);
        if (rc != 0)
            return rc;
    }
    if (r->depth >= PLAN_MAX_DEPTH)
        return sim_plan_fail(&r->e, at, &el, "elements nested deeper than %d", PLAN_MAX_DEPTH);
    sim_plan_frame_t *f = &r->stack[r->depth++];
    memset(f, 0, sizeof *f);
    f->el = el;
    f->at = at;
    memcpy(f->m, m, sizeof m);
    if (name_is(name, nl, "g")) {
        int rc = sim_plan_open_group(r, f, &cls);
        if (rc != 0)
            return rc;
    }
    if (self_close)
        return close_frame(r);
    return 0;
}

/* Reads one end tag after "</" (the '<' at `at`). */
static int read_end_tag(sim_plan_reader_t *r, sim_plan_loc_t at)
{
    size_t ns = r->pos;
    while (r->pos < r->n && is_name_char(r->s[r->pos]))
        r->pos++;
    size_t nl = r->pos - ns;
    const char *name = r->s + ns;
    skip_space(r);
    if (r->pos >= r->n)
        return sim_plan_fail(&r->e, at, NULL, "unclosed tag </%.*s>: the file ends inside it", (int)nl, name);
    if (nl == 0 || r->s[r->pos] != '>')
        return sim_plan_fail(&r->e, at, NULL, "malformed end tag </%.*s", (int)nl, name);
    r->pos++;
    if (r->depth == 0)
        return sim_plan_fail(&r->e, at, NULL, "end tag </%.*s> without a matching start tag", (int)nl, name);
    sim_plan_frame_t *f = &r->stack[r->depth - 1];
    if (f->el.name_len != nl || memcmp(f->el.name, name, nl) != 0) {
        /* A stray end tag is reported where it is; one that closes an outer element means
         * the innermost open element lacks its end tag. */
        int open_somewhere = 0;
        for (int d = 0; d < r->depth - 1; d++)
            if (r->stack[d].el.name_len == nl && memcmp(r->stack[d].el.name, name, nl) == 0)
                open_somewhere = 1;
        if (!open_somewhere)
            return sim_plan_fail(&r->e, at, NULL,
                                 "end tag </%.*s> matches no open element (innermost open: <%.*s> at %d:%d)", (int)nl,
                                 name, (int)f->el.name_len, f->el.name, f->at.line, f->at.col);
        return sim_plan_fail(&r->e, f->at, &f->el, "<%.*s> is never closed (found </%.*s> at %d:%d)",
                             (int)f->el.name_len, f->el.name, (int)nl, name, at.line, at.col);
    }
    return close_frame(r);
}

int sim_plan_read_document(sim_plan_reader_t *r)
{
    while (r->pos < r->n) {
        char c = r->s[r->pos];
        if (c != '<') {
            if (c == '\0')
                return sim_plan_fail(&r->e, here(r), NULL, "NUL byte in the file: not a text SVG file");
            advance(r); /* character data: ignored */
            continue;
        }
        sim_plan_loc_t at = here(r);
        const char *t = r->s + r->pos;
        size_t left = r->n - r->pos;
        if (left >= 4 && memcmp(t, "<!--", 4) == 0) {
            r->pos += 4;
            if (skip_past(r, "-->") != 0)
                return sim_plan_fail(&r->e, at, NULL, "unclosed comment: '<!--' without '-->'");
        } else if (left >= 9 && memcmp(t, "<![CDATA[", 9) == 0) {
            r->pos += 9;
            if (skip_past(r, "]]>") != 0)
                return sim_plan_fail(&r->e, at, NULL, "unclosed CDATA section");
        } else if (left >= 2 && memcmp(t, "<?", 2) == 0) {
            r->pos += 2;
            if (skip_past(r, "?>") != 0)
                return sim_plan_fail(&r->e, at, NULL, "unclosed processing instruction: '<?' without '?>'");
        } else if (left >= 2 && memcmp(t, "<!", 2) == 0) {
            /* <!DOCTYPE ...> possibly with an internal subset [ ... ]. */
            r->pos += 2;
            int bracket = 0, done = 0;
            while (r->pos < r->n && !done) {
                char d = r->s[r->pos];
                advance(r);
                if (d == '[')
                    bracket++;
                else if (d == ']' && bracket > 0)
                    bracket--;
                else if (d == '>' && bracket == 0)
                    done = 1;
            }
            if (!done)
                return sim_plan_fail(&r->e, at, NULL, "unclosed declaration '<!'");
        } else if (left >= 2 && t[1] == '/') {
            r->pos += 2;
            int rc = read_end_tag(r, at);
            if (rc != 0)
                return rc;
        } else {
            r->pos += 1;
            int rc = read_start_tag(r, at);
            if (rc != 0)
                return rc;
        }
    }
    if (!r->root_seen)
        return sim_plan_fail(&r->e, here(r), NULL, "not an SVG file: no <svg> root element");
    if (r->depth > 0) {
        /* Report the innermost unclosed element: that is where a closing tag is missing. */
        sim_plan_frame_t *f = &r->stack[r->depth - 1];
        sim_plan_loc_t end = here(r);
        return sim_plan_fail(&r->e, f->at, &f->el, "<%.*s> is never closed (the file ends at %d:%d)",
                             (int)f->el.name_len, f->el.name, end.line, end.col);
    }
    return 0;
}
