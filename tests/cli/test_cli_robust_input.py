"""Hostile and careless scenario files: every one gets exit 0 or 2, one paragraph, no traceback,
in bounded work and memory (issue 15). In-process CLI calls; hypothesis generates documents.
Work is counted in Python calls (stepbudget.py), memory in traced bytes: no test here reads a
clock (issue 57: a 30-s limit failed on a loaded machine)."""
from __future__ import annotations

import math
import resource
import tracemalloc
import typing
from pathlib import Path

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from pydantic import BaseModel

from ramensim.budget import MAX_EVENTS, estimate_events
from ramensim.cli import main
from ramensim.config import load_scenario, validate
from ramensim.core.errors import InputError
from ramensim.schema import Scenario
from ramensim.yamlsafe import MAX_BYTES, MAX_DEPTH, MAX_NODES, safe_load_bounded
from stepbudget import StepBudgetExceeded, step_budget

SCENARIOS = Path(__file__).resolve().parents[2] / "scenarios"


def _numeric_keys(model: type[BaseModel] = Scenario, prefix: str = "") -> list[tuple[str, type]]:
    """Dotted paths of every int/float leaf of the schema (the first variant of a union of models)."""
    out: list[tuple[str, type]] = []
    for name, f in model.model_fields.items():
        args = typing.get_args(f.annotation) or (f.annotation,)
        subs = [a for a in args if isinstance(a, type) and issubclass(a, BaseModel)]
        for a in args:
            subs += [b for b in typing.get_args(a) if isinstance(b, type) and issubclass(b, BaseModel)]
        if subs:
            out += _numeric_keys(subs[0], f"{prefix}{name}.")
        elif any(a in (int, float) for a in args):
            out.append((f"{prefix}{name}", float if float in args else int))
    return out


NUMERIC = _numeric_keys()

def steps_for(text: str) -> int:
    """Most Python calls one 'ramensim validate' of ``text`` may make: linear in its size and
    in the expansion bound. Validating office_3agents.yaml takes about 55,000 calls (65,000 the
    first time in a process); the pure-Python YAML reader makes about 45 per byte of text (5,000
    unknown keys, 79 kB: 3.5 million); the scenario is copied once (a few calls per value, at
    most MAX_NODES values with aliases expanded); an alias bomb or a nesting without the bounds
    takes billions."""
    return 300_000 + 100 * len(text.encode("utf-8")) + 10 * MAX_NODES


def _cli(capsys, *argv: str) -> tuple[int, str]:
    rc = main(list(argv))
    err = capsys.readouterr().err
    return rc, err


def _check_clean(rc: int, err: str) -> None:
    assert rc in (0, 2), err
    assert "Traceback" not in err
    if rc == 2:
        assert err.startswith("error: ") and err.count("\n") <= 1 + err.count("error: "), err
        assert len(err) < 5000


def test_schema_has_many_numeric_keys() -> None:
    assert len(NUMERIC) > 60


@pytest.mark.parametrize("key,kind", NUMERIC, ids=[k for k, _ in NUMERIC])
def test_non_finite_numbers_refused_on_every_key(key: str, kind: type, capsys) -> None:
    for text in ("nan", ".inf", "-.inf", "inf", "1.0e999"):
        with pytest.raises(InputError) as info:
            validate(_nested(key, safe_load_bounded(text)), "s.yaml")
        msg = str(info.value)
        assert "s.yaml" in msg and key.split(".")[-1] in msg, msg


def _nested(key: str, value: object) -> dict:
    parts = key.split(".")
    out: dict = {}
    node = out
    for p in parts[:-1]:
        node[p] = {}
        node = node[p]
    node[parts[-1]] = value
    if parts[:2] == ["world", "trajectory"]:
        out["world"]["trajectory"].setdefault("kind", "procedural")
    return out


def test_shipped_scenarios_are_valid_and_within_budget() -> None:
    for path in sorted(SCENARIOS.glob("*.yaml")):
        sc = load_scenario(path)
        assert estimate_events(sc)["total"] <= MAX_EVENTS


