/* Host board: its life cycle and the adapters from the HAL operation tables to the world
 * binding, LCM and the storage dir. The lockstep scheduler is hal_host_sched.c, the core
 * threads hal_host_cores.c, the log hal_host_log.c (shared state in hal_host_priv.h). */
#include "hal_host.h"
#include "hal_host_priv.h"
#include "hal_host_stop.h"

#include <errno.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>
#ifdef __linux__
#include <sys/prctl.h>
#endif

hal_host_config_t hal_host_config_default(void)
{
    hal_host_config_t c;
    memset(&c, 0, sizeof(c));
    c.sched = HAL_HOST_SCHED_SERIAL;
    c.log_level = HAL_LOG_INFO;
    return c;
}

uint64_t hal_host_now_us(const hal_host_t *h)
{
    return h == NULL ? 0 : atomic_load_explicit(&((hal_host_t *)h)->now_us, memory_order_acquire);
}

hal_host_net_t *hal_host_get_net(hal_host_t *h)
{
    return h != NULL ? h->net : NULL;
}

uint64_t hal_host_world_steps(const hal_host_t *h)
{
    if (h == NULL)
        return 0;
    hal_host_t *m = (hal_host_t *)h;
    pthread_mutex_lock(&m->mu);
    uint64_t s = m->world_steps;
    pthread_mutex_unlock(&m->mu);
    return s;
}

/* ---- world ------------------------------------------------------------------------------ */
static int op_read_scan(void *ctx, hal_lidar_scan_t *scan)
{
    hal_host_t *h = ctx;
    pthread_mutex_lock(&h->world_mu);
    int r = h->cfg.world->read_scan(h->cfg.world->ctx, h->cfg.robot_id, scan);
    pthread_mutex_unlock(&h->world_mu);
    if (r == 0 && (scan->count == 0 || scan->count > HAL_LIDAR_MAX_BEAMS))
        return -EIO; /* the world broke the scan contract */
    return r;
}

static int op_read_pose(void *ctx, hal_pose_t *pose)
{
    hal_host_t *h = ctx;
    pthread_mutex_lock(&h->world_mu);
    int r = h->cfg.world->read_pose(h->cfg.world->ctx, h->cfg.robot_id, pose);
    pthread_mutex_unlock(&h->world_mu);
    return r;
}

static int op_set_wheels(void *ctx, float left, float right)
{
    hal_host_t *h = ctx;
    pthread_mutex_lock(&h->world_mu);
    int r = h->cfg.world->set_wheels(h->cfg.world->ctx, h->cfg.robot_id, left, right);
    pthread_mutex_unlock(&h->world_mu);
    return r;
}

/* Differential-drive inverse kinematics. */
static int op_set_twist(void *ctx, float v, float omega)
{
    hal_host_t *h = ctx;
    float r = h->cfg.wheel_radius_m, sep = h->cfg.wheel_separation_m;
    return op_set_wheels(ctx, (v - omega * sep * 0.5f) / r, (v + omega * sep * 0.5f) / r);
}

/* ---- net and storage -------------------------------------------------------------------- */
static int op_net_publish(void *ctx, const char *channel, const void *data, size_t len)
{
    return hal_host_net_publish(((hal_host_t *)ctx)->net, channel, data, len);
}

static int op_net_subscribe(void *ctx, const char *channel)
{
    return hal_host_net_subscribe(((hal_host_t *)ctx)->net, channel);
}

static int op_net_receive(void *ctx, hal_net_rx_info_t *info, void *buf, size_t cap)
{
    hal_host_t *h = ctx;
    return hal_host_net_receive(h->net, hal_host_now_us(h), info, buf, cap);
}

static int op_net_stats(void *ctx, hal_net_stats_t *stats)
{
    hal_host_net_get_stats(((hal_host_t *)ctx)->net, stats);
    return 0;
}

/* Longest single wait on the network between two looks at a stop request. */
#define NET_WAIT_SLICE_US 50000u

/* The peers are other processes: the network waits in wall-clock time, in slices, so that a
 * stop request (hal_host_stop.h) ends the wait at once with -ECANCELED and the core waiting
 * for its peers inside a tick gets back to the lockstep, where the program can stop. */
static int op_net_wait(void *ctx, uint32_t timeout_us)
{
    hal_host_t *h = ctx;
    uint32_t left = timeout_us;
    do {
        if (hal_host_stop_signal() != 0)
            return -ECANCELED;
        const uint32_t us = left < NET_WAIT_SLICE_US ? left : NET_WAIT_SLICE_US;
        int r = hal_host_net_wait(h->net, hal_host_now_us(h), (int)((us + 999u) / 1000u));
        if (r != 0)
            return r;
        if (hal_host_net_queued(h->net) > 0)
            return 0;
        left -= us;
    } while (left > 0);
    return -EAGAIN;
}

