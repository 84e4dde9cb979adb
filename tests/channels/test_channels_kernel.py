"""The channel drives SimPy through its public API only, and its times stay exact.

SimPy's public API schedules relative delays (``env.timeout(delay)`` fires at ``now + delay``)
and ``now + (t - now)`` is not always ``t``: sent at 0.13 s, a message due at 1.7 s would fire
at 1.6999999999999997 s. ``Channel._at`` hops in that case (docs/KERNEL.md); these tests pin
exact times and first-in-first-out order where the naive delay would miss, and check that no
code in ramensim.channels or ramensim.agents touches SimPy's private attributes.
"""
from __future__ import annotations

import ast
from pathlib import Path

import ramensim.agents
import ramensim.channels
from ramensim.core.events import MessageDropped

SIMPY_PRIVATE = {"_queue", "_eid", "_now", "_ok", "_value", "_defused", "_active_proc", "_delay", "_target",
                 "_generator"}
"""Private attributes of simpy.Environment and simpy.Event."""

NOW, T = 0.13, 1.7
"""A send time and a due time with NOW + (T - NOW) != T."""


def _env_like(node: ast.expr) -> bool:
    """``env`` or ``<anything>.env`` (e.g. ``self.env``)."""
    return (isinstance(node, ast.Name) and node.id == "env") or (isinstance(node, ast.Attribute) and node.attr == "env")


def _private_uses(path: Path) -> list[str]:
    """``file:line attr`` of every SimPy-private attribute access (any ``env._x``, or a name in SIMPY_PRIVATE)."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    return [
        f"{path}:{node.lineno} {node.attr}"
        for node in ast.walk(tree)
        if isinstance(node, ast.Attribute) and node.attr.startswith("_") and not node.attr.startswith("__")
        and (node.attr in SIMPY_PRIVATE or _env_like(node.value))
    ]


def test_channels_and_agents_use_no_simpy_internals() -> None:
    files = [f for pkg in (ramensim.channels, ramensim.agents) for root in pkg.__path__
             for f in sorted(Path(root).rglob("*.py"))]
    assert any(f.name == "channel.py" for f in files) and any(f.name == "process.py" for f in files)
    uses = [u for f in files for u in _private_uses(f)]
    assert not uses, "SimPy internals used (use env.now, env.timeout, env.schedule, event.value):\n" + "\n".join(uses)


def test_the_private_attribute_check_finds_what_it_should(tmp_path: Path) -> None:
    bad = tmp_path / "bad.py"
    bad.write_text("def f(self, env, ev):\n    a = env._now\n    b = self.env._queue\n    return ev._value, self._eid\n")
    assert [u.split()[-1] for u in _private_uses(bad)] == ["_now", "_queue", "_value", "_eid"]


def test_a_queued_message_arrives_exactly_when_due(make) -> None:
    """B, sent at 0.13 s, waits behind A (1 s on the air) and takes 0.7 s: due at 1.7 s exactly."""
    assert NOW + (T - NOW) != T
    env, ch, inbox = make(n=2, bandwidth_bps=8e6, header_bytes=0, latency={"kind": "constant", "mean_s": 0.0})
    out = []

    def sender():
        out.append(ch.send(0, 1, "A", 1_000_000, env.now))
        yield env.timeout(NOW)
        out.append(ch.send(0, 1, "B", 700_000, env.now))

    env.process(sender())
    env.run()
    a, b = out
    assert (b.t_sent, b.t_start) == (NOW, 1.0)
    assert inbox[1] == [(1.0, a), (T, b)] and b.t_done == T and b.status == "delivered"


def test_transfers_aborted_at_a_window_closing_drop_at_the_closing_in_send_order(make) -> None:
    """Every link's window closes at 1.7 s; 4 MB transfers (4 s on the air) sent at 0, 0.13
    (three links at the same instant) and 1 s are all aborted then: dropped at 1.7 s exactly,
    while the window is closed (not an ulp before, while it is open), first sent first."""
    dropped: list[MessageDropped] = []
    env, ch, inbox = make(n=4, windows={"kind": "schedule", "schedule": {"*": [(0.0, T)]}},
                          bandwidth_bps=8e6, header_bytes=0,
                          emit=lambda e: dropped.append(e) if isinstance(e, MessageDropped) else None)
    sent = []

    def sender():
        sent.append(ch.send(1, 2, None, 4_000_000, env.now))
        yield env.timeout(NOW)
        sent.extend(ch.send(0, j, None, 4_000_000, env.now) for j in (3, 1, 2))
        yield env.timeout(1.0 - env.now)
        sent.append(ch.send(2, 3, None, 4_000_000, env.now))

    env.process(sender())
    env.run()
    assert [m.t_sent for m in sent] == [0.0, NOW, NOW, NOW, 1.0]
    assert all(m.reason == "window_closed" and m.t_done == T for m in sent)
    assert not ch.window_open(0, 1, T) and ch.window_open(0, 1, NOW + (T - NOW))
    assert [(e.t, e.msg_id) for e in dropped] == [(T, m.id) for m in sent]
    assert inbox == [[], [], [], []]
    assert ch.log.records()["t_done"].tolist() == [T] * 5
