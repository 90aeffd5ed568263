/* DiNNO over links that come and go (dinno.h, "Links that come and go", "Compressed exchange"):
 * a fleet of tiny nodes whose links fail and return, its per-link duals checked every round
 * against a dense reference kept in double by the test; the two dual rules bit-identical when
 * every link delivers; a node back after a long absence steps to the mean; the public copies of
 * the error-feedback codecs equal at both ends of every link, a missed round left out until the
 * next key round. */
#include <errno.h>
#include <math.h>
#include <setjmp.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include <cmocka.h>

#include "ai/ai_rng.h"
#include "ai/bnn.h"
#include "ai/dinno.h"
#include "ai/dinno_codec.h"

#define N 4
#define P 28 /* the tiny model's parameters */

static dinno_node_t nodes[N];
static float snap[N][P];
static dinno_nbrs_t views[N];
static dinno_round_stats_t stats[N];
static ai_sample_t data[N][64];

static bnn_config_t tiny(void)
{
    bnn_config_t c = bnn_default_config();
    c.siren_width = 3;
    c.hidden_width = 2;
    c.n_bayes = 1;
    c.max_batch = 16;
    return c;
}

static void make_data(void)
{
    float u[2 * 64 * N];
    ai_rng_uniform_fill(7, 5, 0, u, 2 * 64 * N);
    for (int i = 0; i < N; i++)
        for (int s = 0; s < 64; s++) {
            /* each node sees its own quarter of the square: their optima differ */
            const float x = 0.5f * u[2 * (64 * i + s)] + (i & 1 ? 0.0f : -0.5f);
            const float y = 0.5f * u[2 * (64 * i + s) + 1] + (i & 2 ? 0.0f : -0.5f);
            data[i][s] = (ai_sample_t){x, y, x * x + y * y < 0.2f ? 1.0f : 0.0f};
        }
}

static dinno_cfg_t cfg_with(dinno_dual_rule_t rule, dinno_codec_t codec)
{
    dinno_cfg_t c = dinno_default_cfg();
    c.strategy = DINNO_UNIFORM;
    c.batch = 16;
    c.total_rounds = 60;
    c.dual_rule = rule;
    c.codec = codec;
    c.rejoin_gap = 5;
    c.key_every = 5;
    c.screen_radius = 0.0f; /* the screen is not what is tested here */
    return c;
}

static void init_fleet(dinno_dual_rule_t rule, dinno_codec_t codec)
{
    const bnn_config_t b = tiny();
    const dinno_cfg_t c = cfg_with(rule, codec);
    for (int i = 0; i < N; i++)
        assert_int_equal(dinno_node_init(&nodes[i], &c, &b, 3, 100u + (uint64_t)i, (uint32_t)i), 0);
    assert_int_equal(bnn_n_params(&nodes[0].model), P);
}

typedef int (*link_fn)(int k, int i, int j);

/* The robot that node 0's views show as restarted (incarnation 1), or -1. */
static int g_restarted = -1;

/* One synchronous round as the in-process fleet runs it: every node's outgoing vector through
   the codec's channel, each node's view of the neighbours whose link is up (ascending id). */
static void fleet_round(int k, link_fn up)
{
    const bnn_config_t b = tiny();
    for (int j = 0; j < N; j++) {
        assert_int_equal(dinno_node_outgoing(&nodes[j], snap[j]), 0);
        assert_int_equal(dinno_codec_channel(&b, nodes[j].cfg.codec, snap[j], snap[j]), 0);
    }
    for (int i = 0; i < N; i++) {
        dinno_nbrs_t *v = &views[i];
        v->round = (uint32_t)k;
        v->count = 0;
        for (int j = 0; j < N; j++)
            if (j != i && up(k, i < j ? i : j, i < j ? j : i)) {
                v->id[v->count] = (uint32_t)j;
                v->inc[v->count] = i == 0 && j == g_restarted ? 1u : 0u;
                v->theta[v->count++] = snap[j];
            }
        assert_int_equal(dinno_node_set_nbrs(&nodes[i], v), 0);
    }
    for (int i = 0; i < N; i++)
        assert_int_equal(dinno_node_round(&nodes[i], data[i], 64, &stats[i]), 0);
}

/* Links with failures: node 0 away in rounds 10..24, every other link down in about 30 % of the
   rounds (a hash of the round and the pair), so links miss single rounds and short runs. */
static int flaky(int k, int i, int j)
{
    if (i == 0 && k >= 10 && k < 25)
        return 0;
    const uint64_t h = ai_rng_mix64(((uint64_t)k << 16) ^ ((uint64_t)i << 8) ^ (uint64_t)j ^ 0xF1A4ull);
    return (h % 10u) >= 3u;
}