static int op_net_senders(void *ctx, const char *channel, const uint8_t *wanted, uint32_t n_ids)
{
    return hal_host_net_set_senders(((hal_host_t *)ctx)->net, channel, wanted, n_ids);
}

static int op_net_clock(void *ctx, uint64_t *now_us)
{
    (void)ctx;
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    *now_us = (uint64_t)ts.tv_sec * 1000000u + (uint64_t)ts.tv_nsec / 1000u;
    return 0;
}

static int op_st_write(void *ctx, const char *name, const void *data, size_t len)
{
    return hal_host_storage_write(((hal_host_t *)ctx)->storage, name, data, len);
}

static int op_st_read(void *ctx, const char *name, void *buf, size_t cap, size_t *len)
{
    return hal_host_storage_read(((hal_host_t *)ctx)->storage, name, buf, cap, len);
}

static int op_st_remove(void *ctx, const char *name)
{
    return hal_host_storage_remove(((hal_host_t *)ctx)->storage, name);
}

/* A broken contract in the firmware: say where, then stop the process (a board would reset). */
static void op_fault(void *ctx, const char *file, int line, const char *what)
{
    (void)ctx;
    fprintf(stderr, "%s:%d: contract broken: %s\n", file, line, what);
    fflush(stderr);
    abort();
}

/* The operation tables: read-only, one per interface (two for the motors: with and without
 * twist), shared by every hal_host_t; the instance travels in the board's ctx. Clock, cores
 * and log come from hal_host_sched.c, hal_host_cores.c and hal_host_log.c. */
static const hal_lidar_ops_t host_lidar_ops = {.read_scan = op_read_scan};
static const hal_pose_ops_t host_pose_ops = {.read_pose = op_read_pose};
static const hal_motor_ops_t host_motor_ops_wheels = {.set_wheels = op_set_wheels};
static const hal_motor_ops_t host_motor_ops_twist = {.set_wheels = op_set_wheels, .set_twist = op_set_twist};
static const hal_net_ops_t host_net_ops = {
    .publish = op_net_publish, .subscribe = op_net_subscribe, .receive = op_net_receive, .stats = op_net_stats,
    .wait = op_net_wait, .clock_us = op_net_clock, .senders = op_net_senders};
static const hal_storage_ops_t host_storage_ops = {.write = op_st_write, .read = op_st_read, .remove = op_st_remove};

/* ---- life cycle ------------------------------------------------------------------------- */
static int config_error(const char *what)
{
    fprintf(stderr, "hal_host: invalid configuration: %s\n", what);
    return -EINVAL;
}

