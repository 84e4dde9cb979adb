"""Split 'chunks': one open tour through every room of the scene (:func:`chunk_tour`), cut by
arc length into one contiguous chunk per agent, each walked back and forth. Metres, seconds.
"""
from __future__ import annotations

import itertools
import logging
from dataclasses import dataclass

import numpy as np
from scipy import ndimage
from scipy.sparse.csgraph import dijkstra

from ramensim.core.errors import InputError
from ramensim.world.trajectories.freespace import FreeSpace, _grid_graph, _poses_along, _smooth
from ramensim.world.trajectories.poses import Trajectory

log = logging.getLogger(__name__)


# ----------------------------------------------------------------------------- split 'chunks'
STRUCTURE_HEIGHT = 1.9  # m above the floor: rooms are found in the open space at this height (walls, no furniture)
ROOM_CLEARANCE = 0.55   # m; open cells this far from walls are room cores (doorways < 1.1 m wide separate them)
MIN_ROOM_AREA = 1.0    # m^2; smaller seed areas are not rooms of their own
MIN_CHUNK_M = 0.5      # m; shortest chunk of the tour an agent may be given
END_TURN_M = 1.5       # m; before a cut to a teammate's chunk the camera turns to its room's centre
TOUR_ROOMS = "tour_rooms"
"""Key of a scene mesh's ``metadata`` under which the scene may declare the rooms of the tour:
floor rectangles (x0, y0, x1, y1) in metres, for an open-plan scene whose walls do not cut it into
parts (the warehouse declares its aisles); without it the rooms are found from the walls."""


@dataclass
class Tour:
    """One walk through the whole free space of a scene (split 'chunks').

    ``path`` (M, 2) m, a point every ~5 cm; ``arc`` (M,) m, arc length from the start;
    ``rooms`` (ny, nx) int, the room of every free cell of ``fs`` (-1 elsewhere; rooms =
    free areas separated by walls and doorways); ``centres`` (R, 2)
    m, the centre of each room; ``order``: the rooms in the order the tour visits them;
    ``path_room`` (M,) int, the room of each path point.
    """

    path: np.ndarray
    arc: np.ndarray
    rooms: np.ndarray
    centres: np.ndarray
    order: list[int]
    path_room: np.ndarray
    fs: FreeSpace

    @property
    def length(self) -> float:
        """Arc length of the whole tour (m)."""
        return float(self.arc[-1])

    @property
    def doorways(self) -> np.ndarray:
        """Arc lengths (m) where the tour passes from one room into the next."""
        k = np.nonzero(np.diff(self.path_room) != 0)[0]
        return 0.5 * (self.arc[k] + self.arc[k + 1])

    def edges(self, n: int, snap: float = 0.0) -> np.ndarray:
        """Arc lengths (n + 1,) m cutting the tour into ``n`` contiguous chunks of equal length
        L / n, except that each cut moves onto the nearest doorway within ``snap`` L / n of it
        (so a robot's chunk ends at a door rather than a little way into the next room) where
        every chunk keeps at least half the equal length. Strictly increasing."""
        e = np.linspace(0.0, self.length, n + 1)
        doors = self.doorways
        step = self.length / n
        if n > 1 and len(doors) and snap > 0:
            for k in range(1, n):
                j = int(np.argmin(np.abs(doors - e[k])))
                d = float(doors[j])
                # with snap <= 0.5 the chunk after this cut keeps at least half a chunk too
                if abs(d - e[k]) <= min(snap, 0.5) * step and d - e[k - 1] >= 0.5 * step:
                    e[k] = d
        return e

    def at(self, s) -> np.ndarray:
        """Points (K, 2) m at arc lengths ``s`` (K,) m (clipped to the tour)."""
        s = np.asarray(s, np.float64)
        return np.stack([np.interp(s, self.arc, self.path[:, k]) for k in range(2)], axis=-1)

    def room_at(self, s) -> np.ndarray:
        """Room index (K,) of the tour at arc lengths ``s`` (K,) m."""
        k = np.clip(np.searchsorted(self.arc, np.asarray(s, np.float64)), 0, len(self.arc) - 1)
        return self.path_room[k]


