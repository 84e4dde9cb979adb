"""The radio: links, messages, loss, latency, bandwidth, windows, range and topology.

A leaf package: it knows nothing of neural maps, scenarios or recorders.
"""

from channels.accounting import MessageLog
from channels.channel import Channel
from channels.config import ChannelConfig, LatencyConfig, TopologyConfig, WindowConfig
from channels.message import Message
from channels.topology import Topology

__all__ = [
    "Channel",
    "ChannelConfig",
    "LatencyConfig",
    "Message",
    "MessageLog",
    "Topology",
    "TopologyConfig",
    "WindowConfig",
]