HOSTILE = {
    "alias_bomb": "a: &a [x,x,x,x,x,x,x,x,x]\n" + "".join(
        f"{c}: &{c} [*{p},*{p},*{p},*{p},*{p},*{p},*{p},*{p},*{p}]\n" for p, c in zip("abcdefgh", "bcdefghi")),
    "deep_nesting": "a: " + "[" * 3000 + "]" * 3000 + "\n",
    "deep_mapping": "".join("  " * i + f"k{i}:\n" for i in range(200)) + "  " * 200 + "x: 1\n",
    "long_seed": "seed: " + "7" * 5000 + "\n",
    "tiny_iteration": "agents: {compute: {seconds_per_iteration: 1.0e-9}}\n",
    "huge_duration": "duration: 1.0e300\n",
    "long_name": "name: " + "n" * 100_000 + "\n",
    "many_unknown": "".join(f"unknown_{i}: {i}\n" for i in range(5000)),
    "duplicate": "seed: 1\nduration: 10\nseed: 2\n",
    "cycle": "a: &a [1, *a]\n",
    "python_tag": "seed: !!python/object/apply:os.system ['true']\n",
    "nan_lr": "map: {lr: .nan}\n",
    "tabs": "seed:\t1\n\tduration: 2\n",
    "binary": "seed: !!binary AAAA\n",
    "null_byte_path": 'world: {scene: {kind: mesh, path: "a\\0b.ply"}}\n',
    "list_top": "- 1\n- 2\n",
    "empty": "",
}


@pytest.mark.parametrize("name", sorted(HOSTILE))
def test_hostile_yaml_exit_2_within_a_step_budget(name: str, tmp_path: Path, capsys) -> None:
    path = tmp_path / f"{name}.yaml"
    path.write_text(HOSTILE[name], encoding="utf-8")
    with step_budget(steps_for(HOSTILE[name])):
        rc, err = _cli(capsys, "validate", str(path))
    assert rc == 2, err
    _check_clean(rc, err)
    assert str(path) in err


def test_the_step_budget_stops_an_unbounded_document(tmp_path: Path, capsys, monkeypatch) -> None:
    """Without the expansion bound the alias bomb is walked node by node (9^9 of them): the
    budget above stops it, so the test above fails if the bound goes."""
    import ramensim.yamlsafe as yamlsafe

    monkeypatch.setattr(yamlsafe, "check_node", lambda *a, **k: 0)
    path = tmp_path / "alias_bomb.yaml"
    path.write_text(HOSTILE["alias_bomb"], encoding="utf-8")
    with pytest.raises(StepBudgetExceeded):
        with step_budget(steps_for(HOSTILE["alias_bomb"])):
            _cli(capsys, "validate", str(path))


def test_deep_brackets_refused_before_the_scanner_runs(capsys, monkeypatch) -> None:
    """3,000 open brackets: refused by counting them (a few hundred calls), not by the YAML
    scanner, whose work grows with the open brackets, hitting Python's recursion limit."""
    import yaml as pyyaml

    def no_scanner(*args, **kwargs):
        raise AssertionError("the YAML scanner ran")

    monkeypatch.setattr(pyyaml.scanner.Scanner, "fetch_more_tokens", no_scanner)
    with step_budget(2_000) as count:
        with pytest.raises(pyyaml.YAMLError, match=f"nested deeper than {MAX_DEPTH} levels"):
            safe_load_bounded(HOSTILE["deep_nesting"])
    assert count.steps < 2_000
    monkeypatch.undo()
    deep = MAX_DEPTH - 1  # the mapping is the first level
    assert safe_load_bounded("a: " + "[" * deep + "]" * deep) == {"a": _nest(deep)}


def _nest(n: int) -> list:
    out: list = []
    for _ in range(n - 1):
        out = [out]
    return out


def test_duplicate_key_names_both_lines(tmp_path: Path, capsys) -> None:
    path = tmp_path / "dup.yaml"
    path.write_text(HOSTILE["duplicate"], encoding="utf-8")
    _, err = _cli(capsys, "validate", str(path))
    assert "duplicate key 'seed'" in err and "lines 1 and 3" in err


def test_unknown_keys_capped(tmp_path: Path, capsys) -> None:
    path = tmp_path / "unknown.yaml"
    path.write_text(HOSTILE["many_unknown"], encoding="utf-8")
    _, err = _cli(capsys, "validate", str(path))
    assert "and 4980 more" in err and len(err) < 2000


