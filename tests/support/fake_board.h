/* A fake HAL board for unit tests of the cores, one tick at a time, with no threads, no world
 * and no network: the test scripts the clock, the pose, the lidar and the messages to receive;
 * the board records motor commands, storage writes, publishes and log lines; any operation can
 * be told to fail. All storage is fixed (no allocation), so tests can also prove the cores
 * allocate nothing.
 *
 *   fake_board_t fb;
 *   fake_board_init(&fb);             // every interface present, time 0, nothing scripted
 *   fake_board_install(&fb);          // hal_board_install(); tests then call *_tick() directly
 *   fb.pose = (hal_pose_t){...};      // what hal_pose_read() returns (pose_rc: its result)
 *   fb.storage_fail_count = 1;        // the next write fails with storage_fail_rc
 *
 * Single-threaded: a test and the core it drives share the board. */
#ifndef TESTS_FAKE_BOARD_H
#define TESTS_FAKE_BOARD_H

#include <stddef.h>
#include <stdint.h>

#include "ai/bnn_ckpt.h"
#include "hal/hal.h"

#define FAKE_MOTOR_LOG 64u         /* last motor commands kept */
#define FAKE_FILES 8u              /* files the in-memory storage holds */
#define FAKE_FILE_MAX (BNN_CKPT_MAX_BYTES + 64u)
#define FAKE_NET_LOG 32u           /* last publishes kept */
#define FAKE_NET_KEEP 256u         /* bytes kept of each publish */
#define FAKE_NET_RX 16u            /* scripted messages waiting to be received */
#define FAKE_NET_RX_MAX 4096u
#define FAKE_LOG_LINES 16u

typedef struct fake_motor_cmd {
    uint64_t t_us;
    float left, right; /* rad/s, or v (m/s) and omega (rad/s) when twist */
    int twist;
} fake_motor_cmd_t;

typedef struct fake_file {
    char name[HAL_STORAGE_NAME_MAX];
    size_t len;
    uint8_t data[FAKE_FILE_MAX];
    int used;
} fake_file_t;

typedef struct fake_publish {
    uint64_t t_us;
    char channel[HAL_NET_CHANNEL_MAX];
    size_t len;
    uint8_t data[FAKE_NET_KEEP]; /* the first FAKE_NET_KEEP bytes */
} fake_publish_t;

typedef struct fake_rx {
    char channel[HAL_NET_CHANNEL_MAX];
    size_t len;
    uint8_t data[FAKE_NET_RX_MAX];
} fake_rx_t;

typedef struct fake_board {
    hal_board_t board;
    /* clock */
    uint64_t now_us;
    int stopping;              /* sleep_until_us then returns -ECANCELED */
    /* pose and lidar: what the next read returns, and its result code */
    hal_pose_t pose;
    int pose_rc;
    hal_lidar_scan_t scan;
    int lidar_rc;
    /* motors */
    fake_motor_cmd_t motor[FAKE_MOTOR_LOG];
    uint64_t n_motor;          /* commands so far (the last FAKE_MOTOR_LOG kept) */
    int motor_rc;
    /* storage */
    fake_file_t files[FAKE_FILES];
    uint64_t n_writes;
    int storage_fail_count;    /* the next N writes fail with storage_fail_rc */
    int storage_fail_rc;       /* default -EIO */
    /* network */
    fake_publish_t pub[FAKE_NET_LOG];
    uint64_t n_pub;
    int publish_rc;
    char subscribed[8][HAL_NET_CHANNEL_MAX];
    int n_subscribed;
    fake_rx_t rx[FAKE_NET_RX];
    unsigned rx_head, rx_fill;
    hal_net_stats_t net_stats;
    /* cores started (not run: the test ticks them) */
    hal_core_entry_t started[HAL_CORE_COUNT];
    /* log */
    char log[FAKE_LOG_LINES][160];
    uint64_t n_log;
    uint64_t n_log_level[4];
} fake_board_t;

/* Every interface present; net and storage may be removed by setting board.net / board.storage
 * to NULL before installing. */
void fake_board_init(fake_board_t *fb);
/* hal_board_install(&fb->board); asserts it succeeds. */
void fake_board_install(fake_board_t *fb);

/* The i-th last motor command (0 = latest); NULL when there is none. */
const fake_motor_cmd_t *fake_board_motor(const fake_board_t *fb, unsigned i);
/* The stored file `name`, NULL when absent. */
const fake_file_t *fake_board_file(const fake_board_t *fb, const char *name);
/* The i-th last publish (0 = latest), NULL when there is none. */
const fake_publish_t *fake_board_publish(const fake_board_t *fb, unsigned i);
/* Queues a message for hal_net_receive(); 0, or -ENOSPC when the queue is full. */
int fake_board_push_rx(fake_board_t *fb, const char *channel, const void *data, size_t len);
/* Whether the last log line contains `text`. */
int fake_board_logged(const fake_board_t *fb, const char *text);

#endif /* TESTS_FAKE_BOARD_H */
