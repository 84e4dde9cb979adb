"""TUM RGB-D: ``rgb.txt`` and ``depth.txt`` ('timestamp filename' lines), ``groundtruth.txt``
('timestamp tx ty tz qx qy qz qw'), 16-bit depth at 5000 units per metre. Colour, depth and
pose are associated by timestamp within a maximum difference; the pose is slerp-interpolated
from the ground truth at the colour image's time."""
from __future__ import annotations

import logging
from pathlib import Path

import numpy as np

from ramensim.core.frames import Intrinsics
from ramensim.core.errors import InputError
from ramensim.core.posefile import content_lines
from ramensim.world.datasets.common import DatasetFrame, Sequence, require_dir, require_file
from ramensim.world.trajectories import Trajectory, load_tum

log = logging.getLogger(__name__)

DEPTH_SCALE = 5000.0
# TUM's published calibrations (640 x 480); ROS default for anything else
CALIB = {
    "freiburg1": Intrinsics(517.3, 516.5, 318.6, 255.3, 640, 480),
    "freiburg2": Intrinsics(520.9, 521.0, 325.1, 249.7, 640, 480),
    "freiburg3": Intrinsics(535.4, 539.2, 320.1, 247.6, 640, 480),
}
DEFAULT_K = Intrinsics(525.0, 525.0, 319.5, 239.5, 640, 480)


def read_list(path: Path) -> tuple[np.ndarray, list[str]]:
    """'timestamp filename' lines (comments '#' skipped) -> timestamps (s) and file names."""
    require_file(path, "a TUM list of 'timestamp filename' lines")
    ts, names = [], []
    for no, s in content_lines(path, "'timestamp filename' lines"):
        parts = s.split()
        try:
            t = float(parts[0])
        except (ValueError, IndexError):
            t = float("nan")
        if len(parts) != 2 or not np.isfinite(t):
            raise InputError(f"{path}, line {no}: {s[:60]!r}; expected 'timestamp filename' with a finite "
                             f"timestamp in seconds.")
        ts.append(t)
        names.append(parts[1])
    if not ts:
        raise InputError(f"{path}: lists no images; expected 'timestamp filename' lines.")
    return np.asarray(ts), names


def _nearest(query: np.ndarray, ref: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Index of the nearest ``ref`` time for each ``query`` time and the absolute difference."""
    order = np.argsort(ref)
    r = ref[order]
    pos = np.clip(np.searchsorted(r, query), 1, len(r) - 1) if len(r) > 1 else np.zeros(len(query), int)
    if len(r) == 1:
        return np.full(len(query), order[0]), np.abs(query - r[0])
    left, right = r[pos - 1], r[pos]
    pick = np.where(np.abs(query - left) <= np.abs(right - query), pos - 1, pos)
    return order[pick], np.abs(query - r[pick])


def read_tum(root: Path, max_dt: float, skip_invalid: bool = True) -> Sequence:
    """Read a TUM RGB-D sequence folder; frame times are the colour timestamps minus the
    first associated one (s)."""
    require_dir(root, "a TUM RGB-D sequence folder with rgb.txt, depth.txt and groundtruth.txt")
    t_rgb, rgb = read_list(root / "rgb.txt")
    t_dep, dep = read_list(root / "depth.txt")
    gt_path = require_file(root / "groundtruth.txt", "TUM ground truth 'timestamp tx ty tz qx qy qz qw' lines")
    raw_gt = load_tum(gt_path, loop=False, skip_invalid=skip_invalid)
    t0_gt = _first_timestamp(gt_path)
    gt_times = raw_gt.times + t0_gt
    gt = Trajectory(gt_times, raw_gt.poses, loop=False, source=str(gt_path))
    di, ddt = _nearest(t_rgb, t_dep)
    gi, gdt = _nearest(t_rgb, gt_times)
    inside = (t_rgb >= gt_times[0] - max_dt) & (t_rgb <= gt_times[-1] + max_dt)
    keep = np.nonzero((ddt <= max_dt) & (gdt <= max_dt) & inside)[0]
    if len(keep) == 0:
        raise InputError(f"{root}: no colour image has a depth image and a ground-truth pose within "
                         f"{max_dt} s; expected overlapping timestamps in rgb.txt, depth.txt and "
                         f"groundtruth.txt (or raise world.scene.max_time_diff).")
    log.info("TUM %s: %d of %d colour frames associated", root.name, len(keep), len(t_rgb))
    start = t_rgb[keep[0]]
    frames = [DatasetFrame(float(t_rgb[k] - start), gt.pose(float(t_rgb[k])), root / rgb[k], root / dep[di[k]])
              for k in keep]
    calib = next((key for key in CALIB if key in str(root).lower()), None)
    K = CALIB[calib] if calib else DEFAULT_K
    log.info("TUM %s: intrinsics %s (fx %.1f fy %.1f cx %.1f cy %.1f); world.scene.intrinsics: camera "
             "overrides them with world.camera", root.name,
             f"of {calib} (from the folder name)" if calib else "ROS default (no freiburg1/2/3 in the path)",
             K.fx, K.fy, K.cx, K.cy)
    return Sequence(root.name, frames, K, DEPTH_SCALE, None)


def _first_timestamp(path: Path) -> float:
    for line in path.read_text(encoding="utf-8").splitlines():
        s = line.strip()
        if s and not s.startswith("#"):
            return float(s.split()[0])
    raise InputError(f"{path}: contains no poses; expected 'timestamp tx ty tz qx qy qz qw' lines.")
