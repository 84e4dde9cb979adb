"""A hostile user's trial of the scenario input (issue 15), as a script, not a test:

    .venv/bin/python tests/cli/robust_trial.py validate [--out DIR]   # every variant through 'ramensim validate'
    .venv/bin/python tests/cli/robust_trial.py run [--out DIR]        # the accepted ones through a 2 s run

Variants: every leaf key of the schema (the default scenario's, plus those of the other
scene, trajectory, latency, window, topology and radio variants) set to each of a list of bad
or extreme values, plus section-level type errors and hostile YAML texts. Each variant is
written as a file under DIR and given to the CLI in this process (``ramensim.cli.main``); the
outcome is counted as

- ``clean``: exit 2 with one ``error: ...`` paragraph on stderr;
- ``accepted``: exit 0 (the value is legal) - in ``run`` mode: exit 0 or 1 with a
  ``metrics.json`` whose status is one of ok / interrupted / failed / diverged;
- ``traceback``: an exception left ``main`` or a traceback was printed;
- ``slow``: more than 20 s (validate) or 300 s (run).

The ``run`` stage replays the variants that ``validate`` accepted, on a tiny version of
``scenarios/office_3agents.yaml`` (2 agents, 40x30 images, 2 simulated seconds). A summary
line and ``DIR/<stage>.jsonl`` (one line per variant) are written.
"""
from __future__ import annotations

import argparse
import contextlib
import io
import json
import math
import signal
import time
import traceback
from pathlib import Path
from typing import Any, Iterator

import yaml

ROOT = Path(__file__).resolve().parents[2]
BASE = ROOT / "scenarios" / "office_3agents.yaml"
TINY = {
    "agents.count": 2, "world.camera.width": 40, "world.camera.height": 30, "world.camera.fx": 30,
    "world.camera.fy": 30, "world.camera.cx": 19.5, "world.camera.cy": 14.5, "evaluation.voxel_m": 0.1,
    "evaluation.n_samples": 5000, "evaluation.cull": "frustum", "map.n_rays": 128,
    "consensus.primal_steps": 3, "recording.mode": "off", "duration": 2,
}
BAD: list[Any] = [math.nan, math.inf, -math.inf, -1, 0, 1e12, -1e12, 1e300, 10 ** 30, "abc", "", [], {}, None,
                  True, "x" * 5000, "../../nowhere/file", [1, 2, 3]]
VARIANTS = {  # sections switched to another kind, so that their own keys get tried too
    "world.scene": [{"kind": "mesh", "path": "scene.ply"}, {"kind": "replica", "path": "data/x"}],
    "world.trajectory": [{"kind": "file", "path": "traj.txt"}],
    "channel.latency": [{"kind": "uniform", "low_s": 0.0, "high_s": 0.01}, {"kind": "lognormal", "mean_s": 0.01}],
    "channel.windows": [{"kind": "periodic"}, {"kind": "schedule", "schedule": {"0-1": [[0, 1]]}}],
    "channel.burst": [{"kind": "gilbert_elliott"}],
    "channel.path_loss": [{"enabled": True}],
    "channel.trace": [{"path": "traces/two_robots_wifi.csv"}],
    "topology": [{"kind": "explicit", "edges": [[0, 1]]}, {"kind": "grid", "grid_shape": [1, 3]},
                 {"kind": "disk", "disk_radius_m": 3.0}],
    "radio": [{"mode": "periodic"}],
    "channel": [{"mode": "packet", "reassembly": "retransmit"}],
}


def _leaves(x: Any, path: str = "") -> Iterator[tuple[str, Any]]:
    if isinstance(x, dict) and x:
        for k, v in x.items():
            yield from _leaves(v, f"{path}.{k}" if path else str(k))
    else:
        yield path, x


def _set(doc: dict, key: str, value: Any) -> dict:
    node = doc
    parts = key.split(".")
    for p in parts[:-1]:
        if not isinstance(node.get(p), dict):
            node[p] = {}
        node = node[p]
    node[parts[-1]] = value
    return doc


def _base() -> dict:
    return yaml.safe_load(BASE.read_text())


def variants() -> Iterator[tuple[str, str]]:
    """(label, YAML text) of every variant."""
    from ramensim.schema import Scenario

    defaults = Scenario().model_dump(mode="json")
    sections: list[tuple[str, dict]] = [("", {})]
    for key, alts in VARIANTS.items():
        for i, alt in enumerate(alts):
            sections.append((f"{key}#{i}", {key: alt}))
    seen: set[str] = set()
    for tag, patch in sections:
        full = json.loads(json.dumps(defaults))
        for k, v in patch.items():
            node = full
            for p in k.split(".")[:-1]:
                node = node[p]
            node[k.split(".")[-1]] = {**(node[k.split(".")[-1]] if isinstance(node[k.split(".")[-1]], dict)
                                         else {}), **v}
        keys = [k for k, _ in _leaves(full)]
        if tag:  # only the keys of the switched section
            keys = [k for k in keys if k.startswith(tag.split("#")[0] + ".") or k == tag.split("#")[0]]
        for key in keys:
            if key in seen:
                continue
            seen.add(key)
            for j, bad in enumerate(BAD):
                doc = _base()
                for k, v in patch.items():
                    _set(doc, k, json.loads(json.dumps(v)))
                _set(doc, key, bad)
                yield f"{tag or 'base'}:{key}={_short(bad)}", yaml.safe_dump(doc, width=1 << 20)
    for section in ("world", "agents", "map", "consensus", "channel", "topology", "radio", "evaluation",
                    "recording", "output"):
        for bad in (5, "x", [1], None):
            yield f"section:{section}={bad!r}", yaml.safe_dump(_set(_base(), section, bad))
    from test_cli_robust_input import HOSTILE  # type: ignore[import-not-found]  # beside this script
    for name, text in HOSTILE.items():
        yield f"hostile:{name}", text


