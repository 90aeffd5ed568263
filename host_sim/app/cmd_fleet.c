/* host_sim fleet --inproc: the deterministic in-process DiNNO fleet (and its baselines). */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "ai/bnn_ckpt.h"
#include "cmd_coverage.h"
#include "cli.h"
#include "commands.h"
#include "sim_defaults.h"
#include "sim_fleet.h"
#include "sim_kernels.h"
#include "sim_maps.h"
#include "sim_paths.h"
#include "sim_plan.h"
#include "sim_samples.h"
#include "sim_scan.h"
#include "sim_valset.h"

static const char *const val_mode_names[3] = {"mean", "sample", "mc"}; /* --val-mode, by index */
#define FLEET_STRATEGIES "kl|separate|uniform|central|isolated" /* --strategy, by index */

typedef struct opts {
    const char *plan, *paths, *out, *samples, *valset;
    long long robots, rounds, seed, metrics_every, val_poses, mc, threads, val_mc, val_stride;
    int val_mode; /* 0 mean, 1 sample, 2 mc */
    double radius, occ_res, map_res, scale;
    int inproc;
    int strategy; /* index in FLEET_STRATEGIES */
    sim_fleet_mode_t mode;
    dinno_cfg_t d;
    dinno_graph_kind_t graph;
    char strategy_name[16];
    sim_fleet_bad_t bad;    /* --bad-member I:KIND */
    long long bad_agent;
    double bad_scale;
    sim_links_t links;      /* --link-success, --link-faults (checked against --robots in parse) */
} opts_t;

/* The same values as host_sim run's where the options overlap (sim_defaults.h), so that the
 * in-process fleet with no options is the reference of a process fleet with none. */
static void defaults(opts_t *o)
{
    memset(o, 0, sizeof *o);
    o->robots = o->rounds = o->seed = -1;
    o->metrics_every = 0;
    o->val_poses = SIM_DEF_VAL_POSES;
    o->mc = SIM_DEF_MC;
    o->val_mc = SIM_DEF_MC;
    o->val_stride = 1;
    o->threads = 1;
    o->radius = SIM_DEF_RADIUS_M;
    o->occ_res = SIM_DEF_OCC_RES_M;
    o->map_res = SIM_DEF_MAP_RES_M;
    o->scale = SIM_PLAN_DEFAULT_SCALE;
    o->d = dinno_default_cfg(); /* its strategy, kl, is --strategy's default: FLEET_STRATEGIES lists it first */
    o->mode = SIM_FLEET_DINNO;
    sim_links_default(&o->links);
}

/* --bad-member I:scale=S|flip|random|silent */
static int parse_bad_member(const char *cmd, const char *opt, const char *v, void *field, void *opts)
{
    (void)field;
    opts_t *o = opts;
    const char *colon = strchr(v, ':');
    char *end = NULL;
    long long i = colon ? strtoll(v, &end, 10) : -1;
    if (colon == NULL || end != colon || colon == v || i < 0 || i > SIM_FLEET_MAX_AGENTS - 1 ||
        sim_fleet_bad_parse(colon + 1, &o->bad, &o->bad_scale) != 0) {
        fprintf(stderr, "host_sim %s: %s: '%s' is not I:scale=S, I:flip, I:random or I:silent (I in [0, %d])\n", cmd,
                opt, v, SIM_FLEET_MAX_AGENTS - 1);
        return -1;
    }
    o->bad_agent = i;
    return 0;
}

/* --link-faults SPEC (repeatable: the cuts add up). The agent ids are checked against --robots
   once every option is read (parse). */
static int parse_link_faults(const char *cmd, const char *opt, const char *v, void *field, void *opts)
{
    (void)opts;
    char why[300];
    if (sim_links_parse(v, field, why, sizeof why) != 0) {
        fprintf(stderr, "host_sim %s: %s: '%s': %s\n", cmd, opt, v, why);
        return -1;
    }
    return 0;
}

