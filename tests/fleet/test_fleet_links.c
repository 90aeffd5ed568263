/* The link models of the in-process DiNNO fleet (host_sim/fleet/sim_links.[ch], sim_fleet.c):
 *   - success 1 and no cut: the views are the graph's neighbour lists and the models are bit
 *     for bit those of a model whose every draw delivers (a cut outside the run);
 *   - a partition: in its rounds no node hears one of another group (the agents named in no
 *     group being one more), before and after every node hears all;
 *   - away=i: node i trains alone in those rounds, nobody hears it;
 *   - success 0.3 on a full graph of 8: delivered fraction near 0.3, both ways or neither, the
 *     same drops for the same seed (whatever the threads), others for another seed;
 *   - the spec parser and the checks: good and bad specs, with their reasons.
 * Tiny models and data (a few ms a round): what is tested is who hears whom. */
#include <errno.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <cmocka.h>

#include "ai/ai_rng.h"
#include "sim_fleet.h"
#include "sim_links.h"

#define MAX_N 8
#define N_SAMPLES 64

static ai_sample_t data[MAX_N][N_SAMPLES];

static void make_data(void)
{
    float u[2 * N_SAMPLES];
    for (int a = 0; a < MAX_N; a++) {
        ai_rng_uniform_fill(91, (uint64_t)a, 0, u, 2 * N_SAMPLES);
        for (int s = 0; s < N_SAMPLES; s++) {
            const float x = 2 * u[2 * s] - 1, y = 2 * u[2 * s + 1] - 1;
            data[a][s] = (ai_sample_t){x, y, fabsf(x - 0.3f) < 0.1f || fabsf(y + 0.2f) < 0.1f ? 1.0f : 0.0f};
        }
    }
}

static sim_fleet_cfg_t cfg(int n, uint32_t rounds, uint64_t seed)
{
    sim_fleet_cfg_t c;
    sim_fleet_cfg_default(&c);
    c.n_agents = n;
    c.rounds = rounds;
    c.graph = DINNO_GRAPH_FULL;
    c.seed = seed;
    c.dinno.primal_steps = 1;
    c.dinno.batch = 16;
    return c;
}

static sim_fleet_t *make(const sim_fleet_cfg_t *c)
{
    bnn_config_t b = bnn_default_config();
    b.siren_width = 16;
    b.hidden_width = 16;
    b.n_bayes = 1;
    b.max_batch = 16;
    const ai_sample_t *d[MAX_N];
    size_t n[MAX_N];
    for (int a = 0; a < c->n_agents; a++) {
        d[a] = data[a];
        n[a] = N_SAMPLES;
    }
    sim_fleet_t *f = NULL;
    char err[256];
    const int rc = sim_fleet_create(c, &b, d, n, NULL, &f, err, sizeof err);
    if (rc != 0)
        fail_msg("sim_fleet_create: %d %s", rc, err);
    return f;
}

/* 1 when node i heard node j in the last round. */
static int hears(const sim_fleet_t *f, int i, int j)
{
    const dinno_nbrs_t *v = sim_fleet_view(f, i);
    assert_non_null(v);
    for (uint32_t s = 0; s < v->count; s++)
        if (v->id[s] == (uint32_t)j)
            return 1;
    return 0;
}

static void parse_ok(const char *spec, sim_links_t *l)
{
    char err[256];
    const int rc = sim_links_parse(spec, l, err, sizeof err);
    if (rc != 0)
        fail_msg("'%s': %d %s", spec, rc, err);
}