def test_event_budget_message_has_the_estimate(tmp_path: Path, capsys) -> None:
    path = tmp_path / "fast.yaml"
    path.write_text(HOSTILE["tiny_iteration"], encoding="utf-8")
    _, err = _cli(capsys, "validate", str(path))
    assert "simulation events" in err and "seconds_per_iteration" in err


def test_alias_expansion_bounded_before_any_copy() -> None:
    from ramensim.yamlsafe import YAMLLimitError

    with pytest.raises(YAMLLimitError, match=str(MAX_NODES)):
        safe_load_bounded(HOSTILE["alias_bomb"])
    # a few honest aliases are fine
    assert safe_load_bounded("a: &x {b: 1}\nc: *x\n") == {"a": {"b": 1}, "c": {"b": 1}}


# ---- property-based: generated documents -------------------------------------------------

_TOP = ["name", "seed", "duration", "method", "world", "agents", "map", "consensus", "channel",
        "topology", "radio", "evaluation", "recording", "output", "bogus"]
_leaf = st.one_of(
    st.none(), st.booleans(),
    st.integers(min_value=-(10 ** 30), max_value=10 ** 30),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from(["nan", "inf", "-inf", "1e-9", "ramen", "office", "", "..", "/dev/null", "a" * 300]),
    st.text(max_size=20),
)
_value = st.recursive(_leaf, lambda inner: st.one_of(
    st.lists(inner, max_size=4),
    st.dictionaries(st.sampled_from(["count", "kind", "lr", "n_rays", "success_rate", "period_s",
                                     "seconds_per_iteration", "fps", "scene", "compute", "x"]),
                    inner, max_size=4)), max_leaves=12)
_numeric_override = st.tuples(st.sampled_from([k for k, _ in NUMERIC]), st.one_of(
    st.floats(allow_nan=True, allow_infinity=True), st.integers(min_value=-(10 ** 25), max_value=10 ** 25),
    st.sampled_from(["nan", "inf", "1e-9", "1e300", "-1", "0", "abc", "[1, 2]", "{a: 1}"])))

_SETTINGS = settings(max_examples=60, deadline=None, derandomize=True,
                     suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])


@_SETTINGS
@given(doc=st.dictionaries(st.sampled_from(_TOP), _value, max_size=5))
def test_generated_documents_exit_0_or_2(doc: dict, tmp_path: Path, capsys) -> None:
    path = tmp_path / "gen.yaml"
    path.write_text(yaml.safe_dump(doc, allow_unicode=True), encoding="utf-8")
    rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    with step_budget(steps_for(path.read_text(encoding="utf-8"))):
        rc, err = _cli(capsys, "validate", str(path))
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - rss0 < 512 * 1024  # KiB
    _check_clean(rc, err)


@_SETTINGS
@given(override=_numeric_override)
def test_generated_overrides_exit_0_or_2(override: tuple[str, object], capsys) -> None:
    key, value = override
    text = value if isinstance(value, str) else repr(value)
    rc, err = _cli(capsys, "validate", str(SCENARIOS / "office_3agents.yaml"), "--set", f"{key}={text}")
    _check_clean(rc, err)
    if isinstance(value, float) and not math.isfinite(value):
        assert rc == 2


@_SETTINGS
@given(text=st.one_of(
    st.text(alphabet=st.sampled_from(list("[]{}:&*!,-? \n\t'\"#|>abc1.")), max_size=200),
    st.builds(lambda n, w: "a: &a [" + ",".join(["x"] * w) + "]\n" + "".join(
        f"k{i}: &k{i} [" + ",".join([f"*{'a' if i == 0 else f'k{i - 1}'}"] * w) + "]\n" for i in range(n)),
        st.integers(1, 12), st.integers(1, 12)),
    st.builds(lambda d: "x: " + "{a: " * d + "1" + "}" * d, st.integers(1, 400)),
))
def test_generated_hostile_yaml_exit_0_or_2(text: str, tmp_path: Path, capsys) -> None:
    path = tmp_path / "hostile.yaml"
    path.write_text(text, encoding="utf-8")
    with step_budget(steps_for(text)):
        rc, err = _cli(capsys, "validate", str(path))
    _check_clean(rc, err)


