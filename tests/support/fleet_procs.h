/* Helpers of the tests that run fleets of real `host_sim run --fleet` processes
 * (tests/fleet/test_fleet_procs.c, tests/faults/): children started in process groups of their
 * own and remembered, so that every path kills and reaps them (a passing test, a failed
 * assertion through the teardown, SIGINT/SIGTERM/SIGHUP of the test program through a
 * handler); waits that end at a deadline, so a hang fails a test instead of blocking it; the
 * robots' command lines; readers of what a robot leaves (summary.txt, metrics.csv).
 * Failures are cmocka assertions. Not thread-safe. */
#ifndef TESTS_SUPPORT_FLEET_PROCS_H
#define TESTS_SUPPORT_FLEET_PROCS_H

#include <limits.h>
#include <stddef.h>
#include <sys/types.h>

#define FP_SHORT_PATH 1024 /* the environment's paths; PATH_MAX-sized buffers hold them with a name added */
#define FP_MAX_ROBOTS 40 /* a fleet beyond the host board's 32 neighbour slots */
#define FP_MAX_KIDS 64
#define FP_MAX_ARGS 72
#ifndef FP_CMD_DEADLINE_S
#define FP_CMD_DEADLINE_S 15 /* fp_run_cmd: a short command (ip, iptables) */
#endif

/* What every test of a program shares: filled by fp_setup. */
typedef struct fp_env {
    char bin[FP_SHORT_PATH];   /* build/<config>/bin/host_sim of the test's own build */
    char root[FP_SHORT_PATH];  /* the project (the working directory) */
    char plan[FP_SHORT_PATH];  /* host_sim/plans/apartment.svg */
    char paths[FP_SHORT_PATH]; /* host_sim/plans/apartment (robot_<i>.csv) */
    char dir[FP_SHORT_PATH];   /* scratch folder, removed by fp_teardown */
    unsigned fleet_id;         /* the next fleet's id (one per fleet, so parallel runs do not mix) */
} fp_env_t;

extern fp_env_t fp_env;

/* Fills fp_env (a scratch folder $TMPDIR/<scratch>_XXXXXX, fleet ids from fleet_base plus
 * ten per pid % 10000) and installs the handler of SIGINT, SIGTERM and SIGHUP: it kills every
 * child, calls `cleanup` (NULL: none; must be async-signal-safe) and dies of the signal.
 * 0, or -1 when host_sim is not there. For a cmocka group setup. */
int fp_setup(const char *scratch, unsigned fleet_base, void (*cleanup)(void));
/* Kills every child and removes the scratch folder: 0 or -1. For a cmocka group teardown. */
int fp_teardown(void);

double fp_now(void); /* monotonic seconds */
void fp_sleep_ms(long ms);

/* Starts argv in a process group of its own (a kill reaches whatever it starts), stdout and
 * stderr into `log` (NULL: /dev/null), with NAME=VALUE in its environment when env_name is
 * not NULL. The child is remembered until it is reaped. */
pid_t fp_spawn(const char *const *argv, const char *log, const char *env_name, const char *env_value);
/* Waits for pid until `deadline` (fp_now() seconds): its exit status (128 + the signal when
 * killed), or -1 when it still runs then (not reaped). */
int fp_wait(pid_t pid, double deadline);
/* SIGKILL to its process group, reaped, forgotten. A no-op for 0 and for a pid that is not
 * a running child of ours (already reaped: its number may belong to another process now). */
void fp_kill(pid_t pid);
/* fp_kill of every child still remembered. */
void fp_kill_all(void);
/* Runs argv to its end within FP_CMD_DEADLINE_S (killed after: 124): its status, its output
 * (stdout and stderr) into out when not NULL. */
int fp_run_cmd(const char *const *argv, char *out, size_t cap);
/* A program by name in PATH, /usr/sbin or /sbin: 0 and its path in out, or -1. */
int fp_find_program(const char *name, char *out, size_t cap);
/* Prints the last 3000 bytes of a log (a failed robot's) on stderr. */
void fp_show_log(const char *path);

/* One robot of a test fleet. */
typedef struct fp_robot {
    int id;
    char out[PATH_MAX], log[PATH_MAX], path[PATH_MAX], idtxt[16];
    const char *argv[FP_MAX_ARGS];
    int argc;
    pid_t pid;  /* 0 when not running (reaped or never started) */
    int status; /* exit status of the last start once reaped; -1 before */
} fp_robot_t;

typedef struct fp_fleet {
    char tag[64], dir[PATH_MAX], fid[16], ntxt[8];
    int n;
    double t0; /* fp_now() at fp_fleet_start */
    fp_robot_t r[FP_MAX_ROBOTS];
} fp_fleet_t;

