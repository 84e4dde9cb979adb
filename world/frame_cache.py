"""A folder of rendered camera frames shared by the runs of one trial.

A rendered frame is a pure function of the scene's mesh (vertices, faces, colours), the
camera (intrinsics, sensor model), its pose and time, and its sensor-noise seed
(``ramensim.world.sources.frame_rng``): never of the method, the channel or the consensus
settings. So every method and success rate of a sweep's trial renders the same frames; this
module keeps them on disk so that only the first run of a trial renders them.

Layout: ``<root>/<key>/<idx>.frame``, one file per frame of one agent's stream. ``key``
(32 hex digits) hashes everything the stream's images depend on: the renderer (the bytes of
``world/camera.py`` and ``world/sources.py``, this file format's version, the numpy,
trimesh and embreex versions and the CPU model, since Embree's SIMD path may differ), the
mesh, the intrinsics, the sensor settings, the sensor seed, and every frame's time and pose
(so the scene layout, the trajectory with the run's duration, the split, the number of
robots and the fps are all in it through the poses they produce). ``root`` is
``$RAMENSIM_FRAME_CACHE`` (a folder; ``off`` turns the cache off), default
``$RAMENSIM_CACHE_DIR/frames`` (``~/.cache/ramensim/frames``).

A frame file: a fixed header (magic, format version, the stream's key, the frame index,
height, width, payload bytes), the SHA-256 of header and payload, then the payload: rgb
(H, W, 3) and depth (H, W) as little-endian float32, the exact bytes the camera produced.
Files are written atomically (temp file + rename, without fsync: a torn file fails its
checksum) and verified on every read; a file that is truncated, corrupt, of another format
or of another stream is logged at warning, rendered again and rewritten. Frames are read one
at a time when the run's camera asks for them, nothing is held.

Size: ``16 W H + 80`` bytes per frame (307,280 bytes at 160 x 120); the folder is capped at
``$RAMENSIM_FRAME_CACHE_MB`` megabytes (10^6 bytes, default 4096). When a world is built,
the streams used least recently are evicted until the folder plus the frames this trial may
still write fit the cap; a trial larger than the cap is rendered without writing.
"""
from __future__ import annotations

import hashlib
import json
import logging
import os
import re
import struct
import time
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING, Sequence

import numpy as np

from ramensim.core.errors import InputError
from ramensim.core.files import WriteFailed, atomic_write_with
from ramensim.core.native import cache_root, cpu_model

if TYPE_CHECKING:
    from ramensim.world.camera import RGBDCamera
    from ramensim.world.sources import RenderedFrameSource

log = logging.getLogger(__name__)

CACHE_ENV = "RAMENSIM_FRAME_CACHE"
"""A folder for the cache, or ``off`` (also ``0``, ``false``, ``no``, ``none``) to turn it off."""
CAP_ENV = "RAMENSIM_FRAME_CACHE_MB"
"""The cap on the cache folder's size, MB (10^6 bytes)."""
DEFAULT_CAP_MB = 4096.0
FORMAT_VERSION = 1
MAGIC = b"RMSFRAME"
_HEADER = struct.Struct("<8sI16sIIIQ")  # magic, version, key, index, height, width, payload bytes
_DIGEST = 32  # SHA-256 of header + payload
_KEY_RE = re.compile(r"^[0-9a-f]{32}$")
_FRAME_RE = re.compile(r"^\d+\.frame$")
_STALE_TMP_S = 3600.0  # a temp file this old belongs to a writer that died
_WARN_PER_STREAM = 3  # warnings per stream before the rest go to debug


def frame_file_bytes(width: int, height: int) -> int:
    """Size of one cached frame (bytes): header, checksum, rgb and depth float32."""
    return _HEADER.size + _DIGEST + 16 * width * height


def cache_folder() -> Path | None:
    """The cache folder ``$RAMENSIM_FRAME_CACHE`` names (default ``<cache root>/frames``),
    or None when it is off."""
    raw = os.environ.get(CACHE_ENV, "").strip()
    if raw.lower() in ("off", "0", "false", "no", "none"):
        return None
    return Path(raw).expanduser() if raw else cache_root() / "frames"


