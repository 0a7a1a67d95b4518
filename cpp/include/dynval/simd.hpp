// Vectorisation helpers: `restrict` for the kernels' non-aliasing arrays and, with GCC on
// x86-64 Linux, an AVX2 clone of a kernel chosen at load time (DYNVAL_NO_CLONES turns it off, as
// the DYNVAL_NATIVE build does, whose whole module is compiled for the building machine).
// DYNVAL_FMA_CLONES is the x86-64-v3 clone (AVX2 and FMA: a multiply-add is one instruction, the
// peak the compute-bound lag kernels aim at); DYNVAL_VECTOR_CLONES the AVX2 one, without FMA.
#pragma once

#if defined(_MSC_VER)
#define DYNVAL_RESTRICT __restrict
#else
#define DYNVAL_RESTRICT __restrict__
#endif

#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && defined(__linux__) && \
    !defined(DYNVAL_NO_CLONES)
#define DYNVAL_VECTOR_CLONES __attribute__((target_clones("avx2", "default")))
#define DYNVAL_FMA_CLONES __attribute__((target_clones("arch=x86-64-v3", "default")))
#else
#define DYNVAL_VECTOR_CLONES
#define DYNVAL_FMA_CLONES
#endif

// A register tile inlined into the (cloned) kernel that calls it, so it is compiled for that
// kernel's instruction set.
#if defined(__GNUC__)
#define DYNVAL_ALWAYS_INLINE inline __attribute__((always_inline))
#else
#define DYNVAL_ALWAYS_INLINE inline
#endif

#if defined(__GNUC__)
#include <cstring>

namespace dynval::detail {

/// Four doubles as one GCC/Clang vector (one AVX register in the AVX2 clone, two SSE registers in
/// the default one). Kernels written with it vectorise where the same loop over plain eight-lane
/// arrays compiles to scalar code. DYNVAL_VECTOR_TYPES says it exists; kernels keep a plain loop
/// for compilers without it.
#define DYNVAL_VECTOR_TYPES 1
typedef double vec4 __attribute__((vector_size(32)));

/// v = four consecutive doubles from any address (memcpy: no alignment asked, no aliasing
/// question). An output argument, not a returned vector, whose ABI would depend on the clone.
inline void load4(vec4& v, const double* p) noexcept { std::memcpy(&v, p, sizeof v); }

}  // namespace dynval::detail
#endif
