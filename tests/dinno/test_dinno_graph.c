/* Communication graphs: full, ring, disk, connectivity report. */
#include <errno.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <cmocka.h>

#include "ai/dinno_graph.h"

static void test_full_and_ring(void **st)
{
    (void)st;
    dinno_graph_t g;
    dinno_graph_report_t r;
    assert_int_equal(dinno_graph_full(&g, 7), 0);
    dinno_graph_report(&g, &r);
    assert_int_equal(r.edges, 21);
    assert_int_equal(r.components, 1);
    assert_int_equal(r.isolated, 0);
    assert_int_equal(r.largest, 7);
    for (uint32_t i = 0; i < 7; i++) {
        assert_false(dinno_graph_has_edge(&g, i, i));
        assert_int_equal(dinno_graph_degree(&g, i), 6);
    }
    assert_int_equal(dinno_graph_ring(&g, 7), 0);
    dinno_graph_report(&g, &r);
    assert_int_equal(r.edges, 7);
    assert_true(dinno_graph_has_edge(&g, 6, 0));
    assert_false(dinno_graph_has_edge(&g, 0, 2));
    assert_int_equal(dinno_graph_ring(&g, 2), 0);
    dinno_graph_report(&g, &r);
    assert_int_equal(r.edges, 1);
    assert_int_equal(dinno_graph_ring(&g, 1), 0);
    dinno_graph_report(&g, &r);
    assert_int_equal(r.edges, 0);
    assert_int_equal(r.isolated, 1);
    assert_int_equal(r.components, 1);
    assert_int_equal(dinno_graph_full(&g, 0), -EINVAL);
    assert_int_equal(dinno_graph_full(&g, DINNO_GRAPH_MAX_NODES + 1), -EINVAL);
    dinno_graph_kind_t k;
    assert_int_equal(dinno_graph_parse("disk", &k), 0);
    assert_int_equal(k, DINNO_GRAPH_DISK);
    assert_int_equal(dinno_graph_parse("star", &k), -EINVAL);
}

static void test_disk_components(void **st)
{
    (void)st;
    /* 0-1-2 chained at 1 m, 3-4 at 0.5 m far away, 5 alone. */
    const double xy[] = {0, 0, 1, 0, 2, 0, 10, 10, 10.5, 10, -20, 5};
    dinno_graph_t g;
    dinno_graph_report_t r;
    assert_int_equal(dinno_graph_disk(&g, 6, xy, 1.0), 0);
    dinno_graph_report(&g, &r);
    assert_true(dinno_graph_has_edge(&g, 0, 1));
    assert_true(dinno_graph_has_edge(&g, 1, 2));
    assert_false(dinno_graph_has_edge(&g, 0, 2)); /* 2 m > radius */
    assert_true(dinno_graph_has_edge(&g, 4, 3));
    assert_int_equal(r.edges, 3);
    assert_int_equal(r.components, 3);
    assert_int_equal(r.isolated, 1);
    assert_int_equal(r.largest, 3);
    assert_int_equal(dinno_graph_disk(&g, 6, xy, 100.0), 0);
    dinno_graph_report(&g, &r);
    assert_int_equal(r.edges, 15);
    assert_int_equal(r.components, 1);
    assert_int_equal(dinno_graph_disk(&g, 6, xy, 0.0), 0);
    dinno_graph_report(&g, &r);
    assert_int_equal(r.isolated, 6);
    assert_int_equal(r.components, 6);
    const double bad[] = {0, NAN};
    assert_int_equal(dinno_graph_disk(&g, 1, bad, 1.0), -EINVAL);
    assert_int_equal(dinno_graph_disk(&g, 6, xy, -1.0), -EINVAL);
    assert_int_equal(dinno_graph_disk(&g, 6, NULL, 1.0), -EINVAL);
}

/* More nodes in reach than slots: each node takes its DINNO_GRAPH_MAX_DEGREE nearest (ties by
 * id), listed in ascending id, and the graph is no longer symmetric. */
static void test_disk_keeps_the_nearest(void **st)
{
    (void)st;
    enum { K = DINNO_GRAPH_MAX_DEGREE, N = K + 4 };
    static dinno_graph_t g;
    dinno_graph_report_t r;
    /* Node 0 at the origin, node i at x = i; nodes 1 and 2 swapped so that order is not id
       order, and node N-1 at the same distance as node N-2. */
    double xy[2 * N] = {0};
    for (int i = 1; i < N; i++)
        xy[2 * i] = (double)i;
    xy[2 * 1] = 2.0;
    xy[2 * 2] = 1.0;
    xy[2 * (N - 1)] = (double)(N - 2);
    assert_int_equal(dinno_graph_disk(&g, N, xy, 1e6), 0);
    assert_int_equal(dinno_graph_degree(&g, 0), K);
    for (uint32_t s = 1; s < K; s++)
        assert_true(g.nb[0][s - 1] < g.nb[0][s]); /* ascending ids */
    for (uint32_t j = 1; j <= K; j++)
        assert_true(dinno_graph_has_edge(&g, 0, j)); /* 1 .. K are the nearest K */
    assert_false(dinno_graph_has_edge(&g, 0, N - 2));
    assert_false(dinno_graph_has_edge(&g, 0, N - 1));
    /* Node N-1 ties with N-2 for node 0; from N-1's side node 0 is the farthest and left out. */
    assert_false(dinno_graph_has_edge(&g, N - 1, 0));
    assert_true(dinno_graph_has_edge(&g, N - 1, N - 2));
    dinno_graph_report(&g, &r);
    assert_int_equal(r.components, 1);
    assert_int_equal(r.isolated, 0);
    /* full has no positions to choose by: a fleet beyond the slots is refused. */
    assert_int_equal(dinno_graph_full(&g, K + 1), 0);
    assert_int_equal(dinno_graph_full(&g, K + 2), -E2BIG);
}

int main(void)
{
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_full_and_ring),
        cmocka_unit_test(test_disk_components),
        cmocka_unit_test(test_disk_keeps_the_nearest),
    };
    return cmocka_run_group_tests_name("dinno/graph", tests, NULL, NULL);
}
