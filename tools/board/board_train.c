/* board_train: the firmware image of a board without a simulator. It runs the AI core's work
 * on the board's one thread: the robot's own AI core (fw_robot_ai_work) loads a bundled file
 * of samples into its pool and trains its DiNNO node for a fixed number of rounds, then runs
 * the 50-pass Monte-Carlo inference and the int8 inference, then the one-pass epistemic
 * uncertainty of the same points (bnn_post.h: the AI core's posterior over the model's initial
 * SIREN layer, the training samples summed in). It prints the loss of every round
 * and one `result <key> <value>` line per figure, which tools/board/board_check.py compares
 * with the host build of the same preset and tools/board/board_profile.py turns into the
 * board's profile.
 *
 * Every round has one neighbour: the node's own state at the start of the round (a view of
 * it, read in place), so the round runs the dual update and the regulariser like a round in a
 * fleet.
 * Instructions come from the target (hal_stdc_target.h): exact under QEMU's -icount on the
 * Cortex-M boards, printed here; on a Linux board QEMU's plugin logs the count at marks around
 * the same work, which the profile pairs.
 *
 * The whole robot firmware is linked (the board's build keeps every module's static state),
 * so the image's sections are those of the robot. Built for the host too (make run-board
 * builds both), as the reference the board's losses must match. */
#include <errno.h>
#include <inttypes.h> /* PRIu32; newlib 3.3 (Debian) prints neither PRIu64 under
                       * -std=c11 nor %zu (no C99 formats): %llu and %lu with casts */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "ai/bnn_quant.h"
#include "board_args.h"
#include "fw_robot.h"
#include "gp/gp_fleet.h"
#include "hal_stdc.h"
#include "hal_stdc_target.h"
#include "heap_probe.h"

/* Marks around the measured work, for a counter outside the program (hal_stdc_target_mark;
 * tools/board/board_profile.py pairs them: begin = end - 1). */
enum {
    MARK_ROUND_BEGIN = 10, MARK_ROUND_END = 11, MARK_MC_BEGIN = 20, MARK_MC_END = 21,
    MARK_FP32_BEGIN = 30, MARK_FP32_END = 31, MARK_INT8_BEGIN = 40, MARK_INT8_END = 41,
    MARK_POST_BEGIN = 50, MARK_POST_END = 51, MARK_FACTOR_BEGIN = 60, MARK_FACTOR_END = 61,
    MARK_OBSERVE_BEGIN = 70, MARK_OBSERVE_END = 71,
};

/* Inference points: one forward batch of the preset at most. */
#define TRAIN_POINTS_MAX (BNN_MAX_BATCH < 256u ? BNN_MAX_BATCH : 256u)

typedef struct train_opts {
    uint32_t rounds, steps, batch, mc, points, rt_hz, gp_hz;
    float kl_weight;
    uint64_t seed;
    const char *samples, *dir;
} train_opts_t;

static float xy[2u * TRAIN_POINTS_MAX], mean_p[TRAIN_POINTS_MAX], std_p[TRAIN_POINTS_MAX];
static float logit_fp32[TRAIN_POINTS_MAX], logit_int8[TRAIN_POINTS_MAX];
static float logit_post[TRAIN_POINTS_MAX], unknown_post[TRAIN_POINTS_MAX];
static uint8_t packed[BNN_QUANT_MAX_BYTES];
static void usage(FILE *to)
{
    fprintf(to,
            "usage: board_train [options]\n"
            "Trains the AI core of the firmware image on a bundled sample file and measures it.\n\n"
            "  --samples NAME   sample blob in storage: raw x, y, occ float32 records (default\n"
            "                   train_samples.bin)\n"
            "  --dir DIR        storage directory (default: the current one)\n"
            "  --rounds R       DiNNO rounds (default 10)\n"
            "  --steps B        optimiser steps per round (default 5)\n"
            "  --batch N        minibatch (default min(64, preset max %u))\n"
            "  --kl-weight W    prior KL weight (default 5e-3)\n"
            "  --mc K           Monte-Carlo passes of the inference (default 50)\n"
            "  --points P       points of the inference, 1..%u (default 64)\n"
            "  --seed S         seed of the model and of its noise (default 1)\n"
            "  --rt-hz HZ       the RT core's rate while the AI trains: its wake-ups are timed\n"
            "                   (default %u; 0: not started). Needs the target's scheduler\n"
            "                   (Cortex-M); elsewhere the AI work runs alone\n"
            "  --gp-hz HZ       the same for the GP core (default %u)\n",
            (unsigned)BNN_MAX_BATCH, (unsigned)TRAIN_POINTS_MAX, (unsigned)(1000000u / FW_RT_PERIOD_US),
            (unsigned)(1000000u / FW_GP_PERIOD_US));
}

