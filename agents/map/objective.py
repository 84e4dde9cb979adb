"""The terms of L_obj (eq. 5-6) and their gradients with respect to what the map computes
from theta (docs/ALGORITHM.md section 1): the observation losses over a batch of rendered
rays, w.r.t. the decoder outputs (the step between the decoders' forward and their
backward), and Co-SLAM's smoothness term, w.r.t. the grid features of its lattice.

Two implementations with one contract:

- ``torch``: :mod:`render` (Co-SLAM's weights and compositing) and :mod:`losses` through
  torch autograd: the reference;
- ``c``: ``render_loss`` and ``smooth_loss`` of ``csrc/render.c`` and ``csrc/smooth.c``: the same maths,
  forward and a hand-written backward (one pass per ray; one pass over the lattice), no
  autograd graph (an iteration's ~40 small torch ops and their backward replaced by two calls).

They agree to float rounding (the C kernels sum the batch terms in double, per ray or slab
and then in order, so their results do not depend on the thread count;
tests/map/test_map_objective.py).
"""
from __future__ import annotations

import torch

from . import _native
from .losses import render_losses, sdf_losses, smoothness_loss
from .render import composite, sdf_weights

TERMS = ("rgb", "depth", "sdf", "fs")
"""The unweighted observation terms: rgb and depth MSE (eq. 5; depth m^2), SDF (m^2) and
free-space loss (eq. 6)."""

MAX_SAMPLES_PER_RAY = 1024
"""Samples per ray the C kernel takes (its per-ray scratch lives on the stack)."""


def c_unavailable(device: torch.device, samples_per_ray: int) -> str | None:
    """Why the C implementation cannot run here, or ``None``."""
    if device.type != "cpu":
        return "CPU only"
    if samples_per_ray > MAX_SAMPLES_PER_RAY:
        return f"more than {MAX_SAMPLES_PER_RAY} samples per ray"
    if _native.get_lib() is None:
        return "kernels did not build (see the warning above)"
    return None


def _weighted(terms: dict[str, float], weights: tuple[float, float, float, float]) -> float:
    return sum(w * terms[k] for w, k in zip(weights, TERMS))


def observation_grads(sdf: torch.Tensor, raw: torch.Tensor, z: torch.Tensor,
                      rgb_obs: torch.Tensor, depth_obs: torch.Tensor, truncation: float,
                      weights: tuple[float, float, float, float], backend: str = "torch",
                      threads: int = 0) -> tuple[dict[str, float], float, torch.Tensor, torch.Tensor]:
    """Observation losses of a batch and their gradient w.r.t. the decoder outputs.

    sdf: (R, S) decoder SDF (truncation units); raw: (R, S, 3) decoder colour before the
    sigmoid; z: (R, S) sample depths (m); rgb_obs: (R, 3) in [0, 1]; depth_obs: (R,) m
    (0 = no depth); truncation (m); weights: (rgb, depth, sdf, fs) of eq. 6. Returns
    ``(terms, obs, d_sdf, d_raw)``: the unweighted terms (``TERMS``), their weighted sum, and
    d obs / d sdf (R, S), d obs / d raw (R, S, 3). ``threads``: the C kernel's (0: torch's
    intra-op count).
    """
    if backend == "c":
        return _observation_grads_c(sdf, raw, z, rgb_obs, depth_obs, truncation, weights,
                                    threads)
    if backend != "torch":
        raise ValueError(f"unknown objective backend {backend!r}; expected 'c' or 'torch'")
    sdf = sdf.detach().requires_grad_(True)
    raw = raw.detach().requires_grad_(True)
    terms, obs = observation_losses(sdf, raw, z, rgb_obs, depth_obs, truncation, weights)
    d_sdf, d_raw = torch.autograd.grad(obs, [sdf, raw])
    return terms, float(obs.detach()), d_sdf, d_raw


def observation_losses(sdf: torch.Tensor, raw: torch.Tensor, z: torch.Tensor,
                       rgb_obs: torch.Tensor, depth_obs: torch.Tensor, truncation: float,
                       weights: tuple[float, float, float, float]) -> tuple[dict[str, float], torch.Tensor]:
    """The torch forward (differentiable): the unweighted terms as floats and their weighted
    sum as a tensor, for autograd to the decoder outputs or further back (trainable decoders,
    GPU). Arguments as :func:`observation_grads`."""
    w = sdf_weights(sdf, z, truncation)
    rgb, depth = composite(w, raw, z)
    l_rgb, l_depth = render_losses(rgb, depth, rgb_obs, depth_obs)
    l_fs, l_sdf = sdf_losses(z, depth_obs, sdf, truncation)
    obs = weights[0] * l_rgb + weights[1] * l_depth + weights[2] * l_sdf + weights[3] * l_fs
    terms = {"rgb": float(l_rgb.detach()), "depth": float(l_depth.detach()),
             "sdf": float(l_sdf.detach()), "fs": float(l_fs.detach())}
    return terms, obs


def _observation_grads_c(sdf, raw, z, rgb_obs, depth_obs, truncation, weights, threads):
    lib = _native.get_lib()
    R, S = sdf.shape
    if lib is None or c_unavailable(sdf.device, S) is not None:
        raise RuntimeError(f"the C objective is unavailable here: "
                           f"{c_unavailable(sdf.device, S)}")
    f32 = [t.detach().contiguous().float() for t in (sdf, raw, z, rgb_obs, depth_obs)]
    lw = torch.tensor(weights, dtype=torch.float32)
    losses = torch.empty(4, dtype=torch.float64)
    d_sdf = torch.empty(R, S, dtype=torch.float32)
    d_raw = torch.empty(R, S, 3, dtype=torch.float32)
    part = torch.empty(4 * R, dtype=torch.float64)
    lib.render_loss(*(t.data_ptr() for t in f32), R, S, float(truncation), lw.data_ptr(),
                    losses.data_ptr(), d_sdf.data_ptr(), d_raw.data_ptr(), part.data_ptr(),
                    threads or _native.nthreads())
    terms = dict(zip(TERMS, losses.tolist()))
    return terms, _weighted(terms, weights), d_sdf, d_raw


def smoothness_grads(feats: torch.Tensor, n: int, weight: float, backend: str = "torch",
                     threads: int = 0) -> tuple[float, torch.Tensor]:
    """Co-SLAM's smoothness term (``losses.smoothness_loss``) of the grid features ``feats``
    ((n^3, C), (z, y, x) lattice order) and ``weight`` times its gradient w.r.t. them.
    Returns ``(loss (unweighted), d (weight * loss) / d feats (n^3, C))``."""
    if backend == "c":
        lib = _native.get_lib()
        if lib is None or feats.device.type != "cpu":
            raise RuntimeError("the C smoothness term is unavailable here")
        f = feats.detach().contiguous().float()
        if f.shape[0] != n ** 3:
            raise ValueError(f"smoothness: {f.shape[0]} feature rows, expected n^3 = {n ** 3}")
        grad = torch.empty_like(f)
        loss = torch.empty(1, dtype=torch.float64)
        part = torch.empty(n, dtype=torch.float64)
        lib.smooth_loss(f.data_ptr(), n, f.shape[1], float(weight), loss.data_ptr(),
                        grad.data_ptr(), part.data_ptr(), threads or _native.nthreads())
        return float(loss), grad
    if backend != "torch":
        raise ValueError(f"unknown objective backend {backend!r}; expected 'c' or 'torch'")
    f = feats.detach().requires_grad_(True)
    loss = smoothness_loss(f, n)
    (grad,) = torch.autograd.grad(weight * loss, [f])
    return float(loss.detach()), grad
