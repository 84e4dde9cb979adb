"""What the cause studies on a finished run share (``ramensim paper rescore``, ``artifacts``,
``far-part``, ``plateau``, ``copy-age``, ``tracker-drift``): a finished run folder rebuilt into its
scenario, result and world (as ``ramensim eval --run`` rebuilds it), and a study's outputs written."""
from __future__ import annotations

import json
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any


@dataclass
class Run:
    """A finished run folder: its scenario, metrics.json, world (poses rebuilt from the seed)
    and whether the method merges every robot's frames."""
    scenario: Any
    result: Any
    world: Any
    merged: bool

    def evaluator(self) -> Any:
        """A fresh Evaluator of the run's world (each keeps its own ground-truth culling)."""
        from ramensim.scoring import Evaluator
        return Evaluator.for_scenario(self.scenario, self.world)

    def fed_by(self, k: int) -> list[int]:
        """The robots (indices) whose frames map ``k`` learns from."""
        return list(range(self.scenario.agents.count)) if self.merged else [k]


def load_run(folder: Path) -> Run:
    """The run in ``folder`` (its scenario.yaml and metrics.json) with its world rebuilt from the
    scenario's seed, poses and scene as the run had them."""
    from ramensim.agents.consensus import get_method
    from ramensim.config import load_scenario
    from ramensim.core.results import RunResult
    from ramensim.sim import scenario_world

    sc = load_scenario(folder / "scenario.yaml")
    world = scenario_world(sc, folder)  # as the run composed it
    return Run(sc, RunResult.read(folder / "metrics.json"), world, get_method(sc.method).merges_frames)


def write_outputs(out: Path | None, stem: str, res: dict[str, Any], text: str) -> None:
    """``<stem>.json`` (``res``) and ``<stem>.md`` (``text``) into ``out`` (if given); the text to
    stdout, the study's own output."""
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        (out / f"{stem}.json").write_text(json.dumps(res, indent=1, default=float))
        (out / f"{stem}.md").write_text(text)
    sys.stdout.write(text + "\n")
