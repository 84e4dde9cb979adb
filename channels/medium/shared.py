"""The shared medium inside a run: the channel's messages as jobs of frames on one air.

``Channel.send`` decides what it always decided at send time (the edge, the window, the range,
the queue, the message's loss coin and latency: ``channels/fate.py``) and hands the message to
``SharedMedium.submit``. Each radio serves its messages first in, first out, one job at a time:

* a job is one message, or with ``delivery: broadcast`` every message its robot sent at one
  instant with one stamp (one transmission that all of them hear, its size the largest);
* with ``access: dcf`` a job of B = nbytes + ``channel.header_bytes`` bytes goes out as
  ceil(B / (max_frame_bytes - mac_header_bytes)) frames, each contending on its own; with
  ``access: fair`` as one fluid frame of B bytes (a radio alone on the air then takes exactly
  the time a private link takes);
* the job ends when its last frame ends, or for a receiver as soon as one of its frames fails:
  ``collision`` (a broadcast frame collided at it), ``retry_limit`` (a unicast frame was given up)
  or ``out_of_range`` (it did not hear the sender).

The channel then applies the message's loss coin and latency to what got through.
``summary`` reports per radio and per collision domain how busy the air was.
"""
from __future__ import annotations

from collections import deque
from typing import Any, Callable

import numpy as np
import simpy
from simpy.events import Timeout

from ramensim.channels.config import ChannelConfig
from ramensim.channels.medium.clock import NS, SimpyClock
from ramensim.channels.medium.dcf import COLLIDED, DROPPED_RETRY, LOST, OK, UNHEARD, Dcf, DcfParams, Frame, StateHook
from ramensim.channels.medium.fair import Fair
from ramensim.channels.medium.hearing import Hearing, Position
from ramensim.channels.pathloss import FirstHit
from ramensim.core.events import Fate

_FATE_OF = {OK: 0, COLLIDED: int(Fate.COLLISION), DROPPED_RETRY: int(Fate.RETRY_LIMIT),
            UNHEARD: int(Fate.OUT_OF_RANGE), LOST: int(Fate.LOSS)}

JobDone = Callable[[Any, float, float, int, int, int, int], None]
"""``done(msg, t_start_s, t_end_s, fate, wire_bytes, frames, retries)`` for each message of a job."""


class _Job:
    __slots__ = ("src", "msgs", "stamp", "t_sent", "nbytes", "left", "alive", "fate", "frames", "retries", "wire",
                 "t_start_ns", "p_ok")

    def __init__(self, src: int, msg: Any, nbytes: int) -> None:
        self.src = src
        self.msgs: dict[int, Any] = {msg.dst: msg}
        self.stamp = msg.stamp
        self.t_sent = msg.t_sent
        self.nbytes = nbytes
        self.left = 0
        self.alive: list[int] = []
        self.fate: dict[int, int] = {}
        self.frames = 0
        self.retries = 0
        self.wire = 0
        self.t_start_ns = -1
        self.p_ok = 1.0
        """Success probability of each of its frames (``loss: frame``), else 1."""


