"""A screenshot of the real Rerun viewer showing a recording (e.g. docs/images/viewer.png), made by
``tools/viewer_screenshot.py`` (:func:`main`).

    python tools/viewer_screenshot.py runs/<run>/run.rrd --out docs/images/viewer.png [--time 30]
    python tools/viewer_screenshot.py --demo --out docs/images/viewer.png

Starts a headless ``rerun`` viewer bound to 127.0.0.1 (:class:`~ramensim.recording.viewer.HeadlessViewer`;
software Vulkan works: Debian's ``mesa-vulkan-drivers``), opens the recording, moves the time cursor
to ``--time`` (simulated seconds; default: the end of the run) and saves a PNG. ``--demo`` first
writes a recording of the synthetic event stream (:mod:`ramensim.recording.synthetic`). Not a
``ramensim`` command: it needs the viewer binary and a Vulkan driver, which a run never does, and
only makes the documentation's pictures.
"""
from __future__ import annotations

import argparse
import logging
import tempfile
from pathlib import Path
from typing import Sequence

import numpy as np

log = logging.getLogger(__name__)


def write_demo(run_dir: Path, duration_s: float = 30.0) -> Path:
    """Record the synthetic 3-agent run of ``duration_s`` simulated seconds into ``run_dir/run.rrd``
    and return its path."""
    from ramensim.recording import RecordingConfig, make_recorder
    from ramensim.recording.synthetic import synthetic_events, synthetic_scene

    scene = synthetic_scene()
    events = synthetic_events(3, duration_s, rng=np.random.default_rng(0), scene=scene, image_hw=(240, 320))
    cfg = RecordingConfig(image_downsample=2)
    rec = make_recorder(cfg, run_dir, 3, scene.vertices, scene.faces, scene.colors, scene.bounds, seed=0)
    assert rec is not None
    with rec:
        for e in events:
            rec(e)
    return run_dir / cfg.file_name


def screenshot(rrd: Path, size: tuple[int, int], t: float | None, log_file: Path) -> tuple[bytes, float]:
    """A PNG of the headless viewer (window ``size`` in points, W x H) showing the recording ``rrd``
    at simulated time ``t`` (s; None: the end of its ``sim_time`` timeline), and that time (s)."""
    from ramensim.recording.viewer import HeadlessViewer

    with HeadlessViewer(window_size=size, log_file=log_file) as viewer:
        viewer.open(rrd)
        if t is None:
            start, end = viewer.timelines().get("sim_time", (0, 0))
            t = end / 1e9
        return viewer.screenshot_at(t), t


def main(argv: Sequence[str] | None = None) -> int:
    """The script: 0 with the PNG written; 2 with one logged paragraph when the viewer cannot run
    here or the input is bad."""
    from ramensim.recording.viewer import vulkan_driver_problem

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("rrd", nargs="?", type=Path, help="recording to show (.rrd)")
    ap.add_argument("--demo", action="store_true", help="record the synthetic demo run and show it")
    ap.add_argument("--out", type=Path, default=Path("docs/images/viewer.png"), help="PNG to write")
    ap.add_argument("--time", type=float, default=None, help="simulated time to show (s); default: the end")
    ap.add_argument("--size", default="1600x900", help="viewer window size in points, WxH")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    problem = vulkan_driver_problem()
    if problem is not None:
        log.error("cannot screenshot the viewer: %s", problem)
        return 2
    try:
        w, h = (int(x) for x in args.size.lower().split("x"))
    except ValueError:
        log.error("--size %r: expected WIDTHxHEIGHT, e.g. 1600x900", args.size)
        return 2
    with tempfile.TemporaryDirectory() as tmp:
        if args.demo:
            rrd = write_demo(Path(tmp) / "demo_run")
        elif args.rrd is not None:
            rrd = args.rrd
            if not rrd.is_file():
                log.error("%s: no such recording; expected a .rrd file such as runs/<run>/run.rrd", rrd)
                return 2
        else:
            ap.error("give a recording (.rrd) or --demo")
        png, t = screenshot(rrd, (w, h), args.time, Path(tmp) / "viewer.log")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_bytes(png)
    log.info("wrote %s (%d bytes, sim_time %.2f s)", args.out, len(png), t)
    return 0
