"""``ramensim view RUN [RUN...]``: open one or several runs' recordings in the Rerun viewer.

Each RUN is a run folder (its recording, ``run.rrd`` or the ``recording.file_name`` its
``scenario.yaml`` names) or a ``.rrd`` file. All of them open in one viewer, which lists them
in its Recordings panel: every run has its own recording id (derived from the whole resolved
scenario and seed), so runs that differ in any setting stay apart, and each opens with the
ramensim layout. The viewer is the ``rerun`` binary shipped with rerun-sdk; it needs a display
(X11 or Wayland on Linux). ``--print-command`` prints the command line instead of running it.
"""
from __future__ import annotations

import argparse
import os
import shlex
import subprocess
import sys
from pathlib import Path
from typing import Mapping, Sequence

from ramensim.errors import InputError

DEFAULT_FILE = "run.rrd"


def add_parser(sub) -> None:
    p = sub.add_parser("view", help="open runs' recordings (run.rrd) in the Rerun viewer",
                       description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("runs", nargs="+", metavar="RUN", help="run folders (or .rrd files)")
    p.add_argument("--print-command", action="store_true",
                   help="print the viewer's command line instead of starting it")
    p.set_defaults(func=run)


def _file_name_of(run_dir: Path) -> str:
    """The recording's file name a run folder's scenario.yaml names (recording.file_name),
    else run.rrd."""
    path = run_dir / "scenario.yaml"
    if not path.is_file():
        return DEFAULT_FILE
    from ramensim.yamlsafe import safe_load_bounded

    try:
        data = safe_load_bounded(path.read_text(encoding="utf-8"))
    except Exception:  # noqa: BLE001 - an unreadable scenario.yaml leaves the default name
        return DEFAULT_FILE
    rec = data.get("recording") if isinstance(data, dict) else None
    name = rec.get("file_name") if isinstance(rec, dict) else None
    return name if isinstance(name, str) and name.endswith(".rrd") and "/" not in name else DEFAULT_FILE


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
    cmd = viewer_command(recordings)
    if args.print_command:
        print(shlex.join(cmd))
        return 0
    problem = display_problem()
    if problem is not None:
        print(f"error: {problem}. The recordings are {', '.join(str(r) for r in recordings)}; open them on a "
              f"machine with a display (copy them there and run `ramensim view` or `rerun FILE...`), or log in "
              f"with X forwarding (ssh -X); `ramensim view --print-command RUN...` prints the command line "
              f"without starting the viewer.", file=sys.stderr)
        return 2
    print(f"opening {len(recordings)} recording{'s' if len(recordings) != 1 else ''} in the Rerun viewer "
          f"(close its window to return)")
    return subprocess.call(cmd, stdin=subprocess.DEVNULL)
