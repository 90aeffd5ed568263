/* host_sim maps's options (cmd_maps_opts.h). */
#include "cmd_maps_opts.h"

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

#include "cli.h"
#include "cli_opts.h"
#include "sim_defaults.h"
#include "sim_plan.h"



static maps_opts_t maps_defaults(void)
{
    return (maps_opts_t){.res = SIM_DEF_FLEET_MAP_RES_M, .scale = SIM_PLAN_DEFAULT_SCALE, .mc = SIM_DEF_MC,
                         .seed = SIM_DEF_SEED};
}

static const cli_opt_t maps_opts[] = {
    {.names = "--plan", .meta = "FILE.svg", CLI_STRING(maps_opts_t, plan), .required = 1,
     .help = "the floor plan the models were trained on"},
    {.names = "--out", .meta = "DIR", CLI_STRING(maps_opts_t, out), .required = 1,
     .help = "output folder, created with its parents"},
    {.names = "--res", .meta = "M", CLI_DOUBLE(maps_opts_t, res, 0.001, 100.0), .help = "map cell size in metres"},
    {.names = "--mc", .meta = "K", CLI_INT(maps_opts_t, mc, 1, 100000), .help = "Monte-Carlo passes"},
    {.names = "--seed", .meta = "S", CLI_INT(maps_opts_t, seed, 0, INT64_MAX), .help = "seed of the MC draws"},
    {.names = "--valset", .meta = "FILE", CLI_STRING(maps_opts_t, valset),
     .help = "validation samples of the plan (host_sim valset): val_loss and the thresholds of map.yaml"},
    {.names = "--scale", .meta = "S", CLI_DOUBLE(maps_opts_t, scale, 1e-6, 100.0), .help = "plan metres per pixel"},
    CLI_OPT_END,
};

static void maps_usage(FILE *out)
{
    fprintf(out,
            "usage: host_sim maps --plan FILE.svg --out DIR [options] MODEL.bnn [MODEL.bnn ...]\n"
            "\n"
            "Averages the final models of a fleet (BNN checkpoints of one network: the models/robot_<i>.bnn\n"
            "of host_sim fleet, each robot's final.bnn of host_sim run) into the consensus model, theta =\n"
            "the element-wise mean of the models' parameter vectors (in double, in the order given; the\n"
            "model seed is the first model's), and maps it over the plan's bounding box.\n"
            "\n"
            "Writes into DIR:\n"
            "  consensus.bnn       the consensus model (checkpoint, no optimiser state; with the fleet's\n"
            "                      epistemic posterior when the models carry theirs)\n"
            "  consensus.csv       model,file,val_loss,consensus_error: one row per MODEL (index 0..N-1)\n"
            "                      and a last row 'consensus'; file: the MODEL as given, consensus.bnn (in DIR,\n"
            "                      beside this file; no path is made absolute); consensus_error =\n"
            "                      ||theta_i - mean|| / ||mean||,\n"
            "                      val_loss = BCE with the mean weights on --valset (nan without it)\n"
            "  map_mean.npy        MC mean of the occupancy probability over K passes (float32, H x W)\n"
            "  map_std.npy         MC standard deviation of those passes\n"
            "  map_single.npy      one stochastic pass (the first of the K)\n"
            "  map_truth.npy       the ground truth at the same cells (uint8: 0 free, 1 wall, 255 outside)\n"
            "                      .npy arrays: row 0 is the TOP row (largest y), column 0 the smallest x:\n"
            "                      cell (r, c) has its centre at x = xmin + (c + 0.5) res, y = ymax - (r + 0.5) res\n"
            "  map_meta.json       res, xmin, ymin, xmax, ymax (the grid's edges: W x H cells from the plan's\n"
            "                      lower corner, covering its bounding box), width, height, mc, seed, std_max,\n"
            "                      models, epistemic (the posterior's method and counts, or null)\n"
            "  map.pgm, map.yaml   the MC mean for ROS map_server: P5, first row the top, pixel =\n"
            "                      round(255 (1 - mean)), so occupancy = (255 - pixel) / 255 (negate 0);\n"
            "                      origin = (xmin, ymin), mode trinary (occupied: occupancy > occupied_thresh,\n"
            "                      free: < free_thresh, else unknown). With --valset the thresholds are\n"
            "                      chosen on it for this model: the MC mean (same passes) at its points;\n"
            "                      occupied_thresh = the cut with the best F1 of the lidar hits, free_thresh\n"
            "                      the cut below it with the best F1 of the free points (each half-way\n"
            "                      between two pixel levels). Without: ROS map_server's defaults 0.65 / 0.196,\n"
            "                      which a model's smooth occupancy rarely reaches (no walls: stdout says so).\n"
            "                      The reason is a comment in map.yaml; stdout and map_meta.json give the\n"
            "                      thresholds and how the map scores as nav2 reads it against map_truth.npy\n"
            "                      (wall IoU, share of the free cells truly free)\n"
            "  map_mean.png, map_std.png   the pictures of host_sim fleet/run (no paths), y up like the .npy\n"
            "                      arrays and map.pgm: their row 0 is the largest y\n"
            "  map_epistemic.npy   what the fleet has NOT seen (float32, H x W, same grid and rows as map_std.npy):\n"
            "                      the share of the prior variance of the epistemic posterior's read-out left\n"
            "                      at the cell, in (0, 1], larger = less known (docs/uncertainty.md). Made from\n"
            "                      the posteriors the checkpoints carry (robots' own ones are summed, fleet\n"
            "                      estimates averaged); written only when a model carries one, and an old\n"
            "                      map_epistemic.* in DIR is removed otherwise\n"
            "  map_epistemic.png   its picture, log scale: 1e-6 and below dark blue .. 1 yellow\n"
            "Inputs are checked first (plan, checkpoints, validation set): a bad one stops the run\n"
            "before any file is replaced.\n"
            "\n"
            "options:\n");
    const maps_opts_t d = maps_defaults();
    cli_opts_help(out, maps_opts, &d);
}

/* 0, 1 after --help, -1 on a usage error (printed). o->models points into argv. */
int maps_parse(int argc, char **argv, maps_opts_t *o)
{
    *o = maps_defaults();
    o->models = calloc((size_t)argc, sizeof *o->models);
    if (o->models == NULL) {
        fprintf(stderr, "host_sim maps: out of memory\n");
        return -1;
    }
    const cli_parser_t parser = {.cmd = "maps", .opts = maps_opts, .usage = maps_usage, .operands = "MODEL.bnn"};
    const int pr = cli_opts_parse(&parser, argc, argv, o, o->models, &o->n_models);
    if (pr != 0)
        return pr;
    if (o->n_models == 0) {
        fprintf(stderr, "host_sim maps: no MODEL.bnn given (see --help)\n");
        return -1;
    }
    return 0;
}

