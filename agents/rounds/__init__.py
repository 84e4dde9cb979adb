"""The team engine: every robot's mapping rounds, computed at their start or off the event loop,
in one of several modes, with the results of computing each round inline at its start.

- ``engine.py``: the interface (:class:`Engine`, :class:`Ticket`);
- ``inline.py``, ``threads.py``, ``lockstep.py``: one class per mode;
- ``settings.py``: the engine's environment variables, read in one place;
- ``modes.py``: where the mode is chosen (one line per mode) and ``engine_settings``, the one
  answer the simulation, the memory guard and the lifecycle ask for;
- ``round.py``: the life of a round (plan, fix inputs, submit, hold frames, collect, check).
"""
from .engine import Engine, Ticket
from .inline import InlineEngine
from .lockstep import LockstepEngine, LockstepGate, LockstepLearner
from .modes import MODES, EngineSettings, Mode, engine_settings, mode_named
from .round import RoundOutcome, RoundWork, live_round, planned_grad_evals
from .settings import BATCH_ENV, EVAL_LANE_ENV, WORKERS_ENV, read_wanted, team_batching, team_workers
from .threads import ThreadEngine


__all__ = ["BATCH_ENV", "EVAL_LANE_ENV", "WORKERS_ENV", "Engine", "EngineSettings", "InlineEngine",
           "LockstepEngine", "LockstepGate", "LockstepLearner", "MODES", "Mode", "RoundOutcome", "RoundWork",
           "ThreadEngine", "Ticket", "engine_settings", "live_round", "mode_named", "planned_grad_evals",
           "read_wanted", "team_batching", "team_workers"]
