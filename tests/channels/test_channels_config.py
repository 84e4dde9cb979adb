"""Channel settings validate their ranges; every field has a default and a docstring."""
from __future__ import annotations

import pytest
from pydantic import ValidationError

from ramensim.channels.config import ChannelConfig, LatencyConfig, TopologyConfig, WindowConfig


@pytest.mark.parametrize("model", [ChannelConfig, LatencyConfig, WindowConfig, TopologyConfig])
def test_every_field_has_default_and_doc(model) -> None:
    model()  # all defaults
    for name, field in model.model_fields.items():
        assert field.description, f"{model.__name__}.{name} has no docstring"


def test_ranges_and_combinations() -> None:
    with pytest.raises(ValidationError):
        ChannelConfig(success_rate=1.5)
    with pytest.raises(ValidationError):
        ChannelConfig(packet_loss=-0.1)
    with pytest.raises(ValidationError, match="mtu_bytes"):
        ChannelConfig(mode="packet", mtu_bytes=64, header_bytes=64)
    with pytest.raises(ValidationError, match="open_s"):
        WindowConfig(kind="periodic", period_s=10.0, open_s=11.0)
    with pytest.raises(ValidationError, match="'a-b'"):
        WindowConfig(kind="schedule", schedule={"0_1": [(0.0, 1.0)]})
    with pytest.raises(ValidationError, match="t0 < t1"):
        WindowConfig(kind="schedule", schedule={"0-1": [(2.0, 1.0)]})
    with pytest.raises(ValidationError, match="high_s >= low_s"):
        LatencyConfig(kind="uniform", low_s=0.2, high_s=0.1)
    with pytest.raises(ValidationError):
        ChannelConfig(latency={"kind": "gamma"})
    cfg = ChannelConfig(windows={"kind": "periodic", "period_s": 30, "open_s": 2})
    assert cfg.windows.period_s == 30.0
