"""Encodings round-trip (float32, sparse exactly; float16 within half precision) and count bytes."""
from __future__ import annotations

import numpy as np
import pytest
import torch

from ramensim.agents.encoding import ARRAY_HEADER_BYTES, HEADER_BYTES, decode, encode


def _payload(n=1000, visited=0.1, seed=0):
    g = torch.Generator().manual_seed(seed)
    theta0 = (torch.rand(n, generator=g) - 0.5) * 2e-4
    theta = theta0.clone()
    visits = torch.zeros(n, dtype=torch.int64)
    idx = torch.randperm(n, generator=g)[: int(visited * n)]
    theta[idx] = torch.randn(idx.numel(), generator=g)
    visits[idx] = torch.randint(1, 500, (idx.numel(),), generator=g)
    return {"theta": theta, "visits": visits}, theta0, idx.numel()


def test_float32_round_trip_and_bytes():
    p, _, _ = _payload()
    e = encode(p, "float32")
    d = decode(e)
    assert torch.equal(d["theta"], p["theta"]) and torch.equal(d["visits"], p["visits"])
    assert d["visits"].dtype == torch.int64
    assert e.nbytes == HEADER_BYTES + 2 * ARRAY_HEADER_BYTES + 1000 * 4 + 1000 * 4


def test_float16_within_half_precision():
    p, _, _ = _payload()
    e = encode(p, "float16")
    d = decode(e)
    x, y = p["theta"].double(), d["theta"].double()
    assert bool(((y - x).abs() <= x.abs() * 2.0**-11 + 2.0**-25).all())
    assert torch.equal(d["visits"], p["visits"])
    assert e.nbytes == HEADER_BYTES + 2 * ARRAY_HEADER_BYTES + 1000 * 2 + 1000 * 4


def test_sparse_round_trip_exact_and_small():
    p, theta0, k = _payload(visited=0.1)
    e = encode(p, "sparse", theta0)
    assert e.layout == "sparse"
    d = decode(e, theta0)
    assert torch.equal(d["theta"], p["theta"]) and torch.equal(d["visits"], p["visits"])
    assert e.nbytes == HEADER_BYTES + 3 * ARRAY_HEADER_BYTES + k * (4 + 4 + 4)


def test_sparse_sends_entries_moved_by_consensus():
    p, theta0, k = _payload(visited=0.1)
    p["theta"][0] += 1.0  # moved although never visited (consensus does this)
    p["visits"][0] = 0
    d = decode(encode(p, "sparse", theta0), theta0)
    assert torch.equal(d["theta"], p["theta"]) and torch.equal(d["visits"], p["visits"])


def test_sparse_falls_back_to_dense_when_smaller():
    p, theta0, _ = _payload(visited=0.9)
    e = encode(p, "sparse", theta0)
    assert e.layout == "dense"
    assert e.nbytes == encode(p, "float32").nbytes
    assert torch.equal(decode(e, theta0)["theta"], p["theta"])


def test_small_tensors_and_dsgt_payload():
    n = 50
    p = {"theta": torch.zeros(n), "y": torch.zeros(n), "degree": torch.tensor([3], dtype=torch.int32)}
    p["y"][7] = 2.5
    d = decode(encode(p, "sparse", torch.zeros(n)), torch.zeros(n))
    assert torch.equal(d["y"], p["y"]) and int(d["degree"][0]) == 3 and d["degree"].dtype == torch.int32


def test_encoding_errors():
    p, theta0, _ = _payload()
    with pytest.raises(ValueError, match="unknown"):
        encode(p, "bfloat8")
    with pytest.raises(ValueError, match="theta0"):
        encode(p, "sparse")
    e = encode(p, "sparse", theta0)
    with pytest.raises(ValueError, match="theta0"):
        decode(e)
    big = {"theta": torch.zeros(2), "visits": torch.tensor([0, np.iinfo(np.int64).max])}
    with pytest.raises(ValueError, match="int32"):
        encode(big, "float32")
