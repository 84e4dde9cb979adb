"""Benchmark: one 640x480 RGB-D frame of a ~100k-triangle scene (Embree ray casting,
barycentric colour). Goal: <= 50 ms per frame on a 2-core CPU.

    PYTHONPATH=. python benchmarks/bench_render.py
"""
from __future__ import annotations

import time

import numpy as np
import trimesh

from ramensim.core.frames import Intrinsics
from benchmarks._machine import machine_info
from ramensim.world.camera import RGBDCamera
from ramensim.world.scenes import builtin_scene
from ramensim.world.trajectories import look_rotation


def main() -> None:
    scene = builtin_scene("office", 0)
    mesh = scene.mesh
    # split long edges until the scene has about 100k triangles (uniform, well-shaped ones)
    for edge in (0.4, 0.3, 0.22, 0.17, 0.13, 0.1):
        v, f, idx = trimesh.remesh.subdivide_to_size(mesh.vertices, mesh.faces, max_edge=edge, return_index=True)
        if len(f) >= 100_000:
            break
    sub = trimesh.Trimesh(v, f, process=False)
    # vertex colours: nearest original vertex of the source face (a faithful enough copy)
    src = mesh.faces[idx]
    d = np.linalg.norm(mesh.vertices[src][:, :, None, :] - v[f][:, None, :, :], axis=-1)  # (F, 3 src, 3 new)
    vc = np.zeros((len(v), 4), np.uint8)
    vc[f.ravel()] = mesh.visual.vertex_colors[np.take_along_axis(src, d.argmin(1), 1)].reshape(-1, 4)
    sub.visual = trimesh.visual.ColorVisuals(sub, vertex_colors=vc)
    mesh = sub
    K = Intrinsics(480.0, 480.0, 319.5, 239.5, 640, 480)
    t0 = time.perf_counter()
    cam = RGBDCamera(mesh, K)
    c2w = np.eye(4)
    c2w[:3, :3] = look_rotation(np.array([1.0, 0.4, 0.0]), np.deg2rad(-12))
    c2w[:3, 3] = [1.5, 2.5, 1.4]
    cam.render(c2w)  # builds the BVH
    setup = time.perf_counter() - t0
    times = []
    for k in range(20):
        c2w[:3, :3] = look_rotation(np.array([np.cos(0.3 * k), np.sin(0.3 * k), 0.0]), np.deg2rad(-12))
        t = time.perf_counter()
        f = cam.render(c2w)
        times.append(time.perf_counter() - t)
    ms = np.array(times) * 1e3
    print(f"render 640x480 RGB-D, {len(mesh.faces)} triangles, backend {cam.backend}, "
          f"{cam.caster.threads} threads")
    print(f"  first frame incl. BVH build: {setup * 1e3:.0f} ms")
    print(f"  per frame: median {np.median(ms):.1f} ms, min {ms.min():.1f} ms, max {ms.max():.1f} ms "
          f"(goal <= 50 ms); valid depth {np.mean(f.depth > 0):.3f}")
    print(machine_info())


if __name__ == "__main__":
    main()
