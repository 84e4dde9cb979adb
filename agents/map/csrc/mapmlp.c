/* Fused, frozen decoder MLPs of ramensim.agents.map (see _native.py and decoders.py):
   forward (SDF + raw colour) and backward (d loss / d grid features). The backward needs
   only the ReLU masks of the two hidden layers (the weights are frozen): mlp_fwd_keep
   stores them (one byte per hidden unit and sample) and mlp_bwd_masks reads them, so a
   training step runs the forward once; mlp_bwd recomputes the forward instead. Called through ctypes on contiguous CPU float32 tensors.
   Built by _native.py with gcc (-ffp-contract=fast: FMA contraction allowed here, results
   are checked against the torch decoders to 1e-5) and -fopenmp; the cache key hashes this
   file and the headers of its folder. */
#include <stdint.h>

/* Sizes are compile-time constants (one shared object per decoder shape):
   NG grid features, NP OneBlob features, GH geometry hidden, GO geometry outputs (1 + h),
   CH colour hidden. _native.get_mlp_lib() passes them as -DNG=.. -DNP=.. -DGH=.. -DGO=..
   -DCH=.. (part of the cache key); the defaults below are the default MapConfig's, so an
   editor or a plain `gcc -fsyntax-only mapmlp.c` can parse this file on its own.
   Samples are processed LANES (16 or 8) at a time in structure-of-arrays form (one vector lane per
   sample), so every layer is a run of independent vector FMAs. */
#ifndef NG
#define NG 32 /* n_levels * features_per_level */
#endif
#ifndef NP
#define NP 48 /* 3 * oneblob_bins */
#endif
#ifndef GH
#define GH 32 /* geo_hidden */
#endif
#ifndef GO
#define GO 16 /* 1 (sdf) + geo_feat_dim */
#endif
#ifndef CH
#define CH 32 /* color_hidden */
#endif
#if GO < 2
#error "GO = 1 + geo_feat_dim must be at least 2"
#endif
#define NH (GO - 1)
/* One vector register per block of samples (lanes.h: 16 lanes where the build targets
   AVX-512, else 8; a 16-lane type on an AVX2-only target would spill the 8 accumulators of
   dense()). */
#include "lanes.h"
typedef int8_t vb __attribute__((vector_size(LANES)));
#define NM (GH + CH) /* ReLU mask vectors per block of LANES samples */

/* Y[j] = B[j] + sum_k W[j*ld + k] X[k] (K columns of a row-major matrix with row stride
   ld; B = NULL: no B term), optional ReLU. */
static inline void dense_acc(const vf* X, int Kc, const float* W, int ld, int J, vf* Y,
                             const vf* B, int relu) {
    int j = 0;
    const vf z = {0};
    for (; j + 8 <= J; j += 8) {
        vf a0 = z, a1 = z, a2 = z, a3 = z, a4 = z, a5 = z, a6 = z, a7 = z;
        if (B) {
            a0 = B[j]; a1 = B[j + 1]; a2 = B[j + 2]; a3 = B[j + 3];
            a4 = B[j + 4]; a5 = B[j + 5]; a6 = B[j + 6]; a7 = B[j + 7];
        }
        const float* w = W + (int64_t)j * ld;
        const int K = ld;  /* the row offsets below */
        for (int k = 0; k < Kc; k++) {
            const vf x = X[k];
            a0 += w[k] * x; a1 += w[K + k] * x; a2 += w[2 * K + k] * x; a3 += w[3 * K + k] * x;
            a4 += w[4 * K + k] * x; a5 += w[5 * K + k] * x; a6 += w[6 * K + k] * x;
            a7 += w[7 * K + k] * x;
        }
        Y[j] = a0; Y[j + 1] = a1; Y[j + 2] = a2; Y[j + 3] = a3;
        Y[j + 4] = a4; Y[j + 5] = a5; Y[j + 6] = a6; Y[j + 7] = a7;
    }
    for (; j < J; j++) {
        vf a = B ? B[j] : z;
        const float* w = W + (int64_t)j * ld;
        for (int k = 0; k < Kc; k++) a += w[k] * X[k];
        Y[j] = a;
    }
    if (relu) {
        for (int q = 0; q < J; q++) { vi m = Y[q] > z; Y[q] = (vf)((vi)Y[q] & m); }
    }
}

/* Y[j] = sum_k W[j*K + k] X[k] (W row-major J x K), optional ReLU. */
static inline void dense(const vf* X, int K, const float* W, int J, vf* Y, int relu) {
    dense_acc(X, K, W, K, J, Y, 0, relu);
}

/* Load rows [i0, i0 + cnt) of a row-major (n, C) array into C lane vectors (zero pad). */
static inline void load_soa(const float* A, int C, int64_t i0, int cnt, vf* X) {
    for (int c = 0; c < C; c++) { vf z = {0}; X[c] = z; }
    for (int s = 0; s < cnt; s++) { const float* r = A + (i0 + s) * C;
        for (int c = 0; c < C; c++) X[c][s] = r[c]; }
}

