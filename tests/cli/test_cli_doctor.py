"""``ramensim doctor``: the backends in use (native kernels or the fallback and why, CUDA,
Embree, rerun, threads) and a measured samples/s figure; without a compiler it names the
slowdown and the fix."""
from __future__ import annotations

import re
from pathlib import Path

import pytest
import torch

from ramensim.agents.map import _native
from ramensim.agents.map import backend as B
from ramensim.cli import main

ROOT = Path(__file__).resolve().parents[2]
SMALL = [str(ROOT / "scenarios" / "two_robots_30s.yaml"), "--set", "map.n_rays=64", "--threads", "1"]


@pytest.fixture
def fake_choice(tmp_path, monkeypatch):
    """Backend choices from fixed fake timings (the selector itself is tested elsewhere)."""
    monkeypatch.setattr(B, "_memo", {})
    monkeypatch.setattr(B, "_cache_path", lambda stage, key: tmp_path / f"{stage}_{key}.json")
    monkeypatch.setattr(B, "measure", lambda stage, shape, device, names, **kw:
                        {f"{n}@1": 0.001 * (i + 1) for i, n in enumerate(names)})
    threads = torch.get_num_threads()
    yield
    torch.set_num_threads(threads)


def _speed(out: str) -> float:
    m = re.search(r"map speed: ([\d,]+) field samples/s", out)
    assert m, out
    return float(m.group(1).replace(",", ""))


def test_doctor_prints_backends_and_a_measured_speed(fake_choice, capsys):
    assert main(["doctor", *SMALL, "--speed-s", "0.2"]) == 0
    out = capsys.readouterr().out
    assert "backends in use:" in out
    native = _native.get_lib() is not None
    assert ("map kernels: native C" in out) == native
    assert re.search(r"CUDA: (none|available|torch built for CUDA)", out)
    assert "ray casting (camera, culling, path-loss walls): Embree (embreex " in out
    assert re.search(r"rerun: rerun-sdk 0\.41\.", out)
    assert re.search(r"threads: \d+ logical cores; torch 1 intra-op", out)
    assert _speed(out) > 0
    from ramensim.config import load_scenario

    cfg = load_scenario(SMALL[0], ["map.n_rays=64"]).map
    assert f"of {64 * (cfg.n_stratified + cfg.n_surface):,} samples" in out  # rays x samples per ray


def test_doctor_without_a_compiler_names_the_slowdown_and_the_fix(fake_choice, tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("CC", str(tmp_path / "no-such-cc"))
    monkeypatch.setenv("RAMENSIM_CACHE_DIR", str(tmp_path / "cache"))  # nothing built yet
    monkeypatch.delenv("RAMENSIM_NO_NATIVE", raising=False)
    monkeypatch.setattr(_native, "_lib", None)
    monkeypatch.setattr(_native, "_tried", False)
    monkeypatch.setattr(_native, "_mlp_libs", {})
    assert main(["doctor", *SMALL, "--speed-s", "0"]) == 0
    out = capsys.readouterr().out
    assert f"map kernels: FALLBACK, pure torch: no C compiler: {tmp_path / 'no-such-cc'} was not found ($CC)" in out
    assert "WARNING: the map runs its pure-torch path, roughly 30x slower per mapping iteration" in out
    assert "to fix: install gcc with OpenMP (or set CC to such a C compiler)" in out
    assert "map speed:" not in out  # --speed-s 0 skips the measurement


def test_doctor_fallback_by_setting_says_which_setting(fake_choice, capsys):
    assert main(["doctor", *SMALL, "--set", "map.native=false", "--speed-s", "0"]) == 0
    out = capsys.readouterr().out
    assert "FALLBACK, pure torch: map.native = false in the scenario" in out
    assert "to fix: set map.native: true" in out


def test_doctor_refuses_a_bad_speed_budget(capsys):
    assert main(["doctor", "--speed-s", "-1"]) == 2
    assert "--speed-s" in capsys.readouterr().err
