/* Writes the binary seeds of the fuzz targets with the project's own encoders, so they follow
 * the formats wherever these go:
 *   DIR/wire/NAME.bin     datagram sequences (framing in fuzz_config.h) made by gp_wire: whole
 *                         states reassembled over two rounds, a gap and its resend request, a
 *                         peer restarting, a fleet rounds ahead, a bad CRC, an echo of our own
 *   DIR/ckpt/NAME.bnn     bnn_ckpt_save of the fuzz model, with and without the Adam moments,
 *                         and with an epistemic posterior (bnn_ckpt_save_post)
 *   DIR/samples/NAME.samples  sim_samples_open/append/close files: a few records, and none
 * `make fuzz-seeds` writes them into tests/fuzz/corpus; `make fuzz` into its scratch corpus.
 *   gen_seeds DIR */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "ai/bnn.h"
#include "ai/bnn_ckpt.h"
#include "ai/bnn_post.h"
#include "common/crc32.h"
#include "fuzz/fuzz_config.h"
#include "gp/gp_wire.h"
#include "sim_samples.h"

static const char *g_dir;

static void die(const char *what)
{
    fprintf(stderr, "gen_seeds: %s\n", what);
    exit(1);
}

static void write_file(const char *sub, const char *name, const void *data, size_t len)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/%s", g_dir, sub);
    if (mkdir(path, 0777) != 0 && errno != EEXIST)
        die(path);
    snprintf(path, sizeof path, "%s/%s/%s", g_dir, sub, name);
    FILE *f = fopen(path, "wb");
    if (f == NULL || fwrite(data, 1, len, f) != len || fclose(f) != 0)
        die(path);
}

/* ---- wire: a sequence of framed datagrams and ticks ------------------------------------- */
typedef struct seq {
    uint8_t b[32768];
    size_t n;
} seq_t;

static void put_datagram(seq_t *s, unsigned what, unsigned d, const uint8_t *dg, int len)
{
    if (len < 0 || s->n + 3u + (size_t)len > sizeof s->b)
        die("a wire seed does not fit");
    s->b[s->n++] = FUZZ_WIRE_OP(what, d);
    s->b[s->n++] = (uint8_t)(len >> 8);
    s->b[s->n++] = (uint8_t)len;
    memcpy(s->b + s->n, dg, (size_t)len);
    s->n += (size_t)len;
}

static void tick(seq_t *s, unsigned d)
{
    if (s->n + 1u > sizeof s->b)
        die("a wire seed does not fit");
    s->b[s->n++] = FUZZ_WIRE_OP(FUZZ_WIRE_TICK, d);
}

/* Chunk `chunk` of robot `sender`'s state of `round` (crc_xor != 0: a corrupt CRC). */
static void chunk(seq_t *s, unsigned d, uint32_t sender, uint32_t round, uint32_t chunk, uint32_t inc,
                  uint32_t crc_xor)
{
    uint8_t state[FUZZ_WIRE_STATE_BYTES], dg[GP_WIRE_CHUNK_HEADER_BYTES + FUZZ_WIRE_CHUNK_BYTES];
    for (uint32_t i = 0; i < FUZZ_WIRE_STATE_BYTES; i++)
        state[i] = fuzz_wire_state_byte(sender, round, i);
    const uint32_t n_chunks = (FUZZ_WIRE_STATE_BYTES + FUZZ_WIRE_CHUNK_BYTES - 1u) / FUZZ_WIRE_CHUNK_BYTES;
    const uint32_t off = chunk * FUZZ_WIRE_CHUNK_BYTES;
    const uint32_t left = FUZZ_WIRE_STATE_BYTES - off;
    const gp_pse_chunk_t c = {
        .sender = sender, .round = round, .chunk = chunk, .n_chunks = n_chunks,
        .state_bytes = FUZZ_WIRE_STATE_BYTES, .crc32 = crc32_ieee(state, sizeof state) ^ crc_xor,
        .x_m = 1.0 + sender, .y_m = 2.0,
        .n_bytes = left < FUZZ_WIRE_CHUNK_BYTES ? left : FUZZ_WIRE_CHUNK_BYTES, .data = state + off,
        .encoding = 0, .incarnation = inc,
    };
    put_datagram(s, FUZZ_WIRE_STATE, d, dg, gp_wire_encode_chunk(&c, dg, sizeof dg));
}

