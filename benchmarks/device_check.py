"""The team on one GPU, measured in one prepared run (issue 70): every figure the GPU machine is
asked for, in one call, each stage in a child process with its own time limit, so that a crash
or an overrun in one stage is recorded and the next still runs.

    python3 benchmarks/device_check.py OUT [--device cuda] [--budget-s 480] [--commit SHA]
    python3 benchmarks/device_check.py OUT --device cpu --tiny      # the rehearsal a test runs

Stages, in this order (the figures of each are written to ``OUT/device_check.json`` and
``OUT/device_check.md`` as soon as it ends):

1. ``machine``: GPU, driver, torch and its CUDA, CPU cores.
2. ``tests``: the CUDA tests (tests/map/test_map_cuda.py, tests/e2e/test_e2e_cuda.py with the
   lockstep test); on a machine without CUDA they skip, and the stage says so.
3. ``run_batch`` and ``run_inline``: the 60-s house RAMEN run (``scenarios/house_3agents.yaml``,
   recording off, ``map.native: false``) on the device with the team's lockstep batch on
   (``RAMENSIM_TEAM_BATCH=1``, a GPU's default) and off (``0``): wall s, real-time factor (simulated s / wall s of the
   whole run, start-up and evaluations included), the GPU's busy share (``nvidia-smi``'s
   utilization sampled every 0.5 s over the run), peak device memory (torch's allocator), every
   evaluation's stages (``RAMENSIM_EVAL_STAGES=1``) and each robot's completion. Beside them,
   ``run_cpu``, the same trial on the CPU (the default compiled path, 8 threads), started first
   in the background, gives the completion the device's runs are set against (docs/DESIGN.md's
   cross-host bound: a quarter point per robot, a tenth for the team).
4. ``batch``: one round of B steps of 3, 24 and 100 robots' maps, batched against separate, in
   the default map and the paper preset (2048 rays, 32 + 11 samples): the team's samples/s
   (benchmarks/bench_team_batch.py's :func:`measure`).
5. ``scale``: 3, 24 and 100 robots on a ring of the house for 10 simulated s, the simulation
   alone (no evaluation), team batch on: wall per robot-simulated-second relative to 3 robots,
   real-time factor, device memory per robot.

The goals of issue 70 are printed beside the figures (never asserted: a timing is a reading).
Nothing here changes the device's settings. ``--tiny`` shrinks every stage (the office, 1 s,
2-3 robots, coarse evaluation) so that tests/benchmarks/test_device_check.py runs the whole
script on the CPU in about a minute and a typo cannot waste the GPU machine's time.
"""
from __future__ import annotations

import argparse
import json
import logging
import os
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.append(str(ROOT))  # last: an installed ramensim (editable or not) wins over the checkout's folder
from benchmarks._machine import machine_info  # noqa: E402
from ramensim.agents.rounds import BATCH_ENV, WORKERS_ENV  # noqa: E402
from ramensim.observe import STAGES_ENV  # noqa: E402

log = logging.getLogger("device_check")

HOUSE = ROOT / "scenarios" / "house_3agents.yaml"
OFFICE = ROOT / "scenarios" / "office_3agents.yaml"
CUDA_TESTS = ["tests/map/test_map_cuda.py", "tests/e2e/test_e2e_cuda.py"]
TINY_RUN = ["agents.count=2", "world.camera.width=40", "world.camera.height=30", "world.camera.fx=30",
            "world.camera.fy=30", "world.camera.cx=19.5", "world.camera.cy=14.5", "evaluation.voxel_m=0.1",
            "evaluation.n_samples=5000", "map.n_rays=128", "consensus.primal_steps=3"]
GOALS = {
    "run_rtf": 10.0, "gpu_busy": 0.60, "cost_24_vs_3": 0.3, "rtf_100": 1.0, "paper_msamples": 50.0,
}
"""Issue 70's goals: the 3-robot house run at >= 10x real time with the GPU >= 60 % busy; 24
robots at <= 0.3x the cost per robot-second of 3; 100 robots on a ring at >= 1x real time; the
paper preset at >= 50 M samples/s for the team."""


# --------------------------------------------------------------------------------------------
# the stages (each runs in its own child process: ``--stage NAME``)

