"""The CLI and the API ask libgomp for passive waiting before torch starts it, unless the user
chose a policy; a process that already imported torch is left alone."""
from __future__ import annotations

import os
import subprocess
import sys

import pytest

CODE = ("import os, sys\n{pre}from ramensim.core.native import prefer_passive_openmp\n"
        "print(prefer_passive_openmp(), os.environ.get('OMP_WAIT_POLICY'))\n")


@pytest.mark.parametrize("pre, env, want", [
    ("", {}, "True PASSIVE"),
    ("", {"OMP_WAIT_POLICY": "ACTIVE"}, "False ACTIVE"),
    ("", {"GOMP_SPINCOUNT": "1000"}, "False None"),
    ("import torch\n", {}, "False None"),
])
def test_passive_unless_chosen_or_too_late(pre, env, want):
    base = {k: v for k, v in os.environ.items() if k not in ("OMP_WAIT_POLICY", "GOMP_SPINCOUNT")}
    out = subprocess.run([sys.executable, "-c", CODE.format(pre=pre)], env={**base, **env},
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == want


def test_cli_sets_it_before_any_command_imports_torch():
    base = {k: v for k, v in os.environ.items() if k not in ("OMP_WAIT_POLICY", "GOMP_SPINCOUNT")}
    code = ("import os, sys\nfrom ramensim import cli\n"
            "cli.build_parser = lambda: (_ for _ in ()).throw(SystemExit(f\"{'torch' in sys.modules} "
            "{os.environ.get('OMP_WAIT_POLICY')}\"))\ncli.main(['--version'])\n")
    out = subprocess.run([sys.executable, "-c", code], env=base, capture_output=True, text=True, timeout=120)
    assert out.stderr.strip().splitlines()[-1] == "False PASSIVE"
