"""A run the machine cannot hold is refused before it starts, with the estimate and what to
change (ramensim.memory); the estimate counts parameter-sized vectors per map, per agent and
per neighbour, so it grows with agents x neighbours."""
from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import pytest

from ramensim import memory
from ramensim.agents.consensus import get_method
from ramensim.cli import main
from ramensim.core.errors import InputError

ROOT = Path(__file__).resolve().parents[2]
SCENARIO = ROOT / "scenarios" / "office_3agents.yaml"


def test_estimate_counts_vectors_per_map_agent_and_neighbour():
    n = 1 << 20
    ramen = get_method("ramen").memory_vectors
    ring = memory.estimate_bytes(n, 40, [2] * 40, ramen)
    complete = memory.estimate_bytes(n, 40, [39] * 40, ramen)
    assert ring - memory.BASE_BYTES == 4 * n * (40 * memory.MAP_VECTORS + 40 * (ramen[0] + 2 * ramen[1]))
    assert complete > 8 * ring  # quadratic in the agents on a complete graph
    # the references keep nothing per neighbour; the decentralised methods do
    assert get_method("local").memory_vectors == (0, 0) and get_method("centralised").memory_vectors == (0, 0)
    for name in ("ramen", "dinno", "dsgd", "dsgt"):
        assert get_method(name).memory_vectors[1] > 0, name


def _sc(count: int, kind: str = "complete"):
    return SimpleNamespace(agents=SimpleNamespace(count=count), method="ramen", topology=SimpleNamespace(kind=kind))


def _topology(count: int, degree: int, dynamic: bool = False):
    return SimpleNamespace(dynamic=dynamic, neighbours=lambda k: list(range(degree)))


def test_refused_above_what_is_available_and_warned_above_half(monkeypatch, caplog):
    vec = get_method("ramen").memory_vectors
    need = memory.estimate_bytes(1000, 4, [3] * 4, vec)
    with pytest.raises(InputError, match=r"needs about .* GiB \(4 agents of ramen.*3 neighbours each on the "
                                         r"'complete' topology\).*topology.kind ring.*RAMENSIM_SKIP_MEMORY_CHECK"):
        memory.check_memory(_sc(4), 1000, 4, _topology(4, 3), vec, available=need - 1)
    with caplog.at_level("WARNING", logger="ramensim.memory"):
        assert memory.check_memory(_sc(4), 1000, 4, _topology(4, 3), vec, available=need + need // 2) == need
    assert "more than half" in caplog.text
    # a dynamic (disk) topology may bring every agent together: counted as n - 1 neighbours
    dyn = memory.check_memory(_sc(4, "disk"), 1000, 4, _topology(4, 0, dynamic=True), vec, available=1 << 50)
    assert dyn == need
    monkeypatch.setenv(memory.SKIP_ENV, "1")
    assert memory.check_memory(_sc(4), 1000, 4, _topology(4, 3), vec, available=1) == need


def test_cli_refuses_a_run_that_does_not_fit_in_one_paragraph(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(memory, "available_bytes", lambda: 1 << 20)  # a machine with 1 MiB free
    out = tmp_path / "run"
    rc = main(["run", str(SCENARIO), "--out", str(out), "-q", "--set", "agents.count=2", "--set", "recording.mode=off",
               "--set", "world.camera.width=40", "--set", "world.camera.height=30", "--set", "world.camera.fx=30",
               "--set", "world.camera.fy=30", "--set", "world.camera.cx=19.5", "--set", "world.camera.cy=14.5"])
    err = capsys.readouterr().err
    assert rc == 2 and err.startswith("error: scenario: this run needs about") and err.count("\n") == 1
    assert not (out / "metrics.json").exists()


def _scenario(method: str = "ramen", count: int = 3, kind: str = "complete"):
    from ramensim.config import load_scenario

    sc = load_scenario(SCENARIO, [f"method={method}", f"agents.count={count}", f"topology.kind={kind}"])
    return sc[0] if isinstance(sc, tuple) else sc


def test_scenario_estimate_matches_the_run_formula():
    sc = _scenario()
    n = sc.map.n_params
    ramen = get_method("ramen")
    lent = memory.lent_vectors(ramen, 3)
    assert lent == ramen.round_vectors * memory.concurrent_rounds(3) > 0
    assert memory.scenario_estimate(sc) == memory.estimate_bytes(n, 3, [2, 2, 2], ramen.memory_vectors, lent)
    assert memory.scenario_estimate(_scenario("centralised")) == memory.estimate_bytes(n, 1, [0, 0, 0], (0, 0))
    assert memory.scenario_estimate(_scenario(count=6, kind="path")) < memory.scenario_estimate(_scenario(count=6))


def test_sweep_lowers_workers_or_refuses_the_point_that_cannot_fit():
    gib = 1 << 30
    est = {"small": 2 * gib, "big": 5 * gib, "mid": 4 * gib}
    assert memory.sweep_workers_that_fit(est, 2, available=16 * gib) == 2
    assert memory.sweep_workers_that_fit(est, 2, available=8 * gib) == 1  # big + mid = 9 GiB
    with pytest.raises(InputError, match="sweep point 'big' needs about 5.0 GiB but 4.0 GiB"):
        memory.sweep_workers_that_fit(est, 2, available=4 * gib)


def test_a_sweep_with_a_point_too_large_is_refused_naming_it(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(memory, "available_bytes", lambda: 8 << 30)  # 40 agents, complete graph: ~52 GiB
    sweep = tmp_path / "big.yaml"
    sweep.write_text(f"name: big\nbase: {SCENARIO}\nset: {{duration: 1, recording.mode: 'off'}}\n"
                     "axes:\n  agents.count: [2, 40]\n")
    rc = main(["sweep", str(sweep), "--out", str(tmp_path / "out"), "--workers", "2"])
    err = capsys.readouterr().err
    assert rc != 0 and "sweep point 'agents.count=40' needs about" in err and "Traceback" not in err
    assert not any((tmp_path / "out" / "runs").glob("agents.count=*"))  # nothing was run


def test_round_buffers_are_counted_per_round_at_once_not_per_agent(monkeypatch):
    """RAMEN's and DiNNO's round work vectors are lent per round (agents/consensus/scratch.py):
    the estimate counts one set per worker of the team engine (every map with lockstep
    batches), so 40 agents inline cost 36 MiB of them, not 40 x 36."""
    from ramensim.agents.team import BATCH_ENV, WORKERS_ENV

    ramen = get_method("ramen")
    assert ramen.round_vectors == 9 and get_method("dinno").round_vectors == 4
    monkeypatch.delenv(BATCH_ENV, raising=False)
    monkeypatch.setenv(WORKERS_ENV, "1")
    assert memory.lent_vectors(ramen, 40) == 9
    monkeypatch.setenv(WORKERS_ENV, "2")
    assert memory.lent_vectors(ramen, 40) == 18
    monkeypatch.setenv(BATCH_ENV, "1")
    assert memory.lent_vectors(ramen, 40, "cpu") == 9 * 40
