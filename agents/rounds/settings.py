"""The team engine's environment variables, read in one place (:func:`read_wanted`); the mode
and the settings that follow are decided by ``modes.engine_settings``, which the simulation
(``ramensim/sim.py``), the memory guard (``ramensim/memory.py``) and the run's lifecycle
(``ramensim/lifecycle.py``) all ask. Nothing else reads these variables.

- ``RAMENSIM_TEAM_WORKERS``: worker threads (an integer >= 1; 1 = inline). Unset: torch's
  intra-op thread count (what this process was given: a sweep worker started with ``--threads
  1`` computes inline), 1 on a GPU (its kernels are asynchronous already); never more than the
  maps.
- ``RAMENSIM_TEAM_BATCH``: ``1`` lockstep batches of the team's gradients (the maps must be on
  the torch path: ``map.native: false``, or a GPU), ``0`` none; unset: on for a team of several
  maps on a GPU, off on the CPU. On the CPU's torch path a batch measured 0.90-0.93x the maps'
  separate steps at the default map size and 1.55x slower at 128 rays for 24 robots
  (docs/BENCHMARKS.md, "The team"); on an H200 it costs 0.48x (3 robots) to 0.19x (100 robots)
  of the separate steps and takes the 60-s house run from 1.28x to 2.06x real time, every
  robot's completion within 0.07 points of inline rounds (docs/MAP_PERFORMANCE.md, "On a GPU:
  the prepared check").
- ``RAMENSIM_EVAL_LANE``: ``1`` periodic evaluations on their own thread, ``0`` inline, unset:
  on their own thread whenever the engine computes rounds off the event loop.
"""
from __future__ import annotations

import os
from dataclasses import dataclass

import torch


WORKERS_ENV = "RAMENSIM_TEAM_WORKERS"
"""Environment variable that sets the engine's worker threads (an integer >= 1; 1 = inline)."""

BATCH_ENV = "RAMENSIM_TEAM_BATCH"
"""Environment variable for lockstep batches of the team's gradients: ``1`` (on; maps on the
torch path), ``0`` (off); unset: on for several maps on a GPU, off on the CPU."""

EVAL_LANE_ENV = "RAMENSIM_EVAL_LANE"
"""``1``: periodic evaluations on their own thread; ``0``: inline; unset: on their own thread
whenever the team engine computes rounds off the event loop (the run has cores to spare)."""


def team_batching(n_maps: int = 1, device: torch.device | str = "cpu") -> bool:
    """Whether a team of ``n_maps`` maps on ``device`` computes its gradients in lockstep batches:
    as ``$RAMENSIM_TEAM_BATCH`` says (1 or 0), else when there are several maps on a GPU, where
    the batch is measured faster (ValueError for another value)."""
    raw = os.environ.get(BATCH_ENV, "").strip()
    if raw not in ("", "0", "1"):
        raise ValueError(f"environment variable {BATCH_ENV}={raw!r}: expected 1 (lockstep batches of the "
                         f"team's gradients; maps on the torch path), 0 (none) or unset (batches for "
                         f"several maps on a GPU, none on the CPU).")
    if raw == "":
        return n_maps > 1 and torch.device(device).type == "cuda"
    return raw == "1"


def team_workers(n_maps: int, device: torch.device | str = "cpu") -> int:
    """Worker threads for a team of ``n_maps`` maps on ``device``: ``$RAMENSIM_TEAM_WORKERS``
    when set, else torch's intra-op thread count, never more than the maps; 1 on a GPU or for
    a single map (ValueError for a value that is not an integer >= 1)."""
    raw = os.environ.get(WORKERS_ENV, "").strip()
    if raw:
        try:
            wanted = int(raw)
        except ValueError:
            raise ValueError(f"environment variable {WORKERS_ENV}={raw!r}: expected an integer >= 1 "
                             f"(worker threads of the team engine).") from None
        if wanted < 1:
            raise ValueError(f"environment variable {WORKERS_ENV}={raw!r}: expected an integer >= 1 "
                             f"(worker threads of the team engine).")
    else:
        if torch.device(device).type != "cpu":
            return 1
        wanted = torch.get_num_threads()
    return max(1, min(wanted, n_maps))


def evaluation_lane_wanted() -> bool | None:
    """``$RAMENSIM_EVAL_LANE``: True (1), False (0), None (unset: beside a concurrent engine)."""
    raw = os.environ.get(EVAL_LANE_ENV, "").strip()
    if raw not in ("", "0", "1"):
        raise ValueError(f"environment variable {EVAL_LANE_ENV}={raw!r}: expected 1 (periodic evaluations on "
                         f"their own thread), 0 (inline) or unset (on their own thread beside the team engine).")
    return None if raw == "" else raw == "1"


@dataclass(frozen=True)
class Wanted:
    """What the environment asks of the engine for a team: ``batch`` (lockstep batches),
    ``workers`` (threads, already capped at the maps), ``maps`` (the team's maps), their
    ``device``, and ``eval_lane`` (``$RAMENSIM_EVAL_LANE``; None: automatic)."""

    batch: bool
    workers: int
    maps: int
    device: torch.device
    eval_lane: bool | None = None


def read_wanted(n_maps: int, device: torch.device | str = "cpu") -> Wanted:
    """Read the environment once for a team of ``n_maps`` maps on ``device`` (ValueError naming
    the variable for a bad value). The mode that follows is decided in ``modes.py``."""
    device = torch.device(device)
    return Wanted(team_batching(n_maps, device), team_workers(n_maps, device), n_maps, device,
                  evaluation_lane_wanted())
