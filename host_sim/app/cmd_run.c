/* host_sim run: one robot's firmware image (RT, AI, GP cores as threads) against the ODE
 * world in lockstep, learning online by communication rounds. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "ai/bnn_ckpt.h"
#include "hal_host_file.h"
#include "cli.h"
#include "commands.h"
#include "sim_fleet.h"
#include "sim_maps.h"
#include "sim_image.h"
#include "sim_paths.h"
#include "sim_plan.h"
#include "sim_samples.h"
#include "sim_valset.h"

static void run_usage(FILE *out)
{
    const dinno_cfg_t d = dinno_default_cfg();
    fprintf(out,
            "usage: host_sim run --plan FILE.svg --path FILE.csv --out DIR [options]\n"
            "\n"
            "Runs ONE robot's firmware image in this process: the RT core (50 Hz control, 10 Hz scans\n"
            "-> samples -> ring), the AI core (sample pool, BNN preset '%s', DiNNO node update) and the\n"
            "GP core (round coordination, telemetry, checkpoints) as three threads on the host HAL, in\n"
            "lockstep with the ODE world. The path is split into C communication rounds of equal length;\n"
            "at each boundary the AI core trains B optimiser steps on its pool (a single robot has no\n"
            "neighbours: local DiNNO rounds).\n"
            "\n"
            "Writes into DIR: metrics.csv (round,sim_time_s,distance_m,progress_m,pool_fill,pool_capacity,\n"
            "ring_drops,train_loss,bce,val_loss,kl), round_NNNN.bnn (each round's checkpoint, from the GP\n"
            "core's storage), final.bnn, valset.samples, map_mean.png and map_std.png (MC mean / std of\n"
            "the final model, path on top), profile.txt and profile.csv (per core: ticks, lateness, wall\n"
            "time per tick, stack high-water; static memory per core), summary.txt.\n"
            "\n"
            "options:\n"
            "  --online             learn online by communication rounds (the only mode; accepted for clarity)\n"
            "  --rounds C           communication rounds (default 8)\n"
            "  --pool cdr|dr        cumulative data retention (default) or data refresh per round\n"
            "  --seed S             run seed (default 1): noise, weights, minibatches, reservoir\n"
            "  --steps-per-round B  optimiser steps per round (default %u)\n"
            "  --kl-weight W        weight of the BNN prior KL (default %g)\n"
            "  --batch N            minibatch size (default %u, <= %u)\n"
            "  --lr-start V, --lr-end V   log-decaying learning rate over the rounds (default %g -> %g)\n"
            "  --train-between      one more optimiser step per AI tick between boundaries\n"
            "  --time-limit S       simulated seconds before giving up (default 1800)\n"
            "  --robot I            robot index (noise streams, telemetry channel; default 0)\n"
            "  --net URL            LCM URL for telemetry (default memq://, in-process; 'none' for none)\n"
            "  --sched serial|parallel   lockstep release order (default serial: bit-reproducible)\n"
            "  --val-poses N        validation poses x 500 points (default 500; 0: no validation)\n"
            "  --map-res M          map grid in metres (default 0.1); --mc K passes (default 50)\n"
            "  --no-maps            skip the PNG maps\n"
            "  --quiet              firmware log at WARN (default INFO: a line per round)\n"
            "  --scale S            plan metres per pixel (default %g)\n",
            BNN_PRESET_NAME, d.primal_steps, (double)d.kl_weight, d.batch, BNN_MAX_BATCH,
            (double)d.lr_start, (double)d.lr_end, SIM_PLAN_DEFAULT_SCALE);
}

typedef struct run_opts {
    const char *plan, *path, *out, *net;
    long long rounds, seed, steps, robot, val_poses, mc, batch;
    double kl_weight, time_limit, map_res, scale, lr_start, lr_end;
    ai_pool_policy_t pool;
    hal_host_sched_t sched;
    int train_between, no_maps, quiet;
} run_opts_t;

static int parse(int argc, char **argv, run_opts_t *o)
{
    const dinno_cfg_t d = dinno_default_cfg();
    memset(o, 0, sizeof *o);
    o->rounds = 8;
    o->seed = 1;
    o->steps = d.primal_steps;
    o->batch = d.batch;
    o->kl_weight = d.kl_weight;
    o->lr_start = d.lr_start;
    o->lr_end = d.lr_end;
    o->time_limit = 1800;
    o->val_poses = 500;
    o->mc = 50;
    o->map_res = 0.1;
    o->scale = SIM_PLAN_DEFAULT_SCALE;
    o->net = "memq://";
    o->pool = AI_POOL_CDR;
    o->sched = HAL_HOST_SCHED_SERIAL;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0) {
            run_usage(stdout);
            return 1;
        }
        if (strcmp(a, "--online") == 0)
            continue;
        if (strcmp(a, "--train-between") == 0) {
            o->train_between = 1;
            continue;
        }
        if (strcmp(a, "--no-maps") == 0) {
            o->no_maps = 1;
            continue;
        }
        if (strcmp(a, "--quiet") == 0) {
            o->quiet = 1;
            continue;
        }
        if (strncmp(a, "--", 2) != 0) {
            fprintf(stderr, "host_sim run: unexpected argument '%s'\n", a);
            return -1;
        }
        if (cmd_need_value(argc, argv, i, "run", run_usage) != 0)
            return -1;
        const char *v = argv[++i];
        int bad = 0;
        if (strcmp(a, "--plan") == 0)
            o->plan = v;
        else if (strcmp(a, "--path") == 0)
            o->path = v;
        else if (strcmp(a, "--out") == 0)
            o->out = v;
        else if (strcmp(a, "--net") == 0)
            o->net = strcmp(v, "none") == 0 ? NULL : v;
        else if (strcmp(a, "--rounds") == 0)
            bad = cmd_parse_ll(v, a, 1, GP_CORE_LOG_ROUNDS, &o->rounds);
        else if (strcmp(a, "--seed") == 0)
            bad = cmd_parse_ll(v, a, 0, 0x7FFFFFFFFFFFFFFFLL, &o->seed);
        else if (strcmp(a, "--steps-per-round") == 0)
            bad = cmd_parse_ll(v, a, 1, 1000000, &o->steps);
        else if (strcmp(a, "--batch") == 0)
            bad = cmd_parse_ll(v, a, 1, BNN_MAX_BATCH, &o->batch);
        else if (strcmp(a, "--robot") == 0)
            bad = cmd_parse_ll(v, a, 0, 1000000, &o->robot);
        else if (strcmp(a, "--val-poses") == 0)
            bad = cmd_parse_ll(v, a, 0, 100000, &o->val_poses);
        else if (strcmp(a, "--mc") == 0)
            bad = cmd_parse_ll(v, a, 1, 1000, &o->mc);
        else if (strcmp(a, "--kl-weight") == 0)
            bad = cmd_parse_double(v, a, 0.0, 1e6, &o->kl_weight);
        else if (strcmp(a, "--lr-start") == 0)
            bad = cmd_parse_double(v, a, 1e-12, 10.0, &o->lr_start);
        else if (strcmp(a, "--lr-end") == 0)
            bad = cmd_parse_double(v, a, 1e-12, 10.0, &o->lr_end);
        else if (strcmp(a, "--time-limit") == 0)
            bad = cmd_parse_double(v, a, 0.1, 1e6, &o->time_limit);
        else if (strcmp(a, "--map-res") == 0)
            bad = cmd_parse_double(v, a, 0.01, 10.0, &o->map_res);
        else if (strcmp(a, "--scale") == 0)
            bad = cmd_parse_double(v, a, 1e-6, 100.0, &o->scale);
        else if (strcmp(a, "--pool") == 0) {
            if (ai_pool_policy_parse(v, &o->pool) != 0) {
                fprintf(stderr, "host_sim run: --pool: '%s' is not cdr or dr\n", v);
                bad = 1;
            }
        } else if (strcmp(a, "--sched") == 0) {
            if (strcmp(v, "serial") == 0)
                o->sched = HAL_HOST_SCHED_SERIAL;
            else if (strcmp(v, "parallel") == 0)
                o->sched = HAL_HOST_SCHED_PARALLEL;
            else {
                fprintf(stderr, "host_sim run: --sched: '%s' is not serial or parallel\n", v);
                bad = 1;
            }
        } else {
            fprintf(stderr, "host_sim run: unknown option '%s' (see --help)\n", a);
            return -1;
        }
        if (bad)
            return -1;
    }
    const char *missing = !o->plan ? "--plan" : !o->path ? "--path" : !o->out ? "--out" : NULL;
    if (missing) {
        fprintf(stderr, "host_sim run: %s is required (see --help)\n", missing);
        return -1;
    }
    return 0;
}

typedef struct run_ctx {
    const run_opts_t *o;
    FILE *csv;
    bnn_model_t *model;
    const ai_sample_t *val;
    size_t n_val;
    int failed;
    double last_val;
} run_ctx_t;

static int load_ckpt(bnn_model_t *m, const char *file)
{
    FILE *f = NULL;
    int orc = hal_host_file_open_read(file, &f);
    if (orc < 0) {
        fprintf(stderr, "host_sim run: %s: %s\n", file, strerror(-orc));
        return orc;
    }
    static uint8_t buf[BNN_CKPT_MAX_BYTES];
    size_t n = fread(buf, 1, sizeof buf, f);
    fclose(f);
    const char *why = NULL;
    int rc = bnn_ckpt_load(m, buf, n, &why);
    if (rc != 0)
        fprintf(stderr, "host_sim run: %s: %s\n", file, why ? why : "invalid checkpoint");
    return rc;
}

static void on_round(const ai_round_info_t *in, void *user)
{
    run_ctx_t *c = user;
    double val = NAN;
    if (in->ckpt_status != 0) {
        /* A file of that name may be an earlier run's: never read it as this run's. */
        char name[64];
        gp_core_ckpt_name(in->round, name, sizeof name);
        fprintf(stderr, "host_sim run: %s/%s: %s\n", c->o->out, name, hal_host_file_strerror(in->ckpt_status));
        c->failed = 1;
    } else if (c->n_val > 0) {
        char file[4200], name[64];
        gp_core_ckpt_name(in->round, name, sizeof name);
        snprintf(file, sizeof file, "%s/%s", c->o->out, name);
        float v = NAN;
        if (load_ckpt(c->model, file) != 0 || bnn_eval_bce(c->model, c->val, c->n_val, 0, 0, &v) != 0)
            c->failed = 1;
        val = v;
    }
    c->last_val = val;
    printf("round %3u/%lld  t %7.1f s  progress %6.2f m  distance %6.2f m  pool %7u/%u  drops %u  "
           "train %.4f  val %.4f  kl %.2f\n",
           in->round + 1, c->o->rounds, (double)in->stamp_us * 1e-6, (double)in->progress_m,
           (double)in->distance_m, in->pool_fill, in->pool_capacity, in->ring_drops,
           (double)in->loss_train, val, (double)in->kl);
    fflush(stdout);
    fprintf(c->csv, "%u,%.3f,%.4f,%.4f,%u,%u,%u,%.6g,%.6g,%.6g,%.6g\n", in->round,
            (double)in->stamp_us * 1e-6, (double)in->distance_m, (double)in->progress_m, in->pool_fill,
            in->pool_capacity, in->ring_drops, (double)in->loss_train, (double)in->bce, val,
            (double)in->kl);
    fflush(c->csv);
}

