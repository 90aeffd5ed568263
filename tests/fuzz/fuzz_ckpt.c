/* Fuzz target: the checkpoint loader (firmware/ai/bnn_ckpt.c, bnn_ckpt_load_post, so the
 * epistemic posterior's reader too) into a model of
 * the smallest configuration (fuzz_config.h), initialised once. Beyond memory safety it checks
 * the contract of bnn_ckpt.h: a refused checkpoint leaves the model untouched and gives one of
 * the documented codes with a reason; an accepted one holds the payload's values exactly, and
 * what bnn_ckpt_save then writes loads again. An accepted input changes the model's parameters,
 * seed and Adam state, which the next input never reads (the loader validates against the
 * configuration only); they are put back after each input all the same, so that nothing of an
 * input reaches the next one. The posterior is refused or taken whole like the rest: a refused
 * input leaves it untouched, an accepted one is written back byte for byte. */
#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ai/bnn.h"
#include "ai/bnn_ckpt.h"
#include "ai/bnn_post.h"
#include "fuzz/fuzz_config.h"

static bnn_model_t g_model;
/* What a load may change: theta, gradients and the Adam moments (4 x n_params floats, the
   arena's start), the seed and the Adam states; as bnn_init left them. */
#define FUZZ_MAX_P 64u
static float g_theta0[4u * FUZZ_MAX_P];
static uint64_t g_seed0;
static bnn_adam_t g_adam0[2];
static uint8_t g_out[BNN_CKPT_MAX_BYTES];
static bnn_post_t g_post, g_post0;

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc;
    (void)argv;
    bnn_config_t cfg = bnn_default_config();
    cfg.siren_width = FUZZ_CKPT_SIREN;
    cfg.hidden_width = FUZZ_CKPT_HIDDEN;
    cfg.n_bayes = FUZZ_CKPT_LAYERS;
    cfg.max_batch = 4;
    if (bnn_init(&g_model, &cfg, FUZZ_CKPT_SEED) != 0 || g_model.n_params > FUZZ_MAX_P) {
        fprintf(stderr, "fuzz_ckpt: cannot set up the model\n");
        exit(1);
    }
    memcpy(g_theta0, g_model.arena, sizeof(float) * 4u * g_model.n_params);
    g_seed0 = g_model.seed;
    memcpy(g_adam0, g_model.adam, sizeof g_adam0);
    if (bnn_post_init(&g_post, &g_model) != 0) {
        fprintf(stderr, "fuzz_ckpt: cannot set up the posterior\n");
        exit(1);
    }
    memcpy(&g_post0, &g_post, sizeof g_post);
    return 0;
}

static int model_is_initial(void)
{
    return memcmp(g_theta0, g_model.arena, sizeof(float) * 4u * g_model.n_params) == 0 && g_model.seed == g_seed0 &&
           memcmp(g_adam0, g_model.adam, sizeof g_adam0) == 0;
}

static uint32_t le32(const uint8_t *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    const size_t P = g_model.n_params;
    const bnn_config_t cfg = g_model.cfg;
    const char *why = NULL;
    const int rc = bnn_ckpt_load_post(&g_model, &g_post, data, size, &why);
    CHECK(why != NULL && memcmp(&cfg, &g_model.cfg, sizeof cfg) == 0 && g_model.n_params == P);
    if (rc != 0) {
        CHECK(rc == -ENODATA || rc == -EBADMSG || rc == -EPROTONOSUPPORT || rc == -ENOEXEC || rc == -EILSEQ);
        CHECK(model_is_initial());
        CHECK(memcmp(&g_post, &g_post0, sizeof g_post) == 0);
        return 0;
    }
    const int with_adam = (le32(data + 48) & BNN_CKPT_FLAG_ADAM) != 0;
    const int with_post = (le32(data + 48) & BNN_CKPT_FLAG_POST) != 0;
    CHECK(with_post ? g_post.dim == cfg.siren_width + 1u && g_post.n_obs >= 0.0 && g_post.robots >= 0.0
                    : g_post.robots == 0.0);
    const float *th = bnn_params_const(&g_model);
    for (size_t i = 0; i < P; i++) {
        CHECK(isfinite(th[i]) && memcmp(&th[i], data + BNN_CKPT_HEADER_BYTES + 4 * i, 4) == 0);
        if (with_adam)
            CHECK(th[3 * P + i] >= 0.0f);
    }
    size_t n = 0;
    const bnn_post_t *post = with_post ? &g_post : NULL;
    CHECK(bnn_ckpt_save_post(&g_model, with_adam, post, g_out, sizeof g_out, &n) == 0);
    CHECK(n <= size && n == bnn_ckpt_size_post(&g_model, with_adam, post));
    /* The payload and the seed come back as they were. */
    CHECK(memcmp(g_out + BNN_CKPT_HEADER_BYTES, data + BNN_CKPT_HEADER_BYTES, n - BNN_CKPT_HEADER_BYTES) == 0);
    CHECK(memcmp(g_out + 32, data + 32, 8) == 0);
    CHECK(bnn_ckpt_load_post(&g_model, &g_post, g_out, n, &why) == 0);
    memcpy(&g_post, &g_post0, sizeof g_post);
    memcpy(g_model.arena, g_theta0, sizeof(float) * 4u * P);
    g_model.seed = g_seed0;
    memcpy(g_model.adam, g_adam0, sizeof g_adam0);
    return 0;
}
