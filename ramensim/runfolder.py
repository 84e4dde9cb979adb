"""The run folder: its name, its lock, the check before reusing it, and the per-run log file
(atomic writes: :mod:`ramensim.core.files`)."""
from __future__ import annotations

import errno
import fcntl
import logging
import os
import re
import time
from pathlib import Path

from ramensim.core.errors import InputError

LOCK = ".run.lock"
"""flock held by the process writing a run folder (released by the kernel when it dies)."""
RUN_FILES = ("scenario.yaml", "run.log", "messages.csv", "metrics.json", "run.rrd", "mesh_*.ply", LOCK)
"""What a run writes into its folder (``--overwrite`` removes these, nothing else)."""
MAX_NAME = 80
"""Longest scenario-name part of a run folder's name (characters)."""


def safe_name(name: str) -> str:
    """``name`` as one file-name component: letters, digits, ``_ . -`` only, at most
    :data:`MAX_NAME` characters, never empty, never ``..`` (a scenario name is user input)."""
    return re.sub(r"[^A-Za-z0-9_.-]+", "-", name).strip("-.")[:MAX_NAME].strip("-.") or "run"


def writable_output(path: str | Path, flag: str) -> Path:
    """Check before any work that the output file ``path`` (given by ``flag``) can be written:
    its folder is created if needed and must be a writable folder, and ``path`` must not be a
    folder. Raises an InputError naming the flag, the path and the reason."""
    p = Path(path)
    if p.is_dir():
        raise InputError(f"{flag} {p}: is a folder; expected the name of a file to write.")
    blocker = next((a for a in p.parents if a.exists() and not a.is_dir()), None)
    if blocker is not None:
        raise InputError(f"{flag} {p}: {blocker} is a file, not a folder; expected a path in a writable folder.")
    try:
        p.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"{flag} {p}: its folder cannot be created ({exc.strerror or exc}); expected a path "
                         f"in a writable folder.") from None
    if not os.access(p.parent, os.W_OK | os.X_OK):
        raise InputError(f"{flag} {p}: the folder {p.parent} is not writable; expected a path in a writable folder.")
    return p


def new_run_dir(parent: str | Path, name: str, seed: int) -> Path:
    """``parent/<name>_seed<seed>_<YYYYmmdd-HHMMSS>`` (suffixed if it exists)."""
    safe = safe_name(name)
    stamp = time.strftime("%Y%m%d-%H%M%S")
    base = Path(parent) / f"{safe}_seed{seed}_{stamp}"
    path, k = base, 1
    while path.exists():
        k += 1
        path = base.with_name(f"{base.name}-{k}")
    return path


def prepare_out_dir(out: Path, overwrite: bool, names: tuple[str, str] = ("--out", "--overwrite")) -> None:
    """Refuse an existing non-empty ``out`` unless ``overwrite``; then remove the files of the
    previous run (:data:`RUN_FILES`) so two runs' files never mix. ``names``: how the errors
    call the folder argument and the overwrite switch (the CLI's flags, or the API's keywords)."""
    out = Path(out)
    arg, switch = names
    if out.exists() and not out.is_dir():
        raise InputError(f"{arg} {out}: exists and is not a folder; expected a new or empty folder.")
    if not out.is_dir():
        return
    try:
        entries = sorted(p.name for p in out.iterdir() if p.name != LOCK)
    except OSError as exc:
        raise InputError(f"{arg} {out}: cannot be read ({exc}); expected a writable folder.") from None
    if not entries:
        return
    if not overwrite:
        shown = ", ".join(entries[:5]) + (f" and {len(entries) - 5} more" if len(entries) > 5 else "")
        raise InputError(f"{arg} {out}: the folder is not empty ({shown}); a run writes into a new or empty "
                         f"folder so that two runs' files never mix. Pass {switch} to replace the previous "
                         f"run's files there, or choose another {arg}.")
    with RunLock(out):
        for pattern in RUN_FILES:
            for p in out.glob(pattern):
                if p.is_file() and p.name != LOCK:
                    p.unlink()


class FolderLock:
    """Exclusive ``flock`` on ``<folder>/<lock_name>`` while one process writes the folder (the
    kernel releases it if the process is killed). Subclasses name the file and the message."""

    lock_name = LOCK
    busy = "another run is writing this folder"
    advice = "wait for it to finish or choose another --out"

    def __init__(self, out_dir: Path) -> None:
        self.path = Path(out_dir) / self.lock_name
        self._fd: int | None = None

    def __enter__(self):
        self.path.parent.mkdir(parents=True, exist_ok=True)
        while True:
            fd = os.open(self.path, os.O_RDWR | os.O_CREAT, 0o644)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except OSError as exc:
                os.close(fd)
                if exc.errno in (errno.EAGAIN, errno.EACCES):
                    raise InputError(f"{self.path.parent}: {self.busy} (it holds {self.path}); "
                                     f"{self.advice}.") from None
                raise
            # The holder unlinks the file before it unlocks (so finished folders carry no lock
            # file): a lock taken on an inode that is no longer the path's is stale, try again.
            try:
                same = os.stat(self.path).st_ino == os.fstat(fd).st_ino
            except FileNotFoundError:
                same = False
            if same:
                break
            os.close(fd)
        os.ftruncate(fd, 0)
        os.write(fd, f"{os.getpid()}\n".encode())
        self._fd = fd
        return self

    def __exit__(self, *exc: object) -> None:
        if self._fd is not None:
            try:
                os.unlink(self.path)  # while still locked: see __enter__
            except OSError:
                pass
            fcntl.flock(self._fd, fcntl.LOCK_UN)
            os.close(self._fd)
            self._fd = None


class RunLock(FolderLock):
    """The lock of a run folder (``.run.lock``): two runs never write one folder."""


class _QuietFileHandler(logging.FileHandler):
    """run.log's handler: a line that cannot be written (a full disk) is dropped, not reported
    with a traceback on stderr (logging's default); the same message still reaches the console."""

    def handleError(self, record: logging.LogRecord) -> None:  # noqa: N802 - logging's name
        pass


class RunLog:
    """Attach a file handler writing ``run.log`` in the run folder for the run's duration."""

    def __init__(self, path: Path) -> None:
        self.handler = _QuietFileHandler(path, encoding="utf-8")
        self.handler.setFormatter(logging.Formatter("%(asctime)s %(levelname)s %(name)s: %(message)s"))
        self.handler.setLevel(logging.INFO)

    def __enter__(self) -> "RunLog":
        root = logging.getLogger()
        root.addHandler(self.handler)
        if root.level > logging.INFO or root.level == logging.NOTSET:
            self._old = root.level
            root.setLevel(logging.INFO)
        else:
            self._old = None
        return self

    def __exit__(self, *exc: object) -> None:
        root = logging.getLogger()
        root.removeHandler(self.handler)
        self.handler.close()
        if self._old is not None:
            root.setLevel(self._old)
