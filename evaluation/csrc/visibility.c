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

/* The per-point test: is the point (px, py, pz) seen by pose k (``m``: its rows of [R | t])?
 * Shared by both kernels so they decide every (point, pose) pair with the same arithmetic. */
static inline int seen_by(const double *m, int64_t k, double px, double py, double pz,
                          double fx, double fy, double cx, double cy, int width, int height,
                          double near, double far, const double *depth, int dh, int dw,
                          int stride, int measured, double eps)
{
    const double z = m[8] * px + m[9] * py + m[10] * pz + m[11];
    if (!(z >= near && z <= far))
        return 0;
    const double u = fx * (m[0] * px + m[1] * py + m[2] * pz + m[3]) / z + cx;
    if (!(u >= 0.0 && u < (double)width))
        return 0;
    const double v = fy * (m[4] * px + m[5] * py + m[6] * pz + m[7]) / z + cy;
    if (!(v >= 0.0 && v < (double)height))
        return 0;
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
            return 0;
    }
    return 1;
}

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
            /* rows of [R | t], row-major 3 x 4 */
            if (seen_by(w2c + 12 * k, k, px, py, pz, fx, fy, cx, cy, width, height, near, far,
                        depth, dh, dw, stride, measured, eps)) {
                seen[i] = 1;
                break;
            }
        }
    }
}

/* Unit normals (camera frame) of the frustum's four side planes: inside is n . p >= 0 for z > 0. */
static void side_planes(double fx, double fy, double cx, double cy, int width, int height, double side[4][3])
{
    const double W = (double)width, H = (double)height;
    const double nl = sqrt(fx * fx + cx * cx), nr = sqrt(fx * fx + (W - cx) * (W - cx));
    const double nt = sqrt(fy * fy + cy * cy), nb = sqrt(fy * fy + (H - cy) * (H - cy));
    const double s[4][3] = {{fx / nl, 0.0, cx / nl}, {-fx / nr, 0.0, (W - cx) / nr},
                            {0.0, fy / nt, cy / nt}, {0.0, -fy / nb, (H - cy) / nb}};
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 3; ++j)
            side[i][j] = s[i][j];
}

/* May pose k (``m``: its rows of [R | t]) see some point of the sphere (sx, sy, sz) of radius
 * ``rad`` (m, the margin included)? 0 only when no point of the sphere can pass seen_by(): the
 * sphere lies beyond the near or far plane or outside a side plane, or -- with depth images
 * and their block maxima ``cmax`` (n_poses, ch, cw), the largest depth (no surface or no
 * measurement: +inf) of each cb x cb block of depth pixels -- every point of the sphere lies
 * in the box centre +- rad, so it projects inside the pixel rectangle bounded below (the box's
 * x/z and y/z extremes, one pixel of slack each side) at a depth z >= qz - rad; if that is
 * beyond the largest depth of the blocks the rectangle touches (plus eps), the per-point test
 * fails for every point. One test for both kernels below, so they skip the same pairs. */
