"""A small OpenMP C kernel for the map's hot path, built with gcc at first use.

Holds: hash-grid encoding forward (eq. of ALGORITHM.md section 1), its backward (a
scatter into the flat table, parallel over levels so no two threads touch the same
entries and the sum order is fixed: deterministic), OneBlob, a fused Adam step and the
visit counter of eq. 18. Called through ``ctypes`` on the raw storage of contiguous
CPU float32 / int32 tensors. The shared object is cached under
``$RAMENSIM_CACHE_DIR`` (default ``~/.cache/ramensim``), keyed by the source, the flags
and the CPU model. Anything that goes wrong (no gcc, no write access, a failed load)
gives ``None`` and the callers use the pure-torch path; ``RAMENSIM_NO_NATIVE=1`` forces
that path.

The kernel links ``libgomp.so.1``; torch (imported first) already loaded its own copy
under that soname, so both share one OpenMP runtime and thread pool.
"""
from __future__ import annotations

import ctypes
import hashlib
import logging
import os
import subprocess
import tempfile
from pathlib import Path

import torch

log = logging.getLogger(__name__)

_SOURCE = r"""
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
            float c[129];
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
"""

_FLAGS = ["-O3", "-march=native", "-ffp-contract=off", "-fno-math-errno", "-fopenmp",
          "-shared", "-fPIC"]

_lib: ctypes.CDLL | None = None
_tried = False


def _cpu_model() -> str:
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as fh:
            for line in fh:
                if line.startswith(("model name", "flags")):
                    return line
    except OSError:
        pass
    return ""


def _compile(source: str, name: str, flags: list[str] | None = None) -> ctypes.CDLL:
    """Compile ``source`` into the cache (once per source, flags and CPU) and load it."""
    flags = flags or _FLAGS
    key = hashlib.sha256((source + " ".join(flags) + _cpu_model()).encode()).hexdigest()[:16]
    cache = Path(os.environ.get("RAMENSIM_CACHE_DIR", Path.home() / ".cache" / "ramensim"))
    cache = cache / "native"
    cache.mkdir(parents=True, exist_ok=True)
    so_path = cache / f"{name}_{key}.so"
    if not so_path.exists():
        with tempfile.TemporaryDirectory(dir=cache) as tmp:
            src = Path(tmp) / "mapkernels.c"
            src.write_text(source, encoding="utf-8")
            out = Path(tmp) / "mapkernels.so"
            cmd = [os.environ.get("CC", "gcc"), *flags, str(src), "-o", str(out), "-lm"]
            res = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
            if res.returncode != 0:
                raise RuntimeError(f"gcc failed: {res.stderr.strip()[:2000]}")
            os.replace(out, so_path)  # atomic: parallel builders never see half a file
        log.info("built map kernels into %s", so_path)
    return ctypes.CDLL(str(so_path))


def _build() -> ctypes.CDLL:
    lib = _compile(_SOURCE, "mapkernels")
    P, I64, I = ctypes.c_void_p, ctypes.c_int64, ctypes.c_int
    Fl = ctypes.c_float
    lib.hash_fwd.argtypes = [P, I64, P, I, I, I64, P, P, P, P, I]
    lib.hash_bwd.argtypes = [P, I64, P, I, I, I64, P, P, P, P, I]
    lib.oneblob.argtypes = [P, I64, I, P, I]
    lib.adam_step.argtypes = [P, P, P, P, I64, Fl, Fl, Fl, Fl, Fl, Fl, I]
    lib.count_visits.argtypes = [P, P, I64, I]
    for fn in (lib.hash_fwd, lib.hash_bwd, lib.oneblob, lib.adam_step, lib.count_visits):
        fn.restype = None
    return lib


def get_lib() -> ctypes.CDLL | None:
    """The compiled kernels, building them on first use; ``None`` if unavailable."""
    global _lib, _tried
    if _tried:
        return _lib
    _tried = True
    if os.environ.get("RAMENSIM_NO_NATIVE", "") not in ("", "0"):
        log.info("RAMENSIM_NO_NATIVE set: using the pure-torch map kernels")
        return None
    try:
        _lib = _build()
    except Exception as exc:  # noqa: BLE001 - any failure means: use the torch path
        log.warning("native map kernels unavailable (%s); using the pure-torch path", exc)
        _lib = None
    return _lib


def ptr(t: torch.Tensor) -> int:
    """Address of a contiguous CPU tensor's first element."""
    return t.data_ptr()


def nthreads() -> int:
    """Threads the kernels use: torch's intra-op thread count."""
    return max(1, torch.get_num_threads())


