"""A distributed least-squares problem with a known answer, behind the ``Learner`` protocol.

Agent i holds rows ``(A_i, b_i)`` of one linear system; some of its columns are zero (it
never observes those parameters), so its visit counts (eq. 18) differ from its
neighbours'. Local objective ``L_i(theta) = |A_i theta - b_i|^2 / (2 M)`` with M the total
number of rows, so ``sum_i L_i`` is the centralised objective and its minimiser
(``LeastSquaresProblem.centralised_solution``) is what consensus must reach.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from ramensim.agents.learner import Prox, apply_prox, apply_prox_inv


class LeastSquaresLearner:
    """One agent's least-squares ``Learner`` (float32 theta, int64 visits).

    ``batch_rows``: rows per gradient (sampled without replacement with ``generator``,
    gradient rescaled to stay unbiased); ``None`` = full gradient. ``optimizer``: ``"adam"``
    (lr, betas, eps as the map's Adam) or ``"sgd"`` (plain ``theta -= lr * grad``).
    """

    def __init__(
        self,
        A: torch.Tensor,
        b: torch.Tensor,
        total_rows: int,
        theta0: torch.Tensor,
        *,
        optimizer: str = "sgd",
        lr: float = 0.1,
        betas: tuple[float, float] = (0.9, 0.99),
        eps: float = 1e-15,
        batch_rows: int | None = None,
        generator: torch.Generator | None = None,
    ) -> None:
        if A.dim() != 2 or b.shape != (A.shape[0],) or theta0.shape != (A.shape[1],):
            raise ValueError(
                f"LeastSquaresLearner: A {tuple(A.shape)}, b {tuple(b.shape)}, theta0 "
                f"{tuple(theta0.shape)}; expected A (m, n), b (m,), theta0 (n,)."
            )
        if optimizer not in ("adam", "sgd"):
            raise ValueError(f"LeastSquaresLearner: optimizer {optimizer!r}; expected 'adam' or 'sgd'.")
        if batch_rows is not None and not 1 <= batch_rows <= A.shape[0]:
            raise ValueError(
                f"LeastSquaresLearner: batch_rows = {batch_rows}; expected None or 1..{A.shape[0]}."
            )
        if batch_rows is not None and generator is None:
            raise ValueError("LeastSquaresLearner: minibatches need a torch.Generator (generator=...).")
        self.A = A.to(torch.float32).contiguous()
        self.b = b.to(torch.float32).contiguous()
        self.scale = 1.0 / total_rows
        n = A.shape[1]
        self._theta = theta0.to(torch.float32).clone()
        self._visits = torch.zeros(n, dtype=torch.int64)
        self._grad = torch.empty(n, dtype=torch.float32)
        self._res = torch.empty(A.shape[0], dtype=torch.float32)
        self.optimizer, self.lr, self.betas, self.eps = optimizer, float(lr), betas, float(eps)
        self.batch_rows, self.generator = batch_rows, generator
        self._m = torch.zeros(n, dtype=torch.float32)
        self._v = torch.zeros(n, dtype=torch.float32)
        self._denom = torch.empty(n, dtype=torch.float32)
        self._step = 0

    @property
    def theta(self) -> torch.Tensor:
        """Flat float32 parameters (n), updated in place."""
        return self._theta

    @property
    def visits(self) -> torch.Tensor:
        """u_i (eq. 18): gradient evaluations in which each parameter had a non-zero gradient."""
        return self._visits

    def objective(self, theta: torch.Tensor | None = None) -> float:
        """L_i at ``theta`` (default: current), full data, float64 arithmetic."""
        th = (self._theta if theta is None else theta).double()
        r = self.A.double() @ th - self.b.double()
        return float(0.5 * self.scale * (r @ r))

    def loss_and_grad(self) -> tuple[dict[str, float], torch.Tensor]:
        """``({"loss": L_i}, dL_i/dtheta)`` on the full data or a minibatch; updates visits."""
        if self.batch_rows is None:
            A, b, res, w = self.A, self.b, self._res, self.scale
        else:
            idx = torch.randperm(self.A.shape[0], generator=self.generator)[: self.batch_rows]
            A, b = self.A[idx], self.b[idx]
            res = torch.empty(self.batch_rows, dtype=torch.float32)
            w = self.scale * self.A.shape[0] / self.batch_rows
        torch.mv(A, self._theta, out=res)
        res.sub_(b)
        loss = 0.5 * w * float(torch.dot(res, res).item())
        torch.mv(A.t(), res, out=self._grad)
        self._grad.mul_(w)
        self._visits.add_(self._grad.ne(0))
        return {"loss": loss}, self._grad

    def optimizer_step(self, grad: torch.Tensor, prox: Prox | None = None) -> None:
        """One Adam (bias-corrected) or plain gradient step on theta with ``grad``, then the
        consensus ``prox`` in the same metric (see :func:`ramensim.agents.learner.apply_prox`)."""
        if self.optimizer == "sgd":
            self._theta.add_(grad, alpha=-self.lr)
            if prox is not None:
                apply_prox(self._theta, prox, self.lr)
            return
        b1, b2 = self.betas
        self._step += 1
        self._m.mul_(b1).add_(grad, alpha=1.0 - b1)
        self._v.mul_(b2).addcmul_(grad, grad, value=1.0 - b2)
        bc1 = 1.0 - b1**self._step
        bc2 = 1.0 - b2**self._step
        torch.sqrt(self._v, out=self._denom)
        self._denom.div_(bc2**0.5).add_(self.eps)
        self._theta.addcdiv_(self._m, self._denom, value=-self.lr / bc1)
        if prox is not None:
            apply_prox_inv(self._theta, prox, self._denom.div_(self.lr))


@dataclass
class LeastSquaresProblem:
    """The rows of each agent (``A[i]``, ``b[i]``), the shared initial ``theta0`` and the
    columns each agent never observes (``hidden[i]``, boolean (n,))."""

    A: list[torch.Tensor]
    b: list[torch.Tensor]
    theta0: torch.Tensor
    hidden: list[np.ndarray]

    @property
    def n(self) -> int:
        """Number of shared parameters."""
        return int(self.theta0.numel())

    @property
    def total_rows(self) -> int:
        """M: rows over all agents."""
        return sum(int(a.shape[0]) for a in self.A)

    def centralised_solution(self) -> torch.Tensor:
        """argmin of sum_i L_i (float64 least squares on all rows), as float64 (n,)."""
        A = torch.cat(self.A).double()
        b = torch.cat(self.b).double()
        return torch.linalg.lstsq(A, b.unsqueeze(1)).solution.squeeze(1)

    def learner(self, i: int, **kwargs) -> LeastSquaresLearner:
        """Agent i's learner (keyword arguments go to ``LeastSquaresLearner``)."""
        return LeastSquaresLearner(self.A[i], self.b[i], self.total_rows, self.theta0, **kwargs)

    def centralised_learner(self, **kwargs) -> LeastSquaresLearner:
        """One learner with everybody's rows (the ceiling)."""
        return LeastSquaresLearner(torch.cat(self.A), torch.cat(self.b), self.total_rows, self.theta0, **kwargs)


def make_least_squares(
    n_agents: int,
    n_params: int,
    rows_per_agent: int,
    rng: np.random.Generator,
    hidden_fraction: float = 0.3,
    noise: float = 0.1,
    theta0_scale: float = 1e-4,
) -> LeastSquaresProblem:
    """A random consistent-ish problem: ``b = A x_true + noise``; each agent hides a random
    ``hidden_fraction`` of the columns (zeroed in its A_i), every column is seen by at least
    one agent. ``theta0`` is uniform in ``[-theta0_scale, theta0_scale]`` (like the grid)."""
    if n_agents < 1 or n_params < 1 or rows_per_agent < 1 or not 0.0 <= hidden_fraction < 1.0:
        raise ValueError(
            f"make_least_squares: n_agents = {n_agents}, n_params = {n_params}, rows_per_agent = "
            f"{rows_per_agent}, hidden_fraction = {hidden_fraction}; expected positive sizes and "
            "0 <= hidden_fraction < 1."
        )
    x_true = rng.standard_normal(n_params)
    A, b, hidden = [], [], []
    k = int(round(hidden_fraction * n_params))
    for i in range(n_agents):
        Ai = rng.standard_normal((rows_per_agent, n_params))
        h = np.zeros(n_params, dtype=bool)
        h[rng.permutation(n_params)[:k]] = True
        hidden.append(h)
        A.append(Ai)
    seen_by_none = np.logical_and.reduce(hidden)
    for col in np.flatnonzero(seen_by_none):  # give every column an observer
        hidden[int(col) % n_agents][col] = False
    for i in range(n_agents):
        A[i][:, hidden[i]] = 0.0
        b.append(A[i] @ x_true + noise * rng.standard_normal(rows_per_agent))
    theta0 = rng.uniform(-theta0_scale, theta0_scale, n_params)
    to = lambda x: torch.from_numpy(np.ascontiguousarray(x)).to(torch.float32)  # noqa: E731
    return LeastSquaresProblem([to(a) for a in A], [to(v) for v in b], to(theta0), hidden)


def run_synchronous(
    problem: LeastSquaresProblem,
    method: str,
    cfg,
    rounds: int,
    edges: list[tuple[int, int]],
    *,
    success: float = 1.0,
    rng: np.random.Generator | None = None,
    learner_kwargs: dict | None = None,
    per_edge: bool = False,
) -> tuple[list[float], list]:
    """A small synchronous driver (no SimPy): each round every agent sends its payload
    (encoded with ``cfg.encoding``, stamp = round index in s), each directed copy arrives
    with probability ``success`` (seeded ``rng``), then every agent runs one round with the
    copies its stale policy selects. ``per_edge=True`` draws one Bernoulli per undirected
    edge per round instead (official code: both directions arrive or neither). Returns the worst relative error
    ``max_i |theta_i - x*| / |x*|`` after each round, and the learners.
    ``cfg`` is an ``ramensim.agents.consensus.ConsensusConfig``."""
    from ramensim.agents.consensus import make_method
    from ramensim.agents.copies import CopyStore, NeighbourCopy
    from ramensim.agents.encoding import decode, encode

    if success < 1.0 and rng is None:
        raise ValueError("run_synchronous: success < 1 needs a numpy Generator (rng=...).")
    n_agents = len(problem.A)
    neigh: dict[int, list[int]] = {i: [] for i in range(n_agents)}
    for a, b in edges:
        neigh[a].append(b)
        neigh[b].append(a)
    kw = learner_kwargs or {}
    if method == "centralised":
        learners = [problem.centralised_learner(**kw)]
        neigh = {0: []}
    else:
        learners = [problem.learner(i, **kw) for i in range(n_agents)]
    methods = [make_method(method, cfg, problem.n, degree=len(neigh[i]), agent=i) for i in range(len(learners))]
    stores = [CopyStore(i, neigh[i]) for i in range(len(learners))]
    x_star = problem.centralised_solution()
    errors: list[float] = []
    for r in range(rounds):
        now = float(r)
        if methods[0].communicates:
            msgs = [encode(m.payload(lr), cfg.encoding, problem.theta0) for m, lr in zip(methods, learners)]
            links = [{j: {k: t.clone() for k, t in extra.items()} for j, extra in
                      m.link_payloads().items()} for m in methods]
            if per_edge:
                ok = {(a, b): success >= 1.0 or rng.random() < success for a, b in edges}
                ok.update({(b, a): v for (a, b), v in list(ok.items())})
            for i in range(len(learners)):
                for j in neigh[i]:
                    arrived = ok[(i, j)] if per_edge else (success >= 1.0 or rng.random() < success)
                    if arrived:
                        tensors = {**decode(msgs[j], problem.theta0), **links[j].get(i, {})}
                        stores[i].put(NeighbourCopy(j, tensors, now, now))
        for i, (m, lr) in enumerate(zip(methods, learners)):
            sel = stores[i].select(now, cfg.stale_policy, cfg.max_age_s)
            m.round(lr, sel.copies, len(neigh[i]))
        err = max(float(torch.linalg.vector_norm(lr.theta.double() - x_star) / torch.linalg.vector_norm(x_star))
                  for lr in learners)
        errors.append(err)
    return errors, learners
