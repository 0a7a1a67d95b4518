// Vectorisation helpers: `restrict` for the kernels' non-aliasing arrays and, with GCC on
// x86-64 Linux, an AVX2 clone of a kernel chosen at load time (DYNVAL_NO_CLONES turns it off).
#pragma once

#if defined(_MSC_VER)
#define DYNVAL_RESTRICT __restrict
#else
#define DYNVAL_RESTRICT __restrict__
#endif

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__) && \
    !defined(DYNVAL_NO_CLONES)
#define DYNVAL_VECTOR_CLONES __attribute__((target_clones("avx2", "default")))
#else
#define DYNVAL_VECTOR_CLONES
#endif