static int parse_opts(int argc, char **argv, train_opts_t *o)
{
    *o = (train_opts_t){.rounds = 10, .steps = 5, .batch = BNN_MAX_BATCH < 64u ? BNN_MAX_BATCH : 64u,
                        .mc = 50, .points = 64, .kl_weight = 5e-3f, .seed = 1,
                        .rt_hz = 1000000u / FW_RT_PERIOD_US, .gp_hz = 1000000u / FW_GP_PERIOD_US,
                        .samples = "train_samples.bin", .dir = ""};
    for (int i = 1; i < argc; i += 2) { /* every option takes a value (--help ends here) */
        const char *a = argv[i], *v = i + 1 < argc ? argv[i + 1] : NULL;
        uint32_t seed;
        int r = 0;
        if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0) {
            usage(stdout);
            exit(0);
        } else if (strcmp(a, "--rounds") == 0) {
            r = board_parse_u32(v, 1, 100000, &o->rounds);
        } else if (strcmp(a, "--steps") == 0) {
            r = board_parse_u32(v, 1, 10000, &o->steps);
        } else if (strcmp(a, "--batch") == 0) {
            r = board_parse_u32(v, 1, BNN_MAX_BATCH, &o->batch);
        } else if (strcmp(a, "--mc") == 0) {
            r = board_parse_u32(v, 1, 1000, &o->mc);
        } else if (strcmp(a, "--points") == 0) {
            r = board_parse_u32(v, 1, TRAIN_POINTS_MAX, &o->points);
        } else if (strcmp(a, "--rt-hz") == 0) {
            r = board_parse_u32(v, 0, 10000, &o->rt_hz);
        } else if (strcmp(a, "--gp-hz") == 0) {
            r = board_parse_u32(v, 0, 10000, &o->gp_hz);
        } else if (strcmp(a, "--seed") == 0) {
            r = board_parse_u32(v, 0, UINT32_MAX, &seed);
            o->seed = seed;
        } else if (strcmp(a, "--kl-weight") == 0) {
            char *end;
            o->kl_weight = v != NULL ? strtof(v, &end) : -1.0f;
            r = v != NULL && *v != '\0' && *end == '\0' && isfinite(o->kl_weight) && o->kl_weight >= 0.0f ? 0 : -EINVAL;
        } else if (strcmp(a, "--samples") == 0 && v != NULL) {
            o->samples = v;
        } else if (strcmp(a, "--dir") == 0 && v != NULL) {
            o->dir = v;
        } else {
            fprintf(stderr, "board_train: unknown option '%s' (see --help)\n", a);
            return -EINVAL;
        }
        if (r != 0) {
            fprintf(stderr, "board_train: bad value for %s: '%s' (see --help)\n", a, v ? v : "");
            return -EINVAL;
        }
    }
    return 0;
}

