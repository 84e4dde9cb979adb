/* OneBlob encoding of normalised positions (Co-SLAM; docs/ALGORITHM.md section 1).
   Built with the other files of this folder into one shared object by _native.py (gcc,
   -fopenmp, -ffp-contract=off); called through ctypes on the raw storage of contiguous CPU
   float32 / int32 tensors; ``nthreads`` is torch's intra-op thread count. */
#include <stdint.h>
#include <math.h>
#ifdef _OPENMP
#include <omp.h>
#endif
#include "lanes.h"

static inline float fq(float s, float nb) {
    const float u = s * nb, u2 = u * u;
    float v = 0.9375f * u * (1.0f - (2.0f / 3.0f) * u2 + 0.2f * u2 * u2) + 0.5f;
    return v < 0.0f ? 0.0f : (v > 1.0f ? 1.0f : v);
}

static inline float cumul(float s, float nb) {
    return fq(s - 1.0f, nb) + fq(s, nb) + fq(s + 1.0f, nb);
}

/* Fast path, bit-identical: fq's polynomial p(u) is increasing (p'(u) = 15/16 (1 - u^2)^2)
   with p(-1) = 0 and p(1) = 1, so for |u| >= 1.25 it is <= -0.01 or >= 1.01, far beyond
   float rounding, and the clamp gives exactly 0 or 1. For t in [1.3/nb, 1 - 1.3/nb] the
   periodic images of the kernel never reach the bins: in cumul(s) = (fq(s - 1) + fq(s)) +
   fq(s + 1), u = (s - 1) nb <= -1.3 and (s + 1) nb >= 1.3 for every bin edge, so the sum is
   exactly (0 + fq(s)) + 1 = fq(s) + 1: one polynomial per edge instead of three (4x faster
   on the default 16 bins). Below 1.3/nb an image reaches only edges nb - 1 and nb (u = k -
   t nb - nb > -1.3 needs k > nb - 1.3 + t nb), above 1 - 1.3/nb only edges 0 and 1; those
   get the full sum (nb >= 4). Checked equal to the full sum (the torch path) on random
   points and every float within 200 ulps of 0, 1 and the bounds. */
/* fq on LANES values at once: the same float operations as fq per lane, the clamp written
   with masks (gcc does not if-convert fq's branches for AVX2, so the scalar loop over the
   bin edges ran unvectorised there: 3x slower than with AVX-512's masked operations); a NaN
   stays NaN as in fq. */
static inline vf fq_v(vf s, float nb) {
    const vf u = s * nb, u2 = u * u;
    const vf v = 0.9375f * u * (1.0f - (2.0f / 3.0f) * u2 + 0.2f * u2 * u2) + 0.5f;
    const vf zero = {0}, one = zero + 1.0f;
    const vi below = v < zero;
    const vf w = (vf)((vi)v & ~below);  /* 0 where v < 0 */
    const vi above = w > one;
    return (vf)(((vi)w & ~above) | ((vi)one & above));
}

/* One point and axis at a time as before, the bin edges LANES at a time through fq_v, then
   the few edges near an end patched with the full sum; per edge the same float operations
   as fq, so the values are bit-identical to the scalar loop (and the torch path). */
void oneblob(const float* xn, int64_t n, int nb, float* out, int nthreads) {
    const float fnb = (float)nb;
    const float lo = 1.3f / fnb, hi = 1.0f - 1.3f / fnb;
    const int ne = (nb + 1 + LANES - 1) / LANES;  /* vectors of edges */
    float edge[129 + LANES]; /* nb <= 128 (MapConfig.oneblob_bins is at most 64) */
    for (int k = 0; k < ne * LANES; k++) edge[k] = (float)k / fnb;
    #pragma omp parallel for num_threads(nthreads) schedule(static)
    for (int64_t i = 0; i < n; i++) {
        for (int a = 0; a < 3; a++) {
            const float t = xn[3 * i + a];
            float* o = out + i * 3 * nb + a * nb;
            float c[129 + LANES] __attribute__((aligned(64)));
            if (t >= 0.0f && t <= 1.0f && nb >= 4) {
                for (int v = 0; v < ne; v++) {
                    vf e;
                    __builtin_memcpy(&e, edge + v * LANES, sizeof e);
                    const vf r = fq_v(e - t, fnb) + 1.0f;
                    __builtin_memcpy(c + v * LANES, &r, sizeof r);
                }
                /* near an end of [0, 1] a periodic image reaches the two edges at the far end */
                if (t < lo)
                    for (int k = nb - 1; k <= nb; k++) c[k] = cumul((float)k / fnb - t, fnb);
                if (t > hi)
                    for (int k = 0; k <= 1; k++) c[k] = cumul((float)k / fnb - t, fnb);
            } else {
                for (int k = 0; k <= nb; k++) c[k] = cumul((float)k / fnb - t, fnb);
            }
            for (int k = 0; k < nb; k++) o[k] = c[k + 1] - c[k];
        }
    }
}
