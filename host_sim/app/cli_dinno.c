/* The DiNNO optimiser options `host_sim fleet` and `host_sim run` share: one spelling, one
 * range, one help line each, included in both tables (CLI_INCLUDE over a dinno_cfg_t). */
#include "cli.h"

const cli_opt_t cmd_dinno_opts[] = {
    {.names = "--batch", .meta = "B", CLI_INT(dinno_cfg_t, batch, 1, BNN_MAX_BATCH), .help = "minibatch size"},
    {.names = "--primal-steps|--steps-per-round", .meta = "B", CLI_INT(dinno_cfg_t, primal_steps, 1, 100000),
     .help = "optimiser steps per round"},
    {.names = "--kl-weight", .meta = "W", CLI_DOUBLE(dinno_cfg_t, kl_weight, 0.0, 1e6),
     .help = "weight of the BNN prior KL in the prediction loss"},
    {.names = "--w-mu", .meta = "W", CLI_DOUBLE(dinno_cfg_t, w_mu, 0.0, 1e6),
     .help = "regulariser weight of the mu group, times rho_k"},
    {.names = "--w-rho", .meta = "W", CLI_DOUBLE(dinno_cfg_t, w_rho, 0.0, 1e6),
     .help = "regulariser weight of the rho group, times rho_k"},
    {.names = "--rho0", .meta = "V", CLI_DOUBLE(dinno_cfg_t, rho0, 1e-9, 1e6), .help = "initial ADMM penalty"},
    {.names = "--rho-scaling", .meta = "V", CLI_DOUBLE(dinno_cfg_t, rho_scaling, 1e-3, 10.0),
     .help = "growth of the penalty per round"},
    {.names = "--lr-start", .meta = "V", CLI_DOUBLE(dinno_cfg_t, lr_start, 1e-12, 10.0),
     .help = "log-decaying learning rate over the rounds: first"},
    {.names = "--lr-end", .meta = "V", CLI_DOUBLE(dinno_cfg_t, lr_end, 1e-12, 10.0), .help = "... and last"},
    {.names = "--kl-form", CLI_CHOICE(dinno_cfg_t, kl_form, "own|reverse|full"),
     .values = (const int[]){DINNO_KL_OWN_MEAN, DINNO_KL_REVERSE, DINNO_KL_FULL},
     .help = "the KL of the 'kl' strategy on the rho group (s own sigma, r the neighbours' midpoint sigma, "
             "m their midpoint mean): own = KL(N(mu,s)||N(mu,r)), reverse = KL(N(mu,r)||N(mu,s)), "
             "full = KL(N(m,r)||N(mu,s))"},
    {.names = "--kl-reduce", CLI_CHOICE(dinno_cfg_t, kl_reduce, "sum|mean"),
     .values = (const int[]){DINNO_REDUCE_SUM, DINNO_REDUCE_MEAN},
     .help = "that KL summed over the rho elements or their mean"},
    {.names = "--rho-pred-grad", .meta = "1|0", CLI_INT(dinno_cfg_t, rho_pred_grad, 0, 1),
     .help = "1: both groups get the prediction-loss gradient; 0: Algorithm 2 read literally, the rho group "
             "moves only by its dual and regulariser (separate, kl)"},
    {.names = "--screen-radius", .meta = "R", CLI_DOUBLE(dinno_cfg_t, screen_radius, 0.0, 1e6),
     .help = "fleet: leave out a neighbour state further than R x ||own state|| (and any non-finite one) "
             "before the node update, counted and logged (0: no distance screen)"},
    {.names = "--dual-rule", CLI_CHOICE(dinno_cfg_t, dual_rule, "link|node"),
     .values = (const int[]){DINNO_DUAL_LINK, DINNO_DUAL_NODE},
     .help = "link: one dual per neighbour link, only the links of the round count (a link back after a long "
             "absence starts afresh); node: one dual per robot that keeps every term (the original DiNNO)"},
    {.names = "--rejoin-gap", .meta = "R", CLI_INT(dinno_cfg_t, rejoin_gap, 0, 1000000),
     .help = "a neighbour back after missing R or more rounds makes the robot step to the mean of its own and "
             "the round's states first (0: never)"},
    {.names = "--key-every", .meta = "K", CLI_INT(dinno_cfg_t, key_every, 1, 1000000),
     .help = "int8-ef, int4-ef: every K-th round sends the whole state, the others the difference against "
             "the public copy"},
    CLI_OPT_END,
};
