"""The world: built-in and mesh scenes, camera trajectories, the RGB-D camera, dataset
readers (Replica, ScanNet, TUM RGB-D) and per-agent frame sources.

Entry point: :func:`build_world` (WorldConfig -> World).
"""
from ramensim.world.camera import MeshRayCaster, RGBDCamera
from ramensim.world.config import WorldConfig
from ramensim.world.scenes import Scene, builtin_scene, load_mesh_scene
from ramensim.world.sources import DatasetFrameSource, FrameSource, RenderedFrameSource
from ramensim.world.trajectories import Trajectory, load_matrix, load_tum
from ramensim.world.world import World, build_world, load_scene

__all__ = ["MeshRayCaster", "RGBDCamera", "WorldConfig", "Scene", "builtin_scene", "load_mesh_scene",
           "DatasetFrameSource", "FrameSource", "RenderedFrameSource", "Trajectory", "load_matrix",
           "load_tum", "World", "build_world", "load_scene"]
