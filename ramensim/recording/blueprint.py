"""The default layout of a ramensim recording in the Rerun viewer (``rerun.blueprint``).

Left: the 3-D world (scene, agents, maps, uncertainty, messages) above one tab per
agent's camera (colour and depth side by side). Right: tabs of time-series plots
(Metrics, Mapping, Communication), one plot per ``plots/<category>/<name>`` with one
line per agent, above the event log.
"""
from __future__ import annotations

from collections.abc import Iterable, Sequence

import numpy as np
import rerun.blueprint as rrb

from ramensim.recording import paths

_TABS = (("metrics", "Metrics"), ("round", "Mapping"), ("comm", "Communication"), ("copy_age", "Copy ages"))


def _plots_tab(title: str, groups: Sequence[str]) -> rrb.Container:
    views = [rrb.TimeSeriesView(origin=g, name=g.split("/", 2)[2].replace("/", " ")) for g in groups]
    return rrb.Grid(*views, name=title)


_UP = {"RIGHT_HAND_Z_UP": (0.0, 0.0, 1.0), "FLU": (0.0, 0.0, 1.0), "RIGHT_HAND_Y_UP": (0.0, 1.0, 0.0),
       "RUB": (0.0, 1.0, 0.0), "RIGHT_HAND_Y_DOWN": (0.0, -1.0, 0.0), "RDF": (0.0, -1.0, 0.0)}


def overview_eye(bounds: np.ndarray, world_coordinates: str) -> rrb.EyeControls3D:
    """A 3-D camera above and to one side of the scene's bounding box ((2, 3) m), looking
    at its centre: with back faces culled, closed rooms are seen from above like a doll's house."""
    b = np.asarray(bounds, dtype=np.float64).reshape(2, 3)
    centre, diag = b.mean(axis=0), float(np.linalg.norm(b[1] - b[0]))
    up = np.asarray(_UP.get(world_coordinates, (0.0, 0.0, 1.0)))
    side = np.array([0.0, -1.0, 0.0]) if abs(up[1]) < 0.5 else np.array([0.0, 0.0, 1.0])
    eye = centre + up * 0.7 * diag + side * 0.5 * diag
    return rrb.EyeControls3D(position=eye, look_target=centre, eye_up=up)


def default_blueprint(agent_names: Sequence[str], plot_groups: Iterable[str] = (), bounds: np.ndarray | None = None,
                      world_coordinates: str = "RIGHT_HAND_Z_UP") -> rrb.Blueprint:
    """The viewer layout for ``agent_names`` and the plots known so far.

    ``plot_groups`` are entity paths ``plots/<category>/<name>``; each becomes a
    time-series view in the tab of its category (others go to a tab "Other").
    ``bounds`` ((2, 3) m, optional) places the 3-D view's camera over the scene.
    """
    by_cat: dict[str, list[str]] = {}
    for g in sorted(set(plot_groups)):
        parts = g.split("/")
        if len(parts) >= 3 and parts[0] == paths.PLOTS:
            by_cat.setdefault(parts[1], []).append(g)
    tabs = [_plots_tab(title, by_cat.pop(cat, [])) for cat, title in _TABS]
    rest = [g for cat in sorted(by_cat) for g in by_cat[cat]]
    if rest:
        tabs.append(_plots_tab("Other", rest))

    cameras = [
        rrb.Horizontal(
            rrb.Spatial2DView(origin=paths.camera(n), contents=["$origin", paths.rgb(n)], name=f"{n} colour"),
            rrb.Spatial2DView(origin=paths.camera(n), contents=["$origin", paths.depth(n)], name=f"{n} depth"),
            name=n,
        )
        for n in agent_names
    ]
    eye = overview_eye(bounds, world_coordinates) if bounds is not None else None
    left_parts: list[rrb.Container | rrb.View] = [rrb.Spatial3DView(origin=paths.WORLD, name="World",
                                                                    eye_controls=eye)]
    if cameras:
        left_parts.append(rrb.Tabs(*cameras, name="Cameras"))
    left = rrb.Vertical(*left_parts, row_shares=[3, 2][: len(left_parts)], name="World and cameras")
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