def cap_bytes() -> int:
    """The cache's size cap in bytes, from ``$RAMENSIM_FRAME_CACHE_MB`` (MB, default 4096)."""
    raw = os.environ.get(CAP_ENV, "").strip()
    if not raw:
        return int(DEFAULT_CAP_MB * 1e6)
    try:
        mb = float(raw)
    except ValueError:
        mb = float("nan")
    if not (mb > 0 and np.isfinite(mb)):
        raise InputError(f"environment variable {CAP_ENV} is {raw!r}; expected the camera frame cache's size "
                         f"cap in MB, a positive number (default {DEFAULT_CAP_MB:g}); to turn the cache off set "
                         f"{CACHE_ENV}=off.")
    return int(mb * 1e6)


@lru_cache(maxsize=1)
def renderer_fingerprint() -> bytes:
    """What the renderer's output depends on besides its inputs: its code, this format,
    the libraries' versions and the CPU."""
    from importlib import metadata

    from ramensim.world import camera, sources

    h = hashlib.sha256(b"ramensim frames %d\0" % FORMAT_VERSION)
    for mod in (camera, sources):
        h.update(Path(mod.__file__).read_bytes())
    for dist in ("numpy", "trimesh", "embreex"):
        try:
            h.update(f"{dist} {metadata.version(dist)}\0".encode())
        except metadata.PackageNotFoundError:
            h.update(f"{dist} ?\0".encode())
    h.update(cpu_model().encode())
    return h.digest()


def camera_fingerprint(camera: "RGBDCamera") -> bytes:
    """The mesh (vertices, faces, the colours the camera reads), intrinsics and sensor model."""
    h = hashlib.sha256(renderer_fingerprint())
    mesh = camera.caster.mesh
    for arr in (mesh.vertices, mesh.faces, camera.colors.face, camera.colors.corner):
        if arr is None:
            h.update(b"none\0")
            continue
        a = np.ascontiguousarray(arr)
        h.update(f"{a.dtype.str} {a.shape}\0".encode())
        h.update(a.tobytes())
    h.update(repr(camera.K.as_tuple()).encode())
    sensor = camera.sensor.model_dump() if camera.sensor is not None else None
    h.update(json.dumps(sensor, sort_keys=True).encode())
    return h.digest()


def stream_key(camera_fp: bytes, seed: int, times: np.ndarray, poses: np.ndarray) -> str:
    """The key (32 hex digits) of one agent's stream: camera fingerprint, sensor seed, and
    every frame's time (s) and camera-to-world pose."""
    h = hashlib.sha256(camera_fp)
    h.update(f"seed {int(seed)}\0".encode())
    h.update(np.ascontiguousarray(times, np.float64).tobytes())
    h.update(np.ascontiguousarray(poses, np.float64).tobytes())
    return h.hexdigest()[:32]