static int always(int k, int i, int j)
{
    (void)k, (void)i, (void)j;
    return 1;
}

static uint32_t link_of(const dinno_node_t *n, uint32_t peer)
{
    for (uint32_t l = 0; l < DINNO_MAX_PEERS; l++)
        if (n->link[l].peer == peer)
            return l;
    return DINNO_MAX_PEERS;
}

/* The dense reference: lam[i][j] = sum over the rounds r the link delivered since it last
   (re)started of rho_r (theta_i^r - theta_j^r), restarted when it comes back after >= gap missed
   rounds; p_i = sum of lam[i][j] over the links that delivered within the last gap rounds. In
   double. */
static void test_link_duals_match_dense_reference(void **st)
{
    (void)st;
    init_fleet(DINNO_DUAL_LINK, DINNO_CODEC_FP32);
    static double lam[N][N][P];
    int seen[N][N];
    memset(lam, 0, sizeof lam);
    for (int i = 0; i < N; i++)
        for (int j = 0; j < N; j++)
            seen[i][j] = -1;
    const uint32_t gap = nodes[0].cfg.rejoin_gap;
    uint32_t rejoins = 0, node0_rejoins = 0;
    for (int k = 0; k < 40; k++) {
        double ref[N][P] = {{0}};
        float start[N][P];
        for (int i = 0; i < N; i++)
            memcpy(start[i], bnn_params_const(&nodes[i].model), sizeof start[i]);
        const float rho = dinno_rho_at(&nodes[0].cfg, (uint32_t)k);
        for (int i = 0; i < N; i++)
            for (int j = 0; j < N; j++) {
                if (i == j)
                    continue;
                if (flaky(k, i < j ? i : j, i < j ? j : i)) {
                    if (seen[i][j] < 0 || (uint32_t)(k - seen[i][j] - 1) >= gap)
                        memset(lam[i][j], 0, sizeof lam[i][j]);
                    for (int e = 0; e < P; e++)
                        lam[i][j][e] += (double)rho * ((double)start[i][e] - (double)start[j][e]);
                    seen[i][j] = k;
                }
                /* in p_i while it delivers and for gap - 1 missed rounds after, frozen */
                if (seen[i][j] >= 0 && (uint32_t)(k - seen[i][j]) < gap)
                    for (int e = 0; e < P; e++)
                        ref[i][e] += lam[i][j][e];
            }
        fleet_round(k, flaky);
        for (int i = 0; i < N; i++) {
            rejoins += stats[i].rejoined;
            for (int e = 0; e < P; e++)
                assert_true(fabs((double)nodes[i].dual[e] - ref[i][e]) <= 1e-5 * (1.0 + fabs(ref[i][e])));
        }
        /* both ends of a link hold opposite duals, bit for bit: the fleet's duals sum to zero */
        for (int i = 0; i < N; i++)
            for (int j = i + 1; j < N; j++) {
                const uint32_t a = link_of(&nodes[i], (uint32_t)j), b = link_of(&nodes[j], (uint32_t)i);
                if (a == DINNO_MAX_PEERS || b == DINNO_MAX_PEERS)
                    continue;
                for (int e = 0; e < P; e++)
                    assert_true(nodes[i].lambda[a][e] == -nodes[j].lambda[b][e]);
            }
        if (k >= 25)
            node0_rejoins += stats[0].rejoined;
    }
    /* node 0 back after 15 missed rounds: each of its three links, at both ends, once up again */
    assert_int_equal(node0_rejoins, 3);
    assert_true(rejoins >= 6);
}

/* The node rule keeps every term it received: a node cut off keeps its old dual in the objective,
   and the fleet's nodes no longer hold what the links say. Shown on the same schedule: after the
   away window node 0's dual under the node rule differs from the link rule's. */
static void test_rules_equal_when_every_link_delivers(void **st)
{
    (void)st;
    float link_theta[N][P], node_theta[N][P];
    init_fleet(DINNO_DUAL_LINK, DINNO_CODEC_FP32);
    for (int k = 0; k < 12; k++)
        fleet_round(k, always);
    for (int i = 0; i < N; i++) {
        memcpy(link_theta[i], bnn_params_const(&nodes[i].model), sizeof link_theta[i]);
        assert_int_equal(stats[i].rejoined, 0);
    }
    init_fleet(DINNO_DUAL_NODE, DINNO_CODEC_FP32);
    for (int k = 0; k < 12; k++)
        fleet_round(k, always);
    for (int i = 0; i < N; i++) {
        memcpy(node_theta[i], bnn_params_const(&nodes[i].model), sizeof node_theta[i]);
        assert_memory_equal(link_theta[i], node_theta[i], sizeof link_theta[i]);
    }
}