static const cli_opt_t fleet_opts[] = {
    {.names = "--inproc", CLI_FLAG(opts_t, inproc, 1), .help = "the in-process fleet (required)"},
    {.names = "--plan", .meta = "FILE.svg", CLI_STRING(opts_t, plan), .required = 1, .help = "the floor plan"},
    {.names = "--paths", .meta = "DIR", CLI_STRING(opts_t, paths), .required = 1,
     .help = "the tours, DIR/robot_<i>.csv (host_sim paths gen)"},
    {.names = "--robots", .meta = "N", CLI_INT(opts_t, robots, 1, SIM_FLEET_MAX_AGENTS), .required = 1,
     .help = "agents"},
    {.names = "--rounds", .meta = "R", CLI_INT(opts_t, rounds, 1, 10000000), .required = 1, .help = "DiNNO rounds"},
    {.names = "--graph", CLI_CHOICE(opts_t, graph, "disk|full|ring"),
     .values = (const int[]){DINNO_GRAPH_DISK, DINNO_GRAPH_FULL, DINNO_GRAPH_RING}, .required = 1,
     .help = "communication graph: within --radius, all, or a ring"},
    {.names = "--seed", .meta = "S", CLI_INT(opts_t, seed, 0, INT64_MAX), .required = 1, .help = "run seed"},
    {.names = "--out", .meta = "DIR", CLI_STRING(opts_t, out), .required = 1, .help = "output folder"},
    {.names = "--strategy", .meta = "S", CLI_CHOICE(opts_t, strategy, FLEET_STRATEGIES),
     .help = "kl (as tools/fleet), separate, uniform (DiNNO regularisers), central or isolated (the baselines)"},
    {.names = "--radius", .meta = "M", CLI_DOUBLE(opts_t, radius, 1e-6, 1e6), .help = "disk graph radius in metres"},
    {CLI_INCLUDE(opts_t, d, cmd_dinno_opts)},
    {.names = "--persistent-adam", CLI_FLAG(opts_t, d.persistent_adam, 1),
     .help = "keep the Adam state across rounds (default: fresh each round)"},
    {.names = "--val-mode", .meta = "M", CLI_CHOICE(opts_t, val_mode, "mean|sample|mc"),
     .help = "which validation loss is val_loss: mean (one pass with the mean weights), sample (one sampled "
             "pass), mc (BCE of the --val-mc pass predictive mean); val_mean and val_sample are on every row, "
             "val_mc on the last (on every row with --val-mode mc: --val-mc times dearer)"},
    {.names = "--val-mc", .meta = "K", CLI_INT(opts_t, val_mc, 1, 1000), .help = "passes of the predictive mean"},
    {.names = "--metrics-every", .meta = "M", CLI_INT(opts_t, metrics_every, 1, 10000000), .def = "R/" SIM_DEF_STR(SIM_DEF_METRICS_ROWS),
     .help = "metrics and a progress line every M rounds"},
    {.names = "--val-stride", .meta = "V", CLI_INT(opts_t, val_stride, 1, 10000000),
     .help = "the validation and occupancy columns on every V-th metrics row only (and the last; NaN on the "
             "others): consensus error and losses per round at a fraction of the cost"},
    {.names = "--encoding", CLI_CHOICE(opts_t, d.codec, "fp32|int8|int8-ef|int4-ef"),
     .values = (const int[]){DINNO_CODEC_FP32, DINNO_CODEC_INT8, DINNO_CODEC_INT8_EF, DINNO_CODEC_INT4_EF},
     .help = "how the states travel, as host_sim run's: each node's neighbours hold what the codec delivers "
             "(int8-ef, int4-ef: differences against public copies, dinno.h)"},
    {.names = "--samples", .meta = "DIR", CLI_STRING(opts_t, samples),
     .help = "train on DIR/robot_<i>.samples (host_sim sample files) instead of scanning the paths"},
    {.names = "--valset", .meta = "FILE", CLI_STRING(opts_t, valset), .def = "generate --val-poses poses",
     .help = "validation samples file"},
    {.names = "--val-poses", .meta = "N", CLI_INT(opts_t, val_poses, 1, 100000),
     .help = "random free poses x one 500-point scan (as DiNNO)"},
    {.names = "--occ-res", .meta = "M", CLI_DOUBLE(opts_t, occ_res, 0.01, 10.0), .help = "grid of the occupancy metrics"},
    {.names = "--map-res", .meta = "M", CLI_DOUBLE(opts_t, map_res, 0.01, 10.0), .help = "grid of the final maps"},
    {.names = "--mc", .meta = "K", CLI_INT(opts_t, mc, 1, 1000), .help = "MC passes of the final maps"},
    {.names = "--threads", .meta = "T", CLI_INT(opts_t, threads, 1, 16),
     .help = "worker threads for node updates (results identical)"},
    {.names = "--bad-member", .meta = "I:K", CLI_CUSTOM(opts_t, bad, parse_bad_member),
     .help = "agent I trains honestly but sends bad states every round: K = scale=S (theta x S), flip (-theta), "
             "random (normal, theta's rms), or silent (sends nothing: the baseline); summary.txt gives the "
             "honest members' figures"},
    {.names = "--link-success", .meta = "P", CLI_DOUBLE(opts_t, links.success, 0.0, 1.0),
     .help = "probability a link delivers in a round, both ways or neither (seeded by --seed: the same seed drops "
             "the same links)"},
    {.names = "--link-faults", .meta = "SPEC", CLI_CUSTOM(opts_t, links, parse_link_faults),
     .help = "scheduled cuts, ';'-separated (or the option repeated, at most " SIM_DEF_STR(SIM_LINKS_MAX_CUTS)
             " in all): partition=0.1.2/3.4.5 (robot ids '.'-separated; robots named in no group form one more "
             "group) or away=I (robot I alone), with from=R1, until=R2 (rounds [R1, R2), default 0 and the end): "
             "robots of different groups do not hear each other then"},
    {.names = "--scale", .meta = "S", CLI_DOUBLE(opts_t, scale, 1e-6, 100.0), .help = "plan metres per pixel"},
    CLI_OPT_END,
};