def _structure_free(caster, fs: FreeSpace, height: float = STRUCTURE_HEIGHT) -> np.ndarray:
    """(ny, nx) bool: the cells of ``fs``'s grid that are open at ``height`` m above the floor
    (a ray down meets an upward-facing surface, a ray up a downward-facing one), i.e. not
    inside walls or full-height structure. Below doorway lintels and above most furniture,
    so rooms there are empty rectangles joined by their doorways."""
    ny, nx = fs.shape
    J, I = np.indices(fs.shape)
    xy = fs.centre(J.ravel(), I.ravel())
    o = np.column_stack([xy, np.full(len(xy), fs.floor_z + height)])
    down = np.tile([0.0, 0.0, -1.0], (len(o), 1))
    _, tri_dn, _, _ = caster.cast(o, down)
    _, tri_up, _, _ = caster.cast(o, -down)
    nz = caster.mesh.face_normals[:, 2]
    ok = (tri_dn >= 0) & (tri_up >= 0)
    open_ = ok & (nz[np.maximum(tri_dn, 0)] > 0.5) & (nz[np.maximum(tri_up, 0)] < -0.5)
    if not open_.any():  # inconsistent winding: accept either facing
        open_ = ok & (np.abs(nz[np.maximum(tri_dn, 0)]) > 0.5) & (np.abs(nz[np.maximum(tri_up, 0)]) > 0.5)
    return open_.reshape(ny, nx)


def _segment_rooms(caster, fs: FreeSpace) -> tuple[np.ndarray, np.ndarray]:
    """Rooms of the free space, from the structure (walls) only: the open cells at
    STRUCTURE_HEIGHT at least ROOM_CLEARANCE from a wall form connected areas (a doorway
    narrower than twice that cuts them apart); those of at least MIN_ROOM_AREA are the rooms'
    cores, and every walkable cell joins the core nearest to it along the open space.
    Returns the (ny, nx) room map (-1 off the walkable space) and the rooms' centres (R, 2) m
    (mean of their walkable cells)."""
    struct = _structure_free(caster, fs) | fs.free
    clear = ndimage.distance_transform_edt(struct) * fs.res
    seeds = struct & (clear >= ROOM_CLEARANCE)
    lab, nlab = ndimage.label(seeds, structure=np.ones((3, 3)))
    sizes = ndimage.sum(seeds, lab, index=np.arange(1, nlab + 1)) * fs.res ** 2 if nlab else np.zeros(0)
    keep = [k + 1 for k in range(nlab) if sizes[k] >= MIN_ROOM_AREA]
    seed_lab = np.full(fs.shape, -1, np.int64)
    for r, k in enumerate(keep):
        seed_lab[lab == k] = r
    return _grow_rooms(fs, struct, seed_lab, len(keep))


def _declared_rooms(fs: FreeSpace, rects) -> tuple[np.ndarray, np.ndarray]:
    """The rooms a scene declares (``mesh.metadata[TOUR_ROOMS]``): the walkable cells inside
    rectangle k (x0, y0, x1, y1) m are room k's core (a cell inside several: the first), and
    every other walkable cell joins the core nearest to it along the free space. Returns what
    :func:`_segment_rooms` returns."""
    J, I = np.indices(fs.shape)
    xy = fs.centre(J, I)
    seed_lab = np.full(fs.shape, -1, np.int64)
    for r, (x0, y0, x1, y1) in enumerate(rects):
        inside = (xy[..., 0] >= x0) & (xy[..., 0] <= x1) & (xy[..., 1] >= y0) & (xy[..., 1] <= y1)
        seed_lab[fs.free & inside & (seed_lab < 0)] = r
    return _grow_rooms(fs, fs.free, seed_lab, len(rects))


