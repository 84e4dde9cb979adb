"""Plugins (ramensim/plugins.py, docs/EXTENDING.md): a method, a radio model or a scene in a
user's file, a module or an installed package's entry point, loaded by the CLI, the API and
sweep workers; bad plugins get one paragraph naming the file and the name, exit 2.

Every command runs in a subprocess: a plugin registers into the process's registries."""
from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
import yaml

from tests.e2e.tiny_runs import TINY

REPO = Path(__file__).resolve().parents[2]
SCENARIO = {"name": "plug", "duration": 4, "method": "ramen", "agents": {"count": 2}, "recording": {"mode": "off"}}
TINY_SET = {k: yaml.safe_load(v) for k, v in (t.split("=", 1) for t in TINY)}


def _cli(*args: str, cwd: Path, env: dict[str, str] | None = None, timeout: int = 300) -> subprocess.CompletedProcess:
    full_env = {**os.environ, **(env or {})}
    return subprocess.run([sys.executable, "-m", "ramensim", *args], cwd=cwd, capture_output=True, text=True,
                          timeout=timeout, env=full_env)


def _write(path: Path, text: str) -> Path:
    path.write_text(textwrap.dedent(text))
    return path


def _scenario(folder: Path, **extra) -> Path:
    p = folder / "scenario.yaml"
    p.write_text(yaml.safe_dump({**SCENARIO, **extra}))
    return p


def _error_paragraph(proc: subprocess.CompletedProcess) -> str:
    assert proc.returncode == 2, proc.stdout + proc.stderr
    assert "Traceback" not in proc.stderr
    errors = [line for line in proc.stderr.splitlines() if line.startswith("error:")]
    assert len(errors) == 1, proc.stderr
    return errors[0]


METHOD_TWICE = """
    from ramensim.agents.consensus.registry import MethodSpec, register
    register(MethodSpec(name="ramen", build=lambda s, cfg, ctx: None))
"""
SCENE_TWICE = """
    from ramensim.world.scenes import SceneSpec, register_scene
    register_scene(SceneSpec("office", lambda rng: None))
"""
RADIO_TWICE = """
    from ramensim.channels.radios import RadioModelSpec, register_radio
    register_radio(RadioModelSpec(name="burst", build=lambda s, ctx: None))
"""


@pytest.mark.parametrize("body, expected", [
    (None, ["nothere.py", "does not exist"]),
    ("x = 1\n", ["registers nothing", "register(MethodSpec"]),
    ("import math\nraise RuntimeError('no licence server')\n", ["raised RuntimeError at line 2", "no licence server"]),
    (METHOD_TWICE, ["'ramen' is already registered", "by ", "consensus/ramen.py", "declares it again"]),
    (SCENE_TWICE, ["'office' is already registered"]),
    (RADIO_TWICE, ["'burst' is already registered"]),
], ids=["missing", "registers_nothing", "raises", "builtin_method", "builtin_scene", "builtin_radio"])
def test_bad_plugin_file_is_one_paragraph_naming_file_and_name(tmp_path, body, expected):
    scen = _scenario(tmp_path)
    name = "nothere.py" if body is None else "bad_plugin.py"
    if body is not None:
        _write(tmp_path / name, body)
    line = _error_paragraph(_cli("validate", str(scen), "--plugin", name, cwd=tmp_path))
    assert str(tmp_path / name) in line
    for text in expected:
        assert text in line


def test_two_plugins_registering_one_name(tmp_path):
    for f in ("a.py", "b.py"):
        _write(tmp_path / f, """
            from ramensim.world.scenes import SceneSpec, register_scene
            from ramensim.world.scenes.rooms import _office
            register_scene(SceneSpec("twice", lambda rng: _office(rng)))
        """)
    scen = _scenario(tmp_path, plugins=["a.py", "b.py"])
    line = _error_paragraph(_cli("validate", str(scen), cwd=tmp_path))
    assert str(tmp_path / "b.py") in line and "'twice' is already registered" in line and "key 'plugins'" in line


