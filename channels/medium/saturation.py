"""n saturated stations on the project's own DCF (``channels/medium/dcf.py``): the experiment
that Bianchi's model (``channels/medium/bianchi.py``) predicts, run by the very code the runs use.

Every station always has a frame of ``payload_bits`` for the next station, every station hears
every other, nothing is lost but to collisions, there is no retry limit (unless one is given).
After ``warmup_s`` the counters are read for ``duration_s``:

    throughput            = (payload bits decoded / rate) / duration_s            (S-1)
    collision_probability = failed exchanges / exchanges started                  (S-2)

(an exchange starts with an RTS, or with the DATA frame in basic access). Defaults are
Bianchi's Table II (FHSS, 1 Mbit/s).
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from ramensim.channels.medium.bianchi import durations, saturation
from ramensim.channels.medium.clock import NS, EventClock, to_ns
from ramensim.channels.medium.dcf import Dcf, DcfParams, Frame


@dataclass(frozen=True)
class SaturationSetup:
    """One saturation experiment; times in microseconds, sizes in bits (Bianchi's Table II)."""

    stations: int = 10
    rts_cts: bool = False
    cw_min: int = 32
    max_stage: int = 5
    payload_bits: int = 8184
    mac_header_bits: int = 272
    phy_header_bits: int = 128
    ack_bits: int = 112
    rts_bits: int = 160
    cts_bits: int = 112
    bitrate_mbps: float = 1.0
    prop_us: float = 1.0
    slot_us: float = 50.0
    sifs_us: float = 28.0
    difs_us: float = 128.0
    retry_limit: int | None = None
    duration_s: float = 200.0
    warmup_s: float = 5.0
    seed: int = 0

    def __post_init__(self) -> None:
        problems = []
        if self.stations < 1:
            problems.append(f"--stations {self.stations}: expected at least 1 station")
        if self.cw_min < 1 or self.cw_min & (self.cw_min - 1):
            problems.append(f"--cw-min {self.cw_min}: expected a power of two >= 1 (slots)")
        if not 0 <= self.max_stage <= 16:
            problems.append(f"--max-stage {self.max_stage}: expected 0 to 16 doublings")
        if self.payload_bits < 8 or self.payload_bits % 8:
            problems.append(f"--payload-bits {self.payload_bits}: expected a positive whole number of bytes (bits)")
        if not self.bitrate_mbps > 0:
            problems.append(f"--bitrate-mbps {self.bitrate_mbps}: expected > 0")
        if not (self.slot_us > 0 and self.prop_us > 0 and self.sifs_us >= 0 and self.difs_us > self.sifs_us):
            problems.append("timing: expected --slot-us > 0, --prop-us > 0 and --difs-us > --sifs-us >= 0")
        if not (self.duration_s > 0 and self.warmup_s >= 0):
            problems.append(f"--duration {self.duration_s}: expected > 0 seconds (and a warm-up >= 0)")
        if problems:
            raise ValueError("medium saturation: " + "; ".join(problems) + ".")

    @property
    def rate_bps(self) -> float:
        return self.bitrate_mbps * 1e6

    def params(self) -> DcfParams:
        us = 1000
        rate = self.rate_bps
        return DcfParams(rate_bps=rate, slot_ns=round(self.slot_us * us), sifs_ns=round(self.sifs_us * us),
                         difs_ns=round(self.difs_us * us), prop_ns=round(self.prop_us * us),
                         phy_ns=int(np.ceil(self.phy_header_bits * NS / rate)),
                         mac_header_bits=self.mac_header_bits, ack_bits=self.ack_bits, rts_bits=self.rts_bits,
                         cts_bits=self.cts_bits, cw_min=self.cw_min, max_stage=self.max_stage,
                         retry_limit=self.retry_limit, rts_cts=self.rts_cts)


@dataclass
class SaturationResult:
    throughput: float
    """Eq. S-1: payload airtime decoded per second of the window."""
    collision_probability: float
    """Eq. S-2."""
    model_throughput: float
    """Bianchi's S (eq. B-3) for the same setup (retry limit ignored)."""
    model_collision_probability: float
    """Bianchi's p (eq. B-2)."""
    exchanges: int
    dropped_frames: int
    """Frames given up after ``retry_limit`` retransmissions (0 without a limit)."""
    events: int
    setup: dict = field(default_factory=dict)

    def as_dict(self) -> dict:
        return asdict(self)


def model(setup: SaturationSetup) -> tuple[float, float]:
    """(S, p) of Bianchi's model for ``setup``."""
    rate = setup.rate_bps
    payload, ts, tc = durations(rts_cts=setup.rts_cts, payload_bits=setup.payload_bits,
                                mac_header_bits=setup.mac_header_bits, phy_header_s=setup.phy_header_bits / rate,
                                ack_bits=setup.ack_bits, rts_bits=setup.rts_bits, cts_bits=setup.cts_bits,
                                rate_bps=rate, sifs_s=setup.sifs_us * 1e-6, difs_s=setup.difs_us * 1e-6,
                                prop_s=setup.prop_us * 1e-6)
    r = saturation(setup.stations, setup.cw_min, setup.max_stage, payload, ts, tc, setup.slot_us * 1e-6)
    return r.throughput, r.collision_probability


def simulate(setup: SaturationSetup) -> SaturationResult:
    """Run the saturation experiment of the module docstring on the DCF."""
    n = setup.stations
    clock = EventClock()
    rngs = np.random.default_rng(setup.seed).spawn(n)
    others = [tuple(j for j in range(n) if j != i) for i in range(n)]
    payload_bytes = setup.payload_bits // 8
    dcf: Dcf

    def refill(frame: Frame, _t: int, _out: dict[int, int]) -> None:
        i = frame.src
        dcf.push(i, Frame(i, ((i + 1) % n,), payload_bytes, False))

    dcf = Dcf(clock, n, setup.params(), rngs, lambda i, _t: others[i], refill)
    for i in range(n):
        dcf.push(i, Frame(i, ((i + 1) % n,), payload_bytes, False))
    t_warm, t_end = to_ns(setup.warmup_s), to_ns(setup.warmup_s + setup.duration_s)
    clock.run(t_warm)
    base = [(s.attempts, s.failures, s.delivered_bits, s.drops) for s in dcf.st]
    clock.run(t_end)
    attempts = sum(s.attempts - b[0] for s, b in zip(dcf.st, base))
    failures = sum(s.failures - b[1] for s, b in zip(dcf.st, base))
    bits = sum(s.delivered_bits - b[2] for s, b in zip(dcf.st, base))
    drops = sum(s.drops - b[3] for s, b in zip(dcf.st, base))
    s_model, p_model = model(setup)
    return SaturationResult(
        throughput=bits / setup.rate_bps / setup.duration_s,
        collision_probability=failures / attempts if attempts else 0.0,
        model_throughput=s_model, model_collision_probability=p_model,
        exchanges=attempts, dropped_frames=drops, events=clock.events, setup=asdict(setup))
