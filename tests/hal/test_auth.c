/* A keyed fleet's membership (hal/host/hal_host_auth.h): the datagram MAC's verdicts, the key
 * file's checks, and four networks over real UDP multicast on this host, of which only the
 * member of the same key and run is heard; the others are dropped and counted before the
 * bounds check (see tests/hal/test_net.c for what udpm on one host needs). */
#define _GNU_SOURCE 1
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <pthread.h>
#include <sodium.h>
#include <sys/stat.h>
#include <unistd.h>
#include <cmocka.h>

#include "hal/hal.h"
#include "hal_host.h"
#include "hal_host_auth.h"
#include "hal_host_msg.h"
#include "gp/gp_wire.h"
#include "run_outputs.h"

static char dir[256];

static int setup(void **st)
{
    (void)st;
    snprintf(dir, sizeof dir, "%s/test_auth_XXXXXX", getenv("TMPDIR") ? getenv("TMPDIR") : "/tmp");
    return mkdtemp(dir) != NULL && hal_host_auth_init() == 0 ? 0 : -1;
}

static int teardown(void **st)
{
    (void)st;
    return test_remove_tree(dir);
}

static hal_host_auth_t member(uint8_t key_byte, uint64_t run_id)
{
    hal_host_auth_t a;
    memset(a.key, key_byte, sizeof a.key);
    a.run_id = run_id;
    return a;
}

/* Seal then open: the message comes back; any change, another key, channel or run does not. */
static void test_tag_verdicts(void **st)
{
    (void)st;
    const hal_host_auth_t a = member(1, 77), other_key = member(2, 77), other_run = member(1, 78);
    uint8_t wire[64 + HAL_HOST_AUTH_TRAILER_BYTES];
    for (size_t i = 0; i < 64; i++)
        wire[i] = (uint8_t)(i * 13u);
    hal_host_auth_seal(&a, "fleetsim/3/state", wire, 64);
    size_t len = 0;
    assert_int_equal(hal_host_auth_open(&a, "fleetsim/3/state", wire, sizeof wire, &len), HAL_HOST_AUTH_OK);
    assert_int_equal(len, 64);
    assert_int_equal(hal_host_auth_open(&other_key, "fleetsim/3/state", wire, sizeof wire, &len),
                     HAL_HOST_AUTH_BAD_TAG);
    assert_int_equal(hal_host_auth_open(&other_run, "fleetsim/3/state", wire, sizeof wire, &len),
                     HAL_HOST_AUTH_OTHER_RUN);
    assert_int_equal(hal_host_auth_open(&a, "fleetsim/4/state", wire, sizeof wire, &len), HAL_HOST_AUTH_BAD_TAG);
    assert_int_equal(hal_host_auth_open(&a, "fleetsim/3/state", wire, HAL_HOST_AUTH_TRAILER_BYTES - 1u, &len),
                     HAL_HOST_AUTH_SHORT);
    /* Every single bit flipped, in the message, the run id and the tag, is caught. */
    for (size_t bit = 0; bit < 8u * sizeof wire; bit++) {
        wire[bit / 8] ^= (uint8_t)(1u << (bit % 8));
        assert_int_not_equal(hal_host_auth_open(&a, "fleetsim/3/state", wire, sizeof wire, &len), HAL_HOST_AUTH_OK);
        wire[bit / 8] ^= (uint8_t)(1u << (bit % 8));
    }
    /* A truncated datagram (the tail of a message taken for a trailer) fails too. */
    assert_int_equal(hal_host_auth_open(&a, "fleetsim/3/state", wire + 1, sizeof wire - 1u, &len),
                     HAL_HOST_AUTH_BAD_TAG);
    /* An empty message has a tag of its own. */
    uint8_t empty[HAL_HOST_AUTH_TRAILER_BYTES];
    hal_host_auth_seal(&a, "x", empty, 0);
    assert_int_equal(hal_host_auth_open(&a, "x", empty, sizeof empty, &len), HAL_HOST_AUTH_OK);
    assert_int_equal(len, 0);
}

/* The wire format from its definition (hal_host_auth.h), with libsodium alone: the tag of a
 * sealed message of len bytes, whichever library computed it. */
