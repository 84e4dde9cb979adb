"""``ramensim view RUN [RUN...]``: open one or several runs' recordings in the Rerun viewer.

Each RUN is a run folder (its recording, ``run.rrd`` or the ``recording.file_name`` its
``scenario.yaml`` names) or a ``.rrd`` file. One run opens with the ramensim layout. Several
runs open side by side: their recordings are combined into one (each run below its own
entity path, named after its folder; :mod:`ramensim.recording.combine`) with one column per
run -- its 3-D world over its plots -- and one time cursor for all; the combined file goes
to ``--out FILE`` or a temporary folder removed when the viewer closes. ``--separate``
opens them as separate recordings instead, listed in the viewer's Recordings panel (each
keeps its own recording id, derived from the whole resolved scenario and seed, so runs that
differ in any setting stay apart). The viewer is the ``rerun`` binary shipped with
rerun-sdk; it needs a display (X11 or Wayland on Linux). ``--print-command`` prints the
command line instead of running it (several runs side by side need ``--out FILE.rrd`` then:
the combined file the command opens, kept).

Scrubbing: the viewer's timeline panel (bottom) has two timelines, ``sim_time`` (simulated
seconds) and ``event`` (the count of events); pick ``sim_time``, then drag the time cursor, or
press space to play and the arrow keys to step. Every view (the 3-D world, the maps, the plots,
the message lines, the radios' states on a shared medium) shows the state at the cursor.
"""
from __future__ import annotations

import argparse
import os
import shlex
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Mapping, Sequence

from ramensim.core.errors import InputError

DEFAULT_FILE = "run.rrd"


