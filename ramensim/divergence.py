"""Divergence you can see: rules that mark an agent ``diverged`` although every number it
holds is still finite (docs/RELIABILITY.md).

Non-finite losses or maps are caught by the mapper itself (``AgentProcess``). Two more
symptoms of a map that has turned to noise are watched here:

- **loss growth**: after :attr:`DivergenceRule.warmup_rounds` rounds, a round whose loss is more
  than :attr:`DivergenceRule.loss_factor` times the lowest loss the agent has reached so far
  (its running minimum). A learning rate far too high (``map.lr: 1e3``) sends the loss up by
  orders of magnitude within a few rounds, while a healthy map's loss moves by a small factor
  (new frames of unseen space raise it; see docs/RELIABILITY.md for the measured ratios).
- **loss ceiling**: from the first round on, a loss above :attr:`DivergenceRule.ceiling_factor`
  times the sum of the map's loss weights (``map.rgb_weight + depth_weight + sdf_weight +
  fs_weight + smooth_weight``). Each term of the loss is a mean of squared errors of quantities
  that are O(1) in their own units for a map that fits anything (colour in [0, 1], SDF and free
  space in truncation units, depth in metres), so a loss ten times the sum of the weights means
  errors several times the natural scale of every term at once: a map of noise. This catches
  ``map.lr: 1e3``, whose loss is 10^5 times a healthy one from the first round on and so never
  grows against its own running minimum (docs/RELIABILITY.md has the measurement).
- **evaluation collapse**: at a periodic evaluation (``evaluation.every_s``), a completion
  ratio below :attr:`DivergenceRule.collapse_fraction` of the best one this agent reached,
  once that best was at least :attr:`DivergenceRule.collapse_min_pct` percent.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field


@dataclass
class DivergenceRule:
    """Thresholds of the rule (unitless factors, rounds, percent)."""

    loss_factor: float = 100.0
    warmup_rounds: int = 5
    ceiling_factor: float = 10.0
    loss_weight_sum: float | None = None
    """Sum of the map's loss weights (None: no ceiling, e.g. a learner other than the neural map)."""
    collapse_fraction: float = 0.25
    collapse_min_pct: float = 20.0


@dataclass
class DivergenceWatch:
    """Per-agent state of the rule: running minimum of the loss, best completion ratio."""

    rule: DivergenceRule = field(default_factory=DivergenceRule)
    _min_loss: dict[int, float] = field(default_factory=dict)
    _rounds: dict[int, int] = field(default_factory=dict)
    _best_completion: dict[int, float] = field(default_factory=dict)

    def after_round(self, agent: int, loss: float) -> str | None:
        """Reason when the round's ``loss`` breaks the growth rule, else None."""
        if not math.isfinite(loss):
            return None  # the mapper reports non-finite losses itself
        n = self._rounds.get(agent, 0) + 1
        self._rounds[agent] = n
        low = self._min_loss.get(agent, math.inf)
        reason = None
        ceiling = (self.rule.ceiling_factor * self.rule.loss_weight_sum
                   if self.rule.loss_weight_sum is not None and self.rule.loss_weight_sum > 0 else math.inf)
        if loss > ceiling:
            reason = (f"loss {loss:.4g} is above {self.rule.ceiling_factor:g} times the sum of the loss weights "
                      f"({ceiling:.4g}): the map is noise (e.g. map.lr too high)")
        elif n > self.rule.warmup_rounds and low > 0 and loss > self.rule.loss_factor * low:
            reason = (f"loss {loss:.4g} is more than {self.rule.loss_factor:g} times its running minimum "
                      f"{low:.4g} (the map is no longer fitting its data; e.g. map.lr too high)")
        if n >= self.rule.warmup_rounds:
            self._min_loss[agent] = min(low, loss)
        return reason

    def after_evaluation(self, agent: int, completion_pct: float | None) -> str | None:
        """Reason when the completion ratio (%) collapsed against the agent's best, else None."""
        if completion_pct is None or not math.isfinite(completion_pct):
            return None
        best = self._best_completion.get(agent, -math.inf)
        if best >= self.rule.collapse_min_pct and completion_pct < self.rule.collapse_fraction * best:
            return (f"completion ratio fell to {completion_pct:.1f} % from its best {best:.1f} % "
                    f"(below {self.rule.collapse_fraction:g} of it: the map collapsed)")
        self._best_completion[agent] = max(best, completion_pct)
        return None
