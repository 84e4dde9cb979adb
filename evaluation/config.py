"""Settings of mesh extraction and the paper's metrics (docs/ALGORITHM.md section 5)."""
from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator


class PeriodicExtraction(BaseModel):
    """How the periodic evaluations (every ``evaluation.every_s``) extract a map's mesh; the final
    evaluation always queries the full grid (the paper's protocol)."""

    model_config = ConfigDict(extra="forbid", use_attribute_docstrings=True)

    extraction: Literal["dense", "narrow_band"] = "narrow_band"
    """narrow_band (default): the SDF on a grid coarse_factor times coarser, then on the fine grid only in the coarse cells near the surface (a sign change or a value within band_m of the level, dilated by dilate cells, grown until the band's edge agrees with the sign kept outside it); elsewhere each grid point keeps the sign of its coarse cell, so marching cubes gives no surface there (ramensim.evaluation.mesh.NarrowBand; at most 0.06 completion points per robot from dense over the set measured in docs/BENCHMARKS.md, 'Evaluation cost'); dense: the SDF on every point of the marching-cubes grid, as the final evaluation always does."""
    coarse_factor: int = Field(2, ge=2, le=16)
    """Coarse grid spacing of narrow_band in fine voxels (count)."""
    band_m: float = Field(0.03, ge=0.0, le=1.0)
    """narrow_band: a coarse cell is refined when a corner's SDF is within this many metres of the level, besides a sign change across its corners (m)."""
    dilate: int = Field(0, ge=0, le=8)
    """narrow_band: refined coarse cells grown by this many cells in every direction (count)."""
    voxel_m: float | None = Field(None, gt=0.0, le=1.0)
    """Marching-cubes grid spacing of the periodic evaluations in metres; None = evaluation.voxel_m, the final's (m)."""
    robots: int | None = Field(None, ge=1)
    """Score only this many robots' maps at each periodic evaluation, in turn (a window of that many maps, in map order, that moves on by as many at every evaluation and wraps around), so that a large team's curves cost robots / team size of every map's; None (default) = every map. Each robot then has a point every ceil(team / robots) evaluations, and a timeline entry's team mean is over the robots scored at that time (a sample of the team, not the team); the collapse rule sees a robot only when it is scored, and its latest mesh file is replaced only then. The final evaluation always scores every map (count)."""
    skip_unseen: bool = True
    """narrow_band with culling (evaluation.cull not none): refine the band only in blocks of 4 x 4 x 4 coarse cells that some camera so far may have seen (a conservative frustum and occlusion bound, ramensim.evaluation.cull.SeenBlocks); elsewhere the SDF is not queried and the coarse sign is kept, and whatever surface that makes there the culling drops: the culled mesh keeps the same faces (the metrics of every run measured equal to the last digit), only the uncut mesh's n_faces_mesh moves (docs/BENCHMARKS.md, 'Evaluation cost') (bool)."""


class EvalConfig(BaseModel):
    """How maps are turned into meshes and scored (NICE-SLAM protocol, paper section V)."""

    model_config = ConfigDict(extra="forbid", use_attribute_docstrings=True)

    voxel_m: float = Field(0.02, gt=0.0, le=1.0)
    """Marching-cubes grid spacing in metres (0.02 for Replica-size rooms, 0.03 for ScanNet)."""
    chunk_points: int = Field(65_536, ge=1_024, le=16_777_216)
    """Points per SDF/colour query while extracting a mesh (count); bounds peak memory."""
    mask_unobserved: bool = False
    """If true, a map's mesh keeps only the space its frames observed (the NICE-SLAM / Co-SLAM mask): cells of a 10-cm grid outside every frame's frustum, or deeper than its depth image, produce no faces (bool; ramensim/scoring.py, Evaluator.observed_fn)."""
    cull: Literal["none", "frustum", "frustum_occlusion"] = "none"
    """Cull both meshes to the camera frusta before scoring (none | frustum | frustum_occlusion)."""
    near_m: float = Field(0.0, ge=0.0)
    """Near plane of the culling frusta in metres."""
    far_m: float = Field(1.0e6, gt=0.0)
    """Far plane of the culling frusta in metres (very large = unbounded)."""
    occlusion_eps_m: float = Field(0.03, ge=0.0, le=1.0)
    """Depth tolerance of the occlusion test in metres: a point up to this far behind the rendered surface still counts as seen."""
    occlusion_stride_px: int = Field(4, ge=1, le=64)
    """Pixel stride of the depth images rendered for the occlusion test (pixels; 1 = full resolution)."""
    cull_max_edge_m: float | None = Field(0.1, gt=0.0)
    """Before culling, split mesh faces longer than this (m) so that culling follows what the cameras saw on coarse meshes; None = cull faces as given."""
    n_samples: int = Field(200_000, ge=1_000, le=100_000_000)
    """Points sampled on each mesh for the metrics (count; the paper uses 200,000)."""
    threshold_m: float = Field(0.05, gt=0.0, le=10.0)
    """Completion-ratio distance threshold in metres (the paper uses 0.05)."""
    seed: int = Field(0, ge=0)
    """Seed of the surface-sampling generator (integer)."""
    every_s: float | None = Field(30.0, gt=0.0)
    """Evaluate every agent's map every this many simulated seconds, so the metrics are plotted over time in the recording and metrics.json's timeline (cost measured in docs/RECORDING.md); None = only at the end (s)."""
    consensus_every_s: float | None = Field(2.0, gt=0.0)
    """Record the consensus error between the agents' maps (and the maps' RMS) every this many simulated seconds, a cheap probe with no mesh; None = only at the end (s)."""
    periodic: PeriodicExtraction = Field(default_factory=PeriodicExtraction)
    """How the periodic evaluations extract the maps' meshes (``extraction: narrow_band | dense``, default narrow_band); the final evaluation is always dense."""
    extraction: Literal["dense"] = "dense"
    """The final evaluation's extraction: always dense (the full grid, the paper's protocol); an approximation belongs to ``evaluation.periodic.extraction``."""
    export_mesh: bool = True
    """Write each agent's final mesh as PLY into the run folder (bool)."""

    @field_validator("extraction", mode="before")
    @classmethod
    def _final_is_exact(cls, value: object) -> object:
        if value != "dense":
            raise ValueError(
                f"evaluation.extraction: {value!r} would make the final evaluation inexact; it is always "
                f"'dense', the exact protocol (the SDF on every grid point). For cheaper curves set "
                f"evaluation.periodic.extraction: narrow_band (periodic evaluations only)")
        return value