static inline int sphere_may_see(const double *m, int64_t k, double sx, double sy, double sz, double rad,
                                 const double side[4][3], double fx, double fy, double cx, double cy,
                                 int width, int height, double near, double far, const double *depth,
                                 int dh, int dw, int stride, double eps, const double *cmax, int ch,
                                 int cw, int cb)
{
    const double W = (double)width, H = (double)height;
    const double qz = m[8] * sx + m[9] * sy + m[10] * sz + m[11];
    if (qz + rad < near || qz - rad > far)
        return 0;
    const double qx = m[0] * sx + m[1] * sy + m[2] * sz + m[3];
    const double qy = m[4] * sx + m[5] * sy + m[6] * sz + m[7];
    for (int s = 0; s < 4; ++s)
        if (side[s][0] * qx + side[s][1] * qy + side[s][2] * qz < -rad)
            return 0;
    if (depth && cmax && qz - rad > 0.0) {
        const double zlo = qz - rad, zhi = qz + rad;
        const double xmin = fmin((qx - rad) / zlo, (qx - rad) / zhi);
        const double xmax = fmax((qx + rad) / zlo, (qx + rad) / zhi);
        const double ymin = fmin((qy - rad) / zlo, (qy - rad) / zhi);
        const double ymax = fmax((qy + rad) / zlo, (qy + rad) / zhi);
        const double u0 = fx * xmin + cx - 1.0, u1 = fx * xmax + cx + 1.0;
        const double v0 = fy * ymin + cy - 1.0, v1 = fy * ymax + cy + 1.0;
        if (u1 >= 0.0 && v1 >= 0.0 && u0 < W && v0 < H) {
            int64_t c0 = u0 > 0.0 ? (int64_t)u0 / stride : 0, c1 = u1 < W ? (int64_t)u1 / stride : dw - 1;
            int64_t r0 = v0 > 0.0 ? (int64_t)v0 / stride : 0, r1 = v1 < H ? (int64_t)v1 / stride : dh - 1;
            if (c1 > dw - 1) c1 = dw - 1;
            if (r1 > dh - 1) r1 = dh - 1;
            if (c0 > c1) c0 = c1;
            if (r0 > r1) r0 = r1;
            double maxd = -INFINITY;
            const double *cm = cmax + (int64_t)k * ch * cw;
            for (int64_t rr = r0 / cb; rr <= r1 / cb && maxd < INFINITY; ++rr)
                for (int64_t cc = c0 / cb; cc <= c1 / cb; ++cc)
                    if (cm[rr * cw + cc] > maxd)
                        maxd = cm[rr * cw + cc];
            if (zlo > maxd + eps)
                return 0;
        }
    }
    return 1;
}

/* Poses tried first for each cluster (see visible_clustered; 0: the poses in order only). */
#ifndef N_HINTS
#define N_HINTS 8
#endif

/* Pose k against one cluster (points i0 .. i1 of ``pts``, inside the sphere): nothing when
 * sphere_may_see() rules it out, else the per-point test on the points not yet seen, which it
 * marks; returns how many it marked. */
static inline int64_t cluster_pose(const double *m, int64_t k, const double *pts, int64_t i0, int64_t i1,
                                   double sx, double sy, double sz, double rad, const double side[4][3],
                                   double fx, double fy, double cx, double cy, int width, int height,
                                   double near, double far, const double *depth, int dh, int dw, int stride,
                                   int measured, double eps, const double *cmax, int ch, int cw, int cb,
                                   uint8_t *seen)
{
    if (!sphere_may_see(m, k, sx, sy, sz, rad, side, fx, fy, cx, cy, width, height, near, far, depth, dh, dw,
                        stride, eps, cmax, ch, cw, cb))
        return 0;
    int64_t hit = 0;
    for (int64_t i = i0; i < i1; ++i)
        if (!seen[i] && seen_by(m, k, pts[3 * i], pts[3 * i + 1], pts[3 * i + 2], fx, fy, cx, cy, width, height,
                                near, far, depth, dh, dw, stride, measured, eps)) {
            seen[i] = 1;
            ++hit;
        }
    return hit;
}

/* The same mask as visible(), with points grouped into spatial clusters (``start``: n_clusters
 * + 1 offsets into pts, whose points are ordered by cluster; ``sphere``: per cluster a centre
 * (m, world frame) and a radius (m) holding all its points). A pose whose viewing frustum
 * (near/far planes and the four side planes through the camera centre) leaves a cluster's
 * sphere entirely outside, by more than ``margin`` (m), cannot see any of its points and is
 * skipped for the whole cluster; the other poses run the per-point test of visible(),
 * unchanged. So the mask is visible()'s, while a point no camera sees (the usual case at the
 * end of a long run: surfaces a map made up where no one looked) costs one sphere test per
 * pose and cluster instead of one projection per pose and point. Each thread tries first the
 * N_HINTS poses that last saw a point (neighbouring clusters are usually seen by the same
 * camera): the same mask, 20-25 % less work on a 300-s house map (docs/BENCHMARKS.md). */
