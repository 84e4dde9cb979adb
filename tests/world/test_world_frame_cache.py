"""The frame cache (world/frame_cache.py): a trial's frames rendered once, the same bytes as
rendering them, bad files re-rendered and rewritten, the key, the size cap, memory."""
from __future__ import annotations

import logging
import os
import shutil
import tracemalloc
from pathlib import Path

import numpy as np
import pytest

from ramensim.core.errors import InputError
from ramensim.core.seeding import Seeds
from ramensim.world import RGBDCamera, build_world
from ramensim.world.config import WorldConfig
from ramensim.world.frame_cache import CACHE_ENV, CAP_ENV, MAGIC, cache_folder, frame_file_bytes

W, H = 40, 30


def _cfg(**over) -> WorldConfig:
    cam = {"width": W, "height": H, "fx": 30.0, "fy": 30.0, "cx": 19.5, "cy": 14.5, "fps": 2.0,
           "sensor": {"depth_noise_a": 0.005, "missing_fraction": 0.1, "color_noise": 0.01}}
    cam.update(over.pop("camera", {}))
    return WorldConfig.model_validate({"scene": {"name": "living_room", "seed": over.pop("layout", 0)},
                                       "camera": cam, **over})


def _world(monkeypatch, cache: Path | str, seed: int = 3, agents: int = 2, duration: float = 3.0, **over):
    monkeypatch.setenv(CACHE_ENV, str(cache))
    return build_world(_cfg(**over), agents, duration, Seeds(seed).numpy)


def _all(world) -> list:
    return [world.render(a, i) for a in range(world.n_agents) for i in range(len(world.frames_for(a)))]


def _same(a, b) -> bool:
    return (a.index == b.index and a.t == b.t and a.K == b.K and np.array_equal(a.c2w, b.c2w)
            and a.rgb.dtype == b.rgb.dtype == np.float32 and a.depth.dtype == b.depth.dtype == np.float32
            and a.rgb.tobytes() == b.rgb.tobytes() and a.depth.tobytes() == b.depth.tobytes())


def _no_rendering(monkeypatch) -> None:
    def refuse(self, c2w):
        raise AssertionError("rendered a frame the cache holds")

    monkeypatch.setattr(RGBDCamera, "render_arrays", refuse)


def test_cold_warm_and_off_give_the_same_bytes(tmp_path: Path, monkeypatch) -> None:
    ref = _all(_world(monkeypatch, "off"))
    assert not any(tmp_path.iterdir())
    cold_world = _world(monkeypatch, tmp_path)
    cold = _all(cold_world)
    streams = sorted(p for p in tmp_path.iterdir())
    assert len(streams) == 2 and all(len(list(p.glob("*.frame"))) == 6 for p in streams)
    assert all(f.stat().st_size == frame_file_bytes(W, H) for p in streams for f in p.glob("*.frame"))
    assert [s.store.misses for s in cold_world.sources] == [6, 6]
    _no_rendering(monkeypatch)
    warm_world = _world(monkeypatch, tmp_path)
    warm = _all(warm_world)
    assert [s.store.hits for s in warm_world.sources] == [6, 6]
    assert all(_same(a, b) for a, b in zip(ref, cold)) and all(_same(a, b) for a, b in zip(ref, warm))
    assert warm[0].rgb.flags.writeable and warm[0].depth.flags.writeable  # as a rendered frame's
    assert warm[0].rgb.flags.c_contiguous and warm[0].depth.flags.c_contiguous


