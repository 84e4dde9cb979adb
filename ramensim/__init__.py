"""ramensim: a discrete-event simulator of multi-robot neural implicit mapping under
lossy, delayed, windowed communication. The composition root of the project."""

__version__ = "0.1.0"

# The Python API (docs/API.md): ``ramensim.run(...)`` and ``ramensim.sweep.run(...)``, loaded on
# first use so that ``import ramensim`` stays light. ``ramensim.sweep`` is the package of the
# sweep machinery (``ramensim.sweep.runner``, ...); calling the package itself, the API before
# 2026-11-24, still works with a DeprecationWarning.
import types as _types
import warnings as _warnings


class _CallableSweepPackage(_types.ModuleType):
    def __call__(self, *args, **kwargs):
        _warnings.warn("ramensim.sweep(...) is deprecated; call ramensim.sweep.run(...) (same arguments)",
                       DeprecationWarning, stacklevel=2)
        from ramensim.api import sweep

        return sweep(*args, **kwargs)


from ramensim import sweep  # noqa: E402  (the package; its __init__ imports nothing heavy)

sweep.__class__ = _CallableSweepPackage


def run(scenario, overrides=None, **kwargs):
    """Run one scenario and return its typed result: see :func:`ramensim.api.run`."""
    from ramensim.api import run as _run

    return _run(scenario, overrides, **kwargs)


def __getattr__(name):
    if name in ("RunOutput", "SweepOutput"):
        from ramensim import api

        return getattr(api, name)
    if name == "RunResult":
        from ramensim.core.results import RunResult

        return RunResult
    raise AttributeError(f"module 'ramensim' has no attribute {name!r}")


__all__ = ["__version__", "run", "sweep", "RunOutput", "SweepOutput", "RunResult"]
