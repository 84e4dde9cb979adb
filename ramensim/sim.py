"""Building one simulation: the composition root of the event loop.

One ``simpy.Environment`` (seconds); per agent a camera, a mapper on its own compute
clock and a radio (``ramensim.agents.process``); one packet-level channel over the topology
graph (``channels``); events fan out on one bus (the Rerun recorder, tests...). Nothing waits
on a barrier. Running it is ``ramensim.lifecycle``'s job, observing it ``ramensim.observe``'s.
"""
from __future__ import annotations

import logging
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import Any, Callable

import numpy as np
import simpy
import torch

from ramensim.agents.consensus import MethodSpec, get_method, make_method
from ramensim.agents.copies import CopyStore
from ramensim.agents.map import NeuralMap, load_decoders
from ramensim.agents.map.config import resolve_device
from ramensim.agents.process import AgentProcess, ClockModel, RadioSchedule
from ramensim.agents.step import ConsensusStep
from ramensim.agents.rounds import Engine, EngineSettings, InlineEngine, engine_settings
from ramensim.channels.channel import Channel
from ramensim.core.frames import FrameFeed
from ramensim.core.events import Event
from ramensim.channels.topology import Topology
from ramensim.core.errors import InputError
from ramensim.divergence import DivergenceRule, DivergenceWatch
from ramensim.schema import Scenario
from ramensim.core.seeding import Seeds
from ramensim.core.alloc import keep_freed_memory
from ramensim.memory import check_memory, lent_vectors
from ramensim.world import World, build_world

log = logging.getLogger(__name__)


class EventBus:
    """Fans every event out to the subscribers (the recorder, tests, ...)."""

    def __init__(self) -> None:
        self.subscribers: list[Callable[[Event], None]] = []

    def __call__(self, event: Event) -> None:
        for sub in self.subscribers:
            sub(event)


@dataclass
class Simulation:
    """A built, not yet run, simulation."""

    scenario: Scenario
    env: simpy.Environment
    world: World
    maps: list[NeuralMap]
    """One map per agent; a single one for a method whose learner merges every camera."""
    steps: list[ConsensusStep]
    processes: list[AgentProcess]
    channel: Channel | None
    bus: EventBus
    seeds: Seeds
    timeline: list[dict[str, Any]] = field(default_factory=list)
    """Periodic evaluations: {t, agent, metrics...}."""
    consensus_timeline: list[dict[str, float]] = field(default_factory=list)
    """Periodic consensus probes: {t, consensus_error, theta_rms}."""
    watch: DivergenceWatch = field(default_factory=DivergenceWatch)
    """The divergence rule beyond non-finite values (loss growth, evaluation collapse)."""
    eval_lane: Any = None
    """The periodic evaluations' own thread (``ramensim.observe.EvaluationLane``), or None: inline."""
    engine: Engine = field(default_factory=InlineEngine)
    """Computes the agents' rounds, at their start or off the event loop (``agents/rounds/``);
    whatever reads the maps reads them through :meth:`settled_maps`."""
    device: torch.device = torch.device("cpu")
    """The maps' torch device, resolved once from ``map.device`` (:func:`scenario_device`)."""
    engine_settings: EngineSettings | None = None
    """The engine's settings as decided once for this run (``agents/rounds/modes.py``): its mode,
    threads, the evaluation lane; the memory guard and the lifecycle read the same answer."""

    def settled_maps(self) -> list[NeuralMap]:
        """The maps with every round started before now in them, as inline: the engine's rounds
        in flight (or pending lockstep batches) settled first. The one way to read the maps'
        values during a run (evaluations, consensus probes, snapshots, the final scores)."""
        self.engine.drain()
        return self.maps

    @property
    def method(self) -> MethodSpec:
        return get_method(self.scenario.method)

    def fed_by(self, k: int) -> list[int]:
        """The robots whose cameras feed map ``k``."""
        return list(range(self.scenario.agents.count)) if self.method.merges_frames else [k]

    @property
    def map_names(self) -> list[str]:
        if self.method.merges_frames:
            return ["central"]
        return [f"agent_{i}" for i in range(len(self.maps))]