def stage_machine(a: argparse.Namespace) -> dict[str, Any]:
    """The machine line: GPU name, driver and memory (nvidia-smi), torch, its CUDA, CPU cores."""
    import torch

    info: dict[str, Any] = {"line": machine_info(), "torch": torch.__version__,
                            "torch_cuda": torch.version.cuda, "cores": os.cpu_count(),
                            "cuda_available": torch.cuda.is_available()}
    if torch.cuda.is_available():
        info["gpu"] = torch.cuda.get_device_name(0)
        info["gpu_memory_gib"] = torch.cuda.get_device_properties(0).total_memory / 2**30
    try:
        out = subprocess.run(["nvidia-smi", "--query-gpu=name,driver_version,memory.total",
                              "--format=csv,noheader"], capture_output=True, text=True, timeout=20)
        info["nvidia_smi"] = out.stdout.strip() or out.stderr.strip()
    except (OSError, subprocess.TimeoutExpired) as exc:
        info["nvidia_smi"] = f"unavailable ({exc})"
    return info


def stage_tests(a: argparse.Namespace) -> dict[str, Any]:
    """The CUDA tests under pytest (on several workers when pytest-xdist is there)."""
    import importlib.util

    # -P: the working directory is not put first on sys.path, so the installed ramensim is imported
    cmd = [sys.executable, "-P", "-m", "pytest", "-q", "-p", "no:cacheprovider", "-o", "addopts=", *CUDA_TESTS]
    if importlib.util.find_spec("xdist") is not None and not a.tiny:
        cmd += ["-n", "4"]
    proc = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=a.stage_timeout)
    text = proc.stdout + proc.stderr
    (Path(a.out) / "tests.log").write_text(text)  # one of the four files OUT holds
    summary = [ln for ln in text.splitlines() if " passed" in ln or " failed" in ln or " skipped" in ln
               or " error" in ln]
    return {"returncode": proc.returncode, "summary": summary[-1] if summary else text[-300:]}


