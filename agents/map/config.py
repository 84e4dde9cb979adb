"""Settings of one agent's neural implicit map (docs/ALGORITHM.md section 1).

The defaults are tuned for a 2-core CPU: fewer rays and samples per iteration and a
smaller hash table than the paper. ``MapConfig.paper()`` (or ``PRESETS["paper"]``) gives
the paper's / Co-SLAM's Replica numbers.
"""
from __future__ import annotations

from typing import Literal

import torch
from pydantic import BaseModel, ConfigDict, Field, model_validator

DEVICE_KEY = "map.device"
"""The scenario key :func:`resolve_device` resolves (named in its error)."""


def resolve_device(name: str | torch.device, check: bool = True) -> torch.device:
    """The torch device of scenario key ``map.device``, resolved once per run
    (``ramensim.sim.scenario_device``) and passed down to every map and method: ``cpu``,
    ``cuda``, or ``auto`` (cuda when torch sees a CUDA device, else cpu). A ``torch.device``
    is returned as it is. ``check``: refuse ``cuda`` when torch sees no CUDA device
    (ValueError naming the key); without it ``cuda`` stays ``cuda`` (a run planned here that
    runs on a GPU elsewhere: the memory estimate of a sweep's points)."""
    if isinstance(name, torch.device):
        return name
    if name == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    if name == "cuda" and check and not torch.cuda.is_available():
        raise ValueError(f"scenario key '{DEVICE_KEY}' has value 'cuda' but torch {torch.__version__} sees no "
                         f"CUDA device on this machine; expected cpu, or auto (cuda when there is one), or a "
                         f"CUDA build of torch and a GPU.")
    if name not in ("cpu", "cuda"):
        raise ValueError(f"scenario key '{DEVICE_KEY}' has value {name!r}; expected cpu, cuda or auto.")
    return torch.device(name)


