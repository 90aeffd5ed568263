/* host_sim --version (also `host_sim version` and `host_sim CMD --version`): the commit the
 * program was built from and the build's configuration, as one report can quote them.
 *
 * The commit comes from build_info.h, which the Makefile writes into the build folder
 * ($(GEN)/build_info.h: `git describe --always --dirty`, "unknown" outside a git tree, and the
 * make variables that choose the code) and rewrites only when it changes: a commit recompiles
 * this file and relinks host_sim, nothing else. */
#include <stdio.h>

#include "ai/bnn.h"
#include "ai/kernels/la.h"
#include "ai/kernels/la_bf16.h"
#include "ai/kernels/la_packed.h"
#include "build_info.h"
#include "cli_opts.h"
#include "sim_kernels.h"

#ifndef FLEETSIM_GIT_DESCRIBE
#define FLEETSIM_GIT_DESCRIBE "unknown"
#endif
#ifndef FLEETSIM_BUILD_CONFIG
#define FLEETSIM_BUILD_CONFIG "unknown"
#endif
#ifndef FLEETSIM_BUILD_ARCH
#define FLEETSIM_BUILD_ARCH "unknown"
#endif
#ifndef FLEETSIM_BUILD_ARCH_FLAGS
#define FLEETSIM_BUILD_ARCH_FLAGS ""
#endif

void cli_version(FILE *out)
{
    const la_packed_kernel_t *k = la_packed_active();
    fprintf(out, "host_sim %s\n", FLEETSIM_GIT_DESCRIBE);
    fprintf(out, "build: %s: preset %s, precision %s, math %s, ARCH=%s%s%s%s, compiler %s\n", FLEETSIM_BUILD_CONFIG,
            BNN_PRESET_NAME, BNN_PRECISION_NAME, la_backend_name(), FLEETSIM_BUILD_ARCH,
            FLEETSIM_BUILD_ARCH_FLAGS[0] ? " (" : "", FLEETSIM_BUILD_ARCH_FLAGS, FLEETSIM_BUILD_ARCH_FLAGS[0] ? ")" : "",
#if defined(__clang__)
            "clang " __clang_version__
#elif defined(__GNUC__)
            "gcc " __VERSION__
#else
            "unknown"
#endif
    );
    fprintf(out, "on this CPU: fp32 products %s (%s), bf16 products %s%s%s%s\n", la_kernel_name(),
            k != NULL ? k->isa : "no packed kernel", la_bf16_kernel_name(), sim_kernels_bf16_on_ref() ? " (" : "",
            sim_kernels_bf16_why(), sim_kernels_bf16_on_ref() ? ")" : "");
}
