"""Settings of the Rerun recording of one run (the ``recording:`` block of a scenario)."""
from __future__ import annotations

from typing import Literal

from pydantic import field_validator, BaseModel, ConfigDict, Field

RecordingMode = Literal["save", "spawn", "connect", "serve", "off"]

WorldCoordinates = Literal["RIGHT_HAND_Z_UP", "RIGHT_HAND_Y_UP", "RIGHT_HAND_Y_DOWN", "RDF", "RUB", "FLU"]
"""Names of ``rerun.ViewCoordinates`` presets accepted for the world frame."""


class RecordingConfig(BaseModel):
    """Where a run's Rerun recording goes and how much of the run it holds.

    Only what the recorder logs is affected: the simulation never reads these settings,
    except ``mesh_period_s``, ``mesh_voxel_m`` and ``uncertainty_period_s`` which tell the
    simulation loop how often (and how finely) to extract map meshes and uncertainty
    snapshots for the recorder.
    """

    model_config = ConfigDict(extra="forbid", use_attribute_docstrings=True)

    mode: RecordingMode = "save"
    """save: write <run folder>/<file_name>; spawn: start a viewer; connect: stream to url; serve: host a gRPC server on 127.0.0.1:serve_port; off: no recording (unitless choice)."""

    @field_validator("mode", mode="before")
    @classmethod
    def _yaml_off(cls, v: object) -> object:
        """YAML 1.1 reads an unquoted ``off`` as False (and ``on`` as True)."""
        if v is False:
            return "off"
        if v is True:
            return "save"
        return v

    file_name: str = Field(default="run.rrd", min_length=1, pattern=r"^[^/\\]+\.rrd$")
    """File name of the recording inside the run folder (a bare name ending in .rrd); written in every mode but off, the live modes too."""

    live_timeout_s: float = Field(default=10.0, gt=0.0, le=600.0, allow_inf_nan=False)
    """Live modes (spawn, connect): how long to wait for the viewer to listen, and at the end for it to take what is left, before going on with the file alone (seconds)."""

    url: str = Field(default="rerun+http://127.0.0.1:9876/proxy", pattern=r"^rerun(\+https?)?://")
    """gRPC proxy URL of a running viewer in connect mode (rerun+http://host:port/proxy)."""

    serve_port: int = Field(default=9876, ge=1, le=65535)
    """TCP port on 127.0.0.1 of the gRPC server in serve mode, or of the spawned viewer in spawn mode (port number)."""

    server_memory_limit: str = Field(default="1GiB", pattern=r"^\d+(\.\d+)?\s*(B|KB|KiB|MB|MiB|GB|GiB|TB|TiB|%)$")
    """Memory the serve-mode gRPC server may buffer for late viewers (bytes with unit, e.g. 1GiB, or % of RAM)."""

    application_id: str = Field(default="ramensim", min_length=1)
    """Rerun application id that groups recordings in the viewer (a name)."""

    world_coordinates: WorldCoordinates = "RIGHT_HAND_Z_UP"
    """Axis convention of the world frame, a rerun.ViewCoordinates preset name (e.g. RIGHT_HAND_Z_UP)."""

    log_scene: bool = True
    """Log the ground-truth scene mesh once as static data (flag)."""

    log_rgb: bool = True
    """Log each agent's colour images (flag)."""

    log_depth: bool = True
    """Log each agent's depth images (flag)."""

    image_downsample: int = Field(default=1, ge=1, le=64)
    """Keep every k-th pixel in each image axis before logging (integer stride, pixels); 1 logs the rendered images at full size (world.camera.width x height)."""

    max_image_rate_hz: float = Field(default=1.0, gt=0.0, le=1000.0)
    """At most this many images per agent per simulated second (Hz of simulated time)."""

    jpeg_quality: int = Field(default=85, ge=0, le=100)
    """JPEG quality of logged colour images (1-100); 0 logs them uncompressed (quality, unitless)."""

    image_plane_distance_m: float = Field(default=0.3, gt=0.0, le=100.0)
    """Depth at which the camera frustum is drawn in the 3-D view (m)."""

    trajectory_min_step_m: float = Field(default=0.02, ge=0.0, le=100.0)
    """A new trajectory point is kept only this far from the last kept one (m)."""

    mesh_period_s: float = Field(default=20.0, gt=0.0)
    """Simulated seconds between map-mesh snapshots the simulation extracts for the recording (s)."""
    mesh_voxel_m: float = Field(default=0.08, gt=0.0, le=1.0)
    """Marching-cubes voxel of those snapshots (m): coarser than the evaluation mesh, so that recording costs little; the final meshes use evaluation.voxel_m."""

    uncertainty_period_s: float = Field(default=10.0, gt=0.0)
    """Simulated seconds between uncertainty snapshots the simulation takes for the recording (s)."""

    mesh_faces: Literal["front", "back", "double_sided"] = "front"
    """Which triangles of the scene and map meshes are drawn: front (counter-clockwise) shows closed rooms from outside like a doll's house (choice)."""

    cutaway_fraction: float | None = Field(default=0.7, gt=0.0, le=1.0)
    """Cut the scene and the maps at this fraction of the scene's height (the ground-truth mesh's extent along the up axis, else the bounds'): below the cut everything is drawn, above it only steep faces (upper walls) at wall_opacity, no ceiling; None = draw them whole (fraction)."""

    scene_opacity: float = Field(default=0.4, ge=0.0, le=1.0)
    """Opacity of the ground-truth scene below the cut: below 1 the maps, drawn opaque on the same surfaces, stand out and what no agent mapped stays faint (0 hides the scene, 1 draws it opaque) (fraction)."""

    wall_opacity: float = Field(default=0.15, ge=0.0, le=1.0)
    """Opacity of the walls above the cut (0 hides them, 1 draws them opaque) (fraction)."""

    map_colors: Literal["agent", "predicted"] = "agent"
    """Colour of each agent's map snapshots: agent (its own colour, as its trajectory and marker) or predicted (the colours the map predicts) (choice)."""

    uncertainty_point_radius_m: float = Field(default=0.03, gt=0.0, le=10.0)
    """Radius of the coloured uncertainty points (m)."""

    log_messages: bool = True
    """Draw every delivered or lost message as a line between the two agents (flag)."""

    message_display_s: float = Field(default=1.0, gt=0.0)
    """How long a message line stays visible after delivery or loss (simulated s)."""

    scalar_flush_period_s: float = Field(default=5.0, gt=0.0)
    """Buffered scalars are sent at least this often (simulated s) and always at close."""

    scalar_flush_rows: int = Field(default=20000, ge=1)
    """Buffered scalars are also sent once this many points are waiting (points)."""
