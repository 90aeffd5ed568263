/* Sample files: format in sim_samples.h. Fields are (de)serialised byte by byte, so the
 * file is little-endian whatever the host. */
#include "sim_samples.h"
#include "common/le_bytes.h"

#include <errno.h>
#include <math.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>

static uint32_t crc_table[256];
static pthread_once_t crc_once = PTHREAD_ONCE_INIT;

static void crc_init(void)
{
    for (uint32_t i = 0; i < 256; i++) {
        uint32_t c = i;
        for (int k = 0; k < 8; k++)
            c = (c & 1u) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
        crc_table[i] = c;
    }
}

uint32_t sim_crc32_update(uint32_t crc, const void *data, size_t n)
{
    pthread_once(&crc_once, crc_init);
    const uint8_t *p = data;
    crc = ~crc;
    for (size_t i = 0; i < n; i++)
        crc = crc_table[(crc ^ p[i]) & 0xFFu] ^ (crc >> 8);
    return ~crc;
}

static void encode_header(const sim_samples_header_t *h, uint8_t out[SIM_SAMPLES_HEADER_SIZE])
{
    memset(out, 0, SIM_SAMPLES_HEADER_SIZE);
    memcpy(out, SIM_SAMPLES_MAGIC, 8);
    le_put_u32(out + 8, SIM_SAMPLES_VERSION);
    le_put_u32(out + 12, SIM_SAMPLES_HEADER_SIZE);
    le_put_u32(out + 16, (uint32_t)sizeof(ai_sample_t));
    le_put_u32(out + 20, 0);
    le_put_u64(out + 24, h->count);
    le_put_f64(out + 32, h->min_x);
    le_put_f64(out + 40, h->min_y);
    le_put_f64(out + 48, h->max_x);
    le_put_f64(out + 56, h->max_y);
    le_put_u64(out + 64, h->seed);
    memcpy(out + 72, h->source, strnlen(h->source, SIM_SAMPLES_SOURCE_MAX));
    le_put_u32(out + 204, sim_crc32_update(0, out, 204));
}

static int record_ok(float x, float y, float occ)
{
    return isfinite(x) && isfinite(y) && isfinite(occ) && x >= -1.0f && x <= 1.0f &&
           y >= -1.0f && y <= 1.0f && occ >= 0.0f && occ <= 1.0f;
}

static int box_ok(double a, double b, double c, double d)
{
    return isfinite(a) && isfinite(b) && isfinite(c) && isfinite(d) && c > a && d > b;
}

int sim_samples_open(sim_samples_writer_t *w, const char *path, double min_x, double min_y,
                     double max_x, double max_y, uint64_t seed, const char *source)
{
    if (w == NULL || path == NULL || !box_ok(min_x, min_y, max_x, max_y))
        return -EINVAL;
    memset(w, 0, sizeof *w);
    w->hdr.version = SIM_SAMPLES_VERSION;
    w->hdr.min_x = min_x;
    w->hdr.min_y = min_y;
    w->hdr.max_x = max_x;
    w->hdr.max_y = max_y;
    w->hdr.seed = seed;
    if (source)
        strncpy(w->hdr.source, source, SIM_SAMPLES_SOURCE_MAX);
    int rc = hal_host_file_begin(&w->file, path);
    if (rc < 0)
        return rc;
    uint8_t h[SIM_SAMPLES_HEADER_SIZE];
    encode_header(&w->hdr, h);
    rc = hal_host_file_write(&w->file, h, sizeof h);
    if (rc < 0) {
        hal_host_file_abort(&w->file);
        return rc;
    }
    w->open = 1;
    return 0;
}

int sim_samples_append(sim_samples_writer_t *w, const ai_sample_t *s, size_t n)
{
    if (w == NULL || !w->open || (s == NULL && n > 0))
        return -EINVAL;
    uint8_t buf[12 * 256];
    while (n > 0) {
        size_t m = n < 256 ? n : 256;
        for (size_t i = 0; i < m; i++) {
            if (!record_ok(s[i].x, s[i].y, s[i].occ))
                return -EINVAL;
            le_put_f32(buf + 12 * i, s[i].x);
            le_put_f32(buf + 12 * i + 4, s[i].y);
            le_put_f32(buf + 12 * i + 8, s[i].occ);
        }
        int rc = hal_host_file_write(&w->file, buf, 12 * m);
        if (rc < 0)
            return rc;
        w->crc = sim_crc32_update(w->crc, buf, 12 * m);
        w->hdr.count += m;
        s += m;
        n -= m;
    }
    return 0;
}

int sim_samples_close(sim_samples_writer_t *w)
{
    if (w == NULL || !w->open)
        return -EINVAL;
    w->open = 0;
    uint8_t t[4], h[SIM_SAMPLES_HEADER_SIZE];
    le_put_u32(t, w->crc);
    encode_header(&w->hdr, h);
    int rc = hal_host_file_write(&w->file, t, 4);
    FILE *f = hal_host_file_stream(&w->file);
    if (rc == 0 && (fseek(f, 0, SEEK_SET) != 0 || fwrite(h, 1, sizeof h, f) != sizeof h))
        rc = errno ? -errno : -EIO;
    if (rc == 0)
        rc = hal_host_file_commit(&w->file);
    if (rc < 0)
        hal_host_file_abort(&w->file);
    return rc;
}

void sim_samples_abort(sim_samples_writer_t *w)
{
    if (w == NULL)
        return;
    w->open = 0;
    hal_host_file_abort(&w->file);
}

#define FAIL(code, ...)                                                                    \
    do {                                                                                   \
        snprintf(err, errlen, __VA_ARGS__);                                                \
        rc = (code);                                                                       \
        goto out;                                                                          \
    } while (0)

