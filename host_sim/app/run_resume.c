/* `host_sim run --resume` and the incarnation counter: see run_resume.h. */
#include "run_resume.h"

#include <dirent.h>
#include <errno.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <sys/types.h>
#include <unistd.h>

#include "ai/bnn_ckpt.h"
#include "gp/gp_core.h"
#include "hal_host_file.h"

#define INCARNATION_FILE "incarnation"

/* ---- the checkpoint ------------------------------------------------------------------------ */

/* Reads a checkpoint and validates it on the scratch model. 0 and the bytes in *buf (malloc'd),
 * -ENOENT when there is no such file, or another negative code with *why set. */
static int read_ckpt(const char *file, bnn_model_t *scratch, uint8_t **buf, size_t *len, const char **why)
{
    FILE *f = NULL;
    int rc = hal_host_file_open_read(file, &f);
    if (rc < 0) {
        *why = hal_host_file_strerror(rc);
        return rc;
    }
    const size_t cap = BNN_CKPT_MAX_BYTES + 1; /* one more: a file too large shows */
    uint8_t *b = malloc(cap);
    if (b == NULL) {
        fclose(f);
        *why = "out of memory";
        return -ENOMEM;
    }
    const size_t n = fread(b, 1, cap, f);
    const int bad_read = ferror(f);
    fclose(f);
    if (bad_read) {
        rc = -EIO;
        *why = "read error";
    } else if (n == cap) {
        rc = -EFBIG;
        *why = "larger than any checkpoint of this preset";
    } else {
        rc = bnn_ckpt_load(scratch, b, n, why);
    }
    if (rc != 0) {
        free(b);
        return rc;
    }
    *buf = b;
    *len = n;
    return 0;
}

/* The last round checkpoint below `rounds` that loads; warns about every one skipped. */
static int find_ckpt(const char *out, uint32_t rounds, run_resume_t *r)
{
    bnn_model_t *m = aligned_alloc(_Alignof(bnn_model_t), (sizeof *m + 63) / 64 * 64);
    if (m == NULL || bnn_init(m, NULL, 1) != 0) {
        free(m);
        fprintf(stderr, "host_sim run: out of memory\n");
        return -1;
    }
    for (uint32_t k = rounds; k-- > 0;) {
        char name[64], file[PATH_MAX + 64];
        gp_core_ckpt_name(k, name, sizeof name);
        snprintf(file, sizeof file, "%s/%s", out, name);
        const char *why = NULL;
        int rc = read_ckpt(file, m, &r->ckpt, &r->ckpt_bytes, &why);
        if (rc == -ENOENT)
            continue;
        if (rc != 0) {
            fprintf(stderr, "host_sim run: warning: %s: %s; skipped (torn or invalid)\n", file,
                    why ? why : "invalid checkpoint");
            r->skipped++;
            continue;
        }
        snprintf(r->ckpt_name, sizeof r->ckpt_name, "%s", name);
        r->ckpt_round = k;
        r->start_round = k + 1u;
        break;
    }
    free(m);
    return 0;
}

/* ---- rows of a killed run ------------------------------------------------------------------ */

/* PID of `.BASE.PID.fstmp`, or 0 when name is not a temporary file of BASE. */
static long tmp_pid_of(const char *name, const char *base)
{
    const size_t nb = strlen(base), ns = strlen(HAL_HOST_FILE_TMP_SUFFIX), n = strlen(name);
    if (n < nb + ns + 3 || name[0] != '.' || strncmp(name + 1, base, nb) != 0 || name[1 + nb] != '.' ||
        strcmp(name + n - ns, HAL_HOST_FILE_TMP_SUFFIX) != 0)
        return 0;
    long pid = 0;
    for (const char *p = name + 2 + nb; p < name + n - ns; p++) {
        if (*p < '0' || *p > '9' || pid > 0x7FFFFFFFL / 10)
            return 0;
        pid = pid * 10 + (*p - '0');
    }
    return pid;
}

static int process_alive(long pid)
{
    return pid == (long)getpid() || kill((pid_t)pid, 0) == 0 || errno == EPERM;
}

static int count_commas(const char *s, const char *end)
{
    int n = 0;
    for (; s < end; s++)
        n += *s == ',';
    return n;
}

