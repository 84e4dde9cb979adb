"""Per-message propagation delay (seconds), drawn from ``LatencyConfig``'s distribution.

With keyed draws (``ramensim.channels.draws``) each message draws its delay from its own
generator (``draw``). In send order (``channel.draws: send_order``) draws are made in blocks
from the sampler's own ``numpy.random.Generator`` and handed out one by one, which keeps the
per-message cost to an index; the sequence of values is the same as drawing them one at a
time in block order, so results depend only on the seed and on the order of calls.
"""
from __future__ import annotations

import math
from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, model_validator


class LatencyConfig(BaseModel):
    """Propagation delay of a message after its last bit left the sender (seconds).

    ``delay = offset_s + X`` with X drawn per message from ``kind``: constant (X = mean_s),
    uniform (low_s..high_s), normal (mean_s, std_s; negative draws clipped to 0),
    lognormal (the delay X itself has mean mean_s and standard deviation std_s) or
    exponential (mean mean_s).
    """

    model_config = ConfigDict(extra="forbid", use_attribute_docstrings=True)

    kind: Literal["constant", "uniform", "normal", "lognormal", "exponential"] = "constant"
    """Distribution of the per-message delay (constant | uniform | normal | lognormal | exponential)."""
    mean_s: float = Field(0.001, ge=0.0, le=3600.0)
    """Mean delay in seconds (constant, normal, lognormal, exponential); 1 ms is a one-hop Wi-Fi delay."""
    std_s: float = Field(0.0, ge=0.0, le=3600.0)
    """Standard deviation of the delay in seconds (normal, lognormal)."""
    low_s: float = Field(0.0, ge=0.0, le=3600.0)
    """Smallest delay in seconds (uniform)."""
    high_s: float = Field(0.0, ge=0.0, le=3600.0)
    """Largest delay in seconds (uniform)."""
    offset_s: float = Field(0.0, ge=0.0, le=3600.0)
    """Fixed delay in seconds added to every draw, of any kind."""

    @model_validator(mode="after")
    def _check(self) -> LatencyConfig:
        if self.kind == "uniform" and self.high_s < self.low_s:
            raise ValueError(
                f"channel.latency: uniform needs high_s >= low_s, got low_s={self.low_s} and "
                f"high_s={self.high_s} (seconds)."
            )
        if self.kind == "lognormal" and self.mean_s <= 0.0:
            raise ValueError(
                f"channel.latency: lognormal needs mean_s > 0 (seconds), got mean_s={self.mean_s}."
            )
        return self


_BLOCK = 4096


class LatencySampler:
    """Callable returning the next delay in seconds (``offset_s + X``, see ``LatencyConfig``)."""

    __slots__ = ("_cfg", "_rng", "_buf", "_i", "constant")

    def __init__(self, cfg: LatencyConfig, rng: np.random.Generator) -> None:
        self._cfg = cfg
        self._rng = rng
        self._buf: list[float] = []
        self._i = 0
        self.constant: float | None = None
        """The delay in seconds when it does not vary (constant kind, or zero spread), else None."""
        if cfg.kind == "constant":
            self.constant = cfg.offset_s + cfg.mean_s
        elif cfg.kind == "uniform" and cfg.high_s == cfg.low_s:
            self.constant = cfg.offset_s + cfg.low_s
        elif cfg.kind in ("normal", "lognormal") and cfg.std_s == 0.0:
            self.constant = cfg.offset_s + cfg.mean_s
        elif cfg.kind == "exponential" and cfg.mean_s == 0.0:
            self.constant = cfg.offset_s

    def _block(self, n: int, rng: np.random.Generator | None = None) -> np.ndarray:
        cfg = self._cfg
        rng = self._rng if rng is None else rng
        if cfg.kind == "uniform":
            x = rng.uniform(cfg.low_s, cfg.high_s, n)
        elif cfg.kind == "normal":
            x = np.maximum(rng.normal(cfg.mean_s, cfg.std_s, n), 0.0)
        elif cfg.kind == "lognormal":
            # Delay X with E[X] = m, Std[X] = s: sigma^2 = ln(1 + s^2/m^2), mu = ln m - sigma^2/2.
            sigma2 = math.log1p((cfg.std_s / cfg.mean_s) ** 2)
            x = rng.lognormal(math.log(cfg.mean_s) - 0.5 * sigma2, math.sqrt(sigma2), n)
        elif cfg.kind == "exponential":
            x = rng.exponential(cfg.mean_s, n)
        else:  # constant
            x = np.full(n, cfg.mean_s)
        return x + cfg.offset_s

    def draw(self, rng: np.random.Generator) -> float:
        """One delay in seconds from ``rng`` (a message's own keyed generator; ``ramensim.channels.draws``)."""
        if self.constant is not None:
            return self.constant
        return float(self._block(1, rng)[0])

    def __call__(self) -> float:
        """The next delay in seconds."""
        if self.constant is not None:
            return self.constant
        i = self._i
        if i >= len(self._buf):
            self._buf = self._block(_BLOCK).tolist()
            i = 0
        self._i = i + 1
        return self._buf[i]
