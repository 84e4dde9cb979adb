"""The one place where consensus methods are declared and looked up.

Each method module ends with one ``register(MethodSpec(...))`` line: its name, its
settings class (read from ``consensus.<name>`` in a scenario), how to build one agent's
side of it, and its capabilities. The scenario schema, the simulation, sweeps and
reports ask this registry instead of naming methods; adding a method is one new module
plus its registry line (``tests/consensus/test_consensus_registry.py`` does exactly that
and runs the new method end to end). A module outside the package is loaded as a plugin
(``plugins:`` in a scenario, ``--plugin``, or an installed entry point in the group
``ramensim.methods``; :mod:`ramensim.plugins`, docs/EXTENDING.md).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Callable, Literal

import torch

from ramensim.core.registry import Registry

if TYPE_CHECKING:  # pragma: no cover - typing only
    from pydantic import BaseModel

    from ramensim.agents.consensus.base import ConsensusMethod

ConsensusBlock = Any
"""The scenario's validated ``consensus`` block, a
:class:`ramensim.agents.consensus.config.ConsensusConfig`: the settings every method shares and
each method's own block. Named here, not imported: that class composes the settings classes of
the methods, whose modules register here, so this registry sits below it."""


@dataclass(frozen=True)
class MethodContext:
    """Who a method instance serves: ``n`` shared parameters, agent id ``agent``, its
    initial graph ``degree`` (neighbour count)."""

    n: int
    agent: int = 0
    degree: int = 0
    device: torch.device = torch.device("cpu")
    """Torch device of the agent's map (``map.device`` as the run resolved it once,
    ``ramensim.sim.scenario_device``): the method's state lives there."""


Builder = Callable[["BaseModel | None", ConsensusBlock, MethodContext], "ConsensusMethod"]
"""``build(settings, consensus_cfg, ctx)``: one agent's side of the method; ``settings`` is
the validated ``consensus.<name>`` block (None if the method has no settings class)."""


def visit_counting(cfg: ConsensusBlock) -> dict[str, Any]:
    """The learner's visit rule (eq. 18): count a parameter when the observation losses touch it
    (``count_observation_only``, the paper), or also the smoothness term (the authors' code)."""
    return {"count_observation_only": cfg.ramen.count_observation_only}


@dataclass(frozen=True)
class MethodSpec:
    """A consensus method as the rest of the simulator sees it."""

    name: str
    """The scenario's ``method:`` value."""
    build: Builder
    settings: type[BaseModel] | None = None
    """Pydantic model of the method's own settings, read from ``consensus.<name>``."""
    communicates: bool = True
    """Sends its state (Theta) to neighbours; False for the references local/centralised."""
    sends_uncertainty: bool = False
    """Also sends visit counts u_i (eq. 18): RAMEN; the recorder then logs them."""
    reference: bool = False
    """A floor or ceiling (local, centralised) rather than a decentralised method."""
    merges_frames: bool = False
    """One learner fed by every robot's camera (centralised) instead of one per robot."""
    learner_settings: Callable[[ConsensusBlock], dict[str, Any]] = visit_counting
    """``learner_settings(consensus_cfg) -> {attribute: value}`` set on each agent's learner
    before the run. Default (:func:`visit_counting`): what counts as a visit of a parameter
    (eq. 18), read from ``consensus.ramen.count_observation_only`` for every method, since the
    visit counts feed RAMEN's weights and, for every method, the recorder's uncertainty and
    the weighted consensus error (eq. CE-2)."""
    steps_per_round: Literal["primal_steps", "one"] = "primal_steps"
    """Optimiser iterations of one round: ``consensus.primal_steps`` ("primal_steps": the C-ADMM
    methods and the references), or "one" (DSGD, DSGT: one gradient step, then a message).
    ``ramensim.budget`` sizes a run's events from it."""
    message_arrays: Callable[[ConsensusBlock], dict[str, str]] | None = None
    """``message_arrays(consensus_cfg) -> {array key: "float" or "int"}``: the arrays the method's
    messages carry with these settings (shared and per link); ``consensus.wire`` may name only
    these, with a wire type of their kind (``ramensim.schema``). None: the method declares none,
    so ``consensus.wire`` is refused for it."""
    memory_vectors: tuple[int, int] = (0, 0)
    """Parameter-sized vectors (n float32 or int32) the method holds (per agent, per neighbour):
    its own buffers, and per neighbour the copy it keeps, its link state and one message in
    flight. ``ramensim.memory`` estimates a run's memory from them before it starts."""
    round_vectors: int = 0
    """Parameter-sized work vectors of one round that the method borrows for the round from
    ``agents/consensus/scratch.py``'s pool instead of owning them: one set per round running at
    once (``ramensim.memory``: per worker of the team engine, not per agent)."""
    description: str = ""
    """One line for ``ramensim schema`` and the docs."""

    def settings_of(self, cfg: ConsensusBlock) -> Any:
        """The method's validated settings block in ``cfg`` (None without a settings class)."""
        if self.settings is None:
            return None
        value = getattr(cfg, self.name, None)
        return value if value is not None else self.settings()

    def make(self, cfg: ConsensusBlock, n: int, degree: int = 0, agent: int = 0,
             device: str | torch.device = "cpu") -> ConsensusMethod:
        """Agent ``agent``'s side of the method over ``n`` parameters (see :data:`Builder`);
        ValueError naming the hooks of :class:`ConsensusMethod` the built object lacks."""
        from ramensim.agents.consensus.base import HOOKS

        method = self.build(self.settings_of(cfg), cfg, MethodContext(n, agent, degree, torch.device(device)))
        missing = [h for h in HOOKS if not callable(getattr(method, h, None))]
        if missing:
            raise ValueError(f"consensus method {self.name!r}: its builder returned a {type(method).__name__} "
                             f"without {', '.join(missing)}; a method implements every hook of "
                             f"ramensim.agents.consensus.base.ConsensusMethod ({', '.join(HOOKS)}).")
        return method


_REGISTRY: Registry = Registry("consensus", "method")

DEFAULT_METHOD = "ramen"
"""The method a scenario runs when it names none (``Scenario.method``'s default)."""


def register(spec: MethodSpec) -> MethodSpec:
    """Declare ``spec`` under ``spec.name``; registering a name twice is an error unless it
    is the same declaration (a module imported again)."""
    return _REGISTRY.declare(spec)


def unregister(name: str) -> None:
    """Remove a method (tests that register a temporary one)."""
    _REGISTRY.withdraw(name)


def method_names() -> tuple[str, ...]:
    """Every registered method, in registration order."""
    return _REGISTRY.names()


ALIASES = {"centralized": "centralised"}
"""Other spellings a scenario may use for a method (American English)."""


def canonical_name(name: str) -> str:
    """``name`` with its alias resolved (``centralized`` -> ``centralised``)."""
    return ALIASES.get(name, name)


def get_method(name: str) -> MethodSpec:
    """The spec of ``name`` (or of its alias); ValueError naming the known methods, with the
    closest one when the name looks like a misspelling."""
    if canonical_name(name) in _REGISTRY:
        return _REGISTRY[canonical_name(name)]
    return _REGISTRY.lookup(name)