class MapConfig(BaseModel):
    """Hash grid, decoders, ray sampling, losses and optimiser of the Co-SLAM-style map."""

    model_config = ConfigDict(extra="forbid", use_attribute_docstrings=True)

    device: Literal["cpu", "cuda", "auto"] = "cpu"
    """Torch device for the map: cpu, cuda, or auto (cuda when available, else cpu)."""

    n_levels: int = Field(16, ge=1, le=32)
    """Hash-grid levels L (count); the paper uses 16."""

    features_per_level: int = Field(2, ge=1, le=8)
    """Features F per hash-grid level (count); the paper uses 2."""

    log2_hashmap_size: int = Field(15, ge=8, le=24)
    """log2 of the table size T per level (entries); 15 on CPU (1 M parameters, 4 MB),
    the paper's preset uses 16."""

    base_resolution: int = Field(16, ge=2, le=512)
    """Resolution of the coarsest level (cells per axis); the paper uses 16."""

    voxel_sdf: float = Field(0.02, gt=0.0, le=1.0)
    """Cell size of the finest level in metres; finest resolution R = max_extent / voxel_sdf."""

    oneblob_bins: int = Field(16, ge=2, le=64)
    """OneBlob bins per axis (count); 16 gives 48 positional features."""

    geo_hidden: int = Field(32, ge=1, le=256)
    """Hidden width of the geometry decoder (units); 32 in Co-SLAM."""

    geo_feat_dim: int = Field(15, ge=1, le=64)
    """Geometry feature size h passed to the colour decoder (count); 15 in Co-SLAM."""

    color_hidden: int = Field(32, ge=1, le=256)
    """Hidden width of the colour decoder (units); 32 in Co-SLAM."""

    truncation: float = Field(0.1, gt=0.0, le=1.0)
    """SDF truncation tr in metres; the network's SDF output is in units of tr."""

    n_rays: int = Field(1024, ge=1, le=1_000_000)
    """Rays per mapping iteration (count); 1024 on CPU, the paper uses 2048."""

    n_stratified: int = Field(24, ge=2, le=1024)
    """Stratified samples per ray in [near, far] (count); 24 on CPU, the paper uses 32."""

    n_surface: int = Field(8, ge=0, le=1024)
    """Samples per ray in [D - r, D + r] around the observed depth D (count); 8 on CPU,
    the paper uses 11."""

    surface_range: float = Field(0.1, gt=0.0, le=2.0)
    """Half width r of the near-surface sampling interval in metres."""

    near: float = Field(0.0, ge=0.0)
    """Nearest stratified sample along a ray in metres of camera depth."""

    far: float | None = Field(None, gt=0.0)
    """Farthest stratified sample along a ray in metres of camera depth; None = the diagonal of the scene bounds (so free space is sampled up to every wall)."""

    keyframe_pixel_share: float = Field(0.05, gt=0.0, le=1.0)
    """Share of each keyframe's valid-depth pixels kept in the ray database (fraction)."""

    min_current_rays: int = Field(100, ge=0)
    """Least number of rays drawn from the current frame per iteration (count); the
    current frame gets max(n_rays // n_keyframes, this) rays, as in Co-SLAM."""

    lr: float = Field(0.01, gt=0.0)
    """Adam learning rate on the grid (parameter units per step)."""

    adam_beta1: float = Field(0.9, ge=0.0, lt=1.0)
    """Adam first-moment decay (dimensionless)."""

    adam_beta2: float = Field(0.99, ge=0.0, lt=1.0)
    """Adam second-moment decay (dimensionless)."""

    adam_eps: float = Field(1e-15, gt=0.0)
    """Adam epsilon (parameter-gradient units)."""

    rgb_weight: float = Field(5.0, ge=0.0)
    """Weight of the colour loss (dimensionless)."""

    depth_weight: float = Field(0.1, ge=0.0)
    """Weight of the rendered-depth loss (per m^2)."""

    sdf_weight: float = Field(1000.0, ge=0.0)
    """Weight of the near-surface SDF loss (per m^2)."""

    fs_weight: float = Field(10.0, ge=0.0)
    """Weight of the free-space loss (dimensionless, SDF in truncation units)."""

    smooth_weight: float = Field(1e-6, ge=0.0)
    """Weight of the grid-feature smoothness loss (dimensionless)."""

    smooth_lattice: int = Field(16, ge=2, le=128)
    """Points per axis of the random smoothness lattice (count); 16 on CPU, the paper 32."""

    smooth_spacing: float = Field(0.1, gt=0.0)
    """Spacing of the smoothness lattice in metres."""

    smooth_margin: float = Field(0.05, ge=0.0)
    """Margin in metres kept between the smoothness lattice and the scene bounds."""

    render_samples: int = Field(128, ge=2, le=4096)
    """Uniform samples per ray in [near, far] when rendering a view without depth (count)."""

    chunk: int = Field(65536, ge=1024)
    """Points per chunk for no-grad queries (sdf_and_color, render_depth) (count)."""

    decoders: str | None = None
    """Frozen decoder weights (path to a .pt file written by 'ramensim pretrain-decoders', relative to the scenario file's folder); None = the decoders shipped with ramensim."""

    native: bool = True
    """Use the compiled OpenMP kernels on CPU when they build (falls back to pure torch)."""

    decoder_backend: Literal["auto", "c", "torch"] = "auto"
    """Implementation of the frozen decoders' forward + backward on CPU: 'auto' (the faster one on this machine, measured at first use and cached; `ramensim doctor` shows the choice), 'c' (fused OpenMP kernel) or 'torch' (batched matrix products)."""

    grid_backend: Literal["auto", "c", "torch"] = "auto"
    """Implementation of the hash-grid encoding and its backward on CPU: 'auto' (measured, as decoder_backend), 'c' (OpenMP kernel) or 'torch' (fused all-levels torch path)."""

    objective_backend: Literal["auto", "c", "torch"] = "auto"
    """Implementation of the rendering weights, compositing and observation losses with their gradient on CPU: 'auto' (measured, as decoder_backend), 'c' (one kernel pass per ray, hand-written backward) or 'torch' (torch autograd)."""

    threads: int = Field(0, ge=0, le=1024)
    """Threads of every map stage on CPU (count); 0 = chosen per stage by measurement (1 or torch's thread count, the faster; `ramensim doctor` shows it)."""

    preset: Literal["cpu", "paper"] = "cpu"
    """Named starting point: 'cpu' (these defaults, tuned for a 2-core CPU) or 'paper' (Co-SLAM's Replica settings: 2048 rays, 32 + 11 samples, T = 2^16, 32^3 smoothness lattice); keys given beside it override the preset."""

    @model_validator(mode="before")
    @classmethod
    def _apply_preset(cls, data: object) -> object:
        if isinstance(data, dict) and data.get("preset") == "paper":
            return {**PAPER_SETTINGS, **data}
        return data

    @model_validator(mode="after")
    def _check_range(self) -> "MapConfig":
        if self.far is not None and self.far <= self.near:
            raise ValueError(f"MapConfig: far ({self.far} m) must be greater than near "
                             f"({self.near} m); set map.far above map.near.")
        return self

    @property
    def n_params(self) -> int:
        """Number of shared grid parameters n = L * T * F."""
        return self.n_levels * (1 << self.log2_hashmap_size) * self.features_per_level

    @property
    def samples_per_ray(self) -> int:
        """Samples per training ray (stratified + near-surface)."""
        return self.n_stratified + self.n_surface

    @classmethod
    def paper(cls, **overrides: object) -> "MapConfig":
        """The paper's / Co-SLAM's Replica settings (2048 rays, 32 + 11 samples,
        T = 2^16, 32^3 smoothness lattice)."""
        return cls(**{**overrides, "preset": "paper"})


PAPER_SETTINGS: dict[str, object] = dict(n_rays=2048, n_stratified=32, n_surface=11, log2_hashmap_size=16,
                                         smooth_lattice=32)
"""What the 'paper' preset changes from the CPU defaults."""

PRESETS: dict[str, MapConfig] = {"cpu": MapConfig(), "paper": MapConfig.paper()}
"""Named presets: ``cpu`` (the defaults) and ``paper``."""
