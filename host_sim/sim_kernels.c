/* What the math of this build runs on this CPU (sim_kernels.h). */
#include "sim_kernels.h"

#include <string.h>

#include "ai/bnn.h"
#include "ai/kernels/la.h"
#include "ai/kernels/la_bf16.h"

int sim_kernels_bf16_on_ref(void)
{
    return !la_bf16_cpu_has(LA_BF16_AVX512);
}

const char *sim_kernels_bf16_why(void)
{
    if (!sim_kernels_bf16_on_ref())
        return "";
#if defined(__x86_64__)
    if (strcmp(la_backend_name(), "eigen") != 0)
        return "LA_BACKEND=ref builds only the reference kernels";
    return "this CPU has no AVX512_BF16 instructions";
#else
    return "this build has no bf16 kernel for this CPU family (only x86-64's AVX512_BF16)";
#endif
}

int sim_kernels_bf16_note(FILE *out, const char *prog)
{
    if (!sim_kernels_bf16_on_ref())
        return 0;
    fprintf(out, "%s: note: the bf16 products run on the pure-C reference kernel (%s): the same results, but "
                 "several times slower than fp32 (build with PRECISION=fp32 unless you need a bf16 run's bits; "
                 "firmware/ai/README.md)\n",
            prog, sim_kernels_bf16_why());
    return 1;
}

int sim_kernels_bf16_default(void)
{
    return BNN_PRECISION_DEFAULT == BNN_PRECISION_BF16;
}