def _grow_rooms(fs: FreeSpace, mask: np.ndarray, seed_lab: np.ndarray, n_seeds: int) -> tuple[np.ndarray, np.ndarray]:
    """Every cell of ``mask`` joins the core (``seed_lab`` = 0 .. n_seeds - 1, -1 elsewhere)
    nearest to it along ``mask``; the room map keeps the walkable cells of ``fs`` (-1
    elsewhere), renumbered over the rooms that have any (all of them one room when none has),
    with the rooms' centres (R, 2) m (mean of their walkable cells)."""
    g, idx = _grid_graph(mask)
    rooms = np.full(fs.shape, -1, np.int64)
    if np.any(seed_lab >= 0):
        dist, _, sources = dijkstra(g, indices=idx[seed_lab >= 0], min_only=True, return_predecessors=True)
        jj, ii = np.nonzero(mask)
        reach = np.isfinite(dist)
        rooms[jj[reach], ii[reach]] = seed_lab[mask][sources[reach]]
    rooms[~fs.free] = -1
    present = [r for r in range(n_seeds) if np.any(rooms == r)]
    if not present:  # no spacious area: the whole walkable space is one room
        rooms = np.where(fs.free, 0, -1)
        present = [0] if fs.free.any() else []
    if not present:
        raise InputError("no free floor area was found for a procedural trajectory (the scene is too cluttered "
                         "or too small); lower world.trajectory.clearance or give trajectory files.")
    remap = np.full(max(present) + 2, -1, np.int64)
    remap[np.asarray(present)] = np.arange(len(present))
    rooms = np.where(rooms >= 0, remap[rooms], -1)
    centres = np.stack([fs.centre(*np.nonzero(rooms == r)).mean(axis=0) for r in range(len(present))])
    return rooms, centres


def _weighted_graph(mask: np.ndarray, clearance: np.ndarray, want: float):
    """:func:`_grid_graph` of ``mask`` whose edges cost more near obstacles (up to 3x at no
    clearance, 1x at ``want`` metres or more), so shortest paths keep to the middle of
    passages and doorways."""
    g, idx = _grid_graph(mask)
    cl = clearance[mask]
    rows = np.repeat(np.arange(g.shape[0]), np.diff(g.indptr))
    c = np.minimum(cl[rows], cl[g.indices])
    g.data = g.data * (1.0 + 2.0 * np.clip(1.0 - c / want, 0.0, 1.0))
    return g, idx


