/* Fuzz target: the samples reader (host_sim/sim_samples.c, sim_samples_read). It reads a file
 * by name, so each input goes into a memfd of its own, read as /proc/self/fd/N. Beyond memory
 * safety it checks the contract of sim_samples.h: a refused file leaves *records NULL with a
 * reason; an accepted one is exactly header + 12 * count + 4 bytes, its box is finite and
 * non-empty, every record finite with x, y in [-1, 1] and occ in [0, 1], and its source text
 * terminated. No state survives an input. */
#define _GNU_SOURCE /* memfd_create */
#include "fuzz/fuzz_config.h"

#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <unistd.h>

#include "sim_samples.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const int fd = memfd_create("fuzz.samples", MFD_CLOEXEC);
    CHECK(fd >= 0);
    for (size_t at = 0; at < size;) {
        const ssize_t w = write(fd, data + at, size - at);
        CHECK(w > 0);
        at += (size_t)w;
    }
    char path[64];
    snprintf(path, sizeof path, "/proc/self/fd/%d", fd);
    sim_samples_header_t hdr;
    ai_sample_t *rec = (ai_sample_t *)&hdr; /* must be overwritten */
    char err[256] = "";
    const int rc = sim_samples_read(path, &hdr, &rec, err, sizeof err);
    if (rc == 0) {
        CHECK(size == SIM_SAMPLES_HEADER_SIZE + 12u * hdr.count + 4u);
        CHECK(hdr.version == SIM_SAMPLES_VERSION);
        CHECK(isfinite(hdr.min_x) && isfinite(hdr.min_y) && isfinite(hdr.max_x) && isfinite(hdr.max_y));
        CHECK(hdr.max_x > hdr.min_x && hdr.max_y > hdr.min_y);
        CHECK(memchr(hdr.source, '\0', sizeof hdr.source) != NULL);
        CHECK((hdr.count == 0) == (rec == NULL));
        for (uint64_t i = 0; i < hdr.count; i++)
            CHECK(isfinite(rec[i].x) && isfinite(rec[i].y) && isfinite(rec[i].occ) && rec[i].x >= -1.0f &&
                  rec[i].x <= 1.0f && rec[i].y >= -1.0f && rec[i].y <= 1.0f && rec[i].occ >= 0.0f &&
                  rec[i].occ <= 1.0f);
        free(rec);
    } else {
        CHECK(rc < 0 && rec == NULL && err[0] != '\0');
    }
    close(fd);
    return 0;
}