static void write_profile(const run_opts_t *o, const sim_image_result_t *r, FILE *txt, FILE *csv)
{
    static const char *names[HAL_CORE_COUNT] = {"RT", "GP", "AI"};
    static const double hz[HAL_CORE_COUNT] = {1e6 / FW_RT_PERIOD_US, 1e6 / FW_GP_PERIOD_US,
                                              1e6 / FW_AI_PERIOD_US};
    const fw_robot_memory_t *m = &r->mem;
    const size_t mem_core[HAL_CORE_COUNT] = {m->rt_state + m->rt_links, m->gp_state + m->gp_links,
                                             m->ai_state + m->ai_links};
    if (csv)
        fprintf(csv, "core,rate_hz,ticks,late_ticks,lateness_max_us,wall_min_us,wall_mean_us,wall_max_us,"
                 "stack_used_bytes,stack_size_bytes,static_bytes\n");
    fprintf(txt, "host_sim run profile (board %s, preset %s, seed %lld, sched %s)\n", BOARD_NAME,
            BNN_PRESET_NAME, o->seed, o->sched == HAL_HOST_SCHED_SERIAL ? "serial" : "parallel");
    fprintf(txt, "simulated %.2f s in %.2f s wall (%.1f x real time); %llu physics steps\n\n",
            (double)r->sim_time_us * 1e-6, r->wall_s, (double)r->sim_time_us * 1e-6 / r->wall_s,
            (unsigned long long)r->host_world_steps);
    fprintf(txt, "%-4s %6s %9s %6s %12s %12s %12s %12s %22s %14s\n", "core", "Hz", "ticks", "late",
            "late_max_us", "wall_min_us", "wall_mean_us", "wall_max_us", "stack used/size (B)",
            "static (B)");
    for (int i = 0; i < HAL_CORE_COUNT; i++) {
        const hal_host_core_stats_t *s = &r->core[i];
        double mean = s->wall_ticks ? (double)s->wall_total_ns / (double)s->wall_ticks * 1e-3 : 0;
        double mn = s->wall_ticks ? (double)s->wall_min_ns * 1e-3 : 0;
        double mx = (double)s->wall_max_ns * 1e-3;
        if (csv)
            fprintf(csv, "%s,%g,%llu,%llu,%llu,%.3f,%.3f,%.3f,%zu,%zu,%zu\n", names[i], hz[i],
                (unsigned long long)s->ticks, (unsigned long long)s->late_ticks,
                (unsigned long long)s->lateness_max_us, mn, mean, mx, s->stack_used_bytes,
                s->stack_size_bytes, mem_core[i]);
        char stk[64];
        snprintf(stk, sizeof stk, "%zu/%zu", s->stack_used_bytes, s->stack_size_bytes);
        fprintf(txt, "%-4s %6g %9llu %6llu %12llu %12.1f %12.1f %12.1f %22s %14zu\n", names[i], hz[i],
                (unsigned long long)s->ticks, (unsigned long long)s->late_ticks,
                (unsigned long long)s->lateness_max_us, mn, mean, mx, stk, mem_core[i]);
    }
    fprintf(txt, "\nstatic memory (bytes, sizeof / _get_buffer_size):\n");
    fprintf(txt, "  RT  core state (waypoints, scan, sample scratch) %12zu\n", m->rt_state);
    fprintf(txt, "  RT  links (sample ring %zu + 2 status mailboxes) %12zu\n", m->ring, m->rt_links);
    fprintf(txt, "  AI  core state total                             %12zu\n", m->ai_state);
    fprintf(txt, "        DiNNO node (model, duals, slots, batch)    %12zu\n", m->ai_node);
    fprintf(txt, "          BNN arena (bnn_get_buffer_size)          %12zu\n", m->ai_model_arena);
    fprintf(txt, "        sample pool (%u samples)               %12zu\n", (unsigned)AI_POOL_CAPACITY,
            m->ai_pool);
    fprintf(txt, "  AI  links (status, state, ckpt mailboxes)        %12zu\n", m->ai_links);
    fprintf(txt, "  GP  core state (round log, telemetry)            %12zu\n", m->gp_state);
    fprintf(txt, "  GP  links (ready mailbox + neighbour slots)      %12zu\n", m->gp_links);
    fprintf(txt, "  board budgets: RT %u, GP %u, AI %u; stacks RT %u, GP %u, AI %u\n",
            (unsigned)BOARD_RAM_RT_BYTES, (unsigned)BOARD_RAM_GP_BYTES, (unsigned)BOARD_RAM_AI_BYTES,
            (unsigned)BOARD_STACK_RT_BYTES, (unsigned)BOARD_STACK_GP_BYTES, (unsigned)BOARD_STACK_AI_BYTES);
    if (csv)
        fprintf(csv, "mem,rt_state,%zu\nmem,rt_links,%zu\nmem,ring,%zu\nmem,ai_state,%zu\nmem,ai_node,%zu\n"
                 "mem,ai_model_arena,%zu\nmem,ai_pool,%zu\nmem,ai_links,%zu\nmem,gp_state,%zu\nmem,gp_links,%zu\n",
            m->rt_state, m->rt_links, m->ring, m->ai_state, m->ai_node, m->ai_model_arena, m->ai_pool,
            m->ai_links, m->gp_state, m->gp_links);
}

