"""Where the agents' maps disagree: run a scenario in-process and, every few simulated
seconds, split the grid parameters by how many agents observed them (visit count > 0) and
print, per group, the spread between agents (RMS over parameters of the per-parameter
standard deviation), the parameters' RMS and largest magnitude, and the duals' RMS and the RMS
of their sum over agents (0 at an unbiased fixed point). For RAMEN it also prints, per group,
the eq. 19 weights of the edge (agent 0, agent 1) in units of beta_u: their median and the
share below beta_u / 10 (how weakly RAMEN couples those parameters compared with DiNNO).
docs/CONSENSUS.md, "The primal step"; docs/RESULTS.md, "consensus error".

    PYTHONPATH=. python benchmarks/consensus_maps.py scenarios/office_3agents.yaml 30 \\
        channel.success_rate=1.0 consensus.primal_update=prox
"""
from __future__ import annotations

import argparse
import logging

import numpy as np
import torch

from benchmarks._machine import machine_info
from ramensim.agents.consensus.weights import edge_weights
from ramensim.config import load_scenario
from ramensim.sim import build_simulation

log = logging.getLogger(__name__)


def report(sim) -> list[str]:
    th = torch.stack([m.theta.detach().double() for m in sim.maps])
    n_obs = (torch.stack([m.visits for m in sim.maps]) > 0).sum(0)
    spread = ((th - th.mean(0)) ** 2).mean(0).sqrt()
    duals = [getattr(s.method, "p", None) for s in sim.steps]
    method = sim.steps[0].method
    w01 = None
    if hasattr(method, "beta_l") and hasattr(method, "beta_u") and len(sim.maps) > 1:
        u0, u1 = sim.maps[0].visits, sim.maps[1].visits
        w01 = torch.empty(u0.shape, dtype=torch.float32)
        edge_weights(u0, u1, method.beta_l, method.beta_u, w01, torch.empty_like(w01))  # eq. 19
        w01 = w01.double() / method.beta_u
    rows = []
    for k in range(len(sim.maps) + 1):
        mask = n_obs == k
        if not mask.any():
            continue
        line = (f"  observed by {k}: {100 * mask.double().mean():5.1f} % of parameters, spread "
                f"{spread[mask].pow(2).mean().sqrt():.3g}, rms {th[:, mask].pow(2).mean().sqrt():.3g}, "
                f"max {th[:, mask].abs().max():.3g}")
        if all(d is not None for d in duals):
            p = torch.stack(duals)[:, mask].double()
            line += f", dual rms {p.pow(2).mean().sqrt():.3g}, rms of dual sum {p.sum(0).pow(2).mean().sqrt():.3g}"
        if w01 is not None:
            w = w01[mask]
            line += (f", w_01/beta_u median {w.median():.3g}, "
                     f"{100 * (w < 0.1).double().mean():.0f} % below 0.1")
        rows.append(line)
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scenario")
    ap.add_argument("seconds", type=float)
    ap.add_argument("overrides", nargs="*", help="dotted.key=value")
    ap.add_argument("--every", type=float, default=10.0, help="simulated seconds between reports")
    args = ap.parse_args()
    sc = load_scenario(args.scenario, ["recording.mode=off", *args.overrides])
    sim = build_simulation(sc)
    for t in np.arange(args.every, args.seconds + 1e-9, args.every):
        sim.env.run(until=float(t))
        print(f"t = {t:.0f} s, rounds {[p.rounds for p in sim.processes]}")
        print("\n".join(report(sim)), flush=True)
    print(machine_info())


if __name__ == "__main__":
    main()