def add_parser(sub) -> None:
    p = sub.add_parser("view", help="open runs' recordings (run.rrd) in the Rerun viewer",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("runs", nargs="+", metavar="RUN", help="run folders (or .rrd files)")
    p.add_argument("--print-command", action="store_true",
                   help="print the viewer's command line instead of starting it")
    p.add_argument("--separate", action="store_true",
                   help="open several runs as separate recordings instead of side by side")
    p.add_argument("--out", metavar="FILE", type=Path, default=None,
                   help="where to write the side-by-side recording of several runs (.rrd; default: a "
                        "temporary folder, removed when the viewer closes)")
    p.set_defaults(func=run)


def _recording_settings(run_dir: Path) -> dict:
    """The ``recording`` section of a run folder's scenario.yaml ({} when unreadable)."""
    path = run_dir / "scenario.yaml"
    if not path.is_file():
        return {}
    from ramensim.yamlsafe import safe_load_bounded

    try:
        data = safe_load_bounded(path.read_text(encoding="utf-8"))
    except Exception:  # noqa: BLE001 - an unreadable scenario.yaml leaves the defaults
        return {}
    rec = data.get("recording") if isinstance(data, dict) else None
    return rec if isinstance(rec, dict) else {}


def _file_name_of(run_dir: Path) -> str:
    """The recording's file name a run folder's scenario.yaml names (recording.file_name),
    else run.rrd."""
    name = _recording_settings(run_dir).get("file_name")
    return name if isinstance(name, str) and name.endswith(".rrd") and "/" not in name else DEFAULT_FILE


def _world_coordinates_of(rrd: Path) -> str:
    """The world axes the run of ``rrd`` logged (recording.world_coordinates of the
    scenario.yaml beside it), else RIGHT_HAND_Z_UP."""
    wc = _recording_settings(rrd.parent).get("world_coordinates")
    return wc if isinstance(wc, str) and wc else "RIGHT_HAND_Z_UP"


def _run_name(rrd: Path) -> str:
    """A run's name for the side-by-side view: its folder's name (a loose .rrd: its stem)."""
    return rrd.parent.name if (rrd.parent / "scenario.yaml").is_file() or rrd.name == DEFAULT_FILE else rrd.stem


def side_by_side(recordings: Sequence[Path], out: Path) -> Path:
    """Combine ``recordings`` into ``out`` with one column per run (labels from the run folders)."""
    from ramensim.recording.combine import combine, labels_for

    return combine(recordings, labels_for([_run_name(r) for r in recordings]), out,
                   [_world_coordinates_of(r) for r in recordings])


def recordings_of(runs: Sequence[str | Path]) -> list[Path]:
    """The .rrd file of each RUN (a run folder or a .rrd file), in order, duplicates dropped.
    Raises :class:`InputError` naming the first RUN without a recording."""
    out: list[Path] = []
    for run_arg in runs:
        p = Path(run_arg)
        if p.is_dir():
            rrd = p / _file_name_of(p)
            if not rrd.is_file():
                raise InputError(
                    f"RUN '{run_arg}': the run folder holds no recording {rrd.name}; expected a run of "
                    f"'ramensim run' with recording.mode save (a run with mode off, spawn, connect or serve "
                    f"writes none; rerun it with --rerun save).")
        elif p.is_file():
            if p.suffix != ".rrd":
                raise InputError(f"RUN '{run_arg}': a file that is not a .rrd recording; expected a run folder "
                                 f"or its run.rrd.")
            rrd = p
        else:
            raise InputError(f"RUN '{run_arg}': no such folder or file; expected a run folder written by "
                             f"'ramensim run' (holding run.rrd) or a .rrd file.")
        try:
            with open(rrd, "rb") as fh:
                magic = fh.read(4)
        except OSError as exc:
            raise InputError(f"RUN '{run_arg}': {rrd} cannot be read ({exc}); expected a readable .rrd file.") from None
        if not magic.startswith(b"RRF"):
            raise InputError(f"RUN '{run_arg}': {rrd.name} is not a Rerun recording (it does not start with the "
                             f".rrd magic bytes RRF); expected the run.rrd that 'ramensim run' wrote.")
        rrd = rrd.resolve()
        if rrd not in out:
            out.append(rrd)
    return out


def viewer_command(recordings: Sequence[Path], executable: Path | None = None) -> list[str]:
    """The command line that opens ``recordings`` in one Rerun viewer."""
    if executable is None:
        from ramensim.recording.viewer import rerun_executable

        executable = rerun_executable()
    return [str(executable), *(str(r) for r in recordings)]


def display_problem(env: Mapping[str, str] | None = None, platform: str | None = None) -> str | None:
    """None when a window can be opened, else why not, in words (Linux and other Unix
    systems need an X11 ``DISPLAY`` or a ``WAYLAND_DISPLAY``; macOS and Windows always have one)."""
    env = os.environ if env is None else env
    platform = sys.platform if platform is None else platform
    if platform.startswith(("darwin", "win", "cygwin")):
        return None
    if env.get("DISPLAY") or env.get("WAYLAND_DISPLAY"):
        return None
    return ("no display is available (neither DISPLAY nor WAYLAND_DISPLAY is set), so the Rerun viewer "
            "cannot open a window here")


def run(args: argparse.Namespace) -> int:
    recordings = recordings_of(args.runs)
    combined = len(recordings) > 1 and not args.separate
    if args.out is not None and (not combined or args.out.suffix != ".rrd"):
        raise InputError(f"--out '{args.out}': expected a .rrd file name, and several RUNs opened side by side "
                         f"(not with --separate).")
    if args.print_command and combined and args.out is None:
        raise InputError("--print-command with several runs side by side: expected --out FILE.rrd, the combined "
                         "recording the printed command opens (without --out it would be left in a temporary "
                         "folder that nothing removes); or --separate to print a command opening each run's own "
                         "recording.")
    problem = None if args.print_command else display_problem()
    if problem is not None:
        print(f"error: {problem}. The recordings are {', '.join(str(r) for r in recordings)}; open them on a "
              f"machine with a display (copy them there and run `ramensim view` or `rerun FILE...`), or log in "
              f"with X forwarding (ssh -X); `ramensim view --print-command RUN...` prints the command line "
              f"without starting the viewer.", file=sys.stderr)
        return 2
    tmp = None
    try:
        if combined:
            if args.out is not None:
                out = args.out
            else:
                tmp = Path(tempfile.mkdtemp(prefix="ramensim_view_"))
                out = tmp / "side_by_side.rrd"
            side_by_side(recordings, out)
            to_open = [out]
        else:
            to_open = recordings
        cmd = viewer_command(to_open)
        if args.print_command:
            print(shlex.join(cmd))
            return 0
        what = (f"{len(recordings)} runs side by side" if combined else
                f"{len(recordings)} recording{'s' if len(recordings) != 1 else ''}")
        print(f"opening {what} in the Rerun viewer (close its window to return)")
        return subprocess.call(cmd, stdin=subprocess.DEVNULL)
    finally:  # the temporary side-by-side file goes whether the viewer ran or combining failed
        if tmp is not None:
            shutil.rmtree(tmp, ignore_errors=True)