def test_scenario_plugins_key_errors_name_the_scenario_and_line(tmp_path):
    scen = tmp_path / "s.yaml"
    scen.write_text("name: x\nduration: 4\nplugins: [gone.py]\n")
    line = _error_paragraph(_cli("validate", str(scen), cwd=REPO))
    assert f"{scen} (key 'plugins', line 3)" in line and str(tmp_path / "gone.py") in line
    scen.write_text("name: x\nplugins: gone.py\n")
    line = _error_paragraph(_cli("validate", str(scen), cwd=REPO))
    assert "key 'plugins' has value 'gone.py'; expected a list" in line


def test_unknown_names_until_the_plugin_is_loaded(tmp_path):
    """Without its plugin a scenario naming a plugin's method, radio block or scene is refused;
    with it (scenario key, --plugin, module name on the path) it validates."""
    for name in ("gossip_avg.py", "distance_loss_radio.py", "my_scene.py"):
        (tmp_path / name).write_text((REPO / "examples" / name).read_text())
    scen = _scenario(tmp_path, method="gossip_avg", world={"scene": {"name": "two_rooms"}},
                     channel={"distance_loss": {"range_m": 5.0}}, consensus={"gossip_avg": {"mix": 0.3}})
    line = _error_paragraph(_cli("validate", str(scen), cwd=tmp_path))
    assert "method 'gossip_avg' is unknown" in line and "scene 'two_rooms' is unknown" in line
    assert "'channel.distance_loss'" in line
    ok = _cli("validate", str(scen), "--plugin", "gossip_avg.py", "--plugin", "distance_loss_radio.py",
              "--plugin", "my_scene", cwd=tmp_path, env={"PYTHONPATH": str(tmp_path)})
    assert ok.returncode == 0, ok.stderr
    bad = _cli("validate", str(scen), "--plugin", "gossip_avg.py", "--plugin", "distance_loss_radio.py",
               "--plugin", "my_scene.py", "--set", "channel.distance_loss.range_m=-1", cwd=tmp_path)
    assert "channel.distance_loss.range_m" in _error_paragraph(bad)


def test_installed_package_entry_points(tmp_path):
    """A package's entry point in group ramensim.scenes (a module) and ramensim.methods (a spec
    object) is loaded without any plugins key."""
    site = tmp_path / "site"
    (site / "demo_pkg").mkdir(parents=True)
    _write(site / "demo_pkg" / "__init__.py", """
        from ramensim.world.scenes import SceneSpec, register_scene
        from ramensim.world.scenes.rooms import _office
        register_scene(SceneSpec("ep_room", _office, "an installed package's scene"))
    """)
    _write(site / "demo_pkg" / "method.py", """
        from ramensim.agents.consensus.registry import MethodSpec, get_method
        SPEC = MethodSpec(name="ep_local", build=get_method("local").build, communicates=False)
    """)
    dist = site / "demo_pkg-0.1.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: demo-pkg\nVersion: 0.1\n")
    (dist / "entry_points.txt").write_text("[ramensim.scenes]\nep_room = demo_pkg\n\n"
                                           "[ramensim.methods]\nep_local = demo_pkg.method:SPEC\n")
    scen = _scenario(tmp_path, method="ep_local", world={"scene": {"name": "ep_room"}})
    assert "'ep_room' is unknown" in _error_paragraph(_cli("validate", str(scen), cwd=tmp_path))
    ok = _cli("validate", str(scen), cwd=tmp_path, env={"PYTHONPATH": str(site)})
    assert ok.returncode == 0, ok.stderr


def _tiny_sweep(folder: Path, axes: dict, base: str = "scenario.yaml", **extra) -> Path:
    sweep = folder / "sweep.yaml"
    sweep.write_text(yaml.safe_dump({"name": "plug", "base": base, "set": TINY_SET, "axes": axes, **extra}))
    return sweep