static int tag_is_the_definitions(const hal_host_auth_t *a, const char *channel, const uint8_t *wire, size_t len)
{
    uint8_t ck[crypto_aead_xchacha20poly1305_ietf_KEYBYTES], tag[HAL_HOST_AUTH_TAG_BYTES], none[1] = {0};
    unsigned long long tag_len = 0;
    crypto_generichash(ck, sizeof ck, (const unsigned char *)channel, strlen(channel) + 1u, a->key, sizeof a->key);
    const uint8_t *nonce = wire + len + HAL_HOST_AUTH_RUN_ID_BYTES;
    crypto_aead_xchacha20poly1305_ietf_encrypt_detached(none, tag, &tag_len, none, 0, wire,
                                                        len + HAL_HOST_AUTH_RUN_ID_BYTES, NULL, nonce, ck);
    return memcmp(tag, nonce + HAL_HOST_AUTH_NONCE_BYTES, sizeof tag) == 0;
}

#define LONG_MSG 61376u /* a full state chunk */

typedef struct {
    const hal_host_auth_t *a;
    uint8_t *wire;
    size_t len;
    int ok;
} open_job_t;

static void *open_elsewhere(void *arg)
{
    open_job_t *j = arg;
    size_t len = 0;
    j->ok = hal_host_auth_open(j->a, "fleetsim/3/state", j->wire, j->len + HAL_HOST_AUTH_TRAILER_BYTES, &len) ==
                HAL_HOST_AUTH_OK &&
            len == j->len;
    return NULL;
}

/* Short datagrams' tags come from libsodium, long ones' from OpenSSL's Poly1305: every length
 * on both sides of the switch gives the definition's tag, is opened, and fails when flipped;
 * another thread (its own OpenSSL context) opens what this one sealed. */
static void test_long_and_short_tags_alike(void **st)
{
    (void)st;
    const hal_host_auth_t a = member(5, 0x0123456789abcdefull);
    static uint8_t wire[LONG_MSG + HAL_HOST_AUTH_TRAILER_BYTES];
    for (size_t i = 0; i < LONG_MSG; i++)
        wire[i] = (uint8_t)(i * 2654435761u >> 13);
    const size_t lens[] = {0, 1, 15, 16, 17, 1000, 1999, 2000, 2031, 2032, 2033, 2040, 2047, 2048, 2049,
                           4096, 8191, 30001, LONG_MSG - 1u, LONG_MSG};
    for (size_t k = 0; k < sizeof lens / sizeof lens[0]; k++) {
        const size_t n = lens[k];
        hal_host_auth_seal(&a, "fleetsim/3/state", wire, n);
        assert_true(tag_is_the_definitions(&a, "fleetsim/3/state", wire, n));
        size_t len = 0;
        assert_int_equal(hal_host_auth_open(&a, "fleetsim/3/state", wire, n + HAL_HOST_AUTH_TRAILER_BYTES, &len),
                         HAL_HOST_AUTH_OK);
        assert_int_equal(len, n);
        for (size_t at = 0; at < n + HAL_HOST_AUTH_TRAILER_BYTES; at += 1 + n / 7u) {
            wire[at] ^= 0x40u;
            assert_int_not_equal(
                hal_host_auth_open(&a, "fleetsim/3/state", wire, n + HAL_HOST_AUTH_TRAILER_BYTES, &len),
                HAL_HOST_AUTH_OK);
            wire[at] ^= 0x40u;
        }
    }
    hal_host_auth_seal(&a, "fleetsim/3/state", wire, LONG_MSG);
    open_job_t j = {&a, wire, LONG_MSG, 0};
    pthread_t t;
    assert_int_equal(pthread_create(&t, NULL, open_elsewhere, &j), 0);
    assert_int_equal(pthread_join(t, NULL), 0);
    assert_true(j.ok);
}

static void write_file(const char *path, const char *text, mode_t mode)
{
    unlink(path);
    FILE *f = fopen(path, "w");
    assert_non_null(f);
    fputs(text, f);
    fclose(f);
    assert_int_equal(chmod(path, mode), 0);
}

/* The key file: new keys are 0600 and never overwrite; a key others can read, a short or
 * non-hex one, or a folder are refused with the reason. */
