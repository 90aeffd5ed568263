/* Latest-value mailbox: sequence semantics, and a two-thread run in which the reader checks
 * that every block it sees is whole (all words from one publish) and never goes back. */
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <errno.h>
#include <pthread.h>
#include <stdatomic.h>
#include <cmocka.h>

#include "alloc_count.h"
#include "fake_board.h"
#include "common/mbox.h"

#define WORDS 4096 /* a 32 KB block: far larger than anything copied atomically */
MBOX_DEFINE(box, WORDS * sizeof(uint64_t));

static void fill(uint64_t *w, uint64_t seq)
{
    for (size_t i = 0; i < WORDS; i++)
        w[i] = seq * 1000003ull + i;
}

static int whole(const uint64_t *w, uint64_t seq)
{
    for (size_t i = 0; i < WORDS; i++)
        if (w[i] != seq * 1000003ull + i)
            return 0;
    return 1;
}

static void test_sequence_semantics(void **state)
{
    (void)state;
    static uint64_t dst[WORDS], src[WORDS];
    uint64_t seq = 77;
    assert_int_equal(mbox_get(&box, dst, &seq), 0); /* nothing ever published */
    assert_int_equal(seq, 0);

    fill(src, 1);
    assert_int_equal(mbox_put(&box, src), 0);
    fill(src, 2);
    assert_int_equal(mbox_put(&box, src), 0); /* overwrites the unread publish */
    assert_int_equal(mbox_get(&box, dst, &seq), 1);
    assert_int_equal(seq, 2);
    assert_true(whole(dst, 2));
    assert_int_equal(mbox_get(&box, dst, &seq), 0); /* nothing new: keeps block 2 */
    assert_int_equal(seq, 2);

    alloc_count_reset();
    for (uint64_t s = 3; s < 50; s++) {
        fill(mbox_write_buffer(&box), s);
        assert_int_equal(mbox_publish(&box), s);
        assert_int_equal(mbox_fetch(&box), 1);
        assert_true(whole(mbox_read_buffer(&box, &seq), s));
        assert_int_equal(seq, s);
    }
    assert_int_equal(alloc_count_allocations(), 0);
    fake_board_t fb;
    fake_board_init(&fb);
    fake_board_install(&fb);
    expect_assert_failure((void)!mbox_put(NULL, src));
    expect_assert_failure((void)!mbox_get(&box, NULL, NULL));
    assert_int_equal(hal_board_install(NULL), 0);
}

/* A reset mailbox is as MBOX_DEFINE made it: nothing published, sequences from 1 again. */
static void test_reset(void **state)
{
    (void)state;
    static uint64_t dst[WORDS], src[WORDS];
    uint64_t seq = 0;
    fill(src, 5);
    assert_int_equal(mbox_put(&box, src), 0);
    mbox_reset(&box);
    assert_int_equal(mbox_get(&box, dst, &seq), 0);
    assert_int_equal(seq, 0);
    fill(src, 1);
    assert_int_equal(mbox_put(&box, src), 0);
    assert_int_equal(mbox_get(&box, dst, &seq), 1);
    assert_int_equal(seq, 1);
    assert_true(whole(dst, 1));
}

#define PUBLISHES 20000u
MBOX_DEFINE(stress_box, WORDS * sizeof(uint64_t));
static atomic_int writer_done;

static void *writer(void *arg)
{
    (void)arg;
    for (uint64_t s = 1; s <= PUBLISHES; s++) {
        fill(mbox_write_buffer(&stress_box), s);
        (void)mbox_publish(&stress_box);
    }
    atomic_store(&writer_done, 1);
    return NULL;
}

static void test_reader_never_sees_torn_block(void **state)
{
    (void)state;
    pthread_t t;
    atomic_store(&writer_done, 0);
    assert_int_equal(pthread_create(&t, NULL, writer, NULL), 0);
    uint64_t last = 0, seen = 0, torn = 0, backwards = 0;
    for (;;) {
        int done = atomic_load(&writer_done);
        int r = mbox_fetch(&stress_box);
        assert_true(r >= 0);
        if (r == 1) {
            uint64_t seq;
            const uint64_t *w = mbox_read_buffer(&stress_box, &seq);
            if (!whole(w, seq))
                torn++;
            if (seq <= last)
                backwards++;
            last = seq;
            seen++;
        }
        if (done && r == 0)
            break;
    }
    assert_int_equal(pthread_join(t, NULL), 0);
    assert_int_equal(torn, 0);
    assert_int_equal(backwards, 0);
    assert_int_equal(last, PUBLISHES); /* the newest publish always arrives */
    print_message("mbox: %llu of %u publishes observed, none torn\n", (unsigned long long)seen,
                  PUBLISHES);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_sequence_semantics),
        cmocka_unit_test(test_reset),
        cmocka_unit_test(test_reader_never_sees_torn_block),
    };
    return cmocka_run_group_tests_name("common/mbox", tests, NULL, NULL);
}
