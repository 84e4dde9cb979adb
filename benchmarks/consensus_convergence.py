"""Convergence of every consensus method on the distributed least-squares toy (known
answer): worst-agent relative error |theta_i - x*| / |x*| against round, for full
communication and for 50 % message success (paper semantics: each directed copy
refreshes with probability 0.5 and the latest copy is used; official-code semantics: one
Bernoulli per undirected edge and lost neighbours left out); then the dual updates (node,
per-link, antisymmetric) at 50 / 5 / 1 % success, the primal updates (joint, prox) with
Adam, and the shipped default against the paper's update with Adam down to 1 % success. Numbers for docs/CONSENSUS.md.

    PYTHONPATH=. python benchmarks/consensus_convergence.py
"""
from __future__ import annotations

import itertools

import numpy as np
import torch

from ramensim.agents.consensus import ConsensusConfig
from ramensim.agents.toy import make_least_squares, run_synchronous
from benchmarks._machine import machine_info

ROUNDS = 400
MARKS = (1, 10, 25, 50, 100, 200, 300, 400)
CFGS = {
    "ramen": {"preset": "paper", "ramen": {"rho": 0.1, "beta_l": 0.01}},
    "ramen(beta_l=rho/1000)": {"preset": "paper", "ramen": {"rho": 0.1}},
    "dinno": {"preset": "paper", "dinno": {"rho": 0.1}},
    "dsgd": {"dsgd": {"alpha": 0.5, "mixing": "metropolis"}},
    "dsgt": {"dsgt": {"alpha": 0.5, "mixing": "metropolis"}},
    "local": {},
    "centralised": {},
}


def row(label: str, errors: list[float], learners) -> str:
    th = torch.stack([lr.theta for lr in learners])
    spread = float((th - th.mean(0)).abs().max())
    return f"| {label} | " + " | ".join(f"{errors[k - 1]:.1e}" for k in MARKS) + f" | {spread:.0e} |"


def main() -> None:
    prob = make_least_squares(4, 20, 30, np.random.default_rng(0), hidden_fraction=0.3)
    graphs = {"complete K4": list(itertools.combinations(range(4), 2)), "path 0-1-2-3": [(0, 1), (1, 2), (2, 3)]}
    print("problem: 4 agents, n = 20, 30 rows each, 30 % of columns hidden per agent, seed 0; "
          "plain gradient steps lr 0.5, B = 10")
    head = "| method | " + " | ".join(f"r{k}" for k in MARKS) + " | max spread |"
    sep = "|" + "---|" * (len(MARKS) + 2)
    for gname, edges in graphs.items():
        print(f"\n### full communication, {gname}\n\n{head}\n{sep}")
        for name, c in CFGS.items():
            if name == "centralised" and gname != "complete K4":
                continue
            method = name.split("(")[0]
            e, lrs = run_synchronous(prob, method, ConsensusConfig(**c), ROUNDS, edges, learner_kwargs={"lr": 0.5})
            print(row(name, e, lrs))
    edges = graphs["complete K4"]
    for title, policy, per_edge in (("paper semantics: directed copies refresh w.p. 0.5, latest copy used", "latest", False),
                                    ("official-code semantics: one draw per undirected edge, lost neighbours omitted", "omit_lost", True)):
        print(f"\n### 50 % success, complete K4, {title}\n\n{head}\n{sep}")
        for name in ("ramen", "ramen(beta_l=rho/1000)", "dinno", "dsgd", "dsgt"):
            method = name.split("(")[0]
            cfg = ConsensusConfig(stale_policy=policy, **CFGS[name])
            e, lrs = run_synchronous(prob, method, cfg, ROUNDS, edges, success=0.5, rng=np.random.default_rng(1),
                                     per_edge=per_edge, learner_kwargs={"lr": 0.5})
            print(row(name, e, lrs))
    # Stale copies without bias (docs/CONSENSUS.md): paper semantics (latest copy, each directed
    # copy refreshes with probability p), node dual vs per-link (UDON-style) vs antisymmetric.
    marks = (50, 200, 500, 1000, 2000)
    head2 = "| method | dual | success | " + " | ".join(f"r{k}" for k in marks) + " |"
    sep2 = "|" + "---|" * (len(marks) + 3)
    print(f"\n### latest-copy semantics, complete K4, plain steps lr 0.5: dual updates\n\n{head2}\n{sep2}")
    for name in ("ramen", "dinno"):
        for dual in ("node", "per_link", "antisymmetric"):
            for success in (0.5, 0.05, 0.01):
                cfg = ConsensusConfig(dual_update=dual, **CFGS[name])
                e, _ = run_synchronous(prob, name, cfg, max(marks), edges, success=success,
                                       rng=np.random.default_rng(1), learner_kwargs={"lr": 0.5})
                print(f"| {name} | {dual} | {success:.0%} | " + " | ".join(f"{e[k - 1]:.1e}" for k in marks) + " |")
    print(f"\n### full communication, complete K4, Adam lr 0.05: primal updates\n\n{head}\n{sep}")
    for name, c in (("ramen", CFGS["ramen"]), ("ramen(beta_l=rho/1000)", CFGS["ramen(beta_l=rho/1000)"]),
                    ("dinno", CFGS["dinno"])):
        for primal in ("joint", "prox"):
            cfg = ConsensusConfig(primal_update=primal, **c)
            e, lrs = run_synchronous(prob, name.split("(")[0], cfg, ROUNDS, edges,
                                     learner_kwargs={"lr": 0.05, "optimizer": "adam"})
            print(row(f"{name}, {primal}", e, lrs))
    # The shipped default (preset 'ramensim': prox primal step, scaled antisymmetric duals in
    # the prox, dual step 0.2) against the paper's update, both with the map's optimiser (Adam).
    print(f"\n### latest-copy semantics, complete K4, Adam lr 0.05: the default vs the paper's update\n\n{head2}\n{sep2}")
    for name, rho in (("ramen", {"ramen": {"rho": 0.1, "beta_l": 0.01}}), ("dinno", {"dinno": {"rho": 0.1}})):
        for preset, label in (("paper", "paper (joint, node, 1.0)"), ("ramensim", "default (prox, antisym., 0.2)")):
            for success in (1.0, 0.5, 0.05, 0.01):
                cfg = ConsensusConfig(preset=preset, **rho)
                e, _ = run_synchronous(prob, name, cfg, max(marks), edges, success=success,
                                       rng=np.random.default_rng(1),
                                       learner_kwargs={"lr": 0.05, "optimizer": "adam"})
                print(f"| {name} | {label} | {success:.0%} | " + " | ".join(f"{e[k - 1]:.1e}" for k in marks) + " |")
    print()
    print(machine_info())


if __name__ == "__main__":
    main()
