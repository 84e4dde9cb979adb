/* Hash-grid encoding forward (docs/ALGORITHM.md section 1) and backward (a scatter into the
   flat table, parallel over levels: deterministic). Positions are computed bit-for-bit as in
   the pure-torch path (both floor the same values).
   Built with the other files of this folder into one shared object by _native.py (gcc,
   -fopenmp, -ffp-contract=off); called through ctypes on the raw storage of contiguous CPU
   float32 / int32 tensors; ``nthreads`` is torch's intra-op thread count. */
#include <stdint.h>
#include <math.h>
#include <stdlib.h>
#ifdef _OPENMP
#include <omp.h>
#endif
#include "lanes.h"
#include "hashgrid.h"
/* GATHER_ROWS 1 (default): with AVX-512, a corner's rows are read by hardware gathers (rows2);
   0: lane by lane, as before (benchmarks/bench_hash_rows.py builds both; the values are equal). */
#ifndef GATHER_ROWS
#define GATHER_ROWS 1
#endif
#if GATHER_ROWS && defined(__AVX512F__) && LANES == 16
#define ROWS2_GATHER 1
#include <immintrin.h>
#else
#define ROWS2_GATHER 0
#endif

/* Both features of the LANES rows idx[k] (8 bytes each: F = 2) of level table tl, as two
   vectors (e0 the first feature, e1 the second): the same values as reading them lane by lane.
   With AVX-512, two 8-row gathers and two permutes instead of 32 scalar loads (hash_fwd 8-9 %,
   hash_fwd_grid about 11 % less CPU on the Zen 4 host, docs/BENCHMARKS.md). */
static inline void rows2(const float* tl, vu idx, vf* e0, vf* e1) {
#if ROWS2_GATHER
    const __m512i ix = (__m512i)idx;
    const __m512d g0 = _mm512_i32gather_pd(_mm512_castsi512_si256(ix), (const void*)tl, 8);
    const __m512d g1 = _mm512_i32gather_pd(_mm512_extracti64x4_epi64(ix, 1), (const void*)tl, 8);
    const __m512i ev = _mm512_setr_epi32(0, 2, 4, 6, 8, 10, 12, 14, 16, 18, 20, 22, 24, 26, 28, 30);
    const __m512i od = _mm512_setr_epi32(1, 3, 5, 7, 9, 11, 13, 15, 17, 19, 21, 23, 25, 27, 29, 31);
    *e0 = (vf)_mm512_permutex2var_ps(_mm512_castpd_ps(g0), ev, _mm512_castpd_ps(g1));
    *e1 = (vf)_mm512_permutex2var_ps(_mm512_castpd_ps(g0), od, _mm512_castpd_ps(g1));
#else
    vf a, b;
    for (int k = 0; k < LANES; k++) {
        const float* e = tl + 2 * (int64_t)idx[k];
        a[k] = e[0]; b[k] = e[1];
    }
    *e0 = a; *e1 = b;
#endif
}

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
                        rows2(tl, idx[c], &e0, &e1);
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

/* Hash-grid encoding of every point of a regular grid, for the map's SDF grid query (mesh
   extraction; never training). Point (i, j, k), C order over (nx, ny, nz), has normalised
   coordinates (xa[i], ya[j], za[k]); out is (nx * ny * nz, L * F) as hash_fwd writes it for
   those points, bit for bit: each axis's position, floor, fraction, 1 - fraction and hash term
   are elementwise functions of that axis's coordinate alone, so they are computed once per
   axis value and level (the same float operations hash_fwd does per point), the (x, y)
   products of the weights once per row (i, j), and the per-point weights, corner rows and sums
   exactly as hash_fwd forms them (same products, corners 0..7 in the same order; the corner
   row's integer terms combine with the same wrap-around sum or xor, whose order does not
   matter). Lanes run along z within one row. */
