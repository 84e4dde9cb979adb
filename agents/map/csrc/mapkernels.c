/* Map kernels of ramensim.agents.map (see _native.py, which compiles this file with gcc
   into $RAMENSIM_CACHE_DIR and calls it through ctypes): hash-grid encoding forward and
   backward, OneBlob, a fused Adam step and the visit counter. All arrays are the raw
   storage of contiguous CPU float32 / int32 tensors; ``nthreads`` is torch's intra-op
   thread count. Built with -fopenmp and -ffp-contract=off, so positions are computed
   bit-for-bit as in the pure-torch path (both paths floor the same values).
   Self-contained on purpose: the cache key hashes this file's bytes only. */
#include <stdint.h>
#include <math.h>
#ifdef _OPENMP
#include <omp.h>
#endif

#define P1 2654435761u
#define P2 805459861u

/* Corner rows (within the level) and trilinear weights of LANES points at one level (lane
   k = point k; vectors of 16 lanes where the build targets AVX-512, else 8).
   Corner c has bits (x, y, z) = (c & 1, c >> 1 & 1, c >> 2 & 1); weight (wx*wy)*wz. */
#if defined(__AVX512F__)
#define LANES 16
#else
#define LANES 8
#endif
typedef float vf __attribute__((vector_size(LANES * 4)));
typedef int32_t vi __attribute__((vector_size(LANES * 4)));
typedef uint32_t vu __attribute__((vector_size(LANES * 4)));

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

void count_visits(const float* g, int32_t* visits, int64_t n, int nthreads) {
    #pragma omp parallel for num_threads(nthreads) schedule(static)
    for (int64_t i = 0; i < n; i++) visits[i] += (g[i] != 0.0f);
}

/* ---------------------------------------------------------------------------------------
   Rendering and the observation losses (Co-SLAM's, docs/ALGORITHM.md section 1, eq. 5-6),
   forward and gradient with respect to the decoder outputs, for R rays of S samples: the
   fused replacement of the torch autograd graph over render.sdf_weights, render.composite,
   losses.render_losses and losses.sdf_losses (same maths, checked against it to float
   rounding in tests/map/test_map_objective.py).
   Per ray: u_k = sig(s_k / tr) sig(-s_k / tr); first sign change k* of s (0 if none);
   m_k = z_k < z_k* + tr; w_k = u_k m_k / (sum_j u_j m_j + 1e-8); rgb = sum_k w_k sig(raw_k);
   depth = sum_k w_k z_k. Over the batch (rays with observed depth D > 0 count as valid):
   L_rgb = mean over valid rays and channels of (rgb - rgb_obs)^2, L_depth = mean over valid
   rays of (depth - D)^2; front_k = z_k < D - tr, band_k = !front_k && z_k <= D + tr && D > 0,
   n_f, n_b their counts over the batch, fs_w = 1 - n_f / max(n_f + n_b, 1), sdf_w = 1 -
   n_b / max(n_f + n_b, 1); L_fs = fs_w mean((s front - front)^2), L_sdf = sdf_w mean(((z +
   s tr - D) band)^2), means over all R S samples. Gradients of lw[0] L_rgb + lw[1] L_depth +
   lw[2] L_sdf + lw[3] L_fs. Batch sums are per ray, then over rays in ray order in double:
   the result does not depend on the thread count. */

#define RL_MAX_S 1024  /* samples per ray the kernel takes (the caller checks) */

/* sdf, z: (R, S); raw: (R, S, 3); rgb_obs (R, 3); depth_obs (R,); lw: the four loss weights
   (rgb, depth, sdf, fs). Out: losses[4] = (L_rgb, L_depth, L_sdf, L_fs) unweighted;
   d_sdf (R, S), d_raw (R, S, 3); part: scratch of 4 R doubles. The batch-wide factors
   (n_f, n_b and the number of valid rays) are counts, found first; then one pass per ray
   gives its forward sums and its gradient. */
