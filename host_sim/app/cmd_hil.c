/* host_sim hil: one robot's world served over the hardware-in-the-loop link to firmware that
 * runs elsewhere (sim_hil_serve.h). */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "cli.h"
#include "commands.h"
#include "hal_host_stop.h"
#include "sim_hal_world.h"
#include "sim_hil_bridge.h"
#include "sim_hil_serve.h"
#include "sim_paths.h"
#include "sim_plan.h"

typedef struct hil_opts {
    const char *plan, *path, *listen, *fleet_lcm;
    int64_t robot, seed;
    double idle_timeout_s, scale;
    int quiet, link; /* sim_hil_link_t: udp, serial, ether */
} hil_opts_t;

static hil_opts_t hil_defaults(void)
{
    return (hil_opts_t){.listen = "127.0.0.1:7800", .seed = 1, .idle_timeout_s = 30.0, .scale = SIM_PLAN_DEFAULT_SCALE};
}

static const cli_opt_t hil_opts[] = {
    {.names = "--plan", .meta = "FILE.svg", CLI_STRING(hil_opts_t, plan), .required = 1, .help = "the floor plan"},
    {.names = "--path", .meta = "ROBOT.csv", CLI_STRING(hil_opts_t, path), .required = 1,
     .help = "the robot's tour: it starts at the first waypoint facing the second"},
    {.names = "--listen", .meta = "HOST:PORT", CLI_STRING(hil_opts_t, listen),
     .help = "the address the board talks to (port 0: any free one, printed)"},
    {.names = "--link", CLI_CHOICE(hil_opts_t, link, "udp|serial|ether"),
     .help = "udp: one frame per datagram; serial: a serial line's byte stream carried over TCP "
             "(QEMU's -serial tcp:HOST:PORT), frames back to back; ether: Ethernet frames in UDP "
             "datagrams (QEMU's -nic dgram), EtherType 0x88B5, a frame in each"},
    {.names = "--robot", .meta = "I", CLI_INT(hil_opts_t, robot, 0, BOARD_MAX_FLEET - 1),
     .help = "the robot served: keys the noise streams; the board's HELLO must name it"},
    {.names = "--seed", .meta = "S", CLI_INT(hil_opts_t, seed, 0, INT64_MAX), .help = "run seed of the noise streams"},
    {.names = "--idle-timeout", .meta = "S", CLI_DOUBLE(hil_opts_t, idle_timeout_s, 0.1, 86400),
     .help = "end when no frame came for S seconds"},
    {.names = "--scale", .meta = "S", CLI_DOUBLE(hil_opts_t, scale, 1e-6, 1e3), .help = "plan metres per pixel"},
    {.names = "--fleet-lcm", .meta = "URL", CLI_STRING(hil_opts_t, fleet_lcm),
     .help = "bridge the board's fleet datagrams to this LCM (e.g. udpm://239.255.76.67:7667?ttl=0): the "
             "board's network interface; without it they are counted, not bridged"},
    {.names = "-q|--quiet", CLI_FLAG(hil_opts_t, quiet, 1), .help = "no progress lines"},
    CLI_OPT_END,
};

static void hil_usage(FILE *out)
{
    const hil_opts_t d = hil_defaults();
    fprintf(out,
            "usage: host_sim hil --plan FILE.svg --path ROBOT.csv [options]\n"
            "\n"
            "Serves one robot's ODE world to firmware that runs elsewhere (a board, QEMU, another\n"
            "process) over the hardware-in-the-loop link: CRC-checked frames (hal/include/hal/\n"
            "hal_hil_frame.h), one per UDP datagram (--link udp), back to back on a serial line\n"
            "carried over TCP (--link serial), or in Ethernet frames in UDP datagrams (--link ether,\n"
            "a board's network interface under QEMU). The board keeps the time: it says HELLO, then\n"
            "each control tick sends TICK t (the world steps to t; the latest scan, the fleet's\n"
            "datagrams it has room for and the pose come back) and its wheel command, held until the\n"
            "next one. With --fleet-lcm the world is the board's network interface on the fleet's\n"
            "LCM. Every frame is checked before it acts; refused ones are counted in the last line.\n"
            "Ends when no frame came for --idle-timeout seconds: exit 0 after a session, 1 when no\n"
            "board said HELLO, 2 on bad options.\n"
            "\n"
            "options:\n");
    cli_opts_help(out, hil_opts, &d);
}