/* (a) */
static void test_default_is_every_link(void **st)
{
    (void)st;
    const uint32_t R = 4;
    sim_fleet_cfg_t c = cfg(4, R, 7);
    c.graph = DINNO_GRAPH_RING;
    sim_fleet_t *a = make(&c);
    assert_false(sim_links_active(&c.links));
    /* the same, through the draws: success 1 and a cut after the last round */
    parse_ok("away=1,from=100,until=200", &c.links);
    assert_true(sim_links_active(&c.links));
    sim_fleet_t *b = make(&c);
    for (uint32_t k = 0; k < R; k++) {
        dinno_graph_report_t ra, rb;
        assert_int_equal(sim_fleet_round(a, &ra), 0);
        assert_int_equal(sim_fleet_round(b, &rb), 0);
        assert_memory_equal(&ra, &rb, sizeof ra);
        assert_int_equal(ra.edges, 4);
        const dinno_graph_t *g = sim_fleet_graph(a);
        for (int i = 0; i < 4; i++) {
            const dinno_nbrs_t *v = sim_fleet_view(a, i);
            assert_int_equal(v->round, k);
            assert_int_equal(v->count, g->deg[i]);
            for (uint32_t s = 0; s < v->count; s++)
                assert_int_equal(v->id[s], g->nb[i][s]);
            assert_int_equal(sim_fleet_view(b, i)->count, v->count);
        }
        uint32_t dropped = 99, offered = 0;
        sim_fleet_last_links(a, &dropped, &offered);
        assert_int_equal(dropped, 0);
        assert_int_equal(offered, 8);
    }
    const size_t bytes = bnn_n_params(&sim_fleet_node(a, 0)->model) * sizeof(float);
    for (int i = 0; i < 4; i++) {
        assert_memory_equal(bnn_params(&sim_fleet_node(a, i)->model), bnn_params(&sim_fleet_node(b, i)->model),
                            bytes);
        assert_memory_equal(sim_fleet_node(a, i)->dual, sim_fleet_node(b, i)->dual, bytes);
    }
    uint64_t dropped = 99, offered = 0;
    sim_fleet_link_totals(b, &dropped, &offered);
    assert_int_equal(dropped, 0);
    assert_int_equal(offered, 8 * R);
    sim_fleet_destroy(a);
    sim_fleet_destroy(b);
}

/* (b) 6 agents, partition=0.1.2/3.4 in rounds [2, 4): agent 5, named in no group, is a third. */
static void test_partition_window(void **st)
{
    (void)st;
    sim_fleet_cfg_t c = cfg(6, 6, 3);
    parse_ok("partition=0.1.2/3.4,from=2,until=4", &c.links);
    sim_fleet_t *f = make(&c);
    static const int grp[6] = {1, 1, 1, 2, 2, 0};
    for (uint32_t k = 0; k < 6; k++) {
        dinno_graph_report_t rep;
        assert_int_equal(sim_fleet_round(f, &rep), 0);
        const int cut = k >= 2 && k < 4;
        for (int i = 0; i < 6; i++) {
            for (int j = 0; j < 6; j++)
                if (j != i)
                    assert_int_equal(hears(f, i, j), !cut || grp[i] == grp[j]);
            const uint32_t expect = cut ? (grp[i] == 1 ? 2u : grp[i] == 2 ? 1u : 0u) : 5u;
            assert_int_equal(sim_fleet_view(f, i)->count, expect);
            assert_true(sim_fleet_last_stats(f, i)->neighbours <= expect);
        }
        assert_int_equal(rep.components, cut ? 3 : 1);
        assert_int_equal(rep.isolated, cut ? 1 : 0);
        uint32_t dropped, offered;
        sim_fleet_last_links(f, &dropped, &offered);
        assert_int_equal(offered, 30);
        assert_int_equal(dropped, cut ? 30 - 8 : 0); /* kept: 3 x 2 + 2 x 1 + 0 */
    }
    uint64_t dropped, offered;
    sim_fleet_link_totals(f, &dropped, &offered);
    assert_int_equal(dropped, 2 * 22);
    assert_int_equal(offered, 6 * 30);
    sim_fleet_destroy(f);
}

/* (c) away=2 in rounds [1, 3) and, a second cut, away=0 from round 4 on. */
static void test_away(void **st)
{
    (void)st;
    sim_fleet_cfg_t c = cfg(4, 6, 5);
    parse_ok("away=2,from=1,until=3", &c.links);
    parse_ok("away=0,from=4", &c.links);
    assert_int_equal(c.links.n_cuts, 2);
    sim_fleet_t *f = make(&c);
    for (uint32_t k = 0; k < 6; k++) {
        dinno_graph_report_t rep;
        assert_int_equal(sim_fleet_round(f, &rep), 0);
        const int away = k >= 1 && k < 3 ? 2 : k >= 4 ? 0 : -1;
        for (int i = 0; i < 4; i++) {
            const uint32_t n = sim_fleet_view(f, i)->count;
            if (i == away) {
                assert_int_equal(n, 0);
                assert_int_equal(sim_fleet_last_stats(f, i)->neighbours, 0);
            } else {
                assert_int_equal(n, away < 0 ? 3 : 2);
                assert_false(away >= 0 && hears(f, i, away));
            }
        }
        assert_int_equal(rep.isolated, away >= 0);
    }
    sim_fleet_destroy(f);
}

/* (d) Who heard whom in every round of a run: [round][i][j]. */
typedef uint8_t heard_t[50][MAX_N][MAX_N];

