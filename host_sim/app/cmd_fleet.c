/* host_sim fleet --inproc: the deterministic in-process DiNNO fleet (and its baselines). */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "cli.h"
#include "commands.h"
#include "sim_fleet.h"
#include "sim_maps.h"
#include "sim_paths.h"
#include "sim_plan.h"
#include "sim_samples.h"
#include "sim_scan.h"
#include "sim_valset.h"

static void fleet_usage(FILE *out)
{
    const dinno_cfg_t d = dinno_default_cfg();
    fprintf(out,
            "usage: host_sim fleet --inproc --plan FILE.svg --paths DIR --robots N --rounds R\n"
            "                      --strategy kl|separate|uniform|central|isolated --graph disk|full|ring\n"
            "                      --seed S --out DIR [options]\n"
            "\n"
            "Trains N agents (one BNN each, preset '%s') on lidar samples taken along their paths\n"
            "(DIR/robot_<i>.csv, i = 0..N-1), in synchronous DiNNO rounds, in ONE process. This is the\n"
            "in-process fleet; the multi-process fleet over LCM is on the roadmap, so --inproc is\n"
            "required. Baselines with the same network and step budget: 'central' (one model on the\n"
            "pooled data) and 'isolated' (no communication).\n"
            "\n"
            "Training data: each robot drives its path in the ODE world (the same loop as host_sim scan,\n"
            "seed S, robot i) unless --samples gives host_sim sample files. Validation: host_sim valset\n"
            "(seed S) unless --valset.\n"
            "Writes into --out: samples/robot_<i>.samples (training data, unless --samples), valset.samples,\n"
            "metrics.csv (round,agent,train_loss,val_loss,kl_loss,consensus_error,occ_mse,occ_iou,\n"
            "reg_mu,reg_rho,neighbours), map_mean.png and map_std.png (agent 0, MC mean / std, paths on\n"
            "top) and summary.txt.\n"
            "\n"
            "options:\n"
            "  --radius M          disk graph radius in metres (default 4.0)\n"
            "  --batch B           minibatch size (default %u, <= %u)\n"
            "  --primal-steps B    optimiser steps per round (default %u)\n"
            "  --kl-weight W       weight of the BNN prior KL in the prediction loss (default %g)\n"
            "  --w-mu W, --w-rho W regulariser weights of the mu / rho groups, times rho_k (default 1)\n"
            "  --rho0 V            initial penalty (default %g);  --rho-scaling V (default %g)\n"
            "  --lr-start V, --lr-end V   log-decaying learning rate (default %g -> %g)\n"
            "  --persistent-adam   keep the Adam state across rounds (default: fresh each round)\n"
            "  --metrics-every M   metrics and a progress line every M rounds (default R/20)\n"
            "  --samples DIR       train on DIR/robot_<i>.samples (host_sim sample files) instead of\n"
            "                      scanning the paths\n"
            "  --valset FILE       validation samples file (default: generate --val-poses poses)\n"
            "  --val-poses N       random free poses x one 500-point scan (default 500, as DiNNO)\n"
            "  --occ-res M         grid of the occupancy metrics (default 0.1)\n"
            "  --map-res M         grid of the final maps (default 0.05);  --mc K passes (default 50)\n"
            "  --threads T         worker threads for node updates (default 1; results identical)\n"
            "  --scale S           plan metres per pixel (default %g)\n",
            BNN_PRESET_NAME, d.batch, BNN_MAX_BATCH, d.primal_steps, (double)d.kl_weight, (double)d.rho0,
            (double)d.rho_scaling, (double)d.lr_start, (double)d.lr_end, SIM_PLAN_DEFAULT_SCALE);
}

typedef struct opts {
    const char *plan, *paths, *out, *samples, *valset;
    long long robots, rounds, seed, metrics_every, val_poses, mc, threads;
    double radius, occ_res, map_res, scale;
    int inproc;
    sim_fleet_mode_t mode;
    dinno_cfg_t d;
    dinno_graph_kind_t graph;
    int have_strategy, have_graph;
    char strategy_name[16];
} opts_t;

