/* `host_sim run`'s options: the table (cli_opts.h), the defaults, the checks across options,
 * and --help. cmd_run.c runs what they describe. */
#ifndef HOST_SIM_APP_CMD_RUN_OPTS_H
#define HOST_SIM_APP_CMD_RUN_OPTS_H

#include <stdint.h>

#include "ai/ai_pool.h"
#include "ai/dinno.h"
#include "ai/dinno_codec.h"
#include "gp/gp_fleet.h"
#include "hal_host.h"

enum { RUN_TRANSPORT_LCM = 0, RUN_TRANSPORT_ZMQ = 1, RUN_TRANSPORT_SHM = 2 };

/* The longest network URL --peers can make: zmq:// + the bind + every peer's HOST:PORT. */
#define RUN_NET_URL_MAX 16384

typedef struct run_opts {
    const char *plan, *path, *out, *net;
    long long rounds, per_comm, seed, robot, val_poses, mc, fleet, fleet_id, val_every, chunk_bytes;
    long long pool_samples; /* --pool-samples: the pool's capacity (0: the build's) */
    long long post_rounds; /* fleet: rounds of the epistemic posterior's consensus after the last */
    double time_limit, map_res, scale, radius, peer_timeout, join_timeout, resend_ms;
    dinno_cfg_t d;
    ai_pool_policy_t pool;
    hal_host_sched_t sched;
    dinno_codec_t encoding;
    int offline, train_between, no_maps, quiet, net_given, resume;
    int robot_given, fleet_given; /* --id / --fleet on the command line (else SLURM's may say) */
    int online_given, offline_given; /* --online / --offline given (both: refused) */
    int transport;          /* --transport: RUN_TRANSPORT_LCM, _ZMQ or _SHM */
    int lcm_groups;         /* --lcm-groups: state chunks on per-sender multicast groups */
    int lcm_addressed;      /* --lcm-addressed: one robot's traffic on its own channels */
    const char *peers;      /* --peers HOST:PORT,... (zmq: every member, in id order) */
    const char *zmq_proxy;  /* --zmq-proxy HOST:PORT (zmq: through host_sim zmq-proxy instead) */
    const char *net_faults; /* --net-faults SPEC, checked at parse time; NULL: none */
    const char *key_file;   /* --key-file: a keyed fleet; NULL: unkeyed */
    uint64_t run_id;
    int run_id_given;
    long long ckpt_keep, ckpt_keep_every; /* --keep-ckpt K, --keep-ckpt-every M */
    int explore;            /* --explore: no tour, the robot chooses its goals (docs/exploration.md) */
    int explore_policy;     /* --explore-policy: gp_explore_policy_t */
    double explore_time;    /* --explore-time: simulated seconds */
    int explore_own_posterior; /* --explore-own-posterior: the belief from the robot's data alone */
    int explore_posterior_first; /* --explore-posterior-first: the belief's first layer the posterior's alone */
    int explore_no_fence;      /* --explore-no-fence: the RT core not fenced into the building */
} run_opts_t;

/* o = the defaults (sim_defaults.h, gp_fleet.h's GP_FLEET_*_DEFAULT, dinno_default_cfg). */
void run_defaults(run_opts_t *o);

/* Parses argv into o (defaults first), then checks the options together; --peers becomes the
 * ZeroMQ URL in url (RUN_NET_URL_MAX). 0, 1 after --help, -1 after printing why. */
int run_parse(int argc, char **argv, run_opts_t *o, char *url);

#endif /* HOST_SIM_APP_CMD_RUN_OPTS_H */
