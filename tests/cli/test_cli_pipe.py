"""`ramensim schema | head`: a reader that closes the pipe early is not an input error; the
command stops quietly with 141 (128 + SIGPIPE, as a shell reports for `cat`)."""
from __future__ import annotations

import subprocess
import sys


def test_closed_stdout_stops_quietly():
    proc = subprocess.Popen([sys.executable, "-m", "ramensim", "schema"], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE)
    assert proc.stdout.read(10).startswith(b"{")
    proc.stdout.close()  # like `head -c 10`; the schema (> 64 KiB) does not fit in the pipe's buffer
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=60) == 141
    assert err == ""
