"""A distance-dependent loss: a radio model in one file (docs/EXTENDING.md, part 2).

A message between two robots d metres apart arrives with a success factor

    f(d) = 1                                        for d <= d0
    f(d) = (d0 / d) ** exponent                     for d0 < d < range_m          (DL-1)
    f(d) = 0                                        for d >= range_m (out of range)

multiplied into eq. Q-1 (``success = success_rate * f(d)``). Turn it on with a block
``channel.distance_loss: {...}`` in a scenario that loads this file.
"""
from __future__ import annotations

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from ramensim.channels.radios import RadioContext, RadioModelSpec, register_radio


class DistanceLossSettings(BaseModel):
    """The block ``channel.distance_loss``."""

    model_config = ConfigDict(extra="forbid")

    d0_m: float = Field(1.0, gt=0.0)
    """Distance up to which nothing is lost (m)."""
    exponent: float = Field(2.0, ge=0.0, le=10.0)
    """How fast success falls beyond d0 (dimensionless), eq. DL-1."""
    range_m: float = Field(1e6, gt=0.0)
    """Beyond this distance nothing arrives (m)."""


class DistanceLoss:
    """The factor of eq. DL-1 for any link, from the robots' positions at send time."""

    def __init__(self, cfg: DistanceLossSettings, ctx: RadioContext) -> None:
        if ctx.position is None:
            raise ValueError("channel.distance_loss needs the robots' positions; this channel has none.")
        self.cfg, self.position = cfg, ctx.position

    def quality(self, src: int, dst: int, t: float) -> tuple[float, int, float]:
        """(success factor, walls crossed: -1 = not counted, distance m) of ``src -> dst`` at ``t`` s."""
        d = float(np.linalg.norm(self.position(src, t) - self.position(dst, t)))
        if d >= self.cfg.range_m:
            return 0.0, -1, d
        return (1.0 if d <= self.cfg.d0_m else (self.cfg.d0_m / d) ** self.cfg.exponent), -1, d


register_radio(RadioModelSpec(
    name="distance_loss", settings=DistanceLossSettings, role="factor",
    build=lambda settings, ctx: DistanceLoss(settings, ctx),
    description="success factor (d0 / d) ** exponent beyond d0, 0 beyond range_m (eq. DL-1)"))
