"""Consensus methods (ALGORITHM.md sections 2-3): RAMEN, DiNNO, DSGD, DSGT, local and
centralised, all behind :class:`ConsensusMethod`; build one per agent with :func:`make_method`."""
from __future__ import annotations

from ramensim.agents.consensus.base import ConsensusMethod
from ramensim.agents.consensus.config import (
    ConsensusConfig,
    DinnoConfig,
    DsgdConfig,
    DsgtConfig,
    MethodName,
    RamenConfig,
)
from ramensim.agents.consensus.dinno import DinnoMethod
from ramensim.agents.consensus.dsgd import DsgdMethod
from ramensim.agents.consensus.dsgt import DsgtMethod
from ramensim.agents.consensus.local import LocalMethod
from ramensim.agents.consensus.ramen import RamenMethod
from ramensim.agents.consensus.weights import edge_weights

METHODS = ("ramen", "dinno", "dsgd", "dsgt", "local", "centralised")


def make_method(name: str, cfg: ConsensusConfig, n: int, degree: int = 0) -> ConsensusMethod:
    """One agent's method ``name`` over ``n`` shared parameters; ``degree`` is the agent's
    initial graph degree (sent for Metropolis mixing until its first round)."""
    if name == "ramen":
        r = cfg.ramen
        return RamenMethod(n, cfg.primal_steps, r.resolved_beta_l(), r.resolved_beta_u())
    if name == "dinno":
        return DinnoMethod(n, cfg.primal_steps, cfg.dinno.rho)
    if name == "dsgd":
        return DsgdMethod(n, cfg.dsgd.alpha, cfg.dsgd.mixing, degree, cfg.dsgd.step)
    if name == "dsgt":
        return DsgtMethod(n, cfg.dsgt.alpha, cfg.dsgt.mixing, degree, cfg.dsgt.step)
    if name in ("local", "centralised"):
        return LocalMethod(n, cfg.primal_steps, name)
    raise ValueError(f"make_method: method {name!r} is unknown; expected one of {METHODS}.")


__all__ = [
    "METHODS", "ConsensusConfig", "ConsensusMethod", "DinnoConfig", "DinnoMethod", "DsgdConfig",
    "DsgdMethod", "DsgtConfig", "DsgtMethod", "LocalMethod", "MethodName", "RamenConfig",
    "RamenMethod", "edge_weights", "make_method",
]