void visible_clustered(const double *pts, const int64_t *start, int64_t n_clusters,
                       const double *sphere, const double *w2c, int64_t n_poses,
                       double fx, double fy, double cx, double cy, int width, int height,
                       double near, double far, const double *depth, int dh, int dw, int stride,
                       int measured, double eps, double margin, const double *cmax, int ch, int cw,
                       int cb, uint8_t *seen, int nthreads)
{
    double side[4][3];
    side_planes(fx, fy, cx, cy, width, height, side);
#pragma omp parallel num_threads(nthreads)
    {
    /* The poses that last saw a point on this thread, most recent first: clusters come in
       spatial order, so the pose that saw the last cluster often sees the next one. They are
       tried first; the mask is an OR over poses, so the order changes the cost, not the result. */
    int64_t hint[N_HINTS > 0 ? N_HINTS : 1];
    for (int h = 0; h < N_HINTS; ++h)
        hint[h] = -1;
#pragma omp for schedule(dynamic, 4)
    for (int64_t c = 0; c < n_clusters; ++c) {
        const int64_t i0 = start[c], i1 = start[c + 1];
        int64_t left = 0;
        for (int64_t i = i0; i < i1; ++i)
            left += !seen[i];
        const double sx = sphere[4 * c], sy = sphere[4 * c + 1], sz = sphere[4 * c + 2];
        const double rad = sphere[4 * c + 3] + margin;
        int64_t tried[N_HINTS > 0 ? N_HINTS : 1];
        int n_tried = 0;
        for (int h = 0; h < N_HINTS && left > 0; ++h) {
            const int64_t k = hint[h];
            if (k < 0 || k >= n_poses)
                continue;
            tried[n_tried++] = k;
            const int64_t hit = cluster_pose(w2c + 12 * k, k, pts, i0, i1, sx, sy, sz, rad, side, fx, fy, cx, cy,
                                             width, height, near, far, depth, dh, dw, stride, measured, eps,
                                             cmax, ch, cw, cb, seen);
            left -= hit;
        }
        for (int64_t k = 0; k < n_poses && left > 0; ++k) {
            int again = 0;
            for (int h = 0; h < n_tried; ++h)
                again |= tried[h] == k;
            if (again)
                continue;
            const int64_t hit = cluster_pose(w2c + 12 * k, k, pts, i0, i1, sx, sy, sz, rad, side, fx, fy, cx, cy,
                                             width, height, near, far, depth, dh, dw, stride, measured, eps,
                                             cmax, ch, cw, cb, seen);
            if (hit) {
                left -= hit;
                if (N_HINTS > 0) {  /* k to the front */
                    for (int h = N_HINTS - 1; h > 0; --h)
                        hint[h] = hint[h - 1];
                    hint[0] = k;
                }
            }
        }
    }
    }
}

/* Spheres some pose may see (``may`` |= 1): for each sphere (centre m, radius m; ``margin`` m
 * added) not yet marked, the poses in order until sphere_may_see() holds for one -- the bound
 * visible_clustered() skips by, so a point inside a sphere left 0 is seen by none of the poses.
 * Marks only grow, so poses can be passed a batch at a time. */
void spheres_may_see(const double *sphere, int64_t n_spheres, const double *w2c, int64_t n_poses,
                     double fx, double fy, double cx, double cy, int width, int height,
                     double near, double far, const double *depth, int dh, int dw, int stride,
                     double eps, double margin, const double *cmax, int ch, int cw, int cb,
                     uint8_t *may, int nthreads)
{
    double side[4][3];
    side_planes(fx, fy, cx, cy, width, height, side);
#pragma omp parallel for schedule(dynamic, 64) num_threads(nthreads)
    for (int64_t c = 0; c < n_spheres; ++c) {
        if (may[c])
            continue;
        const double sx = sphere[4 * c], sy = sphere[4 * c + 1], sz = sphere[4 * c + 2];
        const double rad = sphere[4 * c + 3] + margin;
        for (int64_t k = 0; k < n_poses; ++k)
            if (sphere_may_see(w2c + 12 * k, k, sx, sy, sz, rad, side, fx, fy, cx, cy, width, height, near,
                               far, depth, dh, dw, stride, eps, cmax, ch, cw, cb)) {
                may[c] = 1;
                break;
            }
    }
}
