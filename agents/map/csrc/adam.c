/* The fused Adam step and Adam + the consensus proximal step (adam_prox).
   Built with the other files of this folder into one shared object by _native.py (gcc,
   -fopenmp, -ffp-contract=off); called through ctypes on the raw storage of contiguous CPU
   float32 / int32 tensors; ``nthreads`` is torch's intra-op thread count. */
#include <stdint.h>
#include <math.h>
#ifdef _OPENMP
#include <omp.h>
#endif

/* One parameter's Adam step (torch.optim.Adam's formula): updates m[i], v[i], returns the
   new p[i] and the new v[i] in *vi_out. */
static inline float adam_one(float* restrict p, const float* restrict g, float* restrict m,
                             float* restrict v, int64_t i, float step, float b1, float b2,
                             float eps, float bc2sqrt, float* vi_out) {
    const float gi = g[i];
    const float mi = m[i] + (1.0f - b1) * (gi - m[i]);
    const float vi = v[i] * b2 + (1.0f - b2) * gi * gi;
    m[i] = mi;
    v[i] = vi;
    *vi_out = vi;
    return p[i] - step * (mi / (sqrtf(vi) / bc2sqrt + eps));
}

void adam_step(float* restrict p, const float* restrict g, float* restrict m,
               float* restrict v, int64_t n, float lr, float b1, float b2, float eps, float bc1,
               float bc2sqrt, int nthreads) {
    const float step = lr / bc1;
    #pragma omp parallel for num_threads(nthreads) schedule(static)
    for (int64_t i = 0; i < n; i++) {
        float vi;
        p[i] = adam_one(p, g, m, v, i, step, b1, b2, eps, bc2sqrt, &vi);
    }
}

/* adam_step followed by the exact proximal step of the consensus quadratic (A/2)|p - c|^2
   in Adam's metric (NeuralMap._optimizer_step, agents/learner.py apply_prox_inv), in one
   pass: inv = sqrt(v) * k1 + k2 (k1 = 1 / (sqrt(1 - b2^t) lr), k2 = eps / lr: 1 / step),
   r = A / (inv + A) (A per parameter, or a_scalar when A is NULL: (1 / (inv + A)) A),
   p += r (c - p) as one fused multiply-add, which is what torch's addcmul_ computes on CPUs
   with FMA. Every other operation is the single IEEE float operation of the torch op it
   replaces, in the same order: bit-identical to a numpy float32 emulation (tested); against
   the torch ops, 1/step differs where torch's vectorised sqrt is not correctly rounded. */
void adam_prox(float* restrict p, const float* restrict g, float* restrict m,
               float* restrict v, int64_t n, float lr, float b1, float b2, float eps, float bc1,
               float bc2sqrt, float k1, float k2, const float* restrict A, float a_scalar,
               const float* restrict c, int nthreads) {
    const float step = lr / bc1;
    if (A) {
        #pragma omp parallel for simd num_threads(nthreads) schedule(static)
        for (int64_t i = 0; i < n; i++) {
            float vi;
            const float pi = adam_one(p, g, m, v, i, step, b1, b2, eps, bc2sqrt, &vi);
            const float inv = sqrtf(vi) * k1 + k2 + A[i];
            p[i] = fmaf(A[i] / inv, c[i] - pi, pi);
        }
    } else {
        #pragma omp parallel for simd num_threads(nthreads) schedule(static)
        for (int64_t i = 0; i < n; i++) {
            float vi;
            const float pi = adam_one(p, g, m, v, i, step, b1, b2, eps, bc2sqrt, &vi);
            const float inv = sqrtf(vi) * k1 + k2 + a_scalar;
            p[i] = fmaf((1.0f / inv) * a_scalar, c[i] - pi, pi);
        }
    }
}
