/* BNN trainer benchmark (not a test): prints `BENCH <name> <value> <unit>` lines.
 *
 *   bnn_train_step_ms_<preset>_b<B>      full step at the preset's max batch, single thread:
 *                                         sampling, forward, BCE+KL, backward, Adam on both groups
 *   bnn_train_gflops_<preset>_b<B>       GEMM FLOPs of that step / its time
 *   bnn_train_step_ms_ref_<preset>_b<B>  the same step with the pure-C reference GEMM
 *   bnn_train_step_ms_<preset>_b<B>_bf16 the step with its large GEMMs as bf16 products with
 *                                         fp32 sums (bnn_config_t.precision,
 *                                         ai/kernels/la_bf16.h), timed
 *                                         alternating with the fp32 step in the same loop
 *                                         (bnn_train_step_ms_<preset>_b<B>_fp32_alt, and _best_
 *                                         of both); its speed-up (of the medians)
 *                                         bnn_train_step_bf16_speedup_<preset>, its GEMM share
 *                                         bnn_step_share_gemm_<preset>_bf16, the kernel bf16_kernel
 *   bf16gemm_gflops_256x256x1024         la_bf16_gemm alone at the step's shape (and _ref_: the
 *                                         pure-C reference); --shapes: every step shape on it
 *   sgemm_gflops_256x256x1024            single-thread la_sgemm rate (the packed kernel the CPU
 *                                         runs, see gemm_kernel), [1024x256] x [256x256]^T
 *   sgemm_ref_gflops_256x256x1024        the same product with la_ref_sgemm
 *   bnn_mc50_points_per_s_<preset>       MC inference with K = 50
 *   bnn_arena_bytes_<preset>             static storage of one model
 *   bnn_phase_ms_<phase>_<preset>        where the step's time goes (best-of times; the
 *                                         backward and sampling figures are differences)
 *   bnn_step_share_<part>_<preset>       the step's time split: gemm (timed around every
 *                                         la_sgemm call inside the steps), sampling (Gaussians,
 *                                         softplus, w = mu + sigma eps), adam (both groups),
 *                                         other (the element-wise passes of forward and
 *                                         backward, loss, KL and reparameterisation gradients),
 *                                         non_gemm (all but gemm); of the median step
 *   gemm_kernel <name>                   the kernel the large products take (la_kernel_name)
 *   fma_peak_gflops_<isa>                the core's FMA peak for that kernel's instruction set
 *                                         (tools/bench/fma_probe.c)
 *   bnn_train_fma_limit_ms_<preset>_b<B>  the step's GEMM FLOPs at that peak: the bound no
 *                                         step can beat
 *   bnn_train_step_of_fma_peak_<preset>_b<B>  that bound / the step's median time
 *   sgemm_gflops_<op>_<M>x<N>x<K>        every GEMM shape the step calls la_sgemm with (recorded
 *                                         in the step itself), timed alone, bare (beta 0, no
 *                                         epilogue), alternating with the steps below; op: fwd =
 *                                         X W^T (N,T), dx = dY W (N,N), dw = dY^T X (T,N)
 *   sgemm_openblas_gflops_<op>_<M>x<N>x<K>  the same shape on OpenBLAS (cblas_sgemm, 1 thread),
 *                                         in the same loop; openblas_core <name> says which of
 *                                         its kernels ran (OPENBLAS_CORETYPE changes it);
 *                                         sgemm_ours_over_openblas_<op>_<shape> the ratio
 *   bnn_train_gemm_limit_ms_<preset>     the GEMM-bound limit: the step's la_sgemm calls at
 *                                         the rates measured for their shapes (sum of the
 *                                         calls' median bare times)
 *   bnn_train_step_of_limit_<preset>     that limit / the median step of the same loop;
 *                                         _best_: the fastest bare calls over the fastest step
 *   bnn_step_share_gemm_over_bare_<preset>  the GEMM calls' time inside the step beyond their
 *                                         bare time: fused epilogues, colder caches;
 *                                         sgemm_in_step_over_bare_<op>_<shape> the same per shape
 *                                         (mean in-step time over calls x median bare time)
 *   bnn_mc50_of_limit_<preset>           MC-50's points/s / the points/s of its GEMMs at peak
 *   bnn_mean_points_per_s_<preset>       one forward pass with the mean weights, fp32
 *   bnn_int8_points_per_s_<preset>       the same with the int8 state (bnn_quant_forward_mean), on
 *                                         the int8 kernel the CPU takes (int8_kernel <name>);
 *                                         bnn_int8_ref_points_per_s_<preset> on the pure-C one
 *   q8_over_fp32_<preset>                bnn_int8 / bnn_mean points/s, the two passes
 *                                         alternating in the same run
 *   sgemm_shape_gflops_<kernel>_<op>_<M>x<N>x<K>  (--shapes) each GEMM shape of the step alone,
 *                                         on every kernel this CPU runs and on Eigen alone:
 *                                         fwd = X W^T (N,T), dx = dY W (N,N), dw = dY^T X (T,N);
 *                                         median and best
 * Times are medians of repeated runs (CLOCK_MONOTONIC). Run it under `taskset -c 1`. */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "ai/ai_rng.h"
