"""Camera trajectories: timed camera-to-world poses with slerp interpolation.

Poses are 4x4 camera-to-world matrices in OpenCV camera axes (x right, y down, z forward),
metres; times in seconds. Sources: procedural walking paths through the free space of a
mesh scene (:func:`procedural_trajectories`, :mod:`.procedural`; splits 'none' / 'regions'
walk closed loops, :mod:`.freespace`; split 'chunks' cuts one tour through every room,
:func:`chunk_tour` in :mod:`.tour`, into one contiguous piece per agent), or files
(:func:`load_tum`, :func:`load_matrix`, :mod:`.poses`).
"""
from __future__ import annotations

from ramensim.world.trajectories.poses import (Trajectory, check_pose_matrix, load_matrix, load_tum, look_rotation,
                                               quat_pose)
from ramensim.world.trajectories.freespace import FreeSpace  # noqa: I001
from ramensim.world.trajectories.tour import (END_TURN_M, MIN_CHUNK_M, MIN_ROOM_AREA, ROOM_CLEARANCE,
                                              STRUCTURE_HEIGHT, Tour, chunk_tour)
from ramensim.world.trajectories.procedural import procedural_trajectories

__all__ = [
    "END_TURN_M", "MIN_CHUNK_M", "MIN_ROOM_AREA", "ROOM_CLEARANCE", "STRUCTURE_HEIGHT", "FreeSpace", "Tour",
    "Trajectory", "check_pose_matrix", "chunk_tour", "load_matrix", "load_tum", "look_rotation",
    "procedural_trajectories", "quat_pose",
]