static int parse(int argc, char **argv, opts_t *o)
{
    memset(o, 0, sizeof *o);
    o->robots = o->rounds = o->seed = -1;
    o->metrics_every = 0;
    o->val_poses = 500;
    o->mc = 50;
    o->threads = 1;
    o->radius = 4.0;
    o->occ_res = 0.1;
    o->map_res = 0.05;
    o->scale = SIM_PLAN_DEFAULT_SCALE;
    o->d = dinno_default_cfg();
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (strcmp(a, "--help") == 0 || strcmp(a, "-h") == 0) {
            fleet_usage(stdout);
            return 1;
        }
        if (strcmp(a, "--inproc") == 0) {
            o->inproc = 1;
            continue;
        }
        if (strcmp(a, "--persistent-adam") == 0) {
            o->d.persistent_adam = 1;
            continue;
        }
        if (strncmp(a, "--", 2) != 0) {
            fprintf(stderr, "host_sim fleet: unexpected argument '%s'\n", a);
            return -1;
        }
        if (cmd_need_value(argc, argv, i, "fleet", fleet_usage) != 0)
            return -1;
        const char *v = argv[++i];
        int bad = 0;
        long long ll = 0; // set by the parsers on success; 0 keeps -O1 -Wmaybe-uninitialized quiet
        double dv = 0.0;
        if (strcmp(a, "--plan") == 0)
            o->plan = v;
        else if (strcmp(a, "--paths") == 0)
            o->paths = v;
        else if (strcmp(a, "--out") == 0)
            o->out = v;
        else if (strcmp(a, "--samples") == 0)
            o->samples = v;
        else if (strcmp(a, "--valset") == 0)
            o->valset = v;
        else if (strcmp(a, "--robots") == 0)
            bad = cmd_parse_ll(v, a, 1, SIM_FLEET_MAX_AGENTS, &o->robots);
        else if (strcmp(a, "--rounds") == 0)
            bad = cmd_parse_ll(v, a, 1, 10000000, &o->rounds);
        else if (strcmp(a, "--seed") == 0)
            bad = cmd_parse_ll(v, a, 0, 0x7FFFFFFFFFFFFFFFLL, &o->seed);
        else if (strcmp(a, "--metrics-every") == 0)
            bad = cmd_parse_ll(v, a, 1, 10000000, &o->metrics_every);
        else if (strcmp(a, "--val-poses") == 0)
            bad = cmd_parse_ll(v, a, 1, 100000, &o->val_poses);
        else if (strcmp(a, "--mc") == 0)
            bad = cmd_parse_ll(v, a, 1, 1000, &o->mc);
        else if (strcmp(a, "--threads") == 0)
            bad = cmd_parse_ll(v, a, 1, 16, &o->threads);
        else if (strcmp(a, "--batch") == 0) {
            bad = cmd_parse_ll(v, a, 1, BNN_MAX_BATCH, &ll);
            o->d.batch = (uint32_t)ll;
        } else if (strcmp(a, "--primal-steps") == 0) {
            bad = cmd_parse_ll(v, a, 1, 100000, &ll);
            o->d.primal_steps = (uint32_t)ll;
        } else if (strcmp(a, "--kl-weight") == 0) {
            bad = cmd_parse_double(v, a, 0.0, 1e6, &dv);
            o->d.kl_weight = (float)dv;
        } else if (strcmp(a, "--w-mu") == 0) {
            bad = cmd_parse_double(v, a, 0.0, 1e6, &dv);
            o->d.w_mu = (float)dv;
        } else if (strcmp(a, "--w-rho") == 0) {
            bad = cmd_parse_double(v, a, 0.0, 1e6, &dv);
            o->d.w_rho = (float)dv;
        } else if (strcmp(a, "--rho0") == 0) {
            bad = cmd_parse_double(v, a, 1e-9, 1e6, &dv);
            o->d.rho0 = (float)dv;
        } else if (strcmp(a, "--rho-scaling") == 0) {
            bad = cmd_parse_double(v, a, 1e-3, 10.0, &dv);
            o->d.rho_scaling = (float)dv;
        } else if (strcmp(a, "--lr-start") == 0) {
            bad = cmd_parse_double(v, a, 1e-12, 10.0, &dv);
            o->d.lr_start = (float)dv;
        } else if (strcmp(a, "--lr-end") == 0) {
            bad = cmd_parse_double(v, a, 1e-12, 10.0, &dv);
            o->d.lr_end = (float)dv;
        } else if (strcmp(a, "--radius") == 0)
            bad = cmd_parse_double(v, a, 1e-6, 1e6, &o->radius);
        else if (strcmp(a, "--occ-res") == 0)
            bad = cmd_parse_double(v, a, 0.01, 10.0, &o->occ_res);
        else if (strcmp(a, "--map-res") == 0)
            bad = cmd_parse_double(v, a, 0.01, 10.0, &o->map_res);
        else if (strcmp(a, "--scale") == 0)
            bad = cmd_parse_double(v, a, 1e-6, 100.0, &o->scale);
        else if (strcmp(a, "--strategy") == 0) {
            o->have_strategy = 1;
            snprintf(o->strategy_name, sizeof o->strategy_name, "%s", v);
            if (strcmp(v, "central") == 0)
                o->mode = SIM_FLEET_CENTRAL;
            else if (strcmp(v, "isolated") == 0)
                o->mode = SIM_FLEET_ISOLATED;
            else if (dinno_strategy_parse(v, &o->d.strategy) == 0)
                o->mode = SIM_FLEET_DINNO;
            else {
                fprintf(stderr, "host_sim fleet: --strategy: '%s' is not kl, separate, uniform, central or isolated\n", v);
                bad = 1;
            }
        } else if (strcmp(a, "--graph") == 0) {
            o->have_graph = 1;
            if (dinno_graph_parse(v, &o->graph) != 0) {
                fprintf(stderr, "host_sim fleet: --graph: '%s' is not disk, full or ring\n", v);
                bad = 1;
            }
        } else {
            fprintf(stderr, "host_sim fleet: unknown option '%s' (see --help)\n", a);
            return -1;
        }
        if (bad)
            return -1;
    }
    if (!o->inproc) {
        fprintf(stderr, "host_sim fleet: only the in-process fleet exists (--inproc); the multi-process LCM "
                        "fleet is on the roadmap\n");
        return -1;
    }
    const char *missing = !o->plan ? "--plan" : !o->paths ? "--paths" : o->robots < 0 ? "--robots"
                        : o->rounds < 0 ? "--rounds" : !o->have_strategy ? "--strategy"
                        : !o->have_graph ? "--graph" : o->seed < 0 ? "--seed" : !o->out ? "--out" : NULL;
    if (missing) {
        fprintf(stderr, "host_sim fleet: %s is required (see --help)\n", missing);
        return -1;
    }
    if (o->metrics_every == 0)
        o->metrics_every = o->rounds >= 20 ? o->rounds / 20 : 1;
    return 0;
}