void render_loss(const float* sdf, const float* raw, const float* z, const float* rgb_obs,
                 const float* depth_obs, int64_t R, int S, float tr, const float* lw,
                 double* losses, float* d_sdf, float* d_raw, double* part, int nthreads) {
    int64_t nf = 0, nb = 0, nv = 0;
    #pragma omp parallel for num_threads(nthreads) schedule(static) reduction(+: nf, nb, nv)
    for (int64_t r = 0; r < R; r++) {
        const float* zz = z + r * S;
        const float D = depth_obs[r];
        nv += D > 0.0f;
        for (int k = 0; k < S; k++) {
            const int front = zz[k] < D - tr, back = zz[k] > D + tr;
            nf += front;
            nb += !front && !back && D > 0.0f;
        }
    }
    const double n = (double)R * (double)S;
    const double total = nf + nb > 1 ? (double)(nf + nb) : 1.0;
    const double fs_w = 1.0 - (double)nf / total, sdf_w = 1.0 - (double)nb / total;
    const float g_rgb = nv ? (float)(2.0 * lw[0] / (3.0 * (double)nv)) : 0.0f;
    const float g_dep = nv ? (float)(2.0 * lw[1] / (double)nv) : 0.0f;
    const float g_sdf = (float)(2.0 * lw[2] * sdf_w / n), g_fs = (float)(2.0 * lw[3] * fs_w / n);
    #pragma omp parallel for num_threads(nthreads) schedule(static)
    for (int64_t r = 0; r < R; r++) {
        float u[RL_MAX_S], du[RL_MAX_S], sc[3 * RL_MAX_S];
        double wd[RL_MAX_S];
        const float* s = sdf + r * S;
        const float* zz = z + r * S;
        const float* rw = raw + 3 * r * S;
        const float D = depth_obs[r];
        float* ds = d_sdf + r * S;
        float* dr = d_raw + 3 * r * S;
        double* p = part + 4 * r;  /* sums of this ray: rgb, depth, sdf, fs squared errors */
        p[0] = p[1] = p[2] = p[3] = 0.0;
        for (int k = 0; k < S; k++) {  /* free-space and SDF terms */
            const int front = zz[k] < D - tr, back = zz[k] > D + tr;
            const int band = !front && !back && D > 0.0f;
            float g = 0.0f;
            if (front) {
                const float e = s[k] - 1.0f;
                p[3] += (double)(e * e);
                g += g_fs * e;
            }
            if (band) {
                const float e = (zz[k] + s[k] * tr) - D;
                p[2] += (double)(e * e);
                g += g_sdf * e * tr;
            }
            ds[k] = g;
        }
        if (!(D > 0.0f)) {
            for (int k = 0; k < 3 * S; k++) dr[k] = 0.0f;
            continue;
        }
        /* rendering weights: u = sig(a) sig(-a), a = s / tr, with e = exp(-|a|) in (0, 1]
           (no overflow): sig(|a|) = 1 / (1 + e), sig(-|a|) = e / (1 + e);
           du/ds = u (sig(-a) - sig(a)) / tr */
        int first = 0;
        for (int k = 0; k + 1 < S; k++)
            if (s[k + 1] * s[k] < 0.0f) { first = k; break; }
        const float lim = zz[first] + tr;
        /* the normalisation and its backward in double: where one sample carries nearly all
           of a ray's weight, w = 1 - 1e-8 / W and gw_k - sum_j gw_j w_j cancels; in float
           that costs up to ~1e-3 of the entry (as it does torch's float32 autograd) */
        double W = 0.0;
        for (int k = 0; k < S; k++) {
            const float a = s[k] / tr, e = expf(-fabsf(a));
            const float hi = 1.0f / (1.0f + e), lo = e / (1.0f + e);
            const float sp = a >= 0.0f ? hi : lo, sn = a >= 0.0f ? lo : hi;
            const float uk = zz[k] < lim ? sp * sn : 0.0f;
            u[k] = uk;
            du[k] = uk * (sn - sp) / tr;
            W += uk;
        }
        W += 1e-8;
        double r0 = 0.0, r1 = 0.0, r2 = 0.0, dep = 0.0;
        for (int k = 0; k < S; k++) {
            const double w = u[k] / W;
            wd[k] = w;
            for (int c = 0; c < 3; c++) sc[3 * k + c] = 1.0f / (1.0f + expf(-rw[3 * k + c]));
            r0 += w * sc[3 * k]; r1 += w * sc[3 * k + 1]; r2 += w * sc[3 * k + 2];
            dep += w * zz[k];
        }
        const float e0 = (float)r0 - rgb_obs[3 * r], e1 = (float)r1 - rgb_obs[3 * r + 1],
                    e2 = (float)r2 - rgb_obs[3 * r + 2], ed = (float)dep - D;
        p[0] = (double)(e0 * e0) + (double)(e1 * e1) + (double)(e2 * e2);
        p[1] = (double)(ed * ed);
        const float gr0 = g_rgb * e0, gr1 = g_rgb * e1, gr2 = g_rgb * e2, gd = g_dep * ed;
        double dot = 0.0;  /* sum_j gw_j w_j, gw_j = d obs / d w_j */
        for (int k = 0; k < S; k++) {
            const float* c = sc + 3 * k;
            const float gw = gr0 * c[0] + gr1 * c[1] + gr2 * c[2] + gd * zz[k];
            const float w = (float)wd[k];
            dr[3 * k] = gr0 * w * c[0] * (1.0f - c[0]);
            dr[3 * k + 1] = gr1 * w * c[1] * (1.0f - c[1]);
            dr[3 * k + 2] = gr2 * w * c[2] * (1.0f - c[2]);
            dot += gw * wd[k];
            sc[3 * k] = gw;  /* reuse: gw_k */
        }
        for (int k = 0; k < S; k++)  /* du is 0 where the mask is */
            ds[k] += (float)((sc[3 * k] - dot) / W) * du[k];
    }
    double er = 0, ed = 0, sd = 0, fs = 0;
    for (int64_t r = 0; r < R; r++) {  /* in ray order: independent of the thread count */
        er += part[4 * r]; ed += part[4 * r + 1]; sd += part[4 * r + 2]; fs += part[4 * r + 3];
    }
    losses[0] = nv ? er / (3.0 * (double)nv) : 0.0;
    losses[1] = nv ? ed / (double)nv : 0.0;
    losses[2] = sdf_w * sd / n;
    losses[3] = fs_w * fs / n;
}

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

