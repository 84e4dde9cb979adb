"""Benchmark of evaluation (docs/ALGORITHM.md section 5): mesh extraction of a room-sized analytic SDF
at 2 cm, the paper's metrics on a pair of ~500k-triangle meshes (goal <= 5 s on 2 cores), and
frustum / occlusion culling, with the visibility test's compiled kernel against its numpy path.

Run from the repository root:  PYTHONPATH=. python benchmarks/bench_eval.py

The analytic SDF costs almost nothing per point; with a neural map the extraction time is
dominated by the map's own query cost (grid points / map queries per second), which its
own benchmark measures.
"""
from __future__ import annotations

import os
import time

import numpy as np

from benchmarks._machine import machine_info
from ramensim.evaluation import _native
from ramensim.evaluation.cull import OccluderDepths, PinholeCamera, cull_to_views, visible_points
from ramensim.evaluation.mesh import extract_mesh, grid_shape
from ramensim.evaluation.metrics import mesh_metrics

ROOM = np.array([6.0, 5.0, 3.0])  # m
BOUNDS = np.array([[-0.1, -0.1, -0.1], ROOM + 0.1])


def _box(p: np.ndarray, centre, half) -> np.ndarray:
    q = np.abs(p - np.asarray(centre)) - np.asarray(half)
    return np.linalg.norm(np.maximum(q, 0.0), axis=1) + np.minimum(q.max(axis=1), 0.0)


def room_sdf(p: np.ndarray, shift: float = 0.0) -> np.ndarray:
    """Signed distance (m) of a 6 x 5 x 3 m room (free space positive) with a table, a cabinet
    and a ball; ``shift`` moves the furniture along x (m) to make a 'reconstruction'."""
    p = p.astype(np.float64)
    walls = -_box(p, ROOM / 2, ROOM / 2)
    table = _box(p, (2.0 + shift, 2.5, 0.4), (0.8, 0.5, 0.4))
    cabinet = _box(p, (5.4 + shift, 1.0, 0.9), (0.3, 0.6, 0.9))
    ball = np.linalg.norm(p - (3.5 + shift, 3.8, 0.5), axis=1) - 0.5
    return np.minimum(np.minimum(walls, table), np.minimum(cabinet, ball))


def room_rgb(p: np.ndarray) -> np.ndarray:
    return np.clip(p / ROOM, 0.0, 1.0)


def _time(fn, repeats: int = 1):
    best, out = float("inf"), None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        best = min(best, time.perf_counter() - t0)
    return best, out


def main() -> None:
    print(f"load average before start: {os.getloadavg()[0]:.1f} (other processes share the cores)")
    shape = grid_shape(BOUNDS, 0.02)
    n_grid = int(np.prod(shape))
    sdf_time = [0.0]

    def timed_sdf(p: np.ndarray) -> np.ndarray:
        t0 = time.perf_counter()
        out = room_sdf(p)
        sdf_time[0] += time.perf_counter() - t0
        return out

    t_ex, gt = _time(lambda: extract_mesh(timed_sdf, BOUNDS, 0.02, color_fn=room_rgb, chunk=262_144))
    print(f"extract_mesh 6x5x3 m room at 2 cm: grid {shape} = {n_grid / 1e6:.1f} M points, "
          f"{len(gt.faces) / 1e3:.0f} k faces, {t_ex:.2f} s total, of which {sdf_time[0]:.2f} s in the "
          f"analytic SDF (a neural map's query cost replaces that part)")

    recon = extract_mesh(lambda p: room_sdf(p, shift=0.03), BOUNDS, 0.02, chunk=262_144)
    print(f"metric meshes: recon {len(recon.faces) / 1e3:.0f} k faces, gt {len(gt.faces) / 1e3:.0f} k faces")
    t_m, res = _time(lambda: mesh_metrics(recon, gt, n_samples=200_000, seed=0), repeats=3)
    print(f"mesh_metrics 200k samples each: {t_m:.2f} s (goal <= 5 s)  -> artifacts {res['artifacts_cm']:.3f} cm, "
          f"holes {res['holes_cm']:.3f} cm, completion {res['completion_ratio_pct']:.2f} %")

    cam = PinholeCamera(fx=600.0, fy=600.0, cx=599.5 / 2, cy=339.5 / 2, width=600, height=340)
    poses = []
    for yaw in np.linspace(0.0, 2 * np.pi, 100, endpoint=False):
        c2w = np.eye(4)
        fwd = np.array([np.cos(yaw), np.sin(yaw), 0.0])
        down = np.array([0.0, 0.0, -1.0])
        right = np.cross(down, fwd)
        c2w[:3, :3] = np.stack([right, down, fwd], axis=1)
        c2w[:3, 3] = (1.5, 1.5, 1.5)
        poses.append(c2w)
    poses = np.stack(poses)
    t_f, culled = _time(lambda: cull_to_views(gt, poses, cam))
    print(f"frustum cull, {len(poses)} poses: {t_f:.2f} s ({len(gt.faces) / 1e3:.0f} k -> "
          f"{len(culled.faces) / 1e3:.0f} k faces)")
    t_o, occl = _time(lambda: cull_to_views(gt, poses[::5], cam, occluder=gt, stride=4))
    print(f"frustum+occlusion cull, {len(poses[::5])} poses, depth rendered every 4 px: {t_o:.2f} s "
          f"({len(gt.faces) / 1e3:.0f} k -> {len(occl.faces) / 1e3:.0f} k faces)")
    # the visibility test alone, compiled kernel against the numpy path (same masks)
    depths = OccluderDepths(gt, cam, 4)
    for c2w in poses:
        depths(c2w)  # rendered once, as the evaluator shares them across a run
    verts = np.asarray(gt.vertices)
    for what, kw in (("frustum, 100 poses", {}), ("frustum+occlusion, 100 poses", {"occluder": depths})):
        t_np, m_np = _time(lambda: visible_points(verts, poses, cam, native=False, **kw))
        if _native.get_lib() is None:
            print(f"visibility of {len(verts) / 1e3:.0f} k vertices, {what}: numpy {t_np:.3f} s (no C kernel)")
            continue
        t_c, m_c = _time(lambda: visible_points(verts, poses, cam, native=True, **kw), repeats=3)
        print(f"visibility of {len(verts) / 1e3:.0f} k vertices, {what}: numpy {t_np:.3f} s, C kernel "
              f"{t_c:.3f} s ({t_np / t_c:.1f}x; masks equal: {bool((m_np == m_c).all())})")
    print(machine_info())


if __name__ == "__main__":
    main()