static inline void store_soa(const vf* X, int C, int64_t i0, int cnt, float* A) {
    for (int s = 0; s < cnt; s++) { float* r = A + (i0 + s) * C;
        for (int c = 0; c < C; c++) r[c] = X[c][s]; }
}

/* The OneBlob parts of both first layers, pt[j] = sum_k PT[k*(GH+CH) + j] pe[k] (PT: the
   (NP, GH + CH) matrix [W0[:, NG:]; C0[:, :NP]]^T), per sample over its non-zero features
   only: OneBlob has 3 non-zero bins of 16 per axis, so this is ~5x less arithmetic than
   the dense product (exact zeros add nothing; the sum order differs from the dense one
   at float rounding). */
static inline void pe_terms_n(const float* pe, int64_t i0, int cnt, const float* PT, vf* pt, int J) {
    float acc[LANES][GH + CH] __attribute__((aligned(64)));
    for (int s = 0; s < LANES; s++) {
        float* a = acc[s];
        for (int j = 0; j < J; j++) a[j] = 0.0f;
        if (s >= cnt) continue;
        const float* p = pe + (i0 + s) * NP;
        for (int k = 0; k < NP; k++) {
            const float v = p[k];
            if (v == 0.0f) continue;
            const float* w = PT + k * (GH + CH);
            for (int j = 0; j < J; j++) a[j] += v * w[j];
        }
    }
    for (int j = 0; j < J; j++) {
        vf v = {0};
        for (int s = 0; s < LANES; s++) v[s] = acc[s][j];
        pt[j] = v;
    }
}

/* The geometry decoder of one block: the OneBlob terms of the first Jpt columns of both
   first layers into pt, the hidden layer into hid, the first Jgo geometry outputs into geo.
   Never inlined nor cloned, so the forward (Jpt = GH + CH, Jgo = GO) and the SDF alone
   (Jpt = GH, Jgo = 8) run the same machine code for every value the SDF depends on: with
   FMA contraction allowed (this file is built with -ffp-contract=fast) the compiler could
   otherwise contract the two inlined copies differently, and mlp_sdf would differ from the
   forward's sdf in the last bit (it did in AVX2 builds). Jpt and Jgo are multiples of 8. */
__attribute__((noinline, noclone))
static void geo_block(const float* feats, const float* pe, int64_t i0, int cnt,
                      const float* W0, const float* W1, const float* PT, int Jpt, int Jgo,
                      vf* pt, vf* hid, vf* geo) {
    vf x[NG];
    load_soa(feats, NG, i0, cnt, x);
    pe_terms_n(pe, i0, cnt, PT, pt, Jpt);
    dense_acc(x, NG, W0, NG + NP, GH, hid, pt, 1);
    dense(hid, GH, W1, Jgo, geo, 0);
}

static inline void fwd_block(const float* feats, const float* pe, int64_t i0, int cnt,
                             const float* W0, const float* W1, const float* C0,
                             const float* C1, const float* PT, vf* hid, vf* geo, vf* chid,
                             vf* raw) {
    vf xc[NH], pt[GH + CH];
    geo_block(feats, pe, i0, cnt, W0, W1, PT, GH + CH, GO, pt, hid, geo);
    for (int k = 0; k < NH; k++) xc[k] = geo[1 + k];
    dense_acc(xc, NH, C0 + NP, NP + NH, CH, chid, pt + GH, 1);
    dense(chid, CH, C1, 3, raw, 0);
}

/* Forward; with masks != NULL also the ReLU masks: block b of LANES samples owns the NM
   vectors masks[b * NM .. b * NM + NM) of LANES bytes (0 or -1), hidden units of the
   geometry layer first, then the colour layer's (mlp_mask_bytes(n) bytes in all). */
void mlp_fwd_keep(const float* feats, const float* pe, int64_t n, const float* W0,
                  const float* W1, const float* C0, const float* C1, const float* PT,
                  float* sdf, float* rgb, vb* masks, int nthreads) {
    const int64_t nblk = (n + LANES - 1) / LANES;
    #pragma omp parallel for num_threads(nthreads) schedule(static)
    for (int64_t b = 0; b < nblk; b++) {
        const int64_t i0 = b * LANES;
        const int cnt = (int)(n - i0 < LANES ? n - i0 : LANES);
        vf hid[GH], geo[GO], chid[CH], raw[3];
        fwd_block(feats, pe, i0, cnt, W0, W1, C0, C1, PT, hid, geo, chid, raw);
        store_soa(geo, 1, i0, cnt, sdf);
        store_soa(raw, 3, i0, cnt, rgb);
        if (masks) {
            const vf zero = {0};
            vb* mb = masks + b * NM;
            for (int j = 0; j < GH; j++) mb[j] = __builtin_convertvector(hid[j] > zero, vb);
            for (int j = 0; j < CH; j++) mb[GH + j] = __builtin_convertvector(chid[j] > zero, vb);
        }
    }
}

