"""One root seed, one independent generator per named component.

Generators are derived with ``numpy.random.SeedSequence`` from the root seed and a stable
hash of the component's name, so adding a component never shifts another's stream and
nothing touches the global RNGs.
"""
from __future__ import annotations

import zlib

import numpy as np
import torch


class Seeds:
    """Factory of per-component generators from one root ``seed``."""

    def __init__(self, seed: int) -> None:
        self.seed = int(seed)

    def _sequence(self, name: str) -> np.random.SeedSequence:
        key = zlib.crc32(name.encode("utf-8"))
        return np.random.SeedSequence(entropy=self.seed, spawn_key=(key,))

    def numpy(self, name: str) -> np.random.Generator:
        """A ``numpy.random.Generator`` private to component ``name``."""
        return np.random.Generator(np.random.PCG64(self._sequence(name)))

    def torch(self, name: str, device: str | torch.device = "cpu") -> torch.Generator:
        """A ``torch.Generator`` private to component ``name``."""
        state = self._sequence(name).generate_state(1, dtype=np.uint64)[0]
        gen = torch.Generator(device=device)
        gen.manual_seed(int(state) & 0x7FFF_FFFF_FFFF_FFFF)
        return gen

    def integer(self, name: str) -> int:
        """A 31-bit integer seed for libraries that only take ints."""
        return int(self._sequence(name).generate_state(1, dtype=np.uint32)[0] & 0x7FFF_FFFF)
