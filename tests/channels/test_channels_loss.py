"""Message loss: success_rate (binomial), packet all-or-nothing, retransmission."""
from __future__ import annotations

import math

import pytest

from ramensim.channels.packets import expected_retries, fragment, message_loss_probability

Z99 = 2.5758  # two-sided 99% normal quantile


def _burst(ch, env, n: int, nbytes: int) -> None:
    """Send n messages 0 -> 1, one per simulated second (no queueing), then run."""

    def proc():
        for _ in range(n):
            ch.send(0, 1, None, nbytes, env.now)
            yield env.timeout(1.0)

    env.process(proc())
    env.run()


def _within_binomial_99(k: int, n: int, p: float) -> bool:
    return abs(k / n - p) <= Z99 * math.sqrt(p * (1 - p) / n) + 1e-12


@pytest.mark.parametrize("p", [0.2, 0.5, 0.9])
def test_success_rate_matches(make, p: float) -> None:
    env, ch, inbox = make(success_rate=p)
    n = 20_000
    _burst(ch, env, n, 100)
    s = ch.log.summary()["total"]
    assert s["sent"] == n and s["delivered"] == len(inbox[1])
    assert s["dropped_by_reason"]["loss"] == n - s["delivered"]
    assert _within_binomial_99(s["delivered"], n, p)
    # A grossly wrong implementation (e.g. loss = p) would fail.
    assert p == 0.5 or not _within_binomial_99(s["delivered"], n, 1 - p)


def test_fragmentation() -> None:
    assert fragment(0, 1500, 64) == (1, 64)
    assert fragment(1436, 1500, 64) == (1, 1500)
    assert fragment(1437, 1500, 64) == (2, 65)
    assert fragment(10 * 1436, 1500, 64) == (10, 1500)


@pytest.mark.parametrize("q,k", [(0.01, 10), (0.05, 5)])
def test_packet_all_or_nothing(make, q: float, k: int) -> None:
    env, ch, _ = make(mode="packet", packet_loss=q, mtu_bytes=1000, header_bytes=0)
    n = 20_000
    _burst(ch, env, n, k * 1000)
    s = ch.log.summary()["total"]
    expected_loss = 1 - (1 - q) ** k
    assert message_loss_probability(k, q, False, 0) == pytest.approx(expected_loss)
    assert s["dropped"] == s["dropped_by_reason"]["packet_loss"]
    assert _within_binomial_99(s["dropped"], n, expected_loss)
    assert ch.log.records()["packets"].tolist() == [k] * n


@pytest.mark.parametrize("retries", [1, 2])
def test_packet_retransmit_improves_per_formula(make, retries: int) -> None:
    q, k, n = 0.2, 8, 40_000
    env, ch, _ = make(mode="packet", packet_loss=q, mtu_bytes=1000, header_bytes=0,
                      reassembly="retransmit", max_retries=retries, bandwidth_bps=1e9)
    _burst(ch, env, n, k * 1000)
    s = ch.log.summary()["total"]
    p_loss = 1 - (1 - q ** (retries + 1)) ** k
    assert message_loss_probability(k, q, True, retries) == pytest.approx(p_loss)
    assert p_loss < 1 - (1 - q) ** k  # retransmission helps
    assert _within_binomial_99(s["dropped_by_reason"]["packet_loss"], n, p_loss)
    # Delivered messages: every packet got through; retries counted and on the wire.
    r = ch.log.records()
    ok = r[r["status"] == 0]
    assert (ok["wire_bytes"] == (k + ok["retries"]) * 1000).all()
    # Mean retries of delivered messages: per packet E[G-1 | G <= R+1].
    per_packet = sum(a * q**a * (1 - q) for a in range(retries + 1)) / (1 - q ** (retries + 1))
    mean = ok["retries"].mean()
    sd = math.sqrt(k * sum(a * a * q**a * (1 - q) for a in range(retries + 1)) / (1 - q ** (retries + 1))
                   - k * per_packet**2) / math.sqrt(ok.size)
    assert abs(mean - k * per_packet) <= 4 * sd
    assert expected_retries(k, q, retries) > 0


def test_retransmit_time_cost(make) -> None:
    # Lossless retransmit mode: duration is the plain serialisation time.
    env, ch, inbox = make(mode="packet", reassembly="retransmit", packet_loss=0.0,
                          mtu_bytes=100, header_bytes=10, bandwidth_bps=8.0,
                          latency={"kind": "constant", "mean_s": 0.0})
    m = ch.send(0, 1, "x", 180, 0.0)  # 2 packets of 90 payload + 10 header = 200 wire bytes
    env.run()
    assert m.packets == 2 and m.wire_bytes == 200 and inbox[1][0][0] == 200.0


def test_total_loss_retransmit_gives_up(make) -> None:
    env, ch, _ = make(mode="packet", reassembly="retransmit", packet_loss=1.0, max_retries=2,
                      mtu_bytes=100, header_bytes=0, bandwidth_bps=8.0, retry_delay_s=0.5)
    m = ch.send(0, 1, "x", 1000, 0.0)  # 10 packets; the first fails 3 times and the sender gives up
    env.run()
    assert m.status == "dropped" and m.reason == "packet_loss"
    assert m.retries == 2 and m.wire_bytes == 300
    assert m.t_done == pytest.approx(3 * (100.0 + 0.5))