int cmd_hil(int argc, char **argv)
{
    hil_opts_t o = hil_defaults();
    const cli_parser_t parser = {.cmd = "hil", .opts = hil_opts, .usage = hil_usage};
    const int pr = cli_opts_parse(&parser, argc, argv, &o, NULL, NULL);
    if (pr != 0)
        return pr > 0 ? 0 : 2;
    char err[8192];
    uint16_t port = 0;
    const int fd = sim_hil_listen(o.listen, (sim_hil_link_t)o.link, &port, err, sizeof err);
    if (fd < 0) {
        fprintf(stderr, "host_sim hil: --listen %s\n", err);
        return 2;
    }
    sim_plan_t plan;
    if (sim_plan_load(o.plan, o.scale, &plan, err, sizeof err) < 0) {
        fprintf(stderr, "host_sim hil: %s\n", err);
        close(fd);
        return 1;
    }
    sim_path_t path;
    if (sim_path_read_csv(o.path, &plan, &path, err, sizeof err) < 0) {
        fprintf(stderr, "host_sim hil: %s\n", err);
        sim_plan_free(&plan);
        close(fd);
        return 1;
    }
    sim_hal_world_cfg_t wc = sim_hal_world_default_cfg();
    wc.robot = (uint32_t)o.robot;
    wc.seed = (uint64_t)o.seed;
    sim_hal_world_t *hw = NULL;
    int rc = sim_hal_world_create(&plan, &path, &wc, &hw, err, sizeof err);
    if (rc != 0) {
        fprintf(stderr, "host_sim hil: %s\n", err);
        sim_path_free(&path);
        sim_plan_free(&plan);
        close(fd);
        return 1;
    }
    sim_hil_lcm_bridge_t *bridge = NULL;
    sim_hil_bridge_t bridge_ops;
    if (o.fleet_lcm != NULL && sim_hil_lcm_bridge_open(o.fleet_lcm, &bridge, &bridge_ops, err, sizeof err) != 0) {
        fprintf(stderr, "host_sim hil: --fleet-lcm: %s\n", err);
        sim_hal_world_destroy(hw);
        sim_path_free(&path);
        sim_plan_free(&plan);
        close(fd);
        return 1;
    }
    hal_host_stop_set_mode(HAL_HOST_STOP_ASK);
    printf("hil: serving robot %lld's world (plan %s, path %s, seed %lld) on %s %.*s:%u\n", (long long)o.robot,
           o.plan, o.path, (long long)o.seed, o.link == SIM_HIL_SERIAL ? "tcp" : "udp", (int)(strrchr(o.listen, ':') - o.listen),
           o.listen, (unsigned)port);
    fflush(stdout);
    const sim_hil_serve_cfg_t sc = {
        .robot = (uint32_t)o.robot,
        .link = (sim_hil_link_t)o.link,
        .world = {(float)plan.min.x, (float)plan.min.y, (float)plan.max.x, (float)plan.max.y,
                  (uint32_t)(wc.world.dt * 1e6 + 0.5), wc.scan_period_us},
        .idle_timeout_s = o.idle_timeout_s,
        .quiet = o.quiet,
        .bridge = bridge != NULL ? &bridge_ops : NULL};
    sim_hil_serve_stats_t st;
    rc = sim_hil_serve(hw, fd, &sc, &st, err, sizeof err);
    uint64_t refused = 0;
    for (int v = 0; v < HAL_HIL_VERDICTS; v++)
        refused += st.refused[v];
    sim_hal_world_stats_t ws;
    sim_hal_world_get_stats(hw, &ws);
    hal_net_stats_t ns = {0};
    uint64_t echoes = 0;
    if (bridge != NULL)
        sim_hil_lcm_bridge_stats(bridge, &ns, &echoes);
    printf("hil: served %.1f simulated s: %llu ticks, %llu scans sent, %llu wheel commands, %llu sessions, distance %.2f m, "
           "%llu collisions; frames in %llu, out %llu; refused %llu (bad frames), %llu noise bytes, %llu replayed, "
           "%llu before a HELLO, %llu from another address or connection, %llu bad payloads, %llu lost on the way "
           "in, %llu not ours; fleet datagrams: %llu to the fleet, %llu to the board, %llu subscriptions, %llu "
           "bridge errors, %llu dropped on arrival, %llu own echoes, %llu not bridged\n",
           (double)st.t_us * 1e-6, (unsigned long long)st.ticks, (unsigned long long)st.scans,
           (unsigned long long)st.wheels,
           (unsigned long long)st.hellos, ws.distance_m, (unsigned long long)ws.collisions,
           (unsigned long long)st.frames_in, (unsigned long long)st.frames_out, (unsigned long long)refused,
           (unsigned long long)st.noise_bytes, (unsigned long long)st.replayed, (unsigned long long)st.unopened,
           (unsigned long long)st.other_sender, (unsigned long long)(st.bad_payload + st.wrong_robot),
           (unsigned long long)st.lost, (unsigned long long)st.not_ours, (unsigned long long)st.to_fleet,
           (unsigned long long)st.to_board, (unsigned long long)st.subscriptions, (unsigned long long)st.bridge_errors,
           (unsigned long long)(ns.rx_dropped_full + ns.rx_dropped_malformed + ns.rx_dropped_small),
           (unsigned long long)echoes, (unsigned long long)st.datagrams_not_bridged);
    sim_hil_lcm_bridge_close(bridge);
    sim_hal_world_destroy(hw);
    sim_path_free(&path);
    sim_plan_free(&plan);
    close(fd);
    if (rc == -EINTR) {
        const int sig = hal_host_stop_signal();
        fprintf(stderr, "host_sim hil: stopped by %s\n", hal_host_stop_signal_name(sig));
        return hal_host_stop_exit_code(sig);
    }
    if (rc < 0) {
        fprintf(stderr, "host_sim hil: %s\n", err);
        return 1;
    }
    return rc;
}
