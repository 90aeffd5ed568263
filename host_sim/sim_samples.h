/* Sample files: the on-disk form of ai_sample_t streams (host_sim scan/valset write them;
 * the trainer and tools/samples.py read them).
 *
 * Format, version 1. All integers little-endian, floats IEEE-754 little-endian.
 *   offset size  field
 *        0    8  magic "FSSAMPLE"
 *        8    4  u32 version = 1
 *       12    4  u32 header_size = 208 (bytes before the first record)
 *       16    4  u32 record_size = 12 (sizeof ai_sample_t: f32 x, f32 y, f32 occ)
 *       20    4  u32 flags = 0 (reserved)
 *       24    8  u64 count (records)
 *       32   32  f64 min_x, min_y, max_x, max_y: plan bounding box in metres, the box the
 *                x, y of the records are normalised over (x_m = min_x + (x+1)/2 (max_x-min_x))
 *       64    8  u64 seed of the run that produced the file
 *       72  132  source: NUL-padded UTF-8 text (e.g. "scan plan=... path=... beams=20 ...")
 *      204    4  u32 CRC-32 (IEEE 802.3, as zlib's crc32) of bytes 0..203
 *      208 12*count records
 *      end    4  u32 CRC-32 of the record bytes
 * A reader accepts a file only if every field checks: magic, version, sizes, the header
 * CRC, the file length exactly header + 12 * count + 4, the data CRC, and every record
 * finite with x, y in [-1, 1] and occ in [0, 1].
 *
 * The writer streams (records are appended as they come) and patches count and the header
 * CRC on close. Not thread-safe per writer. */
#ifndef SIM_SAMPLES_H
#define SIM_SAMPLES_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "ai/ai_sample.h"
#include "hal_host_file.h"

#define SIM_SAMPLES_MAGIC "FSSAMPLE"
#define SIM_SAMPLES_VERSION 1u
#define SIM_SAMPLES_HEADER_SIZE 208u
#define SIM_SAMPLES_SOURCE_MAX 132u

typedef struct sim_samples_header {
    uint32_t version;
    uint64_t count;
    double min_x, min_y, max_x, max_y;
    uint64_t seed;
    char source[SIM_SAMPLES_SOURCE_MAX + 1]; /* NUL-terminated */
} sim_samples_header_t;

typedef struct sim_samples_writer {
    hal_host_file_t file; /* written whole or not at all (hal_host_file.h) */
    int open;
    sim_samples_header_t hdr;
    uint32_t crc; /* running CRC of the records */
} sim_samples_writer_t;

/* CRC-32 (IEEE, reflected, init/xorout 0xFFFFFFFF). crc32_update(0, ...) starts a new one. */
uint32_t sim_crc32_update(uint32_t crc, const void *data, size_t n);

/* Starts `path` (a temporary file beside it until close) and writes a provisional header.
 * The bounding box must be non-empty and finite; source is truncated to
 * SIM_SAMPLES_SOURCE_MAX bytes. Returns 0, -EINVAL or the writer's error
 * (hal_host_file_begin: -EISDIR, -EEXIST for a device, -ENAMETOOLONG, -errno). */
FS_MUST_CHECK
int sim_samples_open(sim_samples_writer_t *w, const char *path, double min_x, double min_y,
                     double max_x, double max_y, uint64_t seed, const char *source);

/* Appends n records (each validated like the reader does). Returns 0, -EINVAL or -errno
 * of the write (-ENOSPC on a full disk). */
FS_MUST_CHECK
int sim_samples_append(sim_samples_writer_t *w, const ai_sample_t *s, size_t n);

/* Writes the data CRC, patches count and the header CRC, then replaces `path` with the
 * whole file. Returns 0 or -errno, and then `path` is as it was before open. The writer is
 * closed whatever the result. */
FS_MUST_CHECK
int sim_samples_close(sim_samples_writer_t *w);

/* Drops a partly written file (after an error): `path` stays as it was. Safe after close. */
void sim_samples_abort(sim_samples_writer_t *w);

/* Reads and validates the whole file. On success *records is a malloc'd array of
 * hdr->count records (NULL when count is 0), free() it. On failure returns -EINVAL
 * (malformed: bad magic, version, sizes, CRC, truncation, bad count, bad record),
 * -ENOMEM or -errno of the I/O, with a one-line reason in err. */
FS_MUST_CHECK
int sim_samples_read(const char *path, sim_samples_header_t *hdr, ai_sample_t **records,
                     char *err, size_t errlen);

#endif /* SIM_SAMPLES_H */
