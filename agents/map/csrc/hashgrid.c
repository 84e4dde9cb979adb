/* Hash-grid encoding forward (docs/ALGORITHM.md section 1) and backward (a scatter into the
   flat table, parallel over levels: deterministic). Positions are computed bit-for-bit as in
   the pure-torch path (both floor the same values).
   Built with the other files of this folder into one shared object by _native.py (gcc,
   -fopenmp, -ffp-contract=off); called through ctypes on the raw storage of contiguous CPU
   float32 / int32 tensors; ``nthreads`` is torch's intra-op thread count. */
#include <stdint.h>
#include <math.h>
#ifdef _OPENMP
#include <omp.h>
#endif
#include "lanes.h"
#include "hashgrid.h"

/* Corner rows (within the level) and trilinear weights of LANES points at one level (lane
   k = point k; vectors of 16 lanes where the build targets AVX-512, else 8).
   Corner c has bits (x, y, z) = (c & 1, c >> 1 & 1, c >> 2 & 1); weight (wx*wy)*wz. */
static inline void corners_v(vf x, vf y, vf z, float s, uint32_t res, int dense,
                             uint32_t mask, vu idx[8], vf w[8]) {
    const vf px = x * s + 0.5f, py = y * s + 0.5f, pz = z * s + 0.5f;
    vf flx, fly, flz;
    for (int k = 0; k < LANES; k++) {
        flx[k] = floorf(px[k]); fly[k] = floorf(py[k]); flz[k] = floorf(pz[k]);
    }
    const vf wx = px - flx, wy = py - fly, wz = pz - flz;
    const vf ux = 1.0f - wx, uy = 1.0f - wy, uz = 1.0f - wz;
    /* floors are small integers: int32 conversion, then uint32 arithmetic (wraps as the hash needs) */
    const vu cx = (vu)__builtin_convertvector(flx, vi), cy = (vu)__builtin_convertvector(fly, vi),
             cz = (vu)__builtin_convertvector(flz, vi);
    const vf a00 = ux * uy, a10 = wx * uy, a01 = ux * wy, a11 = wx * wy;
    w[0] = a00 * uz; w[1] = a10 * uz; w[2] = a01 * uz; w[3] = a11 * uz;
    w[4] = a00 * wz; w[5] = a10 * wz; w[6] = a01 * wz; w[7] = a11 * wz;
    if (dense) {
        const vu y0 = cy * res, y1 = y0 + res, z0 = cz * (res * res), z1 = z0 + res * res;
        idx[0] = (cx + y0 + z0) & mask; idx[1] = (cx + 1 + y0 + z0) & mask;
        idx[2] = (cx + y1 + z0) & mask; idx[3] = (cx + 1 + y1 + z0) & mask;
        idx[4] = (cx + y0 + z1) & mask; idx[5] = (cx + 1 + y0 + z1) & mask;
        idx[6] = (cx + y1 + z1) & mask; idx[7] = (cx + 1 + y1 + z1) & mask;
    } else {
        const vu x1 = cx + 1u, y0 = cy * P1, y1 = (cy + 1u) * P1;
        const vu z0 = cz * P2, z1 = (cz + 1u) * P2;
        idx[0] = (cx ^ y0 ^ z0) & mask; idx[1] = (x1 ^ y0 ^ z0) & mask;
        idx[2] = (cx ^ y1 ^ z0) & mask; idx[3] = (x1 ^ y1 ^ z0) & mask;
        idx[4] = (cx ^ y0 ^ z1) & mask; idx[5] = (x1 ^ y0 ^ z1) & mask;
        idx[6] = (cx ^ y1 ^ z1) & mask; idx[7] = (x1 ^ y1 ^ z1) & mask;
    }
}

/* Points i0 .. i0 + cnt - 1 as three lane vectors (lanes past cnt: 0, whose corners are
   computed and never used). */
static inline void load_points(const float* xn, int64_t i0, int cnt, vf* x, vf* y, vf* z) {
    vf a = {0}, b = {0}, c = {0};
    for (int k = 0; k < cnt; k++) {
        a[k] = xn[3 * (i0 + k)]; b[k] = xn[3 * (i0 + k) + 1]; c[k] = xn[3 * (i0 + k) + 2];
    }
    *x = a; *y = b; *z = c;
}

/* Points per block of the hash-grid loops: within a block, level by level, so one level's
   table (T * F floats, 256 KiB at the default size) stays in the cache while the block's
   points gather from (fwd) or scatter into (bwd) it. */
#define BLOCK 4096