/* Everything one `host_sim run` holds; freed in one place (job_free). */
typedef struct job {
    run_opts_t o;
    sim_plan_t plan;
    sim_path_t path;
    ai_sample_t *val;
    size_t n_val;
    bnn_model_t *model;
    sim_image_result_t *res;
    hal_host_file_t csv; /* metrics.csv, fed as rounds go, committed only by a run that succeeded */
    run_ctx_t ctx;
    char err[8192];
} job_t;

static void job_free(job_t *j)
{
    hal_host_file_abort(&j->csv); /* a no-op after a commit */
    free(j->res);
    free(j->model);
    free(j->val);
    sim_path_free(&j->path);
    sim_plan_free(&j->plan);
}

/* Plan, tour, output folder, model scratch and the validation set. */
static int prepare(job_t *j)
{
    const run_opts_t *o = &j->o;
    if (sim_plan_load(o->plan, o->scale, &j->plan, j->err, sizeof j->err) != 0 ||
        sim_path_read_csv(o->path, &j->plan, &j->path, j->err, sizeof j->err) != 0) {
        fprintf(stderr, "host_sim run: %s\n", j->err);
        return -1;
    }
    if (j->path.n > RT_CORE_MAX_WAYPOINTS) {
        fprintf(stderr, "host_sim run: %s has %d waypoints; the RT core holds at most %d\n", o->path, j->path.n,
                RT_CORE_MAX_WAYPOINTS);
        return -1;
    }
    if (cmd_prepare_out_dir("run", o->out) != 0)
        return -1;
    printf("run: one robot's firmware image (RT %u Hz / scans %u Hz, GP %u Hz, AI %u Hz), lockstep\n",
           1000000u / FW_RT_PERIOD_US, 1000000u / (FW_RT_PERIOD_US * FW_RT_SCAN_DIVIDER),
           1000000u / FW_GP_PERIOD_US, 1000000u / FW_AI_PERIOD_US);
    printf("seed %lld, preset %s, %lld rounds, pool %s (capacity %u), %lld steps/round, batch %lld, "
           "kl_weight %g%s\n",
           o->seed, BNN_PRESET_NAME, o->rounds, ai_pool_policy_name(o->pool), (unsigned)AI_POOL_CAPACITY,
           o->steps, o->batch, o->kl_weight, o->train_between ? ", training between boundaries" : "");
    fflush(stdout);
    j->res = calloc(1, sizeof *j->res);
    /* bnn_model_t holds 64-byte aligned vectors: malloc's 16 bytes are not enough (the
       compiler may use aligned vector stores on it). */
    j->model = aligned_alloc(_Alignof(bnn_model_t), (sizeof *j->model + 63) / 64 * 64);
    if (j->res == NULL || j->model == NULL || bnn_init(j->model, NULL, 1) != 0) {
        fprintf(stderr, "host_sim run: out of memory\n");
        return -1;
    }
    if (o->val_poses > 0) {
        sim_valset_cfg_t vc = sim_valset_default_cfg();
        vc.n_poses = (int)o->val_poses;
        vc.seed = (uint64_t)o->seed;
        char src[160], file[4200];
        snprintf(src, sizeof src, "valset (run) poses=%lld seed=%lld", o->val_poses, o->seed);
        snprintf(file, sizeof file, "%s/valset.samples", o->out);
        sim_samples_header_t hdr;
        if (sim_valset_write(&j->plan, &vc, file, src, NULL, j->err, sizeof j->err) != 0 ||
            sim_samples_read(file, &hdr, &j->val, j->err, sizeof j->err) != 0) {
            fprintf(stderr, "host_sim run: validation set: %s\n", j->err);
            return -1;
        }
        j->n_val = (size_t)hdr.count;
        printf("validation set: %zu points (%lld poses)\n", j->n_val, o->val_poses);
        fflush(stdout);
    }
    return 0;
}

