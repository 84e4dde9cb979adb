"""A real run on a shared medium (issue 66): metrics.json's communication.medium, busy <= 1,
no more delivered than on private links, and the same messages' coins on both."""
from __future__ import annotations

import csv
import json
from pathlib import Path

import pytest

from ramensim.config import load_scenario
from ramensim.lifecycle import run_scenario

from tiny_runs import SCENARIO, TINY

SMALL = TINY + ["agents.count=3", "duration=4", "evaluation.every_s=null", "channel.success_rate=0.5",
                "channel.bandwidth_bps=1.0e9"]


def _run(tmp_path: Path, name: str, *extra: str) -> tuple[dict, list[dict]]:
    sc = load_scenario(SCENARIO, SMALL + list(extra))
    sc = sc[0] if isinstance(sc, tuple) else sc
    run_scenario(sc, tmp_path / name)
    metrics = json.loads((tmp_path / name / "metrics.json").read_text())
    with open(tmp_path / name / "messages.csv", newline="") as f:
        return metrics, list(csv.DictReader(f))


@pytest.mark.timeout(600)
def test_a_run_on_a_shared_medium_reports_its_air(tmp_path):
    links, links_msgs = _run(tmp_path, "links")
    dcf, dcf_msgs = _run(tmp_path, "dcf", "channel.medium.kind=shared", "channel.medium.access=dcf")
    assert "medium" not in links["communication"]
    med = dcf["communication"]["medium"]
    assert med["kind"] == "shared" and med["access"] == "dcf"
    assert [d["radios"] for d in med["domains"]] == [[0, 1, 2]]
    assert 0.0 < med["domains"][0]["busy_fraction"] <= 1.0
    assert dcf["communication"]["delivered"] <= links["communication"]["delivered"]
    assert dcf["status"] == "ok" and all(not a["diverged"] for a in dcf["per_agent"].values())
    # the same loss coin per message on both channels: what links lost to 'loss', dcf lost too
    lost = {(m["src"], m["dst"], m["t_sent"]) for m in links_msgs if m["reason"] == "loss"}
    sent_both = lost & {(m["src"], m["dst"], m["t_sent"]) for m in dcf_msgs}
    assert sent_both
    for m in dcf_msgs:
        if (m["src"], m["dst"], m["t_sent"]) in sent_both and m["status"] == "dropped":
            assert m["reason"] in ("loss", "retry_limit", "queue_overflow")