class GpuSampler:
    """``nvidia-smi``'s utilization (%) and memory used (MiB) every 0.5 s, on a thread, while
    active; nothing where there is no nvidia-smi (the CPU rehearsal)."""

    def __init__(self, period_ms: int = 500) -> None:
        self.samples: list[tuple[float, float]] = []
        self.period_ms = period_ms
        self.proc: subprocess.Popen | None = None
        self.thread: threading.Thread | None = None

    def __enter__(self) -> "GpuSampler":
        try:
            self.proc = subprocess.Popen(
                ["nvidia-smi", "--query-gpu=utilization.gpu,memory.used", "--format=csv,noheader,nounits",
                 f"--loop-ms={self.period_ms}"], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        except OSError:
            return self
        self.thread = threading.Thread(target=self._read, daemon=True)
        self.thread.start()
        return self

    def _read(self) -> None:
        assert self.proc is not None and self.proc.stdout is not None
        for line in self.proc.stdout:
            try:
                util, mem = (float(x) for x in line.split(","))
            except ValueError:
                continue
            self.samples.append((util, mem))

    def __exit__(self, *exc: object) -> None:
        if self.proc is not None:
            self.proc.terminate()
            self.proc.wait(timeout=10)

    def summary(self) -> dict[str, Any]:
        if not self.samples:
            return {"gpu_samples": 0}
        utils = [u for u, _ in self.samples]
        return {"gpu_samples": len(utils), "gpu_busy_share": sum(utils) / len(utils) / 100.0,
                "gpu_mem_used_max_mib": max(m for _, m in self.samples)}


def _run_overrides(a: argparse.Namespace, device: str) -> tuple[Path, list[str]]:
    scenario = OFFICE if a.tiny else HOUSE
    sets = ["recording.mode=off", "method=ramen", f"map.device={device}",
            f"duration={1 if a.tiny else 60}"]
    if device != "cpu" or a.tiny:
        sets.append("map.native=false")  # the torch path: the one a GPU runs
    if a.tiny:
        sets += TINY_RUN + ["evaluation.every_s=null"]
    return scenario, sets


def _one_run(a: argparse.Namespace, device: str, name: str) -> dict[str, Any]:
    """One run in this process (so torch's peak device memory is readable): its figures."""
    import torch

    from ramensim.config import load_scenario
    from ramensim.lifecycle import run_scenario

    os.environ[STAGES_ENV] = "1"
    scenario, sets = _run_overrides(a, device)
    sc = load_scenario(scenario, sets)
    folder = Path(a.work) / name
    with GpuSampler() as gpu:
        t0 = time.perf_counter()
        run_scenario(sc, folder)
        wall = time.perf_counter() - t0
    m = json.loads((folder / "metrics.json").read_text())
    build = m.get("build") or {}
    row: dict[str, Any] = {
        "scenario": scenario.name, "sets": sets, "status": m["status"], "sim_s": m["sim_time_s"], "wall_s": wall,
        "rtf": m["sim_time_s"] / wall, "team_lockstep": build.get("team_lockstep"),
        "team_largest_batch": build.get("team_largest_batch"), "team_workers": build.get("team_workers"),
        "completion_pct": {k: v.get("completion_ratio_pct") for k, v in m["per_agent"].items()},
        "team_completion_pct": (m.get("summary", {}).get("completion_ratio_pct") or {}).get("mean"),
        "rounds": {k: v.get("rounds") for k, v in m["per_agent"].items()},
        "eval_stage_s": build.get("eval_stage_s"), **gpu.summary()}
    if device == "cuda" and torch.cuda.is_available():
        row["peak_device_mem_gib"] = torch.cuda.max_memory_allocated() / 2**30
    return row


def stage_run_batch(a: argparse.Namespace) -> dict[str, Any]:
    os.environ[BATCH_ENV] = "1"
    os.environ.pop(WORKERS_ENV, None)
    return _one_run(a, a.device, "run_batch")


def stage_run_inline(a: argparse.Namespace) -> dict[str, Any]:
    os.environ[BATCH_ENV] = "0"  # unset means batches on a GPU
    return _one_run(a, a.device, "run_inline")


def stage_run_cpu(a: argparse.Namespace) -> dict[str, Any]:
    os.environ.pop(BATCH_ENV, None)
    return _one_run(a, "cpu", "run_cpu")


def stage_batch(a: argparse.Namespace) -> dict[str, Any]:
    """Batched against separate rounds, default map and paper preset (bench_team_batch.measure)."""
    from benchmarks.bench_team_batch import measure

    sizes = [2] if a.tiny else a.batch_sizes
    rows = []
    for preset in a.batch_presets:
        for k in sizes:
            steps = 1 if a.tiny else (5 if k >= 100 else 10)
            rows.append(measure(k, a.device, steps, 1 if a.tiny else 2, preset, 32 if a.tiny else None))
            log.info("batch %s %d robots: %s", preset, k, rows[-1])
            _partial(a, rows)
    return {"rows": rows}


def _partial(a: argparse.Namespace, rows: list[dict[str, Any]]) -> None:
    """A stage's rows so far, so that a stage cut by its time limit still reports them."""
    (_stages(a) / f"partial_{a.stage}.json").write_text(json.dumps(rows, indent=1))


def stage_scale(a: argparse.Namespace) -> dict[str, Any]:
    """k robots on a ring of the house for 10 simulated s, the simulation alone (the event loop,
    frames, the team's rounds, the channel; no evaluation), team batch on: wall, real-time
    factor, wall per robot-simulated-second, device memory per robot."""
    import torch

    from ramensim.config import load_scenario
    from ramensim.sim import build_simulation

    os.environ[BATCH_ENV] = "1"
    os.environ.pop(WORKERS_ENV, None)
    from ramensim.errors import InputError

    sizes = [2, 3] if a.tiny else a.scale_sizes
    duration = 0.5 if a.tiny else 10.0
    rows: list[dict[str, Any]] = []
    for k in sizes:
        scenario, sets = _run_overrides(a, a.device)
        sets = [s for s in sets if not s.startswith(("duration=", "agents.count="))]
        sets += [f"agents.count={k}", "topology.kind=ring", f"duration={duration}",
                 f"world.trajectory.split={a.scale_split}", "evaluation.every_s=null",
                 "evaluation.consensus_every_s=null"]
        if a.device == "cuda":
            torch.cuda.empty_cache()
            torch.cuda.reset_peak_memory_stats()
        t0 = time.perf_counter()
        try:
            sim = build_simulation(load_scenario(scenario, sets))
        except InputError as exc:  # a team the scene cannot hold: said, and the next size runs
            rows.append({"robots": k, "error": " ".join(str(exc).split())[:400]})
            _partial(a, rows)
            continue
        t1 = time.perf_counter()
        with GpuSampler() as gpu:
            sim.env.run(until=duration)
            sim.engine.drain()
            if a.device == "cuda":
                torch.cuda.synchronize()
            t2 = time.perf_counter()
        row: dict[str, Any] = {"robots": k, "build_s": t1 - t0, "loop_s": t2 - t1, "rtf": duration / (t2 - t1),
                               "wall_per_robot_s": (t2 - t1) / (k * duration), **gpu.summary()}
        if a.device == "cuda":
            row["device_mem_per_robot_mib"] = torch.cuda.max_memory_allocated() / 2**20 / k
        sim.engine.close()
        sim.world.close()
        del sim
        rows.append(row)
        log.info("scale %d robots: %s", k, row)
        _partial(a, rows)
    done = [r for r in rows if "error" not in r]
    for r in done:
        r["cost_vs_first"] = r["wall_per_robot_s"] / done[0]["wall_per_robot_s"]
    return {"rows": rows, "duration_s": duration, "split": a.scale_split}


def stage_profile(a: argparse.Namespace) -> dict[str, Any]:
    """Where the wall time of the house run goes on this device, by stage (map gradient, map step,
    frames, consensus, payloads, rendering, evaluation, the rest): benchmarks/bench_long_run.py
    on a 30-s run (inline rounds: its timers keep one stack on the event loop's thread)."""
    scenario, sets = _run_overrides(a, a.device)
    sets = [s for s in sets if not s.startswith("duration=")] + [f"duration={1 if a.tiny else 30}"]
    cmd = [sys.executable, str(ROOT / "benchmarks" / "bench_long_run.py"), str(scenario), "--window",
           "1" if a.tiny else "10"]
    for x in sets:
        cmd += ["--set", x]
    env = dict(os.environ)
    env.pop(BATCH_ENV, None)
    proc = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True, timeout=a.stage_timeout)
    if proc.returncode != 0:
        raise RuntimeError(f"bench_long_run exited {proc.returncode}: {proc.stderr[-1500:]}")
    return {"text": proc.stdout}


