"""The radio models' link quality reaches the Rerun recording: success, bad state and walls per link."""
from __future__ import annotations

import numpy as np

from ramensim.core.events import LinkQuality
from ramensim.recording import RecordingConfig, make_recorder
from ramensim.recording.readback import RecordingReader


def test_link_quality_is_recorded(tmp_path) -> None:
    events = [
        LinkQuality(0.0, 0, 1, 1.0, "good", 0, 3.0),
        LinkQuality(0.5, 0, 1, 0.0, "bad", 2, 4.0),
        LinkQuality(0.7, 1, 0, 0.25, "iid", 1, 4.0),
        LinkQuality(0.9, 0, 1, 1.0, "good", 2, 4.1),
        LinkQuality(1.0, 1, 0, 0.5, "trace", -1, float("nan")),
    ]
    rec = make_recorder(RecordingConfig(mode="save"), tmp_path, 2)
    for ev in events:
        rec(ev)
    rec.close()
    rd = RecordingReader(tmp_path / "run.rrd")
    t, _, v = rd.scalars("/plots/comm/link_success/agent_0_to_agent_1")
    assert t.tolist() == [0.0, 0.5, 0.9] and v.tolist() == [1.0, 0.0, 1.0]
    t, _, v = rd.scalars("/plots/comm/link_bad_state/agent_0_to_agent_1")
    assert v.tolist() == [0.0, 1.0, 0.0]
    _, _, v = rd.scalars("/plots/comm/link_walls/agent_0_to_agent_1")
    assert v.tolist() == [0.0, 2.0, 2.0]
    t, _, v = rd.scalars("/plots/comm/link_success/agent_1_to_agent_0")
    assert np.allclose(v, [0.25, 0.5])
    # i.i.d. and trace links have no good/bad state; a trace link has no wall count.
    assert not any("link_bad_state/agent_1" in e for e in rd.entities())
    _, _, v = rd.scalars("/plots/comm/link_walls/agent_1_to_agent_0")
    assert v.tolist() == [1.0]
