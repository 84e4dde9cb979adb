"""Random broadcast traffic for the channel tests that compare message logs (determinism,
golden hashes, radio models): the same traffic for every channel seed, so that only the
channel's own randomness differs between runs."""
from __future__ import annotations

from pathlib import Path

import numpy as np


def run_traffic(env, ch, n_agents: int, messages: int, traffic_seed: int, max_bytes: int = 5000) -> None:
    """Each agent broadcasts ``messages`` payloads of 0..max_bytes bytes, 0.05-0.5 s apart
    (simulated), drawn from one generator seeded ``traffic_seed``; runs ``env`` to the end."""
    traffic = np.random.default_rng(traffic_seed)

    def agent(i: int):
        for _ in range(messages):
            ch.broadcast(i, None, int(traffic.integers(0, max_bytes)), env.now)
            yield env.timeout(float(traffic.uniform(0.05, 0.5)))

    for i in range(n_agents):
        env.process(agent(i))
    env.run()


def log_bytes(ch, path: Path) -> bytes:
    """The channel's message log written as CSV to ``path``, read back as bytes."""
    ch.log.write_csv(path)
    return path.read_bytes()
