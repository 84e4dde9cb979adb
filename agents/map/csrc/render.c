/* Rendering: the training rays' sample depths and positions (ray_samples) and the
   rendering + observation losses with their gradients (render_loss).
   Built with the other files of this folder into one shared object by _native.py (gcc,
   -fopenmp, -ffp-contract=off); called through ctypes on the raw storage of contiguous CPU
   float32 / int32 tensors; ``nthreads`` is torch's intra-op thread count. */
#include <stdint.h>
#include <math.h>
#ifdef _OPENMP
#include <omp.h>
#endif

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
