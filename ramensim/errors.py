"""The public name of the error a user can fix (docs/API.md: ``except ramensim.errors.InputError``);
defined in :mod:`ramensim.core.errors`, at the bottom of the layers, so that every package
(world, agents, channels, evaluation) can raise it."""
from ramensim.core.errors import InputError

__all__ = ["InputError"]