def test_other_commands_bad_arguments(tmp_path: Path, capsys) -> None:
    bad_ply = tmp_path / "bad.ply"
    bad_ply.write_text("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                       "property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
                       "0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n", encoding="utf-8")
    good_ply = tmp_path / "good.ply"
    good_ply.write_text(bad_ply.read_text().replace("3 0 1 7", "3 0 1 2"), encoding="utf-8")
    cases = [
        ["eval", "--mesh", str(bad_ply), "--gt", str(bad_ply)],
        ["eval", "--mesh", str(tmp_path / "missing.ply"), "--gt", str(bad_ply)],
        ["pretrain-decoders", "--out", str(tmp_path / "d.pt"), "--agents", "0"],
        ["pretrain-decoders", "--out", str(tmp_path / "d.pt"), "--scene", "nowhere"],
        ["pretrain-decoders", "--out", str(tmp_path / "d.pt"), "--duration", "nan"],
        ["pretrain-decoders", "--out", str(tmp_path / "d.txt")],
        ["world", "export", "nowhere", "--out", str(tmp_path / "a.ply")],
        ["world", "export", "office", "--out", str(tmp_path / "a.xyz")],
        ["world", "export", "office", "--seed", "-1", "--out", str(tmp_path / "a.ply")],
        ["world", "show", str(tmp_path / "missing.yaml")],
        ["report", str(tmp_path)],
        ["report", str(tmp_path / "nowhere")],
        ["run", str(tmp_path / "missing.yaml")],
        # bounds and outputs checked before any work (a huge --samples was a MemoryError, a negative
        # --cull-max-edge "max_iter exceeded!", an unwritable --out came after minutes of pretraining)
        ["eval", "--mesh", str(good_ply), "--gt", str(good_ply), "--samples", str(10 ** 11)],
        ["eval", "--mesh", str(good_ply), "--gt", str(good_ply), "--cull-max-edge", "-1"],
        ["eval", "--mesh", str(good_ply), "--gt", str(good_ply), "--cull-max-edge", "nan"],
        ["pretrain-decoders", "--out", str(bad_ply / "d.pt")],
        ["pretrain-decoders", "--out", "/proc/no/such/d.pt"],
        ["world", "show", str(SCENARIOS / "office_3agents.yaml"), "--out", str(tmp_path / "w.txt")],
        ["world", "show", str(SCENARIOS / "office_3agents.yaml"), "--coverage-points", "0"],
        ["world", "show", str(SCENARIOS / "office_3agents.yaml"), "--out", str(bad_ply / "w.png")],
        ["validate", "/dev/zero"],
        ["validate", str(tmp_path)],
    ]
    for argv in cases:
        rc, err = _cli(capsys, *argv)
        assert rc == 2, (argv, err)
        _check_clean(rc, err)
    rc, _ = _cli(capsys, "schema")
    assert rc == 0


# ---- lines, booleans, magnitudes, devices, paths ---------------------------------------------

def test_errors_name_the_line_or_the_override(tmp_path: Path, capsys) -> None:
    path = tmp_path / "curve.yaml"
    path.write_text("name: c\nchannel:\n  path_loss:\n    enabled: true\n"
                    "    curve: [[-92, 0.0], [-82, 1.0], [-80, 0.5]]\nbogus: 1\n", encoding="utf-8")
    rc, err = _cli(capsys, "validate", str(path))
    assert rc == 2 and str(path) in err
    assert "key 'channel.path_loss.curve' (line 5)" in err and "monotone" in err
    assert "'bogus' (line 6)" in err
    rc, err = _cli(capsys, "validate", str(SCENARIOS / "office_3agents.yaml"), "--set", "agents.count=0")
    assert rc == 2 and "key 'agents.count' (--set)" in err
    # a cross-key check names its key's line too; a key the file does not write gets no line
    path.write_text("name: c\nmap:\n  lr: .nan\n", encoding="utf-8")
    _, err = _cli(capsys, "validate", str(path))
    assert "key 'map.lr' (line 3)" in err
    path.write_text("name: c\nevaluation:\n  near_m: 2.0e6\n", encoding="utf-8")
    rc, err = _cli(capsys, "validate", str(path))
    assert rc == 2 and "key 'evaluation.near_m' (line 3)" in err and "key 'evaluation.far_m' = " in err
    rc, err = _cli(capsys, "validate", str(SCENARIOS / "office_3agents.yaml"), "--set",
                   "world.camera.sensor.min_range=20")
    assert rc == 2 and "key 'world.camera.sensor' (--set)" in err


