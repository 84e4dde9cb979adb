"""Settings of the consensus methods (docs/ALGORITHM.md sections 2-4).

The scenario holds ``method: <name>`` (any registered method, see
:mod:`ramensim.agents.consensus.registry`) beside ``consensus: ConsensusConfig``; only the
settings block of the chosen method is used. Every method declares its settings class in its
own module, beside the method and its registry line (``ramen.py``: ``RamenConfig``, ...); this
module composes them: the built-in methods' blocks are fields here (so ``ramensim schema``
documents them, and they stay importable from here), a method added later (a plugin) brings
its settings class in its registry entry and its ``consensus.<name>`` block is validated with it.
"""
from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from ramensim.agents.consensus.dinno import DinnoConfig
from ramensim.agents.consensus.dsgd import DsgdConfig
from ramensim.agents.consensus.dsgt import DsgtConfig
from ramensim.agents.consensus.ramen import RamenConfig
from ramensim.agents.consensus.registry import get_method

__all__ = ["AUTHORS_RAMEN", "AUTHORS_SETTINGS", "PAPER_SETTINGS", "ConsensusConfig", "DinnoConfig", "DsgdConfig",
           "DsgtConfig", "EncodingKind", "RamenConfig", "StalePolicy", "WireType"]

StalePolicy = Literal["latest", "max_age", "omit_lost"]
"""How a round treats neighbour copies (see :meth:`ramensim.agents.copies.CopyStore.select`)."""

EncodingKind = Literal["float32", "float16", "sparse"]
"""Wire format of a message (see :mod:`ramensim.agents.encoding`)."""

WireType = Literal["float32", "float16", "int32", "uint16", "uint8"]
"""Wire type of one array of a message (``consensus.wire``; :data:`ramensim.agents.encoding.WIRE_TYPES`)."""