static int load_paths(const opts_t *o, const sim_plan_t *plan, sim_path_t *paths)
{
    for (int i = 0; i < (int)o->robots; i++) {
        char file[4096], err[512];
        snprintf(file, sizeof file, "%s/robot_%d.csv", o->paths, i);
        if (sim_path_read_csv(file, plan, &paths[i], err, sizeof err) != 0) {
            fprintf(stderr, "host_sim fleet: %s\n", err);
            return -1;
        }
    }
    return 0;
}

/* Reads `file` into *s (the caller frees it). On any error *s is NULL and nothing is left
 * allocated: the buffer has one owner at a time. */
static int read_samples(const char *file, const sim_plan_t *plan, ai_sample_t **s, size_t *n)
{
    sim_samples_header_t h;
    char err[8192];
    *s = NULL;
    int rc = sim_samples_read(file, &h, s, err, sizeof err);
    if (rc) {
        fprintf(stderr, "host_sim fleet: %s\n", err); /* err names the file */
    } else if (fabs(h.min_x - plan->min.x) > 1e-6 || fabs(h.min_y - plan->min.y) > 1e-6 ||
               fabs(h.max_x - plan->max.x) > 1e-6 || fabs(h.max_y - plan->max.y) > 1e-6) {
        fprintf(stderr, "host_sim fleet: %s: its bounding box is not the plan's (another plan?)\n", file);
        rc = -EINVAL;
    } else if (h.count == 0) {
        fprintf(stderr, "host_sim fleet: %s holds no samples\n", file);
        rc = -EINVAL;
    }
    if (rc) {
        free(*s);
        *s = NULL;
        return rc;
    }
    *n = (size_t)h.count;
    return 0;
}

