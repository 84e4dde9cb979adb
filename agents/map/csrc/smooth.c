/* Co-SLAM's smoothness term and its gradient.
   Built with the other files of this folder into one shared object by _native.py (gcc,
   -fopenmp, -ffp-contract=off); called through ctypes on the raw storage of contiguous CPU
   float32 / int32 tensors; ``nthreads`` is torch's intra-op thread count. */
#include <stdint.h>
#include <math.h>
#ifdef _OPENMP
#include <omp.h>
#endif

/* Co-SLAM's smoothness term (losses.smoothness_loss) and its gradient: f is an n^3 lattice
   of C features in (z, y, x) order; tv = sum over the three axes of squared forward
   differences, loss = tv / n^3 (returned unweighted); grad = weight * d loss / d f, written
   (not accumulated). part: scratch of n doubles (per z slab, summed in slab order). */
void smooth_loss(const float* f, int n, int C, float weight, double* loss, float* grad,
                 double* part, int nthreads) {
    const int64_t sy = (int64_t)n * C, sz = (int64_t)n * n * C;
    const float scale = (float)(2.0 * weight / ((double)n * n * n));
    #pragma omp parallel for num_threads(nthreads) schedule(static)
    for (int a = 0; a < n; a++) {
        double acc = 0.0;
        for (int b = 0; b < n; b++) {
            for (int c = 0; c < n; c++) {
                const int64_t base = a * sz + b * sy + (int64_t)c * C;
                for (int ch = 0; ch < C; ch++) {
                    const int64_t i = base + ch;
                    const float v = f[i];
                    float g = 0.0f;
                    if (a > 0) g += v - f[i - sz];
                    if (b > 0) g += v - f[i - sy];
                    if (c > 0) g += v - f[i - C];
                    if (a + 1 < n) { const float d = f[i + sz] - v; g -= d; acc += (double)(d * d); }
                    if (b + 1 < n) { const float d = f[i + sy] - v; g -= d; acc += (double)(d * d); }
                    if (c + 1 < n) { const float d = f[i + C] - v; g -= d; acc += (double)(d * d); }
                    grad[i] = scale * g;
                }
            }
        }
        part[a] = acc;
    }
    double tv = 0.0;
    for (int a = 0; a < n; a++) tv += part[a];
    *loss = tv / ((double)n * n * n);
}
