"""Streaming every run to Rerun: the recorder (an event sink), its settings, the default
viewer layout, and helpers to read a recording back and to screenshot the real viewer.

Importing this package does not import rerun; the recorder is loaded on first use."""
from __future__ import annotations

from typing import TYPE_CHECKING, Any

from ramensim.recording.config import RecordingConfig

if TYPE_CHECKING:
    from ramensim.recording.recorder import Recorder, make_recorder

__all__ = ["RecordingConfig", "Recorder", "make_recorder"]


def __getattr__(name: str) -> Any:
    if name in ("Recorder", "make_recorder"):
        from ramensim.recording import recorder

        return getattr(recorder, name)
    raise AttributeError(f"module 'ramensim.recording' has no attribute {name!r}")
