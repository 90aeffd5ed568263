#include "net_heard.h"

#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <string.h>
#include <cmocka.h>

#include "gp/gp_wire.h"

uint32_t net_heard_within(hal_host_net_t *rx, int timeout_ms, const char *plain)
{
    uint32_t heard = 0;
    uint8_t b[64];
    assert_int_equal(hal_host_net_wait(rx, 0, timeout_ms), 0);
    hal_net_rx_info_t info;
    while (hal_host_net_receive(rx, 0, &info, b, sizeof b) == 0) {
        if (plain != NULL && strcmp(info.channel, plain) == 0) {
            heard |= 1u << 31;
            continue;
        }
        gp_pse_done_t d;
        assert_int_equal(gp_wire_decode_done(b, info.len, &d), 0);
        assert_true(d.sender < 31u);
        heard |= 1u << d.sender;
    }
    return heard;
}

void net_publish_done(hal_host_net_t *n, const char *channel, uint32_t sender)
{
    uint8_t b[64];
    const gp_pse_done_t d = {sender, 3, 1, 0, 0.0, 0.0};
    const int len = gp_wire_encode_done(&d, b, sizeof b);
    assert_true(len > 0);
    assert_int_equal(hal_host_net_publish(n, channel, b, (size_t)len), 0);
}
