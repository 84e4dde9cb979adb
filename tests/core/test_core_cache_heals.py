"""Caches that heal (issue 28): a cached kernel that does not load is rebuilt once instead of
leaving every later run on the slow fallback; a backend-choice file with wrong types is
ignored, named in a warning, and measured again."""
from __future__ import annotations

import json
import os
import subprocess
import sys

import torch

from ramensim.agents.map import backend


def _load_in_new_process(tmp_path, src) -> str:
    """compile_shared of ``src`` in a fresh process (dlopen caches by path within one)."""
    code = ("import logging, sys; logging.basicConfig(level=logging.WARNING, stream=sys.stdout)\n"
            "from pathlib import Path\nfrom ramensim.core import native\n"
            f"lib = native.compile_shared(Path({str(src)!r}), 'tiny', ['-O2', '-shared', '-fPIC'])\n"
            "print('twice', lib.twice(21))\n")
    env = {**os.environ, "RAMENSIM_CACHE_DIR": str(tmp_path)}
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=300)
    assert res.returncode == 0, res.stderr[-2000:]
    return res.stdout


def test_truncated_kernel_is_rebuilt(tmp_path):
    src = tmp_path / "tiny.c"
    src.write_text("int twice(int x) { return 2 * x; }\n")
    assert "twice 42" in _load_in_new_process(tmp_path, src)
    (so,) = (tmp_path / "native").glob("tiny_*.so")
    so.write_bytes(so.read_bytes()[:100])  # a torn file, as a full disk leaves
    out = _load_in_new_process(tmp_path, src)
    assert "does not load" in out and "rebuilding" in out and "twice 42" in out
    assert so.stat().st_size > 1000


def test_wrong_typed_backend_cache_is_measured_again(tmp_path, monkeypatch, caplog):
    monkeypatch.setenv("RAMENSIM_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(backend, "_memo", {})
    shape = (32, 48, 32, 16, 32)
    key = backend.cache_key("decoder", shape, torch.device("cpu"))
    path = backend._cache_path("decoder", key)
    path.parent.mkdir(parents=True, exist_ok=True)
    bad = {"schema": backend.SCHEMA, "backend": "c", "threads": "two", "timings_ms": [1, 2]}
    path.write_text(json.dumps(bad))
    calls = []
    monkeypatch.setattr(backend, "measure", lambda stage, shape, device, avail, threads=None: calls.append(1) or
                        {f"{nm}@1": 0.001 * (i + 1) for i, nm in enumerate(avail)})
    with caplog.at_level("WARNING"):
        ch = backend.select("decoder", shape, torch.device("cpu"))
    assert calls and ch.how == "measured" and str(path) in caplog.text and "invalid" in caplog.text
    assert json.loads(path.read_text())["threads"] in (0, 1, 2)  # rewritten valid


def test_doctor_reports_the_caches_health(tmp_path):
    """doctor's cache lines name a kernel that does not load and a backend choice that is
    invalid (both healed at their next use), and say 'all' when everything is fine."""
    from ramensim.commands.doctor_backends import cache_health

    good = {"schema": backend.SCHEMA, "stage": "grid", "backend": "c", "threads": 2,
            "timings_ms": {"c@2": 1.0}}
    (tmp_path / "backend_grid_a.json").write_text(json.dumps(good))
    lines = cache_health(tmp_path)
    assert "0 kernels, 1 backend choices" in lines[0] and "all load" in lines[1] and "all valid" in lines[2]
    (tmp_path / "mapkernels_x.so").write_bytes(b"\x7fELF" + b"\0" * 96)
    (tmp_path / "backend_grid_b.json").write_text(json.dumps({**good, "threads": "two"}))
    lines = cache_health(tmp_path)
    assert "1 do not load, rebuilt at next use: mapkernels_x.so" in lines[1]
    assert "1 invalid, measured again at next use: backend_grid_b.json ('threads' is 'two'" in lines[2]
    assert "empty" in cache_health(tmp_path / "missing")[0]
