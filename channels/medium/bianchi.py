"""Bianchi's analytic model of 802.11 DCF saturation throughput (IEEE JSAC 18(3), 2000).

n stations that always have a frame, all within hearing, an ideal channel, backoff window W at
stage 0 doubling up to stage m, no retry limit. The probability tau that a station transmits in
a randomly chosen slot and the conditional collision probability p solve (eq. 7 and 9 of the
paper, the fixed point solved here by bisection on p)

    tau = 2 (1 - 2p) / ((1 - 2p)(W + 1) + p W (1 - (2p)^m))                      (B-1)
    p   = 1 - (1 - tau)^(n - 1)                                                  (B-2)

and the normalised throughput (payload airtime over time, eq. 13) is

    P_tr = 1 - (1 - tau)^n,   P_s = n tau (1 - tau)^(n - 1) / P_tr
    S    = P_s P_tr E[P] / ((1 - P_tr) sigma + P_tr P_s T_s + P_tr (1 - P_s) T_c)  (B-3)

with, for basic access and for RTS/CTS (H = PHY + MAC header, delta the propagation delay):

    T_s = H + E[P] + SIFS + delta + ACK + DIFS + delta,  T_c = H + E[P*] + DIFS + delta   (basic)
    T_s = RTS + SIFS + delta + CTS + SIFS + delta + H + E[P] + SIFS + delta + ACK + DIFS + delta,
    T_c = RTS + DIFS + delta                                                      (RTS/CTS)

All times in seconds; here every payload has one length, so E[P*] = E[P].
"""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class BianchiResult:
    tau: float
    """Probability that a station transmits in a random slot."""
    collision_probability: float
    """p: the probability that a transmitted frame collides."""
    throughput: float
    """S: the share of time the channel carries payload bits that arrive."""


def solve_tau(n: int, w: int, m: int, tol: float = 1e-13) -> tuple[float, float]:
    """(tau, p) of eq. B-1 and B-2 for ``n`` stations, window ``w`` slots, ``m`` stages."""
    if n < 1 or w < 1 or m < 0:
        raise ValueError(f"Bianchi's model needs n >= 1, W >= 1, m >= 0; got n={n}, W={w}, m={m}")

    def tau_of(p: float) -> float:
        if abs(1.0 - 2.0 * p) < 1e-12:  # the removable singularity at p = 1/2 (limit of B-1)
            return 2.0 / (w + 1.0 + w * m / 2.0) if m else 2.0 / (w + 1.0)
        return 2.0 * (1.0 - 2.0 * p) / ((1.0 - 2.0 * p) * (w + 1.0) + p * w * (1.0 - (2.0 * p) ** m))

    if n == 1:
        return tau_of(0.0), 0.0
    lo, hi = 0.0, 1.0  # g(p) = 1 - (1 - tau(p))^(n-1) - p falls from > 0 at 0 to < 0 at 1
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        g = 1.0 - (1.0 - tau_of(mid)) ** (n - 1) - mid
        if g > 0.0:
            lo = mid
        else:
            hi = mid
        if hi - lo < tol:
            break
    p = 0.5 * (lo + hi)
    return tau_of(p), p


def saturation(n: int, w: int, m: int, payload_s: float, ts_s: float, tc_s: float, slot_s: float) -> BianchiResult:
    """Eq. B-3: the throughput of ``n`` saturated stations; times in seconds (the payload's
    airtime E[P], the durations T_s and T_c of a success and a collision, the slot sigma)."""
    tau, p = solve_tau(n, w, m)
    p_tr = 1.0 - (1.0 - tau) ** n
    p_s = n * tau * (1.0 - tau) ** (n - 1) / p_tr
    s = p_s * p_tr * payload_s / ((1.0 - p_tr) * slot_s + p_tr * p_s * ts_s + p_tr * (1.0 - p_s) * tc_s)
    return BianchiResult(tau, p, s)


def durations(*, rts_cts: bool, payload_bits: int, mac_header_bits: int, phy_header_s: float, ack_bits: int,
              rts_bits: int, cts_bits: int, rate_bps: float, sifs_s: float, difs_s: float,
              prop_s: float) -> tuple[float, float, float]:
    """(E[P], T_s, T_c) in seconds for the access mode, as in the module docstring."""
    payload = payload_bits / rate_bps
    h = phy_header_s + mac_header_bits / rate_bps
    ack = phy_header_s + ack_bits / rate_bps
    if not rts_cts:
        return payload, h + payload + sifs_s + prop_s + ack + difs_s + prop_s, h + payload + difs_s + prop_s
    rts = phy_header_s + rts_bits / rate_bps
    cts = phy_header_s + cts_bits / rate_bps
    ts = rts + sifs_s + prop_s + cts + sifs_s + prop_s + h + payload + sifs_s + prop_s + ack + difs_s + prop_s
    return payload, ts, rts + difs_s + prop_s
