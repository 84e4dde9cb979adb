"""Consensus methods (docs/ALGORITHM.md sections 2-3): RAMEN, DiNNO, DSGD, DSGT, local and
centralised, all behind :class:`ConsensusMethod` and declared once in
:mod:`ramensim.agents.consensus.registry`; build one per agent with :func:`make_method`."""
from __future__ import annotations

import torch

# Importing the method modules registers them (each ends with its ``register(...)`` line).
from ramensim.agents.consensus import ramen, dinno, dsgd, dsgt, local  # noqa: F401,I001 - registration order = display order
from ramensim.agents.consensus.base import ConsensusMethod
from ramensim.agents.consensus.config import (
    ConsensusConfig,
    DinnoConfig,
    DsgdConfig,
    DsgtConfig,
    RamenConfig,
)
from ramensim.agents.consensus.dinno import DinnoMethod
from ramensim.agents.consensus.dsgd import DsgdMethod
from ramensim.agents.consensus.dsgt import DsgtMethod
from ramensim.agents.consensus.local import LocalMethod
from ramensim.agents.consensus.ramen import RamenMethod
from ramensim.agents.consensus.registry import MethodContext, MethodSpec, get_method, method_names, register
from ramensim.agents.consensus.weights import edge_weights


def make_method(name: str, cfg: ConsensusConfig, n: int, degree: int = 0, agent: int = 0,
                device: str | torch.device = "cpu") -> ConsensusMethod:
    """Agent ``agent``'s method ``name`` over ``n`` shared parameters; ``degree`` is the
    agent's initial graph degree (sent for Metropolis mixing until its first round); ``device``
    the torch device of the agent's map, where the method keeps its state."""
    return get_method(name).make(cfg, n, degree, agent, device)


__all__ = [
    "ConsensusConfig", "ConsensusMethod", "DinnoConfig", "DinnoMethod", "DsgdConfig",
    "DsgdMethod", "DsgtConfig", "DsgtMethod", "LocalMethod", "MethodContext", "MethodSpec", "RamenConfig",
    "RamenMethod", "edge_weights", "get_method", "make_method", "method_names", "register",
]