/* The complete rows of rounds < before in text (which must begin with header), in order of
 * increasing rounds: into c (rows malloc'd). A torn last line, a row with another number of
 * fields or out of order ends the rows taken. */
static void take_rows(const char *text, size_t len, const char *header, uint32_t before, run_carry_t *c)
{
    const size_t hl = strlen(header);
    if (len < hl || memcmp(text, header, hl) != 0)
        return;
    const int fields = count_commas(header, header + hl);
    char *rows = malloc(len - hl + 1);
    if (rows == NULL)
        return;
    size_t n = 0;
    uint32_t count = 0, first = 0, last = 0;
    for (const char *p = text + hl, *end = text + len; p < end;) {
        const char *nl = memchr(p, '\n', (size_t)(end - p));
        if (nl == NULL)
            break; /* the row the process was writing when it died */
        char *after = NULL;
        errno = 0;
        const unsigned long k = strtoul(p, &after, 10);
        if (after == p || *after != ',' || errno != 0 || count_commas(p, nl) != fields ||
            (count > 0 && k <= last))
            break;
        if (k < before) {
            memcpy(rows + n, p, (size_t)(nl - p) + 1u);
            n += (size_t)(nl - p) + 1u;
            first = count == 0 ? (uint32_t)k : first;
            last = (uint32_t)k;
            count++;
        }
        p = nl + 1;
    }
    if (count == 0) {
        free(rows);
        return;
    }
    c->rows = rows;
    c->len = n;
    c->n_rows = count;
    c->first = first;
    c->last = last;
}

static char *slurp(const char *path, size_t *len)
{
    FILE *f = NULL;
    if (hal_host_file_open_read(path, &f) != 0)
        return NULL;
    size_t cap = 1 << 16, n = 0;
    char *b = malloc(cap);
    for (size_t got; b != NULL && (got = fread(b + n, 1, cap - n, f)) > 0;) {
        n += got;
        if (n == cap) {
            char *nb = realloc(b, cap *= 2);
            if (nb == NULL)
                free(b);
            b = nb;
        }
    }
    fclose(f);
    *len = n;
    return b;
}

/* Of the temporaries of `c->name` that dead processes left in out, the one with the most rows
 * of rounds < before. Without one, the file itself when ALL its rows are of rounds < before:
 * what a run stopped by its --time-limit kept (a finished run's file goes further, and is
 * not taken for a stopped one's). */
static void carry_rows(const char *out, const char *header, uint32_t before, run_carry_t *c)
{
    DIR *d = opendir(out);
    if (d == NULL)
        return; /* no folder yet: nothing to carry */
    for (struct dirent *e; (e = readdir(d)) != NULL;) {
        const long pid = tmp_pid_of(e->d_name, c->name);
        if (pid <= 0 || process_alive(pid))
            continue;
        char file[PATH_MAX];
        if (snprintf(file, sizeof file, "%s/%s", out, e->d_name) >= (int)sizeof file)
            continue;
        size_t len = 0;
        char *text = slurp(file, &len);
        if (text == NULL)
            continue;
        run_carry_t got = {.name = c->name};
        take_rows(text, len, header, before, &got);
        free(text);
        if (got.n_rows > c->n_rows) {
            free(c->rows);
            *c = got;
            snprintf(c->from, sizeof c->from, "%s", e->d_name); /* in the output folder */
        } else {
            free(got.rows);
        }
    }
    closedir(d);
    if (c->n_rows > 0)
        return;
    char file[PATH_MAX];
    size_t len = 0;
    char *text = snprintf(file, sizeof file, "%s/%s", out, c->name) < (int)sizeof file ? slurp(file, &len) : NULL;
    if (text == NULL)
        return;
    run_carry_t got = {.name = c->name};
    take_rows(text, len, header, UINT32_MAX, &got);
    free(text);
    if (got.n_rows > 0 && got.last < before) {
        *c = got;
        snprintf(c->from, sizeof c->from, "%s", c->name);
    } else {
        free(got.rows);
    }
}