class SharedMedium:
    """One air for ``n`` radios (``channel.medium``); see the module docstring."""

    def __init__(self, env: simpy.Environment, cfg: ChannelConfig, n: int, rng: np.random.Generator,
                 position: Position | None, first_hit: FirstHit | None, done: JobDone,
                 hook: StateHook | None = None) -> None:
        mc = cfg.medium
        self.cfg = cfg
        self.n = n
        self.clock = SimpyClock(env)
        self.hearing = Hearing(mc, n, position, cfg.path_loss, first_hit)
        self._done = done
        self._broadcast = mc.delivery == "broadcast"
        self.access = mc.access
        if mc.access == "dcf":
            self._per_frame = mc.max_frame_bytes - mc.mac_header_bytes
            station_rngs = rng.spawn(n + 1)
            self.engine: Dcf | Fair = Dcf(self.clock, n, dcf_params(cfg), station_rngs[:n], self.hearing.listeners,
                                          self._frame_done, hook, loss_rng=station_rngs[n])
        else:
            self._per_frame = 1 << 62
            self.engine = Fair(self.clock, n, cfg.bandwidth_bps, self.hearing, self._frame_done, hook)
        self._mac_header = mc.mac_header_bytes if mc.access == "dcf" else 0
        self._waiting: list[deque[_Job]] = [deque() for _ in range(n)]
        self._current: list[_Job | None] = [None] * n
        self._flush_armed = False
        self.jobs = 0

    # -- from the channel ---------------------------------------------------------------------------

    def waiting_jobs(self, src: int) -> list[_Job]:
        """The jobs queued at ``src`` behind the one on the air (for a radio model's ``ChannelState``)."""
        self.clock.sync()
        return list(self._waiting[src])

    def senses_busy(self, src: int) -> bool:
        """Whether ``src``'s radio senses the air busy now (DCF: carrier sense and NAV; fair: a
        sender it hears, itself included, is active)."""
        self.clock.sync()
        eng = self.engine
        if isinstance(eng, Dcf):
            return bool(eng.st[src].busy)
        return eng.busy(src)

    def accepts(self, msg: Any, queue_limit: int) -> bool:
        """Whether ``msg`` finds room at its sender: it joins a broadcast of this instant, or the
        radio is idle, or fewer than ``queue_limit`` jobs wait behind the one it serves (a job
        submitted at this instant and not yet started counts as the one served)."""
        self.clock.sync()
        q = self._waiting[msg.src]
        if self._joins(q, msg):
            return True
        queued = len(q) - (1 if self._current[msg.src] is None and q else 0)
        return queued < queue_limit if (self._current[msg.src] is not None or q) else True

    def _joins(self, q: deque[_Job], msg: Any) -> bool:
        last = q[-1] if q else None
        return (self._broadcast and last is not None and last.stamp == msg.stamp and last.t_sent == msg.t_sent
                and msg.dst not in last.msgs)

    def submit(self, msg: Any, wire_bytes: int, p_frame: float = 1.0) -> None:
        """Queue ``msg`` (``wire_bytes`` on the air, headers included) at its sender, now; each of
        its frames is kept by a receiver that decodes it with probability ``p_frame``."""
        self.clock.sync()
        q = self._waiting[msg.src]
        if self._joins(q, msg):
            last = q[-1]
            last.msgs[msg.dst] = msg
            last.nbytes = max(last.nbytes, wire_bytes)
        else:
            q.append(_Job(msg.src, msg, wire_bytes))
            q[-1].p_ok = p_frame
        if not self._flush_armed:  # after the sending process's step: its sends of this instant gather first
            self._flush_armed = True
            Timeout(self.clock.env, 0.0).callbacks.append(self._flush)

    def _flush(self, _ev: Any = None) -> None:
        self._flush_armed = False
        self.clock.sync()
        for i in range(self.n):
            if self._current[i] is None:
                self._start_next(i)
        self.clock.sync()

    # -- jobs and frames ------------------------------------------------------------------------------

    def _start_next(self, i: int) -> None:
        q = self._waiting[i]
        if self._current[i] is not None or not q:
            return
        job = self._current[i] = q.popleft()
        self.jobs += 1
        job.alive = sorted(job.msgs)
        job.left = job.nbytes
        self._push_frame(job)

    def _push_frame(self, job: _Job) -> None:
        size = min(job.left, self._per_frame)
        job.left -= size
        job.frames += 1
        self.engine.push(job.src, Frame(job.src, tuple(job.alive), size, self._broadcast, job, job.p_ok))

    def _frame_done(self, frame: Frame, t_ns: int, outcome: dict[int, int]) -> None:
        job = frame.job
        assert isinstance(job, _Job)
        if job.t_start_ns < 0:
            job.t_start_ns = frame.t_first_ns
        job.retries += frame.retries
        job.wire += (frame.payload_bytes + self._mac_header) * (frame.retries + 1)
        for d, res in outcome.items():
            if res != OK:
                job.fate[d] = _FATE_OF[res]
        job.alive = [d for d in job.alive if outcome.get(d) == OK]
        if job.alive and job.left > 0:
            self._push_frame(job)
            return
        self._finish(job, t_ns)
        self._current[job.src] = None
        self._start_next(job.src)

    def _finish(self, job: _Job, t_ns: int) -> None:
        t_end = t_ns / NS
        t_start = job.t_start_ns / NS
        share, extra = divmod(job.wire, len(job.msgs))
        for k, d in enumerate(sorted(job.msgs)):
            self._done(job.msgs[d], t_start, t_end, job.fate.get(d, 0), share + (extra if k == 0 else 0),
                       job.frames, job.retries)

    # -- what a run reports ------------------------------------------------------------------------------

    def summary(self, duration_s: float) -> dict[str, Any]:
        """metrics.json's ``medium``: per radio and per collision domain (the hearing graph's
        components at the end), the share of time the air was sensed busy (<= 1), airtime sent,
        exchanges, failures (collisions and unheard receivers), frames given up, payload decoded."""
        self.clock.sync()
        now = self.clock.now_ns
        self.engine.close(now)
        t = max(duration_s, 1e-12)
        radios = []
        for s in self.engine.st:
            radios.append({
                "radio": s.i, "busy_fraction": s.busy_ns / NS / t, "tx_fraction": s.tx_ns / NS / t,
                "exchanges": s.attempts, "failures": s.failures, "dropped_frames": s.drops,
                "frames_delivered": s.delivered_frames, "bytes_delivered": s.delivered_bits // 8,
            })
        domains = []
        for members in self.hearing.domains(now):
            rs = [radios[i] for i in members]
            domains.append({
                "radios": list(members),
                "busy_fraction": max(r["busy_fraction"] for r in rs),
                "airtime_fraction": sum(r["tx_fraction"] for r in rs),
                "collisions": sum(r["failures"] for r in rs),
                "dropped_frames": sum(r["dropped_frames"] for r in rs),
                "bytes_delivered": sum(r["bytes_delivered"] for r in rs),
            })
        return {"kind": "shared", "access": self.access, "delivery": "broadcast" if self._broadcast else "unicast",
                "duration_s": duration_s, "jobs": self.jobs, "events": self.clock.events,
                "hearing_recomputes": self.hearing.recomputes, "domains": domains, "radios": radios}


def dcf_params(cfg: ChannelConfig) -> DcfParams:
    """The DCF of a run: ``channel.medium``'s timing at ``channel.bandwidth_bps``."""
    mc = cfg.medium
    us = 1000.0
    return DcfParams(rate_bps=cfg.bandwidth_bps, slot_ns=round(mc.slot_us * us), sifs_ns=round(mc.sifs_us * us),
                     difs_ns=round(mc.difs_us * us), prop_ns=max(1, round(mc.propagation_us * us)),
                     phy_ns=round(mc.phy_header_us * us), mac_header_bits=8 * mc.mac_header_bytes,
                     ack_bits=8 * mc.ack_bytes, rts_bits=8 * mc.rts_bytes, cts_bits=8 * mc.cts_bytes,
                     cw_min=mc.cw_min, max_stage=mc.max_stage, retry_limit=mc.retry_limit, rts_cts=mc.rts_cts)