def _farthest_points(pts: np.ndarray, n: int, rng: np.random.Generator) -> list[int]:
    """``n`` spread-out indices into ``pts`` (farthest-point sampling from a random start,
    each pick random among the farthest 10 %)."""
    chosen = [int(rng.integers(len(pts)))]
    dmin = np.linalg.norm(pts - pts[chosen[0]], axis=1)
    for _ in range(min(n, len(pts)) - 1):
        far = np.argsort(dmin, kind="stable")[-max(1, len(dmin) // 10):]
        k = int(far[rng.integers(len(far))])
        chosen.append(k)
        dmin = np.minimum(dmin, np.linalg.norm(pts - pts[k], axis=1))
    return chosen


def _open_order(D: np.ndarray, entry: np.ndarray | None, exit_: np.ndarray | None) -> list[int]:
    """Order the items 0..m-1 (distance matrix ``D`` (m, m)) as an open path of least length,
    counting the distances ``entry`` (m,) from where the path comes from and ``exit_`` (m,) to
    where it goes next (either may be None): exhaustive up to 7 items, else nearest neighbour
    improved by 2-opt."""
    m = len(D)
    e = np.zeros(m) if entry is None else np.asarray(entry, float)
    x = np.zeros(m) if exit_ is None else np.asarray(exit_, float)

    def cost(seq) -> float:
        return e[seq[0]] + x[seq[-1]] + sum(D[a, b] for a, b in zip(seq[:-1], seq[1:]))

    if m <= 7:
        return list(min(itertools.permutations(range(m)), key=cost))
    cur = int(np.argmin(e)) if entry is not None else (int(np.argmax(x)) if exit_ is not None else 0)
    seq, rest = [cur], set(range(m)) - {cur}
    while rest:
        cur = min(sorted(rest), key=lambda k: D[cur, k])
        seq.append(cur)
        rest.remove(cur)
    improved = True
    while improved:
        improved = False
        for i in range(m - 1):
            for j in range(i + 1, m):
                cand = seq[:i] + seq[i:j + 1][::-1] + seq[j + 1:]
                if cost(cand) < cost(seq) - 1e-9:
                    seq, improved = cand, True
    return seq


def _trace(pred: np.ndarray, src: int, dst: int) -> list[int]:
    """Nodes of the shortest path from ``src`` (excluded) to ``dst`` (included) given the
    predecessor row of a Dijkstra search from ``src``."""
    seg, v = [], dst
    while v != src and v >= 0:
        seg.append(int(v))
        v = pred[v]
    return seg[::-1]


class _RoomSweep:
    """Candidate waypoints of one room for the tour: up to 3x the base count (one per ~3 m^2
    of the room's floor, 2 to cfg.waypoints), spread out by farthest-point sampling over the
    largest walkable piece of the room (preferring cells cfg.clearance from obstacles), with
    shortest-path distances and predecessors inside the room. ``nodes`` = their nodes in the
    tour's graph; ``local`` = in the room's subgraph, whose nodes are the graph's ``ids``."""

    def __init__(self, fs: FreeSpace, g, idx: np.ndarray, mask: np.ndarray, cfg, c_path: float,
                 rng: np.random.Generator) -> None:
        lab, nlab = ndimage.label(mask, structure=np.ones((3, 3)))
        if nlab > 1:
            sizes = ndimage.sum(mask, lab, index=np.arange(1, nlab + 1))
            mask = lab == (1 + int(np.argmax(sizes)))
        jj, ii = np.nonzero(mask)
        pts = fs.centre(jj, ii)
        area = float(mask.sum()) * fs.res ** 2
        self.n_base = int(np.clip(round(area / 3.0), 2, cfg.waypoints))
        n_max = 3 * self.n_base
        c = cfg.clearance
        sel = fs.clearance[jj, ii] >= c
        while sel.sum() < 4 * n_max and c > c_path:
            c *= 0.8
            sel = fs.clearance[jj, ii] >= c
        if sel.sum() < 2:
            sel = np.ones(len(jj), bool)
        ks = np.nonzero(sel)[0]
        self.ids = idx[jj, ii]
        self.local = [int(ks[k]) for k in _farthest_points(pts[ks], n_max, rng)]
        self.n_base = min(self.n_base, len(self.local))
        self.nodes = self.ids[self.local]
        sub = g[self.ids][:, self.ids]
        d, self.pred = dijkstra(sub, indices=self.local, return_predecessors=True)
        self.dist = np.atleast_2d(d)[:, self.local]
        self.pred = np.atleast_2d(self.pred)


def chunk_tour(caster, bounds: np.ndarray, cfg, rng: np.random.Generator, fs: FreeSpace | None = None) -> Tour:
    """The tour of split 'chunks': one open walk that visits every room of the scene in turn.

    Rooms are the free areas separated by walls and doorways (:func:`_segment_rooms`; in the
    built-in house its six rooms). They are visited in nearest-neighbour order of their
    distances along the free space, starting at an end of the longest room-to-room route (the
    one nearer the origin; for the house: the serpentine chain of its doorways, from the room
    at x, y = 0). In each room the tour walks through spread-out waypoints (farthest-point
    sampling, preferably ``cfg.clearance`` from obstacles) so the camera sweeps it: as many of
    them (at least 2) as makes its share of the tour closest to the median room's share with
    one waypoint per ~3 m^2 of floor (2 to ``cfg.waypoints``), so that rooms get about equal
    lengths of tour. Waypoints are joined by shortest paths that keep to the middle of
    doorways, and the path is smoothed (Gaussian, mode 'nearest', as strongly as keeps 60 % of
    the clearance from obstacles). A scene with one room gets one long path through all its
    waypoints (up to 3 per ~3 m^2). Deterministic for the state of ``rng``.
    """
    fs = fs or FreeSpace(caster, bounds, cfg.height)
    declared = (getattr(caster.mesh, "metadata", None) or {}).get(TOUR_ROOMS)
    rooms, centres = _segment_rooms(caster, fs) if declared is None else _declared_rooms(fs, declared)
    n_rooms = len(centres)
    c_path = 0.6 * cfg.clearance
    while True:  # the walkable graph: relax the clearance until most of every room is reachable
        walk = fs.free & (fs.clearance >= c_path) & (rooms >= 0)
        lab, nlab = ndimage.label(walk, structure=np.ones((3, 3)))
        if nlab == 0:
            main = walk
        else:
            sizes = ndimage.sum(walk, lab, index=np.arange(1, nlab + 1))
            main = lab == (1 + int(np.argmax(sizes)))
        n_walk = np.bincount(rooms[walk], minlength=n_rooms)
        n_main = np.bincount(rooms[main], minlength=n_rooms)
        reached = {r for r in range(n_rooms) if n_main[r] > 0}
        if np.all(n_main >= 0.5 * n_walk) and len(reached) == n_rooms or c_path <= 0.1:
            break
        c_path *= 0.8
    if main.sum() < 2:
        raise InputError("no free floor area was found for a procedural trajectory (the scene is too cluttered "
                         "or too small); lower world.trajectory.clearance or give trajectory files.")
    if len(reached) < n_rooms:
        log.warning("split chunks: %d of %d rooms cannot be reached at %.2f m from obstacles; the tour skips them",
                    n_rooms - len(reached), n_rooms, c_path)
    g, idx = _weighted_graph(main, fs.clearance, cfg.clearance)
    rs = sorted(reached)
    anchors = []  # each room's walkable cell nearest its centre
    for r in rs:
        jj, ii = np.nonzero(main & (rooms == r))
        k = int(np.argmin(np.linalg.norm(fs.centre(jj, ii) - centres[r], axis=1)))
        anchors.append(int(idx[jj[k], ii[k]]))
    d_anc = np.atleast_2d(dijkstra(g, indices=anchors))
    # room order: nearest neighbour along the free space from an end of the longest route
    DR = d_anc[:, anchors]
    order_i = [0]
    if len(rs) > 1:
        i, j = np.unravel_index(int(np.argmax(DR)), DR.shape)
        order_i = [min((int(i), int(j)), key=lambda k: float(centres[rs[k]].sum()))]
        while len(order_i) < len(rs):
            cur = order_i[-1]
            order_i.append(min((k for k in range(len(rs)) if k not in order_i), key=lambda k: DR[cur, k]))
    order = [rs[k] for k in order_i]
    sweeps = [_RoomSweep(fs, g, idx, main & (rooms == rs[k]), cfg, c_path, rng) for k in order_i]

    def plan(k: int, prev: int | None, d_prev: np.ndarray | None, m: int) -> tuple[list[int], float]:
        """Order the first m waypoints of the k-th room of the tour; its length (m) counts half
        of the legs in from ``prev`` (distances d_prev) and out to the next room's anchor."""
        sw = sweeps[k]
        entry = d_prev[sw.nodes[:m]] if prev is not None else None
        exit_ = d_anc[order_i[k + 1]][sw.nodes[:m]] if k + 1 < len(order) else None
        seq = _open_order(sw.dist[:m, :m], entry, exit_)
        length = sum(sw.dist[a, b] for a, b in zip(seq[:-1], seq[1:]))
        length += 0.5 * (entry[seq[0]] if entry is not None else 0.0)
        length += 0.5 * (exit_[seq[-1]] if exit_ is not None else 0.0)
        return seq, float(length)

    # every room gets about the same length of tour (the median room's sweep through its base
    # number of waypoints): each room walks through as many of its waypoints (at least 2) as
    # comes closest, so equal chunks of the tour hold whole rooms
    target = float(np.median([plan(k, order_i[k - 1] if k else None, d_anc[order_i[k - 1]] if k else None,
                                   sweeps[k].n_base)[1] for k in range(len(order))]))
    if len(order) == 1:  # a single room: one long path through all its waypoints
        target = np.inf
    cells: list[int] = []
    prev, d_prev, p_prev = None, None, None
    for k, sw in enumerate(sweeps):
        options = [plan(k, prev, d_prev, m) for m in range(min(2, len(sw.nodes)), len(sw.nodes) + 1)]
        seq, _ = min(reversed(options), key=lambda o: abs(o[1] - target))
        first = sw.nodes[seq[0]]
        if prev is None:
            cells.append(first)
        else:
            cells.extend(_trace(p_prev, prev, first))
        for a_, b_ in zip(seq[:-1], seq[1:]):
            cells.extend(int(sw.ids[v]) for v in _trace(sw.pred[a_], sw.local[a_], sw.local[b_]))
        prev = sw.nodes[seq[-1]]
        if k + 1 < len(sweeps):
            d_prev, p_prev = dijkstra(g, indices=prev, return_predecessors=True)
    flat = np.nonzero(main.ravel())[0][np.asarray(cells, np.int64)]
    path = _smooth(fs.centre(*np.unravel_index(flat, fs.shape)), fs, c_path, closed=False)
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(path, axis=0), axis=1))])
    j, i = fs.cell(path)
    pr = rooms[j, i]
    for k in range(len(pr)):  # points off the room map (none expected): the previous point's room
        if pr[k] < 0:
            pr[k] = pr[k - 1] if k > 0 else order[0]
    log.debug("split chunks: %d rooms, order %s, tour %.1f m", n_rooms, order, arc[-1])
    return Tour(path, arc, rooms, centres, order, pr, fs)




