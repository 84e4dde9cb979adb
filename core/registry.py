"""A table of named declarations of one kind (the consensus methods, the radio models, the
scenes): each name declared once, looked up with a "did you mean" when misspelt. Built-ins and
plugins register the same way (docs/EXTENDING.md)."""
from __future__ import annotations

from typing import Any, TypeVar

from ramensim.core.names import did_you_mean

S = TypeVar("S")


class Registry(dict):
    """Name -> spec (a dict, in registration order). ``kind`` names the registry in errors
    ("consensus", "radio", "scene"), ``noun`` one of its entries ("method", "radio model",
    "scene"). A spec has a ``name`` and a ``build`` callable (whose module is named when a name
    is taken twice)."""

    def __init__(self, kind: str, noun: str) -> None:
        super().__init__()
        self.kind, self.noun = kind, noun

    def declare(self, spec: S) -> S:
        """Keep ``spec`` under ``spec.name``; a name taken by another declaration is an error
        (the same declaration again, a module imported twice, is not)."""
        name = spec.name  # type: ignore[attr-defined]
        held = self.get(name)
        if held is not None and held != spec:
            raise ValueError(f"{self.kind} registry: a {self.noun} named {name!r} is already registered by "
                             f"{_home(held)}; {_home(spec)} declares it again: two files cannot register one "
                             f"name; rename one of them.")
        self[name] = spec
        return spec

    def withdraw(self, name: str) -> None:
        """Remove ``name`` (tests that register a temporary one)."""
        self.pop(name, None)

    def names(self) -> tuple[str, ...]:
        """Every registered name, in registration order."""
        return tuple(self)

    def lookup(self, name: Any) -> Any:
        """The spec of ``name``; ValueError naming the registered ones and the closest, regardless
        of case ('DiNNO' -> 'dinno')."""
        try:
            return self[name]
        except (KeyError, TypeError):
            hint = did_you_mean(str(name), self)
            plugin = "" if hint else (f" (a {self.noun} of your own is registered by a plugin: load it with "
                                      f"'plugins: [file.py]' in the scenario or --plugin file.py; docs/EXTENDING.md)")
            raise ValueError(f"{self.noun} {name!r} is unknown{hint}; expected one of "
                             f"{', '.join(self)}{plugin}.") from None


def _home(spec: object) -> str:
    """Where a declaration comes from: the file of the module its builder lives in (a plugin's
    path, not the internal module name it was imported under), else that module's name."""
    import sys

    module = getattr(getattr(spec, "build", None), "__module__", None)
    if not module:
        return "another module"
    path = getattr(sys.modules.get(module), "__file__", None)
    return str(path) if path else module