int cmd_fleet(int argc, char **argv)
{
    opts_t o;
    int pr = parse(argc, argv, &o);
    if (pr > 0)
        return 0;
    if (pr < 0)
        return 2;
    const int N = (int)o.robots;
    int status = 1;
    char err[8192];
    sim_plan_t plan;
    memset(&plan, 0, sizeof plan);
    sim_path_t paths[SIM_FLEET_MAX_AGENTS];
    memset(paths, 0, sizeof paths);
    ai_sample_t *data[SIM_FLEET_MAX_AGENTS] = {0}, *val = NULL;
    size_t n_data[SIM_FLEET_MAX_AGENTS] = {0}, n_val = 0;
    sim_fleet_t *fleet = NULL;
    sim_occ_eval_t ev;
    memset(&ev, 0, sizeof ev);
    hal_host_file_t csv_out, sum_out; /* whole files or none (hal_host_file.h) */
    memset(&csv_out, 0, sizeof csv_out);
    memset(&sum_out, 0, sizeof sum_out);
    FILE *csv = NULL;
    char file[4096];

    if (sim_plan_load(o.plan, o.scale, &plan, err, sizeof err) != 0) {
        fprintf(stderr, "host_sim fleet: %s\n", err);
        return 1;
    }
    if (load_paths(&o, &plan, paths) != 0)
        goto out;
    if (cmd_prepare_out_dir("fleet", o.out) != 0)
        goto out;
    const uint64_t seed = (uint64_t)o.seed;
    printf("fleet (in-process, one host_sim process; the multi-process LCM fleet is on the roadmap)\n");
    printf("seed %llu, preset %s, %d agents, %lld rounds, strategy %s, graph %s", (unsigned long long)seed,
           BNN_PRESET_NAME, N, o.rounds, o.strategy_name, dinno_graph_name(o.graph));
    if (o.graph == DINNO_GRAPH_DISK)
        printf(" (radius %.2f m)", o.radius);
    printf("\n");
    /* ---- training data ---- */
    char sdir[2048];
    snprintf(sdir, sizeof sdir, "%s/samples", o.out);
    if (!o.samples && cmd_prepare_out_dir("fleet", sdir) != 0)
        goto out;
    for (int i = 0; i < N; i++) {
        if (o.samples) {
            snprintf(file, sizeof file, "%s/robot_%d.samples", o.samples, i);
            if (read_samples(file, &plan, &data[i], &n_data[i]) != 0)
                goto out;
        } else {
            sim_scan_cfg_t sc = sim_scan_default_cfg();
            sc.seed = seed;
            sc.robot = (uint32_t)i;
            char src[160];
            snprintf(src, sizeof src, "scan (fleet) path=%s/robot_%d.csv seed=%llu robot=%d", o.paths, i,
                     (unsigned long long)seed, i);
            snprintf(file, sizeof file, "%s/robot_%d.samples", sdir, i);
            sim_scan_stats_t ss;
            if (sim_scan_run(&plan, &paths[i], &sc, file, src, &ss, NULL, NULL, err, sizeof err) != 0) {
                fprintf(stderr, "host_sim fleet: scanning path %d: %s\n", i, err);
                goto out;
            }
            if (read_samples(file, &plan, &data[i], &n_data[i]) != 0)
                goto out;
        }
        printf("agent %d: %zu samples\n", i, n_data[i]);
    }
    /* ---- validation set ---- */
    if (o.valset) {
        if (read_samples(o.valset, &plan, &val, &n_val) != 0)
            goto out;
    } else {
        sim_valset_cfg_t vc = sim_valset_default_cfg();
        vc.n_poses = (int)o.val_poses;
        vc.seed = seed;
        char src[160];
        snprintf(src, sizeof src, "valset (fleet) poses=%lld seed=%llu", o.val_poses, (unsigned long long)seed);
        snprintf(file, sizeof file, "%s/valset.samples", o.out);
        if (sim_valset_write(&plan, &vc, file, src, NULL, err, sizeof err) != 0) {
            fprintf(stderr, "host_sim fleet: validation set: %s\n", err);
            goto out;
        }
        if (read_samples(file, &plan, &val, &n_val) != 0)
            goto out;
    }
    printf("validation set: %zu points\n", n_val);
    if (sim_occ_eval_build(&plan, o.occ_res, &ev) != 0) {
        fprintf(stderr, "host_sim fleet: cannot rasterise the plan for the occupancy metrics\n");
        goto out;
    }
    /* ---- the fleet ---- */
    sim_fleet_cfg_t fc;
    sim_fleet_cfg_default(&fc);
    fc.n_agents = N;
    fc.rounds = (uint32_t)o.rounds;
    fc.mode = o.mode;
    fc.dinno = o.d; /* sim_fleet_create sets total_rounds from fc.rounds */
    fc.graph = o.graph;
    fc.radius = o.radius;
    fc.seed = seed;
    fc.threads = (int)o.threads;
    const ai_sample_t *cdata[SIM_FLEET_MAX_AGENTS];
    for (int i = 0; i < N; i++)
        cdata[i] = data[i];
    if (sim_fleet_create(&fc, NULL, cdata, n_data, paths, &fleet, err, sizeof err) != 0) {
        fprintf(stderr, "host_sim fleet: %s\n", err);
        goto out;
    }
    snprintf(file, sizeof file, "%s/metrics.csv", o.out);
    int wrc = hal_host_file_begin(&csv_out, file);
    if (wrc < 0) {
        fprintf(stderr, "host_sim fleet: %s: %s\n", file, hal_host_file_strerror(wrc));
        goto out;
    }
    csv = hal_host_file_stream(&csv_out); /* fed as rounds go; replaces metrics.csv at the end */
    fprintf(csv, "round,agent,train_loss,val_loss,kl_loss,consensus_error,occ_mse,occ_iou,reg_mu,reg_rho,neighbours\n");
    const int M = sim_fleet_models(fleet);
    sim_fleet_metrics_t last[SIM_FLEET_MAX_AGENTS];
    uint64_t isolated_rounds = 0, split_rounds = 0;
    dinno_graph_report_t rep; /* of the last round's graph */
    memset(&rep, 0, sizeof rep);
    for (uint32_t k = 0; k <= (uint32_t)o.rounds; k++) {
        if (k > 0) {
            int rc = sim_fleet_round(fleet, &rep);
            if (rc) {
                fprintf(stderr, "host_sim fleet: round %u failed (%d)\n", k - 1, rc);
                goto out;
            }
            if (o.mode == SIM_FLEET_DINNO) {
                isolated_rounds += rep.isolated > 0;
                split_rounds += rep.components > 1;
            }
        }
        if (k % (uint32_t)o.metrics_every != 0 && k != (uint32_t)o.rounds)
            continue;
        double vmean = 0, cmax = 0, iou = 0;
        for (int i = 0; i < M; i++) {
            int rc = sim_fleet_metrics(fleet, i, val, n_val, &ev, &last[i]);
            if (rc) {
                fprintf(stderr, "host_sim fleet: metrics failed (%d)\n", rc);
                goto out;
            }
            const sim_fleet_metrics_t *m = &last[i];
            const dinno_round_stats_t *st = sim_fleet_last_stats(fleet, i);
            fprintf(csv, "%u,%d,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%u\n", k, i, m->train_loss, m->val_loss,
                    m->kl_loss, m->consensus_error, m->occ_mse, m->occ_iou, m->reg_mu, m->reg_rho,
                    k ? st->neighbours : 0);
            vmean += m->val_loss / M;
            iou += m->occ_iou / M;
            cmax = fmax(cmax, m->consensus_error);
        }
        fflush(csv);
        printf("round %6u/%lld  val_loss %.4f  occ_iou %.3f  consensus_err(max) %.4f", k, o.rounds, vmean, iou, cmax);
        if (o.mode == SIM_FLEET_DINNO && k > 0)
            printf("  graph: %u edges, %u components, %u isolated", rep.edges, rep.components, rep.isolated);
        printf("\n");
        fflush(stdout);
    }
    csv = NULL;
    snprintf(file, sizeof file, "%s/metrics.csv", o.out);
    if ((wrc = hal_host_file_commit(&csv_out)) < 0) {
        fprintf(stderr, "host_sim fleet: %s: %s\n", file, hal_host_file_strerror(wrc));
        goto out;
    }
    /* ---- maps and summary ---- */
    char mean_png[4096], std_png[4096];
    snprintf(mean_png, sizeof mean_png, "%s/map_mean.png", o.out);
    snprintf(std_png, sizeof std_png, "%s/map_std.png", o.out);
    double smax = 0;
    if (sim_maps_write(&sim_fleet_node(fleet, 0)->model, &plan, o.map_res, (uint32_t)o.mc, seed, paths, N,
                             mean_png, std_png, &smax, err, sizeof err) != 0) {
        fprintf(stderr, "host_sim fleet: maps: %s\n", err);
        goto out;
    }
    snprintf(file, sizeof file, "%s/summary.txt", o.out);
    if ((wrc = hal_host_file_begin(&sum_out, file)) < 0) {
        fprintf(stderr, "host_sim fleet: %s: %s\n", file, hal_host_file_strerror(wrc));
        goto out;
    }
    FILE *s = hal_host_file_stream(&sum_out);
    double v = 0, vmin = INFINITY, vmax = -INFINITY, mse = 0, io = 0, ce = 0, tl = 0;
    for (int i = 0; i < M; i++) {
        v += last[i].val_loss / M;
        vmin = fmin(vmin, last[i].val_loss);
        vmax = fmax(vmax, last[i].val_loss);
        mse += last[i].occ_mse / M;
        io += last[i].occ_iou / M;
        ce = fmax(ce, last[i].consensus_error);
        tl += last[i].train_loss / M;
    }
    for (int pass = 0; pass < 2; pass++) {
        FILE *f = pass ? stdout : s;
        fprintf(f, "mode: in-process fleet (one process; the multi-process LCM fleet is on the roadmap)\n");
        fprintf(f, "seed: %llu\npreset: %s (%zu parameters)\nagents: %d\nmodels: %d\nrounds: %lld\n",
                (unsigned long long)seed, BNN_PRESET_NAME, bnn_n_params(&sim_fleet_node(fleet, 0)->model), N, M,
                o.rounds);
        fprintf(f, "strategy: %s\ngraph: %s\n", o.strategy_name, dinno_graph_name(o.graph));
        if (o.graph == DINNO_GRAPH_DISK)
            fprintf(f, "radius_m: %g\n", o.radius);
        fprintf(f, "rho0: %g\nrho_scaling: %g\nprimal_steps: %u\nbatch: %u\nlr: %g -> %g\nkl_weight: %g\n"
                   "w_mu: %g\nw_rho: %g\nadam: %s\n",
                (double)o.d.rho0, (double)o.d.rho_scaling, o.d.primal_steps, o.d.batch, (double)o.d.lr_start,
                (double)o.d.lr_end, (double)o.d.kl_weight, (double)o.d.w_mu, (double)o.d.w_rho,
                o.d.persistent_adam ? "persistent" : "fresh each round");
        if (o.mode == SIM_FLEET_DINNO)
            fprintf(f, "rounds with an isolated agent: %llu; with a split graph: %llu\n",
                    (unsigned long long)isolated_rounds, (unsigned long long)split_rounds);
        fprintf(f, "validation points: %zu\n", n_val);
        fprintf(f, "final val_loss (mean over models): %.5f (min %.5f, max %.5f)\n", v, vmin, vmax);
        fprintf(f, "final train_loss (mean): %.5f\n", tl);
        fprintf(f, "final occ_mse (mean, %.2f m grid): %.5f\nfinal occ_iou (mean): %.4f\n", o.occ_res, mse, io);
        fprintf(f, "final consensus_error (max): %.6f\n", ce);
        fprintf(f, "maps: agent 0, %lld MC passes, %.3f m grid, max std %.4f: %s %s\n", o.mc, o.map_res, smax,
                mean_png, std_png);
    }
    if ((wrc = hal_host_file_commit(&sum_out)) < 0) {
        fprintf(stderr, "host_sim fleet: %s: %s\n", file, hal_host_file_strerror(wrc));
        goto out;
    }
    printf("results in %s (metrics.csv, map_mean.png, map_std.png, summary.txt)\n", o.out);
    status = 0;
out:
    hal_host_file_abort(&csv_out); /* no-ops after a commit */
    hal_host_file_abort(&sum_out);
    sim_fleet_destroy(fleet);
    sim_occ_eval_free(&ev);
    for (int i = 0; i < SIM_FLEET_MAX_AGENTS; i++) {
        free(data[i]);
        sim_path_free(&paths[i]);
    }
    free(val);
    sim_plan_free(&plan);
    return status;
}