static void state(seq_t *s, uint32_t sender, uint32_t round, uint32_t inc)
{
    for (uint32_t k = 0; k * FUZZ_WIRE_CHUNK_BYTES < FUZZ_WIRE_STATE_BYTES; k++)
        chunk(s, 1, sender, round, k, inc, 0);
}

static void done(seq_t *s, unsigned d, uint32_t sender, uint32_t round, uint32_t inc)
{
    uint8_t dg[GP_WIRE_DONE_BYTES];
    const gp_pse_done_t m = {sender, round, inc, 0, 0.0, 0.0};
    put_datagram(s, FUZZ_WIRE_DONE, d, dg, gp_wire_encode_done(&m, dg, sizeof dg));
}

/* A resend request for chunks[0..n) (n = 0: a beacon, target = requester). */
static void request(seq_t *s, unsigned d, uint32_t requester, uint32_t target, uint32_t round, uint32_t inc,
                    uint32_t n, const uint32_t *chunks)
{
    uint8_t dg[GP_WIRE_REQUEST_BYTES(GP_PSE_MAX_REQUEST)];
    gp_pse_request_t r = {.requester = requester, .target = target, .round = round, .n = n, .incarnation = inc};
    if (n > 0)
        memcpy(r.chunks, chunks, sizeof *chunks * n);
    put_datagram(s, FUZZ_WIRE_REQUEST, d, dg, gp_wire_encode_request(&r, dg, sizeof dg));
}

static void save_seq(const char *name, const seq_t *s)
{
    write_file("wire", name, s->b, s->n);
}

static void wire_seeds(void)
{
    static seq_t s;
    static const uint32_t first_two[] = {0, 1}, ends[] = {0, 2};

    /* Two whole rounds: both peers' states, our RoundComplete, theirs, the next round. */
    s.n = 0;
    for (uint32_t round = 0; round < 2; round++) {
        state(&s, 1, round, 1);
        state(&s, 2, round, 1);
        tick(&s, 2);
        done(&s, 1, 1, round, 1);
        done(&s, 1, 2, round, 1);
        tick(&s, 2);
    }
    save_seq("two_rounds.bin", &s);

    /* A gap: the last chunk first (a fast retransmit), the rest after our request; a peer asks
       us for two chunks; a beacon. */
    s.n = 0;
    chunk(&s, 1, 1, 0, 2, 1, 0);
    tick(&s, 3);
    tick(&s, 8);
    chunk(&s, 1, 1, 0, 0, 1, 0);
    chunk(&s, 1, 1, 0, 1, 1, 0);
    request(&s, 1, 2, FUZZ_WIRE_SELF, 0, 1, 2, ends);
    request(&s, 1, 2, 2, 0, 1, 0, NULL);
    request(&s, 1, 1, 2, 0, 1, 2, first_two);
    state(&s, 2, 0, 1);
    tick(&s, 2);
    save_seq("gap_resend.bin", &s);

    /* A restart: peer 1's first incarnation sends part of its state, its second one all of it,
       then a late RoundComplete of the first arrives. */
    s.n = 0;
    chunk(&s, 1, 1, 0, 0, 1, 0);
    chunk(&s, 1, 1, 0, 1, 1, 0);
    state(&s, 1, 0, 2);
    done(&s, 1, 1, 0, 1);
    state(&s, 2, 0, 1);
    tick(&s, 2);
    save_seq("restart.bin", &s);

    /* The fleet is rounds ahead: a beacon of round 4 and a RoundComplete of round 3 end our
       round and make us skip. */
    s.n = 0;
    chunk(&s, 1, 2, 1, 0, 1, 0);
    request(&s, 1, 2, 2, 4, 1, 0, NULL);
    done(&s, 1, 1, 3, 1);
    tick(&s, 2);
    tick(&s, 4);
    tick(&s, 4);
    save_seq("ahead.bin", &s);

    /* A corrupt state (every chunk's CRC wrong), then a silent peer times out. */
    s.n = 0;
    for (uint32_t k = 0; k < 3; k++)
        chunk(&s, 1, 1, 0, k, 1, 0x1u);
    tick(&s, 40);
    tick(&s, 40);
    save_seq("bad_crc.bin", &s);

    /* Our own chunk echoed back (dropped), one datagram of each kind alone. */
    s.n = 0;
    chunk(&s, 0, FUZZ_WIRE_SELF, 0, 0, 1, 0);
    save_seq("echo.bin", &s);
    s.n = 0;
    chunk(&s, 0, 1, 0, 1, 1, 0);
    save_seq("chunk.bin", &s);
    s.n = 0;
    done(&s, 0, 2, 0, 1);
    save_seq("done.bin", &s);
    s.n = 0;
    request(&s, 0, 1, FUZZ_WIRE_SELF, 0, 1, 2, first_two);
    save_seq("request.bin", &s);
}

