"""Mutations of the radio models, to check that tests/channels/test_channels_radio.py can fail.

A pytest plugin, not a test file. Each mutation plants one plausible bug; the radio tests
must fail with every one of them and pass without:

    for m in ge_swap ge_biased walls_hits wall_db_half trace_left trace_latency; do
        MUT=$m PYTHONPATH=tests/channels .venv/bin/python -m pytest -q -p no:cacheprovider \\
            -p radio_mutations tests/channels/test_channels_radio.py | tail -1
    done

- ``ge_swap``: T_G of eq. GE-3 inverted (T_B pi_B / (1 - pi_B));
- ``ge_biased``: pi_B 8 % too high;
- ``walls_hits``: every surface hit counted as a wall (twice the walls);
- ``wall_db_half``: half the configured attenuation per wall;
- ``trace_left``: a trace row looked up strictly before t instead of at or before;
- ``trace_latency``: replayed latencies off by 1e-7 relative.
"""
from __future__ import annotations

import bisect
import os

import ramensim.channels.burst as burst
import ramensim.channels.pathloss as pathloss
import ramensim.channels.quality as quality
import ramensim.channels.trace as trace

MUTATION = os.environ.get("MUT", "")

if MUTATION == "ge_swap":
    _mean_good = burst.mean_good_s

    def _swapped(success: float, good_loss: float, bad_loss: float, mean_bad_s: float) -> float:
        pi_b = burst.stationary_bad(success, good_loss, bad_loss)
        if not 0.0 < pi_b < 1.0:
            return _mean_good(success, good_loss, bad_loss, mean_bad_s)
        return mean_bad_s * pi_b / (1.0 - pi_b)

    burst.mean_good_s = quality.mean_good_s = _swapped
elif MUTATION == "ge_biased":
    _stationary = burst.stationary_bad
    burst.stationary_bad = quality.stationary_bad = lambda s, g, b: min(1.0, _stationary(s, g, b) * 1.08)
elif MUTATION == "walls_hits":
    _count = pathloss.count_walls
    pathloss.count_walls = lambda *a, **k: _count(*a, **k) * 2
elif MUTATION == "wall_db_half":
    _compute = pathloss.PathLoss._compute

    def _half_walls(self, pairs, k, ts):
        cfg = self.cfg
        full = cfg.wall_loss_db
        object.__setattr__(cfg, "wall_loss_db", full / 2)
        try:
            return _compute(self, pairs, k, ts)
        finally:
            object.__setattr__(cfg, "wall_loss_db", full)

    pathloss.PathLoss._compute = _half_walls
elif MUTATION == "trace_left":
    def _lookup_before(self, src, dst, t):
        rows = self.links.get((src, dst))
        if rows is None:
            return None
        ts, oks, lats = rows
        i = max(0, bisect.bisect_left(ts, self.trace_time(t)) - 1)
        return oks[i], lats[i]

    trace.TraceReplay.lookup = _lookup_before
elif MUTATION == "trace_latency":
    _lookup = trace.TraceReplay.lookup

    def _late(self, src, dst, t):
        row = _lookup(self, src, dst, t)
        return None if row is None else (row[0], row[1] * (1 + 1e-7))

    trace.TraceReplay.lookup = _late
elif MUTATION:
    raise ValueError(f"MUT={MUTATION!r}: unknown mutation (see the module docstring)")
