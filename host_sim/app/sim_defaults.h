/* The simulation's defaults, each named once. host_sim's commands start their options from
 * them (run, fleet --inproc, maps, valset) and `host_sim defaults` prints them, with the
 * firmware's own (gp_fleet.h's protocol timings, dinno_default_cfg), as key=value lines: the
 * launchers tools/fleet and tools/run-fleet.sh read them from the binary they start, so a
 * default changed here changes everywhere at the next build.
 *
 * Two kinds: a robot's (host_sim run alone, and host_sim fleet --inproc, which equals a fleet
 * of `host_sim run` processes with the same values), and the launchers' fleet experiment (the
 * paper's 7 robots, 1500 rounds, offline), which `make run` and `make run-inproc` run. */
#ifndef HOST_SIM_APP_SIM_DEFAULTS_H
#define HOST_SIM_APP_SIM_DEFAULTS_H

/* A default as text, for a help line: SIM_DEF_STR(SIM_DEF_MC) is "50". */
#define SIM_DEF_STR_(x) #x
#define SIM_DEF_STR(x) SIM_DEF_STR_(x)

/* ---- one robot, and the in-process fleet ---- */
#define SIM_DEF_SEED 1
/* Disk graph radius: each robot sweeps its own room, so at 4 m the apartment's graph is split
 * in most rounds and the models drift apart; at 6 m it stays connected (tools/run-fleet.sh). */
#define SIM_DEF_RADIUS_M 6.0
#define SIM_DEF_MAP_RES_M 0.1   /* a robot's own maps (run), the in-process fleet's maps */
#define SIM_DEF_OCC_RES_M 0.1   /* fleet --inproc: the grid of the occupancy metrics */
#define SIM_DEF_MC 50           /* MC passes of a map */
#define SIM_DEF_VAL_POSES 500   /* validation poses x one 500-point scan (as DiNNO) */
#define SIM_DEF_RUN_ROUNDS 8    /* host_sim run: a short run of one robot */
#define SIM_DEF_TIME_LIMIT_S 1800.0
/* Validation (and a round checkpoint) about this many times in a fleet run: every
 * rounds / SIM_DEF_FLEET_VAL_CHECKS rounds (host_sim run --fleet, tools/fleet). */
#define SIM_DEF_FLEET_VAL_CHECKS 50
/* fleet --inproc: a metrics row (and a progress line) every rounds / this many rounds. */
#define SIM_DEF_METRICS_ROWS 20

/* ---- the launchers' fleet (make run: tools/fleet; make run-inproc: tools/run-fleet.sh) ---- */
#define SIM_DEF_FLEET_ROBOTS 7      /* the default plan's 7 tours */
#define SIM_DEF_FLEET_ROUNDS 1500
#define SIM_DEF_FLEET_MODE "offline" /* tours first, then every round (paper 6.3) */
#define SIM_DEF_FLEET_VAL_POSES 200  /* each robot's validation set (tools/fleet) */
/* The fleet's final maps: tools/fleet's consensus map (host_sim maps) and make run-inproc's. */
#define SIM_DEF_FLEET_MAP_RES_M 0.05
#define SIM_DEF_POST_ROUNDS 3   /* fleet: rounds of the epistemic posterior's consensus (one is exact
                                   when no state is lost; the others repair a lost one) */

#endif /* HOST_SIM_APP_SIM_DEFAULTS_H */
