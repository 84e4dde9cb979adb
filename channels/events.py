"""The radio's events live with every other event type in ``ramensim.core.events``; this
module keeps the old import path of ``LinkQuality`` working."""
from __future__ import annotations

from ramensim.core.events import LinkQuality

__all__ = ["LinkQuality"]