def test_sweep_worker_that_cannot_import_a_plugin_fails_that_point_only(tmp_path):
    """The plugin imports in the driver (the plan is checked there) but raises in a worker
    process: that point fails with the reason, the other point runs."""
    _write(tmp_path / "driver_only.py", """
        import multiprocessing
        if multiprocessing.parent_process() is not None:
            raise ImportError("this plugin's library is not installed on the worker")
        from ramensim.world.scenes import SceneSpec, register_scene
        from ramensim.world.scenes.rooms import _office
        register_scene(SceneSpec("driver_room", _office))
    """)
    _scenario(tmp_path)
    sweep = _tiny_sweep(tmp_path, {"plugins": [[], ["driver_only.py"]]})
    proc = _cli("sweep", str(sweep), "--workers", "2", "--out", "out", "--no-report", cwd=tmp_path)
    assert proc.returncode == 1, proc.stdout + proc.stderr
    assert "Traceback" not in proc.stderr
    status = {d.name: json.loads((d / "status.json").read_text()) for d in (tmp_path / "out" / "runs").iterdir()}
    failed = [s for s in status.values() if s["status"] == "failed"]
    ok = [s for s in status.values() if s["status"] == "ok"]
    assert len(failed) == 1 and len(ok) == 1, status
    assert str(tmp_path / "driver_only.py") in failed[0]["error"]
    assert "not installed on the worker" in failed[0]["error"]
    assert "1 ok, 0 diverged, 1 failed" in proc.stdout


def test_sweep_plugins_key_and_plugin_option_reach_every_worker(tmp_path):
    """A sweep file's own plugins: key (relative to it) and --plugin (relative to the working
    directory) travel to the workers as absolute paths in each point's scenario."""
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "gossip_avg.py").write_text((REPO / "examples" / "gossip_avg.py").read_text())
    (tmp_path / "my_scene.py").write_text((REPO / "examples" / "my_scene.py").read_text())
    _scenario(tmp_path / "sub", world={"scene": {"name": "two_rooms"}})
    sweep = _tiny_sweep(tmp_path / "sub", {"method": ["gossip_avg", "dinno"]}, plugins=["gossip_avg.py"])
    proc = _cli("sweep", str(sweep), "--workers", "2", "--out", str(tmp_path / "out"), "--no-report",
                "--plugin", "my_scene.py", cwd=tmp_path)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    for point in ("method=gossip_avg", "method=dinno"):
        sc = yaml.safe_load((tmp_path / "out" / "runs" / point / "scenario.yaml").read_text())
        assert sc["plugins"] == [str(tmp_path / "sub" / "gossip_avg.py"), str(tmp_path / "my_scene.py")]
        m = json.loads((tmp_path / "out" / "runs" / point / "metrics.json").read_text())
        assert m["status"] == "ok" and m["method"] == point.split("=")[1]


def test_api_honours_the_plugins_key_and_argument(tmp_path):
    (tmp_path / "my_scene.py").write_text((REPO / "examples" / "my_scene.py").read_text())
    (tmp_path / "gossip_avg.py").write_text((REPO / "examples" / "gossip_avg.py").read_text())
    _scenario(tmp_path, world={"scene": {"name": "two_rooms"}}, plugins=["my_scene.py"])
    script = textwrap.dedent(f"""
        import ramensim
        if __name__ == "__main__":  # sweep workers are spawned processes that import this file
            out = ramensim.run("scenario.yaml", {TINY_SET!r} | {{"method": "gossip_avg"}}, out="api_run",
                               plugins=["gossip_avg.py"])
            print(out.status, out.method, sorted(out.per_agent))
            sweep = ramensim.sweep.run("sweep.yaml", "api_sweep", workers=1, plugins=["gossip_avg.py"])
            print(sweep.ok, sweep.failed)
    """)
    _tiny_sweep(tmp_path, {"method": ["gossip_avg"]})
    (tmp_path / "main.py").write_text(script)
    proc = subprocess.run([sys.executable, "main.py"], cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert "ok gossip_avg ['agent_0', 'agent_1']" in proc.stdout
    assert "['method=gossip_avg'] {}" in proc.stdout
    sc = yaml.safe_load((tmp_path / "api_sweep" / "runs" / "method=gossip_avg" / "scenario.yaml").read_text())
    assert sc["plugins"] == [str(tmp_path / "my_scene.py"), str(tmp_path / "gossip_avg.py")]


RAY_SITE = os.environ.get("RAMENSIM_TEST_RAY_PATH", "")


def _ray_available() -> bool:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(p for p in (RAY_SITE, os.environ.get("PYTHONPATH", "")) if p)}
    return subprocess.run([sys.executable, "-c", "import ray"], env=env, capture_output=True).returncode == 0