void mlp_fwd(const float* feats, const float* pe, int64_t n, const float* W0,
             const float* W1, const float* C0, const float* C1, const float* PT, float* sdf,
             float* rgb, int nthreads) {
    mlp_fwd_keep(feats, pe, n, W0, W1, C0, C1, PT, sdf, rgb, 0, nthreads);
}

/* The SDF alone (no colour layers, the first 8 geometry outputs), for mesh extraction on a
   grid: each value comes from the same machine code as mlp_fwd's (geo_block), so the result
   is bit-identical to its sdf (tests/map/test_map_backends.py), at about half the work. */
void mlp_sdf(const float* feats, const float* pe, int64_t n, const float* W0, const float* W1,
             const float* PT, float* sdf, int nthreads) {
    const int64_t nblk = (n + LANES - 1) / LANES;
    #pragma omp parallel for num_threads(nthreads) schedule(static)
    for (int64_t b = 0; b < nblk; b++) {
        const int64_t i0 = b * LANES;
        const int cnt = (int)(n - i0 < LANES ? n - i0 : LANES);
        vf pt[GH + CH], hid[GH], g0[GO];
        geo_block(feats, pe, i0, cnt, W0, W1, PT, GH, GO < 8 ? GO : 8, pt, hid, g0);
        store_soa(g0, 1, i0, cnt, sdf);
    }
}

/* Bytes of the mask buffer of mlp_fwd_keep for n samples. */
int64_t mlp_mask_bytes(int64_t n) { return (n + LANES - 1) / LANES * NM * LANES; }

/* d(loss)/d(grid features) from d(loss)/d(sdf) and d(loss)/d(raw colour), recomputing
   the forward pass for the ReLU masks. C1T (CH,3), C0hT (NH,CH), W1T (GH,GO), W0gT (NG,GH)
   are the transposed matrices (colour-layer-0's h columns, geometry-layer-0's grid columns). */
void mlp_bwd(const float* feats, const float* pe, int64_t n, const float* W0,
             const float* W1, const float* C0, const float* C1, const float* PT, const float* C1T,
             const float* C0hT, const float* W1T, const float* W0gT, const float* dsdf,
             const float* drgb, float* dfeats, int nthreads) {
    const int64_t nblk = (n + LANES - 1) / LANES;
    #pragma omp parallel for num_threads(nthreads) schedule(static)
    for (int64_t b = 0; b < nblk; b++) {
        const int64_t i0 = b * LANES;
        const int cnt = (int)(n - i0 < LANES ? n - i0 : LANES);
        vf hid[GH], geo[GO], chid[CH], raw[3], dr[3], dchid[CH], dgeo[GO], dhid[GH], df[NG];
        const vf zero = {0};
        fwd_block(feats, pe, i0, cnt, W0, W1, C0, C1, PT, hid, geo, chid, raw);
        load_soa(drgb, 3, i0, cnt, dr);
        dense(dr, 3, C1T, CH, dchid, 0);
        for (int j = 0; j < CH; j++) { vi m = chid[j] > zero; dchid[j] = (vf)((vi)dchid[j] & m); }
        load_soa(dsdf, 1, i0, cnt, dgeo);
        dense(dchid, CH, C0hT, NH, dgeo + 1, 0);
        dense(dgeo, GO, W1T, GH, dhid, 0);
        for (int j = 0; j < GH; j++) { vi m = hid[j] > zero; dhid[j] = (vf)((vi)dhid[j] & m); }
        dense(dhid, GH, W0gT, NG, df, 0);
        store_soa(df, NG, i0, cnt, dfeats);
    }
}

/* mlp_bwd from the masks mlp_fwd_keep stored for the same n samples (no forward): the
   same operations in the same order as mlp_bwd, so the result is bit-identical. */
void mlp_bwd_masks(const vb* masks, int64_t n, const float* C1T, const float* C0hT,
                   const float* W1T, const float* W0gT, const float* dsdf, const float* drgb,
                   float* dfeats, int nthreads) {
    const int64_t nblk = (n + LANES - 1) / LANES;
    #pragma omp parallel for num_threads(nthreads) schedule(static)
    for (int64_t b = 0; b < nblk; b++) {
        const int64_t i0 = b * LANES;
        const int cnt = (int)(n - i0 < LANES ? n - i0 : LANES);
        vf dr[3], dchid[CH], dgeo[GO], dhid[GH], df[NG];
        const vb* mb = masks + b * NM;
        load_soa(drgb, 3, i0, cnt, dr);
        dense(dr, 3, C1T, CH, dchid, 0);
        for (int j = 0; j < CH; j++) dchid[j] = (vf)((vi)dchid[j] & __builtin_convertvector(mb[GH + j], vi));
        load_soa(dsdf, 1, i0, cnt, dgeo);
        dense(dchid, CH, C0hT, NH, dgeo + 1, 0);
        dense(dgeo, GO, W1T, GH, dhid, 0);
        for (int j = 0; j < GH; j++) dhid[j] = (vf)((vi)dhid[j] & __builtin_convertvector(mb[j], vi));
        dense(dhid, GH, W0gT, NG, df, 0);
        store_soa(df, NG, i0, cnt, dfeats);
    }
}
