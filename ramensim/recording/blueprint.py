"""The default layout of a ramensim recording in the Rerun viewer (``rerun.blueprint``).

Left: the 3-D world (cut-away scene, agents, their trajectories and maps in their own
colours, messages) above tabs of small views, one per agent side by side: Cameras (colour
images), Depth, Maps (each agent's map and trajectory alone) and Uncertainty (RAMEN's visit
counts). Right: tabs of time-series plots (Metrics, Mapping, Communication, Copy ages), one
plot per ``plots/<category>/<name>`` with one line per agent, above the event log.

:func:`comparison_blueprint` lays several runs side by side (one column each) for a
recording combined by :mod:`ramensim.recording.combine`.
"""
from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

import numpy as np
import rerun.blueprint as rrb

from ramensim.recording import paths
from ramensim.recording.cutaway import up_vector

@dataclass
class RunLayout:
    """What the side-by-side layout needs of one run: its ``label`` (view names), the entity
    path ``root`` its entities were moved below, its agents, its plot groups
    (``plots/<category>/<name>``), the scene's bounds ((2, 3) m) or None and its world axes."""

    label: str
    root: str
    agent_names: list[str] = field(default_factory=list)
    plot_groups: list[str] = field(default_factory=list)
    bounds: np.ndarray | None = None
    world_coordinates: str = "RIGHT_HAND_Z_UP"


_TABS = (("metrics", "Metrics"), ("round", "Mapping"), ("comm", "Communication"), ("copy_age", "Copy ages"))


_TITLES = {
    "completion_ratio_pct": "completion %", "completion_unseen_pct": "unseen-part compl. %",
    "own_coverage_pct": "own coverage %", "team_coverage_pct": "team coverage %",
    "consensus_error": "consensus error", "consensus_error_weighted": "weighted cons. error",
    "age_on_arrival_s": "age on arrival s",
}
"""Short titles of the plots whose metric names would be cut in a small view."""

_UNITS = (("_pct", " %"), ("_cm", " cm"), ("_s", " s"), ("_m", " m"))

FALLING = ("consensus_error", "consensus_error_weighted", "artifacts_cm", "holes_cm", "loss", "residual")
"""Plots whose lines mostly fall: their legend goes top right, the others' top left (lines
that rise leave that corner empty), so a legend does not hide the lines."""


def view_title(name: str) -> str:
    """A plot's title from its metric name: ``completion_ratio_pct`` -> ``completion %``,
    ``bytes_sent`` -> ``bytes sent``, units as words after the name."""
    if name in _TITLES:
        return _TITLES[name]
    for suffix, unit in _UNITS:
        if name.endswith(suffix) and len(name) > len(suffix):
            return name[: -len(suffix)].replace("_", " ") + unit
    return name.replace("_", " ")


def _plots_tab(title: str, groups: Sequence[str], root: str = "") -> rrb.Container:
    """A grid of time-series views, one per group ``plots/<category>/<name>`` (below ``root``),
    titled by :func:`view_title`, the legend in the corner the lines leave free."""
    views = []
    for g in groups:
        name = g.split("/", 2)[2]
        corner = "RightTop" if any(name.startswith(f) for f in FALLING) else "LeftTop"
        views.append(rrb.TimeSeriesView(origin=f"{root}{g}", name=view_title(name.replace("/", " ")),
                                        plot_legend=rrb.PlotLegend(corner=corner)))
    return rrb.Grid(*views, name=title)


def _plot_tabs(plot_groups: Iterable[str], root: str = "") -> list[rrb.Container]:
    """One tab per plot category (Metrics, Mapping, Communication, Copy ages, then Other);
    ``plot_groups`` are entity paths ``plots/<category>/<name>``."""
    by_cat: dict[str, list[str]] = {}
    for g in sorted(set(plot_groups)):
        parts = g.split("/")
        if len(parts) >= 3 and parts[0] == paths.PLOTS:
            by_cat.setdefault(parts[1], []).append(g)
    tabs = [_plots_tab(title, by_cat.pop(cat, []), root) for cat, title in _TABS]
    rest = [g for cat in sorted(by_cat) for g in by_cat[cat]]
    if rest:
        tabs.append(_plots_tab("Other", rest, root))
    return tabs


def _world_view(origin: str, name: str, agent_names: Sequence[str], eye: rrb.EyeControls3D | None,
                root: str = "") -> rrb.View:
    """The 3-D world: everything but the uncertainty lattice, which would hide the maps (and
    the depth images, which a 3-D view would draw as point clouds in front of each camera)."""
    return rrb.Spatial3DView(origin=origin, name=name, eye_controls=eye,
                             contents=["$origin/**", f"- {root}{paths.WORLD}/uncertainty/**",
                                       *(f"- {root}{paths.depth(n)}" for n in agent_names)])


