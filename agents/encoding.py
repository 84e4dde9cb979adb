"""Message encodings that make message sizes honest: the bytes a message costs on the
channel are the bytes of the arrays it carries plus a small fixed header.

- ``float32``: every float vector as float32, integer vectors (visits, degree) as int32.
  The reference; lossless.
- ``float16``: float vectors as IEEE half (relative error <= 2^-11, absolute <= 2^-25 below
  the normal range, values beyond 65504 overflow to inf), integers as int32.
- ``sparse``: one shared int32 index list of the entries where *any* vector of the message
  differs from its reference (``theta`` vs the shared initial ``theta0`` every agent starts
  from; ``visits``, ``y`` vs zero) and float32/int32 values at those entries; the receiver
  fills the rest from the references. Lossless. Before consensus has touched an entry this
  is "entries with visits > 0"; afterwards consensus also moves unvisited entries, which
  must be sent too to stay exact. When the index list would make the message larger than
  float32, the message is sent dense (float32 layout) instead, so sparse never costs more.

Per-array wire types (``wire``, the scenario's ``consensus.wire``) override the kind's choice
for the arrays they name, in the dense kinds (``float32``, ``float16``): a float array as
``float32`` or ``float16`` (the float16 rules above), an integer array as ``int32`` or as
``uint16`` / ``uint8`` by linear quantisation against the array's own maximum (:func:`quantise`;
its scale travels with the message, :data:`SCALE_BYTES` counted in its bytes). This is how
RAMEN's message (theta, visits, the link half lam) is brought to DiNNO's bytes (theta, lam):
``{lam: float16, visits: uint16}`` (docs/CONSENSUS.md, "Equal bytes").
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Mapping

import numpy as np
import torch

KINDS = ("float32", "float16", "sparse")
HEADER_BYTES = 16
"""Fixed header per message (bytes): kind, n, sender, stamp."""
ARRAY_HEADER_BYTES = 8
"""Per array carried (bytes): key id and length."""
FLOAT_WIRE = ("float32", "float16")
"""Wire types of a float array (``consensus.wire``)."""
INT_WIRE = ("int32", "uint16", "uint8")
"""Wire types of an integer array: int32 as it is, uint16 / uint8 quantised (:func:`quantise`)."""
WIRE_TYPES = FLOAT_WIRE + INT_WIRE
"""Every per-array wire type ``consensus.wire`` accepts."""
SCALE_BYTES = 8
"""Per quantised array (bytes): its scale, a float64 (:func:`quantise`)."""
_QUANTISED = {"uint16": 16, "uint8": 8}
"""Quantised wire types and their bits."""


@dataclass(frozen=True)
class Encoded:
    """A message as it travels: ``arrays`` (numpy, the wire content), ``dtypes`` (torch dtype
    names to restore per key), ``layout`` (``dense`` or ``sparse``) and ``n``."""

    kind: str
    layout: str
    n: int
    arrays: dict[str, np.ndarray]
    dtypes: dict[str, str] = field(default_factory=dict)
    sparse_keys: tuple[str, ...] = ()
    """Keys carried as values at ``arrays["index"]`` (sparse layout only)."""
    scales: dict[str, float] = field(default_factory=dict)
    """Quantised integer arrays (wire ``uint16`` / ``uint8``): key -> scale, counts per step
    (:func:`quantise`); each costs :data:`SCALE_BYTES`."""
    _decoded: dict[str, torch.Tensor] = field(default_factory=dict, compare=False, repr=False)
    """What :func:`decode` made of this message, kept so that every receiver of one sent state
    holds the same read-only tensors (a copy stored once, however many robots hold it)."""

    @property
    def nbytes(self) -> int:
        """Exact bytes of the arrays carried plus the headers."""
        return (HEADER_BYTES + sum(ARRAY_HEADER_BYTES + a.nbytes for a in self.arrays.values())
                + SCALE_BYTES * len(self.scales))


def _wire_dtype(t: torch.Tensor, kind: str) -> np.dtype:
    if t.is_floating_point():
        return np.dtype(np.float16 if kind == "float16" else np.float32)
    return np.dtype(np.int32)


def _check(tensors: dict[str, torch.Tensor]) -> None:
    for k, t in tensors.items():
        if not t.is_floating_point():
            if t.numel() and (int(t.max()) > np.iinfo(np.int32).max or int(t.min()) < np.iinfo(np.int32).min):
                raise ValueError(
                    f"encode: integer tensor {k!r} has values outside int32 "
                    f"([{int(t.min())}, {int(t.max())}]); expected counts that fit 32 bits."
                )


def quantise(u: np.ndarray, bits: int) -> tuple[np.ndarray, float]:
    """Linear quantisation of non-negative integer counts (eq. 18's visit counts u) to ``bits``
    (8 or 16) against their own maximum M: ``q = round(u (2^b - 1) / M)``, returned with the
    scale ``s = M / (2^b - 1)`` (counts per step, float64; 0 when M = 0). :func:`dequantise`
    gives ``round(q s)`` back, and per entry ``|round(q s) - u| <= E = floor((s + 1) / 2)``:
    exact while ``M <= 2^b - 1`` (s < 1, E = 0), otherwise ``E <= s``.

    The weights of eq. 19 (``agents/consensus/weights.py``) are linear in the counts: with the
    edge's line fixed, ``w = eps u + zeta``, ``eps = (beta_u - beta_l) / R``, ``R = max u_sum -
    min u_sum`` over ``u_sum = u_i + u_j``, a neighbour's quantised counts move its weight by
    ``eps |du| <= eps s = (beta_u - beta_l) / (2^b - 1) * M_j / R``, which is at most
    ``(beta_u - beta_l) / (2^b - 1)`` per entry whenever ``M_j <= R`` (e.g. some parameter
    neither robot visited: min u_sum = 0). Both ends recompute the line from the counts they
    hold, and min and max of u_sum move by at most E too; with that the error, clamped weights
    included, is at most ``(beta_u - beta_l) * E / (R - 2E)`` in the receiver's own weight w_ij
    and ``(beta_u - beta_l) * 2E / (R - 2E)`` in the neighbour's w_ji (for R > 2E; first order:
    ``(beta_u - beta_l) / (2^b - 1)`` and twice that when M_j = R). Tested in
    ``tests/consensus/test_consensus_wire.py``."""
    if bits not in (8, 16):
        raise ValueError(f"quantise: {bits} bits; expected 8 or 16.")
    u = np.asarray(u)
    if u.size and int(u.min()) < 0:
        raise ValueError(f"quantise: counts down to {int(u.min())}; expected non-negative integers (visit counts).")
    top = (1 << bits) - 1
    m = int(u.max()) if u.size else 0
    if m == 0:
        return np.zeros(u.shape, dtype=np.uint16 if bits == 16 else np.uint8), 0.0
    q = np.rint(u.astype(np.float64) * top / m)  # u (2^b - 1) exact in float64 for int32 counts
    return q.astype(np.uint16 if bits == 16 else np.uint8), m / top


def dequantise(q: np.ndarray, scale: float) -> np.ndarray:
    """Counts back from :func:`quantise`: ``round(q * scale)`` as int64 (float64 arithmetic)."""
    return np.rint(q.astype(np.float64) * scale).astype(np.int64)


def _wire_type(t: torch.Tensor, kind: str, key: str, wire: Mapping[str, str]) -> str:
    """The wire type of array ``key``: ``wire``'s override, else the kind's choice."""
    chosen = wire.get(key)
    if chosen is None:
        return str(_wire_dtype(t, kind))
    allowed = FLOAT_WIRE if t.is_floating_point() else INT_WIRE
    if chosen not in allowed:
        raise ValueError(f"encode: wire type {chosen!r} for the {'float' if t.is_floating_point() else 'integer'} "
                         f"array {key!r}; expected one of {allowed}.")
    return chosen


def _dense(tensors: dict[str, torch.Tensor], kind: str, n: int, wire: Mapping[str, str] | None = None) -> Encoded:
    """``tensors``: detached host tensors (:func:`encode` makes them so); ``wire``: per-array
    wire types overriding ``kind``'s (none: the kind's own layout, unchanged)."""
    if not wire:
        arrays = {k: t.reshape(-1).numpy().astype(_wire_dtype(t, kind)) for k, t in tensors.items()}
        return Encoded(kind, "dense", n, arrays, {k: str(t.dtype) for k, t in tensors.items()})
    arrays, scales = {}, {}
    for k, t in tensors.items():
        wt = _wire_type(t, kind, k, wire)
        if wt in _QUANTISED:
            arrays[k], scales[k] = quantise(t.reshape(-1).numpy(), _QUANTISED[wt])
        else:
            arrays[k] = t.reshape(-1).numpy().astype(np.dtype(wt))
    return Encoded(kind, "dense", n, arrays, {k: str(t.dtype) for k, t in tensors.items()}, scales=scales)


def _reference(key: str, theta0: torch.Tensor) -> torch.Tensor | None:
    """What the receiver fills missing entries of ``key`` with: theta0 for theta, else zero (None)."""
    return theta0 if key == "theta" else None


def encode(tensors: dict[str, torch.Tensor], kind: str, theta0: torch.Tensor | None = None,
           wire: Mapping[str, str] | None = None) -> Encoded:
    """Encode a payload (``theta`` and friends) as ``kind``; ``theta0`` (n) is needed for sparse.
    ``wire``: array key -> wire type (:data:`WIRE_TYPES`) for the arrays it names, in the dense
    kinds; keys the payload does not carry are ignored (a link's extras are encoded apart)."""
    if kind not in KINDS:
        raise ValueError(f"encode: encoding {kind!r} is unknown; expected one of {KINDS}.")
    if wire and kind == "sparse":
        raise ValueError(f"encode: per-array wire types {dict(wire)} with the sparse encoding; expected "
                         "float32 or float16 (sparse sends float32 / int32 values at its index list).")
    # the wire is host memory: a map on CUDA sends what its tensors hold, copied to the CPU
    tensors = {k: t.detach().cpu() for k, t in tensors.items()}
    _check(tensors)
    n = int(tensors["theta"].numel()) if "theta" in tensors else 0
    if kind != "sparse":
        return _dense(tensors, kind, n, wire)
    if theta0 is None or theta0.numel() != n:
        raise ValueError(
            f"encode: sparse encoding needs the shared initial theta0 with n = {n} entries, got "
            f"{None if theta0 is None else theta0.numel()}; pass theta0=."
        )
    vectors = {k: t.reshape(-1) for k, t in tensors.items() if t.numel() == n}
    mask = torch.zeros(n, dtype=torch.bool)
    for k, v in vectors.items():
        ref = _reference(k, theta0)
        mask |= (v != ref) if ref is not None else (v != 0)
    idx = torch.nonzero(mask).reshape(-1)
    dense = _dense(tensors, "float32", n)
    sparse_bytes = dense.nbytes + ARRAY_HEADER_BYTES + idx.numel() * 4 - sum(
        (n - idx.numel()) * dense.arrays[k].itemsize for k in vectors
    )
    if sparse_bytes >= dense.nbytes:
        return Encoded("sparse", "dense", n, dense.arrays, dense.dtypes)
    arrays: dict[str, np.ndarray] = {"index": idx.numpy().astype(np.int32)}
    for k, t in tensors.items():
        src = t.reshape(-1)
        if k in vectors:
            src = src[idx]
        arrays[k] = src.numpy().astype(_wire_dtype(t, "float32"))
    return Encoded("sparse", "sparse", n, arrays, {k: str(t.dtype) for k, t in tensors.items()},
                   tuple(vectors))


def _torch_dtype(name: str) -> torch.dtype:
    return getattr(torch, name.removeprefix("torch."))


def decode(enc: Encoded, theta0: torch.Tensor | None = None) -> dict[str, torch.Tensor]:
    """The payload back as torch tensors (float32 for floats, the original integer dtype).

    Decoded once per message object: one sent state reaches every neighbour as the same
    ``Encoded``, and every receiver gets the same tensors (a new dict each call), which are
    read-only by contract (consensus methods never write a neighbour's copy). A dense float32 /
    int32 array is not even copied: the tensor shares the wire buffer, which nothing writes
    after :func:`encode` made it. So a state held by d robots costs its bytes once, not d times."""
    if not enc._decoded:
        enc._decoded.update(_decode(enc, theta0))
    return dict(enc._decoded)


def _decode(enc: Encoded, theta0: torch.Tensor | None) -> dict[str, torch.Tensor]:
    out: dict[str, torch.Tensor] = {}
    if enc.layout == "dense":
        for k, a in enc.arrays.items():
            dt = _torch_dtype(enc.dtypes[k])
            if k in enc.scales:  # a quantised integer array: round(q * scale), original dtype
                out[k] = torch.from_numpy(dequantise(a, enc.scales[k])).to(dt)
                continue
            out[k] = torch.from_numpy(a.astype(np.float32) if a.dtype == np.float16 else a).to(dt)
        return out
    if theta0 is None or theta0.numel() != enc.n:
        raise ValueError(
            f"decode: a sparse message needs the shared initial theta0 with n = {enc.n} entries, got "
            f"{None if theta0 is None else theta0.numel()}; pass theta0=."
        )
    idx = torch.from_numpy(enc.arrays["index"].astype(np.int64))
    for k, a in enc.arrays.items():
        if k == "index":
            continue
        dt = _torch_dtype(enc.dtypes[k])
        vals = torch.from_numpy(a.copy())
        if k in enc.sparse_keys:
            base = theta0.detach().clone().to(dt) if k == "theta" else torch.zeros(enc.n, dtype=dt)
            base[idx] = vals.to(dt)
            out[k] = base
        else:
            out[k] = vals.to(dt)
    return out
