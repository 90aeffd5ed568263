/* What the math of this build runs on this CPU, for the programs' start-up notes: a
 * PRECISION=bf16 build (or bench_bnn's bf16 figures) on a CPU without AVX512_BF16 runs every
 * bf16 product on the pure-C reference (firmware/ai/kernels/la_bf16.c): the same bits, several
 * times slower than fp32. The programs say so once on stderr instead of being silently slow. */
#ifndef HOST_SIM_SIM_KERNELS_H
#define HOST_SIM_SIM_KERNELS_H

#include <stdio.h>

/* 1 when bf16 products run on the pure-C reference here (this build has no bf16 kernel for
 * this CPU, or the CPU lacks the instruction), else 0. */
int sim_kernels_bf16_on_ref(void);

/* Why they do ("this CPU has no AVX512_BF16", "LA_BACKEND=ref", ...); "" when they do not. */
const char *sim_kernels_bf16_why(void);

/* When bf16 products run on the reference: one line "PROG: note: ..." on `out` saying so, why,
 * and what to do (PRECISION=fp32); returns 1. Else prints nothing and returns 0. Call it where
 * the program is about to run bf16 products (host_sim run and fleet in a PRECISION=bf16 build:
 * sim_kernels_bf16_default(); bench_bnn's bf16 figures). */
int sim_kernels_bf16_note(FILE *out, const char *prog);

/* 1 when this build's training step defaults to bf16 products (PRECISION=bf16). */
int sim_kernels_bf16_default(void);

#endif /* HOST_SIM_SIM_KERNELS_H */
