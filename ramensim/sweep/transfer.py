"""Bring a finished point folder from the node that ran it into the sweep folder (Ray).

On a cluster a point runs on whichever node Ray picks, in that node's own file system: a
relative or even absolute sweep folder on the driver means nothing there. So a Ray task runs
its point in a temp folder of its node and hands the finished folder back in one of two ways:

* **through Ray** (default): the folder is packed into one uncompressed tar archive that is
  the task's return value; the driver unpacks it;
* **through a storage folder** the user names (``--storage PATH``): a folder mounted at the
  same path on every node and on the driver (NFS, a cluster file system); the task leaves
  the finished folder there and returns only its path, the driver moves or copies it.

Either way the task also returns a manifest (relative path -> size in bytes of every file).
The driver unpacks/copies into ``runs/.partial-NAME-XXXX``, checks every file of the
manifest is there with its size, and only then renames it to ``runs/NAME``
(:func:`ramensim.sweep.store.commit_dir`): a point is reported ok only once its files are in
the sweep folder.
"""
from __future__ import annotations

import io
import os
import shutil
import tarfile
from dataclasses import dataclass
from pathlib import Path, PurePosixPath
from typing import Any

from ramensim.sweep import store

MAX_ARCHIVE_BYTES = 2 * 1024 ** 3
"""Largest run folder sent back through Ray (2 GiB); a larger one fails with a pointer to
``--storage``."""


class TransferError(RuntimeError):
    """A run's files could not be brought into the sweep folder."""


@dataclass
class Shipment:
    """What a Ray task returns for one point: its result and its files (archive or location)."""

    result: Any
    """The :class:`ramensim.sweep.worker.PointResult`."""
    manifest: dict[str, int]
    """Relative POSIX path -> size in bytes of every file of the finished point folder."""
    host: str
    """Host name of the node that ran the point."""
    archive: bytes | None = None
    """The folder as an uncompressed tar archive (sent back through Ray)."""
    location: str | None = None
    """Absolute path of the finished folder under the storage folder."""


def manifest(folder: Path) -> dict[str, int]:
    """Relative path -> size in bytes of every regular file under ``folder``."""
    folder = Path(folder)
    out: dict[str, int] = {}
    for root, _dirs, files in os.walk(folder):
        for name in files:
            path = Path(root) / name
            if path.is_file() and not path.is_symlink():
                out[path.relative_to(folder).as_posix()] = path.stat().st_size
    return dict(sorted(out.items()))


def pack(folder: Path) -> bytes:
    """The regular files and folders under ``folder`` as one tar archive (relative names)."""
    folder = Path(folder)
    total = sum(manifest(folder).values())
    if total > MAX_ARCHIVE_BYTES:
        raise TransferError(f"the run folder holds {total / 1024 ** 3:.1f} GiB, more than the "
                            f"{MAX_ARCHIVE_BYTES / 1024 ** 3:.0f} GiB sent back through Ray; pass --storage PATH, "
                            f"a folder mounted at the same path on every node, to move it through the file system")
    buf = io.BytesIO()
    with tarfile.open(fileobj=buf, mode="w", format=tarfile.PAX_FORMAT) as tar:
        for root, dirs, files in os.walk(folder):
            dirs.sort()
            for name in sorted(files):
                path = Path(root) / name
                if path.is_file() and not path.is_symlink():
                    tar.add(path, arcname=path.relative_to(folder).as_posix(), recursive=False)
    return buf.getvalue()


def _safe_member(member: tarfile.TarInfo) -> bool:
    name = PurePosixPath(member.name)
    return (member.isfile() or member.isdir()) and not name.is_absolute() and ".." not in name.parts


def unpack(archive: bytes, dest: Path) -> None:
    """Unpack an archive made by :func:`pack` into the existing folder ``dest`` (regular files
    and folders with relative names only; anything else is refused)."""
    with tarfile.open(fileobj=io.BytesIO(archive), mode="r:") as tar:
        members = tar.getmembers()
        bad = [m.name for m in members if not _safe_member(m)]
        if bad:
            raise TransferError(f"the archive sent back holds entries that are not plain relative files: {bad[:5]}")
        tar.extractall(dest, members=members, filter="data")


def verify(dest: Path, expected: dict[str, int]) -> None:
    """Raise :class:`TransferError` unless every file of ``expected`` is under ``dest`` with its size."""
    have = manifest(dest)
    missing = [p for p in expected if p not in have]
    wrong = [p for p, size in expected.items() if p in have and have[p] != size]
    if missing or wrong:
        parts = []
        if missing:
            parts.append(f"{len(missing)} missing ({', '.join(missing[:5])})")
        if wrong:
            parts.append(f"{len(wrong)} with another size ({', '.join(wrong[:5])})")
        raise TransferError(f"the files that arrived in {dest} differ from those the node wrote: " + "; ".join(parts))


def receive(shipment: Shipment, runs_dir: Path, name: str) -> None:
    """Put a shipped point folder into ``runs_dir/name``: unpack or move it into a temp folder,
    check it against the manifest, then commit it atomically. A storage copy is removed
    once committed; if the driver cannot read it, it stays where it is and the error says where."""
    runs_dir = Path(runs_dir)
    if shipment.archive is None and shipment.location is None:
        raise TransferError("the task sent back neither an archive nor a storage location")
    partial = store.new_partial_dir(runs_dir, name)
    moved_from: Path | None = None
    try:
        if shipment.archive is not None:
            unpack(shipment.archive, partial)
        else:
            source = Path(shipment.location)  # type: ignore[arg-type]
            if not (source / store.STATUS).is_file():
                raise TransferError(
                    f"node {shipment.host} left the run's files in {source}, which the driver cannot read: "
                    f"--storage must name a folder mounted at the same path on every node and on the driver")
            partial.rmdir()
            try:
                os.rename(source, partial)  # same file system: instant
                moved_from = source
            except OSError:
                shutil.copytree(source, partial)
        verify(partial, shipment.manifest)
    except BaseException:
        if moved_from is not None and not moved_from.exists():
            os.rename(partial, moved_from)  # leave the files where the node put them
        else:
            shutil.rmtree(partial, ignore_errors=True)
        raise
    store.commit_dir(partial, runs_dir / name)
    if shipment.location is not None:
        shutil.rmtree(Path(shipment.location).parent, ignore_errors=True)