static void run_lossy(uint64_t seed, int threads, heard_t h, uint64_t *dropped, uint64_t *offered)
{
    sim_fleet_cfg_t c = cfg(MAX_N, 50, seed);
    c.threads = threads;
    c.links.success = 0.3;
    sim_fleet_t *f = make(&c);
    for (uint32_t k = 0; k < 50; k++) {
        assert_int_equal(sim_fleet_round(f, NULL), 0);
        for (int i = 0; i < MAX_N; i++) {
            for (int j = 0; j < MAX_N; j++)
                h[k][i][j] = j != i && hears(f, i, j);
            assert_true(sim_fleet_last_stats(f, i)->neighbours <= sim_fleet_view(f, i)->count);
        }
    }
    sim_fleet_link_totals(f, dropped, offered);
    sim_fleet_destroy(f);
}

static heard_t h1, h2, h3;

static void test_lossy_links(void **st)
{
    (void)st;
    uint64_t d1, o1, d2, o2, d3, o3;
    run_lossy(3, 1, h1, &d1, &o1);
    run_lossy(3, 2, h2, &d2, &o2);
    run_lossy(4, 1, h3, &d3, &o3);
    assert_int_equal(o1, 50u * MAX_N * (MAX_N - 1));
    uint64_t delivered = 0;
    for (int k = 0; k < 50; k++)
        for (int i = 0; i < MAX_N; i++)
            for (int j = 0; j < MAX_N; j++) {
                assert_int_equal(h1[k][i][j], h1[k][j][i]); /* both ways or neither */
                delivered += h1[k][i][j];
            }
    assert_int_equal(delivered, o1 - d1);
    /* 1400 independent pairs: sd sqrt(0.3 x 0.7 / 1400) = 0.012; 4 sd */
    const double frac = (double)delivered / (double)o1;
    print_message("delivered %.4f of %llu neighbour entries (p 0.3)\n", frac, (unsigned long long)o1);
    assert_true(fabs(frac - 0.3) < 4 * sqrt(0.3 * 0.7 / 1400.0));
    assert_memory_equal(h1, h2, sizeof h1); /* same seed, other threads: the same drops */
    assert_int_equal(d1, d2);
    assert_memory_not_equal(h1, h3, sizeof h1);
    /* the fleet's drops are sim_links_deliver's */
    sim_links_t l;
    sim_links_default(&l);
    l.success = 0.3;
    for (uint32_t k = 0; k < 50; k++)
        for (uint32_t i = 0; i < MAX_N; i++)
            for (uint32_t j = 0; j < MAX_N; j++)
                if (i != j) {
                    assert_int_equal(h3[k][i][j], sim_links_deliver(&l, 4, k, i, j));
                    assert_int_equal(sim_links_deliver(&l, 4, k, i, j), sim_links_deliver(&l, 4, k, j, i));
                }
    /* 0 and 1 are sure, whatever the seed */
    l.success = 0.0;
    assert_int_equal(sim_links_deliver(&l, 4, 0, 1, 2), 0);
    l.success = 1.0;
    assert_int_equal(sim_links_deliver(&l, 4, 0, 1, 2), 1);
}