int hal_host_create(const hal_host_config_t *cfg, hal_host_t **out)
{
    if (cfg == NULL || out == NULL)
        return -EINVAL;
    *out = NULL;
    if (cfg->sched != HAL_HOST_SCHED_SERIAL && cfg->sched != HAL_HOST_SCHED_PARALLEL)
        return config_error("sched must be HAL_HOST_SCHED_SERIAL or _PARALLEL");
    if ((unsigned)cfg->log_level > (unsigned)HAL_LOG_DEBUG)
        return config_error("log_level out of range");
    if (cfg->log_fd < 0)
        return config_error("log_fd is negative");
    if (cfg->net_queue_depth > HAL_HOST_NET_QUEUE_MAX)
        return config_error("net_queue_depth above 16384 (HAL_HOST_NET_QUEUE_MAX)");
    if (cfg->net_queue_bytes != 0 && cfg->net_queue_bytes < HAL_HOST_NET_QUEUE_BYTES_MIN)
        return config_error("net_queue_bytes below two MTU-sized datagrams (HAL_HOST_NET_QUEUE_BYTES_MIN)");
    if (cfg->net_queue_bytes > HAL_HOST_NET_QUEUE_BYTES_MAX)
        return config_error("net_queue_bytes above 256 MB (HAL_HOST_NET_QUEUE_BYTES_MAX)");
    if (cfg->world != NULL && cfg->world->advance_to_us == NULL)
        return config_error("world without advance_to_us");
    if (!(cfg->wheel_radius_m >= 0.0f) || !(cfg->wheel_separation_m >= 0.0f))
        return config_error("wheel geometry negative or NaN");
    hal_host_netfault_cfg_t faults;
    char why[200];
    if (hal_host_netfault_parse(cfg->net_faults, &faults, why, sizeof why) != 0) {
        fprintf(stderr, "hal_host: invalid configuration: net_faults: %s\n", why);
        return -EINVAL;
    }
    if (hal_host_netfault_active(&faults) && cfg->net_url == NULL)
        return config_error("net_faults without a network (net_url is NULL)");
    if (cfg->net_auth != NULL && cfg->net_url == NULL)
        return config_error("net_auth without a network (net_url is NULL)");

    hal_host_t *h = calloc(1, sizeof(*h));
    if (h == NULL)
        return -ENOMEM;
    h->cfg = *cfg;
    pthread_mutex_init(&h->mu, NULL);
    pthread_mutex_init(&h->world_mu, NULL);
    pthread_condattr_t ca;
    pthread_condattr_init(&ca);
    pthread_condattr_setclock(&ca, CLOCK_MONOTONIC); /* the watchdog's clock */
    pthread_cond_init(&h->sched_cv, &ca);
    for (int i = 0; i < HAL_CORE_COUNT; i++) {
        h->core[i].h = h;
        h->core[i].id = (hal_core_id_t)i;
        pthread_cond_init(&h->core[i].cv, &ca); /* monotonic too: the work while asleep */
    }
    pthread_condattr_destroy(&ca);
    int r = 0;
    if (cfg->net_url != NULL)
        r = hal_host_net_open(cfg->net_url,
                              cfg->net_queue_depth ? cfg->net_queue_depth
                                                   : HAL_HOST_NET_QUEUE_DEFAULT,
                              cfg->net_queue_bytes, &h->net);
    if (r == 0 && h->net != NULL)
        r = hal_host_net_set_faults(
            h->net, &faults,
            hal_host_netfault_seed(faults.has_seed ? faults.seed : cfg->net_faults_seed, cfg->robot_id),
            cfg->robot_id);
    if (r == 0 && h->net != NULL)
        r = hal_host_net_set_self(h->net, cfg->robot_id);
    if (r == 0 && h->net != NULL && cfg->net_auth != NULL)
        r = hal_host_net_set_auth(h->net, cfg->net_auth);
    if (r == 0 && cfg->storage_dir != NULL)
        r = hal_host_storage_open(cfg->storage_dir, &h->storage);
    if (r != 0) {
        hal_host_destroy(h);
        return r;
    }

    h->board.name = cfg->board_name != NULL ? cfg->board_name : BOARD_NAME;
    h->board.ctx = h;
    h->board.fault = op_fault;
    h->board.clock = &hal_host_clock_ops;
    h->board.core = &hal_host_core_ops;
    h->board.log = &hal_host_log_ops;
    const hal_host_world_t *w = cfg->world;
    if (w != NULL && w->read_scan != NULL) {
        h->board.lidar = &host_lidar_ops;
    }
    if (w != NULL && w->read_pose != NULL) {
        h->board.pose = &host_pose_ops;
    }
    if (w != NULL && w->set_wheels != NULL) {
        /* Twist needs the wheel geometry; without it the board offers wheels only. */
        const int twist = cfg->wheel_radius_m > 0.0f && cfg->wheel_separation_m > 0.0f;
        h->board.motor = twist ? &host_motor_ops_twist : &host_motor_ops_wheels;
    }
    if (h->net != NULL) {
        h->board.net = &host_net_ops;
    }
    if (h->storage != NULL) {
        h->board.storage = &host_storage_ops;
    }
    *out = h;
    return 0;
}

void hal_host_name_thread(const char *name)
{
#ifdef __linux__
    (void)prctl(PR_SET_NAME, (unsigned long)name, 0UL, 0UL, 0UL); /* cut at 15 characters */
#else
    (void)name;
#endif
}

const hal_board_t *hal_host_board(const hal_host_t *h)
{
    return h == NULL ? NULL : &h->board;
}

void hal_host_destroy(hal_host_t *h)
{
    if (h == NULL)
        return;
    hal_host_stop(h);
    if (hal_board_current == &h->board) {
        int r = hal_board_install(NULL); /* uninstalling cannot fail */
        (void)r;
    }
    hal_host_net_close(h->net);
    hal_host_storage_close(h->storage);
    for (int i = 0; i < HAL_CORE_COUNT; i++)
        pthread_cond_destroy(&h->core[i].cv);
    pthread_cond_destroy(&h->sched_cv);
    pthread_mutex_destroy(&h->world_mu);
    pthread_mutex_destroy(&h->mu);
    free(h);
}