def _corrupt(kind: str, path: Path, other: Path) -> None:
    data = bytearray(path.read_bytes())
    if kind == "truncated":
        path.write_bytes(bytes(data[: len(data) // 2]))
    elif kind == "flipped byte":
        data[-7] ^= 0x10
        path.write_bytes(bytes(data))
    elif kind == "foreign format":
        path.write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(data[8:]))
    elif kind == "other frame":
        shutil.copyfile(other, path)
    elif kind == "longer":
        path.write_bytes(bytes(data) + b"\0")
    elif kind == "empty":
        path.write_bytes(b"")
    else:
        raise AssertionError(kind)


@pytest.mark.parametrize("kind", ["truncated", "flipped byte", "foreign format", "other frame", "longer", "empty"])
def test_a_bad_file_is_rendered_again_and_rewritten(tmp_path: Path, monkeypatch, caplog, kind: str) -> None:
    ref = _world(monkeypatch, "off").render(0, 2)
    _all(_world(monkeypatch, tmp_path))
    world = _world(monkeypatch, tmp_path)
    store = world.sources[0].store
    path, other = store.path(2), store.path(3)
    _corrupt(kind, path, other)
    with caplog.at_level(logging.WARNING, logger="ramensim.world.frame_cache"):
        got = world.render(0, 2)
    assert _same(got, ref)
    assert any(str(path) in r.getMessage() and r.levelno == logging.WARNING for r in caplog.records)
    assert path.stat().st_size == frame_file_bytes(W, H) and path.read_bytes()[:8] == MAGIC
    _no_rendering(monkeypatch)
    assert _same(_world(monkeypatch, tmp_path).render(0, 2), ref)  # the rewritten file reads back


def _keys(world) -> list[str]:
    return [s.store.key for s in world.sources]


def test_the_key_follows_what_determines_the_frames(tmp_path: Path, monkeypatch) -> None:
    base = _keys(_world(monkeypatch, tmp_path))
    assert base == _keys(_world(monkeypatch, tmp_path)) and len(set(base)) == 2
    variants = {
        "run seed": _keys(_world(monkeypatch, tmp_path, seed=4)),
        "scene layout": _keys(_world(monkeypatch, tmp_path, layout=1)),
        "duration": _keys(_world(monkeypatch, tmp_path, duration=3.5)),
        "robots": _keys(_world(monkeypatch, tmp_path, agents=3)),
        "fps": _keys(_world(monkeypatch, tmp_path, camera={"fps": 2.5})),
        "intrinsics": _keys(_world(monkeypatch, tmp_path, camera={"fx": 31.0})),
        "sensor": _keys(_world(monkeypatch, tmp_path, camera={"sensor": {"depth_noise_a": 0.006}})),
        "split": _keys(_world(monkeypatch, tmp_path, trajectory={"kind": "procedural", "split": "chunks"})),
    }
    for what, keys in variants.items():
        assert not set(keys) & set(base), what


def _age(path: Path, seconds: float) -> None:
    t = path.stat().st_mtime - seconds
    os.utime(path, (t, t))


def test_the_cap_evicts_the_least_recently_used_stream(tmp_path: Path, monkeypatch, caplog) -> None:
    stream = 6 * frame_file_bytes(W, H)  # one robot, 3 s at 2 fps
    monkeypatch.setenv(CAP_ENV, str(2.5 * stream / 1e6))
    a = _world(monkeypatch, tmp_path, seed=1, agents=1)
    _all(a)
    b = _world(monkeypatch, tmp_path, seed=2, agents=1)
    _all(b)
    _age(a.sources[0].store.folder, 20)
    _age(b.sources[0].store.folder, 10)
    _world(monkeypatch, tmp_path, seed=1, agents=1)  # a used again: now b is the older one
    with caplog.at_level(logging.INFO, logger="ramensim.world.frame_cache"):
        c = _world(monkeypatch, tmp_path, seed=5, agents=1)
    _all(c)
    assert a.sources[0].store.folder.is_dir() and c.sources[0].store.folder.is_dir()
    assert not b.sources[0].store.folder.exists()
    assert any("evicting" in r.getMessage() for r in caplog.records)
    total = sum(f.stat().st_size for f in tmp_path.rglob("*") if f.is_file())
    assert total <= 2.5 * stream


def test_a_trial_larger_than_the_cap_is_not_written(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.setenv(CAP_ENV, str(frame_file_bytes(W, H) * 8 / 1e6))  # 12 frames would not fit
    ref = _all(_world(monkeypatch, "off"))
    world = _world(monkeypatch, tmp_path)
    assert all(_same(a, b) for a, b in zip(ref, _all(world)))
    assert not list(tmp_path.rglob("*.frame"))


def test_where_off_and_a_bad_cap(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.delenv(CACHE_ENV, raising=False)
    monkeypatch.setenv("RAMENSIM_CACHE_DIR", str(tmp_path / "root"))
    assert cache_folder() == tmp_path / "root" / "frames"  # beside the kernels' native/
    for off in ("off", "OFF", "0", "false", "none"):
        monkeypatch.setenv(CACHE_ENV, off)
        assert cache_folder() is None
    world = _world(monkeypatch, "off")
    assert all(s.store is None for s in world.sources)
    monkeypatch.setenv(CAP_ENV, "lots")
    with pytest.raises(InputError, match=f"{CAP_ENV} is 'lots'; expected .* size cap in MB"):
        _world(monkeypatch, tmp_path)


def test_cached_frames_are_not_held(tmp_path: Path, monkeypatch) -> None:
    """Frames are read one at a time as asked for: rendering a whole stream from the cache
    leaves no more memory allocated than before (nothing of a trial's frames is kept)."""
    w = _world(monkeypatch, tmp_path, agents=1, duration=20.0)  # 40 frames of 19 kB
    _all(w)
    w = _world(monkeypatch, tmp_path, agents=1, duration=20.0)
    n = len(w.frames_for(0))
    tracemalloc.start()
    try:
        w.render(0, 0)
        before = tracemalloc.get_traced_memory()[0]
        for i in range(n):
            w.render(0, i)
        after = tracemalloc.get_traced_memory()[0]
    finally:
        tracemalloc.stop()
    assert w.sources[0].store.hits == n + 1
    assert after - before < 2 * 16 * W * H, (after - before, n)