void hash_fwd_grid(const float* xa, int64_t nx, const float* ya, int64_t ny, const float* za, int64_t nz,
                   const float* table, int L, int F, int64_t T, const float* scales, const int32_t* res,
                   const int32_t* dense, float* out, int nthreads) {
    const uint32_t mask = (uint32_t)(T - 1);
    const int64_t nzp = (nz + LANES - 1) / LANES * LANES;  /* z arrays padded to whole vectors */
    const int64_t LF = (int64_t)L * F;
    /* per level and axis value: 1 - frac, frac, and the corner-row terms of cell and cell + 1 */
    float* ux = (float*)calloc((size_t)L * (2 * nx + 2 * ny + 2 * nzp), sizeof(float));
    uint32_t* hx = (uint32_t*)calloc((size_t)L * (2 * nx + 2 * ny + 2 * nzp), sizeof(uint32_t));
    if (!ux || !hx) { free(ux); free(hx); return; }
    float* wx = ux + (size_t)L * nx;
    float* uy = wx + (size_t)L * nx;
    float* wy = uy + (size_t)L * ny;
    float* uz = wy + (size_t)L * ny;
    float* wz = uz + (size_t)L * nzp;
    uint32_t* hx1 = hx + (size_t)L * nx;
    uint32_t* hy0 = hx1 + (size_t)L * nx;
    uint32_t* hy1 = hy0 + (size_t)L * ny;
    uint32_t* hz0 = hy1 + (size_t)L * ny;
    uint32_t* hz1 = hz0 + (size_t)L * nzp;
    for (int l = 0; l < L; l++) {
        const float s = scales[l];
        const uint32_t r = (uint32_t)res[l];
        const int d = dense[l];
        const int64_t lengths[3] = {nx, ny, nz};
        const float* vals[3] = {xa, ya, za};
        float* us[3] = {ux + l * nx, uy + l * ny, uz + l * nzp};
        float* ws[3] = {wx + l * nx, wy + l * ny, wz + l * nzp};
        uint32_t* h0s[3] = {hx + l * nx, hy0 + l * ny, hz0 + l * nzp};
        uint32_t* h1s[3] = {hx1 + l * nx, hy1 + l * ny, hz1 + l * nzp};
        /* the term of coordinate c on axis a: dense c, c * res, c * res^2; hashed c, c * P1, c * P2 */
        const uint32_t mul[3] = {1u, d ? r : (uint32_t)P1, d ? r * r : (uint32_t)P2};
        for (int a = 0; a < 3; a++) {
            for (int64_t t = 0; t < lengths[a]; t++) {
                const float p = vals[a][t] * s + 0.5f;
                const float fl = floorf(p);
                const float w = p - fl;
                const uint32_t c = (uint32_t)(int32_t)fl;
                us[a][t] = 1.0f - w;
                ws[a][t] = w;
                if (d) { h0s[a][t] = c * mul[a]; h1s[a][t] = c * mul[a] + mul[a]; }
                else { h0s[a][t] = c * mul[a]; h1s[a][t] = (c + 1u) * mul[a]; }
            }
        }
    }
    /* rows (i, j) in blocks of about BLOCK points, level by level inside a block (the level's
       table stays in the cache, as in hash_fwd) */
    int64_t rows_per = BLOCK / (nz > 0 ? nz : 1);
    if (rows_per < 1) rows_per = 1;
    const int64_t nrows = nx * ny;
    const int64_t nb = (nrows + rows_per - 1) / rows_per;
    #pragma omp parallel for num_threads(nthreads) schedule(static)
    for (int64_t b = 0; b < nb; b++) {
        const int64_t r0 = b * rows_per, r1 = r0 + rows_per < nrows ? r0 + rows_per : nrows;
        for (int l = 0; l < L; l++) {
            const float* tl = table + (int64_t)l * T * F;
            const int d = dense[l];
            const float* luz = uz + l * nzp;
            const float* lwz = wz + l * nzp;
            const uint32_t* lz0 = hz0 + l * nzp;
            const uint32_t* lz1 = hz1 + l * nzp;
            for (int64_t row = r0; row < r1; row++) {
                const int64_t i = row / ny, j = row % ny;
                const float fux = ux[l * nx + i], fwx = wx[l * nx + i];
                const float fuy = uy[l * ny + j], fwy = wy[l * ny + j];
                const float a00 = fux * fuy, a10 = fwx * fuy, a01 = fux * fwy, a11 = fwx * fwy;
                const uint32_t x0 = hx[l * nx + i], x1 = hx1[l * nx + i];
                const uint32_t y0 = hy0[l * ny + j], y1 = hy1[l * ny + j];
                uint32_t bxy[4];
                if (d) { bxy[0] = x0 + y0; bxy[1] = x1 + y0; bxy[2] = x0 + y1; bxy[3] = x1 + y1; }
                else { bxy[0] = x0 ^ y0; bxy[1] = x1 ^ y0; bxy[2] = x0 ^ y1; bxy[3] = x1 ^ y1; }
                float* orow = out + row * nz * LF + (int64_t)l * F;
                for (int64_t k0 = 0; k0 < nz; k0 += LANES) {
                    const int cnt = (int)(nz - k0 < LANES ? nz - k0 : LANES);
                    vf vuz, vwz;
                    vu vz0, vz1;
                    __builtin_memcpy(&vuz, luz + k0, sizeof(vf));
                    __builtin_memcpy(&vwz, lwz + k0, sizeof(vf));
                    __builtin_memcpy(&vz0, lz0 + k0, sizeof(vu));
                    __builtin_memcpy(&vz1, lz1 + k0, sizeof(vu));
                    vf w[8];
                    vu idx[8];
                    w[0] = a00 * vuz; w[1] = a10 * vuz; w[2] = a01 * vuz; w[3] = a11 * vuz;
                    w[4] = a00 * vwz; w[5] = a10 * vwz; w[6] = a01 * vwz; w[7] = a11 * vwz;
                    if (d) {
                        for (int c = 0; c < 4; c++) {
                            idx[c] = (bxy[c] + vz0) & mask;
                            idx[c + 4] = (bxy[c] + vz1) & mask;
                        }
                    } else {
                        for (int c = 0; c < 4; c++) {
                            idx[c] = (bxy[c] ^ vz0) & mask;
                            idx[c + 4] = (bxy[c] ^ vz1) & mask;
                        }
                    }
                    if (F == 2) {
                        vf s0 = {0}, s1 = {0};
                        for (int c = 0; c < 8; c++) {
                            vf e0, e1;
                            rows2(tl, idx[c], &e0, &e1);
                            s0 += w[c] * e0; s1 += w[c] * e1;
                        }
                        for (int k = 0; k < cnt; k++) {
                            float* o = orow + (k0 + k) * LF;
                            o[0] = s0[k]; o[1] = s1[k];
                        }
                    } else {
                        for (int f = 0; f < F; f++) {
                            vf s0 = {0};
                            for (int c = 0; c < 8; c++) {
                                vf e;
                                for (int k = 0; k < LANES; k++) e[k] = tl[(int64_t)idx[c][k] * F + f];
                                s0 += w[c] * e;
                            }
                            for (int k = 0; k < cnt; k++) orow[(k0 + k) * LF + f] = s0[k];
                        }
                    }
                }
            }
        }
    }
    free(ux);
    free(hx);
}