/* (e) */
static void test_parse_and_check(void **st)
{
    (void)st;
    sim_links_t l;
    char err[256], line[512];
    sim_links_default(&l);
    sim_links_describe(&l, line, sizeof line);
    assert_string_equal(line, "every link delivers");
    assert_int_equal(sim_links_check(&l, 3, err, sizeof err), 0);

    parse_ok("partition=0.1.2/3.4.5,from=10,until=20;away=6,from=5,until=6", &l);
    assert_int_equal(l.n_cuts, 2);
    assert_int_equal(l.cut[0].groups, 2);
    assert_int_equal(l.cut[0].from, 10);
    assert_int_equal(l.cut[0].until, 20);
    assert_int_equal(l.cut[0].group[2], 1);
    assert_int_equal(l.cut[0].group[3], 2);
    assert_int_equal(l.cut[0].group[6], 0);
    assert_int_equal(l.cut[1].group[6], 1);
    parse_ok("until=7,partition=1/0", &l); /* keys in any order; from 0 */
    assert_int_equal(l.cut[2].from, 0);
    parse_ok("partition=3", &l); /* {3} | the rest, for ever */
    assert_int_equal(l.cut[3].until, SIM_LINKS_FOREVER);
    l.success = 0.25;
    sim_links_describe(&l, line, sizeof line);
    assert_string_equal(line, "success 0.25; partition=0.1.2/3.4.5 rounds [10, 20); away=6 rounds [5, 6); "
                              "partition=1/0 rounds [0, 7); away=3 rounds [0, end)");
    assert_int_equal(sim_links_check(&l, 7, err, sizeof err), 0);
    assert_int_equal(sim_links_check(&l, 6, err, sizeof err), -EINVAL); /* agent 6 of 6 */
    assert_non_null(strstr(err, "cut 2: agent 6 is not one of the 6 agents"));
    /* a fifth cut: too many, and l unchanged */
    const sim_links_t before = l;
    assert_int_equal(sim_links_parse("away=1", &l, err, sizeof err), -E2BIG);
    assert_memory_equal(&l, &before, sizeof l);

    static const char *const bad[][2] = {
        {"", "empty spec"},
        {"away=1;", "an empty cut"},
        {"away=1,,from=2", "an empty item"},
        {"bogus=1", "unknown key 'bogus'"},
        {"away", "is not key=value"},
        {"away=x", "away=x: not an agent id"},
        {"away=1,away=2", "away given twice"},
        {"away=1,partition=2/3", "not both"},
        {"from=1,until=2", "needs partition=A/B or away=I"},
        {"away=1,from=5,until=5", "until=5 is not after from=5"},
        {"away=1,from=6,until=5", "until=5 is not after from=6"},
        {"away=1,from=-1", "not a round"},
        {"away=1,until=", "until=: no value"},
        {"partition=0.1/1.2", "agent 1 is in two groups"},
        {"partition=0.0/1", "agent 0 is named twice"},
        {"partition=0..1/2", "an empty group or id"},
        {"partition=0/", "an empty group or id"},
        {"partition=/1", "an empty group or id"},
        {"partition=0//1", "an empty group or id"},
        {"partition=0/a", "'a' is not an agent id"},
        {"partition=0/99999999", "is not an agent id"},
        {"away=1;away=2,bogus=3", "cut 3: unknown key"},
    };
    for (size_t t = 0; t < sizeof bad / sizeof bad[0]; t++) {
        sim_links_t m;
        sim_links_default(&m);
        parse_ok("away=0", &m);
        const sim_links_t keep = m;
        err[0] = '\0';
        if (sim_links_parse(bad[t][0], &m, err, sizeof err) != -EINVAL || strstr(err, bad[t][1]) == NULL)
            fail_msg("'%s': '%s', expected '%s'", bad[t][0], err, bad[t][1]);
        assert_memory_equal(&m, &keep, sizeof m); /* a bad spec changes nothing */
    }

    /* checks against the fleet */
    sim_links_default(&l);
    l.success = 1.5;
    assert_int_equal(sim_links_check(&l, 3, err, sizeof err), -EINVAL);
    assert_non_null(strstr(err, "not a probability"));
    l.success = NAN;
    assert_int_equal(sim_links_check(&l, 3, err, sizeof err), -EINVAL);
    sim_links_default(&l);
    parse_ok("partition=0.1.2", &l);
    assert_int_equal(sim_links_check(&l, 4, err, sizeof err), 0); /* 3 | the rest */
    assert_int_equal(sim_links_check(&l, 3, err, sizeof err), -EINVAL);
    assert_non_null(strstr(err, "splits nothing"));

    /* the fleet refuses a bad model, and a link model of a baseline */
    sim_fleet_cfg_t c = cfg(3, 1, 1);
    const ai_sample_t *d[3] = {data[0], data[1], data[2]};
    const size_t n[3] = {N_SAMPLES, N_SAMPLES, N_SAMPLES};
    sim_fleet_t *f = NULL;
    parse_ok("away=3", &c.links);
    assert_int_equal(sim_fleet_create(&c, NULL, d, n, NULL, &f, err, sizeof err), -EINVAL);
    assert_non_null(strstr(err, "agent 3 is not one of the 3 agents"));
    sim_links_default(&c.links);
    c.links.success = 0.5;
    c.mode = SIM_FLEET_ISOLATED;
    assert_int_equal(sim_fleet_create(&c, NULL, d, n, NULL, &f, err, sizeof err), -EINVAL);
    assert_non_null(strstr(err, "needs a DiNNO fleet"));
    assert_null(f);
}

int main(void)
{
    make_data();
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_default_is_every_link),
        cmocka_unit_test(test_partition_window),
        cmocka_unit_test(test_away),
        cmocka_unit_test(test_lossy_links),
        cmocka_unit_test(test_parse_and_check),
    };
    return cmocka_run_group_tests_name("fleet/links", tests, NULL, NULL);
}