def scenario_world(sc: Scenario, base_dir: Path | str | None = None, seeds: Seeds | None = None) -> World:
    """The world of scenario ``sc`` (scene, trajectories, camera), paths relative to ``base_dir``:
    the one composition every run and command uses (a run's, ``ramensim eval``'s, ``world show``'s)."""
    return build_world(sc.world, sc.agents.count, sc.duration, (seeds or Seeds(sc.seed)).numpy,
                       base_dir=None if base_dir is None else Path(base_dir))


def scenario_device(sc: Scenario) -> torch.device:
    """The torch device of ``sc``'s maps (``map.device``; ``auto``: cuda when torch sees one, else
    cpu), resolved once per run and passed down to the maps, the methods and the team engine.
    InputError naming the key for ``cuda`` where torch sees no CUDA device."""
    try:
        return resolve_device(sc.map.device)
    except ValueError as exc:
        raise InputError(str(exc)) from None


def build_simulation(sc: Scenario, base_dir: Path | None = None) -> Simulation:
    """Compose world, maps, methods, channel and processes for ``sc``."""
    keep_freed_memory()  # no page faults per mapping iteration (core/alloc.py)
    device = scenario_device(sc)
    seeds = Seeds(sc.seed)
    n = sc.agents.count
    world = scenario_world(sc, base_dir, seeds)
    env = simpy.Environment()
    bus = EventBus()
    spec = get_method(sc.method)
    try:
        topology = Topology(sc.topology, n, position=world.position)
    except ValueError as exc:
        raise InputError(f"scenario: {exc}") from None
    channel: Channel | None = None
    if spec.communicates:
        try:
            channel_seeds = seeds if sc.channel.seed is None else Seeds(sc.channel.seed)
            channel = Channel(env, sc.channel, topology, n, channel_seeds.numpy("channel"),
                              position=world.position, emit=bus, first_hit=_first_hit(sc, world), base_dir=base_dir)
        except ValueError as exc:
            raise InputError(f"scenario: {exc}") from None
    decoders = _decoders(sc.map.decoders, base_dir)
    feeds = [world.frame_feed(k) for k in range(n)]
    if spec.merges_frames:
        feeds = [FrameFeed.merged(feeds)]
    # Every agent draws its initial table from the same seed: a shared Theta_init (paper, Alg. 1).
    maps = [NeuralMap(world.bounds, sc.map, decoders, seeds.torch("map/init"), seeds.torch(f"map/samples/{k}"),
                      device=device)
            for k in range(len(feeds))]
    settings = _engine_settings(len(maps), device)
    # before the agents and their per-neighbour state: refuse what the machine cannot hold
    check_memory(sc, maps[0].n_params, len(maps), topology, spec.memory_vectors,
                 lent=lent_vectors(spec, len(maps), device, settings))
    theta0 = maps[0].theta.detach().cpu().clone()  # on the host, as the messages' encoding
    engine = _engine(settings, maps)
    steps: list[ConsensusStep] = []
    processes: list[AgentProcess] = []
    for k, (feed, learner) in enumerate(zip(feeds, maps)):
        step, proc = build_agent(sc, k, env, learner, feed, theta0, channel, topology, seeds, bus, engine,
                                 device)
        steps.append(step)
        processes.append(proc)
    mc = sc.map
    watch = DivergenceWatch(DivergenceRule(loss_weight_sum=mc.rgb_weight + mc.depth_weight + mc.sdf_weight
                                           + mc.fs_weight + mc.smooth_weight))
    return Simulation(sc, env, world, maps, steps, processes, channel, bus, seeds, watch=watch, engine=engine,
                      device=device, engine_settings=settings)


def _engine_settings(n_maps: int, device: torch.device) -> EngineSettings:
    """The team engine's settings for ``n_maps`` maps on ``device`` (``agents/rounds/modes.py``,
    from the environment); InputError naming the variable for a bad value."""
    try:
        return engine_settings(n_maps, device)
    except ValueError as exc:
        raise InputError(str(exc)) from None