static void test_key_files(void **st)
{
    (void)st;
    char path[300], why[512];
    uint8_t k1[HAL_HOST_AUTH_KEY_BYTES], k2[HAL_HOST_AUTH_KEY_BYTES];
    snprintf(path, sizeof path, "%s/fleet.key", dir);
    assert_int_equal(hal_host_auth_key_new(path, why, sizeof why), 0);
    struct stat s;
    assert_int_equal(stat(path, &s), 0);
    assert_int_equal(s.st_mode & 0777, 0600);
    assert_int_equal(s.st_size, 65);
    assert_int_equal(hal_host_auth_key_load(path, k1, why, sizeof why), 0);
    assert_int_equal(hal_host_auth_key_new(path, why, sizeof why), -1);
    assert_non_null(strstr(why, "never overwritten"));
    assert_int_equal(hal_host_auth_key_load(path, k2, why, sizeof why), 0);
    assert_memory_equal(k1, k2, sizeof k1); /* still the first key */

    char hex[80];
    for (int i = 0; i < 64; i++)
        hex[i] = "0123456789abcdef"[i % 16];
    hex[64] = '\0';
    write_file(path, hex, 0600); /* no newline: fine */
    assert_int_equal(hal_host_auth_key_load(path, k1, why, sizeof why), 0);
    assert_int_equal(k1[0], 0x01);
    write_file(path, hex, 0640);
    assert_int_equal(hal_host_auth_key_load(path, k1, why, sizeof why), -1);
    assert_non_null(strstr(why, "chmod 600"));
    hex[63] = '\0';
    write_file(path, hex, 0600);
    assert_int_equal(hal_host_auth_key_load(path, k1, why, sizeof why), -1);
    assert_non_null(strstr(why, "not a fleet key"));
    /* The contents first: no key at all is "not a fleet key" whatever its mode (a README). */
    write_file(path, hex, 0644);
    assert_int_equal(hal_host_auth_key_load(path, k1, why, sizeof why), -1);
    assert_non_null(strstr(why, "not a fleet key"));
    assert_null(strstr(why, "chmod"));
    hex[63] = 'g';
    hex[64] = '\0';
    write_file(path, hex, 0600);
    assert_int_equal(hal_host_auth_key_load(path, k1, why, sizeof why), -1);
    strcat(hex, "\n0");
    write_file(path, hex, 0600);
    assert_int_equal(hal_host_auth_key_load(path, k1, why, sizeof why), -1);
    assert_int_equal(hal_host_auth_key_load(dir, k1, why, sizeof why), -1);
    assert_non_null(strstr(why, "not a regular file"));
    snprintf(path, sizeof path, "%s/missing.key", dir);
    assert_int_equal(hal_host_auth_key_load(path, k1, why, sizeof why), -1);
    assert_non_null(strstr(why, "No such file"));
}

#define CH "fleetsim/authtest/x"

/* Four senders on one multicast group: a member (same key and run), an unkeyed process, a
 * member of another run (a replay) and a holder of another key. The keyed receiver takes the
 * member's messages only, stripped of their trailers, and counts the others by kind. */
