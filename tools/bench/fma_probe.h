/* The core's peak single-precision FMA rate for one instruction set, measured: a loop of
 * independent FMAs on registers (12 chains, enough to cover the latency of two FMA pipes), no
 * memory traffic. What a GEMM-bound step is compared against (bench_bnn). */
#ifndef TOOLS_BENCH_FMA_PROBE_H
#define TOOLS_BENCH_FMA_PROBE_H

/* isa: "avx512f", "avx2+fma" or "neon" (la_packed_kernel_t.isa). Returns GFLOP/s (best of a few
 * runs of about 50 ms), or 0 when this build cannot probe that instruction set. The caller
 * checks that the CPU has it. */
double fma_probe_gflops(const char *isa);

#endif
