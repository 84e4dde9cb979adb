/* Map kernels of ramensim.agents.map (see _native.py, which compiles this file with gcc
   into $RAMENSIM_CACHE_DIR and calls it through ctypes): hash-grid encoding forward and
   backward, OneBlob, a fused Adam step and the visit counter. All arrays are the raw
   storage of contiguous CPU float32 / int32 tensors; ``nthreads`` is torch's intra-op
   thread count. Built with -fopenmp and -ffp-contract=off, so positions are computed
   bit-for-bit as in the pure-torch path (both paths floor the same values).
   Self-contained on purpose: the cache key hashes this file's bytes only. */
#include <stdint.h>
#include <math.h>

#define P1 2654435761u
#define P2 805459861u

/* Corner rows (within the level) and trilinear weights of one point at one level.
   Corner c has bits (x, y, z) = (c & 1, c >> 1 & 1, c >> 2 & 1); weight (wx*wy)*wz. */
static inline void corners(float x, float y, float z, float s, uint32_t res, int dense,
                           uint32_t mask, uint32_t idx[8], float w[8]) {
    const float px = x * s + 0.5f, py = y * s + 0.5f, pz = z * s + 0.5f;
    const float flx = floorf(px), fly = floorf(py), flz = floorf(pz);
    const float wx = px - flx, wy = py - fly, wz = pz - flz;
    const float ux = 1.0f - wx, uy = 1.0f - wy, uz = 1.0f - wz;
    const uint32_t cx = (uint32_t)flx, cy = (uint32_t)fly, cz = (uint32_t)flz;
    const float a00 = ux * uy, a10 = wx * uy, a01 = ux * wy, a11 = wx * wy;
    w[0] = a00 * uz; w[1] = a10 * uz; w[2] = a01 * uz; w[3] = a11 * uz;
    w[4] = a00 * wz; w[5] = a10 * wz; w[6] = a01 * wz; w[7] = a11 * wz;
    if (dense) {
        const uint32_t y0 = cy * res, y1 = y0 + res, z0 = cz * res * res, z1 = z0 + res * res;
        idx[0] = (cx + y0 + z0) & mask; idx[1] = (cx + 1 + y0 + z0) & mask;
        idx[2] = (cx + y1 + z0) & mask; idx[3] = (cx + 1 + y1 + z0) & mask;
        idx[4] = (cx + y0 + z1) & mask; idx[5] = (cx + 1 + y0 + z1) & mask;
        idx[6] = (cx + y1 + z1) & mask; idx[7] = (cx + 1 + y1 + z1) & mask;
    } else {
        const uint32_t x1 = cx + 1u, y0 = cy * P1, y1 = (cy + 1u) * P1;
        const uint32_t z0 = cz * P2, z1 = (cz + 1u) * P2;
        idx[0] = (cx ^ y0 ^ z0) & mask; idx[1] = (x1 ^ y0 ^ z0) & mask;
        idx[2] = (cx ^ y1 ^ z0) & mask; idx[3] = (x1 ^ y1 ^ z0) & mask;
        idx[4] = (cx ^ y0 ^ z1) & mask; idx[5] = (x1 ^ y0 ^ z1) & mask;
        idx[6] = (cx ^ y1 ^ z1) & mask; idx[7] = (x1 ^ y1 ^ z1) & mask;
    }
}

void hash_fwd(const float* xn, int64_t n, const float* table, int L, int F, int64_t T,
              const float* scales, const int32_t* res, const int32_t* dense,
              float* out, int nthreads) {
    const uint32_t mask = (uint32_t)(T - 1);
    #pragma omp parallel for num_threads(nthreads) schedule(static)
    for (int64_t i = 0; i < n; i++) {
        const float x = xn[3 * i], y = xn[3 * i + 1], z = xn[3 * i + 2];
        float* o = out + i * (int64_t)L * F;
        uint32_t idx[8];
        float w[8];
        for (int l = 0; l < L; l++) {
            corners(x, y, z, scales[l], (uint32_t)res[l], dense[l], mask, idx, w);
            const float* tl = table + (int64_t)l * T * F;
            if (F == 2) {
                float a0 = 0.0f, a1 = 0.0f;
                for (int c = 0; c < 8; c++) {
                    const float* e = tl + 2 * (int64_t)idx[c];
                    a0 += w[c] * e[0];
                    a1 += w[c] * e[1];
                }
                o[2 * l] = a0;
                o[2 * l + 1] = a1;
            } else {
                for (int f = 0; f < F; f++) {
                    float a = 0.0f;
                    for (int c = 0; c < 8; c++) a += w[c] * tl[(int64_t)idx[c] * F + f];
                    o[l * F + f] = a;
                }
            }
        }
    }
}

void hash_bwd(const float* xn, int64_t n, const float* grad_out, int L, int F, int64_t T,
              const float* scales, const int32_t* res, const int32_t* dense,
              float* grad_table, int nthreads) {
    const uint32_t mask = (uint32_t)(T - 1);
    #pragma omp parallel for num_threads(nthreads) schedule(static, 1)
    for (int l = 0; l < L; l++) {
        const float s = scales[l];
        const uint32_t r = (uint32_t)res[l];
        const int d = dense[l];
        float* gl = grad_table + (int64_t)l * T * F;
        uint32_t idx[8];
        float w[8];
        for (int64_t i = 0; i < n; i++) {
            const float* go = grad_out + i * (int64_t)L * F + l * F;
            corners(xn[3 * i], xn[3 * i + 1], xn[3 * i + 2], s, r, d, mask, idx, w);
            if (F == 2) {
                const float g0 = go[0], g1 = go[1];
                for (int c = 0; c < 8; c++) {
                    float* e = gl + 2 * (int64_t)idx[c];
                    e[0] += w[c] * g0;
                    e[1] += w[c] * g1;
                }
            } else {
                for (int c = 0; c < 8; c++)
                    for (int f = 0; f < F; f++) gl[(int64_t)idx[c] * F + f] += w[c] * go[f];
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

void oneblob(const float* xn, int64_t n, int nb, float* out, int nthreads) {
    const float fnb = (float)nb;
    #pragma omp parallel for num_threads(nthreads) schedule(static)
    for (int64_t i = 0; i < n; i++) {
        for (int a = 0; a < 3; a++) {
            const float t = xn[3 * i + a];
            float* o = out + i * 3 * nb + a * nb;
            float c[129]; /* nb <= 128 (MapConfig.oneblob_bins is at most 64) */
            for (int k = 0; k <= nb; k++) c[k] = cumul((float)k / fnb - t, fnb);
            for (int k = 0; k < nb; k++) o[k] = c[k + 1] - c[k];
        }
    }
}

void adam_step(float* p, const float* g, float* m, float* v, int64_t n, float lr,
               float b1, float b2, float eps, float bc1, float bc2sqrt, int nthreads) {
    const float step = lr / bc1;
    #pragma omp parallel for num_threads(nthreads) schedule(static)
    for (int64_t i = 0; i < n; i++) {
        const float gi = g[i];
        const float mi = m[i] + (1.0f - b1) * (gi - m[i]);
        const float vi = v[i] * b2 + (1.0f - b2) * gi * gi;
        m[i] = mi;
        v[i] = vi;
        p[i] -= step * (mi / (sqrtf(vi) / bc2sqrt + eps));
    }
}

void count_visits(const float* g, int32_t* visits, int64_t n, int nthreads) {
    #pragma omp parallel for num_threads(nthreads) schedule(static)
    for (int64_t i = 0; i < n; i++) visits[i] += (g[i] != 0.0f);
}