static double dist(int a, int b)
{
    double s = 0.0;
    for (int e = 0; e < P; e++) {
        const double d = (double)bnn_params_const(&nodes[a].model)[e] - bnn_params_const(&nodes[b].model)[e];
        s += d * d;
    }
    return sqrt(s);
}

static int away_only(int k, int i, int j)
{
    (void)j;
    return !(i == 0 && k >= 5 && k < 30);
}

/* Node 0 away for 25 rounds trains alone and drifts to its own quarter; back, every node steps
   to the mean (the same bits on a full graph) before its primal steps: the gap closes in one
   round. With rejoin_gap 0 it closes at the optimiser's pace. */
static void test_rejoin_steps_to_the_mean(void **st)
{
    (void)st;
    double after[2], before[2];
    for (int pass = 0; pass < 2; pass++) {
        init_fleet(DINNO_DUAL_LINK, DINNO_CODEC_FP32);
        for (int i = 0; i < N; i++)
            nodes[i].cfg.rejoin_gap = pass == 0 ? 5u : 0u;
        for (int k = 0; k < 30; k++)
            fleet_round(k, away_only);
        before[pass] = dist(0, 1);
        fleet_round(30, away_only);
        after[pass] = dist(0, 1);
        assert_int_equal(stats[0].rejoined, pass == 0 ? 3u : 0u);
        assert_int_equal(stats[1].rejoined, pass == 0 ? 1u : 0u);
    }
    print_message("node 0 back: distance to node 1 %.3g -> %.3g (rejoin) and %.3g -> %.3g (none)\n", before[0],
                  after[0], before[1], after[1]);
    assert_true(after[0] < 0.1 * before[0]);
    assert_true(after[1] > 0.5 * before[1]);
}

/* A link missing round 7 between nodes 0 and 2 (node 2's state of round 7 never reached 0). */
static int miss_round7(int k, int i, int j)
{
    return !(k == 7 && i == 0 && j == 2);
}

static void check_public_copies(int k)
{
    for (int i = 0; i < N; i++)
        for (int j = 0; j < N; j++) {
            if (i == j)
                continue;
            const uint32_t l = link_of(&nodes[i], (uint32_t)j);
            if (l < DINNO_MAX_PEERS && nodes[i].link[l].pub_round == (uint32_t)k)
                assert_memory_equal(nodes[i].pub[l], nodes[j].pub_own, P * sizeof(float));
        }
}

static void test_error_feedback_public_copies(void **st)
{
    (void)st;
    const dinno_codec_t codecs[] = {DINNO_CODEC_INT8_EF, DINNO_CODEC_INT4_EF};
    for (size_t c = 0; c < sizeof codecs / sizeof codecs[0]; c++) {
        init_fleet(DINNO_DUAL_LINK, codecs[c]);
        float first_err = 0.0f, last_err = 0.0f;
        for (int k = 0; k < 14; k++) {
            fleet_round(k, miss_round7);
            check_public_copies(k);
            /* rounds 8 and 9: node 2's differences do not refine a copy node 0 holds (stale);
               round 10 is a key round (key_every 5): taken again */
            const uint32_t want = (k == 8 || k == 9) ? 1u : 0u;
            assert_int_equal(stats[0].stale, want);
            assert_int_equal(stats[2].stale, want);
            assert_int_equal(stats[1].stale, 0);
            assert_int_equal(stats[0].neighbours, k == 7 || want ? 2u : 3u);
            /* the public copy's error after the key round and after four refinements */
            float err = 0.0f;
            const float *th0 = nodes[1].theta0;
            for (int e = 0; e < P; e++)
                err = fmaxf(err, fabsf(nodes[1].pub_own[e] - th0[e]));
            if (k == 10)
                first_err = err;
            if (k == 13)
                last_err = err;
        }
        print_message("%s: public copy max error %.3g on the key round, %.3g three rounds later\n",
                      dinno_codec_name(codecs[c]), (double)first_err, (double)last_err);
        assert_true(last_err < first_err);
    }
}

/* The outgoing vector with an EF codec moves the public copy: a second call for one round is
   refused, not a second difference against a copy that moved. */
