"""The team engine's package (agents/rounds/): one reader of its settings, where modes are chosen,
lockstep's proxy learner, the life of a round; whole runs in every mode are in test_agents_team.py."""
from __future__ import annotations

import threading

import pytest
import torch

from ramensim.agents.rounds import (BATCH_ENV, EVAL_LANE_ENV, MODES, WORKERS_ENV, Engine, InlineEngine, LockstepEngine,
                                    LockstepLearner, Mode, RoundWork, ThreadEngine, engine_settings)
from ramensim.agents.rounds import modes as modes_module


@pytest.fixture
def clean_env(monkeypatch):
    for name in (WORKERS_ENV, BATCH_ENV, EVAL_LANE_ENV):
        monkeypatch.delenv(name, raising=False)
    return monkeypatch


def test_settings_choose_each_mode_and_what_it_holds(clean_env) -> None:
    clean_env.setenv(WORKERS_ENV, "1")
    s = engine_settings(3)
    assert (s.mode, s.workers, s.rounds_at_once, s.concurrent, s.evaluation_lane) == ("inline", 1, 1, False, False)
    clean_env.setenv(WORKERS_ENV, "2")
    s = engine_settings(3)
    assert (s.mode, s.workers, s.rounds_at_once, s.evaluation_lane, s.lane_threads) == ("threads", 2, 2, True, 1)
    clean_env.setenv(BATCH_ENV, "1")
    s = engine_settings(3)
    assert (s.mode, s.workers, s.rounds_at_once, s.lane_threads) == ("lockstep", 1, 3, 0)
    assert engine_settings(1).mode == "inline"  # a single map has no batch to form
    clean_env.setenv(EVAL_LANE_ENV, "0")
    assert not engine_settings(3).evaluation_lane
    clean_env.delenv(BATCH_ENV)
    clean_env.delenv(WORKERS_ENV)
    # a GPU: lockstep batches for several maps unless told 0 (measured faster there), else one worker
    assert engine_settings(5, torch.device("cuda")).mode == "lockstep"
    assert engine_settings(1, torch.device("cuda")).mode == "inline"
    assert engine_settings(5, torch.device("cpu")).mode != "lockstep"  # the CPU: off unless asked
    clean_env.setenv(BATCH_ENV, "0")
    assert engine_settings(5, torch.device("cuda")).mode == "inline"


@pytest.mark.parametrize("name, value", [(WORKERS_ENV, "0"), (BATCH_ENV, "yes"), (EVAL_LANE_ENV, "2")])
def test_a_bad_value_names_its_variable(clean_env, name: str, value: str) -> None:
    clean_env.setenv(name, value)
    with pytest.raises(ValueError, match=name):
        engine_settings(3)


def test_the_memory_guard_counts_what_the_settings_say(clean_env) -> None:
    from ramensim import memory
    from ramensim.agents.consensus.registry import get_method

    ramen = get_method("ramen")
    for env in ({WORKERS_ENV: "1"}, {WORKERS_ENV: "2"}, {BATCH_ENV: "1"}):
        for k, v in env.items():
            clean_env.setenv(k, v)
        assert memory.lent_vectors(ramen, 4) == ramen.round_vectors * engine_settings(4).rounds_at_once
        for k in env:
            clean_env.delenv(k)


class _Scaled(Engine):
    """A mode of this test: inline, counting its rounds (stands for a new mode, e.g. CUDA streams)."""

    mode = "scaled"

    def submit(self, job):
        from ramensim.agents.rounds import Ticket

        self.submitted += 1
        return Ticket.computed(job)


def test_a_new_mode_is_its_class_and_one_line(clean_env, monkeypatch) -> None:
    monkeypatch.setattr(modes_module, "MODES", (Mode("scaled", _Scaled, lambda want: want.maps >= 7), *MODES))
    s = engine_settings(7)
    assert s.mode == "scaled" and isinstance(s.make([]), _Scaled)
    assert engine_settings(3).mode != "scaled"


def test_every_mode_is_an_engine_with_its_own_name() -> None:
    assert [m.name for m in MODES] == [m.engine.mode for m in MODES]
    assert all(issubclass(m.engine, Engine) for m in MODES) and MODES[-1].name == "inline"


class _Map:
    """A stand-in map: records who computed its gradient."""

    def __init__(self, k: int) -> None:
        self.k = k
        self.theta = torch.full((2,), float(k))
        self.own_calls = 0

    def loss_and_grad(self):
        self.own_calls += 1
        return {"loss": 0.0}, self.theta


def test_lockstep_gives_each_round_a_proxy_whose_gradient_joins_the_batch() -> None:
    batches: list[list[int]] = []

    def batch(learners):
        batches.append([m.k for m in learners])
        return [({"loss": float(m.k)}, m.theta * 2) for m in learners]

    engine = LockstepEngine(batch)
    maps = [_Map(k) for k in range(3)]
    seen = []

    def work(m: _Map) -> RoundWork:
        def compute(learner):
            seen.append(type(learner))
            scalars, grad = learner.loss_and_grad()
            scalars2, _ = learner.loss_and_grad()  # a second step: a second batch
            return scalars["loss"] + scalars2["loss"], float(learner.theta[0]), threading.current_thread().name
        return RoundWork(m, compute)

    tickets = [engine.submit(work(m)) for m in maps]
    assert batches == []  # nothing runs before a result is needed
    assert tickets[1].result()[:2] == (2.0, 1.0)  # the proxy reads the map's own state
    assert batches == [[0, 1, 2], [0, 1, 2]] and engine.batches == 2 and engine.largest_batch == 3
    assert all(t.done for t in tickets) and seen == [LockstepLearner] * 3
    assert all(m.own_calls == 0 for m in maps)  # the map's own loss_and_grad never ran


def test_every_mode_returns_the_rounds_result_and_keeps_its_exception() -> None:
    for engine in (InlineEngine(), ThreadEngine(2), LockstepEngine(lambda ls: [({}, None) for _ in ls])):
        ok = engine.submit(RoundWork(_Map(0), lambda learner: 5))
        bad = engine.submit(RoundWork(_Map(1), lambda learner: 1 / 0))
        engine.drain()  # never raises a round's exception
        assert ok.result() == 5
        with pytest.raises(ZeroDivisionError):
            bad.result()
        engine.close()