/* The firmware image in lockstep with the world, metrics per round; then every check a
 * result must pass before anything of it replaces an earlier run's files. */
static int run_image(job_t *j)
{
    const run_opts_t *o = &j->o;
    char file[4200];
    snprintf(file, sizeof file, "%s/metrics.csv", o->out);
    if (cmd_out_begin("run", &j->csv, file) != 0)
        return -1;
    FILE *csv = hal_host_file_stream(&j->csv);
    fprintf(csv, "round,sim_time_s,distance_m,progress_m,pool_fill,pool_capacity,ring_drops,train_loss,bce,"
                 "val_loss,kl\n");
    j->ctx = (run_ctx_t){o, csv, j->model, j->val, j->n_val, 0, NAN};
    sim_image_cfg_t ic;
    sim_image_cfg_default(&ic);
    ic.seed = (uint64_t)o->seed;
    ic.robot = (uint32_t)o->robot;
    ic.rounds = (uint32_t)o->rounds;
    ic.policy = o->pool;
    ic.steps_per_round = (uint32_t)o->steps;
    ic.kl_weight = (float)o->kl_weight;
    ic.dinno.batch = (uint32_t)o->batch;
    ic.dinno.lr_start = (float)o->lr_start;
    ic.dinno.lr_end = (float)o->lr_end;
    ic.train_between = o->train_between;
    ic.time_limit_s = o->time_limit;
    ic.storage_dir = o->out;
    ic.net_url = o->net;
    ic.sched = o->sched;
    ic.log_level = o->quiet ? HAL_LOG_WARN : HAL_LOG_INFO;
    ic.on_round = on_round;
    ic.user = &j->ctx;
    const sim_image_result_t *res = j->res;
    if (sim_image_run(&j->plan, &j->path, &ic, j->res, j->err, sizeof j->err) != 0) {
        fprintf(stderr, "host_sim run: %s\n", j->err);
        return -1;
    }
    write_profile(o, res, stdout, NULL);
    if (j->ctx.failed)
        return -1;
    if (!res->completed) {
        fprintf(stderr,
                "host_sim run: only %u of %lld rounds done within --time-limit %.1f s (path progress %.2f of "
                "%.2f m); no final checkpoint\n",
                res->rounds_done, o->rounds, o->time_limit, (double)res->rt_status.progress_m,
                (double)res->path_length_m);
        return -1;
    }
    if (res->final_ckpt_status != 0) {
        fprintf(stderr, "host_sim run: %s/final.bnn: %s\n", o->out, hal_host_file_strerror(res->final_ckpt_status));
        return -1;
    }
    if (res->gp.ckpt_failed > 0) {
        fprintf(stderr, "host_sim run: %llu round checkpoint(s) could not be written (see above)\n",
                (unsigned long long)res->gp.ckpt_failed);
        return -1;
    }
    return 0;
}

