/* host_sim zmq-proxy: the one forwarder of a ZeroMQ fleet too large for the full mesh
 * (hal_host_zmq_proxy_run). Runs until SIGINT or SIGTERM, then prints what it forwarded. */
#include <errno.h>
#include <stdio.h>

#include "cli.h"
#include "commands.h"
#include "hal_host.h"
#include "hal_host_stop.h"

typedef struct proxy_opts {
    const char *bind;
    int port, quiet;
    double every_s;
} proxy_opts_t;

static const cli_opt_t proxy_opts[] = {
    {.names = "--port", .meta = "P", CLI_INT(proxy_opts_t, port, 1, 65534), .required = 1,
     .help = "the robots' publishers connect to P, their subscribers to P + 1 (host_sim run --zmq-proxy HOST:P)"},
    {.names = "--bind", .meta = "HOST", CLI_STRING(proxy_opts_t, bind),
     .help = "the address bound (* for every interface)"},
    {.names = "--every", .meta = "S", CLI_DOUBLE(proxy_opts_t, every_s, 1, 86400),
     .help = "seconds between progress lines"},
    {.names = "-q|--quiet", CLI_FLAG(proxy_opts_t, quiet, 1), .help = "no progress lines"},
    CLI_OPT_END,
};

static proxy_opts_t proxy_defaults(void)
{
    return (proxy_opts_t){.bind = "127.0.0.1", .every_s = 60};
}

static void proxy_usage(FILE *out)
{
    const proxy_opts_t d = proxy_defaults();
    fprintf(out,
            "usage: host_sim zmq-proxy --port P [options]\n"
            "\n"
            "Forwards a ZeroMQ fleet's datagrams for fleets too large for the full mesh, in which every\n"
            "robot holds 2 (N - 1) TCP connections (256 robots: 130,560 sockets). Each robot started with\n"
            "host_sim run --transport zmq --zmq-proxy HOST:P holds two: its publisher to P, its subscriber\n"
            "to P + 1. A datagram goes only to the robots subscribed to its topic, so each robot still\n"
            "receives the states of the neighbours it keeps, not the fleet's. Order per sender is kept.\n"
            "The proxy forwards and stores nothing, never reads a datagram, and holds no fleet key: a\n"
            "keyed fleet's tags are checked by the robots as over the mesh. If it stops, the robots\n"
            "hear nobody and time their peers out as for a network that failed. tools/fleet --transport\n"
            "zmq --zmq-proxy starts one. Runs until SIGINT or SIGTERM, then prints its counts and exits 0.\n"
            "\n"
            "options:\n");
    cli_opts_help(out, proxy_opts, &d);
}

typedef struct proxy_run {
    atomic_int stop;
    const proxy_opts_t *o;
    double t0_s, said_s; /* cmd_wall_now() at the start, at the last progress line */
    hal_host_zmq_proxy_stats_t last;
} proxy_run_t;

static void proxy_line(const hal_host_zmq_proxy_stats_t *s, double t)
{
    printf("zmq-proxy: %.0f s: %llu datagrams (%.1f MB) forwarded, %llu subscriber queue overflows (copies "
           "dropped), %llu subscription changes\n",
           t, (unsigned long long)s->frames, (double)s->bytes / 1e6, (unsigned long long)s->overflows,
           (unsigned long long)s->subscriptions);
    fflush(stdout);
}

/* After every poll: a signal asks the loop to stop; a progress line every --every seconds. */
static void proxy_progress(const hal_host_zmq_proxy_stats_t *s, void *user)
{
    proxy_run_t *r = user;
    r->last = *s;
    if (hal_host_stop_signal() != 0)
        atomic_store(&r->stop, 1);
    const double now_s = cmd_wall_now();
    if (!r->o->quiet && now_s - r->said_s >= r->o->every_s) {
        r->said_s = now_s;
        proxy_line(s, now_s - r->t0_s);
    }
}

int cmd_zmq_proxy(int argc, char **argv)
{
    proxy_opts_t o = proxy_defaults();
    const cli_parser_t parser = {.cmd = "zmq-proxy", .opts = proxy_opts, .usage = proxy_usage};
    const int pr = cli_opts_parse(&parser, argc, argv, &o, NULL, NULL);
    if (pr != 0)
        return pr > 0 ? 0 : 2;
    hal_host_stop_set_mode(HAL_HOST_STOP_ASK); /* the loop sees the request within 200 ms */
    proxy_run_t r = {.o = &o};
    atomic_init(&r.stop, 0);
    r.t0_s = r.said_s = cmd_wall_now();
    printf("zmq-proxy: publishers to tcp://%s:%d, subscribers to tcp://%s:%d\n", o.bind, o.port, o.bind, o.port + 1);
    fflush(stdout);
    const int rc = hal_host_zmq_proxy_run(o.bind, (unsigned)o.port, &r.stop, proxy_progress, &r);
    if (rc == -EINVAL)
        return 2;
    proxy_line(&r.last, cmd_wall_now() - r.t0_s);
    if (rc == 0)
        printf("zmq-proxy: stopped by %s\n", hal_host_stop_signal_name(hal_host_stop_signal()));
    return rc == 0 ? 0 : 1; /* a stop asked for is this service's normal end */
}
