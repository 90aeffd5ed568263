/* `host_sim maps`'s options: the table (cli_opts.h), the defaults and --help. cmd_maps.c runs
 * what they describe. */
#ifndef HOST_SIM_APP_CMD_MAPS_OPTS_H
#define HOST_SIM_APP_CMD_MAPS_OPTS_H

typedef struct maps_opts {
    const char *plan, *out, *valset;
    double res, scale;
    long long mc, seed;
    char **models;
    int n_models;
} maps_opts_t;

/* 0, 1 after --help, -1 on a usage error (printed). o->models (calloc'd, the caller frees)
 * points into argv. */
int maps_parse(int argc, char **argv, maps_opts_t *o);

#endif /* HOST_SIM_APP_CMD_MAPS_OPTS_H */
