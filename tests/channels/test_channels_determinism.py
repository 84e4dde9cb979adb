"""Same seed -> byte-identical CSV log and summary; a different seed -> a different log."""
from __future__ import annotations

import csv
import json
import math

import numpy as np
import pytest
from channel_traffic import log_bytes, run_traffic


def _pos(agent: int, t: float) -> np.ndarray:
    return np.array([agent * 3.0 + 4.0 * math.sin(0.1 * t + agent), 0.0, 0.0])


def _run(make, seed: int, tmp_path, name: str, **cfg):
    env, ch, _ = make(n=4, topology="ring", seed=seed, position=_pos, **cfg)
    run_traffic(env, ch, 4, 150, traffic_seed=123)  # the same traffic for every channel seed
    return log_bytes(ch, tmp_path / f"{name}.csv"), json.dumps(ch.log.summary(), sort_keys=True)


CONFIGS = {
    "message": dict(success_rate=0.6, latency={"kind": "lognormal", "mean_s": 0.01, "std_s": 0.005},
                    range_m=9.0, bandwidth_bps=1e5),
    "packet": dict(mode="packet", packet_loss=0.02, reassembly="retransmit", mtu_bytes=500,
                   latency={"kind": "normal", "mean_s": 0.01, "std_s": 0.01}, bandwidth_bps=1e5,
                   windows={"kind": "periodic", "period_s": 5.0, "open_s": 3.0}, queue_limit=3),
}


@pytest.mark.parametrize("name", list(CONFIGS))
def test_same_seed_same_bytes(make, tmp_path, name) -> None:
    a_csv, a_sum = _run(make, 7, tmp_path, "a", **CONFIGS[name])
    b_csv, b_sum = _run(make, 7, tmp_path, "b", **CONFIGS[name])
    c_csv, c_sum = _run(make, 8, tmp_path, "c", **CONFIGS[name])
    assert a_csv == b_csv and a_sum == b_sum
    assert a_csv != c_csv and a_sum != c_sum


def test_csv_and_summary_content(make, tmp_path) -> None:
    env, ch, _ = make(n=3, topology="path", bandwidth_bps=8.0, header_bytes=0,
                      latency={"kind": "constant", "mean_s": 0.5}, success_rate=1.0)
    ch.send(0, 1, None, 2, -1.0)       # delivered at 2.5
    ch.send(0, 2, None, 2, 0.0)        # no link
    ch.send(1, 0, None, 4, 0.0)        # delivered at 4.5
    env.run()
    path = tmp_path / "log.csv"
    ch.log.write_csv(path)
    rows = list(csv.DictReader(path.open()))
    assert [r["id"] for r in rows] == ["0", "1", "2"]
    assert rows[0]["t_done"] == "2.5" and rows[0]["latency"] == "2.5" and rows[0]["age"] == "3.5"
    assert rows[1]["status"] == "dropped" and rows[1]["reason"] == "no_link" and rows[1]["latency"] == ""
    s = ch.log.summary()
    t = s["total"]
    assert (t["sent"], t["delivered"], t["dropped"]) == (3, 2, 1)
    assert t["delivered_fraction"] == pytest.approx(2 / 3)
    assert t["bytes_sent"] == 8 and t["bytes_delivered"] == 6
    assert t["latency_s"]["mean"] == 3.5 and t["latency_s"]["p50"] == 3.5
    assert set(s["links"]) == {"0->1", "0->2", "1->0"}
    assert s["links"]["0->2"]["dropped_by_reason"]["no_link"] == 1
    assert s["links"]["0->2"]["latency_s"]["mean"] is None
    assert s["links"]["1->0"]["age_s"]["p95"] == 4.5
    assert len(ch.log) == 3
