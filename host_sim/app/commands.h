/* Sub-commands of the host_sim program. Each lives in host_sim/app/cmd_<name>.c, takes the
 * arguments after its own name (argv[0] is the command name), prints its own --help, and
 * returns the process exit code: 0 success, 1 failure at run time, 2 bad usage. */
#ifndef HOST_SIM_APP_COMMANDS_H
#define HOST_SIM_APP_COMMANDS_H

typedef int (*host_sim_cmd_fn)(int argc, char **argv);

typedef struct host_sim_cmd {
    const char *name;
    host_sim_cmd_fn run;
    const char *summary; /* one line for `host_sim --help` */
} host_sim_cmd_t;

#endif /* HOST_SIM_APP_COMMANDS_H */