class FrameStore:
    """The cached frames of one stream (one agent's camera in one trial)."""

    def __init__(self, folder: Path, key: str, width: int, height: int) -> None:
        self.folder = folder
        self.key = key
        self._key_bytes = bytes.fromhex(key)[:16]
        self.width, self.height = int(width), int(height)
        self.writable = True
        self.hits = 0
        self.misses = 0
        self._warned = 0

    def path(self, idx: int) -> Path:
        return self.folder / f"{int(idx):06d}.frame"

    def _header(self, idx: int) -> bytes:
        return _HEADER.pack(MAGIC, FORMAT_VERSION, self._key_bytes, int(idx), self.height, self.width,
                            16 * self.width * self.height)

    def load(self, idx: int) -> tuple[np.ndarray, np.ndarray] | None:
        """Frame ``idx``'s (rgb (H, W, 3), depth (H, W)) float32 arrays, or None when it is not
        cached or its file fails a check (logged at warning; the caller renders it again)."""
        path = self.path(idx)
        try:
            fh = open(path, "rb")
        except FileNotFoundError:
            self.misses += 1
            return None
        except OSError as exc:
            return self._reject(path, idx, f"unreadable ({exc.strerror or exc})")
        with fh:
            head = fh.read(_HEADER.size + _DIGEST)
            if len(head) < _HEADER.size + _DIGEST:
                return self._reject(path, idx, f"truncated ({len(head)} bytes, shorter than its header)")
            magic, version, key, index, h, w, nbytes = _HEADER.unpack_from(head)
            if magic != MAGIC:
                return self._reject(path, idx, "not a frame-cache file")
            if version != FORMAT_VERSION:
                return self._reject(path, idx, f"of format version {version} (this one reads {FORMAT_VERSION})")
            if key != self._key_bytes or index != idx:
                return self._reject(path, idx, f"frame {index} of another stream")
            if (h, w, nbytes) != (self.height, self.width, 16 * self.width * self.height):
                return self._reject(path, idx, f"a {w}x{h} image ({nbytes} payload bytes), expected "
                                               f"{self.width}x{self.height}")
            rgb = np.empty((self.height, self.width, 3), "<f4")
            depth = np.empty((self.height, self.width), "<f4")
            got = fh.readinto(memoryview(rgb).cast("B")) + fh.readinto(memoryview(depth).cast("B"))
            if got != nbytes:
                return self._reject(path, idx, f"truncated ({got} of {nbytes} payload bytes)")
            if fh.read(1):
                return self._reject(path, idx, "longer than its header says")
        digest = hashlib.sha256(head[:_HEADER.size])
        digest.update(memoryview(rgb).cast("B"))
        digest.update(memoryview(depth).cast("B"))
        if digest.digest() != head[_HEADER.size:]:
            return self._reject(path, idx, "corrupt (checksum mismatch)")
        self.hits += 1
        return rgb.astype(np.float32, copy=False), depth.astype(np.float32, copy=False)

    def _reject(self, path: Path, idx: int, why: str) -> None:
        self.misses += 1
        self._warned += 1
        level = logging.WARNING if self._warned <= _WARN_PER_STREAM else logging.DEBUG
        log.log(level, "frame cache: %s is %s; rendering frame %d again and rewriting it%s", path, why, idx,
                " (further such files of this stream are logged at debug level)"
                if self._warned == _WARN_PER_STREAM else "")
        return None

    def save(self, idx: int, rgb: np.ndarray, depth: np.ndarray) -> None:
        """Write frame ``idx`` (atomically); a failure turns writing off for this stream, logged once."""
        if not self.writable:
            return
        rgb = np.ascontiguousarray(rgb, "<f4")
        depth = np.ascontiguousarray(depth, "<f4")
        if rgb.shape != (self.height, self.width, 3) or depth.shape != (self.height, self.width):
            raise ValueError(f"frame {idx}: rgb {rgb.shape} / depth {depth.shape} do not match the stream's "
                             f"{self.width}x{self.height} camera")
        head = self._header(idx)
        digest = hashlib.sha256(head)
        digest.update(memoryview(rgb).cast("B"))
        digest.update(memoryview(depth).cast("B"))

        def write(tmp: Path) -> None:
            with open(tmp, "wb") as fh:
                fh.write(head)
                fh.write(digest.digest())
                fh.write(memoryview(rgb).cast("B"))
                fh.write(memoryview(depth).cast("B"))

        try:
            self.folder.mkdir(parents=True, exist_ok=True)  # again: another process may have evicted it
            atomic_write_with(self.path(idx), write, frame_file_bytes(self.width, self.height), durable=False)
        except (WriteFailed, OSError) as exc:
            self.writable = False
            log.warning("frame cache: cannot write %s (%s); this stream's frames are rendered without caching",
                        self.folder, exc)


def _folder_usage(folder: Path, now: float) -> tuple[int, int]:
    """(bytes, frame files) of one stream's folder; removes temp files left by dead writers."""
    size = count = 0
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return 0, 0
    for e in entries:
        try:
            st = e.stat(follow_symlinks=False)
        except OSError:
            continue
        if e.name.endswith(".tmp") and e.name.startswith("."):
            if now - st.st_mtime > _STALE_TMP_S:
                try:
                    os.unlink(e.path)
                except OSError:
                    pass
                continue
        elif _FRAME_RE.match(e.name):
            count += 1
        size += st.st_size
    return size, count