/* A run that succeeded: the final model's maps and figures, then metrics, profile, summary. */
static int report(job_t *j)
{
    const run_opts_t *o = &j->o;
    const sim_image_result_t *res = j->res;
    char file[4200], f2[4200];
    snprintf(file, sizeof file, "%s/final.bnn", o->out);
    if (load_ckpt(j->model, file) != 0)
        return -1;
    double occ = NAN;
    size_t cells = 0;
    if (sim_image_occ_near_path(&j->plan, &j->path, j->model, 0.1, 1.0, &occ, &cells) != 0) {
        fprintf(stderr, "host_sim run: occupancy metric failed\n");
        return -1;
    }
    double smax = 0;
    char mean_png[4200], std_png[4200];
    snprintf(mean_png, sizeof mean_png, "%s/map_mean.png", o->out);
    snprintf(std_png, sizeof std_png, "%s/map_std.png", o->out);
    if (!o->no_maps && sim_maps_write(j->model, &j->plan, o->map_res, (uint32_t)o->mc, (uint64_t)o->seed, &j->path,
                                      1, mean_png, std_png, &smax, j->err, sizeof j->err) != 0) {
        fprintf(stderr, "host_sim run: maps: %s\n", j->err);
        return -1;
    }
    if (cmd_out_commit("run", &j->csv) != 0)
        return -1;
    hal_host_file_t pt, pc, sum;
    snprintf(file, sizeof file, "%s/profile.txt", o->out);
    snprintf(f2, sizeof f2, "%s/profile.csv", o->out);
    if (cmd_out_begin("run", &pt, file) != 0)
        return -1;
    if (cmd_out_begin("run", &pc, f2) != 0) {
        hal_host_file_abort(&pt);
        return -1;
    }
    write_profile(o, res, hal_host_file_stream(&pt), hal_host_file_stream(&pc));
    const int profile_ok = cmd_out_commit("run", &pt) == 0;
    if (!profile_ok || cmd_out_commit("run", &pc) != 0) {
        hal_host_file_abort(&pc);
        return -1;
    }
    snprintf(file, sizeof file, "%s/summary.txt", o->out);
    if (cmd_out_begin("run", &sum, file) != 0)
        return -1;
    for (int pass = 0; pass < 2; pass++) {
        FILE *f = pass ? stdout : hal_host_file_stream(&sum);
        fprintf(f, "seed: %lld\npreset: %s (%zu parameters)\nrounds: %lld\npool: %s (capacity %u)\n"
                   "steps_per_round: %lld\nbatch: %lld\nkl_weight: %g\ntrain_between: %d\n",
                o->seed, BNN_PRESET_NAME, bnn_n_params(j->model), o->rounds, ai_pool_policy_name(o->pool),
                (unsigned)AI_POOL_CAPACITY, o->steps, o->batch, o->kl_weight, o->train_between);
        fprintf(f, "path: %s (%d waypoints, %.2f m)\nsimulated: %.2f s; wall: %.2f s\n", o->path, j->path.n,
                (double)res->path_length_m, (double)res->sim_time_us * 1e-6, res->wall_s);
        fprintf(f, "distance (true pose): %.2f m; odometry: %.2f m; collisions: %llu\n", res->world.distance_m,
                (double)res->rt_status.distance_m, (unsigned long long)res->world.collisions);
        fprintf(f, "scans: %u; samples: %u; ring drops: %u; pool offered: %llu\n", res->rt_status.scans,
                res->rt_status.samples, res->rt_status.ring_drops,
                (unsigned long long)res->ai_status.pool_offered);
        fprintf(f, "final train loss: %.5f; final val loss: %.5f\n", (double)res->ai_status.loss_train,
                j->ctx.last_val);
        fprintf(f, "occupancy MSE within 1 m of the path (0.1 m grid, %zu cells): %.5f\n", cells, occ);
        fprintf(f, "checkpoints: %llu written, %llu failed; telemetry: %llu sent, %llu not sent\n",
                (unsigned long long)res->gp.ckpt_written, (unsigned long long)res->gp.ckpt_failed,
                (unsigned long long)res->gp.telemetry_sent, (unsigned long long)res->gp.telemetry_failed);
        if (!o->no_maps)
            fprintf(f, "maps: %lld MC passes, %.3f m grid, max std %.4f: %s %s\n", o->mc, o->map_res, smax,
                    mean_png, std_png);
    }
    if (cmd_out_commit("run", &sum) != 0)
        return -1;
    printf("results in %s\n", o->out);
    return 0;
}

int cmd_run(int argc, char **argv)
{
    static job_t job; /* one run per process */
    job_t *j = &job;
    memset(j, 0, sizeof *j);
    int pr = parse(argc, argv, &j->o);
    if (pr > 0)
        return 0;
    if (pr < 0)
        return 2;
    const int ok = prepare(j) == 0 && run_image(j) == 0 && report(j) == 0;
    job_free(j);
    return ok ? 0 : 1;
}