static void fleet_usage(FILE *out)
{
    fprintf(out,
            "usage: host_sim fleet --inproc --plan FILE.svg --paths DIR --robots N --rounds R\n"
            "                      --graph disk|full|ring --seed S --out DIR\n"
            "                      [--strategy kl|separate|uniform|central|isolated] [options]\n"
            "\n"
            "Trains N agents (one BNN each, preset '%s') on lidar samples taken along their paths\n"
            "(DIR/robot_<i>.csv, i = 0..N-1), in synchronous DiNNO rounds, in ONE process (--inproc, required):\n"
            "the reference of the multi-process fleet (tools/fleet: one `host_sim run --fleet N` per robot\n"
            "over LCM), which trains the same models bit for bit from the same seed (offline, no loss).\n"
            "The options both take have the same defaults (`host_sim defaults`: radius_m, map_res_m, ...).\n"
            "Baselines with the same network and step budget: 'central' (one model on the\n"
            "pooled data) and 'isolated' (no communication).\n"
            "\n"
            "Training data: each robot drives its path in the ODE world (the same loop as host_sim scan,\n"
            "seed S, robot i) unless --samples gives host_sim sample files. Validation: host_sim valset\n"
            "(seed S) unless --valset.\n"
            "Writes into --out: samples/robot_<i>.samples (training data, unless --samples), valset.samples,\n"
            "coverage.csv and coverage.bin (the union of the tours' scans, each tour from t = 0; unless\n"
            "--samples: see host_sim coverage --help),\n"
            "metrics.csv (round,agent,train_loss,val_loss,kl_loss,consensus_error,occ_mse,occ_iou,\n"
            "reg_mu,reg_rho,neighbours,val_mean,val_sample,val_mc,sigma_mean; val_loss is the --val-mode one,\n"
            "sigma_mean the mean softplus(rho) of the Bayesian weights),\n"
            "map_mean.png and map_std.png (agent 0, MC mean / std, paths on\n"
            "top), models/robot_<i>.bnn (every final model) and summary.txt.\n"
            "\n"
            "options:\n",
            BNN_PRESET_NAME);
    opts_t d;
    defaults(&d);
    cli_opts_help(out, fleet_opts, &d);
}