def _short(v: Any) -> str:
    r = repr(v)
    return r if len(r) <= 24 else r[:21] + "..."


class _Timeout(Exception):
    pass


def _alarm(signum, frame):  # noqa: ARG001
    raise _Timeout()


def _cli(argv: list[str], limit: int) -> tuple[str, int | None, str, float]:
    from ramensim.cli import main

    err = io.StringIO()
    t0 = time.perf_counter()
    signal.signal(signal.SIGALRM, _alarm)
    signal.alarm(limit)
    try:
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            rc = main(argv)
    except _Timeout:
        return "slow", None, err.getvalue(), time.perf_counter() - t0
    except BaseException:  # noqa: BLE001 - this is what the trial counts
        return "traceback", None, err.getvalue() + traceback.format_exc(), time.perf_counter() - t0
    finally:
        signal.alarm(0)
    dt = time.perf_counter() - t0
    text = err.getvalue()
    if "Traceback" in text:
        return "traceback", rc, text, dt
    return ("clean" if rc == 2 and text.lstrip().startswith("error: ") else
            "accepted" if rc in (0, 1) else "unclear"), rc, text, dt


def stage_validate(out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    counts: dict[str, int] = {}
    with open(out / "validate.jsonl", "w") as log:
        for i, (label, text) in enumerate(variants()):
            f = out / "files" / f"v{i:05d}.yaml"
            f.parent.mkdir(exist_ok=True)
            f.write_text(text, encoding="utf-8")
            kind, rc, err, dt = _cli(["-q", "validate", str(f)], 20)
            counts[kind] = counts.get(kind, 0) + 1
            log.write(json.dumps({"i": i, "label": label, "file": str(f), "outcome": kind, "rc": rc,
                                  "seconds": round(dt, 3), "stderr": err[-3000:]}) + "\n")
    print("validate:", sum(counts.values()), "variants;", ", ".join(f"{k} {v}" for k, v in sorted(counts.items())))


def stage_run(out: Path) -> None:
    rows = [json.loads(line) for line in open(out / "validate.jsonl")]
    accepted = [r for r in rows if r["outcome"] == "accepted"]
    counts: dict[str, int] = {}
    statuses: dict[str, int] = {}
    with open(out / "run.jsonl", "w") as log:
        for r in accepted:
            doc = yaml.safe_load(open(r["file"]))
            for k, v in TINY.items():
                _set(doc, k, v)
            # the variant's own value wins over the tiny settings
            key, _, _ = r["label"].split(":", 1)[1].partition("=")
            orig = yaml.safe_load(open(r["file"]))
            node: Any = orig
            for p in key.split("."):
                node = node.get(p) if isinstance(node, dict) else None
            if key:
                _set(doc, key, node)
            f = Path(r["file"]).with_suffix(".run.yaml")
            f.write_text(yaml.safe_dump(doc, width=1 << 20), encoding="utf-8")
            folder = out / "runs" / f"v{r['i']:05d}"
            kind, rc, err, dt = _cli(["-q", "run", str(f), "--out", str(folder), "--overwrite"], 300)
            status = None
            if kind == "accepted":
                try:
                    status = json.loads((folder / "metrics.json").read_text())["status"]
                except (OSError, ValueError, KeyError):
                    kind = "no metrics.json"
                if status not in ("ok", "interrupted", "failed", "diverged"):
                    kind = f"bad status {status}"
                statuses[str(status)] = statuses.get(str(status), 0) + 1
            counts[kind] = counts.get(kind, 0) + 1
            log.write(json.dumps({"i": r["i"], "label": r["label"], "outcome": kind, "rc": rc, "status": status,
                                  "seconds": round(dt, 1), "stderr": err[-3000:]}) + "\n")
            log.flush()
            print(r["label"], kind, rc, status, f"{dt:.1f}s", flush=True)
    print("run:", len(accepted), "accepted variants;", ", ".join(f"{k} {v}" for k, v in sorted(counts.items())),
          "; statuses:", statuses)


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("stage", choices=["validate", "run"])
    ap.add_argument("--out", default="/tmp/robust_trial")
    a = ap.parse_args()
    import logging
    logging.disable(logging.WARNING)
    (stage_validate if a.stage == "validate" else stage_run)(Path(a.out))
