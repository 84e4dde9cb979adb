/* RAMEN's per-edge consensus terms (agents/consensus/ramen.py RamenMethod._edge, eq. 14, 16,
   17 and 19) in two passes over the parameters instead of ~25 torch passes, called through
   ctypes by agents/consensus/_native.py. Built with -ffp-contract=off: every operation is the
   single IEEE float operation of the torch op it replaces, in the same order, and the dual
   increment d += h t is one fused multiply-add as torch's addcmul_ computes it on CPUs with
   FMA, so the per-parameter results (w_ij, 2 h_ij, Theta_i^t - Theta_j, D, A) are
   bit-identical to the torch path (tests/consensus/test_consensus_native.py). The three
   batch sums (squared residual, sum of w_ij, penalty) are accumulated in double, so they
   differ from torch's float32 reductions at rounding; they are diagnostics of the round.
   Self-contained on purpose: the cache key hashes this file's bytes only. */
#include <stdint.h>
#include <math.h>

/* min and max of u_i + u_j (int64, as torch promotes two int32 counts to int32: the sums of
   counts stay far below 2^31) */
void usum_minmax(const int32_t* ui, const int32_t* uj, int64_t n, int64_t* lo_hi, int nthreads) {
    int64_t lo = INT64_MAX, hi = INT64_MIN;
    #pragma omp parallel for num_threads(nthreads) schedule(static) reduction(min: lo) reduction(max: hi)
    for (int64_t k = 0; k < n; k++) {
        const int64_t s = (int64_t)(int32_t)(ui[k] + uj[k]);
        lo = s < lo ? s : lo;
        hi = s > hi ? s : hi;
    }
    lo_hi[0] = lo;
    lo_hi[1] = hi;
}

#define SUM_BLOCK 65536 /* parameters per partial sum (part: 3 doubles per block) */

/* One edge. Weights (eq. 19): w = clamp(float(u) * eps + zeta, beta_l, beta_u) (the caller
   passes eps = 0, zeta = beta_u when max == min of u_i + u_j: w = beta_u everywhere);
   h2 = 2 w_ij w_ji / (w_ij + w_ji); t = Theta_i^t - Theta_j; d += h2 t (fma); a += 2 w_ij.
   Outputs h2 and t (n); d and a updated in place. Sums: |t|^2, sum w_ij and the penalty
   sum ((h2 t) / 2)^2 / w_ij (eq. 14), in double, per block of SUM_BLOCK parameters (an
   OpenMP simd reduction: a fixed order for a given build) and over the blocks in order, so
   they do not depend on the thread count. Two passes in all (min/max, then this): the
   arrays are 4 MiB each, so the cost is memory traffic. */
void ramen_edge(const int32_t* restrict ui, const int32_t* restrict uj, int64_t n, float eps,
                float zeta, float beta_l, float beta_u, const float* restrict theta_t,
                const float* restrict theta_j, float* restrict h2, float* restrict t,
                float* restrict d, float* restrict a, double* sums, double* part, int nthreads) {
    const int64_t nb = (n + SUM_BLOCK - 1) / SUM_BLOCK;
    #pragma omp parallel for num_threads(nthreads) schedule(static)
    for (int64_t b = 0; b < nb; b++) {
        const int64_t k0 = b * SUM_BLOCK, k1 = k0 + SUM_BLOCK < n ? k0 + SUM_BLOCK : n;
        double res = 0.0, wsum = 0.0, pen = 0.0;
        #pragma omp simd reduction(+: res, wsum, pen)
        for (int64_t k = k0; k < k1; k++) {
            float w_i = (float)ui[k] * eps + zeta;
            w_i = w_i < beta_l ? beta_l : w_i;
            w_i = w_i > beta_u ? beta_u : w_i;
            float w_j = (float)uj[k] * eps + zeta;
            w_j = w_j < beta_l ? beta_l : w_j;
            w_j = w_j > beta_u ? beta_u : w_j;
            const float h = (w_i * w_j) / (w_i + w_j) * 2.0f;
            const float tk = theta_t[k] - theta_j[k];
            d[k] = fmaf(h, tk, d[k]);
            a[k] = a[k] + 2.0f * w_i;
            h2[k] = h;
            t[k] = tk;
            const float hq = (h * tk) * 0.5f;
            res += (double)tk * (double)tk;
            wsum += (double)w_i;
            pen += (double)((hq * hq) / w_i);
        }
        part[3 * b] = res;
        part[3 * b + 1] = wsum;
        part[3 * b + 2] = pen;
    }
    double res = 0.0, wsum = 0.0, pen = 0.0;
    for (int64_t b = 0; b < nb; b++) {
        res += part[3 * b];
        wsum += part[3 * b + 1];
        pen += part[3 * b + 2];
    }
    sums[0] = res;
    sums[1] = wsum;
    sums[2] = pen;
}