def test_booleans_are_not_numbers(tmp_path: Path, capsys) -> None:
    path = tmp_path / "bools.yaml"
    path.write_text("duration: true\nagents: {count: yes}\nmap: {native: true}\n", encoding="utf-8")
    rc, err = _cli(capsys, "validate", str(path))
    assert rc == 2 and "key 'duration' (line 1) has value True; expected a number" in err
    assert "'agents.count' (line 2)" in err and "native" not in err


@pytest.mark.parametrize("key", ["map.near", "consensus.ramen.rho", "world.trajectory.height", "map.rgb_weight"])
def test_huge_magnitudes_refused(key: str) -> None:
    from ramensim.schema import MAX_FLOAT

    with pytest.raises(InputError, match="magnitude at most"):
        validate(_nested(key, 1e300), "s.yaml")
    with pytest.raises(InputError, match="magnitude at most"):
        validate(_nested(key, MAX_FLOAT * 10), "s.yaml")


def _traced_peak(fn) -> int:
    """Peak bytes Python allocated while ``fn`` ran (tracemalloc)."""
    tracemalloc.start()
    try:
        tracemalloc.reset_peak()
        fn()
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def test_device_and_huge_files_read_bounded(tmp_path: Path, capsys) -> None:
    """Reading stops after MAX_BYTES + 1: a 64-MiB file (sparse) and /dev/zero (unbounded reading
    was OOM-killed) cost a few MiB, counted in bytes allocated, not seconds."""
    huge = tmp_path / "huge.yaml"
    with huge.open("wb") as fh:
        fh.truncate(64 * MAX_BYTES)
    for path in (str(huge), "/dev/zero"):
        out: dict = {}
        peak = _traced_peak(lambda: out.update(zip(("rc", "err"), _cli(capsys, "validate", path))))
        assert out["rc"] == 2 and "longer than" in out["err"] and path in out["err"], out
        assert peak < 8 * MAX_BYTES, peak
    rc, err = _cli(capsys, "validate", str(tmp_path))
    assert rc == 2 and "cannot be read" in err


def test_paths_checked_when_the_scenario_is_loaded(tmp_path: Path, capsys) -> None:
    scen = tmp_path / "s.yaml"
    scen.write_text(
        "name: p\nagents: {count: 2}\nchannel:\n  trace: {path: t.csv}\n", encoding="utf-8")
    rc, err = _cli(capsys, "validate", str(scen))
    assert rc == 2 and "key 'channel.trace.path' (line 4)" in err and "is not a file" in err
    (tmp_path / "t.csv").write_text("time,from,to,delivered,latency\n0,0,1,1,0.01\n0.5,0,2,1,0.01\n")
    rc, err = _cli(capsys, "validate", str(scen))  # read row by row: agent 2 of a 2-agent team
    assert rc == 2 and "t.csv" in err and "line 3" in err and "unknown agent" in err
    (tmp_path / "t.csv").write_text("time,from,to,delivered,latency\n0,0,1,1,0.01\n")
    assert _cli(capsys, "validate", str(scen))[0] == 0
    cases = {
        "world:\n  scene: {kind: mesh, path: nowhere.ply}\n": ("world.scene.path", "not a file"),
        "world:\n  scene: {kind: replica, path: no/such/folder}\n": ("world.scene.path", "not a folder"),
        "world:\n  trajectory: {kind: file, paths: [a.txt, b.txt]}\n": ("world.trajectory.paths[0]", "not a file"),
        "map: {decoders: dec.pt}\n": ("map.decoders", "not a file"),
    }
    for text, (key, what) in cases.items():
        scen.write_text(text, encoding="utf-8")
        rc, err = _cli(capsys, "validate", str(scen))
        assert rc == 2 and f"key '{key}'" in err and what in err, err
        _check_clean(rc, err)