/* Reads the sample blob into the pool's storage and checks every record. Returns the count. */
static int load_samples(ai_core_t *ai, const char *name, uint32_t *n_out)
{
    size_t len = 0;
    int r = hal_storage_read(name, ai->pool_data, sizeof ai->pool_data, &len);
    if (r == -EMSGSIZE) {
        fprintf(stderr, "board_train: %s holds %lu samples, more than the pool's %u (AI_POOL_CAPACITY)\n",
                name, (unsigned long)(len / sizeof(ai_sample_t)), (unsigned)AI_POOL_CAPACITY);
        return r;
    }
    if (r != 0) {
        fprintf(stderr, "board_train: cannot read %s: %s\n", name, strerror(-r));
        return r;
    }
    if (len == 0 || len % sizeof(ai_sample_t) != 0) {
        fprintf(stderr, "board_train: %s: %lu bytes is not a whole number of 12-byte samples\n", name,
                (unsigned long)len);
        return -EINVAL;
    }
    uint32_t n = (uint32_t)(len / sizeof(ai_sample_t));
    for (uint32_t i = 0; i < n; i++) {
        const ai_sample_t *s = &ai->pool_data[i];
        if (!(fabsf(s->x) <= 1.0f && fabsf(s->y) <= 1.0f && (s->occ == 0.0f || s->occ == 1.0f))) {
            fprintf(stderr, "board_train: %s: sample %" PRIu32 " is out of range (x, y in [-1, 1], occ 0 or 1)\n",
                    name, i);
            return -EINVAL;
        }
    }
    /* The records are already in the pool's storage: the pool takes them as its content. */
    ai->pool.fill = n;
    *n_out = n;
    return 0;
}

/* A core started beside the AI work (which runs on the main program, below every core): at its
 * period it wakes, and how late each wake-up came is what it keeps. The RT core's control loop
 * needs the world's scans and wheels (hardware in the loop, not here), so what is measured is
 * the slot the core's tick runs in: the scheduler's wake-up latency and the deadlines missed
 * while the AI core trains. */
typedef struct timed_core {
    hal_core_id_t id;
    uint32_t period_us;
    int started;
    volatile uint64_t ticks, misses, late_sum_ns, late_max_ns;
} timed_core_t;

static timed_core_t timed[2];

static void timed_entry(void *arg)
{
    timed_core_t *c = arg;
    uint64_t start = 0;
    if (hal_clock_now_us(&start) != 0)
        return;
    start -= start % c->period_us; /* released at whole periods of the board's time, as a
                                      scheduler's tick falls: the lateness is the switch's */
    for (uint64_t k = 1;; k++) {
        const uint64_t due = start + k * c->period_us;
        if (hal_sleep_until_us(due) != 0)
            return;
        const uint64_t now_ns = hal_stdc_target_now_ns(), due_ns = due * 1000u;
        const uint64_t late = now_ns > due_ns ? now_ns - due_ns : 0;
        c->late_sum_ns += late;
        if (late > c->late_max_ns)
            c->late_max_ns = late;
        if (late >= 1000u * (uint64_t)c->period_us) /* woke after its next tick was due: one lost */
            c->misses++;
        c->ticks++;
    }
}

static void start_timed(timed_core_t *c, hal_core_id_t id, uint32_t hz)
{
    c->id = id;
    c->period_us = hz > 0 ? 1000000u / hz : 0;
    if (hz == 0)
        return;
    const int r = hal_core_start(id, timed_entry, c);
    if (r == 0)
        c->started = 1;
    else if (r == -ENOTSUP)
        printf("board_train: target %s has no scheduler: the %s core is not started, the AI work runs alone\n",
               hal_stdc_target_name(), hal_core_name(id));
    else
        fprintf(stderr, "board_train: the %s core did not start (%d)\n", hal_core_name(id), r);
}

static void print_timed(const timed_core_t *c)
{
    if (!c->started)
        return;
    const char *n = c->id == HAL_CORE_RT ? "rt" : "gp";
    size_t used = 0, size = 0;
    printf("result %s_period_us %lu\n", n, (unsigned long)c->period_us);
    printf("result %s_ticks %llu\n", n, (unsigned long long)c->ticks);
    printf("result %s_late_mean_ns %.0f\n", n, c->ticks > 0 ? (double)c->late_sum_ns / (double)c->ticks : 0.0);
    printf("result %s_late_max_ns %llu\n", n, (unsigned long long)c->late_max_ns);
    printf("result %s_deadline_misses %llu\n", n, (unsigned long long)c->misses);
    if (hal_core_stack_high_water(c->id, &used, &size) == 0)
        printf("result stack_%s_used %lu of %lu\n", n, (unsigned long)used, (unsigned long)size);
}

/* Instructions since start, or 0 where the target does not count them. */
static uint64_t insns(void)
{
    uint64_t n = 0;
    return hal_stdc_target_instructions(&n) == 0 ? n : 0;
}

static float sigmoidf(float z)
{
    return 1.0f / (1.0f + expf(-z));
}