STAGES = {"machine": stage_machine, "tests": stage_tests, "run_cpu": stage_run_cpu,
          "run_batch": stage_run_batch, "run_inline": stage_run_inline, "batch": stage_batch,
          "scale": stage_scale, "profile": stage_profile}
LIMITS_S = {"machine": 30, "tests": 150, "run_cpu": 400, "run_batch": 120, "run_inline": 110, "batch": 70,
            "scale": 150, "profile": 120}
"""Each stage's own time limit on the GPU machine (s); the budget cuts the later ones first."""
ORDER = ["machine", "tests", "run_batch", "batch", "scale", "run_inline", "profile"]
"""Foreground stages in order of what the issue needs most; ``run_cpu`` runs beside them."""


# --------------------------------------------------------------------------------------------
# the parent: stages as children, the report

def _child(a: argparse.Namespace, stage: str, limit: float) -> subprocess.Popen:
    cmd = [sys.executable, str(Path(__file__).resolve()), a.out, "--stage", stage, "--device", a.device,
           "--stage-timeout", str(int(limit)), "--work", a.work, "--scale-split", a.scale_split,
           "--scale-sizes", ",".join(map(str, a.scale_sizes)), "--batch-sizes", ",".join(map(str, a.batch_sizes)),
           "--batch-presets", ",".join(a.batch_presets)] + (["--tiny"] if a.tiny else [])
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in (os.environ.get("PYTHONPATH"), str(ROOT)) if p))
    if stage == "run_cpu":
        env.update(OMP_NUM_THREADS="8" if not a.tiny else "1")
    log_file = open(_stages(a) / f"{stage}.log", "w")
    return subprocess.Popen(cmd, cwd=ROOT, env=env, stdout=log_file, stderr=subprocess.STDOUT)


