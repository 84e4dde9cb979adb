"""Streaming every run to Rerun: the recorder (an event sink), its settings, the default
viewer layout, and helpers to read a recording back and to screenshot the real viewer.

Importing this package does not import rerun; the recorder is loaded on first use."""
from __future__ import annotations

from typing import TYPE_CHECKING, Any

from ramensim.recording.config import RecordingConfig

if TYPE_CHECKING:
    from ramensim.recording.recorder import Recorder

__all__ = ["RecordingConfig", "Recorder", "make_recorder"]


def make_recorder(cfg: RecordingConfig, *args: Any, **kwargs: Any) -> "Recorder | None":
    """:func:`ramensim.recording.recorder.make_recorder`, except that ``mode: off`` returns
    None without importing rerun (a run with recording off never loads it)."""
    if cfg.mode == "off":
        return None
    from ramensim.recording.recorder import make_recorder as _make

    return _make(cfg, *args, **kwargs)


def __getattr__(name: str) -> Any:
    if name == "Recorder":
        from ramensim.recording import recorder

        return getattr(recorder, name)
    raise AttributeError(f"module 'ramensim.recording' has no attribute {name!r}")