void hash_fwd(const float* xn, int64_t n, const float* table, int L, int F, int64_t T,
              const float* scales, const int32_t* res, const int32_t* dense,
              float* out, int nthreads) {
    const uint32_t mask = (uint32_t)(T - 1);
    /* blocks of at most BLOCK points, a multiple of LANES, at least one per thread */
    int64_t blk = (n + nthreads - 1) / (nthreads > 0 ? nthreads : 1);
    blk = (blk + LANES - 1) / LANES * LANES;
    if (blk > BLOCK) blk = BLOCK;
    if (blk < LANES) blk = LANES;
    const int64_t nb = (n + blk - 1) / blk;
    #pragma omp parallel for num_threads(nthreads) schedule(static)
    for (int64_t b = 0; b < nb; b++) {
        const int64_t j0 = b * blk, j1 = j0 + blk < n ? j0 + blk : n;
        for (int l = 0; l < L; l++) {
            const float* tl = table + (int64_t)l * T * F;
            for (int64_t i0 = j0; i0 < j1; i0 += LANES) {
                const int cnt = (int)(j1 - i0 < LANES ? j1 - i0 : LANES);
                vf x, y, z, w[8];
                vu idx[8];
                load_points(xn, i0, cnt, &x, &y, &z);
                corners_v(x, y, z, scales[l], (uint32_t)res[l], dense[l], mask, idx, w);
                if (F == 2) {  /* the default: both features of a corner from one 8-byte row */
                    vf a0 = {0}, a1 = {0};
                    for (int c = 0; c < 8; c++) {  /* corners 0..7 in order: the same sums as before */
                        vf e0, e1;
                        for (int k = 0; k < LANES; k++) {
                            const float* e = tl + 2 * (int64_t)idx[c][k];
                            e0[k] = e[0]; e1[k] = e[1];
                        }
                        a0 += w[c] * e0; a1 += w[c] * e1;
                    }
                    for (int k = 0; k < cnt; k++) {
                        float* o = out + (i0 + k) * (int64_t)L * F + 2 * l;
                        o[0] = a0[k]; o[1] = a1[k];
                    }
                } else {
                    for (int f = 0; f < F; f++) {
                        vf a = {0};
                        for (int c = 0; c < 8; c++) {
                            vf e;
                            for (int k = 0; k < LANES; k++) e[k] = tl[(int64_t)idx[c][k] * F + f];
                            a += w[c] * e;
                        }
                        for (int k = 0; k < cnt; k++) out[(i0 + k) * (int64_t)L * F + l * F + f] = a[k];
                    }
                }
            }
        }
    }
}

/* Scatter of d loss / d features into the flat table gradient. Thread t owns the levels
   t, t + nthreads, ...: levels own disjoint table rows, so there are no atomics, and each
   entry sums its contributions in point order whatever the thread count (deterministic). */
void hash_bwd(const float* xn, int64_t n, const float* grad_out, int L, int F, int64_t T,
              const float* scales, const int32_t* res, const int32_t* dense,
              float* grad_table, int nthreads) {
    const uint32_t mask = (uint32_t)(T - 1);
    #pragma omp parallel num_threads(nthreads)
    {
#ifdef _OPENMP
        const int tid = omp_get_thread_num(), nth = omp_get_num_threads();
#else
        const int tid = 0, nth = 1;
#endif
        for (int64_t j0 = 0; j0 < n; j0 += BLOCK) {
            const int64_t j1 = j0 + BLOCK < n ? j0 + BLOCK : n;
            for (int l = tid; l < L; l += nth) {
                const float s = scales[l];
                const uint32_t r = (uint32_t)res[l];
                const int d = dense[l];
                float* gl = grad_table + (int64_t)l * T * F;
                for (int64_t i0 = j0; i0 < j1; i0 += LANES) {
                    const int cnt = (int)(j1 - i0 < LANES ? j1 - i0 : LANES);
                    vf x, y, z, w[8];
                    vu idx[8];
                    load_points(xn, i0, cnt, &x, &y, &z);
                    corners_v(x, y, z, s, r, d, mask, idx, w);
                    for (int k = 0; k < cnt; k++) {
                        const float* go = grad_out + (i0 + k) * (int64_t)L * F + l * F;
                        if (F == 2) {
                            const float g0 = go[0], g1 = go[1];
                            for (int c = 0; c < 8; c++) {
                                float* e = gl + 2 * (int64_t)idx[c][k];
                                e[0] += w[c][k] * g0;
                                e[1] += w[c][k] * g1;
                            }
                        } else {
                            for (int c = 0; c < 8; c++) {
                                float* e = gl + (int64_t)idx[c][k] * F;
                                for (int f = 0; f < F; f++) e[f] += w[c][k] * go[f];
                            }
                        }
                    }
                }
            }
        }
    }
}