@pytest.mark.skipif(not _ray_available(), reason="the optional 'ray' extra is not installed "
                    "(pip install 'ramensim[ray]', or RAMENSIM_TEST_RAY_PATH naming a folder that holds it)")
def test_ray_workers_load_the_plugins(tmp_path):
    """On a local Ray cluster (started by the sweep) the tasks load the points' plugins: a
    method, a radio model and a scene from files outside the package."""
    for name in ("gossip_avg.py", "distance_loss_radio.py", "my_scene.py"):
        (tmp_path / name).write_text((REPO / "examples" / name).read_text())
    _scenario(tmp_path, method="gossip_avg", world={"scene": {"name": "two_rooms"}},
              channel={"distance_loss": {"range_m": 5.0}},
              plugins=["gossip_avg.py", "distance_loss_radio.py", "my_scene.py"])
    sweep = _tiny_sweep(tmp_path, {"channel.success_rate": [1.0, 0.5]})
    env = {"PYTHONPATH": os.pathsep.join(p for p in (RAY_SITE, os.environ.get("PYTHONPATH", "")) if p),
           "RAY_TMPDIR": "/tmp"}
    proc = _cli("sweep", str(sweep), "--executor", "ray", "--workers", "2", "--out", "out", "--no-report",
                cwd=tmp_path, env=env, timeout=600)
    assert proc.returncode == 0, proc.stdout + proc.stderr[-3000:]
    for d in (tmp_path / "out" / "runs").iterdir():
        m = json.loads((d / "metrics.json").read_text())
        assert m["status"] == "ok" and m["method"] == "gossip_avg"


def test_module_entries():
    """Module names: an imported module counts when it declared something (the built-ins do);
    one that declares nothing, one that cannot be found and a malformed name are refused."""
    from ramensim import plugins
    from ramensim.core.errors import InputError

    assert plugins.load_plugins(["ramensim.agents.consensus.dinno"]) == ["ramensim.agents.consensus.dinno"]
    with pytest.raises(InputError, match="plugin module 'json' registers nothing"):
        plugins.load_plugins(["json"])
    with pytest.raises(InputError, match="'no_such_plugin_module' cannot be found"):
        plugins.load_plugins(["no_such_plugin_module"])
    with pytest.raises(InputError, match="expected a plugin file"):
        plugins.load_plugins(["not a module!"])


def test_world_export_and_show_take_plugins(tmp_path):
    (tmp_path / "my_scene.py").write_text((REPO / "examples" / "my_scene.py").read_text())
    refused = _cli("world", "export", "two_rooms", "--out", "tr.ply", cwd=tmp_path)
    assert "scene 'two_rooms' is unknown" in _error_paragraph(refused) and "--plugin" in _error_paragraph(refused)
    ok = _cli("world", "export", "two_rooms", "--out", "tr.ply", "--plugin", "my_scene.py", cwd=tmp_path)
    assert ok.returncode == 0, ok.stderr
    import trimesh

    mesh = trimesh.load(tmp_path / "tr.ply")
    assert len(mesh.faces) > 0 and 7.9 < mesh.extents[0] < 8.5  # the two rooms: 8 m of floor plus walls


def test_a_plugin_file_imports_modules_beside_it(tmp_path):
    (tmp_path / "plug").mkdir()
    _write(tmp_path / "plug" / "room_helpers.py", """
        from ramensim.world.scenes.rooms import _office
        def build(rng):
            return _office(rng)
    """)
    _write(tmp_path / "plug" / "helper_scene.py", """
        from room_helpers import build
        from ramensim.world.scenes import SceneSpec, register_scene
        register_scene(SceneSpec("helper_room", build))
    """)
    scen = _scenario(tmp_path, world={"scene": {"name": "helper_room"}}, plugins=["plug/helper_scene.py"])
    ok = _cli("validate", str(scen), cwd=REPO)
    assert ok.returncode == 0, ok.stderr
