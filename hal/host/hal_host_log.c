/* Host board: the log, one line per call with simulated time and core, written whole. */
#include "hal_host_priv.h"

#include <stdio.h>
#include <unistd.h>

/* ---- log -------------------------------------------------------------------------------- */
static void op_vlog(void *ctx, hal_log_level_t level, const char *fmt, va_list ap)
{
    static const char *const names[] = {"ERROR", "WARN", "INFO", "DEBUG"};
    hal_host_t *h = ctx;
    if (level > h->cfg.log_level)
        return;
    uint64_t now = hal_host_now_us(h);
    host_core_t *c = hal_host_tls_core;
    const char *who = (c != NULL && c->h == h) ? hal_core_name(c->id) : "host";
    char line[HAL_LOG_LINE_MAX + 64u];
    int n = snprintf(line, sizeof(line), "[%6llu.%06llu] %-4s %-5s ",
                     (unsigned long long)(now / 1000000u), (unsigned long long)(now % 1000000u),
                     who, names[level]);
    if (n < 0)
        return;
    size_t head = (size_t)n;
    int m = vsnprintf(line + head, HAL_LOG_LINE_MAX, fmt, ap);
    if (m < 0)
        return;
    size_t len = head + ((size_t)m < HAL_LOG_LINE_MAX ? (size_t)m : HAL_LOG_LINE_MAX - 1u);
    line[len++] = '\n';
    /* One write per line, so lines of different cores never interleave. */
    ssize_t w = write(h->cfg.log_fd > 0 ? h->cfg.log_fd : 2, line, len);
    (void)w;
}

const hal_log_ops_t hal_host_log_ops = {.vlog = op_vlog};
