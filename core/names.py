"""The closest registered name to a mistyped one, for "did you mean" hints of the registries
(methods, scenes, radio models).

Names are compared by their *folded* form: lower case, with ``_``, ``-``, spaces and dots
removed, so ``DiNNO`` finds ``dinno``, ``LIVINGROOM`` and ``Living-Room`` find ``living_room``
(an exact folded match wins), and ``ofice`` finds ``office`` (difflib's ratio >= ``cutoff`` on
the folded forms).
"""
from __future__ import annotations

import difflib
import re
from typing import Iterable

_SEPARATORS = re.compile(r"[\s_.\-]+")


def fold(name: str) -> str:
    """``name`` in lower case without separators (``'Living-Room'`` -> ``'livingroom'``)."""
    return _SEPARATORS.sub("", str(name)).lower()


def closest_name(name: str, known: Iterable[str], cutoff: float = 0.6) -> str | None:
    """The known name closest to ``name`` regardless of case and separators, or None when none
    is close (difflib's similarity ratio of the folded forms below ``cutoff``)."""
    known = list(known)
    folded = {fold(k): k for k in reversed(known)}  # the first registered wins a tie
    target = fold(name)
    if target in folded:
        return folded[target]
    close = difflib.get_close_matches(target, list(folded), n=1, cutoff=cutoff)
    return folded[close[0]] if close else None


def did_you_mean(name: str, known: Iterable[str], cutoff: float = 0.6) -> str:
    """`` (did you mean 'x'?)`` for the closest known name, or an empty string."""
    close = closest_name(name, known, cutoff)
    return f" (did you mean {close!r}?)" if close is not None and close != name else ""
