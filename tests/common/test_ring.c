/* SPSC ring: single-thread contract, drop counting, allocation-free, and a two-thread stress
 * run of ten million records checking order, content and the drop count. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <errno.h>
#include <pthread.h>
#include <cmocka.h>

#include "alloc_count.h"
#include "fake_board.h"
#include "common/ring.h"

typedef struct {
    uint64_t seq;
    uint64_t check; /* derived from seq, so a torn or mixed record is caught */
    uint8_t pad[16];
} rec_t;

static uint64_t check_of(uint64_t seq)
{
    return seq * 0x9E3779B97F4A7C15ull ^ 0xA5A5A5A5A5A5A5A5ull;
}

RING_DEFINE(small_ring, sizeof(rec_t), 8);

static void test_put_get_fifo_and_full(void **state)
{
    (void)state;
    rec_t r = {0}, out;
    assert_int_equal(ring_get(&small_ring, &out), -EAGAIN);
    for (uint64_t i = 0; i < 8; i++) {
        r.seq = i;
        r.check = check_of(i);
        assert_int_equal(ring_put(&small_ring, &r), 0);
    }
    assert_int_equal(ring_count(&small_ring), 8);
    r.seq = 99;
    assert_int_equal(ring_put(&small_ring, &r), -ENOSPC);
    assert_int_equal(ring_put(&small_ring, &r), -ENOSPC);
    assert_int_equal(ring_drops(&small_ring), 2);
    for (uint64_t i = 0; i < 8; i++) {
        assert_int_equal(ring_get(&small_ring, &out), 0);
        assert_int_equal(out.seq, i);
        assert_int_equal(out.check, check_of(i));
    }
    assert_int_equal(ring_get(&small_ring, &out), -EAGAIN);
    assert_int_equal(ring_count(&small_ring), 0);
}

/* A reset ring is empty, has no drops and takes records again. */
static void test_reset(void **state)
{
    (void)state;
    rec_t r = {0}, out;
    for (uint64_t i = 0; i < 8; i++)
        assert_int_equal(ring_put(&small_ring, &r), 0);
    assert_int_equal(ring_put(&small_ring, &r), -ENOSPC); /* dropped and counted */
    assert_true(ring_drops(&small_ring) > 0);
    ring_reset(&small_ring);
    assert_int_equal(ring_count(&small_ring), 0);
    assert_int_equal(ring_drops(&small_ring), 0);
    assert_int_equal(ring_get(&small_ring, &out), -EAGAIN);
    r.seq = 7;
    r.check = check_of(7);
    assert_int_equal(ring_put(&small_ring, &r), 0);
    assert_int_equal(ring_get(&small_ring, &out), 0);
    assert_int_equal(out.seq, 7);
    assert_int_equal(out.check, check_of(7));
}

static void test_rejects_null(void **state)
{
    (void)state;
    rec_t r = {0};
    /* NULL breaks the contract: the board's fault handler, here cmocka's mock_assert. */
    fake_board_t fb;
    fake_board_init(&fb);
    fake_board_install(&fb);
    expect_assert_failure((void)!ring_put(NULL, &r));
    expect_assert_failure((void)!ring_put(&small_ring, NULL));
    expect_assert_failure((void)!ring_get(NULL, &r));
    expect_assert_failure((void)!ring_get(&small_ring, NULL));
    assert_int_equal(hal_board_install(NULL), 0);
}

static void test_wraps_and_allocates_nothing(void **state)
{
    (void)state;
    rec_t r = {0}, out;
    alloc_count_reset();
    /* Many times the capacity, so the indices wrap the storage repeatedly. */
    for (uint64_t i = 0; i < 1000; i++) {
        r.seq = i;
        assert_int_equal(ring_put(&small_ring, &r), 0);
        assert_int_equal(ring_get(&small_ring, &out), 0);
        assert_int_equal(out.seq, i);
    }
    assert_int_equal(alloc_count_allocations(), 0);
}

/* ---- two-thread stress ---- */
#define STRESS_RECORDS 10000000ull
RING_DEFINE(stress_ring, sizeof(rec_t), 1024);

typedef struct {
    uint64_t accepted; /* records the ring took */
    uint64_t rejected; /* ring_put() returned -ENOSPC */
} producer_result_t;

static void *producer(void *arg)
{
    producer_result_t *res = arg;
    rec_t r = {0};
    /* The producer never waits: like the RT core, it offers each record once. Every
     * accepted record carries the next sequence number, so the consumer can check that
     * nothing accepted was lost, duplicated or reordered. */
    uint64_t offered = 0;
    while (res->accepted < STRESS_RECORDS) {
        r.seq = res->accepted;
        r.check = check_of(r.seq);
        r.pad[0] = (uint8_t)r.seq;
        if (ring_put(&stress_ring, &r) == 0)
            res->accepted++;
        else
            res->rejected++;
        offered++;
    }
    (void)offered;
    return NULL;
}

static void test_two_thread_stress(void **state)
{
    (void)state;
    producer_result_t res = {0, 0};
    uint32_t drops_before = ring_drops(&stress_ring);
    pthread_t t;
    assert_int_equal(pthread_create(&t, NULL, producer, &res), 0);
    uint64_t expect = 0, bad = 0;
    rec_t out;
    while (expect < STRESS_RECORDS) {
        if (ring_get(&stress_ring, &out) != 0)
            continue;
        if (out.seq != expect || out.check != check_of(expect) || out.pad[0] != (uint8_t)expect)
            bad++;
        expect++;
    }
    assert_int_equal(pthread_join(t, NULL), 0);
    assert_int_equal(bad, 0);
    assert_int_equal(res.accepted, STRESS_RECORDS);
    /* Every -ENOSPC is counted as a drop, exactly (the counter is 32-bit and wraps). */
    assert_int_equal((uint32_t)(ring_drops(&stress_ring) - drops_before), (uint32_t)res.rejected);
    assert_int_equal(ring_count(&stress_ring), 0);
    print_message("stress: %llu records through, %llu drops counted\n",
                  (unsigned long long)STRESS_RECORDS, (unsigned long long)res.rejected);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_put_get_fifo_and_full),
        cmocka_unit_test(test_reset),
        cmocka_unit_test(test_rejects_null),
        cmocka_unit_test(test_wraps_and_allocates_nothing),
        cmocka_unit_test(test_two_thread_stress),
    };
    return cmocka_run_group_tests_name("common/ring", tests, NULL, NULL);
}