def _collect(a: argparse.Namespace, stage: str, proc: subprocess.Popen, limit: float, t0: float) -> dict[str, Any]:
    try:
        proc.wait(timeout=max(1.0, limit))
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
        res: dict[str, Any] = {"error": f"stopped at its limit of {limit:.0f} s"}
        part = _stages(a) / f"partial_{stage}.json"
        if part.exists():
            res["rows"] = json.loads(part.read_text())
        res["stage_wall_s"] = time.perf_counter() - t0
        return res
    path = _stages(a) / f"{stage}.json"
    if proc.returncode != 0 or not path.exists():
        tail = (_stages(a) / f"{stage}.log").read_text()[-1500:]
        return {"error": f"exit {proc.returncode}", "log_tail": tail, "stage_wall_s": time.perf_counter() - t0}
    res = json.loads(path.read_text())
    # the stage's own wall (child start to collection) beside, never over, a run's own wall_s
    res["stage_wall_s"] = time.perf_counter() - t0
    return res


def orchestrate(a: argparse.Namespace) -> int:
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    for name in ("stages", "run_batch", "run_inline", "run_cpu"):  # a second call starts clean
        shutil.rmtree(Path(a.work) / name, ignore_errors=True)
    start = time.perf_counter()
    deadline = start + a.budget_s
    results: dict[str, Any] = {"commit": a.commit, "device": a.device, "tiny": a.tiny, "budget_s": a.budget_s}
    t_cpu = time.perf_counter()
    cpu_limit = min(LIMITS_S["run_cpu"], a.budget_s - 10)
    cpu_proc = _child(a, "run_cpu", cpu_limit) if "run_cpu" in a.stages else None
    for stage in (s for s in ORDER if s in a.stages):
        left = deadline - time.perf_counter() - 15
        if left < 20:
            results[stage] = {"error": "not run: the budget was spent"}
            continue
        limit = min(LIMITS_S[stage], left)
        t0 = time.perf_counter()
        results[stage] = _collect(a, stage, _child(a, stage, limit), limit, t0)
        log.info("%s: %.0f s%s", stage, results[stage]["stage_wall_s"],
                 f" ({results[stage]['error']})" if "error" in results[stage] else "")
        _write(a, results)
    if cpu_proc is not None:
        results["run_cpu"] = _collect(a, "run_cpu", cpu_proc, max(1.0, min(cpu_limit - (time.perf_counter() - t_cpu),
                                                                          deadline - time.perf_counter())), t_cpu)
    results["total_wall_s"] = time.perf_counter() - start
    _write(a, results)
    print((out / "device_check.md").read_text())
    return 0


def _f(x: Any, fmt: str = ".2f") -> str:
    return "—" if x is None else format(x, fmt)


