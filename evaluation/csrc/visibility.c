/* Visibility of points from camera poses (NICE-SLAM culling, docs/ALGORITHM.md section 5),
 * the hot loop of ramensim.evaluation.cull.visible_points.
 *
 * A point (metres, world frame) is seen by pose k when, with (x, y, z) = R_k p + t_k its
 * camera coordinates (OpenCV axes, m), near <= z <= far, the pixel (u, v) = (fx x / z + cx,
 * fy y / z + cy) lies in [0, width) x [0, height), and -- with depth images -- z <= d + eps
 * where d is the depth (m) at that pixel: rendered images are read at
 * (floor(v) / stride, floor(u) / stride) and an infinite d (no surface) never occludes;
 * measured images (stride 1) treat 0 and non-finite values as no measurement.
 *
 * Each point is tested against the poses in order until one sees it (so the cost falls as
 * coverage grows). Points are independent, so the result does not depend on the thread
 * count; the arithmetic is double precision without FMA contraction, in the order the
 * numpy path of cull.py uses.
 */
#include <math.h>
#include <stdint.h>

void visible(const double *pts, int64_t n, const double *w2c, int64_t n_poses,
             double fx, double fy, double cx, double cy, int width, int height,
             double near, double far, const double *depth, int dh, int dw, int stride,
             int measured, double eps, uint8_t *seen, int nthreads)
{
#pragma omp parallel for schedule(dynamic, 2048) num_threads(nthreads)
    for (int64_t i = 0; i < n; ++i) {
        if (seen[i])
            continue;
        const double px = pts[3 * i], py = pts[3 * i + 1], pz = pts[3 * i + 2];
        for (int64_t k = 0; k < n_poses; ++k) {
            const double *m = w2c + 12 * k; /* rows of [R | t], row-major 3 x 4 */
            const double z = m[8] * px + m[9] * py + m[10] * pz + m[11];
            if (!(z >= near && z <= far))
                continue;
            const double u = fx * (m[0] * px + m[1] * py + m[2] * pz + m[3]) / z + cx;
            if (!(u >= 0.0 && u < (double)width))
                continue;
            const double v = fy * (m[4] * px + m[5] * py + m[6] * pz + m[7]) / z + cy;
            if (!(v >= 0.0 && v < (double)height))
                continue;
            if (depth) {
                int64_t r = (int64_t)v / stride, c = (int64_t)u / stride;
                if (r > dh - 1)
                    r = dh - 1;
                if (c > dw - 1)
                    c = dw - 1;
                double d = depth[((int64_t)k * dh + r) * dw + c];
                if (measured && !(isfinite(d) && d > 0.0))
                    d = INFINITY;
                if (!(z <= d + eps))
                    continue;
            }
            seen[i] = 1;
            break;
        }
    }
}