static int parse(int argc, char **argv, opts_t *o)
{
    defaults(o);
    const cli_parser_t parser = {.cmd = "fleet", .opts = fleet_opts, .usage = fleet_usage};
    const int pr = cli_opts_parse(&parser, argc, argv, o, NULL, NULL);
    if (pr != 0)
        return pr;
    if (!o->inproc) {
        fprintf(stderr, "host_sim fleet: --inproc is required (this command is the in-process fleet; the "
                        "multi-process one is tools/fleet, one `host_sim run --fleet N` per robot)\n");
        return -1;
    }
    (void)cli_choice_name(FLEET_STRATEGIES, o->strategy, o->strategy_name, sizeof o->strategy_name);
    o->mode = strcmp(o->strategy_name, "central") == 0    ? SIM_FLEET_CENTRAL
              : strcmp(o->strategy_name, "isolated") == 0 ? SIM_FLEET_ISOLATED
                                                          : SIM_FLEET_DINNO;
    if (o->mode == SIM_FLEET_DINNO && dinno_strategy_parse(o->strategy_name, &o->d.strategy) != 0)
        return -1;
    if (o->mode == SIM_FLEET_DINNO && o->graph == DINNO_GRAPH_FULL && o->robots - 1 > (long long)DINNO_GRAPH_MAX_DEGREE) {
        /* Said before the robots' tours are scanned, not after (sim_fleet_create says it too). */
        fprintf(stderr, "host_sim fleet: --graph full of %d robots needs %d neighbour slots, the board has %u: "
                        "use --graph disk (each robot takes its %u nearest in reach)\n",
                (int)o->robots, (int)o->robots - 1, (unsigned)DINNO_GRAPH_MAX_DEGREE, (unsigned)DINNO_GRAPH_MAX_DEGREE);
        return -1;
    }
    char why[300];
    if (sim_links_check(&o->links, (int)o->robots, why, sizeof why) != 0) {
        fprintf(stderr, "host_sim fleet: --link-faults: %s\n", why);
        return -1;
    }
    if (sim_links_active(&o->links) && o->mode != SIM_FLEET_DINNO) {
        fprintf(stderr, "host_sim fleet: --link-success and --link-faults need a DiNNO strategy (the '%s' baseline "
                        "does not communicate)\n", o->strategy_name);
        return -1;
    }
    if (o->metrics_every == 0)
        o->metrics_every = o->rounds >= SIM_DEF_METRICS_ROWS ? o->rounds / SIM_DEF_METRICS_ROWS : 1;
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

/* Everything one `host_sim fleet` run holds; freed in one place (job_free). */
typedef struct job {
    opts_t o;
    int n;                       /* agents */
    uint64_t seed;
    sim_plan_t plan;
    sim_path_t paths[SIM_FLEET_MAX_AGENTS];
    ai_sample_t *data[SIM_FLEET_MAX_AGENTS], *val;
    size_t n_data[SIM_FLEET_MAX_AGENTS], n_val;
    sim_occ_eval_t ev;
    sim_fleet_t *fleet;
    sim_fleet_metrics_t last[SIM_FLEET_MAX_AGENTS]; /* metrics of the final round */
    uint64_t isolated_rounds, split_rounds;
    uint64_t rejoined, stale; /* dinno_round_stats_t, summed over the rounds and models */
    sim_coverage_t cov;       /* the union of the tours' scans (empty with --samples) */
    char err[8192];
} job_t;

static void job_free(job_t *j)
{
    sim_coverage_free(&j->cov);
    sim_fleet_destroy(j->fleet);
    sim_occ_eval_free(&j->ev);
    for (int i = 0; i < SIM_FLEET_MAX_AGENTS; i++) {
        free(j->data[i]);
        sim_path_free(&j->paths[i]);
    }
    free(j->val);
    sim_plan_free(&j->plan);
}

/* Each agent's training samples: read from --samples, or scanned along its tour now. */
static int load_training_data(job_t *j)
{
    const opts_t *o = &j->o;
    char sdir[2048], file[4096];
    snprintf(sdir, sizeof sdir, "%s/samples", o->out);
    if (!o->samples && cmd_prepare_out_dir("fleet", sdir) != 0)
        return -1;
    /* Every robot's tour starts at t = 0 on its own clock, as the fleet's robots drive at once:
       one grid of first-seen times over them all is the fleet's union (sim_coverage.h). */
    if (!o->samples && sim_coverage_from_plan(&j->cov, &j->plan, SIM_COVERAGE_RES_M) != 0) {
        fprintf(stderr, "host_sim fleet: %s: cannot make its %.2f m coverage grid\n", o->plan, SIM_COVERAGE_RES_M);
        return -1;
    }
    for (int i = 0; i < j->n; i++) {
        if (o->samples) {
            snprintf(file, sizeof file, "%s/robot_%d.samples", o->samples, i);
        } else {
            sim_scan_cfg_t sc = sim_scan_default_cfg();
            sc.seed = j->seed;
            sc.robot = (uint32_t)i;
            sc.coverage = &j->cov;
            char src[160];
            snprintf(src, sizeof src, "scan (fleet) path=%s/robot_%d.csv seed=%llu robot=%d", o->paths, i,
                     (unsigned long long)j->seed, i);
            snprintf(file, sizeof file, "%s/robot_%d.samples", sdir, i);
            sim_scan_stats_t ss;
            if (sim_scan_run(&j->plan, &j->paths[i], &sc, file, src, &ss, NULL, NULL, j->err, sizeof j->err) != 0) {
                fprintf(stderr, "host_sim fleet: scanning path %d: %s\n", i, j->err);
                return -1;
            }
        }
        if (read_samples(file, &j->plan, &j->data[i], &j->n_data[i]) != 0)
            return -1;
        printf("agent %d: %zu samples\n", i, j->n_data[i]);
    }
    if (!o->samples) {
        char bin[4096];
        snprintf(file, sizeof file, "%s/coverage.csv", o->out);
        snprintf(bin, sizeof bin, "%s/coverage.bin", o->out);
        if (cmd_coverage_write("fleet", &j->cov, j->n, file, bin) != 0)
            return -1;
        cmd_coverage_line(stdout, &j->cov, j->n);
    }
    return 0;
}

/* The validation set (--valset, or drawn now) and the ground-truth cells of the metrics. */
static int load_validation(job_t *j)
{
    const opts_t *o = &j->o;
    if (o->valset) {
        if (read_samples(o->valset, &j->plan, &j->val, &j->n_val) != 0)
            return -1;
    } else {
        sim_valset_cfg_t vc = sim_valset_default_cfg();
        vc.n_poses = (int)o->val_poses;
        vc.seed = j->seed;
        char src[160], file[4096];
        snprintf(src, sizeof src, "valset (fleet) poses=%lld seed=%llu", o->val_poses, (unsigned long long)j->seed);
        snprintf(file, sizeof file, "%s/valset.samples", o->out);
        if (sim_valset_write(&j->plan, &vc, file, src, NULL, j->err, sizeof j->err) != 0) {
            fprintf(stderr, "host_sim fleet: validation set: %s\n", j->err);
            return -1;
        }
        if (read_samples(file, &j->plan, &j->val, &j->n_val) != 0)
            return -1;
    }
    printf("validation set: %zu points\n", j->n_val);
    if (sim_occ_eval_build(&j->plan, o->occ_res, &j->ev) != 0) {
        fprintf(stderr, "host_sim fleet: cannot rasterise the plan for the occupancy metrics\n");
        return -1;
    }
    return 0;
}

/* The validation loss --val-mode names. */
static double val_of(const opts_t *o, const sim_fleet_metrics_t *m)
{
    return o->val_mode == 0 ? m->val_loss : o->val_mode == 1 ? m->val_sample : m->val_mc;
}

/* The rounds, with metrics.csv fed as they go (it replaces the old one at the end). */
static int train(job_t *j)
{
    const opts_t *o = &j->o;
    sim_fleet_cfg_t fc;
    sim_fleet_cfg_default(&fc);
    fc.n_agents = j->n;
    fc.rounds = (uint32_t)o->rounds;
    fc.mode = o->mode;
    fc.dinno = o->d; /* sim_fleet_create sets total_rounds from fc.rounds */
    fc.graph = o->graph;
    fc.radius = o->radius;
    fc.seed = j->seed;
    fc.threads = (int)o->threads;
    fc.bad = o->bad;
    fc.bad_agent = (int)o->bad_agent;
    fc.bad_scale = o->bad_scale;
    fc.links = o->links;
    const ai_sample_t *cdata[SIM_FLEET_MAX_AGENTS];
    for (int i = 0; i < j->n; i++)
        cdata[i] = j->data[i];
    if (sim_fleet_create(&fc, NULL, cdata, j->n_data, j->paths, &j->fleet, j->err, sizeof j->err) != 0) {
        fprintf(stderr, "host_sim fleet: %s\n", j->err);
        return -1;
    }
    char file[4096];
    snprintf(file, sizeof file, "%s/metrics.csv", o->out);
    hal_host_file_t out;
    if (cmd_out_begin("fleet", &out, file) != 0)
        return -1;
    FILE *csv = hal_host_file_stream(&out);
    int rc = 0;
    fprintf(csv, "round,agent,train_loss,val_loss,kl_loss,consensus_error,occ_mse,occ_iou,reg_mu,reg_rho,neighbours,"
                 "val_mean,val_sample,val_mc,sigma_mean\n");
    const int M = sim_fleet_models(j->fleet);
    dinno_graph_report_t rep; /* of the last round's graph */
    memset(&rep, 0, sizeof rep);
    for (uint32_t k = 0; k <= (uint32_t)o->rounds && rc == 0; k++) {
        if (k > 0) {
            if ((rc = sim_fleet_round(j->fleet, &rep)) != 0) {
                fprintf(stderr, "host_sim fleet: round %u failed (%d)\n", k - 1, rc);
                break;
            }
            if (o->mode == SIM_FLEET_DINNO) {
                j->isolated_rounds += rep.isolated > 0;
                j->split_rounds += rep.components > 1;
                for (int i = 0; i < M; i++) {
                    j->rejoined += sim_fleet_last_stats(j->fleet, i)->rejoined;
                    j->stale += sim_fleet_last_stats(j->fleet, i)->stale;
                }
            }
        }
        if (k % (uint32_t)o->metrics_every != 0 && k != (uint32_t)o->rounds)
            continue;
        double vmean = 0, cmax = 0, iou = 0;
        const uint32_t mc_k = o->val_mode == 2 || k == (uint32_t)o->rounds ? (uint32_t)o->val_mc : 0;
        const int val_row = (k / (uint32_t)o->metrics_every) % (uint32_t)o->val_stride == 0 || k == (uint32_t)o->rounds;
        for (int i = 0; i < M && rc == 0; i++) {
            if ((rc = sim_fleet_metrics(j->fleet, i, val_row ? j->val : NULL, val_row ? j->n_val : 0,
                                        val_row ? &j->ev : NULL, val_row ? mc_k : 0, &j->last[i])) != 0) {
                fprintf(stderr, "host_sim fleet: metrics failed (%d)\n", rc);
                break;
            }
            const sim_fleet_metrics_t *m = &j->last[i];
            const dinno_round_stats_t *st = sim_fleet_last_stats(j->fleet, i);
            fprintf(csv, "%u,%d,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%u,%.6g,%.6g,%.6g,%.6g\n", k, i, m->train_loss,
                    val_of(o, m), m->kl_loss, m->consensus_error, m->occ_mse, m->occ_iou, m->reg_mu, m->reg_rho,
                    k ? st->neighbours : 0, m->val_loss, m->val_sample, m->val_mc, m->sigma_mean);
            vmean += val_of(o, m) / M;
            iou += m->occ_iou / M;
            cmax = fmax(cmax, m->consensus_error);
        }
        if (rc != 0)
            break;
        fflush(csv);
        if (!val_row)
            continue;
        printf("round %6u/%lld  val_loss %.4f  occ_iou %.3f  consensus_err(max) %.4f", k, o->rounds, vmean, iou, cmax);
        if (o->mode == SIM_FLEET_DINNO && k > 0)
            printf("  graph: %u edges, %u components, %u isolated", rep.edges, rep.components, rep.isolated);
        if (o->mode == SIM_FLEET_DINNO && k > 0 && sim_links_active(&o->links)) {
            uint32_t dropped, offered;
            sim_fleet_last_links(j->fleet, &dropped, &offered);
            printf("  links: %u of %u dropped", dropped, offered);
        }
        printf("\n");
        fflush(stdout);
    }
    if (rc != 0) {
        hal_host_file_abort(&out);
        return -1;
    }
    return cmd_out_commit("fleet", &out);
}

/* Maps of agent 0 and summary.txt (also on stdout). */
static int report(job_t *j)
{
    const opts_t *o = &j->o;
    const int M = sim_fleet_models(j->fleet);
    char mean_png[4096], std_png[4096], file[4096];
    snprintf(mean_png, sizeof mean_png, "%s/map_mean.png", o->out);
    snprintf(std_png, sizeof std_png, "%s/map_std.png", o->out);
    double smax = 0;
    if (sim_maps_write(&sim_fleet_node(j->fleet, 0)->model, &j->plan, o->map_res, (uint32_t)o->mc, j->seed, j->paths,
                       j->n, mean_png, std_png, &smax, j->err, sizeof j->err) != 0) {
        fprintf(stderr, "host_sim fleet: maps: %s\n", j->err);
        return -1;
    }
    /* Every model's final checkpoint: the reference the multi-process fleet is compared with. */
    snprintf(file, sizeof file, "%s/models", o->out);
    if (hal_host_file_mkdirs(file) != 0) {
        fprintf(stderr, "host_sim fleet: cannot create %s\n", file);
        return -1;
    }
    /* What each robot knows after the posterior's consensus: in its checkpoint, and robot 0's map. */
    bnn_post_t *posts = malloc((size_t)M * sizeof *posts);
    sim_fleet_post_report_t prep;
    int prc = posts ? sim_fleet_posteriors(j->fleet, posts, SIM_DEF_POST_ROUNDS, &prep) : -ENOMEM;
    if (prc == 0) {
        sim_maps_grid_t g = {.res = o->map_res, .x0 = j->plan.min.x, .y0 = j->plan.min.y};
        g.w = (int)ceil((j->plan.max.x - j->plan.min.x) / o->map_res);
        g.h = (int)ceil((j->plan.max.y - j->plan.min.y) / o->map_res);
        float *epi = malloc((size_t)g.w * g.h * sizeof *epi);
        snprintf(file, sizeof file, "%s/map_epistemic.png", o->out);
        prc = !epi ? -ENOMEM
                   : sim_maps_epistemic(&sim_fleet_node(j->fleet, 0)->model, &posts[0], &j->plan, &g, epi, j->err,
                                        sizeof j->err);
        if (prc == 0)
            prc = sim_maps_write_epistemic_png(&g, epi, &j->plan, j->paths, j->n, file, j->err, sizeof j->err);
        free(epi);
        if (prc == 0)
            printf("epistemic: %d model(s), %d posterior round(s) (every robot the fleet's posterior); agent 0: %s\n", M,
                   prep.iterations, file);
    }
    if (prc != 0) {
        fprintf(stderr, "host_sim fleet: epistemic posterior failed (%d): %s\n", prc, j->err);
        free(posts);
        return -1;
    }
    static uint8_t ckpt[BNN_CKPT_MAX_BYTES];
    for (int i = 0; i < M; i++) {
        size_t n = 0;
        hal_host_file_t mf;
        snprintf(file, sizeof file, "%s/models/robot_%d.bnn", o->out, i);
        if (bnn_ckpt_save_post(&sim_fleet_node(j->fleet, i)->model, 0, &posts[i], ckpt, sizeof ckpt, &n) != 0) {
            free(posts);
            fprintf(stderr, "host_sim fleet: model %d: checkpoint failed\n", i);
            return -1;
        }
        int wrc = cmd_out_begin("fleet", &mf, file);
        if (wrc == 0 && fwrite(ckpt, 1, n, hal_host_file_stream(&mf)) != n) {
            hal_host_file_abort(&mf);
            fprintf(stderr, "host_sim fleet: %s: write failed\n", file);
            wrc = -1;
        }
        if (wrc != 0 || cmd_out_commit("fleet", &mf) != 0) {
            free(posts);
            return -1;
        }
    }
    free(posts);
    snprintf(file, sizeof file, "%s/summary.txt", o->out);
    hal_host_file_t out;
    if (cmd_out_begin("fleet", &out, file) != 0)
        return -1;
    double v = 0, vmin = INFINITY, vmax = -INFINITY, mse = 0, io = 0, ce = 0, tl = 0, vm[3] = {0, 0, 0};
    for (int i = 0; i < M; i++) {
        const sim_fleet_metrics_t *m = &j->last[i];
        v += val_of(o, m) / M;
        vmin = fmin(vmin, val_of(o, m));
        vmax = fmax(vmax, val_of(o, m));
        vm[0] += m->val_loss / M;
        vm[1] += m->val_sample / M;
        vm[2] += m->val_mc / M;
        mse += m->occ_mse / M;
        io += m->occ_iou / M;
        ce = fmax(ce, m->consensus_error);
        tl += m->train_loss / M;
    }
    /* The honest members alone (a bad member trains honestly; what it sends is what is bad). */
    double hv = 0, hce = 0;
    for (int i = 0; i < M; i++)
        if (o->bad == SIM_FLEET_BAD_NONE || i != o->bad_agent) {
            hv += val_of(o, &j->last[i]) / (o->bad == SIM_FLEET_BAD_NONE ? M : M - 1);
            hce = fmax(hce, j->last[i].consensus_error);
        }
    uint64_t excluded = 0, dropped = 0, offered = 0;
    double dist_max = 0;
    sim_fleet_screen_totals(j->fleet, &excluded, &dist_max);
    sim_fleet_link_totals(j->fleet, &dropped, &offered);
    char links[1024];
    sim_links_describe(&o->links, links, sizeof links);
    for (int pass = 0; pass < 2; pass++) {
        FILE *f = pass ? stdout : hal_host_file_stream(&out);
        fprintf(f, "mode: in-process fleet (one process)\n");
        fprintf(f, "seed: %llu\npreset: %s (%zu parameters)\nagents: %d\nmodels: %d\nrounds: %lld\n",
                (unsigned long long)j->seed, BNN_PRESET_NAME, bnn_n_params(&sim_fleet_node(j->fleet, 0)->model),
                j->n, M, o->rounds);
        fprintf(f, "strategy: %s\ngraph: %s\n", o->strategy_name, dinno_graph_name(o->graph));
        if (o->graph == DINNO_GRAPH_DISK)
            fprintf(f, "radius_m: %g\n", o->radius);
        fprintf(f, "rho0: %g\nrho_scaling: %g\nprimal_steps: %u\nbatch: %u\nlr: %g -> %g\nkl_weight: %g\n"
                   "w_mu: %g\nw_rho: %g\nadam: %s\nkl_form: %s\nkl_reduce: %s\nrho_pred_grad: %d\nval_mode: %s\n",
                (double)o->d.rho0, (double)o->d.rho_scaling, o->d.primal_steps, o->d.batch, (double)o->d.lr_start,
                (double)o->d.lr_end, (double)o->d.kl_weight, (double)o->d.w_mu, (double)o->d.w_rho,
                o->d.persistent_adam ? "persistent" : "fresh each round", dinno_kl_form_name(o->d.kl_form),
                dinno_kl_reduce_name(o->d.kl_reduce), o->d.rho_pred_grad, val_mode_names[o->val_mode]);
        if (o->mode == SIM_FLEET_DINNO) {
            fprintf(f, "links: %s; %llu of %llu neighbour states dropped\n", links, (unsigned long long)dropped,
                    (unsigned long long)offered);
            fprintf(f, "rounds with an isolated agent: %llu; with a split graph: %llu\n",
                    (unsigned long long)j->isolated_rounds, (unsigned long long)j->split_rounds);
            fprintf(f, "duals: %s rule, rejoin after %u missed rounds%s; links rejoined: %llu\n",
                    dinno_dual_rule_name(o->d.dual_rule), o->d.rejoin_gap, o->d.rejoin_gap ? "" : " (never)",
                    (unsigned long long)j->rejoined);
            const bnn_config_t bc = bnn_default_config();
            fprintf(f, "encoding: %s", dinno_codec_name(o->d.codec));
            if (dinno_codec_is_ef(o->d.codec))
                fprintf(f, " (key round every %u; %llu differences without their public copy left out)", o->d.key_every,
                        (unsigned long long)j->stale);
            fprintf(f, "\nstate bytes per round and robot: %zu\n", dinno_codec_bytes(&bc, o->d.codec));
        }
        fprintf(f, "validation points: %zu\n", j->n_val);
        fprintf(f, "final val_loss (mean over models): %.5f (min %.5f, max %.5f)\n", v, vmin, vmax);
        fprintf(f, "final val_mean / val_sample / val_mc%lld (mean over models): %.5f / %.5f / %.5f\n", o->val_mc,
                vm[0], vm[1], vm[2]);
        fprintf(f, "final train_loss (mean): %.5f\n", tl);
        fprintf(f, "final occ_mse (mean, %.2f m grid): %.5f\nfinal occ_iou (mean): %.4f\n", o->occ_res, mse, io);
        fprintf(f, "final consensus_error (max): %.6f\n", ce);
        if (j->cov.first_seen != NULL) /* the tours' scans (not with --samples) */
            cmd_coverage_line(f, &j->cov, j->n);
        if (o->mode == SIM_FLEET_DINNO)
            fprintf(f, "screen: radius %g x ||theta||: %llu neighbour states left out; largest honest neighbour "
                       "distance %.4f x ||theta||\n",
                    (double)o->d.screen_radius, (unsigned long long)excluded, dist_max);
        if (o->bad != SIM_FLEET_BAD_NONE)
            fprintf(f, "bad member: agent %lld sends %s states; honest members: final val_loss (mean) %.5f, "
                       "consensus_error (max) %.6f\n",
                    o->bad_agent, o->bad == SIM_FLEET_BAD_FLIP     ? "sign-flipped"
                    : o->bad == SIM_FLEET_BAD_RANDOM ? "random"
                    : o->bad == SIM_FLEET_BAD_SILENT ? "no"
                                                     : "scaled",
                    hv, hce);
        fprintf(f, "maps: agent 0, %lld MC passes, %.3f m grid, max std %.4f: %s %s\n", o->mc, o->map_res, smax,
                pass ? mean_png : "map_mean.png", pass ? std_png : "map_std.png"); /* the file: in its folder */
    }
    if (cmd_out_commit("fleet", &out) != 0)
        return -1;
    printf("results in %s (metrics.csv, map_mean.png, map_std.png, summary.txt, models/robot_<i>.bnn)\n", o->out);
    return 0;
}

int cmd_fleet(int argc, char **argv)
{
    static job_t job; /* large (paths, metrics): static, one run per process */
    job_t *j = &job;
    memset(j, 0, sizeof *j);
    int pr = parse(argc, argv, &j->o);
    if (pr > 0)
        return 0;
    if (pr < 0)
        return 2;
    if (sim_kernels_bf16_default()) /* PRECISION=bf16: say so when its products run on the reference */
        (void)sim_kernels_bf16_note(stderr, "host_sim fleet");
    j->n = (int)j->o.robots;
    j->seed = (uint64_t)j->o.seed;
    if (sim_plan_load(j->o.plan, j->o.scale, &j->plan, j->err, sizeof j->err) != 0) {
        fprintf(stderr, "host_sim fleet: %s\n", j->err);
        return 1;
    }
    int ok = load_paths(&j->o, &j->plan, j->paths) == 0 && cmd_prepare_out_dir("fleet", j->o.out) == 0;
    if (ok) {
        printf("fleet (in-process, one host_sim process)\n");
        printf("seed %llu, preset %s, %d agents, %lld rounds, strategy %s, graph %s", (unsigned long long)j->seed,
               BNN_PRESET_NAME, j->n, j->o.rounds, j->o.strategy_name, dinno_graph_name(j->o.graph));
        if (j->o.graph == DINNO_GRAPH_DISK)
            printf(" (radius %.2f m)", j->o.radius);
        printf("\n");
        ok = load_training_data(j) == 0 && load_validation(j) == 0 && train(j) == 0 && report(j) == 0;
    }
    job_free(j);
    return ok ? 0 : 1;
}
