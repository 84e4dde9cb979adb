"""CopyStore keeps the newest copy and applies the stale policies."""
from __future__ import annotations

import pytest
import torch

from ramensim.agents.copies import CopyStore, NeighbourCopy


def _c(j, stamp, recv):
    return NeighbourCopy(j, {"theta": torch.full((3,), float(stamp))}, stamp, recv)


def test_keeps_only_newer_stamp():
    s = CopyStore(0, [1, 2])
    assert s.put(_c(1, 5.0, 6.0))
    assert not s.put(_c(1, 4.0, 7.0))  # older state arriving late: ignored
    assert not s.put(_c(1, 5.0, 8.0))  # same stamp: ignored
    assert s.get(1).stamp == 5.0
    assert s.put(_c(1, 6.0, 8.0))
    assert s.get(1).stamp == 6.0 and s.get(1).age(10.0) == 4.0


def test_latest_uses_every_copy_held():
    s = CopyStore(0, [1, 2, 3])
    s.put(_c(1, 1.0, 1.5))
    s.put(_c(2, 9.0, 9.5))
    sel = s.select(10.0, "latest")
    assert [c.agent for c in sel.copies] == [1, 2]
    assert sel.copy_ages() == {1: 9.0, 2: 1.0, 3: None}
    assert sel.record[3].reason == "never_received"
    # stale copies stay usable round after round
    assert [c.agent for c in s.select(20.0, "latest").copies] == [1, 2]


def test_max_age_drops_old_copies():
    s = CopyStore(0, [1, 2])
    s.put(_c(1, 1.0, 1.5))
    s.put(_c(2, 9.0, 9.5))
    sel = s.select(10.0, "max_age", max_age_s=5.0)
    assert [c.agent for c in sel.copies] == [2]
    assert sel.record[1].reason == "too_old" and sel.record[1].age == 9.0
    assert sel.copy_ages() == {1: None, 2: 1.0}


def test_omit_lost_uses_only_copies_since_previous_round():
    s = CopyStore(0, [1, 2])
    s.put(_c(1, 1.0, 1.0))
    s.put(_c(2, 1.0, 1.0))
    assert [c.agent for c in s.select(2.0, "omit_lost").copies] == [1, 2]
    s.put(_c(2, 2.5, 2.5))  # only 2 delivered between the rounds
    sel = s.select(3.0, "omit_lost")
    assert [c.agent for c in sel.copies] == [2]
    assert sel.record[1].reason == "not_fresh"
    assert s.select(4.0, "omit_lost").copies == []  # nothing new
    s.put(_c(1, 0.5, 4.5))  # an older state arriving late is not "fresh"
    assert s.select(5.0, "omit_lost").copies == []


def test_bad_policy_and_self_neighbour():
    s = CopyStore(0, [1])
    with pytest.raises(ValueError, match="stale policy"):
        s.select(0.0, "newest")
    with pytest.raises(ValueError, match="itself"):
        CopyStore(3, [3])
