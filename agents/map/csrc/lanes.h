/* Vector lanes of the map kernels (shared by every file of this folder): one vector register
   per block of values, 16 lanes (zmm) where the build targets AVX-512, else 8 (ymm: AVX2,
   and SSE pairs). A 16-lane type on an AVX2-only target is split by gcc into ymm halves and
   spills (measured 3-4x slower there). */
#ifndef RAMENSIM_LANES_H
#define RAMENSIM_LANES_H
#include <stdint.h>
#ifndef LANES
#if defined(__AVX512F__)
#define LANES 16
#else
#define LANES 8
#endif
#endif
typedef float vf __attribute__((vector_size(LANES * 4)));
typedef int32_t vi __attribute__((vector_size(LANES * 4)));
typedef uint32_t vu __attribute__((vector_size(LANES * 4)));
#endif
