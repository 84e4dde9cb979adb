"""A new drop reason is one member of ``ramensim.core.events.Fate`` plus its colour (issue 26):
in a fresh interpreter, core/events.py is loaded with one more member (``JAMMED``) and
recording/style.py given its colour; nothing else is edited, and the message log, its CSV,
the run's totals, ``Message``'s reason names and the recorder's colour all know the reason."""
from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import ramensim.core.events as events

SCRIPT = textwrap.dedent('''
    import importlib.util, sys
    src = open(sys.argv[1], encoding="utf-8").read()
    anchor = "    RETRY_LIMIT = 8\\n"
    assert anchor in src, "Fate.RETRY_LIMIT (the last member) moved: update this test's anchor"
    i = src.index("\\n", src.index(anchor) + len(anchor)) + 1  # after its docstring line
    src = src[:i] + "    JAMMED = 9\\n" + src[i:]  # the one place
    spec = importlib.util.spec_from_loader("ramensim.core.events", loader=None)
    mod = importlib.util.module_from_spec(spec)
    sys.modules["ramensim.core.events"] = mod
    exec(compile(src, sys.argv[1], "exec"), mod.__dict__)

    import ramensim.recording.style as style
    style._LOST["jammed"] = (10, 20, 30)  # plus its colour

    from ramensim.channels.accounting import REASON_CODES, MessageLog
    from ramensim.channels.message import REASONS
    from ramensim.core.events import DROP_REASONS, Fate, MessageDropped

    assert REASONS[-1] == DROP_REASONS[-1] == REASON_CODES[-1] == "jammed", (REASONS, REASON_CODES)
    log = MessageLog()
    # id, src, dst, nbytes, wire_bytes, t_sent, t_start, t_done, stamp, status, reason, packets, retries
    log.append((0, 0, 1, 100, 164, 1.0, 1.0, 1.5, 0.5, 1, int(Fate.JAMMED), 1, 0))
    log.append((1, 1, 0, 100, 164, 2.0, 2.0, 2.1, 1.5, 0, 0, 1, 0))
    total = log.summary()["total"]
    assert total["dropped_by_reason"]["jammed"] == 1 and total["delivered"] == 1, total
    log.write_csv(sys.argv[2])
    assert ",dropped,jammed," in open(sys.argv[2]).read()
    ev = MessageDropped(1.5, 0, 0, 1, 100, 0.5, Fate.JAMMED.reason)
    assert style.lost_color(ev.reason) == (10, 20, 30)
    print("ok")
''')


def test_a_new_drop_reason_is_one_member_plus_its_colour(tmp_path: Path) -> None:
    proc = subprocess.run([sys.executable, "-c", SCRIPT, events.__file__, str(tmp_path / "messages.csv")],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0 and proc.stdout.strip() == "ok", proc.stderr


def test_every_reason_has_its_own_colour() -> None:
    from ramensim.recording import style

    assert set(style._LOST) == set(events.DROP_REASONS)
