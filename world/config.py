"""Settings of the world: the scene, the agents' trajectories and the RGB-D camera.

Composed by the lead into the scenario schema as ``scenario.world``. Every field has a default
and states its unit. File paths that are relative are resolved against the ``base_dir`` given
to :func:`ramensim.world.build_world` (the scenario file's folder), else the working directory.
"""
from __future__ import annotations

from typing import Annotated, Literal, Union

from pydantic import BaseModel, ConfigDict, Discriminator, Field, Tag, field_validator, model_validator

BUILTIN_SCENES = ("office", "living_room", "apartment", "house", "warehouse", "pretrain_room")
"""The scenes shipped with ramensim; :func:`ramensim.world.scenes.scene_names` lists every registered one."""


def _scene_names() -> tuple[str, ...]:
    from ramensim.world.scenes.registry import scene_names

    return scene_names()


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", use_attribute_docstrings=True)


# ----------------------------------------------------------------------------- scenes
class BuiltinSceneConfig(_Strict):
    """A procedurally generated indoor scene (coloured triangle mesh)."""

    kind: Literal["builtin"] = "builtin"
    """Scene source: 'builtin' = generated from a name and a seed."""
    name: str = Field("office", json_schema_extra=lambda schema: schema.update(enum=list(_scene_names())))
    """Which generated scene: a built-in one ('office', 'living_room', 'apartment', 'house' = six rooms in a 2 x 3 grid joined in a chain by one doorway each, 'warehouse' = a hall of shelving racks in an aisle grid that the seed lays out; 'pretrain_room' is for pretraining decoders only, never evaluation) or one a plugin registers (docs/EXTENDING.md)."""
    seed: int = Field(0, ge=0)
    """Seed of the scene generator: same name + seed = the same mesh (integer)."""

    @field_validator("name")
    @classmethod
    def _registered(cls, name: str) -> str:
        from ramensim.world.scenes.registry import get_scene

        return get_scene(name).name  # ValueError naming the registered scenes


class MeshSceneConfig(_Strict):
    """Any triangle mesh file (PLY/OBJ/GLB/...) used as the scene."""

    kind: Literal["mesh"] = "mesh"
    """Scene source: 'mesh' = a mesh file."""
    path: str = "scene.ply"
    """Mesh file path (PLY, OBJ, GLB, ...; relative to the scenario folder)."""
    bounds: list[list[float]] | None = None
    """Scene bounds [[xmin, ymin, zmin], [xmax, ymax, zmax]] (m); None = the mesh's bounding box padded by bounds_padding."""
    bounds_padding: float = Field(0.1, ge=0)
    """Padding added on every side of the mesh's bounding box when bounds is None (m)."""
    default_color: tuple[float, float, float] = (0.7, 0.7, 0.7)
    """RGB colour in [0, 1] used when the file has no vertex or face colours (unitless)."""
    up_axis: Literal["z", "y"] = "z"
    """Which axis of the file points up; 'y' files are rotated so that +z is up (axis name)."""

    @model_validator(mode="after")
    def _check(self) -> "MeshSceneConfig":
        if any(not 0.0 <= c <= 1.0 for c in self.default_color):
            raise ValueError(f"default_color {self.default_color} must have 3 values in [0, 1]")
        _check_bounds(self.bounds)
        return self


