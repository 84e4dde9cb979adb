"""The radio: links, messages, loss, latency, bandwidth, windows, range and topology.

A leaf package: it knows nothing of neural maps, scenarios or recorders.
"""

# the built-in radio models register first, in this order (burst, path_loss, trace)
from ramensim.channels import burst, pathloss, trace  # noqa: F401,I001
from ramensim.channels.accounting import MessageLog
from ramensim.channels.channel import Channel
from ramensim.channels.config import ChannelConfig, LatencyConfig, TopologyConfig, WindowConfig
from ramensim.channels.message import Message
from ramensim.channels.topology import Topology

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
