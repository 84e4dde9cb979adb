"""Per-array wire types (``consensus.wire``, agents/encoding.py): each type round-trips within
its rule, RAMEN with ``{lam: float16, visits: uint16}`` costs DiNNO's bytes, the quantised
visit counts move eq. 19's weights within the stated bound, decoded copies are still shared,
and a wrong key or type is one paragraph naming the file and the key."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import torch

from ramensim.agents.consensus import ConsensusConfig, make_method
from ramensim.agents.consensus.weights import edge_weights
from ramensim.agents.copies import CopyStore
from ramensim.agents.encoding import (ARRAY_HEADER_BYTES, HEADER_BYTES, SCALE_BYTES, decode, dequantise,
                                      encode, quantise)
from ramensim.agents.step import ConsensusStep
from ramensim.agents.toy import make_least_squares
from ramensim.cli import main
from ramensim.config import load_scenario
from ramensim.core.errors import InputError

EQUAL_BYTES = {"lam": "float16", "visits": "uint16"}
"""RAMEN's message at DiNNO's bytes (docs/CONSENSUS.md, "Equal bytes")."""


def _counts(n: int, top: int, seed: int, zeros: float = 0.3) -> torch.Tensor:
    """Visit-count-like int32 vector: a share of zeros, a heavy tail up to ``top``."""
    g = np.random.default_rng(seed)
    u = np.floor(top * g.random(n) ** 4).astype(np.int64)
    u[g.random(n) < zeros] = 0
    u[g.integers(n)] = top
    return torch.from_numpy(u.astype(np.int32))


# --- round trips ---------------------------------------------------------------------

@pytest.mark.parametrize("dtype", [torch.int32, torch.int64])
@pytest.mark.parametrize("wt,bits", [("uint16", 16), ("uint8", 8)])
def test_quantised_counts_round_trip_within_E(wt: str, bits: int, dtype: torch.dtype) -> None:
    top = (1 << bits) - 1
    for m in (7, top, top + 1, 3 * top + 2, 1_000_003, 2**31 - 1):
        u = _counts(4000, m, seed=m).to(dtype)
        e = encode({"theta": torch.zeros(4000), "visits": u}, "float32", wire={"visits": wt})
        assert e.arrays["visits"].dtype == np.dtype(wt)
        back = decode(e)["visits"]
        assert back.dtype == dtype
        s = m / top
        bound = math.floor((s + 1) / 2)  # |round(q s) - u| <= E (agents/encoding.quantise)
        err = int((back.long() - u.long()).abs().max())
        assert err <= bound, (m, err, bound)
        if m <= top:
            assert err == 0  # s <= 1: lossless
        elif s >= 3:
            assert err >= 1  # it really is quantised (the check above is not vacuous)
        assert int(back.max()) == m  # the maximum maps to 2^b - 1 and back exactly


def test_quantise_zero_counts_and_bad_input() -> None:
    q, s = quantise(np.zeros(5, dtype=np.int32), 16)
    assert s == 0.0 and not q.any() and not dequantise(q, s).any()
    with pytest.raises(ValueError, match="non-negative"):
        quantise(np.array([3, -1]), 8)
    with pytest.raises(ValueError, match="8 or 16"):
        quantise(np.array([3]), 12)


def test_float_wire_types_round_trip() -> None:
    g = torch.Generator().manual_seed(1)
    x = torch.randn(3000, generator=g) * 10.0 ** torch.randint(-6, 3, (3000,), generator=g)
    d32 = decode(encode({"theta": x, "lam": x}, "float32", wire={"lam": "float32"}))
    assert torch.equal(d32["theta"], x) and torch.equal(d32["lam"], x)
    d16 = decode(encode({"theta": x, "lam": x}, "float32", wire={"lam": "float16"}))
    assert torch.equal(d16["theta"], x)  # not named: the kind's float32
    err = (d16["lam"].double() - x.double()).abs()
    assert bool((err <= x.double().abs() * 2.0**-11 + 2.0**-25).all())  # the float16 rules
    assert float(err.max()) > 0.0
    # the float16 kind with theta kept float32 by the override
    mixed = encode({"theta": x, "y": x}, "float16", wire={"theta": "float32"})
    assert mixed.arrays["theta"].dtype == np.float32 and mixed.arrays["y"].dtype == np.float16


def test_int32_wire_is_exact_and_wrong_kinds_refused() -> None:
    u = _counts(100, 10**6, seed=3).to(torch.int64)
    e = encode({"visits": u}, "float32", wire={"visits": "int32"})
    assert torch.equal(decode(e)["visits"], u) and not e.scales
    with pytest.raises(ValueError, match="integer array 'visits'"):
        encode({"visits": u}, "float32", wire={"visits": "float16"})
    with pytest.raises(ValueError, match="float array 'theta'"):
        encode({"theta": torch.zeros(3)}, "float32", wire={"theta": "uint8"})
    with pytest.raises(ValueError, match="sparse"):
        encode({"theta": torch.zeros(3)}, "sparse", torch.zeros(3), wire={"theta": "float16"})


def test_no_override_is_the_kind_unchanged() -> None:
    theta, u = torch.randn(500), _counts(500, 900, seed=4)
    for kind in ("float32", "float16"):
        a, b = encode({"theta": theta, "visits": u}, kind), encode({"theta": theta, "visits": u}, kind, wire={})
        assert a.nbytes == b.nbytes and not b.scales
        assert all(a.arrays[k].dtype == b.arrays[k].dtype and np.array_equal(a.arrays[k], b.arrays[k])
                   for k in a.arrays)


# --- bytes -----------------------------------------------------------------------------

def _outbox_bytes(method: str, wire: dict[str, str], n: int = 257) -> tuple[int, int, int]:
    """(bytes of agent 0's message to agent 1, its shared part, its link part) after one
    round of a two-agent ``method`` team with antisymmetric duals (the default), through
    ``ConsensusStep`` as the simulation drives it."""
    prob = make_least_squares(2, n, 40, np.random.default_rng(0))
    cfg = ConsensusConfig(primal_steps=2, wire=wire)
    steps = [ConsensusStep(k, prob.learner(k), make_method(method, cfg, n, degree=1, agent=k),
                           CopyStore(k, [1 - k]), "float32", prob.theta0, lambda: 1, wire=cfg.wire)
             for k in range(2)]
    for k in range(2):
        steps[k].run_round(0.0)
    steps[0].receive(1, steps[1].make_payload(1.0).for_link(0)[0], 1.0, 1.0)
    steps[0].run_round(1.0)
    out = steps[0].make_payload(2.0)
    payload, nbytes = out.for_link(1)
    assert isinstance(payload, tuple), "antisymmetric duals: the link half travels with the message"
    return nbytes, out.nbytes, out.links[1][1]


@pytest.mark.parametrize("n", [257, 4096])
def test_ramen_at_equal_bytes_costs_dinno_bytes(n: int) -> None:
    ramen, ramen_shared, ramen_link = _outbox_bytes("ramen", {}, n)
    equal, equal_shared, equal_link = _outbox_bytes("ramen", EQUAL_BYTES, n)
    dinno, dinno_shared, dinno_link = _outbox_bytes("dinno", {}, n)
    # default RAMEN: theta f32 + visits i32 + lam f32 = 12 n, DiNNO theta + lam = 8 n
    assert ramen - 2 * HEADER_BYTES - 3 * ARRAY_HEADER_BYTES == 12 * n
    assert dinno - 2 * HEADER_BYTES - 2 * ARRAY_HEADER_BYTES == 8 * n
    # with the override: theta 4 n + visits 2 n + lam 2 n = DiNNO's 8 n; the headers differ by
    # visits' array header and its scale
    assert equal - 2 * HEADER_BYTES - 3 * ARRAY_HEADER_BYTES - SCALE_BYTES == 8 * n
    assert equal == dinno + ARRAY_HEADER_BYTES + SCALE_BYTES
    assert (equal_shared, equal_link) == (HEADER_BYTES + 2 * ARRAY_HEADER_BYTES + SCALE_BYTES + 6 * n,
                                          HEADER_BYTES + ARRAY_HEADER_BYTES + 2 * n)
    assert (ramen_link, dinno_link) == (HEADER_BYTES + ARRAY_HEADER_BYTES + 4 * n,) * 2


def test_map_sized_message_bytes() -> None:
    """The byte counts docs/CONSENSUS.md states, at the default map's n."""
    from ramensim.agents.map.config import MapConfig

    n = MapConfig().n_params
    shared = {"theta": torch.zeros(n), "visits": torch.ones(n, dtype=torch.int32)}
    link = {"lam": torch.zeros(n)}
    equal = encode(shared, "float32", wire=EQUAL_BYTES).nbytes + encode(link, "float32", wire=EQUAL_BYTES).nbytes
    dinno = encode({"theta": torch.zeros(n)}, "float32").nbytes + encode(link, "float32").nbytes
    ramen = encode(shared, "float32").nbytes + encode(link, "float32").nbytes
    assert (ramen, equal, dinno) == (12 * n + 56, 8 * n + 64, 8 * n + 48)


# --- eq. 19 under quantised counts -------------------------------------------------------

@pytest.mark.parametrize("bits", [8, 16])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_eq19_weight_error_bound(bits: int, seed: int) -> None:
    """The receiver computes eq. 19 from its own counts u_i and the neighbour's decoded ones.
    With the line (eps, zeta) of the exact counts the error is eps |du| <= (beta_u - beta_l) /
    (2^b - 1) when max u_j <= R (here min u_sum = 0); with the line recomputed from the decoded
    counts, as both ends do, at most (beta_u - beta_l) E / (R - 2E) in w_ij and twice that in
    w_ji (agents/encoding.quantise)."""
    n, top = 20000, (1 << bits) - 1
    beta_l, beta_u = 1e-7, 1e-4
    span = beta_u - beta_l
    u_i, u_j = _counts(n, 180_000, seed), _counts(n, 250_000, seed + 10)
    u_i[:5] = 0
    u_j[:5] = 0  # parameters neither robot visited: min u_sum = 0
    q, s = quantise(u_j.numpy(), bits)
    d_j = torch.from_numpy(dequantise(q, s)).to(torch.int32)
    du = (d_j.long() - u_j.long()).abs()
    E = math.floor((s + 1) / 2)
    assert int(du.max()) <= E
    usum = (u_i.long() + u_j.long())
    R = int(usum.max() - usum.min())
    m_j = int(u_j.max())
    assert m_j <= R
    eps = span / R
    line_err = float((eps * du.double()).max())
    assert line_err <= span / top * m_j / R * (1 + 1e-12) <= span / top * (1 + 1e-12)
    assert line_err > 0.25 * span / top  # the bound is nearly reached: the check is not vacuous

    w = [torch.empty(n) for _ in range(4)]
    edge_weights(u_i, u_j, beta_l, beta_u, w[0], w[1])
    edge_weights(u_i, d_j, beta_l, beta_u, w[2], w[3])
    ulp = 4 * beta_u * 2.0**-23  # float32 weights
    err_ij = float((w[2].double() - w[0].double()).abs().max())
    err_ji = float((w[3].double() - w[1].double()).abs().max())
    assert err_ij <= span * E / (R - 2 * E) + ulp
    assert err_ji <= span * 2 * E / (R - 2 * E) + ulp
    assert err_ji <= 2 * span / top * (1 + 1e-3) + ulp  # first order: twice the line's bound at most


def test_eq19_line_bound_needs_unvisited_parameters() -> None:
    """Without a parameter that neither robot visited the range R can be far below max u_j and
    the line's bound grows with max u_j / R, as stated: quantising counts 10^6 .. 10^6 + 9 to
    8 bits loses which parameter was visited more."""
    u_i = torch.zeros(10, dtype=torch.int32)
    u_j = torch.arange(10, dtype=torch.int32) + 1_000_000
    q, s = quantise(u_j.numpy(), 8)
    d_j = torch.from_numpy(dequantise(q, s)).to(torch.int32)
    w = [torch.empty(10) for _ in range(4)]
    edge_weights(u_i, u_j, 1e-7, 1e-4, w[0], w[1])
    edge_weights(u_i, d_j, 1e-7, 1e-4, w[2], w[3])
    assert float((w[3] - w[1]).abs().max()) > (1e-4 - 1e-7) / 255 * 10


# --- decoded once, shared ------------------------------------------------------------------

def test_decoded_once_and_shared_with_quantised_arrays() -> None:
    prob = make_least_squares(3, 64, 20, np.random.default_rng(1))
    cfg = ConsensusConfig(primal_steps=1, wire=EQUAL_BYTES)
    steps = [ConsensusStep(k, prob.learner(k), make_method("ramen", cfg, 64, degree=2, agent=k),
                           CopyStore(k, [j for j in range(3) if j != k]), "float32", prob.theta0, lambda: 2,
                           wire=cfg.wire) for k in range(3)]
    steps[0].run_round(0.0)
    shared = steps[0].make_payload(1.0).payload
    assert "visits" in shared.scales
    steps[1].receive(0, shared, 1.0, 1.0)
    steps[2].receive(0, shared, 1.0, 1.0)
    a, b = steps[1].store.get(0).tensors, steps[2].store.get(0).tensors
    assert a["visits"] is b["visits"] and a["theta"] is b["theta"]  # one copy for both robots
    assert a["visits"].dtype == prob.learner(0).visits.dtype
    assert decode(shared)["visits"] is a["visits"]


# --- input errors ----------------------------------------------------------------------------

CASES = {
    # name: (file text, fragments the message must contain)
    "key_not_sent_by_dinno": ("method: dinno\nconsensus:\n  wire: {visits: uint16}\n",
                              ["consensus.wire.visits", "dinno", "theta (float), lam (float)"]),
    "unknown_key": ("consensus:\n  wire:\n    thetas: float16\n", ["consensus.wire.thetas", "line 3", "visits (int)"]),
    "unknown_type": ("consensus:\n  wire:\n    visits: uint12\n", ["consensus.wire.visits", "'uint12'", "uint8"]),
    "float_as_uint": ("consensus:\n  wire: {theta: uint8}\n", ["consensus.wire.theta", "float array", "float16"]),
    "count_as_float": ("consensus:\n  wire: {visits: float16}\n", ["consensus.wire.visits", "integer array", "uint16"]),
    "lam_without_link_duals": ("consensus:\n  dual_update: node\n  wire: {lam: float16}\n",
                               ["consensus.wire.lam", "antisymmetric", "'node'"]),
    "with_sparse": ("consensus:\n  encoding: sparse\n  wire: {lam: float16}\n", ["consensus.wire", "sparse"]),
    "local_sends_nothing": ("method: local\nconsensus:\n  wire: {theta: float16}\n",
                            ["consensus.wire.theta", "local", "no messages"]),
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_wire_input_errors(name: str, tmp_path: Path, capsys) -> None:
    text, fragments = CASES[name]
    path = tmp_path / f"{name}.yaml"
    path.write_text(text)
    with pytest.raises(InputError) as info:
        load_scenario(path)
    message = str(info.value)
    assert str(path) in message and "\n" not in message.strip()
    for fragment in fragments:
        assert fragment in message, (fragment, message)
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and str(path) in err


def test_wire_accepted_where_it_fits(tmp_path: Path) -> None:
    path = tmp_path / "ok.yaml"
    path.write_text("method: ramen\nconsensus:\n  wire: {lam: float16, visits: uint16}\n")
    assert dict(load_scenario(path).consensus.wire) == EQUAL_BYTES
    path.write_text("method: dsgt\nconsensus:\n  encoding: float16\n  wire: {theta: float32, degree: uint8}\n")
    assert load_scenario(path).consensus.wire == {"theta": "float32", "degree": "uint8"}
    assert load_scenario(tmp_path / "ok.yaml", ["method=dinno", "consensus.wire={lam: float16}"]).consensus.wire \
        == {"lam": "float16"}