def report(r: dict[str, Any]) -> str:
    """The figures as Markdown, with issue 70's goals beside them."""
    m = r.get("machine", {})
    lines = ["# Device check (issue 70)", "",
             f"commit {r.get('commit') or 'unknown'}; device {r.get('device')}{' (tiny rehearsal)' if r.get('tiny') else ''}; "
             f"{m.get('nvidia_smi', '')}; {m.get('line', '')}; torch CUDA {m.get('torch_cuda')}", ""]
    for stage in ("machine", "tests", "run_batch", "run_inline", "run_cpu", "batch", "scale", "profile"):
        if "error" in r.get(stage, {}):
            lines.append(f"- **{stage}: {r[stage]['error']}**")
    t = r.get("tests", {})
    if "summary" in t:
        lines += [f"- CUDA tests: {t['summary']} (exit {t['returncode']})"]
    lines += ["", "## The 3-robot house run", "",
              "| run | status | run's wall s | sim s / wall s | GPU busy | peak device GiB | team completion % | robots' completion % |",
              "|---|---|---|---|---|---|---|---|"]
    for stage in ("run_batch", "run_inline", "run_cpu"):
        x = r.get(stage, {})
        if "status" not in x:
            continue
        busy = x.get("gpu_busy_share")
        lines.append(f"| {stage} | {x['status']} | {x['wall_s']:.1f} | {x['rtf']:.2f} | "
                     f"{'—' if busy is None else f'{busy:.0%}'} | {_f(x.get('peak_device_mem_gib'))} | "
                     f"{_f(x.get('team_completion_pct'))} | "
                     f"{', '.join(_f(v) for v in x['completion_pct'].values())} |")
    ref = r.get("run_cpu", {}).get("completion_pct")
    for stage in ("run_batch", "run_inline"):
        x = r.get(stage, {})
        if ref and "completion_pct" in x:
            d = [x["completion_pct"][k] - ref[k] for k in ref if x["completion_pct"].get(k) is not None
                 and ref[k] is not None]
            if d:
                lines.append(f"\n{stage} against the CPU run: robots {', '.join(f'{v:+.2f}' for v in d)} points "
                             f"(bound: 0.25 per robot, 0.10 for the team; team {sum(d) / len(d):+.2f})")
    for stage in ("run_batch", "run_inline", "run_cpu"):
        ev = (r.get(stage) or {}).get("eval_stage_s") or []
        if ev:
            stages = sorted({s for e in ev for s in e["stage_s"]})
            lines += ["", f"Evaluation stages of {stage} (s, summed over the maps):", "",
                      "| t | wall | " + " | ".join(stages) + " |", "|---" * (len(stages) + 2) + "|"]
            for e in ev:
                lines.append(f"| {e['t']:g}{' final' if e.get('final') else ''} | {_f(e.get('wall_s'))} | "
                             + " | ".join(_f(e["stage_s"].get(s)) for s in stages) + " |")
    b = r.get("batch", {}).get("rows") or []
    if b:
        lines += ["", "## One round of the team's maps: batched against separate", "",
                  "| preset | robots | rays x samples | steps | separate s | batched s | ratio | M samples/s (batched) |",
                  "|---|---|---|---|---|---|---|---|"]
        for x in b:
            lines.append(f"| {x['preset']} | {x['robots']} | {x['n_rays']} x {x['samples_per_ray']} | {x['steps']} | "
                         f"{x['separate_s']:.3f} | {x['batched_s']:.3f} | {x['ratio']:.2f} | "
                         f"{x['batched_samples_per_s'] / 1e6:.1f} |")
    s = r.get("scale", {}).get("rows") or []
    if s:
        lines += ["", "## Robots on a ring of the house, the simulation alone (team batch on)", "",
                  "| robots | build s | loop s | sim s / wall s | wall per robot-s | vs first | GPU busy | device MiB per robot |",
                  "|---|---|---|---|---|---|---|---|"]
        for x in s:
            if "error" in x:
                lines.append(f"| {x['robots']} | refused: {x['error']} |||||||")
                continue
            busy = x.get("gpu_busy_share")
            lines.append(f"| {x['robots']} | {x['build_s']:.1f} | {x['loop_s']:.1f} | {x['rtf']:.2f} | "
                         f"{x['wall_per_robot_s']:.3f} | {_f(x.get('cost_vs_first'))} | "
                         f"{'—' if busy is None else f'{busy:.0%}'} | {_f(x.get('device_mem_per_robot_mib'), '.1f')} |")
    if r.get("profile", {}).get("text"):
        lines += ["", "## Where the house run's wall time goes (benchmarks/bench_long_run.py, inline rounds)", "",
                  "```", r["profile"]["text"].strip(), "```"]
    lines += ["", "## Goals (issue 70; readings, not tests)", ""] + goals(r)
    return "\n".join(lines) + "\n"


