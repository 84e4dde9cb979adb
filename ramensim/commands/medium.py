"""``ramensim medium``: check the shared medium's DCF against Bianchi's analytic model.

    ramensim medium saturation --stations 20 --access basic --cw-min 32 --max-stage 5 --json

``saturation`` runs n saturated stations that all hear each other on the project's own 802.11
DCF (``channels/medium/dcf.py``, the module every ``channel.medium.access: dcf`` run uses) and
prints the normalised throughput (payload airtime decoded / time) and the collision probability
(the share of exchanges that fail) beside Bianchi's model for the same setup (IEEE JSAC 18(3),
2000; ``channels/medium/bianchi.py``). Defaults are Bianchi's Table II (FHSS, 1 Mbit/s, slot
50 us, SIFS 28 us, DIFS 128 us, payload 8184 bits); docs/RADIO.md has the table of both.
"""
from __future__ import annotations

import argparse
import json
import logging
import sys
import time

from ramensim.core.errors import InputError

log = logging.getLogger(__name__)


def add_parser(subparsers) -> argparse.ArgumentParser:
    """Register ``medium`` and its ``saturation`` subcommand."""
    p = subparsers.add_parser("medium", help="check the shared medium (802.11 DCF) against Bianchi's model",
                              description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = p.add_subparsers(dest="medium_command", required=True)
    s = sub.add_parser("saturation", help="n saturated stations on the DCF: throughput and collision probability")
    s.add_argument("--stations", type=int, default=10, help="stations, all within hearing (default 10)")
    s.add_argument("--access", choices=("basic", "rts-cts"), default="basic", help="basic access or RTS/CTS")
    s.add_argument("--cw-min", type=int, default=32, help="window W at stage 0, slots, a power of two (default 32)")
    s.add_argument("--max-stage", type=int, default=5, help="doublings m of the window (default 5)")
    s.add_argument("--payload-bits", type=int, default=8184, help="payload of every frame, bits (default 8184)")
    s.add_argument("--bitrate-mbps", type=float, default=1.0, help="channel bit rate, Mbit/s (default 1)")
    s.add_argument("--slot-us", type=float, default=50.0, help="slot time, us (default 50)")
    s.add_argument("--sifs-us", type=float, default=28.0, help="SIFS, us (default 28)")
    s.add_argument("--difs-us", type=float, default=128.0, help="DIFS, us (default 128)")
    s.add_argument("--prop-us", type=float, default=1.0, help="propagation delay, us (default 1)")
    s.add_argument("--retry-limit", default="none", help="retransmissions before a frame is dropped, or 'none' "
                                                         "(the model's assumption; default none)")
    s.add_argument("--duration", type=float, default=200.0, help="simulated seconds measured, after a 5-s warm-up "
                                                                 "(default 200)")
    s.add_argument("--seed", type=int, default=0, help="seed of the backoff draws (default 0)")
    s.add_argument("--json", action="store_true", help="print one JSON line instead of a table")
    p.set_defaults(func=run)
    return p


def _retry_limit(text: str) -> int | None:
    if str(text).strip().lower() == "none":
        return None
    try:
        v = int(text)
    except ValueError:
        v = -1
    if v < 0:
        raise InputError(f"ramensim medium saturation: --retry-limit {text!r} is not a count; expected an integer "
                         ">= 0 or 'none' (never give up, as Bianchi's model assumes).")
    return v


def run(args: argparse.Namespace) -> int:
    from ramensim.channels.medium.saturation import SaturationSetup, simulate

    try:
        setup = SaturationSetup(
            stations=args.stations, rts_cts=args.access == "rts-cts", cw_min=args.cw_min, max_stage=args.max_stage,
            payload_bits=args.payload_bits, bitrate_mbps=args.bitrate_mbps, slot_us=args.slot_us,
            sifs_us=args.sifs_us, difs_us=args.difs_us, prop_us=args.prop_us,
            retry_limit=_retry_limit(args.retry_limit), duration_s=args.duration, seed=args.seed)
    except ValueError as exc:
        raise InputError(str(exc)) from None
    t0 = time.perf_counter()
    r = simulate(setup)
    wall = time.perf_counter() - t0
    out = {"stations": setup.stations, "access": args.access, "cw_min": setup.cw_min,
           "max_stage": setup.max_stage, "throughput": r.throughput,
           "collision_probability": r.collision_probability, "model_throughput": r.model_throughput,
           "model_collision_probability": r.model_collision_probability, "exchanges": r.exchanges,
           "events": r.events, "duration_s": setup.duration_s, "seed": setup.seed, "wall_s": round(wall, 3)}
    if args.json:
        sys.stdout.write(json.dumps(out) + "\n")
        return 0
    sys.stdout.write(
        f"{setup.stations} saturated stations, {args.access}, W={setup.cw_min}, m={setup.max_stage}, "
        f"{setup.duration_s:g} s simulated ({r.exchanges} exchanges, {wall:.1f} s wall)\n"
        f"                         simulated   Bianchi's model\n"
        f"  throughput             {r.throughput:9.4f}   {r.model_throughput:9.4f}\n"
        f"  collision probability  {r.collision_probability:9.4f}   {r.model_collision_probability:9.4f}\n")
    return 0