#include "ai/bnn.h"
#include "ai/bnn_post.h"
#include "ai/bnn_quant.h"
#include "ai/kernels/la.h"
#include "ai/kernels/la_bf16.h"
#include "sim_kernels.h"
#include "ai/kernels/la_packed.h"
#include "ai/kernels/q8_gemm.h"
#include "fma_probe.h"

static bnn_model_t model;
static ai_sample_t batch[BNN_MAX_BATCH];
static float xy[2 * 4096], mean[4096], sd[4096], logits[BNN_MAX_BATCH];
static float ga[1024 * 256], gb[256 * 256], gc[1024 * 256];
static float eps_buf[BNN_N_RHO];
static uint8_t qstate[BNN_QUANT_MAX_BYTES];

static double now_s(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static int cmp_d(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

#define MAX_REPS 512
static double samples_[MAX_REPS];

static double median(int n)
{
    qsort(samples_, (size_t)n, sizeof(double), cmp_d);
    return samples_[n / 2];
}

static void die(const char *what, int rc)
{
    fprintf(stderr, "bench_bnn: %s failed (%d)\n", what, rc);
    exit(1);
}

static void usage(FILE *f)
{
    fprintf(f, "usage: bench_bnn [--reps N] [--steps-only] [--shapes] [--infer-only]\n"
               "  Times the BNN training step, GEMM rate, MC inference of the compiled preset\n"
               "  and prints `BENCH <name> <value> <unit>` lines. --reps: timed repetitions\n"
               "  (default 30 for paper, 100 otherwise; 3..%d). --steps-only: only the Eigen\n"
               "  training step (for profiling). --shapes: only the step's GEMM shapes, each\n"
               "  alone (la_sgemm on the board's back end). --infer-only: only the mean-weight\n"
               "  pass, fp32 against int8 (N alternating repetitions).\n",
            MAX_REPS);
}

/* The step's three big GEMM shapes (layer 2 of the preset: in = out = H), each alone, on the
 * kernel la_sgemm takes now; tag names it in the BENCH lines. */
static void bench_shapes_on(int reps, const char *tag, int bf16)
{
    const int n = (int)BNN_MAX_BATCH, H = (int)BNN_HIDDEN_MAX, I = (int)BNN_HIDDEN_MAX;
    static float out[1024 * 256];
    const double gf = 2.0 * n * H * I;
    for (int op = 0; op < 3; op++) {
        for (int r = -3; r < reps; r++) {
            double t0 = now_s();
            switch (op) {
            case 0: /* forward: Y[n x H] = X[n x I] W[H x I]^T */
                if (bf16)
                    la_bf16_gemm(LA_NO_TRANS, LA_TRANS, n, H, I, ga, I, gb, I, out, H, NULL);
                else
                    la_sgemm(LA_NO_TRANS, LA_TRANS, n, H, I, 1.0f, ga, I, gb, I, 0.0f, out, H);
                break;
            case 1: /* dX[n x I] = dY[n x H] W[H x I] */
                if (bf16)
                    la_bf16_gemm(LA_NO_TRANS, LA_NO_TRANS, n, I, H, gc, H, gb, I, out, I, NULL);
                else
                    la_sgemm(LA_NO_TRANS, LA_NO_TRANS, n, I, H, 1.0f, gc, H, gb, I, 0.0f, out, I);
                break;
            default: /* dW[H x I] = dY[n x H]^T X[n x I] */
                if (bf16)
                    la_bf16_gemm(LA_TRANS, LA_NO_TRANS, H, I, n, gc, H, ga, I, out, I, NULL);
                else
                    la_sgemm(LA_TRANS, LA_NO_TRANS, H, I, n, 1.0f, gc, H, ga, I, 0.0f, out, I);
                break;
            }
            if (r >= 0)
                samples_[r] = now_s() - t0;
        }
        const char *nm = op == 0 ? "fwd" : op == 1 ? "dx" : "dw";
        const int M = op == 2 ? H : n, N = op == 0 ? H : I, K = op == 0 ? I : op == 1 ? H : n;
        printf("BENCH sgemm_shape_gflops_%s_%s_%dx%dx%d %.2f GFLOP/s\n", tag, nm, M, N, K,
               gf / median(reps) * 1e-9);
        printf("BENCH sgemm_shape_gflops_best_%s_%s_%dx%dx%d %.2f GFLOP/s\n", tag, nm, M, N, K,
               gf / samples_[0] * 1e-9);
    }
}

static int bench_shapes(int reps)
{
    const int n = (int)BNN_MAX_BATCH, H = (int)BNN_HIDDEN_MAX, I = (int)BNN_HIDDEN_MAX;
    if ((size_t)n * (size_t)I > sizeof ga / sizeof ga[0] || (size_t)H * (size_t)I > sizeof gb / sizeof gb[0]) {
        fprintf(stderr, "bench_bnn: --shapes buffers too small for this preset\n");
        return 1;
    }
    ai_rng_uniform_fill(1, 1, 0, ga, (size_t)n * (size_t)I);
    ai_rng_uniform_fill(1, 2, 0, gb, (size_t)H * (size_t)I);
    ai_rng_uniform_fill(1, 3, 0, gc, (size_t)n * (size_t)H);
    for (int id = 0; id < LA_PACKED_N; id++) {
        if (!la_packed_cpu_has(id)) {
            printf("# %s: %s\n", la_packed_kernels[id].name,
                   la_packed_kernels[id].fn ? "this CPU lacks the instruction set"
                                            : "not compiled for this target");
            continue;
        }
        (void)la_packed_force(id);
        bench_shapes_on(reps, la_packed_kernels[id].name, 0);
    }
    if (la_bf16_cpu_has(LA_BF16_AVX512))
        bench_shapes_on(reps, la_bf16_kernel_name(), 1);
#if defined(LA_BACKEND_EIGEN)
    (void)la_packed_force(-1);
    bench_shapes_on(reps, la_eigen_kernel_name(), 0);
#endif
    (void)la_packed_force(-2);
    return 0;
}

/* Every la_sgemm and la_sgemm_ep call of the program passes through here (linked with
 * --wrap), so the GEMM time inside a training step is measured in the step itself. A fused
 * epilogue (bias, ReLU, gate, column sums on the tiles) counts as GEMM time: it is what the
 * products cost now. */
void __real_la_sgemm_ep(la_trans_t ta, la_trans_t tb, int M, int N, int K, float alpha,
                        const float *A, int lda, const float *B, int ldb, float beta, float *C,
                        int ldc, const la_epilogue_t *ep);
void __wrap_la_sgemm_ep(la_trans_t ta, la_trans_t tb, int M, int N, int K, float alpha,
                        const float *A, int lda, const float *B, int ldb, float beta, float *C,
                        int ldc, const la_epilogue_t *ep);
void __real_la_sgemm(la_trans_t ta, la_trans_t tb, int M, int N, int K, float alpha,
                     const float *A, int lda, const float *B, int ldb, float beta, float *C,
                     int ldc);
void __wrap_la_sgemm(la_trans_t ta, la_trans_t tb, int M, int N, int K, float alpha,
                     const float *A, int lda, const float *B, int ldb, float beta, float *C,
                     int ldc);
void __real_la_bf16_gemm(la_trans_t ta, la_trans_t tb, int M, int N, int K, const float *A,
                         int lda, const float *B, int ldb, float *C, int ldc,
                         const la_epilogue_t *ep);
void __wrap_la_bf16_gemm(la_trans_t ta, la_trans_t tb, int M, int N, int K, const float *A,
                         int lda, const float *B, int ldb, float *C, int ldc,
                         const la_epilogue_t *ep);
static double gemm_seconds; /* accumulated by the wrapper */

/* The GEMM shapes of one step, recorded by the wrapper while `recording` is set: what the
 * GEMM-bound limit sums, and what OpenBLAS is compared on. */
typedef struct gemm_shape {
    la_trans_t ta, tb;
    int M, N, K, calls;
} gemm_shape_t;
#define MAX_SHAPES 16
static gemm_shape_t shapes[MAX_SHAPES];
static int n_shapes, recording;
/* while `per_shape` is set, the wrapper also adds each call's time to its shape's entry */
static double shape_in_step[MAX_SHAPES];
static int per_shape;

static void add_shape_time(la_trans_t ta, la_trans_t tb, int M, int N, int K, double t)
{
    for (int i = 0; i < n_shapes; i++)
        if (shapes[i].ta == ta && shapes[i].tb == tb && shapes[i].M == M && shapes[i].N == N &&
            shapes[i].K == K) {
            shape_in_step[i] += t;
            return;
        }
}

static void note_shape(la_trans_t ta, la_trans_t tb, int M, int N, int K)
{
    for (int i = 0; i < n_shapes; i++)
        if (shapes[i].ta == ta && shapes[i].tb == tb && shapes[i].M == M && shapes[i].N == N &&
            shapes[i].K == K) {
            shapes[i].calls++;
            return;
        }
    if (n_shapes < MAX_SHAPES)
        shapes[n_shapes++] = (gemm_shape_t){ta, tb, M, N, K, 1};
}

void __wrap_la_bf16_gemm(la_trans_t ta, la_trans_t tb, int M, int N, int K, const float *A,
                         int lda, const float *B, int ldb, float *C, int ldc,
                         const la_epilogue_t *ep)
{
    const double t0 = now_s();
    __real_la_bf16_gemm(ta, tb, M, N, K, A, lda, B, ldb, C, ldc, ep);
    gemm_seconds += now_s() - t0;
}

void __wrap_la_sgemm(la_trans_t ta, la_trans_t tb, int M, int N, int K, float alpha,
                     const float *A, int lda, const float *B, int ldb, float beta, float *C,
                     int ldc)
{
    if (recording)
        note_shape(ta, tb, M, N, K);
    const double t0 = now_s();
    __real_la_sgemm(ta, tb, M, N, K, alpha, A, lda, B, ldb, beta, C, ldc);
    const double t = now_s() - t0;
    gemm_seconds += t;
    if (per_shape)
        add_shape_time(ta, tb, M, N, K, t);
}

void __wrap_la_sgemm_ep(la_trans_t ta, la_trans_t tb, int M, int N, int K, float alpha,
                        const float *A, int lda, const float *B, int ldb, float beta, float *C,
                        int ldc, const la_epilogue_t *ep)
{
    if (recording)
        note_shape(ta, tb, M, N, K);
    const double t0 = now_s();
    __real_la_sgemm_ep(ta, tb, M, N, K, alpha, A, lda, B, ldb, beta, C, ldc, ep);
    const double t = now_s() - t0;
    gemm_seconds += t;
    if (per_shape)
        add_shape_time(ta, tb, M, N, K, t);
}

/* The one-pass epistemic map (ai/bnn_post.h) against the MC-50 mean and std it stands beside:
 * the same 4096 points, the posterior of 100,000 observed points (factored once, outside the
 * timing, and timed on its own: once per map). */
static bnn_post_t post;
static void bench_post(const char *P, int nrep)
{
    const size_t n = 4096, n_obs = 100000;
    int rc;
    if ((rc = bnn_post_init(&post, &model)))
        die("bnn_post_init", rc);
    ai_rng_uniform_fill(5, 5, 0, xy, 2 * n);
    for (size_t i = 0; i < 2 * n; i++)
        xy[i] = 0.5f * xy[i] - 0.25f; /* the observed region: a quarter of the square */
    double t_obs = now_s();
    for (size_t k = 0; k < n_obs; k += n)
        if ((rc = bnn_post_observe(&post, &model, xy, n_obs - k < n ? n_obs - k : n)))
            die("bnn_post_observe", rc);
    t_obs = now_s() - t_obs;
    double t_fac = now_s();
    if ((rc = bnn_post_factor(&post)))
        die("bnn_post_factor", rc);
    t_fac = now_s() - t_fac;
    ai_rng_uniform_fill(2, 2, 0, xy, 2 * n);
    for (size_t i = 0; i < 2 * n; i++)
        xy[i] = 2 * xy[i] - 1;
    for (int r = 0; r < nrep && r < MAX_REPS; r++) {
        const double t0 = now_s();
        if ((rc = bnn_post_predict(&post, &model, xy, n, mean, sd)))
            die("bnn_post_predict", rc);
        samples_[r] = now_s() - t0;
    }
    const double pps = (double)n / median(nrep);
    printf("BENCH bnn_post_points_per_s_%s %.0f points/s\n", P, pps);
    printf("BENCH bnn_post_observe_points_per_s_%s %.0f points/s\n", P, (double)n_obs / t_obs);
    printf("BENCH bnn_post_factor_ms_%s %.2f ms\n", P, 1e3 * t_fac);
    printf("BENCH bnn_post_bytes_%s %zu bytes\n", P, sizeof(bnn_post_t));
}

/* One mean-weight pass over the preset's batch of points, fp32 (bnn_forward_logits) and int8
 * (bnn_quant_forward_mean on the kernel the CPU takes, then on the pure-C reference). The fp32
 * and int8 passes alternate within every repetition, so that both see the same machine (it is
 * shared: the rate of either moves by 5-10 % between runs) and their ratio is of one run. */
static void bench_mean_pass(const char *P, int nrep)
{
    const size_t n = BNN_MAX_BATCH;
    size_t len = 0;
    int rc;
    ai_rng_uniform_fill(2, 2, 0, xy, 2 * n);
    for (size_t i = 0; i < 2 * n; i++)
        xy[i] = 2 * xy[i] - 1;
    if ((rc = bnn_quant_pack(&model, BNN_GROUP_ALL, qstate, sizeof qstate, &len)))
        die("bnn_quant_pack", rc);
    printf("BENCH int8_kernel %s -\n", q8_kernel_name());
    static double t_fp[MAX_REPS], t_q8[MAX_REPS];
    if (nrep > MAX_REPS)
        nrep = MAX_REPS;
    for (int r = -1; r < nrep; r++) {
        for (int q = 0; q < 2; q++) {
            const double t0 = now_s();
            rc = q ? bnn_quant_forward_mean(&model.cfg, BNN_GROUP_ALL, qstate, len, xy, n, mean)
                   : bnn_forward_logits(&model, xy, n, 1, 0, mean);
            const double t = now_s() - t0;
            if (rc)
                die(q ? "bnn_quant_forward_mean" : "bnn_forward_logits", rc);
            if (r >= 0)
                (q ? t_q8 : t_fp)[r] = t;
        }
    }
    memcpy(samples_, t_fp, (size_t)nrep * sizeof(double));
    const double fp = (double)n / median(nrep);
    memcpy(samples_, t_q8, (size_t)nrep * sizeof(double));
    const double q8 = (double)n / median(nrep);
    printf("BENCH bnn_mean_points_per_s_%s %.0f points/s\n", P, fp);
    printf("BENCH bnn_int8_points_per_s_%s %.0f points/s\n", P, q8);
    printf("BENCH q8_over_fp32_%s %.2f x\n", P, q8 / fp);
    if (q8_active() != &q8_kernels[Q8_REF] && q8_force(Q8_REF) == 0) {
        const int nr = nrep / 3 > 3 ? nrep / 3 : 3;
        for (int r = -1; r < nr; r++) {
            const double t0 = now_s();
            rc = bnn_quant_forward_mean(&model.cfg, BNN_GROUP_ALL, qstate, len, xy, n, mean);
            if (r >= 0)
                samples_[r] = now_s() - t0;
            if (rc)
                die("bnn_quant_forward_mean", rc);
        }
        printf("BENCH bnn_int8_ref_points_per_s_%s %.0f points/s\n", P, (double)n / median(nr));
    }
    (void)q8_force(Q8_AUTO);
}

/* OpenBLAS (Debian's libopenblas-dev), the same shapes in the same run. Declared here rather
 * than through cblas.h: Debian's cblas.h is whichever BLAS its alternatives point at, and the
 * openblas_* calls are OpenBLAS's own. Only this benchmark links it, never the firmware. */
enum { CBLAS_ROW_MAJOR = 101, CBLAS_NO_TRANS = 111, CBLAS_TRANS = 112 };
void cblas_sgemm(int order, int ta, int tb, int M, int N, int K, float alpha, const float *A,
                 int lda, const float *B, int ldb, float beta, float *C, int ldc);
void openblas_set_num_threads(int n);
char *openblas_get_corename(void);

static const char *shape_op(const gemm_shape_t *g)
{
    return g->ta == LA_NO_TRANS ? (g->tb == LA_TRANS ? "fwd" : "dx")
                                : (g->tb == LA_NO_TRANS ? "dw" : "tt");
}

#define LIM_BUF ((size_t)BNN_MAX_BATCH * (BNN_SIREN_MAX > BNN_HIDDEN_MAX ? BNN_SIREN_MAX : BNN_HIDDEN_MAX))
static float lim_a[LIM_BUF], lim_b[LIM_BUF], lim_c[LIM_BUF];
static double lim_t[2][MAX_SHAPES][MAX_REPS], lim_step[MAX_REPS];

static double median_of(double *v, int n)
{
    memcpy(samples_, v, (size_t)n * sizeof(double));
    return median(n);
}

/* The step against its GEMM-bound limit: one step, then every GEMM shape of the step alone on
 * our la_sgemm, then on OpenBLAS, in turn, reps times, so that all three see the same state of
 * a shared machine. The limit is the step's calls at the median bare time of their shapes. */
static void bench_limit(int reps, double gemm_in_step_share)
{
    const char *P = BNN_PRESET_NAME;
    const unsigned B = BNN_MAX_BATCH;
    n_shapes = 0;
    recording = 1;
    int rc = bnn_train_step(&model, batch, B, 1e-4f, 99, 1e-4f, NULL);
    recording = 0;
    if (rc)
        die("bnn_train_step", rc);
    for (int s = 0; s < n_shapes; s++) {
        const gemm_shape_t *g = &shapes[s];
        if ((size_t)g->M * g->K > LIM_BUF || (size_t)g->K * g->N > LIM_BUF ||
            (size_t)g->M * g->N > LIM_BUF) {
            fprintf(stderr, "bench_bnn: GEMM shape %dx%dx%d exceeds the buffers\n", g->M, g->N, g->K);
            exit(1);
        }
    }
    ai_rng_uniform_fill(3, 1, 0, lim_a, LIM_BUF);
    ai_rng_uniform_fill(3, 2, 0, lim_b, LIM_BUF);
    openblas_set_num_threads(1);
    printf("BENCH openblas_core %s -\n", openblas_get_corename());
    memset(shape_in_step, 0, sizeof shape_in_step);
    for (int r = -2; r < reps; r++) {
        per_shape = r >= 0;
        double t0 = now_s();
        rc = bnn_train_step(&model, batch, B, 1e-4f, 200 + (uint64_t)(r + 2), 1e-4f, NULL);
        const double ts = now_s() - t0;
        per_shape = 0;
        if (rc)
            die("bnn_train_step", rc);
        if (r >= 0)
            lim_step[r] = ts;
        /* each shape once untimed first (the step left other data in the caches), then ours
         * and OpenBLAS, which of them first alternating from one repetition to the next */
        for (int s = 0; s < n_shapes; s++)
            for (int q = -1; q < 2; q++) {
                const gemm_shape_t *g = &shapes[s];
                const int lib = q < 0 ? 0 : (q + r) & 1;
                const int lda = g->ta == LA_NO_TRANS ? g->K : g->M;
                const int ldb = g->tb == LA_NO_TRANS ? g->N : g->K;
                t0 = now_s();
                if (lib == 0)
                    la_sgemm(g->ta, g->tb, g->M, g->N, g->K, 1.0f, lim_a, lda, lim_b, ldb, 0.0f,
                             lim_c, g->N);
                else
                    cblas_sgemm(CBLAS_ROW_MAJOR, g->ta == LA_NO_TRANS ? CBLAS_NO_TRANS : CBLAS_TRANS,
                                g->tb == LA_NO_TRANS ? CBLAS_NO_TRANS : CBLAS_TRANS, g->M, g->N,
                                g->K, 1.0f, lim_a, lda, lim_b, ldb, 0.0f, lim_c, g->N);
                if (r >= 0 && q >= 0)
                    lim_t[lib][s][r] = now_s() - t0;
            }
    }
    double limit = 0.0, limit_best = 0.0;
    for (int s = 0; s < n_shapes; s++) {
        const gemm_shape_t *g = &shapes[s];
        const double gf = 2.0 * g->M * g->N * g->K * 1e-9;
        double med[2], best[2];
        for (int lib = 0; lib < 2; lib++) {
            med[lib] = median_of(lim_t[lib][s], reps);
            best[lib] = samples_[0];
        }
        limit += g->calls * med[0];
        limit_best += g->calls * best[0];
        for (int lib = 0; lib < 2; lib++) {
            const char *who = lib ? "_openblas" : "";
            printf("BENCH sgemm%s_gflops_%s_%dx%dx%d %.2f GFLOP/s\n", who, shape_op(g), g->M,
                   g->N, g->K, gf / med[lib]);
            printf("BENCH sgemm%s_gflops_best_%s_%dx%dx%d %.2f GFLOP/s\n", who, shape_op(g), g->M,
                   g->N, g->K, gf / best[lib]);
        }
        printf("BENCH sgemm_calls_per_step_%s_%dx%dx%d %d calls\n", shape_op(g), g->M, g->N,
               g->K, g->calls);
        printf("BENCH sgemm_ours_over_openblas_%s_%dx%dx%d %.3f x\n", shape_op(g), g->M, g->N,
               g->K, med[1] / med[0]);
        printf("BENCH sgemm_in_step_over_bare_%s_%dx%dx%d %.1f %%\n", shape_op(g), g->M, g->N,
               g->K, 100.0 * (shape_in_step[s] / reps / (g->calls * med[0]) - 1.0));
    }
    const double step = median_of(lim_step, reps);
    printf("BENCH bnn_train_step_ms_of_limit_loop_%s %.3f ms\n", P, 1e3 * step);
    printf("BENCH bnn_train_gemm_limit_ms_%s %.3f ms\n", P, 1e3 * limit);
    printf("BENCH bnn_train_step_of_limit_%s %.1f %%\n", P, 100.0 * limit / step);
    /* the same from the fastest repetitions: what a busy shared machine disturbs least */
    printf("BENCH bnn_train_step_of_limit_best_%s %.1f %%\n", P, 100.0 * limit_best / samples_[0]);
    printf("BENCH bnn_step_share_gemm_over_bare_%s %.1f %%\n", P,
           100.0 * (gemm_in_step_share - limit / step));
}

int main(int argc, char **argv)
{
    int reps = BNN_MAX_BATCH >= 1024 && BNN_HIDDEN_MAX >= 256 ? 30 : 100;
    int steps_only = 0, shapes_only = 0, infer_only = 0;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--help") || !strcmp(argv[i], "-h")) {
            usage(stdout);
            return 0;
        } else if (!strcmp(argv[i], "--steps-only")) {
            steps_only = 1;
        } else if (!strcmp(argv[i], "--infer-only")) {
            infer_only = 1;
        } else if (!strcmp(argv[i], "--shapes")) {
            shapes_only = 1;
        } else if (!strcmp(argv[i], "--reps") && i + 1 < argc) {
            char *end;
            long v = strtol(argv[++i], &end, 10);
            if (*end || v < 3 || v > MAX_REPS) {
                fprintf(stderr, "bench_bnn: --reps must be an integer in 3..%d\n", MAX_REPS);
                return 2;
            }
            reps = (int)v;
        } else {
            usage(stderr);
            return 2;
        }
    }
    printf("BENCH gemm_kernel %s -\n", la_kernel_name());
    const la_packed_kernel_t *kern = la_packed_active();
    const double peak = kern && strcmp(la_backend_name(), "eigen") == 0 ? fma_probe_gflops(kern->isa) : 0.0;
    if (peak > 0.0)
        printf("BENCH fma_peak_gflops_%s %.1f GFLOP/s\n", kern->isa, peak);
    if (shapes_only)
        return bench_shapes(reps);
    const char *P = BNN_PRESET_NAME;
    const unsigned B = BNN_MAX_BATCH;
    /* fp32 unless a figure says bf16, whatever the build's PRECISION */
    bnn_config_t cfg = bnn_default_config();
    cfg.precision = BNN_PRECISION_FP32;
    int rc = bnn_init(&model, &cfg, 1);
    if (rc)
        die("bnn_init", rc);
    float u[3 * BNN_MAX_BATCH];
    ai_rng_uniform_fill(9, 9, 0, u, 3 * B);
    for (unsigned i = 0; i < B; i++)
        batch[i] = (ai_sample_t){2 * u[3 * i] - 1, 2 * u[3 * i + 1] - 1, u[3 * i + 2] > 0.8f};
    if (infer_only) { /* a few steps first, so that the weights are not the initial ones */
        for (int w = 0; w < 3; w++)
            if ((rc = bnn_train_step(&model, batch, B, 1e-4f, (uint64_t)w, 1e-4f, NULL)))
                die("bnn_train_step", rc);
        bench_post(P, 5);
        bench_mean_pass(P, reps);
        return 0;
    }

    /* GEMM FLOPs of one step: per Bayesian layer forward, dW and dX (3 GEMMs of 2*B*in*H),
     * plus the output layer's forward and dW (2 x 2*B*H). */
    const bnn_config_t c = model.cfg;
    double flops = 0.0;
    for (unsigned l = 0; l < c.n_bayes; l++) {
        double in = l == 0 ? c.siren_width : c.hidden_width;
        flops += 3.0 * 2.0 * B * in * c.hidden_width;
    }
    flops += 2.0 * 2.0 * B * c.hidden_width;

    double step_med = 0.0, gemm_share = 0.0;
    for (int backend = 0; backend < (steps_only ? 1 : 2); backend++) {
        la_force_ref(backend == 1);
        int n = backend == 1 ? (reps / 5 > 3 ? reps / 5 : 3) : reps;
        for (int w = 0; w < 3; w++)
            if ((rc = bnn_train_step(&model, batch, B, 1e-4f, (uint64_t)w, 1e-4f, NULL)))
                die("bnn_train_step", rc);
        double gemm_in_steps = 0.0, all_steps = 0.0;
        for (int r = 0; r < n; r++) {
            gemm_seconds = 0.0;
            double t0 = now_s();
            rc = bnn_train_step(&model, batch, B, 1e-4f, 100 + (uint64_t)r, 1e-4f, NULL);
            samples_[r] = now_s() - t0;
            all_steps += samples_[r];
            gemm_in_steps += gemm_seconds;
            if (rc)
                die("bnn_train_step", rc);
        }
        double t = median(n);
        if (backend == 0)
            gemm_share = gemm_in_steps / all_steps;
        if (backend == 0) {
            printf("BENCH bnn_train_step_ms_%s_b%u %.3f ms\n", P, B, 1e3 * t);
            printf("BENCH bnn_train_step_ms_best_%s_b%u %.3f ms\n", P, B, 1e3 * samples_[0]);
            printf("BENCH bnn_train_gflops_%s_b%u %.2f GFLOP/s\n", P, B, flops / t * 1e-9);
            step_med = t;
            if (peak > 0.0) {
                const double lim = flops / (peak * 1e9);
                printf("BENCH bnn_train_fma_limit_ms_%s_b%u %.3f ms\n", P, B, 1e3 * lim);
                printf("BENCH bnn_train_step_of_fma_peak_%s_b%u %.1f %%\n", P, B, 100.0 * lim / t);
            }
        } else {
            printf("BENCH bnn_train_step_ms_ref_%s_b%u %.3f ms\n", P, B, 1e3 * t);
        }
    }
    la_force_ref(0);
    if (steps_only)
        return 0;
    bench_limit(reps, gemm_share);

    /* the bf16 step beside the fp32 one: alternating in one loop, so that both see the same
     * machine (it is shared) */
    {
        static double t32[MAX_REPS], t16[MAX_REPS];
        double g16 = 0.0, all16 = 0.0;
        printf("BENCH bf16_kernel %s -\n", la_bf16_kernel_name());
        (void)sim_kernels_bf16_note(stderr, "bench_bnn"); /* the bf16 figures: on the reference? */
        for (int r = -3; r < reps; r++)
            for (int p = 0; p < 2; p++) {
                model.cfg.precision = p ? BNN_PRECISION_BF16 : BNN_PRECISION_FP32;
                gemm_seconds = 0.0;
                const double t0 = now_s();
                rc = bnn_train_step(&model, batch, B, 1e-4f, 200 + (uint64_t)r, 1e-4f, NULL);
                const double dt = now_s() - t0;
                if (rc)
                    die("bnn_train_step", rc);
                if (r < 0)
                    continue;
                (p ? t16 : t32)[r] = dt;
                if (p) {
                    g16 += gemm_seconds;
                    all16 += dt;
                }
            }
        model.cfg.precision = BNN_PRECISION_FP32;
        memcpy(samples_, t32, sizeof(double) * (size_t)reps);
        const double m32 = median(reps), b32 = samples_[0];
        memcpy(samples_, t16, sizeof(double) * (size_t)reps);
        const double m16 = median(reps);
        printf("BENCH bnn_train_step_ms_%s_b%u_bf16 %.3f ms\n", P, B, 1e3 * m16);
        printf("BENCH bnn_train_step_ms_best_%s_b%u_bf16 %.3f ms\n", P, B, 1e3 * samples_[0]);
        printf("BENCH bnn_train_step_ms_%s_b%u_fp32_alt %.3f ms\n", P, B, 1e3 * m32);
        printf("BENCH bnn_train_step_ms_best_%s_b%u_fp32_alt %.3f ms\n", P, B, 1e3 * b32);
        printf("BENCH bnn_train_step_bf16_speedup_%s %.2f x\n", P, m32 / m16);
        printf("BENCH bnn_step_share_gemm_%s_bf16 %.1f %%\n", P, 100.0 * g16 / all16);
    }

    /* where the step's time goes (Eigen back end) */
    {
        const size_t R = bnn_group_len(&model, BNN_GROUP_RHO);
        double ph[5];
        for (int phase = 0; phase < 5; phase++) {
            for (int r = 0; r < reps; r++) {
                double t0 = now_s();
                switch (phase) {
                case 0: ai_rng_normal_fill(1, (uint64_t)r, 0, eps_buf, R); break;
                case 1:
                    for (unsigned i = 0; i < B; i++) {
                        xy[2 * i] = batch[i].x;
                        xy[2 * i + 1] = batch[i].y;
                    }
                    rc = bnn_forward_logits(&model, xy, B, 1, 0, logits);
                    break;
                case 2: rc = bnn_forward_logits(&model, xy, B, 0, (uint64_t)r, logits); break;
                case 3: rc = bnn_loss_grad(&model, batch, B, 1e-4f, (uint64_t)r, NULL); break;
                case 4:
                    rc = bnn_adam_step(&model, BNN_GROUP_MU, 1e-5f);
                    if (!rc)
                        rc = bnn_adam_step(&model, BNN_GROUP_RHO, 1e-5f);
                    break;
                }
                samples_[r] = now_s() - t0;
                if (rc)
                    die("phase", rc);
            }
            (void)median(reps); /* sorts */
            ph[phase] = samples_[0]; /* best-of: the subtraction below needs low-noise figures */
        }
        printf("BENCH bnn_phase_ms_gaussians_%s %.3f ms\n", P, 1e3 * ph[0]);
        printf("BENCH bnn_phase_ms_forward_mean_%s %.3f ms\n", P, 1e3 * ph[1]);
        printf("BENCH bnn_phase_ms_sample_weights_%s %.3f ms\n", P, 1e3 * (ph[2] - ph[1]));
        printf("BENCH bnn_phase_ms_loss_grad_%s %.3f ms\n", P, 1e3 * ph[3]);
        printf("BENCH bnn_phase_ms_backward_kl_%s %.3f ms\n", P, 1e3 * (ph[3] - ph[2]));
        printf("BENCH bnn_phase_ms_adam_both_%s %.3f ms\n", P, 1e3 * ph[4]);
        {
            /* gemm: its share of all timed steps; sampling, adam: best-of phase times over the
             * median step; other: the rest */
            const double sh_g = gemm_share, sh_s = (ph[2] - ph[1]) / step_med;
            const double sh_a = ph[4] / step_med;
            printf("BENCH bnn_step_share_gemm_%s %.1f %%\n", P, 100.0 * sh_g);
            printf("BENCH bnn_step_share_sampling_%s %.1f %%\n", P, 100.0 * sh_s);
            printf("BENCH bnn_step_share_adam_%s %.1f %%\n", P, 100.0 * sh_a);
            printf("BENCH bnn_step_share_other_%s %.1f %%\n", P,
                   100.0 * (1.0 - sh_g - sh_s - sh_a));
            printf("BENCH bnn_step_share_non_gemm_%s %.1f %%\n", P, 100.0 * (1.0 - sh_g));
        }
    }

    /* raw GEMM rate at the step's shape */
    {
        ai_rng_uniform_fill(1, 1, 0, ga, 1024 * 256);
        ai_rng_uniform_fill(1, 2, 0, gb, 256 * 256);
        const double gf = 2.0 * 1024 * 256 * 256;
        for (int backend = 0; backend < 2; backend++) {
            int n = backend ? 10 : 50;
            for (int r = 0; r < n; r++) {
                double t0 = now_s();
                if (backend == 0)
                    la_sgemm(LA_NO_TRANS, LA_TRANS, 1024, 256, 256, 1.0f, ga, 256, gb, 256, 0.0f,
                             gc, 256);
                else
                    la_ref_sgemm(LA_NO_TRANS, LA_TRANS, 1024, 256, 256, 1.0f, ga, 256, gb, 256,
                                 0.0f, gc, 256);
                samples_[r] = now_s() - t0;
            }
            printf("BENCH %s_256x256x1024 %.2f GFLOP/s\n",
                   backend ? "sgemm_ref_gflops" : "sgemm_gflops", gf / median(n) * 1e-9);
            printf("BENCH %s_256x256x1024_best %.2f GFLOP/s\n",
                   backend ? "sgemm_ref_gflops" : "sgemm_gflops", gf / samples_[0] * 1e-9);
        }
        /* the same product as bf16 products with fp32 sums: the kernel the CPU runs, then the
         * pure-C reference */
        for (int backend = 0; backend < 2; backend++) {
            if (backend == 0 && !la_bf16_cpu_has(LA_BF16_AVX512))
                continue;
            (void)la_bf16_force(backend ? LA_BF16_REF : LA_BF16_AUTO);
            int n = backend ? 3 : 50;
            for (int r = 0; r < n; r++) {
                double t0 = now_s();
                la_bf16_gemm(LA_NO_TRANS, LA_TRANS, 1024, 256, 256, ga, 256, gb, 256, gc, 256,
                             NULL);
                samples_[r] = now_s() - t0;
            }
            printf("BENCH %s_256x256x1024 %.2f GFLOP/s\n",
                   backend ? "bf16gemm_ref_gflops" : "bf16gemm_gflops", gf / median(n) * 1e-9);
        }
        (void)la_bf16_force(LA_BF16_AUTO);
    }

    /* MC inference, K = 50 */
    {
        const size_t n = 4096;
        ai_rng_uniform_fill(2, 2, 0, xy, 2 * n);
        for (size_t i = 0; i < 2 * n; i++)
            xy[i] = 2 * xy[i] - 1;
        int nrep = 3;
        for (int r = 0; r < nrep; r++) {
            double t0 = now_s();
            rc = bnn_predict_mc(&model, xy, n, BNN_MC_DEFAULT_K, 7, mean, sd);
            samples_[r] = now_s() - t0;
            if (rc)
                die("bnn_predict_mc", rc);
        }
        const double pps = (double)n / median(nrep);
        printf("BENCH bnn_mc50_points_per_s_%s %.0f points/s\n", P, pps);
        if (peak > 0.0) { /* the GEMM FLOPs of one point's K forward passes */
            double fp = 2.0 * c.hidden_width;
            for (unsigned l = 0; l < c.n_bayes; l++)
                fp += 2.0 * (l == 0 ? c.siren_width : c.hidden_width) * c.hidden_width;
            fp *= BNN_MC_DEFAULT_K;
            printf("BENCH bnn_mc50_of_limit_%s %.1f %%\n", P, 100.0 * pps / (peak * 1e9 / fp));
        }
    }

    bench_post(P, 5);
    bench_mean_pass(P, 30);
    printf("BENCH bnn_arena_bytes_%s %zu bytes\n", P, bnn_get_buffer_size());
    printf("BENCH bnn_params_%s %zu params\n", P, bnn_n_params(&model));
    return 0;
}