def goals(r: dict[str, Any]) -> list[str]:
    """Each goal with the figure that answers it, or why there is none."""
    out = []
    rb = r.get("run_batch", {})
    best = max((r.get(s, {}).get("rtf") or 0.0 for s in ("run_batch", "run_inline")), default=0.0)
    out.append(f"- 3-robot house run >= {GOALS['run_rtf']:g}x real time: {best:.2f}x (best of batch on/off)")
    busy = rb.get("gpu_busy_share")
    out.append(f"- GPU >= {GOALS['gpu_busy']:.0%} busy: {'—' if busy is None else f'{busy:.0%}'} (batch on)")
    rows = {x["robots"]: x for x in r.get("scale", {}).get("rows") or [] if "error" not in x}
    if 3 in rows and 24 in rows:
        out.append(f"- 24 robots <= {GOALS['cost_24_vs_3']}x the cost per robot-second of 3: "
                   f"{rows[24]['wall_per_robot_s'] / rows[3]['wall_per_robot_s']:.2f}x")
    if 100 in rows:
        out.append(f"- 100 robots on a ring >= {GOALS['rtf_100']:g}x real time: {rows[100]['rtf']:.2f}x")
    paper = [x for x in r.get("batch", {}).get("rows") or [] if x["preset"] == "paper"]
    if paper:
        top = max(paper, key=lambda x: x["batched_samples_per_s"])
        out.append(f"- paper preset >= {GOALS['paper_msamples']:g} M samples/s for the team: "
                   f"{top['batched_samples_per_s'] / 1e6:.1f} M ({top['robots']} robots)")
    return out


def _stages(a: argparse.Namespace) -> Path:
    """The stages' own files (logs, results, partial rows): beside the runs, not in OUT, which
    holds four files (device_check.json and .md, tests.log, stages.log)."""
    path = Path(a.work) / "stages"
    path.mkdir(parents=True, exist_ok=True)
    return path


def _write(a: argparse.Namespace, results: dict[str, Any]) -> None:
    """The report so far, and every stage's log in one file, into OUT."""
    out = Path(a.out)
    (out / "device_check.json").write_text(json.dumps(results, indent=1, default=str))
    (out / "device_check.md").write_text(report(results))
    logs = [f"===== {f.stem}\n{f.read_text(errors='replace')[-20000:]}" for f in sorted(_stages(a).glob("*.log"))]
    (out / "stages.log").write_text("\n".join(logs))


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("out", help="folder for device_check.json / .md and each stage's log")
    p.add_argument("--device", default="cuda", choices=("cuda", "cpu"))
    p.add_argument("--tiny", action="store_true", help="every stage shrunk: the CPU rehearsal of the script")
    p.add_argument("--budget-s", type=float, default=480.0, help="wall seconds for all stages (default 480)")
    p.add_argument("--commit", default=os.environ.get("RAMENSIM_COMMIT"), help="the commit measured, for the record")
    p.add_argument("--stages", default=",".join(ORDER + ["run_cpu"]),
                   help="the stages to run, comma-separated (default: all; a second call runs what the first lacked)")
    p.add_argument("--scale-sizes", default="3,24,100", help="team sizes of the scale stage")
    p.add_argument("--scale-split", default="chunks", choices=("chunks", "regions", "none"),
                   help="world.trajectory.split of the scale stage (chunks: one tour cut per robot)")
    p.add_argument("--batch-sizes", default="3,24,100", help="team sizes of the batch stage")
    p.add_argument("--batch-presets", default="cpu,paper", help="map presets of the batch stage")
    p.add_argument("--stage", choices=sorted(STAGES), help=argparse.SUPPRESS)
    p.add_argument("--stage-timeout", type=float, default=300.0, help=argparse.SUPPRESS)
    p.add_argument("--work", default=None, help="folder for the runs and the stages' files (default: a temporary one)")
    a = p.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    a.work = a.work or str(Path(tempfile.gettempdir()) / "device_check_runs")
    a.stages = [s for s in a.stages.split(",") if s]
    unknown = sorted(set(a.stages) - set(STAGES))
    if unknown:
        p.error(f"--stages: unknown stage(s) {', '.join(unknown)}; expected some of {', '.join(sorted(STAGES))}")
    a.scale_sizes = [int(x) for x in a.scale_sizes.split(",") if x]
    a.batch_sizes = [int(x) for x in a.batch_sizes.split(",") if x]
    a.batch_presets = [x for x in a.batch_presets.split(",") if x]
    if a.stage is None:
        return orchestrate(a)
    Path(a.work).mkdir(parents=True, exist_ok=True)
    res = STAGES[a.stage](a)
    (_stages(a) / f"{a.stage}.json").write_text(json.dumps(res, indent=1, default=str))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