_MLP_SOURCE = r"""
#include <stdint.h>
/* Sizes are compile-time constants (one shared object per decoder shape):
   NG grid features, NP OneBlob features, GH geometry hidden, GO geometry outputs (1 + h),
   CH colour hidden. Samples are processed 16 at a time in structure-of-arrays form
   (one vector lane per sample), so every layer is a run of independent vector FMAs. */
#define NH (GO - 1)
#define LANES 16
typedef float vf __attribute__((vector_size(64)));
typedef int32_t vi __attribute__((vector_size(64)));

/* Y[j] = sum_k W[j*K + k] X[k] (W row-major J x K), optional ReLU. */
static inline void dense(const vf* X, int K, const float* W, int J, vf* Y, int relu) {
    int j = 0;
    for (; j + 8 <= J; j += 8) {
        vf a0 = {0}, a1 = {0}, a2 = {0}, a3 = {0}, a4 = {0}, a5 = {0}, a6 = {0}, a7 = {0};
        const float* w = W + j * K;
        for (int k = 0; k < K; k++) {
            const vf x = X[k];
            a0 += w[k] * x; a1 += w[K + k] * x; a2 += w[2 * K + k] * x; a3 += w[3 * K + k] * x;
            a4 += w[4 * K + k] * x; a5 += w[5 * K + k] * x; a6 += w[6 * K + k] * x;
            a7 += w[7 * K + k] * x;
        }
        Y[j] = a0; Y[j + 1] = a1; Y[j + 2] = a2; Y[j + 3] = a3;
        Y[j + 4] = a4; Y[j + 5] = a5; Y[j + 6] = a6; Y[j + 7] = a7;
    }
    for (; j < J; j++) {
        vf a = {0};
        const float* w = W + j * K;
        for (int k = 0; k < K; k++) a += w[k] * X[k];
        Y[j] = a;
    }
    if (relu) {
        const vf zero = {0};
        for (int q = 0; q < J; q++) { vi m = Y[q] > zero; Y[q] = (vf)((vi)Y[q] & m); }
    }
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

static inline void fwd_block(const float* feats, const float* pe, int64_t i0, int cnt,
                             const float* W0, const float* W1, const float* C0,
                             const float* C1, vf* hid, vf* geo, vf* chid, vf* raw) {
    vf x[NG + NP], xc[NP + NH];
    load_soa(feats, NG, i0, cnt, x);
    load_soa(pe, NP, i0, cnt, x + NG);
    dense(x, NG + NP, W0, GH, hid, 1);
    dense(hid, GH, W1, GO, geo, 0);
    for (int k = 0; k < NP; k++) xc[k] = x[NG + k];
    for (int k = 0; k < NH; k++) xc[NP + k] = geo[1 + k];
    dense(xc, NP + NH, C0, CH, chid, 1);
    dense(chid, CH, C1, 3, raw, 0);
}

void mlp_fwd(const float* feats, const float* pe, int64_t n, const float* W0,
             const float* W1, const float* C0, const float* C1, float* sdf, float* rgb,
             int nthreads) {
    const int64_t nblk = (n + LANES - 1) / LANES;
    #pragma omp parallel for num_threads(nthreads) schedule(static)
    for (int64_t b = 0; b < nblk; b++) {
        const int64_t i0 = b * LANES;
        const int cnt = (int)(n - i0 < LANES ? n - i0 : LANES);
        vf hid[GH], geo[GO], chid[CH], raw[3];
        fwd_block(feats, pe, i0, cnt, W0, W1, C0, C1, hid, geo, chid, raw);
        store_soa(geo, 1, i0, cnt, sdf);
        store_soa(raw, 3, i0, cnt, rgb);
    }
}

/* d(loss)/d(grid features) from d(loss)/d(sdf) and d(loss)/d(raw colour), recomputing
   the forward pass for the ReLU masks. C1T (CH,3), C0hT (NH,CH), W1T (GH,GO), W0gT (NG,GH)
   are the transposed matrices (colour-layer-0's h columns, geometry-layer-0's grid columns). */
void mlp_bwd(const float* feats, const float* pe, int64_t n, const float* W0,
             const float* W1, const float* C0, const float* C1, const float* C1T,
             const float* C0hT, const float* W1T, const float* W0gT, const float* dsdf,
             const float* drgb, float* dfeats, int nthreads) {
    const int64_t nblk = (n + LANES - 1) / LANES;
    #pragma omp parallel for num_threads(nthreads) schedule(static)
    for (int64_t b = 0; b < nblk; b++) {
        const int64_t i0 = b * LANES;
        const int cnt = (int)(n - i0 < LANES ? n - i0 : LANES);
        vf hid[GH], geo[GO], chid[CH], raw[3], dr[3], dchid[CH], dgeo[GO], dhid[GH], df[NG];
        const vf zero = {0};
        fwd_block(feats, pe, i0, cnt, W0, W1, C0, C1, hid, geo, chid, raw);
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
"""

_mlp_libs: dict[tuple[int, ...], ctypes.CDLL | None] = {}


def get_mlp_lib(ng: int, np_: int, gh: int, go: int, ch: int) -> ctypes.CDLL | None:
    """Fused decoder kernels compiled for these sizes; ``None`` if unavailable."""
    key = (ng, np_, gh, go, ch)
    if key in _mlp_libs:
        return _mlp_libs[key]
    lib = None
    if get_lib() is not None:
        src = (f"#define NG {ng}\n#define NP {np_}\n#define GH {gh}\n#define GO {go}\n"
               f"#define CH {ch}\n") + _MLP_SOURCE
        try:
            # FMA contraction allowed here (results are checked against torch to 1e-5)
            flags = [f if f != "-ffp-contract=off" else "-ffp-contract=fast" for f in _FLAGS]
            lib = _compile(src, "mapmlp", flags)
            P, I64, I = ctypes.c_void_p, ctypes.c_int64, ctypes.c_int
            lib.mlp_fwd.argtypes = [P, P, I64, P, P, P, P, P, P, I]
            lib.mlp_bwd.argtypes = [P, P, I64, P, P, P, P, P, P, P, P, P, P, P, I]
            lib.mlp_fwd.restype = lib.mlp_bwd.restype = None
        except Exception as exc:  # noqa: BLE001 - fall back to torch decoders
            log.warning("fused decoder kernel unavailable (%s); using torch decoders", exc)
            lib = None
    _mlp_libs[key] = lib
    return lib
