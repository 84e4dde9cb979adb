"""``recording.mode: off`` never imports rerun (issue 14): neither building the recorder nor
a whole (tiny) run loads it. Checked in fresh interpreters, since the test session itself
may have imported rerun already."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]


def _python(code: str) -> str:
    res = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True,
                         timeout=600)
    assert res.returncode == 0, res.stderr[-2000:]
    return res.stdout.strip().splitlines()[-1]


def test_recorder_off_does_not_import_rerun():
    out = _python("import sys\n"
                  "import ramensim.lifecycle\n"
                  "from ramensim.recording import RecordingConfig, make_recorder\n"
                  "r = make_recorder(RecordingConfig(mode='off'), None, 1, None, None, None, None)\n"
                  "print(r is None, 'rerun' in sys.modules)")
    assert out == "True False"


@pytest.mark.slow
def test_run_with_recording_off_does_not_import_rerun():
    out = _python("import sys, tempfile\n"
                  "from ramensim.config import load_scenario\n"
                  "from ramensim.lifecycle import run_scenario\n"
                  "sc = load_scenario('scenarios/office_3agents.yaml', ['recording.mode=off', "
                  "'duration=1', 'agents.count=1', 'method=local'])\n"
                  "with tempfile.TemporaryDirectory() as t:\n"
                  "    r = run_scenario(sc, t + '/run')\n"
                  "print(r.status, 'rerun' in sys.modules)")
    assert out == "ok False"
