"""One agent's neural implicit map: the ``Learner`` the consensus methods drive.

``theta`` (the flat hash-grid table, n = L*T*F float32) is the only learned parameter
during mapping; the decoders are pretrained and frozen (docs/ALGORITHM.md section 1).
A call of ``loss_and_grad`` draws rays from the keyframe database plus the current
frame, renders them, evaluates L_obj (eq. 5-6), and returns the flat gradient; the
visit counts u_i (eq. 18) count, per parameter, the evaluations in which the
OBSERVATION losses (rgb, depth, sdf, free space; not smoothness) gave a non-zero
gradient. The step itself is defined once, for one map or a team, in ``step.py``; the map
contributes its draws (``draw_step``), its gradient buffer and its visit counts.
``optimizer_step`` is Adam on theta with whatever gradient the method passes.
"""
from __future__ import annotations

import copy
import functools
import logging
import math

import numpy as np
import torch

from ramensim.agents.learner import Prox, apply_prox_inv
from ramensim.core.frames import Frame, Intrinsics
from . import _native
from . import backend as _backend
from .config import MapConfig, resolve_device  # noqa: F401 - resolve_device: its old import path
from .decoders import KEYS, Decoders, check_decoders
from .hashgrid import GridSpec, encode, encode_grid, vertex_positions
from .losses import smoothness_points
from .oneblob import oneblob
from .threads import capped, thread_count
from .rays import RayDatabase, check_frame, frame_rays, image_rays, valid_pixel_ids
from .render import sample_points, sdf_weights
from .step import MAP_STAGES, StepDraw, loss_and_grad as step_loss_and_grad

GRID_BATCH = 8_192
"""Points per batch of :meth:`NeuralMap.sdf_grid` (whole x-slabs, or rows of y within one slab):
its OneBlob codes (192 bytes a point) and grid features (128) stay in the cache between the
hash-grid and decoder kernels (``benchmarks/bench_extract.py --batches`` measures sizes)."""

log = logging.getLogger(__name__)


def check_bounds(bounds: np.ndarray | torch.Tensor) -> torch.Tensor:
    """Scene bounds as a float32 (2, 3) tensor [lo, hi] in metres, validated."""
    b = torch.as_tensor(np.asarray(bounds, dtype=np.float64), dtype=torch.float32)
    if b.shape != (2, 3) or not bool(torch.isfinite(b).all()) or not bool((b[1] > b[0]).all()):
        raise ValueError(f"Map bounds must be a finite (2, 3) array [lo, hi] in metres with "
                         f"hi > lo on every axis; got {np.asarray(bounds).tolist()}.")
    return b


def _on_map_threads(method):
    """Run a NeuralMap method on the map's measured thread count (``torch_threads``): on a
    loaded machine a torch op on more threads than the map measured as worth it can cost
    10-100x (OpenMP spin-waits). Elementwise work and row-wise reductions only, so the
    results do not depend on the count."""
    @functools.wraps(method)
    def wrapped(self, *args, **kwargs):
        with thread_count(self.torch_threads):
            return method(self, *args, **kwargs)
    return wrapped