int main(int argc, char **argv)
{
    train_opts_t o;
    if (parse_opts(argc, argv, &o) != 0)
        return 2;
    int r = hal_stdc_install(o.dir);
    if (r != 0) {
        fprintf(stderr, "board_train: cannot install the board (%d)\n", r);
        return 1;
    }
    /* The image's fleet exchange (fw_robot_fleet) is linked and counted (its RAM is the
       board's), but this program has no fleet to talk to: it stays empty. */
    memset(fw_robot_fleet(), 0, sizeof *fw_robot_fleet());
    ai_core_t *ai = fw_robot_ai_work();
    ai_core_cfg_t cfg = ai_core_default_cfg();
    cfg.rounds = o.rounds;
    cfg.model_seed = cfg.seed = o.seed;
    cfg.dinno.primal_steps = o.steps;
    cfg.dinno.batch = o.batch;
    cfg.dinno.kl_weight = o.kl_weight;
    fw_link_reset();
    if ((r = ai_core_init(ai, &cfg, fw_link_get())) != 0) {
        fprintf(stderr, "board_train: AI core configuration refused (%d)\n", r);
        return 1;
    }
    bnn_model_t *m = &ai->node.model;
    /* The epistemic posterior: the AI core's own (static, in its state), made over the freshly
       initialised model's SIREN layer, before any training step (ai_core_init made it so
       already; made again here so the harness does not depend on it). */
    if ((r = bnn_post_init(&ai->post, m)) != 0) {
        fprintf(stderr, "board_train: posterior refused (%d)\n", r);
        return 1;
    }
    uint32_t n = 0;
    if (load_samples(ai, o.samples, &n) != 0)
        return 1;
    size_t n_params = bnn_n_params(m);

    printf("board_train: board %s, target %s, preset %s (%lu parameters), math %s\n", BOARD_NAME,
           hal_stdc_target_name(), BNN_PRESET_NAME, (unsigned long)n_params,
#if defined(LA_BACKEND_EIGEN)
           "eigen"
#else
           "ref"
#endif
    );
    printf("board_train: %" PRIu32 " samples, %" PRIu32 " rounds x %" PRIu32 " steps, batch %" PRIu32
           ", kl_weight %g, seed %llu\n",
           n, o.rounds, o.steps, o.batch, (double)o.kl_weight, (unsigned long long)o.seed);

    /* After the first output: the C library's stdout buffer is part of init. */
    uint64_t heap_init = heap_probe_in_use();
    start_timed(&timed[0], HAL_CORE_RT, o.rt_hz);
    start_timed(&timed[1], HAL_CORE_GP, o.gp_hz);
    uint64_t train_insns = 0, round_max = 0;
    dinno_round_stats_t st = {0};
    for (uint32_t k = 0; k < o.rounds; k++) {
        /* One neighbour: the model itself, read in place (the screen, the dual update and the
           neighbour sums all read it before the round's first step changes it). */
        const dinno_nbrs_t self_view = {.round = k, .count = 1, .id = {0}, .theta = {bnn_params_const(m)}};
        if ((r = dinno_node_set_nbrs(&ai->node, &self_view)) != 0)
            break;
        uint64_t t0 = insns();
        hal_stdc_target_mark(MARK_ROUND_BEGIN);
        r = dinno_node_round(&ai->node, ai->pool_data, n, &st);
        hal_stdc_target_mark(MARK_ROUND_END);
        uint64_t dt = insns() - t0;
        if (r != 0)
            break;
        train_insns += dt;
        round_max = dt > round_max ? dt : round_max;
        printf("round %" PRIu32 " loss %.6f bce %.6f kl %.3f insn %llu\n", k, (double)st.pred_total,
               (double)st.bce, (double)st.kl_prior, (unsigned long long)dt);
    }
    if (r != 0) {
        fprintf(stderr, "board_train: training failed (%d)\n", r);
        return 1;
    }

    /* Inference on the first points of the file. */
    for (uint32_t i = 0; i < o.points; i++) {
        const ai_sample_t *s = &ai->pool_data[(uint64_t)i * n / o.points];
        xy[2u * i] = s->x;
        xy[2u * i + 1u] = s->y;
    }
    uint64_t t0 = insns();
    hal_stdc_target_mark(MARK_MC_BEGIN);
    r = bnn_predict_mc(m, xy, o.points, o.mc, o.seed, mean_p, std_p);
    hal_stdc_target_mark(MARK_MC_END);
    uint64_t mc_insns = insns() - t0;
    t0 = insns();
    hal_stdc_target_mark(MARK_FP32_BEGIN);
    if (r == 0)
        r = bnn_forward_logits(m, xy, o.points, 1, 0, logit_fp32);
    hal_stdc_target_mark(MARK_FP32_END);
    uint64_t fp32_insns = insns() - t0;
    size_t packed_len = 0;
    if (r == 0)
        r = bnn_quant_pack(m, BNN_GROUP_MU, packed, sizeof packed, &packed_len);
    t0 = insns();
    hal_stdc_target_mark(MARK_INT8_BEGIN);
    if (r == 0)
        r = bnn_quant_forward_mean(&m->cfg, BNN_GROUP_MU, packed, packed_len, xy, o.points, logit_int8);
    hal_stdc_target_mark(MARK_INT8_END);
    uint64_t int8_insns = insns() - t0;
    if (r != 0) {
        fprintf(stderr, "board_train: inference failed (%d)\n", r);
        return 1;
    }

    /* The one-pass uncertainty of the same points: every training sample summed into the
       posterior (what the AI core does as samples arrive; the model's activations are its
       scratch), the factor (once per map, not per point: marked apart), then the marked
       prediction, the mean-weight logits and the share of prior variance left per point:
       what replaces the 50 passes' mean and std. */
    t0 = insns();
    hal_stdc_target_mark(MARK_OBSERVE_BEGIN);
    r = bnn_post_observe_samples(&ai->post, m, ai->pool_data, n);
    hal_stdc_target_mark(MARK_OBSERVE_END);
    uint64_t observe_insns = insns() - t0;
    t0 = insns();
    hal_stdc_target_mark(MARK_FACTOR_BEGIN);
    if (r == 0)
        r = bnn_post_factor(&ai->post);
    hal_stdc_target_mark(MARK_FACTOR_END);
    uint64_t factor_insns = insns() - t0;
    t0 = insns();
    hal_stdc_target_mark(MARK_POST_BEGIN);
    if (r == 0)
        r = bnn_post_predict(&ai->post, m, xy, o.points, logit_post, unknown_post);
    hal_stdc_target_mark(MARK_POST_END);
    uint64_t post_insns = insns() - t0;
    if (r != 0) {
        fprintf(stderr, "board_train: one-pass uncertainty failed (%d)\n", r);
        return 1;
    }
    double sigma = 0.0, dp_max = 0.0, unknown_sum = 0.0, dlogit_max = 0.0;
    float unknown_min = INFINITY, unknown_max = 0.0f;
    for (uint32_t i = 0; i < o.points; i++) {
        sigma += std_p[i];
        double dp = fabs((double)sigmoidf(logit_fp32[i]) - (double)sigmoidf(logit_int8[i]));
        dp_max = dp > dp_max ? dp : dp_max;
        double dl = fabs((double)logit_post[i] - (double)logit_fp32[i]);
        dlogit_max = dl > dlogit_max ? dl : dlogit_max;
        unknown_sum += unknown_post[i];
        unknown_min = unknown_post[i] < unknown_min ? unknown_post[i] : unknown_min;
        unknown_max = unknown_post[i] > unknown_max ? unknown_post[i] : unknown_max;
        /* %e: the shares of well observed points are small, their digits are what is compared */
        printf("post %" PRIu32 " p %.6f unknown %.6e\n", i, (double)sigmoidf(logit_post[i]),
               (double)unknown_post[i]);
    }
    float val_bce = NAN;
    if (bnn_eval_bce(m, ai->pool_data, n, 0, 0, &val_bce) != 0)
        return 1;

    /* Static memory of the robot image (exact sizes), and the model arena split as TFLM
     * reports its own: persistent (parameters, gradients, Adam moments) and scratch (sampled
     * weights, noise, sigma, activations of one batch). */
    fw_robot_memory_t mem;
    fw_robot_memory(&mem);
    const size_t persistent = 4u * (size_t)BNN_N_PARAMS * sizeof(float);
    printf("result mem_rt_state %lu\n", (unsigned long)mem.rt_state);
    printf("result mem_rt_links %lu\n", (unsigned long)mem.rt_links);
    printf("result mem_ai_state %lu\n", (unsigned long)mem.ai_state);
    printf("result mem_ai_node %lu\n", (unsigned long)mem.ai_node);
    printf("result mem_ai_pool %lu\n", (unsigned long)mem.ai_pool);
    printf("result mem_ai_links %lu\n", (unsigned long)mem.ai_links);
    printf("result mem_gp_state %lu\n", (unsigned long)mem.gp_state);
    printf("result mem_gp_links %lu\n", (unsigned long)mem.gp_links);
    printf("result mem_gp_fleet %lu\n", (unsigned long)mem.gp_fleet);
    printf("result arena_bytes %lu\n", (unsigned long)mem.ai_model_arena);
    printf("result arena_persistent_bytes %lu\n", (unsigned long)persistent);
    printf("result arena_scratch_bytes %lu\n", (unsigned long)(mem.ai_model_arena - persistent));

    size_t stack_used = 0, stack_size = 0;
    int have_stack = hal_stdc_target_stack(&stack_used, &stack_size) == 0;
    printf("result loss_final %.6f\n", (double)st.pred_total);
    printf("result bce_final %.6f\n", (double)st.bce);
    printf("result bce_all_mean_weights %.6f\n", (double)val_bce);
    printf("result sigma_mean_mc %.6f\n", sigma / o.points);
    printf("result int8_max_abs_prob_diff %.6f\n", dp_max);
    printf("result unknown_mean_post %.6e\n", unknown_sum / o.points);
    printf("result unknown_min_post %.6e\n", (double)unknown_min);
    printf("result unknown_max_post %.6e\n", (double)unknown_max);
    printf("result post_logit_max_abs_diff %.6e\n", dlogit_max);
    printf("result post_observed %.0f\n", ai->post.n_obs);
    printf("result post_dim %lu\n", (unsigned long)ai->post.dim);
    printf("result post_bytes %lu\n", (unsigned long)BNN_POST_BYTES);
    printf("result int8_packed_bytes %lu\n", (unsigned long)packed_len);
    printf("result parameters %lu\n", (unsigned long)n_params);
    printf("result parameters_mean %lu\n", (unsigned long)bnn_group_len(m, BNN_GROUP_MU));
    printf("result net_siren %lu\n", (unsigned long)m->cfg.siren_width);
    printf("result net_hidden %lu\n", (unsigned long)m->cfg.hidden_width);
    printf("result net_layers %lu\n", (unsigned long)m->cfg.n_bayes);
    printf("result steps %" PRIu32 "\n", o.rounds * o.steps);
    printf("result batch %" PRIu32 "\n", o.batch);
    printf("result mc_passes %" PRIu32 "\n", o.mc);
    printf("result points %" PRIu32 "\n", o.points);
    if (train_insns > 0) {
        printf("result insn_train_step %llu\n", (unsigned long long)(train_insns / ((uint64_t)o.rounds * o.steps)));
        printf("result insn_round_max %llu\n", (unsigned long long)(round_max));
        printf("result insn_mc_inference %llu\n", (unsigned long long)(mc_insns));
        printf("result insn_fp32_inference %llu\n", (unsigned long long)(fp32_insns));
        printf("result insn_int8_inference %llu\n", (unsigned long long)(int8_insns));
        printf("result insn_post_observe %llu\n", (unsigned long long)(observe_insns));
        printf("result insn_post_factor %llu\n", (unsigned long long)(factor_insns));
        printf("result insn_post_inference %llu\n", (unsigned long long)(post_insns));
    }
    if (have_stack)
        printf("result stack_main_used %lu of %lu\n", (unsigned long)stack_used, (unsigned long)stack_size);
    print_timed(&timed[0]);
    print_timed(&timed[1]);
    printf("result heap_in_use_after_init %llu\n", (unsigned long long)(heap_init));
    printf("result heap_growth_after_init %lld\n", (long long)(heap_probe_in_use() - heap_init));
    hal_stdc_uninstall();
    return 0;
}
