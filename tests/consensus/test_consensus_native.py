"""RAMEN's compiled edge kernel (agents/consensus/csrc/ramenedge.c) against the torch path of
RamenMethod._edge: over several rounds and every dual mode, the consensus state (D, A, the
dual p, the per-link duals and halves, 2 h_ij) is bit-identical; the round's three sums
(residual, mean weight, penalty) agree to float rounding; equal counts (flat weights) too."""
from __future__ import annotations

from types import SimpleNamespace

import pytest
import torch

from ramensim.agents.consensus import RamenMethod
from ramensim.agents.consensus import _native
from ramensim.agents.copies import NeighbourCopy

pytestmark = pytest.mark.skipif(_native.get_lib() is None, reason="native kernel unavailable")

N = 70_001  # more than one partial-sum block, not a multiple of a vector width


def _state(seed: int, flat: bool = False):
    g = torch.Generator().manual_seed(seed)
    theta = torch.randn(N, generator=g) * 0.1
    visits = torch.zeros(N, dtype=torch.int32) if flat else torch.randint(0, 60, (N,), generator=g, dtype=torch.int32)
    copies = []
    for j in (1, 2, 3):
        vj = visits.clone() if flat else torch.randint(0, 60, (N,), generator=g, dtype=torch.int32)
        copies.append(NeighbourCopy(j, {"theta": theta + torch.randn(N, generator=g) * 0.05,
                                        "visits": vj}, float(seed), float(seed)))
    return SimpleNamespace(theta=theta, visits=visits), copies


@pytest.mark.parametrize("dual", ["node", "per_link", "antisymmetric"])
@pytest.mark.parametrize("flat", [False, True])
def test_kernel_gives_the_torch_paths_state(dual, flat):
    native = RamenMethod(N, 2, beta_l=1e-3, beta_u=0.1, primal="prox", dual=dual)
    ref = RamenMethod(N, 2, beta_l=1e-3, beta_u=0.1, primal="prox", dual=dual)
    ref._kernel_takes = lambda *a: False
    for r in range(3):
        learner, copies = _state(r, flat)
        assert native._kernel_takes(learner, copies[0], native._c, native._incr)
        out = []
        for m in (native, ref):
            m._theta_t.copy_(learner.theta)
            out.append(m._prepare(learner, copies))
        for key in ("residual_sq", "mean_weight", "penalty"):
            assert out[0][key] == pytest.approx(out[1][key], rel=1e-5, abs=1e-12), (r, key)
        assert torch.equal(native._c, ref._c) and torch.equal(native._a, ref._a)
        assert torch.equal(native._h, ref._h) and torch.equal(native.p, ref.p)
        assert native.links.keys() == ref.links.keys()
        for j in ref.links:
            assert torch.equal(native.links[j], ref.links[j])
        for j in ref.half_links:
            assert torch.equal(native.half_links[j], ref.half_links[j])


def test_sums_do_not_depend_on_the_thread_count():
    learner, copies = _state(7)
    stats = []
    for threads in (1, 3):
        m = RamenMethod(N, 2, beta_l=1e-3, beta_u=0.1)
        m._theta_t.copy_(learner.theta)
        old = torch.get_num_threads()
        torch.set_num_threads(threads)
        try:
            stats.append(m._prepare(learner, copies))
        finally:
            torch.set_num_threads(old)
    assert stats[0] == stats[1]


def test_int64_counts_take_the_torch_path():
    learner, copies = _state(1)
    learner.visits = learner.visits.long()
    m = RamenMethod(N, 2, beta_l=1e-3, beta_u=0.1)
    assert not m._kernel_takes(learner, copies[0], m._c, m._incr)


def test_source_is_package_data_and_compiles_without_warnings(tmp_path):
    import fnmatch
    import shutil
    import subprocess
    import tomllib
    from pathlib import Path

    from ramensim.core.native import BASE_FLAGS, compiler, with_march

    repo = Path(__file__).resolve().parents[2]
    cfg = tomllib.loads((repo / "pyproject.toml").read_text())["tool"]["setuptools"]
    rel = _native.SOURCE.relative_to((repo / cfg["package-dir"]["ramensim.agents"]).resolve()).as_posix()
    assert any(fnmatch.fnmatch(rel, p) for p in cfg["package-data"]["ramensim.agents"]), rel
    cc = compiler()
    if shutil.which(cc[0]) is None:
        pytest.skip("no C compiler")
    flags = [f for f in with_march(BASE_FLAGS) if f not in ("-shared", "-fPIC", "-g")]
    res = subprocess.run([*cc, *flags, "-Werror", "-c", str(_native.SOURCE), "-o",
                          str(tmp_path / "x.o")], capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    assert "#define SUM_BLOCK " + str(_native.SUM_BLOCK) in _native.SOURCE.read_text()