int sim_samples_read(const char *path, sim_samples_header_t *hdr, ai_sample_t **records,
                     char *err, size_t errlen)
{
    char dummy[2];
    if (err == NULL || errlen == 0) {
        err = dummy;
        errlen = sizeof dummy;
    }
    if (path == NULL || hdr == NULL || records == NULL) {
        snprintf(err, errlen, "sim_samples_read: bad arguments");
        return -EINVAL;
    }
    *records = NULL;
    int rc = 0;
    ai_sample_t *rec = NULL;
    uint8_t *buf = NULL;
    FILE *f = NULL;
    rc = hal_host_file_open_read(path, &f);
    if (rc < 0) {
        snprintf(err, errlen, "%s: %s", path, strerror(-rc));
        return rc;
    }
    uint8_t h[SIM_SAMPLES_HEADER_SIZE];
    if (fseek(f, 0, SEEK_END) != 0)
        FAIL(-EIO, "%s: cannot seek", path);
    long size = ftell(f);
    if (size < 0 || fseek(f, 0, SEEK_SET) != 0)
        FAIL(-EIO, "%s: cannot seek", path);
    if ((unsigned long)size < 8 || fread(h, 1, 8, f) != 8 || memcmp(h, SIM_SAMPLES_MAGIC, 8) != 0)
        FAIL(-EINVAL, "%s: not a samples file (bad magic)", path);
    if ((unsigned long)size < SIM_SAMPLES_HEADER_SIZE + 4u)
        FAIL(-EINVAL, "%s: truncated header (%ld bytes, at least %u expected)", path, size,
             SIM_SAMPLES_HEADER_SIZE + 4u);
    if (fread(h + 8, 1, SIM_SAMPLES_HEADER_SIZE - 8, f) != SIM_SAMPLES_HEADER_SIZE - 8)
        FAIL(-EIO, "%s: read error in header", path);
    uint32_t version = le_get_u32(h + 8);
    if (version != SIM_SAMPLES_VERSION)
        FAIL(-EINVAL, "%s: unsupported version %u (this reader knows %u)", path, version,
             SIM_SAMPLES_VERSION);
    if (le_get_u32(h + 12) != SIM_SAMPLES_HEADER_SIZE || le_get_u32(h + 16) != sizeof(ai_sample_t))
        FAIL(-EINVAL, "%s: bad header size %u or record size %u (expected %u, %zu)", path,
             le_get_u32(h + 12), le_get_u32(h + 16), SIM_SAMPLES_HEADER_SIZE, sizeof(ai_sample_t));
    if (le_get_u32(h + 204) != sim_crc32_update(0, h, 204))
        FAIL(-EINVAL, "%s: header CRC mismatch (corrupted header)", path);
    memset(hdr, 0, sizeof *hdr);
    hdr->version = version;
    hdr->count = le_get_u64(h + 24);
    hdr->min_x = le_get_f64(h + 32);
    hdr->min_y = le_get_f64(h + 40);
    hdr->max_x = le_get_f64(h + 48);
    hdr->max_y = le_get_f64(h + 56);
    hdr->seed = le_get_u64(h + 64);
    memcpy(hdr->source, h + 72, SIM_SAMPLES_SOURCE_MAX);
    hdr->source[SIM_SAMPLES_SOURCE_MAX] = '\0';
    if (!box_ok(hdr->min_x, hdr->min_y, hdr->max_x, hdr->max_y))
        FAIL(-EINVAL, "%s: invalid bounding box in header", path);
    uint64_t data = (uint64_t)size - SIM_SAMPLES_HEADER_SIZE - 4u;
    if (hdr->count > data / 12u)
        FAIL(-EINVAL, "%s: truncated: header says %llu records (%llu bytes) but only %llu bytes follow",
             path, (unsigned long long)hdr->count, (unsigned long long)hdr->count * 12u,
             (unsigned long long)data);
    if (hdr->count * 12u != data)
        FAIL(-EINVAL, "%s: bad count: header says %llu records but the file holds %llu bytes of "
                      "records (%llu extra)",
             path, (unsigned long long)hdr->count, (unsigned long long)data,
             (unsigned long long)(data - hdr->count * 12u));
    size_t nbytes = (size_t)data + 4u;
    buf = malloc(nbytes);
    if (buf == NULL)
        FAIL(-ENOMEM, "%s: out of memory for %zu bytes", path, nbytes);
    if (fread(buf, 1, nbytes, f) != nbytes)
        FAIL(-EIO, "%s: read error in records", path);
    if (le_get_u32(buf + data) != sim_crc32_update(0, buf, (size_t)data))
        FAIL(-EINVAL, "%s: data CRC mismatch (corrupted records)", path);
    if (hdr->count > 0) {
        rec = malloc(sizeof(ai_sample_t) * (size_t)hdr->count);
        if (rec == NULL)
            FAIL(-ENOMEM, "%s: out of memory for %llu records", path,
                 (unsigned long long)hdr->count);
    }
    for (uint64_t i = 0; i < hdr->count; i++) {
        const uint8_t *p = buf + 12 * i;
        rec[i].x = le_get_f32(p);
        rec[i].y = le_get_f32(p + 4);
        rec[i].occ = le_get_f32(p + 8);
        if (!record_ok(rec[i].x, rec[i].y, rec[i].occ))
            FAIL(-EINVAL, "%s: record %llu out of range (x, y in [-1, 1], occ in [0, 1])",
                 path, (unsigned long long)i);
    }
    *records = rec;
    rec = NULL;
out:
    free(rec);
    free(buf);
    fclose(f);
    return rc;
}