/* Sample depths and normalised sample positions of R training rays: render.sample_depths
   (stratified + surface samples, merged in order, jittered between midpoints), then
   o + d z and NeuralMap._normalise ((p - lo) / extent clamped to [0, 1]), with the same
   float operations in the same order as the torch path, so the result is bit-identical
   (tests/map/test_map_rays.py). A merge of the two sorted lists gives the values torch.sort
   gives (the caller checks that both are sorted and every depth finite).
   rows: (R, 10) [origin, direction, rgb, depth]; strat (ns) = linspace(near, far, ns);
   off (nf) = linspace(-range, range, nf); nodepth (nf) = linspace(near, far, nf), the
   surface samples of a ray without depth (<= 0); rnd (R, ns + nf): the jitter draws, or
   NULL for none; lo, ext (3). Out: z (R, ns + nf) m, xn (R (ns + nf), 3). */
void ray_samples(const float* rows, int64_t R, const float* strat, int ns, const float* off,
                 int nf, const float* nodepth, const float* rnd, const float* lo,
                 const float* ext, float* z, float* xn, int nthreads) {
    const int S = ns + nf;
    #pragma omp parallel for num_threads(nthreads) schedule(static)
    for (int64_t r = 0; r < R; r++) {
        const float* row = rows + 10 * r;
        const float D = row[9];
        float* zz = z + r * S;
        float surf[RL_MAX_S];
        for (int k = 0; k < nf; k++) surf[k] = D <= 0.0f ? nodepth[k] : D + off[k];
        int i = 0, j = 0;
        for (int k = 0; k < S; k++)
            zz[k] = (j >= nf || (i < ns && strat[i] <= surf[j])) ? strat[i++] : surf[j++];
        if (rnd) {
            const float* u = rnd + r * S;
            float prev = zz[0];  /* lower bound of sample k: midpoint (k-1, k), zz[0] for k = 0 */
            for (int k = 0; k < S; k++) {
                const float upper = k + 1 < S ? 0.5f * (zz[k + 1] + zz[k]) : zz[k];
                const float lower = prev;
                prev = upper;
                zz[k] = lower + (upper - lower) * u[k];
            }
        }
        for (int k = 0; k < S; k++) {
            float* p = xn + 3 * (r * S + k);
            for (int a = 0; a < 3; a++) {
                const float v = ((row[a] + row[3 + a] * zz[k]) - lo[a]) / ext[a];
                p[a] = v < 0.0f ? 0.0f : (v > 1.0f ? 1.0f : v);
            }
        }
    }
}
