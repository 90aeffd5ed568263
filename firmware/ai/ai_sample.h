/* One labelled training point: the unit of data from the RT core's scan processing to the
 * AI core's sample pool, and the record of host_sim's sample files.
 *
 * x, y: position normalised to [-1, 1] over the floor plan's bounding box (docs/architecture.md section 2):
 *       x_n = 2 * (x_m - min_x) / (max_x - min_x) - 1, likewise y.
 * occ:  0.0f free, 1.0f occupied (a lidar hit). */
#ifndef AI_SAMPLE_H
#define AI_SAMPLE_H

typedef struct ai_sample {
    float x;
    float y;
    float occ;
} ai_sample_t;

_Static_assert(sizeof(ai_sample_t) == 12, "ai_sample_t is a 12-byte wire/file record");

#endif /* AI_SAMPLE_H */
