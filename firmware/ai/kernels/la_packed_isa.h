/* Compile the code that follows for an instruction set beyond the build's baseline, so that an
 * ARCH=portable binary carries the wide kernels and picks one at run time (la_packed.c):
 *   LA_ISA_BEGIN("avx512f,avx512vl,avx2,fma") ... LA_ISA_END
 * GCC takes `#pragma GCC target`, clang a function attribute pushed over the region. */
#ifndef AI_LA_PACKED_ISA_H
#define AI_LA_PACKED_ISA_H

#define LA_ISA_PRAGMA_(x) _Pragma(#x)
#if defined(__clang__)
#define LA_ISA_BEGIN(isa)                                                                      \
    LA_ISA_PRAGMA_(clang attribute push(__attribute__((target(isa))), apply_to = function))
#define LA_ISA_END LA_ISA_PRAGMA_(clang attribute pop)
#else
#define LA_ISA_BEGIN(isa) LA_ISA_PRAGMA_(GCC push_options) LA_ISA_PRAGMA_(GCC target(isa))
#define LA_ISA_END LA_ISA_PRAGMA_(GCC pop_options)
#endif

#endif /* AI_LA_PACKED_ISA_H */