def _evict(folder: Path) -> None:
    """Remove a stream's frame files (and stale temp files), then its folder if empty; nothing
    else is touched, so a cache pointed at a user's folder never deletes the user's files."""
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return
    for e in entries:
        if _FRAME_RE.match(e.name) or (e.name.startswith(".") and e.name.endswith(".tmp")):
            try:
                os.unlink(e.path)
            except OSError:
                pass
    try:
        folder.rmdir()
    except OSError:
        pass


class FrameCache:
    """The cache folder ``root`` with a size cap ``cap`` (bytes)."""

    def __init__(self, root: Path, cap: int) -> None:
        self.root = Path(root)
        self.cap = int(cap)

    @classmethod
    def from_env(cls) -> "FrameCache | None":
        """The cache the environment asks for (:data:`CACHE_ENV`, :data:`CAP_ENV`), or None when off."""
        folder = cache_folder()
        if folder is None:
            return None
        return cls(folder, cap_bytes())

    def streams(self) -> list[tuple[float, str, int, int]]:
        """Every stream in the folder: (last use, key, bytes, frames), least recently used first."""
        now = time.time()
        out = []
        try:
            entries = list(os.scandir(self.root))
        except OSError:
            return []
        for e in entries:
            if not (_KEY_RE.match(e.name) and e.is_dir(follow_symlinks=False)):
                continue
            try:
                mtime = e.stat(follow_symlinks=False).st_mtime
            except OSError:
                continue
            size, count = _folder_usage(Path(e.path), now)
            out.append((mtime, e.name, size, count))
        return sorted(out)

    def open(self, keys: Sequence[str], n_frames: Sequence[int], width: int, height: int) -> list[FrameStore]:
        """One store per stream (``keys[i]`` with ``n_frames[i]`` frames of ``width`` x ``height``).

        Marks the streams used now and evicts the least recently used others until the folder
        plus the frames these streams may still write fit the cap; when they cannot fit on
        their own, the stores only read."""
        try:
            self.root.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            log.warning("frame cache: cannot create %s (%s); frames are rendered without caching "
                        "(set %s to a writable folder, or to off)", self.root, exc, CACHE_ENV)
            return []
        stores = [FrameStore(self.root / k, k, width, height) for k in keys]
        per_frame = frame_file_bytes(width, height)
        now = time.time()
        mine = set(keys)
        held = {k: (0, 0) for k in keys}
        others = []
        for mtime, key, size, count in self.streams():
            if key in mine:
                held[key] = (size, count)
            else:
                others.append((mtime, key, size))
        for s in stores:
            if s.folder.is_dir():
                try:
                    os.utime(s.folder, (now, now))  # last use: now
                except OSError:
                    pass
        own = sum(size for size, _ in held.values())
        need = sum(max(0, n - held[k][1]) * per_frame for k, n in zip(keys, n_frames))
        if own + need > self.cap:
            log.info("frame cache: this trial's frames take %.1f MB, more than the cap of %.1f MB (%s); they are "
                     "read where cached and rendered without writing", (own + need) / 1e6, self.cap / 1e6, CAP_ENV)
            for s in stores:
                s.writable = False
            return stores
        total = own + sum(size for _, _, size in others)
        for _, key, size in others:  # least recently used first
            if total + need <= self.cap:
                break
            log.info("frame cache: evicting stream %s (%.1f MB, least recently used) to stay under %.1f MB",
                     key, size / 1e6, self.cap / 1e6)
            _evict(self.root / key)
            total -= size
        return stores


def attach_frame_cache(sources: Sequence["RenderedFrameSource"], camera: "RGBDCamera") -> FrameCache | None:
    """Give every source its store in the cache the environment names (nothing when it is
    off); returns the cache. Sources keep rendering frames the cache lacks."""
    cache = FrameCache.from_env()
    if cache is None or not sources:
        return None
    fp = camera_fingerprint(camera)
    keys = []
    for s in sources:
        sched = s.frames()
        times = np.array([t for t, _ in sched], np.float64)
        poses = np.stack([p for _, p in sched]) if sched else np.zeros((0, 4, 4))
        keys.append(stream_key(fp, s.seed, times, poses))
    stores = cache.open(keys, [len(s) for s in sources], camera.K.width, camera.K.height)
    for s, store in zip(sources, stores):
        s.store = store
    return cache