class ConsensusConfig(BaseModel):
    """Everything a consensus method needs besides the learner."""

    model_config = ConfigDict(extra="allow", use_attribute_docstrings=True)

    preset: Literal["ramensim", "paper", "authors"] = "ramensim"
    """Named starting point: 'ramensim' (the defaults of this block: proximal primal step, antisymmetric per-link duals in the proximal step, dual step 0.2; the variant whose maps converge, docs/CONSENSUS.md), 'paper' (the paper's update as written: joint primal gradient, node dual, latest copies) or 'authors' (the switches of the authors' public code: the paper's update with lost neighbours omitted, visit counts including the smoothness term, the observation loss counted twice in the backward pass, 200 local steps on the first frame); keys given beside it override the preset."""
    primal_steps: int = Field(10, ge=1, le=10_000)
    """B: optimiser steps per mapping round for RAMEN, DiNNO and local (count); DSGD/DSGT always take one."""
    primal_update: Literal["joint", "prox"] = "prox"
    """C-ADMM primal step (RAMEN, DiNNO): 'joint' gives the optimiser the gradient of the whole augmented objective (paper, official code); 'prox' gives it grad L_obj + p_i and then applies the penalty sum_j w_ij |Theta - z_ij|^2 exactly, as a proximal step in the optimiser's own metric (see docs/CONSENSUS.md)."""
    dual_update: Literal["node", "per_link", "antisymmetric"] = "antisymmetric"
    """C-ADMM dual (RAMEN, DiNNO): 'node' adds every copy's increment to one dual p_i each round (paper, eq. 9b / 17); 'per_link' keeps one dual per link, advanced only when a new copy from that neighbour arrived (UDON-style); 'antisymmetric' splits each link's dual into two halves, one held by each end, kept in parameter units (scaled by the link's coefficient 2 h_ij when used), advanced by half the difference Theta_i^t - Theta_j on each new copy and sent with that end's messages on the link; each end uses 2 h_ij (own half - the other's half), so the duals of the two ends cancel at any fixed point whatever the losses and ages; being bounded against the penalty, it enters the proximal step with it (docs/CONSENSUS.md)."""
    dual_step: float = Field(0.2, gt=0.0, le=2.0, allow_inf_nan=False)
    """Factor gamma on the dual increment of the C-ADMM methods (dimensionless): p += gamma * D. Eq. 9b / 17 have gamma = 1 (the 'paper' and 'authors' presets); with the proximal primal step and scaled antisymmetric duals gamma = 1 makes RAMEN's maps oscillate apart with every message delivered, 0.2 lets them converge (under-relaxed dual ascent for inexact primal steps on stale copies; docs/CONSENSUS.md)."""
    local_gradient_scale: float = Field(1.0, gt=0.0, le=1e3, allow_inf_nan=False)
    """Factor on grad L_obj in the C-ADMM primal steps (dimensionless); the authors' code counts the observation loss twice (2.0), which halves the consensus terms' relative weight."""
    first_round_steps: int = Field(0, ge=0, le=100_000)
    """Extra optimiser steps on L_obj alone in an agent's first round, before any consensus (count; the authors' code: 200 on the first frame)."""
    stale_policy: StalePolicy = "latest"
    """latest: use the last copy received whatever its age (paper); max_age: drop copies older than max_age_s; omit_lost: use only copies that arrived since this agent's previous round (official code)."""
    max_age_s: float = Field(30.0, gt=0.0)
    """Oldest copy (send stamp to now, seconds) that the max_age policy still uses."""
    encoding: EncodingKind = "float32"
    """Wire format of messages: float32 (reference), float16, or sparse (indices + values of entries that differ from the shared initial map)."""
    wire: dict[str, WireType] = Field(default_factory=dict)
    """Per-array wire types overriding the encoding's, array key -> float32 / float16 for float arrays (theta, lam, y), int32 / uint16 / uint8 for integer ones (visits, degree; uint by linear quantisation against the message's own maximum, its float64 scale counted in the bytes); keys are the arrays the method sends (the scenario check names them); e.g. {lam: float16, visits: uint16} sends RAMEN at DiNNO's bytes (docs/CONSENSUS.md, "Equal bytes"). Empty (default): none. Not with encoding sparse."""
    ramen: RamenConfig = Field(default_factory=RamenConfig)
    """RAMEN settings (used when method = ramen)."""
    dinno: DinnoConfig = Field(default_factory=DinnoConfig)
    """DiNNO settings (used when method = dinno)."""
    dsgd: DsgdConfig = Field(default_factory=DsgdConfig)
    """DSGD settings (used when method = dsgd)."""
    dsgt: DsgtConfig = Field(default_factory=DsgtConfig)
    """DSGT settings (used when method = dsgt)."""

    @model_validator(mode="before")
    @classmethod
    def _apply_preset(cls, data: object) -> object:
        if isinstance(data, dict) and data.get("preset") == "authors":
            ramen = {**AUTHORS_RAMEN, **(data.get("ramen") or {})}
            return {**AUTHORS_SETTINGS, **data, "ramen": ramen}
        if isinstance(data, dict) and data.get("preset") == "paper":
            return {**PAPER_SETTINGS, **data}
        return data

    @model_validator(mode="after")
    def _extra_blocks_are_methods(self) -> ConsensusConfig:
        """A key beyond the declared ones must be a registered method with a settings
        class; its block is validated with that class (methods added by registration)."""
        for key, value in list((self.__pydantic_extra__ or {}).items()):
            try:
                spec = get_method(key)
            except ValueError:
                spec = None
            if spec is None or spec.settings is None:
                raise ValueError(f"unknown key {key!r}: expected a setting of the consensus block or the "
                                 f"name of a registered method that has settings")
            self.__pydantic_extra__[key] = spec.settings.model_validate(value if value is not None else {})
        return self


PAPER_SETTINGS: dict[str, object] = dict(primal_update="joint", dual_update="node", dual_step=1.0)
"""What the 'paper' preset sets: the update of eq. 9 / 14-17 as written (Adam on the whole
augmented objective, one dual per agent advanced by every copy used)."""
AUTHORS_SETTINGS: dict[str, object] = dict(stale_policy="omit_lost", local_gradient_scale=2.0, first_round_steps=200,
                                           primal_update="joint", dual_update="node", dual_step=1.0)
"""What the 'authors' preset sets (labicon/RAMEN main.py: lost neighbours left out of the round,
loss.backward() twice without zero_grad, first_iters = 200). Their loss itself, one Bernoulli per
edge and round shared by both directions, is the channel's: ``channel.loss_unit: edge_round``
(docs/RADIO.md)."""
AUTHORS_RAMEN: dict[str, object] = dict(count_observation_only=False)
"""The authors count a parameter as visited after the backward pass that includes smoothness."""
