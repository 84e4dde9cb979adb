/* RAMEN's visit counter (eq. 18): a parameter is visited when its gradient is non-zero.
   Built with the other files of this folder into one shared object by _native.py (gcc,
   -fopenmp, -ffp-contract=off); called through ctypes on the raw storage of contiguous CPU
   float32 / int32 tensors; ``nthreads`` is torch's intra-op thread count. */
#include <stdint.h>
#include <math.h>
#ifdef _OPENMP
#include <omp.h>
#endif

void count_visits(const float* g, int32_t* visits, int64_t n, int nthreads) {
    #pragma omp parallel for num_threads(nthreads) schedule(static)
    for (int64_t i = 0; i < n; i++) visits[i] += (g[i] != 0.0f);
}