def overview_eye(bounds: np.ndarray, world_coordinates: str, height: float = 0.6, side: float = 0.35,
                 ) -> rrb.EyeControls3D:
    """A 3-D camera above and to one side of the scene's bounding box ((2, 3) m), looking at
    its centre from ``height`` and ``side`` times the box's diagonal: with the ceiling cut
    away, the rooms and the maps in them are seen from above like a doll's house."""
    b = np.asarray(bounds, dtype=np.float64).reshape(2, 3)
    centre, diag = b.mean(axis=0), float(np.linalg.norm(b[1] - b[0]))
    up = up_vector(world_coordinates)
    away = np.array([0.0, -1.0, 0.0]) if abs(up[1]) < 0.5 else np.array([0.0, 0.0, 1.0])
    eye = centre + up * height * diag + away * side * diag
    return rrb.EyeControls3D(position=eye, look_target=centre, eye_up=up)


def _agent_views(agent_names: Sequence[str], eye: rrb.EyeControls3D | None) -> list[rrb.Container]:
    """The bottom-left tabs: per agent side by side, its colour images, depth images, map and
    trajectory alone, and its uncertainty points."""
    def side_by_side(title: str, views: list[rrb.View]) -> rrb.Container:
        return rrb.Horizontal(*views, name=title)

    colour = [rrb.Spatial2DView(origin=paths.camera(n), contents=["$origin", paths.rgb(n)], name=n)
              for n in agent_names]
    depth = [rrb.Spatial2DView(origin=paths.camera(n), contents=["$origin", paths.depth(n)], name=f"{n} depth")
             for n in agent_names]
    maps = [rrb.Spatial3DView(origin=paths.WORLD, name=f"{n} map", eye_controls=eye,
                              contents=[f"{paths.map_mesh(n)}/**", f"{paths.trajectory(n)}/**",
                                        f"{paths.agent(n)}/marker"])
            for n in agent_names]
    unc = [rrb.Spatial3DView(origin=paths.WORLD, name=f"{n} uncertainty", eye_controls=eye,
                             contents=[f"{paths.uncertainty(n)}/**", f"{paths.agent(n)}/marker"])
           for n in agent_names]
    return [side_by_side("Cameras", colour), side_by_side("Depth", depth), side_by_side("Maps", maps),
            side_by_side("Uncertainty", unc)]


def default_blueprint(agent_names: Sequence[str], plot_groups: Iterable[str] = (), bounds: np.ndarray | None = None,
                      world_coordinates: str = "RIGHT_HAND_Z_UP") -> rrb.Blueprint:
    """The viewer layout for ``agent_names`` and the plots known so far.

    ``plot_groups`` are entity paths ``plots/<category>/<name>``; each becomes a
    time-series view in the tab of its category (others go to a tab "Other").
    ``bounds`` ((2, 3) m, optional) places the 3-D view's camera over the scene.
    """
    tabs = _plot_tabs(plot_groups)
    eye = overview_eye(bounds, world_coordinates) if bounds is not None else None
    world = _world_view(paths.WORLD, "World", agent_names, eye)
    left_parts: list[rrb.Container | rrb.View] = [world]
    if agent_names:
        left_parts.append(rrb.Tabs(*_agent_views(agent_names, eye), name="Agents"))
    left = rrb.Vertical(*left_parts, row_shares=[3, 2][: len(left_parts)], name="World and agents")
    right = rrb.Vertical(
        rrb.Tabs(*tabs, name="Plots"),
        rrb.TextLogView(origin=paths.EVENTS_LOG, name="Events"),
        row_shares=[3, 1],
        name="Plots and events",
    )
    return rrb.Blueprint(
        rrb.Horizontal(left, right, column_shares=[3, 2]),
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
        rrb.TimePanel(state="expanded", timeline="sim_time"),
    )


def comparison_blueprint(runs: Sequence[RunLayout]) -> rrb.Blueprint:
    """Several runs side by side (``ramensim view RUN RUN...``): one column per run, each with
    its 3-D world over tabs of its plots, every run's entities below its own ``root``; one
    time cursor moves them all."""
    columns = []
    for r in runs:
        eye = overview_eye(r.bounds, r.world_coordinates) if r.bounds is not None else None
        world = _world_view(f"{r.root}/{paths.WORLD}", r.label, r.agent_names, eye, root=f"{r.root}/")
        plots = rrb.Tabs(*_plot_tabs(r.plot_groups, root=f"{r.root}/"),
                         name=f"{r.label} plots")
        columns.append(rrb.Vertical(world, plots, row_shares=[3, 2], name=r.label))
    return rrb.Blueprint(
        rrb.Horizontal(*columns),
        rrb.BlueprintPanel(state="collapsed"),
        rrb.SelectionPanel(state="collapsed"),
        rrb.TimePanel(state="expanded", timeline="sim_time"),
    )
