/* Stop requests from SIGINT / SIGTERM: see hal_host_stop.h. */
#include "hal_host_stop.h"

#include <errno.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "hal_host_file.h"

_Static_assert(ATOMIC_INT_LOCK_FREE == 2, "the signal handler needs lock-free atomics");

#define STOP_MSG_MAX 256

static atomic_int g_signal; /* the first request's signal, 0: none */
static atomic_int g_mode = HAL_HOST_STOP_NOW;

/* Two sets of the forced-stop lines (SIGINT, SIGTERM): a new text goes into the set the
 * handler is not reading, which then becomes the current one with one atomic store. */
static char g_msg[2][2][STOP_MSG_MAX];
static atomic_int g_msg_cur;

static int msg_index(int signo)
{
    return signo == SIGTERM ? 1 : 0;
}

static size_t msg_len(const char *s)
{
    size_t n = 0; /* strlen is not on every system's list of async-signal-safe calls */
    while (n < STOP_MSG_MAX && s[n] != '\0')
        n++;
    return n;
}

static void on_signal(int signo)
{
    int none = 0;
    const int first = atomic_compare_exchange_strong(&g_signal, &none, signo);
    if (first && atomic_load(&g_mode) == HAL_HOST_STOP_ASK)
        return; /* the program stops at its next clean point */
    (void)hal_host_file_remove_open_temporaries();
    const char *m = g_msg[atomic_load(&g_msg_cur)][msg_index(signo)];
    ssize_t w = write(STDERR_FILENO, m, msg_len(m));
    (void)w;
    _exit(hal_host_stop_exit_code(signo));
}

void hal_host_stop_set_message(const char *prefix, const char *suffix)
{
    const int next = 1 - atomic_load(&g_msg_cur);
    static const int sigs[2] = {SIGINT, SIGTERM};
    for (int k = 0; k < 2; k++)
        snprintf(g_msg[next][k], STOP_MSG_MAX, "%.120s: stopped by %s%.100s\n", prefix ? prefix : "",
                 hal_host_stop_signal_name(sigs[k]), suffix ? suffix : "");
    atomic_store(&g_msg_cur, next);
}

int hal_host_stop_install(const char *prefix)
{
    hal_host_stop_set_message(prefix, "");
    atomic_store(&g_mode, HAL_HOST_STOP_NOW);
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_signal;
    sa.sa_flags = SA_RESTART; /* the program's own reads and writes go on undisturbed */
    sigemptyset(&sa.sa_mask);
    if (sigaction(SIGINT, &sa, NULL) != 0 || sigaction(SIGTERM, &sa, NULL) != 0)
        return -errno;
    return 0;
}

void hal_host_stop_set_mode(hal_host_stop_mode_t mode)
{
    atomic_store(&g_mode, mode);
}

void hal_host_request_stop(int signo)
{
    int none = 0;
    (void)atomic_compare_exchange_strong(&g_signal, &none, signo);
}

int hal_host_stop_signal(void)
{
    return atomic_load(&g_signal);
}

void hal_host_stop_clear(void)
{
    atomic_store(&g_signal, 0);
}

const char *hal_host_stop_signal_name(int signo)
{
    switch (signo) {
    case SIGINT:
        return "SIGINT";
    case SIGTERM:
        return "SIGTERM";
    case SIGHUP:
        return "SIGHUP";
    case SIGKILL:
        return "SIGKILL";
    default:
        return "signal";
    }
}

int hal_host_stop_exit_code(int signo)
{
    return 128 + signo;
}
