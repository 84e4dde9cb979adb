"""Per-message propagation delay (seconds), drawn from ``LatencyConfig``'s distribution.

With keyed draws (``ramensim.channels.draws``) each message draws its delay from its own
generator (``draw``). In send order (``channel.draws: send_order``) draws are made in blocks
from the sampler's own ``numpy.random.Generator`` and handed out one by one, which keeps the
per-message cost to an index; the sequence of values is the same as drawing them one at a
time in block order, so results depend only on the seed and on the order of calls.
"""
from __future__ import annotations

import math

import numpy as np

from ramensim.channels.config import LatencyConfig

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
