"""The air the radios share (issue 66): collision domains from positions and walls, a fluid fair
share or 802.11 DCF, and the saturation experiment that checks the DCF against Bianchi's model.

``channel.medium.kind: links`` (default) leaves the channel as it always was.
"""
from ramensim.channels.medium.config import MediumConfig

__all__ = ["MediumConfig"]
