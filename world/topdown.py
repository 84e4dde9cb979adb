"""Top-down picture of a world: the scene seen from above with its ceiling cut away
(orthographic rays cast down from below the ceiling, coloured like the mesh and shaded by
height) and every agent's trajectory in its own colour."""
from __future__ import annotations

import numpy as np

from ramensim.world.camera import MeshColors, MeshRayCaster
from ramensim.world.scenes import Scene
from ramensim.world.trajectories import Trajectory


def topdown_image(scene: Scene, res: float = 0.02, cut: float | None = None,
                  caster: MeshRayCaster | None = None) -> tuple[np.ndarray, tuple[float, float, float, float]]:
    """RGB image (H, W, 3) float in [0, 1] of ``scene`` from above, ``res`` metres per pixel,
    cut at height ``cut`` (m; default 80 % of the way from floor to ceiling of the bounds, at
    most 2.25 m above their bottom, so that doorways (2.1 m high) show as gaps in the walls).
    Points inside walls (rays start inside solid) are drawn dark grey. Returns the image and
    its extent (xmin, xmax, ymin, ymax) in metres for ``imshow``."""
    b = scene.bounds
    caster = caster or MeshRayCaster(scene.mesh)
    colors = MeshColors(scene.mesh)
    z_cut = cut if cut is not None else b[0, 2] + min(0.8 * (b[1, 2] - b[0, 2]), 2.25)
    xs = np.arange(b[0, 0], b[1, 0], res) + res / 2
    ys = np.arange(b[0, 1], b[1, 1], res) + res / 2
    X, Y = np.meshgrid(xs, ys[::-1])
    o = np.stack([X.ravel(), Y.ravel(), np.full(X.size, z_cut)], axis=1)
    d = np.tile([0.0, 0.0, -1.0], (X.size, 1))
    s, tri, bu, bv = caster.cast(o, d)
    hit = tri >= 0
    img = np.ones((X.size, 3))
    img[hit] = colors.lookup(tri[hit], bu[hit], bv[hit])
    zn = np.where(hit, (z_cut - s - b[0, 2]) / max(b[1, 2] - b[0, 2], 1e-6), 0.0)
    img[hit] *= (0.55 + 0.45 * np.clip(zn[hit] / 0.8, 0, 1))[:, None]  # lower = darker
    solid = hit & (scene.mesh.face_normals[np.maximum(tri, 0), 2] < -0.5)
    img[solid] = 0.25
    return np.clip(img, 0, 1).reshape(X.shape + (3,)), (b[0, 0], b[1, 0], b[0, 1], b[1, 1])


def draw_world(ax, scene: Scene | None, trajectories: list[Trajectory], times: np.ndarray | None = None,
               title: str | None = None, caster: MeshRayCaster | None = None) -> None:
    """Draw the top-down scene (if any) and each trajectory (agent i in colour C<i>, a dot
    at its start) on matplotlib axes ``ax``; axes in metres."""
    if scene is not None:
        img, ext = topdown_image(scene, caster=caster)
        ax.imshow(img, extent=ext, interpolation="nearest")
    for i, tr in enumerate(trajectories):
        ts = times if times is not None else np.linspace(tr.times[0], tr.times[-1], 600)
        p = tr.positions_at(ts)
        c = f"C{i % 10}"
        ax.plot(p[:, 0], p[:, 1], "-", color=c, lw=1.6, label=f"agent {i}")
        ax.plot(p[0, 0], p[0, 1], "o", color=c, ms=6, mec="k")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    if trajectories:
        ax.legend(loc="upper right", fontsize=8, framealpha=0.8)
    if title:
        ax.set_title(title)


def save_world_png(path, scene: Scene | None, trajectories: list[Trajectory], title: str | None = None,
                   caster: MeshRayCaster | None = None, duration: float | None = None) -> None:
    """Write the top-down picture of :func:`draw_world` to a PNG file."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    from matplotlib.figure import Figure

    fig = Figure(figsize=(7, 6), dpi=110)
    ax = fig.add_subplot(1, 1, 1)
    times = np.linspace(0, duration, 800) if duration else None
    draw_world(ax, scene, trajectories, times, title, caster)
    fig.tight_layout()
    fig.savefig(path)