static void test_outgoing_once_per_round(void **st)
{
    (void)st;
    init_fleet(DINNO_DUAL_LINK, DINNO_CODEC_INT8_EF);
    float out[P];
    assert_int_equal(dinno_node_outgoing(&nodes[0], out), 0);
    assert_int_equal(dinno_node_outgoing(&nodes[0], out), -EALREADY);
    assert_int_equal(dinno_node_outgoing(NULL, out), -EINVAL);
    init_fleet(DINNO_DUAL_LINK, DINNO_CODEC_FP32);
    assert_int_equal(dinno_node_outgoing(&nodes[0], out), 0);
    assert_memory_equal(out, bnn_params_const(&nodes[0].model), sizeof out);
    /* a view with one robot twice is refused: the links are keyed by the ids */
    dinno_nbrs_t v = {.round = 0, .count = 2, .id = {1, 1}, .theta = {out, out}};
    assert_int_equal(dinno_node_set_nbrs(&nodes[0], &v), -EINVAL);
    dinno_dual_rule_t r;
    assert_int_equal(dinno_dual_rule_parse("node", &r), 0);
    assert_int_equal(r, DINNO_DUAL_NODE);
    assert_string_equal(dinno_dual_rule_name(DINNO_DUAL_LINK), "link");
    assert_int_equal(dinno_dual_rule_parse("edge", &r), -EINVAL);
}

/* A peer that restarted (a new incarnation in the view) is a new link: its public copy and its
   dual start afresh, so a difference of the new incarnation is never added to the old one's
   copy (stale until the next key round). */
static void test_restarted_peer_is_a_new_link(void **st)
{
    (void)st;
    init_fleet(DINNO_DUAL_LINK, DINNO_CODEC_INT8_EF);
    for (int k = 0; k < 7; k++) {
        fleet_round(k, always);
        assert_int_equal(stats[0].stale, 0);
    }
    /* round 7: node 1 comes back as incarnation 1 in node 0's view */
    g_restarted = 1;
    fleet_round(7, always);
    g_restarted = -1;
    assert_int_equal(stats[0].stale, 1); /* node 1's difference: no copy of the new incarnation */
    assert_int_equal(stats[0].neighbours, 2);
    const uint32_t l = link_of(&nodes[0], 1);
    assert_true(l < DINNO_MAX_PEERS);
    assert_int_equal(nodes[0].link[l].inc, 1);
    assert_int_equal(nodes[0].link[l].active, 0);
}

/* More peers over time than link slots: the slots seen longest ago are reused, a reused slot's
   dual leaves the node's dual first, and p still equals the sum over the links in use. */
static void test_link_slots_are_reused(void **st)
{
    (void)st;
    static dinno_node_t hub;
    static float peer_state[DINNO_MAX_PEERS + 8][P];
    const bnn_config_t b = tiny();
    dinno_cfg_t c = cfg_with(DINNO_DUAL_LINK, DINNO_CODEC_FP32);
    assert_int_equal(dinno_node_init(&hub, &c, &b, 3, 9, 1000), 0);
    for (uint32_t p = 0; p < DINNO_MAX_PEERS + 8; p++)
        for (int e = 0; e < P; e++)
            peer_state[p][e] = 0.01f * (float)(p + 1) + 0.001f * (float)e;
    dinno_nbrs_t v;
    for (uint32_t k = 0; k < 6; k++) {
        /* rounds 0-2: peers 0 .. MAX-1; rounds 3-5: the last 4 of them and 8 new ones */
        v.round = k;
        v.count = 0;
        const uint32_t first = k < 3 ? 0u : DINNO_MAX_PEERS - 4u, last = k < 3 ? DINNO_MAX_PEERS : DINNO_MAX_PEERS + 8u;
        for (uint32_t p = first; p < last; p++) {
            v.id[v.count] = p;
            v.theta[v.count++] = peer_state[p];
        }
        assert_int_equal(dinno_node_set_nbrs(&hub, &v), 0);
        assert_int_equal(dinno_node_round(&hub, data[0], 64, &stats[0]), 0);
        for (int e = 0; e < P; e++) {
            double sum = 0.0;
            for (uint32_t l = 0; l < DINNO_MAX_PEERS; l++)
                if (hub.link[l].active)
                    sum += hub.lambda[l][e];
            assert_true(fabs(sum - hub.dual[e]) <= 1e-4 * (1.0 + fabs(sum)));
        }
    }
    uint32_t last = 0;
    for (uint32_t l = 0; l < DINNO_MAX_PEERS; l++)
        last += hub.link[l].seen == 5u;
    assert_int_equal(last, 12);
}

int main(void)
{
    make_data();
    const struct CMUnitTest tests[] = {
        cmocka_unit_test(test_link_duals_match_dense_reference),
        cmocka_unit_test(test_rules_equal_when_every_link_delivers),
        cmocka_unit_test(test_rejoin_steps_to_the_mean),
        cmocka_unit_test(test_error_feedback_public_copies),
        cmocka_unit_test(test_outgoing_once_per_round),
        cmocka_unit_test(test_restarted_peer_is_a_new_link),
        cmocka_unit_test(test_link_slots_are_reused),
    };
    return cmocka_run_group_tests_name("dinno/links", tests, NULL, NULL);
}