static void test_only_members_are_heard(void **st)
{
    (void)st;
    char url[128];
    snprintf(url, sizeof url, "udpm://239.255.76.67:%u?ttl=0&recv_buf_size=1048576", 7930u + (unsigned)(getpid() % 30));
    const hal_host_auth_t me = member(7, 1000), replay = member(7, 999), stranger = member(8, 1000);
    hal_host_net_t *rx = NULL, *tx[4] = {NULL};
    assert_int_equal(hal_host_net_open(url, 256, 0, &rx), 0);
    assert_int_equal(hal_host_net_set_auth(rx, &me), 0);
    assert_int_equal(hal_host_net_subscribe(rx, CH), 0);
    assert_int_equal(hal_host_net_set_auth(rx, &me), -EBUSY); /* once, before the first datagram */
    for (int i = 0; i < 4; i++)
        assert_int_equal(hal_host_net_open(url, 4, 0, &tx[i]), 0);
    assert_int_equal(hal_host_net_set_auth(tx[0], &me), 0);
    assert_int_equal(hal_host_net_set_auth(tx[2], &replay), 0);
    assert_int_equal(hal_host_net_set_auth(tx[3], &stranger), 0);
    static uint8_t msg[HAL_NET_MTU_BYTES], got[HAL_NET_MTU_BYTES];
    for (size_t i = 0; i < sizeof msg; i++)
        msg[i] = (uint8_t)(i * 7u);
    /* A member may send a whole MTU: the trailer rides on top. */
    int heard = 0;
    hal_net_stats_t s = {0};
    for (int tries = 0; tries < 50 && (heard == 0 || s.rx_dropped_unauth < 2 || s.rx_dropped_replay < 1); tries++) {
        for (int i = 0; i < 4; i++)
            assert_int_equal(hal_host_net_publish(tx[i], CH, msg, i == 0 ? sizeof msg : 100u), 0);
        assert_int_equal(hal_host_net_wait(rx, 0, 100), 0);
        hal_net_rx_info_t info;
        while (hal_host_net_receive(rx, 0, &info, got, sizeof got) == 0) {
            assert_int_equal(info.len, sizeof msg); /* only the member's, trailer stripped */
            assert_memory_equal(got, msg, sizeof msg);
            heard++;
        }
        hal_host_net_get_stats(rx, &s);
    }
    assert_true(heard >= 1);
    assert_true(s.rx_dropped_unauth >= 2); /* the unkeyed one and the other key */
    assert_true(s.rx_dropped_replay >= 1);
    assert_int_equal(s.rx_dropped_malformed, 0);
    hal_net_stats_t ts;
    hal_host_net_get_stats(tx[0], &ts);
    assert_int_equal(ts.tx_bytes % (sizeof msg + HAL_HOST_AUTH_TRAILER_BYTES), 0); /* wire bytes counted */
    for (int i = 0; i < 4; i++)
        hal_host_net_close(tx[i]);
    hal_host_net_close(rx);
}

/* A node told its id (hal_host_net_set_self) drops its own datagrams coming back before their
 * tag is checked: on a typed channel, sender field = its id. LCM's memq provider, like
 * multicast, delivers a publisher's own messages to its subscriptions. Others are heard. */
static void test_own_datagrams_dropped_before_the_tag(void **st)
{
    (void)st;
    const char *ch = "fleetsim/authtest/done";
    const hal_host_auth_t me = member(7, 1000);
    hal_host_net_t *n = NULL;
    assert_int_equal(hal_host_net_open("memq://", 16, 0, &n), 0);
    assert_int_equal(hal_host_net_set_self(n, 3), 0);
    assert_int_equal(hal_host_net_set_auth(n, &me), 0);
    assert_int_equal(hal_host_net_expect_type(n, ch, HAL_HOST_MSG_ROUND_COMPLETE), 0);
    assert_int_equal(hal_host_net_subscribe(n, ch), 0);
    assert_int_equal(hal_host_net_set_self(n, 4), -EBUSY); /* before the first subscribe only */
    assert_int_equal(hal_host_net_set_self(NULL, 4), -EINVAL);
    uint8_t buf[64], got[64];
    for (uint32_t sender = 3; sender <= 4; sender++) {
        const gp_pse_done_t d = {sender, 17, 1, 0, 0.0, 0.0};
        const int len = gp_wire_encode_done(&d, buf, sizeof buf);
        assert_true(len > 0);
        assert_int_equal(hal_host_net_publish(n, ch, buf, (size_t)len), 0);
    }
    hal_net_rx_info_t info;
    hal_net_stats_t s = {0};
    int heard = 0;
    for (int tries = 0; tries < 50 && heard + (int)s.rx_own < 2; tries++) { /* bounded: 5 s */
        assert_int_equal(hal_host_net_wait(n, 0, 100), 0);
        while (hal_host_net_receive(n, 0, &info, got, sizeof got) == 0) {
            gp_pse_done_t d;
            assert_int_equal(gp_wire_decode_done(got, info.len, &d), 0);
            assert_int_equal(d.sender, 4);
            heard++;
        }
        hal_host_net_get_stats(n, &s);
    }
    assert_int_equal(heard, 1);
    assert_int_equal(s.rx_own, 1);
    assert_int_equal(s.rx_dropped_unauth, 0);
    assert_int_equal(s.rx_messages, 1);
    hal_host_net_close(n);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_tag_verdicts),
        cmocka_unit_test(test_long_and_short_tags_alike),
        cmocka_unit_test(test_key_files),
        cmocka_unit_test(test_only_members_are_heard),
        cmocka_unit_test(test_own_datagrams_dropped_before_the_tag),
    };
    return cmocka_run_group_tests(tests, setup, teardown);
}