/* Prepares (does not start) the n robots of a fleet in the folder fp_env.dir/<tag> (made
 * here): robot i is `[prefix...] host_sim run --plan P --path <tours>/robot_<i>.csv --out
 * DIR/<tag>/robot_<i> --offline --seed 3 --fleet n --id i --fleet-id F --transport lcm
 * --val-poses 5 --no-maps --quiet [args...]`, its output into DIR/<tag>/log_<i>.txt. prefix
 * (e.g. `ip netns exec NS`) and args are NULL-terminated lists or NULL; their strings must
 * outlive the fleet. */
void fp_fleet_init(fp_fleet_t *f, const char *tag, int n, const char *const *prefix, const char *const *args);
/* Appends one argument to a robot's command (e.g. "--resume" before a restart). */
void fp_robot_add_arg(fp_robot_t *r, const char *arg);
/* Starts (again) one robot with its command, output into r->log. */
void fp_robot_start(fp_robot_t *r, const char *env_name, const char *env_value);
/* Starts every robot and sets f->t0. */
void fp_fleet_start(fp_fleet_t *f, const char *env_name, const char *env_value);
/* Waits for every running robot until f->t0 + deadline_s: each status into r[i].status. When
 * one is still running then it is named ("robot 1 still running after 90 s: killed"), every
 * robot is killed and the test FAILS (a hang is a failure); when one exited non-zero its log
 * is shown and the test fails. Returns the fleet's wall time. */
double fp_fleet_wait_ok(fp_fleet_t *f, double deadline_s);
/* Waits until robot r has written a file whose name starts with `prefix` and ends with
 * `suffix` into its folder (e.g. "round_", ".bnn"), until `deadline`. Fails the test, naming
 * the robot and the file it waited for, when the deadline passes or the robot exits first. */
void fp_wait_for_file(const fp_robot_t *r, const char *prefix, const char *suffix, double deadline);

/* The same for a line of its log (r->log) holding `text`. */
void fp_wait_for_log(const fp_robot_t *r, const char *text, double deadline);
/* The in-process reference of a test fleet: `host_sim fleet --inproc` with the settings
 * fp_fleet_init gives the robots (3 robots, seed 3, disk graph of 6 m, strategy kl) and
 * `rounds`, into fp_env.dir/inproc (made once per program: later calls return at once).
 * Fails the test when it fails or is not done within deadline_s. */
void fp_inproc_reference(int n, const char *rounds, int deadline_s);
/* The same with a disk radius of its own (fp_inproc_reference's is "6"). */
void fp_inproc_reference_radius(int n, const char *rounds, const char *radius, int deadline_s);
/* Every robot's DIR/<tag>/robot_<i>/final.bnn equals the reference's model bit for bit;
 * fails the test naming the first robot that differs. */
void fp_expect_reference_models(const char *tag, int n);
/* host_sim fleet --inproc as fp_inproc_reference runs it, with the options `extra` (NULL-ended,
 * may be NULL) added, into DIR/<name>: the reference of a fleet run with those options. */
void fp_inproc_run(int n, const char *rounds, const char *radius, const char *name, const char *const *extra,
                   int deadline_s);
/* Each robot's final model of run `tag` equals DIR/<name>/models/robot_<i>.bnn's, bit for bit
 * (the network, the seed and theta; not the posterior). */
void fp_expect_models_of(const char *tag, int n, const char *name);

/* fp_summary_number of DIR/<tag>/robot_<i>/summary.txt, summed over robots 0 .. n-1. */
unsigned long long fp_summary_sum(const char *tag, int n, const char *line, const char *what, int after);

/* Deletes the network namespace `name` with `ip netns del` (its veths and bridges go with it),
 * output discarded. Async-signal-safe (fork, execv, waitpid): signal handlers call it. */
void fp_netns_delete(const char *ip, const char *name);

/* Skips the running test with the reason (cmocka prints SKIPPED; tools/run-tests.sh counts it). */
#define FP_SKIP_BECAUSE(...)                                                                                  \
    do {                                                                                                      \
        printf("# skipped: ");                                                                                \
        printf(__VA_ARGS__);                                                                                  \
        printf("\n");                                                                                         \
        fflush(stdout);                                                                                       \
        skip();                                                                                               \
    } while (0)

/* A number of a summary.txt: on the first line that contains `line`, the number just before
 * `what` (just after, when `after`). Fails the test when the file, the line or `what` is not
 * there. */
double fp_summary_number(const char *file, const char *line, const char *what, int after);
/* Column `column` of a CSV file with a header line: up to cap values into out (NaN for "nan"
 * or an empty field), the number of rows returned. Fails the test when the file or the column
 * is not there. */
int fp_csv_column(const char *file, const char *column, double *out, int cap);

#endif /* TESTS_SUPPORT_FLEET_PROCS_H */