class DatasetSceneConfig(_Strict):
    """Posed RGB-D frames read from a dataset on disk (Replica, ScanNet or TUM RGB-D)."""

    kind: Literal["replica", "scannet", "tum"] = "replica"
    """Dataset layout: 'replica' (NICE-SLAM layout), 'scannet' or 'tum' (TUM RGB-D)."""
    path: str = "data/Replica/room0"
    """Folder of one sequence (relative to the scenario folder)."""
    mesh: str | None = None
    """Ground-truth mesh file; None = the dataset's own (Replica '<seq>_mesh.ply' beside the folder, ScanNet '<seq>_vh_clean_2.ply' inside it) if present (path)."""
    depth_scale: float | None = Field(None, gt=0)
    """Depth PNG units per metre; None = the dataset's convention (Replica 6553.5, ScanNet 1000, TUM 5000) (1/m)."""
    intrinsics: Literal["dataset", "camera"] = "dataset"
    """Where intrinsics come from: 'dataset' (ScanNet intrinsic file, Replica cam_params.json or NICE-SLAM's camera, TUM's calibration chosen by the folder name freiburg1/2/3) or 'camera' (the override: world.camera fx, fy, cx, cy, width, height, which must be the images' native size)."""
    crop_edge: int = Field(0, ge=0)
    """Pixels ignored along every image border at native resolution, as NICE-SLAM/Co-SLAM's crop_edge (ScanNet 10, TUM 8): their depth is set to 0 (no reading), so the map never samples them (pixels)."""
    bounds: list[list[float]] | None = None
    """Scene bounds [[xmin, ymin, zmin], [xmax, ymax, zmax]] of the map (m); None = the ground-truth mesh's bounding box, or an estimate from the depth images when there is no mesh."""
    image_scale: float = Field(1.0, gt=0, le=1)
    """Resize factor applied to every image and the intrinsics (1 = native resolution) (fraction)."""
    fps: float = Field(30.0, gt=0)
    """Frame rate used to timestamp Replica/ScanNet frames, which carry no time (frames/s)."""
    stride: int = Field(1, ge=1)
    """Use every stride-th frame of the sequence (frames)."""
    max_frames: int | None = Field(None, ge=1)
    """Use at most this many frames (after stride); None = all (frames)."""
    max_time_diff: float = Field(0.02, gt=0)
    """TUM: largest allowed timestamp difference when associating rgb, depth and pose (s)."""
    skip_invalid_poses: bool = True
    """Drop frames whose pose has NaN/inf (lost tracking: ScanNet writes inf; Replica's traj.txt and TUM's groundtruth.txt lines alike), with their count in the log; false = stop with an error naming the first such pose (file and line). The rule of every pose file (ramensim.core.posefile)."""
    split: Literal["chunks", "regions"] = "chunks"
    """How frames are divided between agents: 'chunks' = contiguous equal chunks of the sequence (the paper's rule), 'regions' = by camera position along the longest horizontal axis."""


    @model_validator(mode="after")
    def _check_dataset(self) -> "DatasetSceneConfig":
        _check_bounds(self.bounds)
        return self


def _kind(default: str):
    """Discriminator reading 'kind' from a dict or a model, ``default`` when it is absent."""
    def get(v):
        return v.get("kind", default) if isinstance(v, dict) else getattr(v, "kind", default)
    return get


SceneConfig = Annotated[
    Union[Annotated[BuiltinSceneConfig, Tag("builtin")], Annotated[MeshSceneConfig, Tag("mesh")],
          Annotated[DatasetSceneConfig, Tag("replica")], Annotated[DatasetSceneConfig, Tag("scannet")],
          Annotated[DatasetSceneConfig, Tag("tum")]],
    Discriminator(_kind("builtin")),
]


# ----------------------------------------------------------------------------- trajectories
class ProceduralTrajectoryConfig(_Strict):
    """Smooth walking-speed camera paths through the free space of a mesh scene."""

    kind: Literal["procedural"] = "procedural"
    """Trajectory source: 'procedural' = generated from a seed."""
    speed: float = Field(0.4, gt=0, le=5)
    """Walking speed along the path (m/s)."""
    height: float = Field(1.4, gt=0)
    """Mean camera height above the floor (m)."""
    height_variation: float = Field(0.15, ge=0)
    """Amplitude of the slow up-and-down of the camera around `height` (m)."""
    pitch_deg: float = Field(-12.0, ge=-80, le=80)
    """Camera pitch; negative looks down (degrees)."""
    look_at_center: float = Field(0.5, ge=0, le=1)
    """Blend of viewing direction: 0 = along the path, 1 = at the centre of the agent's region (fraction). Split 'chunks': the centre of the room the agent is in, looked at fully (unless 0) when walking away from it and near a cut to a teammate's chunk."""
    clearance: float = Field(0.45, gt=0)
    """Minimum horizontal distance from waypoints to furniture and walls (m)."""
    waypoints: int = Field(8, ge=2)
    """Number of random waypoints per lap, joined by a periodic spline; split 'chunks': the most per room (one per ~3 m^2 of floor, at least 2) (count)."""
    seed: int = Field(0, ge=0)
    """Seed of the trajectory generator, combined with the scenario's root seed (integer)."""
    chunk_passes: float | None = Field(None, gt=0, le=1000)
    """Split 'chunks': how many times each agent walks its chunk over the run (1 = start to end once, 2 = there and back), each at the speed that takes (its chunk's length x chunk_passes / duration), in place of `speed`; like the authors' code, which hands robot i the frames i*F/n .. (i+1)*F/n - 1 of one F-frame sequence and processes each once. None = walk at `speed`, back and forth for the whole run (passes)."""
    chunk_snap: float = Field(0.5, ge=0, le=0.5)
    """Split 'chunks': each cut between two agents' chunks moves onto the nearest doorway within this fraction of the equal chunk length, keeping every chunk at least half that length, so robots own whole rooms; 0 = exactly equal chunks (fraction)."""
    split: Literal["none", "regions", "chunks"] = "regions"
    """'regions': agent i explores the i-th of n equal slabs along the longest horizontal axis (halves for 2 agents, thirds for 3, like the paper's hardware run); 'chunks': one tour visits every room in turn (through the doorways; a single-room scene gets one long path), is cut by arc length into n equal contiguous chunks and agent i walks chunk i back and forth (like cutting one Replica/ScanNet sequence into chunks, the paper's rule; best with the multi-room 'house'); 'none': every agent roams the whole scene."""


