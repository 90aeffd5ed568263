/* Stopping a host program on SIGINT or SIGTERM without leaving a part-written file behind.
 *
 * hal_host_stop_install() sets the handlers of SIGINT and SIGTERM for the whole process. What a
 * signal then does depends on the mode:
 *   - HAL_HOST_STOP_NOW (the default), for programs with no place where they could stop in good
 *     order: the handler removes the temporary files of the writers that are open
 *     (hal_host_file_remove_open_temporaries), writes the one-line message and _exits with
 *     128 + the signal (130 for SIGINT, 143 for SIGTERM). Finished outputs are never touched.
 *   - HAL_HOST_STOP_ASK, for a program that can stop cleanly between two steps (host_sim run):
 *     the handler only records the request (one lock-free atomic store). The host back end
 *     reads it where a stop is clean and prompt: hal_host_run_until() returns -EINTR before
 *     the next lockstep instant (every core blocked), and the network's wait returns
 *     -ECANCELED at once, so a GP core waiting for its peers inside one tick ends its wait and
 *     the lockstep can stop. The program then stops the board, aborts its writers, prints its
 *     message and exits with hal_host_stop_exit_code().
 *     A second signal while the requested stop is under way acts as in NOW mode: a stop that
 *     does not come promptly can always be forced.
 * Everything the handler does is async-signal-safe: atomic loads and stores, unlink, write,
 * _exit. The messages are composed beforehand (hal_host_stop_set_message), never in it.
 *
 * hal_host_request_stop() is what the handler calls; tests call it to stop a run without a
 * signal, and hal_host_stop_clear() to forget the request. */
#ifndef HAL_HOST_STOP_H
#define HAL_HOST_STOP_H

typedef enum hal_host_stop_mode {
    HAL_HOST_STOP_NOW = 0,
    HAL_HOST_STOP_ASK = 1
} hal_host_stop_mode_t;

/* Installs the handlers of SIGINT and SIGTERM (sigaction, SA_RESTART) in NOW mode, the message
 * "<prefix>: stopped by SIG..." (prefix e.g. "host_sim run"). 0 or a negative errno. */
FS_MUST_CHECK int hal_host_stop_install(const char *prefix);

void hal_host_stop_set_mode(hal_host_stop_mode_t mode);

/* The line a forced stop writes: "<prefix>: stopped by SIGTERM<suffix>" (suffix e.g. " at round
 * 12", or ""). Long texts are cut. Not from a signal handler. */
void hal_host_stop_set_message(const char *prefix, const char *suffix);

/* Records a stop request for signal signo (the first request is kept). Async-signal-safe. */
void hal_host_request_stop(int signo);

/* The signal of the recorded request, 0 when none. Any thread, async-signal-safe. */
int hal_host_stop_signal(void);

/* Forgets the request (tests, or a program that handled it and goes on). */
void hal_host_stop_clear(void);

/* "SIGINT", "SIGTERM", ... ("signal" for another number). */
const char *hal_host_stop_signal_name(int signo);

/* The exit status of a program stopped by signo: 128 + signo (130, 143). */
int hal_host_stop_exit_code(int signo);

#endif /* HAL_HOST_STOP_H */