/* ---- checkpoints of the fuzz model ------------------------------------------------------ */
static void ckpt_seeds(void)
{
    static bnn_model_t m;
    bnn_config_t cfg = bnn_default_config();
    cfg.siren_width = FUZZ_CKPT_SIREN;
    cfg.hidden_width = FUZZ_CKPT_HIDDEN;
    cfg.n_bayes = FUZZ_CKPT_LAYERS;
    cfg.max_batch = 4;
    if (bnn_init(&m, &cfg, FUZZ_CKPT_SEED) != 0)
        die("bnn_init");
    static uint8_t buf[BNN_CKPT_MAX_BYTES];
    size_t n = 0;
    if (bnn_ckpt_save(&m, 0, buf, sizeof buf, &n) != 0)
        die("bnn_ckpt_save");
    write_file("ckpt", "init.bnn", buf, n);
    /* One training step, so the Adam moments and step counts are not zero. */
    const ai_sample_t batch[4] = {{-0.5f, -0.5f, 1.0f}, {0.5f, -0.5f, 0.0f}, {-0.5f, 0.5f, 0.0f}, {0.5f, 0.5f, 1.0f}};
    if (bnn_train_step(&m, batch, 4, 1e-3f, 1, 1e-2f, NULL) != 0)
        die("bnn_train_step");
    if (bnn_ckpt_save(&m, 1, buf, sizeof buf, &n) != 0)
        die("bnn_ckpt_save");
    write_file("ckpt", "adam.bnn", buf, n);
    /* With an epistemic posterior (flag bit 1) over the initial SIREN layer, of four points. */
    static bnn_model_t m0;
    static bnn_post_t post;
    const float xy[8] = {-0.5f, -0.5f, 0.5f, -0.5f, -0.5f, 0.5f, 0.5f, 0.5f};
    if (bnn_init(&m0, &cfg, FUZZ_CKPT_SEED) != 0 || bnn_post_init(&post, &m0) != 0 ||
        bnn_post_observe(&post, &m, xy, 4) != 0 || bnn_ckpt_save_post(&m, 0, &post, buf, sizeof buf, &n) != 0)
        die("bnn_ckpt_save_post");
    write_file("ckpt", "post.bnn", buf, n);
}

/* ---- samples files ---------------------------------------------------------------------- */
static void samples_seed(const char *name, size_t count)
{
    char path[4096];
    snprintf(path, sizeof path, "%s/samples", g_dir);
    if (mkdir(path, 0777) != 0 && errno != EEXIST)
        die(path);
    snprintf(path, sizeof path, "%s/samples/%s", g_dir, name);
    sim_samples_writer_t w;
    if (sim_samples_open(&w, path, 0.0, 0.0, 12.0, 9.0, 7, "scan plan=apartment.svg fuzz seed") != 0)
        die(path);
    for (size_t i = 0; i < count; i++) {
        const float t = (float)i / (float)(count > 1 ? count - 1 : 1);
        const ai_sample_t s = {2.0f * t - 1.0f, 1.0f - 2.0f * t, (float)(i & 1u)};
        if (sim_samples_append(&w, &s, 1) != 0) {
            sim_samples_abort(&w);
            die(path);
        }
    }
    if (sim_samples_close(&w) != 0)
        die(path);
}

int main(int argc, char **argv)
{
    if (argc != 2) {
        fprintf(stderr, "usage: gen_seeds DIR\n");
        return 2;
    }
    g_dir = argv[1];
    if (mkdir(g_dir, 0777) != 0 && errno != EEXIST)
        die(g_dir);
    wire_seeds();
    ckpt_seeds();
    samples_seed("eight.samples", 8);
    samples_seed("empty.samples", 0);
    return 0;
}