class FileTrajectoryConfig(_Strict):
    """Per-agent trajectory files."""

    kind: Literal["file"] = "file"
    """Trajectory source: 'file'."""
    paths: list[str] = Field(default_factory=list)
    """One file per agent (relative to the scenario folder); agent i uses paths[i]."""
    format: Literal["tum", "matrix"] = "tum"
    """'tum': lines 'timestamp tx ty tz qx qy qz qw' (s, m); 'matrix': one row-major 4x4 camera-to-world per line (16 numbers, m)."""
    fps: float = Field(30.0, gt=0)
    """Frame rate of 'matrix' files, whose lines carry no timestamp (poses/s)."""
    loop: bool = True
    """Run the trajectory back and forth (ping-pong) when the simulation outlasts it; False = hold the last pose."""


TrajectoryConfig = Annotated[
    Union[Annotated[ProceduralTrajectoryConfig, Tag("procedural")], Annotated[FileTrajectoryConfig, Tag("file")]],
    Discriminator(_kind("procedural")),
]


# ----------------------------------------------------------------------------- camera
class SensorConfig(_Strict):
    """Depth sensor model applied to rendered frames (seeded)."""

    depth_noise_a: float = Field(0.0, ge=0)
    """Constant part of the depth noise std sigma = a + b z^2 (m)."""
    depth_noise_b: float = Field(0.0, ge=0)
    """Quadratic part of the depth noise std sigma = a + b z^2 (1/m)."""
    missing_fraction: float = Field(0.0, ge=0, lt=1)
    """Fraction of pixels with no depth reading (depth 0), chosen at random per frame (fraction)."""
    min_range: float = Field(0.05, ge=0)
    """Depths below this read as missing (m)."""
    max_range: float = Field(10.0, gt=0)
    """Depths beyond this read as missing (m)."""
    color_noise: float = Field(0.0, ge=0, le=0.5)
    """Std of additive Gaussian noise on RGB values in [0, 1] (unitless)."""

    @model_validator(mode="after")
    def _check(self) -> "SensorConfig":
        if self.max_range <= self.min_range:
            raise ValueError(f"max_range {self.max_range} must exceed min_range {self.min_range}")
        return self


class CameraConfig(_Strict):
    """Pinhole RGB-D camera (OpenCV axes: x right, y down, z forward)."""

    width: int = Field(160, ge=1, le=8192)
    """Image width (pixels)."""
    height: int = Field(120, ge=1, le=8192)
    """Image height (pixels)."""
    fx: float = Field(120.0, gt=0)
    """Focal length along x (pixels); 120 at 160 px wide = a 67 degree horizontal field of view."""
    fy: float = Field(120.0, gt=0)
    """Focal length along y (pixels)."""
    cx: float = Field(79.5, ge=0)
    """Principal point x (pixels, pixel-centre convention)."""
    cy: float = Field(59.5, ge=0)
    """Principal point y (pixels, pixel-centre convention)."""
    fps: float = Field(5.0, gt=0)
    """Frames captured per simulated second (frames/s)."""
    keyframe_every: int = Field(5, ge=1)
    """Every k-th frame becomes a keyframe (frames)."""
    sensor: SensorConfig = Field(default_factory=SensorConfig)
    """Noise, missing pixels and range limits of the depth sensor."""


class WorldConfig(_Strict):
    """Scene, trajectories and camera of a simulation."""

    scene: SceneConfig = Field(default_factory=BuiltinSceneConfig)
    """Where the world comes from: a built-in scene, a mesh file or a dataset (choose with 'kind')."""
    trajectory: TrajectoryConfig = Field(default_factory=ProceduralTrajectoryConfig)
    """How agents move (ignored for datasets, whose frames carry their poses)."""
    camera: CameraConfig = Field(default_factory=CameraConfig)
    """The RGB-D camera every agent carries."""


def _check_bounds(bounds: list[list[float]] | None) -> None:
    if bounds is None:
        return
    if len(bounds) != 2 or any(len(b) != 3 for b in bounds):
        raise ValueError(f"bounds {bounds} must be [[xmin, ymin, zmin], [xmax, ymax, zmax]]")
    if any(lo >= hi for lo, hi in zip(bounds[0], bounds[1])):
        raise ValueError(f"bounds {bounds}: every min must be below its max")