def _chunk_trajectories(fs: FreeSpace, caster, bounds, n_agents: int, times: np.ndarray, cfg,
                        rng: np.random.Generator, rate: float, duration: float) -> list[Trajectory]:
    tour = chunk_tour(caster, bounds, cfg, rng, fs)
    edges = tour.edges(n_agents, cfg.chunk_snap)
    chunk = float(np.min(np.diff(edges)))
    if chunk < MIN_CHUNK_M:
        raise InputError(f"world.trajectory.split: 'chunks' cuts the {tour.length:.1f} m tour through the free space "
                         f"of the scene into {n_agents} chunks, the shortest {chunk:.2f} m, under the {MIN_CHUNK_M} m "
                         f"each agent needs to walk; use fewer agents, a larger scene (e.g. the built-in 'house'), "
                         f"a lower world.trajectory.clearance, or split: 'regions' or 'none'.")
    out = []
    for a in range(n_agents):
        s0, L = float(edges[a]), float(edges[a + 1] - edges[a])
        # m/s: the configured walking speed, or the one that walks the chunk chunk_passes times
        # over the run's duration (s)
        speed = cfg.speed if cfg.chunk_passes is None else cfg.chunk_passes * L / max(float(duration), 1e-9)
        u = np.mod(speed * times, 2 * L)  # ping-pong inside the chunk, from its start
        forward = u <= L
        s = s0 + np.where(forward, u, 2 * L - u)
        direction = np.where(forward, 1.0, -1.0)[:, None]
        xy = tour.at(s)
        tangent = (tour.at(np.clip(s + 0.15, s0, s0 + L)) - tour.at(np.clip(s - 0.15, s0, s0 + L))) * direction
        # the room whose centre the camera looks at: the one the agent is in (at a cut on a
        # doorway, the one on the agent's own side)
        inner = min(0.3, 0.5 * L)
        centre = tour.centres[tour.room_at(np.clip(s, s0 + inner, s0 + L - inner))]
        # the camera looks fully at that centre over the last END_TURN_M before a cut to a
        # teammate's chunk, and when walking away from the centre (towards a wall or a doorway):
        # the robot looks into its own part rather than out of a doorway into a teammate's, and
        # never blends two opposite directions
        to_end = np.minimum(s - s0 if a > 0 else np.inf, s0 + L - s if a < n_agents - 1 else np.inf)
        ramp = np.clip(1.0 - to_end / END_TURN_M, 0.0, 1.0)
        to_c = centre - xy
        tn = tangent / np.maximum(np.linalg.norm(tangent, axis=1, keepdims=True), 1e-9)
        cos = np.sum(tn * to_c, axis=1) / np.maximum(np.linalg.norm(to_c, axis=1), 1e-9)
        away = np.clip(-cos / 0.5, 0.0, 1.0)
        w = cfg.look_at_center
        look = w + (1.0 - w) * np.maximum(ramp, away) if w > 0 else 0.0
        out.append(_poses_along(xy, tangent, centre, times, fs, cfg, rng, rate, f"procedural agent {a} (chunk {a})",
                                look))
        log.debug("agent %d: chunk %.1f-%.1f m of a %.1f m tour, %d poses", a, s0, s0 + L, tour.length, len(times))
    return out