class NeuralMap:
    """Co-SLAM-style map of one agent implementing ``ramensim.agents.learner.Learner``.

    bounds: (2, 3) metres; decoders: the four decoder matrices (see ``decoders.py``);
    init_generator: draws the initial table (uniform in +-1e-4), so agents built with the
    same seed share theta; sample_generator: ray and sample jitter draws.
    ``train_decoders`` (pretraining only) also returns decoder gradients in
    ``decoder_grads`` after each ``loss_and_grad``. ``device``: the torch device the run
    resolved from ``map.device`` (None: resolve ``cfg.device`` here, as a test or a tool does).
    """

    def __init__(self, bounds: np.ndarray | torch.Tensor, cfg: MapConfig,
                 decoders: dict[str, torch.Tensor], init_generator: torch.Generator,
                 sample_generator: torch.Generator, train_decoders: bool = False,
                 device: torch.device | None = None) -> None:
        self.cfg = cfg
        self.device = resolve_device(cfg.device) if device is None else device
        """The map's torch device: ``device`` as resolved once for the run
        (``ramensim.sim.scenario_device``), else ``cfg.device`` resolved here."""
        b = check_bounds(bounds)
        self.lo, self.hi = b[0].to(self.device), b[1].to(self.device)
        self.extent = self.hi - self.lo
        check_decoders(decoders, cfg, "the decoders passed to NeuralMap")
        max_extent = float((b[1] - b[0]).max())
        self.far = float(cfg.far) if cfg.far is not None else float(torch.linalg.vector_norm(b[1] - b[0]))
        """Farthest stratified sample (m): the config's, or the diagonal of the bounds."""
        finest = max(float(int(max_extent / cfg.voxel_sdf)), float(cfg.base_resolution))
        self.spec = GridSpec.build(cfg.n_levels, cfg.features_per_level, cfg.log2_hashmap_size,
                                   cfg.base_resolution, finest)
        n = self.spec.n_params
        init = (torch.rand(n, generator=init_generator, dtype=torch.float32) * 2 - 1) * 1e-4
        self._theta = init.to(self.device)
        self._m = torch.zeros_like(self._theta)
        self._v = torch.zeros_like(self._theta)
        self._prox_buf: tuple[torch.Tensor, torch.Tensor] | None = None
        self._step = 0
        self._visits = torch.zeros(n, dtype=torch.int32, device=self.device)
        self._grad = torch.zeros_like(self._theta)
        self.decoders = Decoders(decoders, cfg, self.device, trainable=train_decoders)
        self.decoder_grads: dict[str, torch.Tensor] = {}
        self.gen = sample_generator
        self.keyframes = RayDatabase()
        self._current: torch.Tensor | None = None  # (M, 10) rays of the current frame
        self.count_observation_only = True
        """Eq. 18 counts gradients of the observation losses only (False: smoothness too, as the official code)."""
        self.native = cfg.native and self.device.type == "cpu" and _native.get_lib() is not None
        """Compiled kernels for OneBlob, Adam and the visit count (CPU, when they build)."""
        self.grid_choice = None
        self.objective_choice = None
        self.objective_backend = "torch"
        """Rendering + observation losses with their gradient (``objective.py``): 'c' or 'torch'."""
        self.grid_native = False
        """Hash grid through the C kernel (True) or the fused torch path (False)."""
        self.grid_threads = 0
        if self.device.type == "cpu":
            self.grid_choice = _backend.select("grid", _backend.grid_shape(cfg), self.device,
                                               cfg.grid_backend if cfg.native else "torch",
                                               threads=cfg.threads)
            self.grid_native = self.grid_choice.backend == "c"
            self.grid_threads = self.grid_choice.threads if self.grid_native else 0
        self.torch_threads = 0
        if self.device.type == "cpu":
            self.objective_choice = _backend.select("objective", _backend.objective_shape(cfg),
                                                 self.device,
                                                 cfg.objective_backend if cfg.native else "torch",
                                                 threads=cfg.threads)
            self.objective_backend = self.objective_choice.backend
            self.torch_threads = self.objective_choice.threads

    @property
    def grid_threads(self) -> int:
        """Threads of the C hash-grid kernels (0: torch's intra-op count); the other
        parallel C loops of an iteration (OneBlob, the visit count, Adam) run on it too.
        Under the calling thread's cap (``threads.capped``: 1 on a team-engine worker)."""
        return capped(self._grid_threads)

    @grid_threads.setter
    def grid_threads(self, n: int) -> None:
        self._grid_threads = int(n)

    @property
    def torch_threads(self) -> int:
        """Threads of the torch part of ``loss_and_grad`` and of the objective stage (0: the
        process's count), chosen by measurement (agents/map/backend.py, stage ``objective``),
        under the calling thread's cap."""
        return capped(self._torch_threads)

    @torch_threads.setter
    def torch_threads(self, n: int) -> None:
        self._torch_threads = int(n)

    # ----------------------------------------------------------------- Learner
    @property
    def theta(self) -> torch.Tensor:
        """Flat float32 grid table (n,), updated in place."""
        return self._theta

    @property
    def visits(self) -> torch.Tensor:
        """u_i of eq. 18, int32 (n,)."""
        return self._visits

    @property
    def n_params(self) -> int:
        return self.spec.n_params

    # ------------------------------------------------------------------- data
    @_on_map_threads
    def add_frame(self, frame: Frame, keyframe: bool) -> None:
        """Make ``frame`` the current frame; a keyframe also stores a random share
        (``keyframe_pixel_share`` of all pixels, drawn among valid-depth pixels) in the
        ray database."""
        check_frame(frame)
        ids = valid_pixel_ids(frame)
        if ids.numel() == 0:
            log.debug("frame %d has no valid depth; ignored", frame.index)
            return
        rays = frame_rays(frame, ids)
        self._current = torch.cat([rays["origin"], rays["dir"], rays["rgb"],
                                   rays["depth"][:, None]], dim=1)
        if keyframe:
            k = min(ids.numel(), max(1, int(math.ceil(self.cfg.keyframe_pixel_share
                                                      * frame.K.width * frame.K.height))))
            pick = torch.randperm(ids.numel(), generator=self.gen)[:k]
            self.keyframes.add({key: val[pick] for key, val in rays.items()})

    @property
    def has_data(self) -> bool:
        return self._current is not None

    def _sample_rays(self) -> torch.Tensor:
        cfg = self.cfg
        assert self._current is not None
        if self.keyframes.size == 0:
            n_cur = cfg.n_rays
        else:
            n_cur = min(cfg.n_rays, max(cfg.n_rays // self.keyframes.n_frames, cfg.min_current_rays))
        cur_ids = torch.randint(0, self._current.shape[0], (n_cur,), generator=self.gen)
        parts = [self._current[cur_ids]]
        if n_cur < cfg.n_rays:
            parts.append(self.keyframes.sample(cfg.n_rays - n_cur, self.gen))
        return torch.cat(parts, dim=0).to(self.device)

    # --------------------------------------------------------------- training
    def _normalise(self, pts: torch.Tensor) -> torch.Tensor:
        return ((pts - self.lo) / self.extent).clamp_(0.0, 1.0)

    def loss_and_grad(self) -> tuple[dict[str, float], torch.Tensor]:
        """Sample a batch, evaluate L_obj (eq. 5-6) and return ``(scalars, grad)``.

        scalars: ``loss`` (weighted total) and the unweighted ``rgb``, ``depth`` (m^2),
        ``sdf`` (m^2), ``fs``, ``smooth``. grad: an internal flat buffer (n,), valid until
        the next call. Before any frame: zero loss and gradient, visits unchanged. The step of
        ``step.py`` with this map's own stages, on ``torch_threads`` threads (the C stages on
        their own chosen counts). The map knows nothing of the team: in the team engine's
        lockstep mode a round is given a proxy of the map whose ``loss_and_grad`` joins the
        team's batched step instead (``agents/rounds/lockstep.py``; the same step with the
        stages of ``agents/map/team_batch.py``: the same values up to float rounding).
        """
        with thread_count(self.torch_threads):
            return step_loss_and_grad((self,), MAP_STAGES)[0]

    # --------------------------------------------------- what a step reads and writes
    @property
    def grad_buffer(self) -> torch.Tensor:
        """The flat float32 gradient buffer (n,) that ``loss_and_grad`` fills and returns."""
        return self._grad

    def draw_step(self, native: bool | None = None) -> StepDraw | None:
        """The random inputs of one step of L_obj (``step.py``), from the map's generator in
        this order: ``n_rays`` rays (the current frame's share, the rest from the keyframe
        database), their sample depths (m) and normalised positions, and, when the smoothness
        weight is not 0, the smoothness term's random lattice (normalised). None before any
        frame (nothing is drawn). ``native``: the compiled sampler (bit for bit the torch one's
        draws; default: the map's choice)."""
        if self._current is None:
            return None
        cfg = self.cfg
        rays = self._sample_rays()
        z, xn = sample_points(rays, cfg.n_stratified, cfg.n_surface, cfg.near, self.far,
                              cfg.surface_range, self.gen, self.lo, self.extent,
                              self.native if native is None else native, self.grid_threads)
        lattice = None
        if cfg.smooth_weight > 0:
            sp = smoothness_points(self.lo.cpu(), self.hi.cpu(), cfg.smooth_lattice, cfg.smooth_spacing,
                                   cfg.smooth_margin, self.gen).to(self.device)
            lattice = self._normalise(sp)
        return StepDraw(rays, z, xn, lattice)

    def _c_threads(self) -> int:
        """Threads of the elementwise C loops (visit count, Adam): the grid kernels'
        measured count. Inside ``loss_and_grad`` torch's own count is the objective stage's
        (often 1: its small ops gain nothing from a second thread), which these
        memory-bound loops over the whole table would otherwise inherit."""
        return self.grid_threads or _native.nthreads()

    def count_visits(self, grad: torch.Tensor) -> None:
        """u_i += 1 where ``grad`` (n,) is non-zero (eq. 18; the step passes its observation
        terms' gradient, or with smoothness as the authors' code)."""
        if self.native:
            _native.get_lib().count_visits(grad.data_ptr(), self._visits.data_ptr(),
                                           grad.numel(), self._c_threads())
        else:
            self._visits += (grad != 0).to(torch.int32)

    def optimizer_step(self, grad: torch.Tensor, prox: Prox | None = None) -> None:
        """One Adam step on theta (lr, betas, eps of the config; torch.optim.Adam's formula),
        then, with ``prox``, the exact proximal step of the consensus quadratic in Adam's
        metric ``lr / (sqrt(v_hat) + eps)`` (:func:`ramensim.agents.learner.apply_prox_inv`).
        Runs on the measured thread count of ``loss_and_grad`` (elementwise: the same numbers
        on any count)."""
        with thread_count(self.torch_threads):
            self._optimizer_step(grad, prox)

    def _optimizer_step(self, grad: torch.Tensor, prox: Prox | None) -> None:
        if prox is not None and self._fused_prox(prox):
            self._adam(grad, prox)  # Adam and the proximal step in one pass (bit-identical)
            return
        self._adam(grad)
        if prox is not None:
            if self._prox_buf is None:
                self._prox_buf = (torch.empty_like(self._theta), torch.empty_like(self._theta))
            inv_step, scratch = self._prox_buf  # 1 / (lr / (sqrt(v_hat) + eps)), no allocation
            bc2s = math.sqrt(1.0 - self.cfg.adam_beta2 ** self._step)
            torch.sqrt(self._v, out=inv_step).mul_(1.0 / (bc2s * self.cfg.lr)).add_(self.cfg.adam_eps / self.cfg.lr)
            apply_prox_inv(self._theta, prox, inv_step, scratch)

    def _fused_prox(self, prox: Prox) -> bool:
        """Whether the compiled Adam + proximal step takes this ``(A, c)``: CPU kernels, c a
        contiguous float32 vector like theta, A a Python number or such a vector (a 0-d
        tensor A goes the torch way: its division rounds differently from 1/x * A)."""
        a, c = prox
        n = self._theta.numel()

        def vec(t: object) -> bool:
            return (isinstance(t, torch.Tensor) and t.dtype == torch.float32 and t.numel() == n
                    and t.device.type == "cpu" and t.is_contiguous())
        return self.native and vec(c) and (isinstance(a, (int, float)) or vec(a))

    def _adam(self, grad: torch.Tensor, prox: Prox | None = None) -> None:
        """Adam on theta; with ``prox`` (only when :meth:`_fused_prox` accepts it) followed by
        the proximal step in the same pass (``adam_prox`` of ``csrc/adam.c``)."""
        cfg = self.cfg
        if grad.shape != self._theta.shape:
            raise ValueError(f"optimizer_step: gradient has shape {tuple(grad.shape)}, "
                             f"expected {tuple(self._theta.shape)} (the flat grid).")
        self._step += 1
        bc1 = 1.0 - cfg.adam_beta1 ** self._step
        bc2s = math.sqrt(1.0 - cfg.adam_beta2 ** self._step)
        g = grad.to(device=self.device, dtype=torch.float32).contiguous()
        if self.native and prox is not None:
            a, c = prox
            tensor_a = isinstance(a, torch.Tensor)
            _native.get_lib().adam_prox(
                self._theta.data_ptr(), g.data_ptr(), self._m.data_ptr(), self._v.data_ptr(),
                g.numel(), cfg.lr, cfg.adam_beta1, cfg.adam_beta2, cfg.adam_eps, bc1, bc2s,
                1.0 / (bc2s * cfg.lr), cfg.adam_eps / cfg.lr, a.data_ptr() if tensor_a else None,
                0.0 if tensor_a else float(a), c.data_ptr(), self._c_threads())
            return
        if self.native:
            _native.get_lib().adam_step(self._theta.data_ptr(), g.data_ptr(), self._m.data_ptr(),
                                        self._v.data_ptr(), g.numel(), cfg.lr, cfg.adam_beta1,
                                        cfg.adam_beta2, cfg.adam_eps, bc1, bc2s, self._c_threads())
            return
        self._m.lerp_(g, 1.0 - cfg.adam_beta1)
        self._v.mul_(cfg.adam_beta2).addcmul_(g, g, value=1.0 - cfg.adam_beta2)
        denom = (self._v.sqrt() / bc2s).add_(cfg.adam_eps)
        self._theta.addcdiv_(self._m, denom, value=-cfg.lr / bc1)

    # ---------------------------------------------------------------- queries
    @torch.no_grad()
    def _field(self, xn: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        feats = encode(xn, self._theta, self.spec, self.grid_native, threads=self.grid_threads)
        pe = oneblob(xn, self.cfg.oneblob_bins, self.native, self.grid_threads)
        if self.decoders.fused and xn.device.type == "cpu":
            return self.decoders.fused_forward(feats, pe)
        return self.decoders.forward(feats, pe)

    @_on_map_threads
    @torch.no_grad()
    def sdf(self, points: np.ndarray | torch.Tensor) -> np.ndarray:
        """SDF in metres (N,) at world points (N, 3) m, chunked, without gradients: equal to
        ``sdf_and_color(points)[0]`` without evaluating the colour decoder (mesh extraction
        queries every grid point, colours are only needed at the mesh's vertices)."""
        pts = self._query_points(points)
        out = np.empty(pts.shape[0], dtype=np.float32)
        for s in range(0, pts.shape[0], self.cfg.chunk):
            p = pts[s: s + self.cfg.chunk].to(self.device)
            xn = self._normalise(p)
            sdf = self._sdf_units(xn, oneblob(xn, self.cfg.oneblob_bins, self.native,
                                              self.grid_threads))
            out[s: s + p.shape[0]] = (sdf * self.cfg.truncation).cpu().numpy()
        return out

    def _sdf_units(self, xn: torch.Tensor, pe: torch.Tensor) -> torch.Tensor:
        """SDF in truncation units at normalised points ``xn`` (N, 3) with their OneBlob
        encoding ``pe``: the fused decoders' SDF-only pass on the CPU, else the full forward's."""
        feats = encode(xn, self._theta, self.spec, self.grid_native, threads=self.grid_threads)
        return self._sdf_from_feats(feats, pe)

    def _sdf_from_feats(self, feats: torch.Tensor, pe: torch.Tensor) -> torch.Tensor:
        """SDF in truncation units from grid features (N, L*F) and OneBlob codes (N, 3*bins)."""
        if self.decoders.fused and feats.device.type == "cpu":
            return self.decoders.fused_sdf(feats, pe)
        return self.decoders.forward(feats, pe)[0]

    @_on_map_threads
    @torch.no_grad()
    def sdf_grid(self, origin: np.ndarray, voxel_m: float, shape: tuple[int, int, int]) -> np.ndarray:
        """SDF in metres on the regular grid ``origin + (i, j, k) * voxel_m`` (m), array of
        ``shape`` (nx, ny, nz), float32: the values :meth:`sdf` gives for those points (as
        ``evaluation.mesh.extract_mesh`` builds them), bit for bit with the C decoder (a torch
        decoder may round differently: its products depend on the batch). Faster on a grid: the
        normalised coordinates and the OneBlob encoding depend on one axis each, so they are
        computed once per axis value (nx + ny + nz, not nx * ny * nz) and gathered."""
        cfg = self.cfg
        origin = np.asarray(origin, dtype=np.float64)
        xn_axes = []
        for a in range(3):
            vals = (origin[a] + np.arange(shape[a], dtype=np.int64) * voxel_m).astype(np.float32)
            pts = torch.zeros(shape[a], 3, dtype=torch.float32)
            pts[:, a] = torch.from_numpy(vals)
            xn_axes.append(self._normalise(pts.to(self.device)))           # elementwise per axis
        nb = cfg.oneblob_bins
        pe_axes = [oneblob(xn_axes[a], nb, self.native, self.grid_threads)[:, a * nb:(a + 1) * nb]
                   for a in range(3)]
        xn_axes = [xn_axes[a][:, a] for a in range(3)]
        nx, ny, nz = shape
        out = np.empty(shape, dtype=np.float32)
        # batches of about GRID_BATCH points: whole x-slabs, or rows of y within one slab, so the
        # OneBlob codes and grid features of a batch stay in the cache between the two kernels
        target = min(cfg.chunk, GRID_BATCH)
        rows = max(1, target // (ny * nz))  # x-slabs per batch
        cols = ny if rows > 1 or ny * nz <= target else max(1, target // nz)  # y-rows per batch
        # the C kernels: the hash grid straight from the per-axis coordinates (hash_fwd_grid,
        # bit for bit hash_fwd's on the gathered points, without gathering them)
        by_axes = self.grid_native and self.device.type == "cpu"
        for i0 in range(0, nx, rows):
            i1 = min(i0 + rows, nx)
            for j0 in range(0, ny, cols):
                j1 = min(j0 + cols, ny)
                n = (i1 - i0) * (j1 - j0) * nz
                pe = torch.empty(i1 - i0, j1 - j0, nz, 3 * nb, dtype=torch.float32, device=self.device)
                pe[..., :nb] = pe_axes[0][i0:i1, None, None, :]
                pe[..., nb:2 * nb] = pe_axes[1][j0:j1, None, :][None]
                pe[..., 2 * nb:] = pe_axes[2][None, None, :, :]
                if by_axes:
                    feats = encode_grid((xn_axes[0][i0:i1], xn_axes[1][j0:j1], xn_axes[2]), self._theta, self.spec,
                                        threads=self.grid_threads)
                    sdf = self._sdf_from_feats(feats, pe.reshape(n, 3 * nb))
                else:
                    # every (i, j, k) of the batch in C order, by broadcast copies (no index arithmetic)
                    xn = torch.empty(i1 - i0, j1 - j0, nz, 3, dtype=torch.float32, device=self.device)
                    xn[..., 0] = xn_axes[0][i0:i1, None, None]
                    xn[..., 1] = xn_axes[1][None, j0:j1, None]
                    xn[..., 2] = xn_axes[2][None, None, :]
                    sdf = self._sdf_units(xn.reshape(n, 3), pe.reshape(n, 3 * nb))
                out[i0:i1, j0:j1] = (sdf * cfg.truncation).cpu().numpy().reshape(i1 - i0, j1 - j0, nz)
        return out

    def _query_points(self, points: np.ndarray | torch.Tensor) -> torch.Tensor:
        pts = torch.as_tensor(np.asarray(points, dtype=np.float32) if not torch.is_tensor(points)
                              else points, dtype=torch.float32)
        if pts.ndim != 2 or pts.shape[1] != 3:
            raise ValueError(f"map queries expect points of shape (N, 3) in metres; got "
                             f"{tuple(pts.shape)}.")
        return pts

    @_on_map_threads
    @torch.no_grad()
    def sdf_and_color(self, points: np.ndarray | torch.Tensor) -> tuple[np.ndarray, np.ndarray]:
        """SDF in metres (N,) and colour (N, 3) in [0, 1] at world points (N, 3) m,
        chunked, without gradients (for mesh extraction). Returns float32 numpy arrays."""
        pts = self._query_points(points)
        sdf_out = np.empty(pts.shape[0], dtype=np.float32)
        rgb_out = np.empty((pts.shape[0], 3), dtype=np.float32)
        for s in range(0, pts.shape[0], self.cfg.chunk):
            p = pts[s: s + self.cfg.chunk].to(self.device)
            sdf, raw = self._field(self._normalise(p))
            sdf_out[s: s + p.shape[0]] = (sdf * self.cfg.truncation).cpu().numpy()
            rgb_out[s: s + p.shape[0]] = torch.sigmoid(raw).cpu().numpy()
        return sdf_out, rgb_out

    @_on_map_threads
    @torch.no_grad()
    def render_depth(self, c2w: np.ndarray, K: Intrinsics, stride: int = 1) -> np.ndarray:
        """Rendered depth (H, W) in metres of a view (every ``stride``-th pixel), with
        ``render_samples`` uniform samples in [near, far] per ray and Co-SLAM's weights."""
        cfg = self.cfg
        o, d, shape = image_rays(np.asarray(c2w, dtype=np.float64), K, stride)
        S = cfg.render_samples
        per = max(1, cfg.chunk // S)
        out = torch.empty(o.shape[0], dtype=torch.float32)
        z_all = torch.linspace(cfg.near, self.far, S)
        for s in range(0, o.shape[0], per):
            oo, dd = o[s: s + per].to(self.device), d[s: s + per].to(self.device)
            z = z_all.to(self.device).expand(oo.shape[0], S)
            pts = (oo[:, None, :] + dd[:, None, :] * z[..., None]).reshape(-1, 3)
            sdf, _ = self._field(self._normalise(pts))
            w = sdf_weights(sdf.reshape(-1, S), z, cfg.truncation)
            out[s: s + oo.shape[0]] = (w * z).sum(dim=1).cpu()
        return out.reshape(shape).numpy()

    def frozen_copy(self) -> "NeuralMap":
        """A read-only twin of this map as it is now, for scoring on another thread while this
        one goes on training: its own copies of theta and the visit counts (n float32 / int32)
        and its own decoder kernels (their scratch buffers are per instance); everything else
        (configuration, bounds, generator, ray database) is shared and must not be used to train."""
        twin = copy.copy(self)
        twin._theta = self._theta.detach().clone()
        twin._visits = self._visits.clone()
        kind = self.decoders.backend
        twin.decoders = Decoders(self.decoders.weights(), self.cfg, self.device,
                                 backend=kind if kind in ("c", "torch") else None)
        return twin

    def coarse_level_points_and_visits(self) -> tuple[np.ndarray, np.ndarray]:
        """Vertices of the coarsest level in world metres (N, 3) and their visit counts
        (N,) int64 (max over the level's F features), for the uncertainty picture."""
        xn, rows = vertex_positions(self.spec, 0)
        pts = self.lo.cpu() + xn * self.extent.cpu()
        v = self._visits.view(self.spec.n_levels, self.spec.T, self.spec.features)[0]
        counts = v.cpu()[rows].max(dim=1).values.to(torch.int64)
        return pts.numpy().astype(np.float32), counts.numpy()

    # ------------------------------------------------------------------ state
    def state_dict(self) -> dict[str, torch.Tensor]:
        """Copies of theta, Adam moments and step, visits, bounds and decoder weights."""
        sd = {"theta": self._theta.detach().cpu().clone(), "adam_m": self._m.cpu().clone(),
              "adam_v": self._v.cpu().clone(), "adam_step": torch.tensor(self._step),
              "visits": self._visits.cpu().clone(),
              "bounds": torch.stack([self.lo, self.hi]).cpu()}
        for k, w in self.decoders.weights().items():
            sd["decoder." + k] = w.cpu()
        return sd

    def load_state_dict(self, sd: dict[str, torch.Tensor]) -> None:
        """Restore what ``state_dict`` wrote (same configuration)."""
        for key, dst in (("theta", self._theta), ("adam_m", self._m), ("adam_v", self._v),
                         ("visits", self._visits)):
            src = sd[key]
            if src.shape != dst.shape:
                raise ValueError(f"Map state {key!r} has shape {tuple(src.shape)} but this map "
                                 f"needs {tuple(dst.shape)}; the configuration differs.")
            dst.copy_(src.to(dst.device))
        self._step = int(sd["adam_step"])
        with torch.no_grad():
            for k in KEYS:
                if "decoder." + k in sd:
                    self.decoders.params[k].copy_(sd["decoder." + k])

    def memory_bytes(self) -> dict[str, int]:
        """Bytes of theta, the Adam state (m, v), the visits, the gradient buffer and
        the keyframe ray database."""
        es = self._theta.element_size()
        return {"theta": self._theta.numel() * es, "optimizer": 2 * self._m.numel() * es,
                "visits": self._visits.numel() * self._visits.element_size(),
                "grad": self._grad.numel() * es,
                "keyframes": self.keyframes.rows().numel() * 4}