def _engine(settings: EngineSettings, maps: list[NeuralMap]) -> Engine:
    """The engine ``settings`` chose for ``maps``; InputError when the maps cannot run it (the
    mode's own paragraph: lockstep batches need the maps on the torch path)."""
    try:
        return settings.make(maps)
    except ValueError as exc:
        raise InputError(str(exc)) from None


def _first_hit(sc: Scenario, world: World) -> Callable[[np.ndarray, np.ndarray], np.ndarray] | None:
    """The scene's first-hit distance (m) along rays, for the channel to count the walls between
    two robots (``channel.path_loss``); None when walls do not matter or there is no scene mesh."""
    pl = sc.channel.path_loss
    if not pl.enabled or pl.wall_loss_db <= 0.0 or world.scene is None:
        return None
    from ramensim.world import MeshRayCaster

    caster = world.camera.caster if world.camera is not None else MeshRayCaster(world.scene.mesh, threads=1)
    return lambda origins, directions: caster.cast(origins, directions)[0]


def _decoders(path: str | None, base_dir: Path | None) -> dict[str, torch.Tensor]:
    """The frozen decoders of scenario key ``map.decoders`` (relative to ``base_dir``), or the
    shipped ones when it is None."""
    if path is None:
        return load_decoders()
    p = Path(path).expanduser()
    if not p.is_absolute() and base_dir is not None:
        p = base_dir / p
    try:
        weights = load_decoders(p)
    except (OSError, ValueError) as exc:
        raise InputError(f"scenario key 'map.decoders' has value {path!r}: {exc}") from None
    log.info("decoders: %s", p)
    return weights


def build_agent(sc: Scenario, k: int, env: simpy.Environment, learner: NeuralMap, feed: FrameFeed,
                theta0: torch.Tensor, channel: Channel | None, topology: Topology, seeds: Seeds,
                emit: Callable[[Event], None],
                engine: Engine | None = None,
                device: torch.device | None = None) -> tuple[ConsensusStep, AgentProcess]:
    """Agent ``k``: its method (from the registry), neighbour copies, mapper step, compute
    clock and SimPy processes, fed by ``feed`` and attached to ``channel`` (None: it never
    communicates); its rounds computed by ``engine`` (None: inline); the method's state on
    ``device`` (the run's, :func:`scenario_device`; None: the learner's)."""
    for key, value in get_method(sc.method).learner_settings(sc.consensus).items():
        setattr(learner, key, value)
    neighbours = topology.neighbours(k) if channel is not None else []
    method = make_method(sc.method, sc.consensus, learner.n_params, degree=len(neighbours), agent=k,
                         device=learner.theta.device if device is None else device)
    degree = partial(_degree, channel, k)
    step = ConsensusStep(k, learner, method, CopyStore(k, neighbours), sc.consensus.encoding, theta0, degree,
                         sc.consensus.stale_policy, sc.consensus.max_age_s,
                         first_round_steps=sc.consensus.first_round_steps, wire=sc.consensus.wire)
    if channel is not None:
        channel.attach(k, partial(_deliver, step, env))
    comp = sc.agents.compute
    clock = ClockModel(comp.seconds_per_iteration, sc.agents.speed(k), comp.jitter, comp.mode == "wall",
                       start_delay=sc.agents.start_delay(k), rng=seeds.numpy(f"clock/{k}"))
    proc = AgentProcess(env, k, step, feed, clock, radio=channel,
                        schedule=RadioSchedule(sc.radio.mode, sc.radio.period_s), emit=emit, engine=engine,
                        on_error=sc.run.on_robot_error)
    return step, proc


def _degree(channel: Channel | None, k: int) -> int:
    return len(channel.neighbours(k)) if channel is not None else 0


def _deliver(step: ConsensusStep, env: simpy.Environment, msg: Any) -> None:
    step.receive(msg.src, msg.payload, msg.stamp, env.now)
