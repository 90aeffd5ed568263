/* host_sim run: one robot's firmware image (RT, AI, GP cores as threads) against the ODE
 * world in lockstep, learning online by communication rounds. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <time.h>

#include "ai/bnn_ckpt.h"
#include "hal_host_file.h"
#include "hal_host_stop.h"
#include "cli.h"
#include "cmd_coverage.h"
#include "cmd_run_opts.h"
#include "commands.h"
#include "run_resume.h"
#include "run_summary.h"
#include "sim_fleet.h"
#include "sim_maps.h"
#include "sim_image.h"
#include "sim_kernels.h"
#include "sim_explore.h"
#include "sim_paths.h"
#include "sim_plan.h"
#include "sim_samples.h"
#include "sim_valset.h"

/* Rows of metrics.csv wait until the fleet's record of their round arrived (the GP core closes
 * it when the next round begins), so both logs are joined by round. */
#define RUN_PENDING 2048u

typedef struct run_row {
    ai_round_info_t in;
    double val, wall_s;
    int deferred; /* the last DiNNO round's validation waits for final.bnn (posterior rounds) */
} run_row_t;

typedef struct run_ctx {
    const run_opts_t *o;
    FILE *csv, *traffic;
    bnn_model_t *model;
    const ai_sample_t *val;
    size_t n_val;
    int failed, ckpt_failed;
    uint32_t post_rounds;                /* after the DiNNO rounds: no rows of their own */
    uint32_t post_done;                  /* ... their traffic, for summary.txt */
    uint64_t post_sent, post_received;
    double last_val, t0;
    uint32_t rows_in, rows_out;          /* AI records taken / written */
    run_row_t rows[RUN_PENDING];
    uint32_t fleet_in;                    /* fleet records taken */
    gp_fleet_round_t fleet[RUN_PENDING]; /* by round % RUN_PENDING */
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

static int val_round(const run_opts_t *o, uint32_t round)
{
    return (round + 1u) % (uint32_t)o->val_every == 0 || round + 1u == (uint32_t)o->rounds;
}

/* Writes the rows whose fleet record is there (all of them when `all`). */
static void flush_rows(run_ctx_t *c, int all)
{
    while (c->rows_out < c->rows_in) {
        const run_row_t *r = &c->rows[c->rows_out % RUN_PENDING];
        const uint32_t k = r->in.round;
        if (r->deferred && !all)
            return;
        const gp_fleet_round_t *fr = NULL;
        if (c->o->fleet > 1) {
            if (c->fleet_in > k)
                fr = &c->fleet[k % RUN_PENDING];
            else if (!all)
                return;
        }
        const ai_round_info_t *in = &r->in;
        printf("round %4u/%lld  t %7.1f s  progress %6.2f m  pool %7u  train %.4f  val %.4f  kl %.2f  nbrs %u  "
               "dis %.3g  sent %llu B  lost %llu  recovered %llu  resent %llu  wait %.1f ms\n",
               k + 1u, c->o->rounds, (double)in->stamp_us * 1e-6, (double)in->progress_m, in->pool_fill,
               (double)in->loss_train, r->val, (double)in->kl, in->neighbours,
               fr ? (double)fr->disagreement : NAN, fr ? (unsigned long long)fr->bytes_sent : 0ull,
               fr ? (unsigned long long)fr->chunks_lost : 0ull, fr ? (unsigned long long)fr->chunks_recovered : 0ull,
               fr ? (unsigned long long)fr->chunks_resent : 0ull,
               fr ? (double)fr->wait_us * 1e-3 : 0.0);
        fprintf(c->csv, "%u,%.3f,%.4f,%.4f,%u,%u,%u,%.6g,%.6g,%.6g,%.6g,%u,%.6g,%.3f\n", k,
                (double)in->stamp_us * 1e-6, (double)in->distance_m, (double)in->progress_m, in->pool_fill,
                in->pool_capacity, in->ring_drops, (double)in->loss_train, (double)in->bce, r->val, (double)in->kl,
                in->neighbours, fr ? (double)fr->disagreement : NAN, r->wall_s);
        c->rows_out++;
    }
    /* Into the temporary file at once: a killed run leaves its rows there for --resume. */
    fflush(c->csv);
    fflush(stdout);
}

static void on_round(const ai_round_info_t *in, void *user)
{
    run_ctx_t *c = user;
    double val = NAN;
    int deferred = 0;
    char name[64];
    gp_core_ckpt_name(in->round, name, sizeof name);
    if (in->ckpt_status != 0) {
        /* A file of that name may be an earlier run's: never read it as this run's. The run
           stops at the end of this slice (sim_image_run), so only the first failure is news. */
        if (!c->ckpt_failed)
            fprintf(stderr, "host_sim run: %s/%s: %s; stopping at round %u\n", c->o->out,
                    val_round(c->o, in->round) ? name : "final.bnn", hal_host_file_strerror(in->ckpt_status),
                    in->round);
        c->ckpt_failed = 1;
        c->failed = 1;
    } else if (in->round >= (uint32_t)c->o->rounds) {
        /* A posterior round (ai_core.h): no row. The last writes final.bnn, which validates the
           last DiNNO round's row (theta no longer changes). */
        if (in->round + 1u == (uint32_t)c->o->rounds + c->post_rounds && c->rows_in > c->rows_out) {
            run_row_t *r = &c->rows[(c->rows_in - 1u) % RUN_PENDING];
            if (r->deferred) {
                char file[4200];
                snprintf(file, sizeof file, "%s/final.bnn", c->o->out);
                float v = NAN;
                if (load_ckpt(c->model, file) != 0 || bnn_eval_bce(c->model, c->val, c->n_val, 0, 0, &v) != 0)
                    c->failed = 1;
                r->val = c->last_val = v;
                r->deferred = 0;
            }
        }
        flush_rows(c, 0);
        return;
    } else if (c->n_val > 0 && c->post_rounds > 0 && in->round + 1u == (uint32_t)c->o->rounds &&
               (in->round + 1u) % (uint32_t)c->o->val_every != 0) {
        deferred = 1; /* its checkpoint is final.bnn, written after the posterior rounds */
    } else if (c->n_val > 0 && val_round(c->o, in->round)) {
        /* The last round's checkpoint may exist only as final.bnn (--val-every not dividing it). */
        char file[4200];
        snprintf(file, sizeof file, "%s/%s", c->o->out,
                 in->round + 1u == (uint32_t)c->o->rounds && c->post_rounds == 0 ? "final.bnn" : name);
        float v = NAN;
        if (load_ckpt(c->model, file) != 0 || bnn_eval_bce(c->model, c->val, c->n_val, 0, 0, &v) != 0)
            c->failed = 1;
        val = v;
        c->last_val = val;
    }
    if (c->rows_in - c->rows_out == RUN_PENDING)
        flush_rows(c, 1); /* never expected: the fleet's log runs one round behind at most */
    c->rows[c->rows_in % RUN_PENDING] = (run_row_t){*in, val, cmd_wall_now() - c->t0, deferred};
    c->rows_in++;
    flush_rows(c, 0);
}

static void on_fleet_round(const gp_fleet_round_t *r, void *user)
{
    run_ctx_t *c = user;
    if (r->timeouts > 0)
        fprintf(stderr, "host_sim run: robot %lld, round %u: %llu peer(s) timed out and left the round\n", c->o->robot,
                r->round, (unsigned long long)r->timeouts);
    if (r->round >= (uint32_t)c->o->rounds) { /* a posterior round: summed, not a row (summary.txt) */
        c->post_done++;
        c->post_sent += r->bytes_sent;
        c->post_received += r->bytes_received;
        return;
    }
    c->fleet[r->round % RUN_PENDING] = *r;
    c->fleet_in = r->round + 1u;
    fprintf(c->traffic, "%u,%.3f,%.3f,%llu,%llu,%llu,%llu,%llu,%llu,%llu,%llu,%llu,%llu,%llu,%llu,%llu,%llu,%llu,%llu,%llu,%llu,%llu\n",
            r->round,
            (double)r->wall_us * 1e-3, (double)r->wait_us * 1e-3, (unsigned long long)r->bytes_sent,
            (unsigned long long)r->bytes_received, (unsigned long long)r->chunks_sent,
            (unsigned long long)r->chunks_received, (unsigned long long)r->chunks_resent,
            (unsigned long long)r->chunks_requested, (unsigned long long)r->duplicates, (unsigned long long)r->stale,
            (unsigned long long)r->timeouts, (unsigned long long)r->rejoins, (unsigned long long)r->crc_failures,
            (unsigned long long)r->invalid, (unsigned long long)r->chunks_recovered, (unsigned long long)r->chunks_lost,
            (unsigned long long)r->states_missed, (unsigned long long)r->rounds_skipped,
            (unsigned long long)r->beacons_sent, (unsigned long long)r->restarts,
            (unsigned long long)r->old_incarnation);
    fflush(c->traffic);
    flush_rows(c, 0);
}

static void write_profile(const run_opts_t *o, const sim_image_result_t *r, FILE *txt, FILE *csv)
{
    static const char *names[HAL_CORE_COUNT] = {"RT", "GP", "AI"};
    static const double hz[HAL_CORE_COUNT] = {1e6 / FW_RT_PERIOD_US, 1e6 / FW_GP_PERIOD_US,
                                              1e6 / FW_AI_PERIOD_US};
    const fw_robot_memory_t *m = &r->mem;
    const size_t mem_core[HAL_CORE_COUNT] = {m->rt_state + m->rt_links, m->gp_state + m->gp_links + m->gp_fleet,
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
    fprintf(txt, "  RT  core state (tour, scan, samples, explore grid) %10zu\n", m->rt_state);
    fprintf(txt, "  RT  links (sample ring %zu + status, seen mailboxes) %6zu\n", m->ring, m->rt_links);
    fprintf(txt, "  AI  core state total                             %12zu\n", m->ai_state);
    fprintf(txt, "        DiNNO node (model, duals, view, batch)     %12zu\n", m->ai_node);
    fprintf(txt, "          BNN arena (bnn_get_buffer_size)          %12zu\n", m->ai_model_arena);
    fprintf(txt, "        sample pool (%u samples)               %12zu\n", (unsigned)AI_POOL_CAPACITY,
            m->ai_pool);
    fprintf(txt, "  AI  links (status, state, ckpt, belief mailboxes) %10zu\n", m->ai_links);
    fprintf(txt, "  GP  core state (round log, telemetry, goals)     %12zu\n", m->gp_state);
    fprintf(txt, "  GP  links (ready, goal mailboxes + neighbour view) %10zu\n", m->gp_links);
    fprintf(txt, "  GP  fleet exchange (state buffers of 2 rounds)   %12zu\n", m->gp_fleet);
    fprintf(txt, "  board budgets: RT %u, GP %u, AI %u; stacks RT %u, GP %u, AI %u\n",
            (unsigned)BOARD_RAM_RT_BYTES, (unsigned)BOARD_RAM_GP_BYTES, (unsigned)BOARD_RAM_AI_BYTES,
            (unsigned)BOARD_STACK_RT_BYTES, (unsigned)BOARD_STACK_GP_BYTES, (unsigned)BOARD_STACK_AI_BYTES);
    if (csv)
        fprintf(csv, "mem,rt_state,%zu\nmem,rt_links,%zu\nmem,ring,%zu\nmem,ai_state,%zu\nmem,ai_node,%zu\n"
                 "mem,ai_model_arena,%zu\nmem,ai_pool,%zu\nmem,ai_links,%zu\nmem,gp_state,%zu\nmem,gp_links,%zu\n"
                 "mem,gp_fleet,%zu\n",
            m->rt_state, m->rt_links, m->ring, m->ai_state, m->ai_node, m->ai_model_arena, m->ai_pool,
            m->ai_links, m->gp_state, m->gp_links, m->gp_fleet);
}

/* Everything one `host_sim run` holds; freed in one place (job_free). */
typedef struct job {
    run_opts_t o;
    sim_plan_t plan;
    sim_path_t path;
    sim_explore_trace_t trace; /* --explore: explore.csv */
    sim_explore_opts_t explore; /* --explore: what the image runs and summary.txt says (run_image) */
    ai_sample_t *val;
    size_t n_val;
    bnn_model_t *model;
    sim_image_result_t *res;
    hal_host_file_t csv; /* metrics.csv, fed as rounds go, committed only by a run that succeeded */
    hal_host_file_t traffic; /* traffic.csv (fleet), likewise */
    rt_waypoint_t *tour;     /* the path as the firmware holds it (fleet positions) */
    gp_fleet_cfg_t fleet;
    run_resume_t resume;     /* --resume: the checkpoint and the rows carried over */
    uint32_t incarnation;    /* starts of a robot with this --out (DIR/incarnation) */
    hal_host_auth_t auth;    /* --key-file: the fleet key and --run-id */
    char net_url[RUN_NET_URL_MAX]; /* --transport zmq: the URL --peers makes */
    run_ctx_t ctx;
    sim_coverage_t cov;      /* what the robot's lidar saw (coverage.bin, coverage.csv) */
    char err[8192];
} job_t;

static void job_free(job_t *j)
{
    hal_host_file_abort(&j->csv); /* a no-op after a commit */
    hal_host_file_abort(&j->traffic);
    run_resume_free(&j->resume);
    sim_coverage_free(&j->cov);
    hal_host_auth_wipe(&j->auth);
    free(j->tour);
    free(j->res);
    free(j->model);
    free(j->val);
    sim_path_free(&j->path);
    sim_plan_free(&j->plan);
}

/* The header lines of metrics.csv and traffic.csv: --resume carries a stopped run's rows over
 * only when its temporary file has the same header (the rows' format is the header's). */
static const char run_metrics_header[] =
    "round,sim_time_s,distance_m,progress_m,pool_fill,pool_capacity,ring_drops,train_loss,bce,val_loss,kl,"
    "neighbours,disagreement,wall_s\n";
static const char run_traffic_header[] =
    "round,wall_ms,wait_ms,bytes_sent,bytes_received,chunks_sent,chunks_received,chunks_resent,chunks_requested,"
    "duplicates,stale,timeouts,rejoins,crc_failures,invalid,chunks_recovered,chunks_lost,states_missed,"
    "rounds_skipped,beacons_sent,peer_restarts,old_incarnation\n";

/* --resume: the checkpoint to continue from and the rows to carry over (run_resume.h). */
static int prepare_resume(job_t *j)
{
    const run_opts_t *o = &j->o;
    const char *const headers[RUN_CARRY_FILES] = {run_metrics_header, o->fleet > 1 ? run_traffic_header : NULL};
    if (run_resume_find(o->out, (uint32_t)o->rounds, headers, &j->resume) != 0)
        return -1;
    const uint32_t post = o->fleet > 1 && o->encoding == DINNO_CODEC_FP32 ? (uint32_t)o->post_rounds : 0u;
    if (j->resume.start_round >= (uint32_t)o->rounds && post == 0) { /* else: the posterior rounds are left */
        fprintf(stderr, "host_sim run: %s/%s is the last round's checkpoint: every round is done, nothing to "
                        "resume (run without --resume to start over)\n", o->out, j->resume.ckpt_name);
        return -1;
    }
    return 0;
}

/* Plan, tour, output folder, model scratch and the validation set. */
static int prepare(job_t *j)
{
    const run_opts_t *o = &j->o;
    if (o->key_file != NULL) { /* first: a bad key stops the robot before anything is written */
        if (hal_host_auth_key_load(o->key_file, j->auth.key, j->err, sizeof j->err) != 0) {
            fprintf(stderr, "host_sim run: --key-file %s\n", j->err);
            return -1;
        }
        j->auth.run_id = o->run_id;
    }
    if (sim_plan_load(o->plan, o->scale, &j->plan, j->err, sizeof j->err) != 0 ||
        (o->explore ? sim_explore_start(&j->plan, (uint64_t)o->seed, (int)o->robot, o->fleet > o->robot ? (int)o->fleet
                                                                                                         : (int)o->robot + 1,
                                        &j->path, j->err, sizeof j->err)
                    : sim_path_read_csv(o->path, &j->plan, &j->path, j->err, sizeof j->err)) != 0) {
        fprintf(stderr, "host_sim run: %s\n", j->err);
        return -1;
    }
    if (sim_coverage_from_plan(&j->cov, &j->plan, SIM_COVERAGE_RES_M) != 0) {
        fprintf(stderr, "host_sim run: %s: cannot make its %.2f m coverage grid\n", o->plan, SIM_COVERAGE_RES_M);
        return -1;
    }
    if (j->path.n > RT_CORE_MAX_WAYPOINTS) {
        fprintf(stderr, "host_sim run: %s has %d waypoints; the RT core holds at most %d\n", o->path, j->path.n,
                RT_CORE_MAX_WAYPOINTS);
        return -1;
    }
    /* Before the folder is cleared of the temporaries a killed run left: its rows are there. */
    if (o->resume && prepare_resume(j) != 0)
        return -1;
    if (cmd_prepare_out_dir("run", o->out) != 0 || run_incarnation_next(o->out, o->resume, &j->incarnation) != 0)
        return -1;
    printf("run: robot %lld's firmware image (RT %u Hz / scans %u Hz, GP %u Hz, AI %u Hz), lockstep, %s\n", o->robot,
           1000000u / FW_RT_PERIOD_US, 1000000u / (FW_RT_PERIOD_US * FW_RT_SCAN_DIVIDER),
           1000000u / FW_GP_PERIOD_US, 1000000u / FW_AI_PERIOD_US, o->offline ? "offline" : "online");
    printf("seed %lld, preset %s, %lld rounds (%lld per communication round), pool %s (capacity %u), strategy %s, "
           "%u steps/round, batch %u, kl_weight %g%s\n",
           o->seed, BNN_PRESET_NAME, o->rounds, o->per_comm, ai_pool_policy_name(o->pool), (unsigned)AI_POOL_CAPACITY,
           dinno_strategy_name(o->d.strategy), o->d.primal_steps, o->d.batch, (double)o->d.kl_weight,
           o->train_between ? ", training between boundaries" : "");
    if (o->fleet > 1)
        printf("fleet %lld: member %lld of %lld over %s %s, %s states, neighbours %s%.3g m\n", o->fleet_id, o->robot,
               o->fleet, o->transport == RUN_TRANSPORT_ZMQ ? "ZeroMQ" : o->transport == RUN_TRANSPORT_SHM ? "shared memory" : "LCM", o->net[0] ? o->net : HAL_HOST_NET_URL_DEFAULT, dinno_codec_name(o->encoding),
               o->radius > 0 ? "within " : "all (radius ", o->radius);
    if (o->key_file != NULL && o->transport == RUN_TRANSPORT_SHM)
        printf("keyed fleet over shared memory: no tag, the segment is 0600 like the key %s\n", o->key_file);
    else if (o->key_file != NULL)
        printf("keyed fleet: every datagram authenticated (XChaCha20-Poly1305, key %s, run id %016llx)\n", o->key_file,
               (unsigned long long)o->run_id);
    printf("incarnation %u (%s/incarnation)\n", j->incarnation, o->out);
    if (o->resume && j->resume.start_round > 0)
        printf("resuming robot %lld from %s (round %u); continuing at round %u of %lld\n", o->robot,
               j->resume.ckpt_name, j->resume.ckpt_round, j->resume.start_round, o->rounds);
    else if (o->resume)
        printf("resuming robot %lld: no complete round checkpoint in %s; starting from round 0\n", o->robot, o->out);
    run_resume_describe(&j->resume, stdout);
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

/* The rows of the rounds before a resumed one, as the stopped run wrote them. */
static void carry_rows(const run_carry_t *k, FILE *f)
{
    if (k->rows != NULL)
        fwrite(k->rows, 1, k->len, f);
    fflush(f);
}

/* A run that ended early in good order: stopped by a signal (the exit status 128 + it, after
 * the one-line message) or by a checkpoint that could not be written (1; on_round said which).
 * 0 when it was neither. */
static int stopped_early(const job_t *j)
{
    const sim_image_result_t *res = j->res;
    if (res->stop_signal != 0) {
        fprintf(stderr, "host_sim run: stopped by %s at round %u\n", hal_host_stop_signal_name(res->stop_signal),
                res->rounds_done);
        return hal_host_stop_exit_code(res->stop_signal);
    }
    if (res->ckpt_error != 0) {
        if (!j->ctx.ckpt_failed) /* on_round says it; this covers a run without the callback's message */
            fprintf(stderr, "host_sim run: %s: round %u's checkpoint: %s; stopping at round %u\n", j->o.out,
                    res->ckpt_error_round, hal_host_file_strerror(res->ckpt_error), res->ckpt_error_round);
        return 1;
    }
    return 0;
}

/* The firmware image in lockstep with the world, metrics per round; then every check a
 * result must pass before anything of it replaces an earlier run's files. 0, -1 (failed,
 * said why) or the exit status of a run stopped by a signal. */
static int run_image(job_t *j)
{
    const run_opts_t *o = &j->o;
    char file[4200];
    snprintf(file, sizeof file, "%s/metrics.csv", o->out);
    if (cmd_out_begin("run", &j->csv, file) != 0)
        return -1;
    FILE *csv = hal_host_file_stream(&j->csv);
    fputs(run_metrics_header, csv);
    carry_rows(&j->resume.carry[RUN_CARRY_METRICS], csv);
    FILE *traffic = NULL;
    if (o->fleet > 1) {
        snprintf(file, sizeof file, "%s/traffic.csv", o->out);
        if (cmd_out_begin("run", &j->traffic, file) != 0)
            return -1;
        traffic = hal_host_file_stream(&j->traffic);
        fputs(run_traffic_header, traffic);
        carry_rows(&j->resume.carry[RUN_CARRY_TRAFFIC], traffic);
    }
    run_ctx_t *c = &j->ctx;
    memset(c, 0, sizeof *c);
    c->o = o;
    c->csv = csv;
    c->traffic = traffic;
    c->model = j->model;
    c->val = j->val;
    c->post_rounds = o->fleet > 1 && o->encoding == DINNO_CODEC_FP32 ? (uint32_t)o->post_rounds : 0u;
    c->n_val = j->n_val;
    c->last_val = NAN;
    c->t0 = cmd_wall_now();
    sim_image_cfg_t ic;
    sim_image_cfg_default(&ic);
    ic.seed = (uint64_t)o->seed;
    ic.robot = (uint32_t)o->robot;
    ic.rounds = (uint32_t)o->rounds;
    ic.rounds_per_boundary = (uint32_t)o->per_comm;
    ic.offline = o->offline;
    ic.policy = o->pool;
    ic.dinno = o->d;
    ic.dinno.codec = (dinno_codec_t)o->encoding; /* the AI core sends what the GP core packs */
    ic.steps_per_round = o->d.primal_steps;
    ic.kl_weight = o->d.kl_weight;
    ic.train_between = o->train_between;
    ic.pool_samples = (uint32_t)o->pool_samples;
    ic.time_limit_s = o->time_limit;
    ic.storage_dir = o->out;
    ic.net_url = o->net;
    ic.net_groups = o->lcm_groups;
    ic.net_faults = o->net_faults;
    ic.net_auth = o->key_file != NULL ? &j->auth : NULL;
    ic.sched = o->sched;
    ic.log_level = o->quiet ? HAL_LOG_WARN : HAL_LOG_INFO;
    ic.ckpt_every = (uint32_t)o->val_every;
    ic.ckpt_keep = (uint32_t)o->ckpt_keep;
    ic.ckpt_keep_every = (uint32_t)o->ckpt_keep_every;
    ic.start_round = j->resume.start_round;
    ic.resume_ckpt = j->resume.ckpt;
    ic.resume_ckpt_bytes = j->resume.ckpt_bytes;
    ic.on_round = on_round;
    ic.on_fleet_round = on_fleet_round;
    ic.user = c;
    ic.coverage = &j->cov;
    /* a posterior crosses the exchange only as fp32 words: with another encoding each robot's
       belief is its own, and the image and summary.txt say so alike */
    j->explore = (sim_explore_opts_t){(gp_explore_policy_t)o->explore_policy, o->explore_time,
                                      SIM_EXPLORE_BELIEF_PERIOD_S_DEFAULT,
                                      o->explore_own_posterior || o->encoding != DINNO_CODEC_FP32,
                                      o->explore_policy == GP_EXPLORE_UNCERTAINTY && !o->explore_posterior_first,
                                      o->explore_no_fence};
    if (o->explore && o->fleet > 1 && !o->explore_own_posterior && o->encoding != DINNO_CODEC_FP32)
        fprintf(stderr, "host_sim run: robot %lld: --encoding is not fp32, so the posterior is not shared while "
                        "exploring: each robot's belief is its own\n", o->robot);
    if (o->explore) {
        ic.explore = &j->explore;
        if (sim_explore_trace_open(&j->trace, o->out, (int)o->robot) != 0) {
            fprintf(stderr, "host_sim run: %s/explore.csv: cannot write\n", o->out);
            return -1;
        }
        ic.on_second = sim_explore_trace_row;
        ic.second_user = &j->trace;
    }
    if (o->fleet > 1) {
        j->tour = malloc(sizeof(rt_waypoint_t) * (size_t)j->path.n);
        if (j->tour == NULL) {
            fprintf(stderr, "host_sim run: out of memory\n");
            return -1;
        }
        for (int i = 0; i < j->path.n; i++)
            j->tour[i] = (rt_waypoint_t){(float)j->path.p[i].x, (float)j->path.p[i].y};
        gp_fleet_cfg_t *f = &j->fleet;
        *f = gp_fleet_default_cfg();
        f->fleet_id = (uint32_t)o->fleet_id;
        f->self = (uint32_t)o->robot;
        f->n_peers = (uint32_t)o->fleet;
        f->rounds = (uint32_t)o->rounds;
        f->radius_m = o->radius;
        f->encoding = o->encoding;
        f->incarnation = j->incarnation;
        f->chunk_bytes = (uint32_t)o->chunk_bytes;
        f->peer_timeout_us = (uint32_t)llround(o->peer_timeout * 1e6);
        f->resend_after_us = (uint32_t)llround(o->resend_ms * 1e3);
        f->join_timeout_us = (uint32_t)llround(o->join_timeout * 1e6);
        f->positions_from_tour = o->offline;
        /* A copy per connection (ZeroMQ), per inbox group (LCM groups) or on the robot's own
           channels, which the other robots' kernel filters drop (LCM addressed). */
        f->addressed = o->transport != RUN_TRANSPORT_LCM || o->lcm_groups || o->lcm_addressed;
        f->ordered = o->transport == RUN_TRANSPORT_ZMQ;   /* TCP keeps each sender's order */
        f->post_rounds = o->encoding == DINNO_CODEC_FP32 ? (uint32_t)o->post_rounds : 0u;
        f->tour = j->tour;
        f->n_tour = j->path.n;
        ic.fleet = f;
    }
    const sim_image_result_t *res = j->res;
    const int ran = sim_image_run(&j->plan, &j->path, &ic, j->res, j->err, sizeof j->err);
    if (sim_explore_trace_close(&j->trace) != 0) {
        fprintf(stderr, "host_sim run: %s/explore.csv: write failed\n", o->out);
        return -1;
    }
    if (ran != 0) {
        fprintf(stderr, "host_sim run: %s\n", j->err);
        return -1;
    }
    flush_rows(&j->ctx, 1);
    const int early = stopped_early(j);
    if (early != 0)
        return early == 1 ? -1 : early;
    write_profile(o, res, stdout, NULL);
    if (j->ctx.failed)
        return -1;
    if (!res->completed) {
        /* Out of simulated time: what was done is kept (the rows, the round checkpoints), so the
           run can go on from there rather than start over. */
        const int kept = cmd_out_commit("run", &j->csv) == 0 &&
                         (o->fleet < 2 || cmd_out_commit("run", &j->traffic) == 0);
        fprintf(stderr,
                "host_sim run: stopped by --time-limit %.1f s after %u of %lld rounds (path progress %.2f of "
                "%.2f m); no final checkpoint\n",
                o->time_limit, res->rounds_done, o->rounds, (double)res->rt_status.progress_m,
                (double)res->path_length_m);
        if (kept && res->rounds_done > 0 && o->offline)
            fprintf(stderr, "host_sim run: kept %s/metrics.csv and the round checkpoints; to go on, run the same "
                            "command with --resume and a larger --time-limit\n", o->out);
        else if (kept && res->rounds_done > 0)
            fprintf(stderr, "host_sim run: kept %s/metrics.csv and the round checkpoints; an online run cannot "
                            "resume: run it again with a larger --time-limit\n", o->out);
        else
            fprintf(stderr, "host_sim run: no round was done (the tour takes longer): run again with a larger "
                            "--time-limit\n");
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
    if (cmd_out_commit("run", &j->csv) != 0 || (o->fleet > 1 && cmd_out_commit("run", &j->traffic) != 0))
        return -1;
    /* Coverage up to the end of the run (the robot stood still after its tour: no new cells). */
    if (j->cov.t_end < (double)res->sim_time_us * 1e-6)
        j->cov.t_end = (double)res->sim_time_us * 1e-6;
    snprintf(file, sizeof file, "%s/coverage.csv", o->out);
    snprintf(f2, sizeof f2, "%s/coverage.bin", o->out);
    if (cmd_coverage_write("run", &j->cov, 1, file, f2) != 0)
        return -1;
    /* The samples the robot trained on (its pool at the end), for the fleet's density plot. */
    const ai_core_t *ai = fw_robot_ai();
    sim_samples_writer_t wr;
    snprintf(file, sizeof file, "%s/train.samples", o->out);
    char src[160];
    snprintf(src, sizeof src, "run pool robot=%lld seed=%lld %s", o->robot, o->seed, o->offline ? "offline" : "online");
    int wrc = sim_samples_open(&wr, file, j->plan.min.x, j->plan.min.y, j->plan.max.x, j->plan.max.y,
                               (uint64_t)o->seed, src);
    if (wrc == 0 && (wrc = sim_samples_append(&wr, ai->pool.data, ai->pool.fill)) < 0)
        sim_samples_abort(&wr);
    else if (wrc == 0)
        wrc = sim_samples_close(&wr);
    if (wrc < 0) {
        fprintf(stderr, "host_sim run: %s: %s\n", file, hal_host_file_strerror(wrc));
        return -1;
    }
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
                   "steps_per_round: %u\nbatch: %u\nkl_weight: %g\ntrain_between: %d\nmode: %s\nstrategy: %s\n",
                o->seed, BNN_PRESET_NAME, bnn_n_params(j->model), o->rounds, ai_pool_policy_name(o->pool),
                o->pool_samples > 0 ? (unsigned)o->pool_samples : (unsigned)AI_POOL_CAPACITY, o->d.primal_steps,
                o->d.batch, (double)o->d.kl_weight, o->train_between,
                o->offline ? "offline" : "online", dinno_strategy_name(o->d.strategy));
        if (o->explore)
            fprintf(f, "path: none (explore, from (%.2f, %.2f))\nsimulated: %.2f s; wall: %.2f s\n", j->path.p[0].x,
                    j->path.p[0].y, (double)res->sim_time_us * 1e-6, res->wall_s);
        else
            fprintf(f, "path: %s (%d waypoints, %.2f m)\nsimulated: %.2f s; wall: %.2f s\n", o->path, j->path.n,
                    (double)res->path_length_m, (double)res->sim_time_us * 1e-6, res->wall_s);
        fprintf(f, "incarnation: %u\n", j->incarnation);
        if (j->resume.start_round > 0) {
            fprintf(f, "resumed: from %s (round %u), rounds %u .. %lld run by this start\n", j->resume.ckpt_name,
                    j->resume.ckpt_round, j->resume.start_round, o->rounds - 1);
            run_resume_describe(&j->resume, f);
        }
        fprintf(f, "distance (true pose): %.2f m; odometry: %.2f m; collisions: %llu\n", res->world.distance_m,
                (double)res->rt_status.distance_m, (unsigned long long)res->world.collisions);
        fprintf(f, "scans: %u; samples: %u; ring drops: %u; pool offered: %llu\n", res->rt_status.scans,
                res->rt_status.samples, res->rt_status.ring_drops,
                (unsigned long long)res->ai_status.pool_offered);
        fprintf(f, "final train loss: %.5f; final val loss: %.5f\n", (double)res->ai_status.loss_train,
                j->ctx.last_val);
        fprintf(f, "occupancy MSE within 1 m of the path (0.1 m grid, %zu cells): %.5f\n", cells, occ);
        cmd_coverage_line(f, &j->cov, 1);
        if (o->explore)
            sim_explore_summary(f, &j->explore, &res->rt_status, &res->explore, &res->claims,
                                o->fleet > 1 ? &res->fleet : NULL);
        if (o->fleet > 1) {
            const run_post_t post = {j->ctx.post_rounds, j->ctx.post_done, j->ctx.post_sent, j->ctx.post_received};
            run_summary_fleet(f, o, res, (uint32_t)j->resume.start_round, &post);
        }
        struct rusage ru;
        if (getrusage(RUSAGE_SELF, &ru) == 0) /* what the process cost the machine (scaling tables) */
            fprintf(f, "process: %.2f s CPU (user %.2f, system %.2f), peak RSS %.1f MB\n",
                    (double)ru.ru_utime.tv_sec + 1e-6 * (double)ru.ru_utime.tv_usec +
                        (double)ru.ru_stime.tv_sec + 1e-6 * (double)ru.ru_stime.tv_usec,
                    (double)ru.ru_utime.tv_sec + 1e-6 * (double)ru.ru_utime.tv_usec,
                    (double)ru.ru_stime.tv_sec + 1e-6 * (double)ru.ru_stime.tv_usec, (double)ru.ru_maxrss / 1024.0);
        fprintf(f, "checkpoints: %llu written, %llu failed; telemetry: %llu sent, %llu not sent\n",
                (unsigned long long)res->gp.ckpt_written, (unsigned long long)res->gp.ckpt_failed,
                (unsigned long long)res->gp.telemetry_sent, (unsigned long long)res->gp.telemetry_failed);
        if (!o->no_maps)
            fprintf(f, "maps: %lld MC passes, %.3f m grid, max std %.4f: %s %s\n", o->mc, o->map_res, smax,
                    pass ? mean_png : "map_mean.png", pass ? std_png : "map_std.png"); /* the file: in its folder */
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
    int pr = run_parse(argc, argv, &j->o, j->net_url);
    if (pr > 0)
        return 0;
    if (pr < 0)
        return 2;
    if (sim_kernels_bf16_default()) /* PRECISION=bf16: say so when its products run on the reference */
        (void)sim_kernels_bf16_note(stderr, "host_sim run");
    /* SIGINT/SIGTERM: the image stops at its next lockstep instant and this function ends it in
       good order; once the image is over, a signal stops the report at once (hal_host_stop.h). */
    hal_host_stop_set_mode(HAL_HOST_STOP_ASK);
    int rc = prepare(j);
    if (rc == 0)
        rc = run_image(j);
    if (rc == 0) {
        char at[48];
        snprintf(at, sizeof at, " at round %lld", j->o.rounds);
        hal_host_stop_set_message("host_sim run", at);
        hal_host_stop_set_mode(HAL_HOST_STOP_NOW);
        const int sig = hal_host_stop_signal(); /* asked for after the image's last slice */
        if (sig != 0) {
            fprintf(stderr, "host_sim run: stopped by %s%s\n", hal_host_stop_signal_name(sig), at);
            rc = hal_host_stop_exit_code(sig);
        } else {
            rc = report(j);
        }
    }
    job_free(j);
    return rc == 0 ? 0 : rc > 0 ? rc : 1;
}
