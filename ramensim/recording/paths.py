"""Entity paths of a ramensim recording: one place that names where everything is logged.

Layout (``<a>`` is an agent's name, escaped for Rerun):

- ``world``                          world axes (ViewCoordinates), static
- ``world/scene``                    ground-truth scene mesh (below the cut-away plane), static
- ``world/scene/upper_walls``        its steep faces above the plane, faded, static
- ``world/bounds``                   scene bounding box, static
- ``world/agents/<a>``               the agent's camera pose (Transform3D, camera-to-world)
- ``world/agents/<a>/marker``        a labelled point at the camera centre, static
- ``world/agents/<a>/camera``        pinhole (camera_xyz RDF) with ``rgb`` and ``depth`` images below
- ``world/trajectories/<a>/seg_NNNN`` the trajectory so far, in bounded segments (LineStrips3D)
- ``world/maps/<a>``                 the agent's extracted map mesh (Mesh3D, below the cut)
- ``world/maps/<a>/upper_walls``     its steep faces above the cut, faded
- ``world/uncertainty/<a>``          visit counts on the coarsest grid level (Points3D)
- ``world/messages/<src>_to_<dst>``  the last message on a directed link (LineStrips3D + label)
- ``plots/<category>/<name>/<series>`` scalar time series (one plot per ``plots/<category>/<name>``)
- ``log/events``                     TextLog of notable events
"""
from __future__ import annotations

import rerun as rr

WORLD = "world"
SCENE = "world/scene"
BOUNDS = "world/bounds"
EVENTS_LOG = "log/events"
PLOTS = "plots"


def escape(name: str) -> str:
    """One entity-path part, with Rerun's special characters escaped."""
    return rr.escape_entity_path_part(str(name))


def agent(name: str) -> str:
    """Entity of an agent's camera pose."""
    return f"world/agents/{escape(name)}"


def agent_marker(name: str) -> str:
    """Entity of the labelled point at an agent's camera centre."""
    return f"{agent(name)}/marker"


def camera(name: str) -> str:
    """Entity of an agent's pinhole camera; images are logged below it."""
    return f"{agent(name)}/camera"


def rgb(name: str) -> str:
    """Entity of an agent's colour image."""
    return f"{camera(name)}/rgb"


def depth(name: str) -> str:
    """Entity of an agent's depth image."""
    return f"{camera(name)}/depth"


def trajectory(name: str) -> str:
    """Parent entity of an agent's trajectory segments."""
    return f"world/trajectories/{escape(name)}"


def trajectory_segment(name: str, index: int) -> str:
    """Entity of one bounded segment of an agent's trajectory."""
    return f"{trajectory(name)}/seg_{index:04d}"


def map_mesh(name: str) -> str:
    """Entity of an agent's extracted map mesh."""
    return f"world/maps/{escape(name)}"


def upper_walls(entity: str) -> str:
    """Entity of the faded steep faces above the cut-away plane of a mesh entity."""
    return f"{entity}/upper_walls"


def uncertainty(name: str) -> str:
    """Entity of an agent's uncertainty (visit-count) points."""
    return f"world/uncertainty/{escape(name)}"


def message(src_name: str, dst_name: str) -> str:
    """Entity of the line showing the last message on the directed link src -> dst."""
    return f"world/messages/{escape(src_name)}_to_{escape(dst_name)}"


def plot(category: str, name: str, series: str) -> str:
    """Entity of one scalar series; all series of ``plots/<category>/<name>`` share a plot."""
    return f"{PLOTS}/{escape(category)}/{escape(name)}/{escape(series)}"


def plot_group(series_path: str) -> str:
    """The plot (``plots/<category>/<name>``) a series entity belongs to."""
    return series_path.rsplit("/", 1)[0]