int run_resume_find(const char *out, uint32_t rounds, const char *const headers[RUN_CARRY_FILES], run_resume_t *r)
{
    memset(r, 0, sizeof *r);
    r->carry[RUN_CARRY_METRICS].name = headers[RUN_CARRY_METRICS] ? "metrics.csv" : NULL;
    r->carry[RUN_CARRY_TRAFFIC].name = headers[RUN_CARRY_TRAFFIC] ? "traffic.csv" : NULL;
    if (find_ckpt(out, rounds, r) != 0)
        return -1;
    for (int i = 0; i < RUN_CARRY_FILES; i++)
        if (r->carry[i].name != NULL && r->start_round > 0)
            carry_rows(out, headers[i], r->start_round, &r->carry[i]);
    /* Read first, removed now: the rows were in those temporaries. */
    const int removed = hal_host_file_clean_stale(out);
    if (removed > 0) {
        r->tmp_removed = removed;
        printf("removed %d temporary file(s) a stopped run left in %s\n", removed, out);
    }
    return 0;
}

void run_resume_describe(const run_resume_t *r, FILE *f)
{
    if (r->start_round == 0)
        return;
    const uint32_t c = r->start_round - 1u;
    for (int i = 0; i < RUN_CARRY_FILES; i++) {
        const run_carry_t *k = &r->carry[i];
        if (k->name == NULL)
            continue;
        if (k->n_rows == 0) {
            fprintf(f, "%s: the rows of rounds 0 .. %u are missing (the stopped run left no temporary file "
                       "of it)\n", k->name, c);
            continue;
        }
        fprintf(f, "%s: %u row(s) of rounds %u .. %u carried over from %s", k->name, k->n_rows, k->first, k->last,
                k->from);
        if (k->first > 0 || k->last < c || k->n_rows != k->last - k->first + 1u)
            fprintf(f, "; rows of rounds 0 .. %u are missing in part (%u of %u there)", c, k->n_rows, c + 1u);
        fputc('\n', f);
    }
}

void run_resume_free(run_resume_t *r)
{
    free(r->ckpt);
    r->ckpt = NULL;
    for (int i = 0; i < RUN_CARRY_FILES; i++) {
        free(r->carry[i].rows);
        r->carry[i].rows = NULL;
    }
}

/* ---- incarnation --------------------------------------------------------------------------- */

/* The number in the incarnation file: 0 and *n (0 when there is no file), or -1 (printed). */
static int read_incarnation(const char *file, uint32_t *n)
{
    *n = 0;
    FILE *f = NULL;
    int rc = hal_host_file_open_read(file, &f);
    if (rc == -ENOENT)
        return 0;
    if (rc < 0) {
        fprintf(stderr, "host_sim run: %s: %s\n", file, hal_host_file_strerror(rc));
        return -1;
    }
    char buf[32];
    const size_t len = fread(buf, 1, sizeof buf - 1, f);
    fclose(f);
    buf[len] = '\0';
    size_t digits = strspn(buf, "0123456789");
    const int ok = digits >= 1 && digits <= 10 && (buf[digits] == '\0' || strcmp(buf + digits, "\n") == 0) &&
                   strtoull(buf, NULL, 10) < UINT32_MAX;
    if (!ok) {
        buf[strcspn(buf, "\n")] = '\0';
        fprintf(stderr, "host_sim run: %s: malformed: expected one decimal number below %u, found '%.20s'; "
                        "fix or remove it\n", file, UINT32_MAX, buf);
        return -1;
    }
    *n = (uint32_t)strtoull(buf, NULL, 10);
    return 0;
}

int run_incarnation_next(const char *out, int resume, uint32_t *inc)
{
    char file[PATH_MAX];
    if (snprintf(file, sizeof file, "%s/%s", out, INCARNATION_FILE) >= (int)sizeof file) {
        fprintf(stderr, "host_sim run: %s/%s: %s\n", out, INCARNATION_FILE, strerror(ENAMETOOLONG));
        return -1;
    }
    uint32_t n = 0;
    if (resume && read_incarnation(file, &n) != 0)
        return -1;
    char text[16];
    const int len = snprintf(text, sizeof text, "%u\n", n + 1u);
    int rc = hal_host_file_write_all(file, text, (size_t)len);
    if (rc < 0) {
        fprintf(stderr, "host_sim run: %s: %s\n", file, hal_host_file_strerror(rc));
        return -1;
    }
    *inc = n + 1u;
    return 0;
}
