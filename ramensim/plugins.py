"""Plugins: a user's consensus method, radio model or scene, loaded from a file, a module or an
installed package (docs/EXTENDING.md).

A plugin is a Python file or module that registers what it declares when imported:

* ``register(MethodSpec(...))``        (:mod:`ramensim.agents.consensus.registry`)
* ``register_radio(RadioModelSpec(...))`` (:mod:`ramensim.channels.radios`)
* ``register_scene(SceneSpec(...))``   (:mod:`ramensim.world.scenes.registry`)

It is loaded from three places, before a scenario is validated (its names are then valid
``method``, ``channel.<radio>`` and ``world.scene.name`` values):

* the ``plugins:`` list of a scenario or sweep file: files (``.py``, relative to that file's
  folder) or importable module names;
* ``--plugin FILE_OR_MODULE`` on ``ramensim run``, ``sweep`` and ``validate`` (relative to the
  working directory), which joins the scenario's list;
* the entry points of installed packages in the groups :data:`GROUPS` (an entry point names a
  module, imported, or a spec object, registered).

A plugin file's folder is appended to ``sys.path`` (after the installed packages), so it can
import modules beside it. Sweep points carry their plugins as absolute paths in their resolved scenario, so every worker
(a local process or a Ray task) loads the same ones before it runs a point. Loading is
idempotent: a file is imported once per process (keyed by its absolute path), a module once.
Bad input (a missing file, an import error, nothing registered, a name taken, a built-in's
included) is an :class:`~ramensim.core.errors.InputError` naming the file and the name.
"""
from __future__ import annotations

import hashlib
import importlib
import importlib.util
import logging
import re
import sys
from pathlib import Path
from typing import Any, Iterable

from ramensim.core.errors import InputError

log = logging.getLogger(__name__)

GROUPS = ("ramensim.methods", "ramensim.radios", "ramensim.scenes")
"""Entry-point groups of installed packages: a method, a radio model, a scene."""

_MODULE_RE = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)*$")
_LOADED: dict[str, dict[str, tuple[str, ...]]] = {}
"""Plugin key (absolute path or module name) -> what it registered, per kind."""
_ENTRY_POINTS_LOADED = False


def registered() -> dict[str, tuple[str, ...]]:
    """Every registered name per kind: ``{"method": ..., "radio": ..., "scene": ...}``."""
    from ramensim.agents.consensus import method_names
    from ramensim.channels.radios import radio_names
    from ramensim.world.scenes import scene_names

    return {"method": method_names(), "radio": radio_names(), "scene": scene_names()}


def is_file_entry(entry: str) -> bool:
    """A ``plugins:`` entry names a file (``.py`` suffix or a path separator), not a module."""
    return entry.endswith(".py") or "/" in entry or "\\" in entry


def resolve(entries: Iterable[Any], base: Path | None, source: str, key: str = "plugins") -> list[str]:
    """``entries`` with every file made absolute against ``base`` (default: the working
    directory); module names unchanged. InputError when ``entries`` is not a list of strings."""
    if isinstance(entries, (str, bytes)) or not isinstance(entries, (list, tuple)):
        raise InputError(f"{source}: key '{key}' has value {_clip(repr(entries))}; expected a list of plugin "
                         f"files (.py, relative to the file's folder) or module names, e.g. "
                         f"'{key}: [my_method.py]'.")
    out: list[str] = []
    for i, entry in enumerate(entries):
        if not isinstance(entry, str) or not entry.strip():
            raise InputError(f"{source}: key '{key}[{i}]' has value {_clip(repr(entry))}; expected a plugin "
                             f"file (.py) or a module name.")
        entry = entry.strip()
        if is_file_entry(entry):
            p = Path(entry).expanduser()
            entry = str((p if p.is_absolute() else (base or Path.cwd()) / p).resolve())
        elif not _MODULE_RE.match(entry):
            raise InputError(f"{source}: key '{key}[{i}]' has value {entry!r}; expected a plugin file "
                             f"(ending in .py) or an importable module name (e.g. my_package.gossip).")
        if entry not in out:
            out.append(entry)
    return out


def load_plugins(entries: Iterable[Any], base: Path | None = None, source: str = "--plugin",
                 key: str = "plugins") -> list[str]:
    """Load the installed entry points (once) and every plugin of ``entries`` (files relative
    to ``base``); returns the entries as resolved (absolute files). See the module docstring."""
    load_installed()
    resolved = resolve(entries, base, source, key)
    for entry in resolved:
        load_one(entry, source)
    return resolved


def load_one(entry: str, source: str = "--plugin") -> dict[str, tuple[str, ...]]:
    """Import one plugin (an absolute file path or a module name) unless already loaded;
    returns what it registered per kind."""
    if entry in _LOADED:
        return _LOADED[entry]
    before = registered()
    if is_file_entry(entry):
        path = Path(entry)
        what = f"plugin file {path}"
        if not path.is_file():
            raise InputError(f"{source}: {what} does not exist; expected a Python file that registers a "
                             f"method, radio model or scene (docs/EXTENDING.md), its path relative to the "
                             f"scenario or sweep file (or, for --plugin, to the working directory).")
        already = _module_of_file(path)
        if already is not None:  # imported by another plugin (``import mine`` beside it): the same module
            mine = _declared_by(already)
            _LOADED[entry] = mine
            log.info("%s was imported already (as module %s) by another plugin", what, already)
            return mine
        name = "ramensim_plugin_" + re.sub(r"\W", "_", path.stem) + "_" + \
            hashlib.sha1(str(path).encode()).hexdigest()[:10]
        spec = importlib.util.spec_from_file_location(name, path)
        if spec is None or spec.loader is None:
            raise InputError(f"{source}: {what} cannot be imported; expected a Python (.py) file.")
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module  # dataclasses and pickling find the module by name
        alias = path.stem  # a sibling plugin's ``import <stem>`` finds this very module, not a second copy
        if _MODULE_RE.match(alias) and alias not in sys.modules and _finds_itself_or_nothing(alias, path):
            sys.modules[alias] = module
        if str(path.parent) not in sys.path:  # modules beside the file import as from a script's folder,
            sys.path.append(str(path.parent))  # after the installed ones (it shadows none of them)
        try:
            spec.loader.exec_module(module)
        except BaseException as exc:  # noqa: BLE001 - any failure of a user's file is reported as its own
            sys.modules.pop(name, None)
            if sys.modules.get(alias) is module:
                sys.modules.pop(alias, None)
            _import_failed(source, what, exc)
    else:
        what = f"plugin module {entry!r}"
        if entry in sys.modules:  # imported before (e.g. as an installed entry point): registered then
            mine = _declared_by(entry)
            if not any(mine.values()):
                raise InputError(f"{source}: {what} registers nothing; expected it to call "
                                 f"register(MethodSpec(...)), register_radio(RadioModelSpec(...)) or "
                                 f"register_scene(SceneSpec(...)) when imported (docs/EXTENDING.md).")
            _LOADED[entry] = mine
            return mine
        try:
            importlib.import_module(entry)
        except ModuleNotFoundError as exc:
            if exc.name and entry.startswith(exc.name):
                raise InputError(f"{source}: {what} cannot be found (no module named {exc.name!r} on the Python "
                                 f"path); expected an installed module, or a file path ending in .py.") from None
            _import_failed(source, what, exc)
        except BaseException as exc:  # noqa: BLE001
            _import_failed(source, what, exc)
    after = registered()
    added = {kind: tuple(n for n in after[kind] if n not in before[kind]) for kind in after}
    if not any(added.values()):
        raise InputError(f"{source}: {what} registers nothing; expected it to call "
                         f"register(MethodSpec(...)), register_radio(RadioModelSpec(...)) or "
                         f"register_scene(SceneSpec(...)) when imported (docs/EXTENDING.md).")
    log.info("%s registered %s", what, "; ".join(f"{k} {', '.join(v)}" for k, v in added.items() if v))
    _LOADED[entry] = added
    return added


def loaded_files() -> list[dict[str, str]]:
    """The plugin files loaded in this process, each ``{"path", "sha256"}`` of its source now
    (metrics.json's ``build.plugins``: what code a run's method, radio or scene came from)."""
    out = []
    for entry in sorted(_LOADED):
        if is_file_entry(entry) and Path(entry).is_file():
            out.append({"path": entry, "sha256": hashlib.sha256(Path(entry).read_bytes()).hexdigest()})
    return out


def _finds_itself_or_nothing(alias: str, path: Path) -> bool:
    """``import <alias>`` would find no module, or this very file (its folder is on the path)."""
    try:
        found = importlib.util.find_spec(alias)
    except (ImportError, ValueError):
        return False
    return found is None or (found.origin is not None and Path(found.origin).resolve() == path.resolve())


def _module_of_file(path: Path) -> str | None:
    """The name of a module already imported from the file ``path``, if any."""
    target = path.resolve()
    for name, module in list(sys.modules.items()):
        f = getattr(module, "__file__", None)
        if f and f.endswith(".py"):
            try:
                if Path(f).resolve() == target:
                    return name
            except OSError:
                continue
    return None


def _declared_by(module: str) -> dict[str, tuple[str, ...]]:
    """The registered names whose builder lives in ``module`` (or a submodule), per kind."""
    from ramensim.agents.consensus.registry import _REGISTRY as methods
    from ramensim.channels.radios import _REGISTRY as radios
    from ramensim.world.scenes.registry import _REGISTRY as scenes

    def mine(spec: Any) -> bool:
        home = getattr(spec.build, "__module__", None) or ""
        return home == module or home.startswith(module + ".")

    return {kind: tuple(n for n, spec in reg.items() if mine(spec))
            for kind, reg in (("method", methods), ("radio", radios), ("scene", scenes))}


def _import_failed(source: str, what: str, exc: BaseException) -> None:
    if isinstance(exc, KeyboardInterrupt):
        raise exc
    text = " ".join(str(exc).split()) or "(no message)"
    where = ""
    tb = exc.__traceback__
    while tb is not None:  # the line of the user's file that raised (the innermost frame in it)
        if tb.tb_frame.f_code.co_filename == what.removeprefix("plugin file "):
            where = f" at line {tb.tb_lineno}"
        tb = tb.tb_next
    raise InputError(f"{source}: {what} raised {type(exc).__name__}{where} when imported: {_clip(text.rstrip('.'), 400)}; "
                     f"expected it to import and register a method, radio model or scene "
                     f"(docs/EXTENDING.md).") from None


def load_installed() -> list[str]:
    """Load the entry points of installed packages in :data:`GROUPS` (once per process);
    an entry point names a module (imported: it registers) or a spec (registered here)."""
    global _ENTRY_POINTS_LOADED
    if _ENTRY_POINTS_LOADED:
        return []
    _ENTRY_POINTS_LOADED = True
    from importlib.metadata import entry_points

    loaded = []
    for group in GROUPS:
        for ep in entry_points(group=group):
            what = f"entry point {ep.name!r} = {ep.value!r} (group {group}" + \
                (f", package {ep.dist.name})" if getattr(ep, "dist", None) is not None else ")")
            key = f"entry-point:{group}:{ep.value}"
            if key in _LOADED:
                continue
            before = registered()
            try:
                obj = ep.load()
                _register_object(obj)
            except InputError:
                raise
            except BaseException as exc:  # noqa: BLE001
                _ENTRY_POINTS_LOADED = False
                _import_failed("installed plugins", what, exc)
            after = registered()
            _LOADED[key] = {k: tuple(n for n in after[k] if n not in before[k]) for k in after}
            loaded.append(ep.name)
    return loaded


def _register_object(obj: Any) -> None:
    """An entry point's object: a spec is registered; a module registered itself on import."""
    from ramensim.agents.consensus.registry import MethodSpec, register
    from ramensim.channels.radios import RadioModelSpec, register_radio
    from ramensim.world.scenes import SceneSpec, register_scene

    if isinstance(obj, MethodSpec):
        register(obj)
    elif isinstance(obj, RadioModelSpec):
        register_radio(obj)
    elif isinstance(obj, SceneSpec):
        register_scene(obj)


def _clip(text: str, n: int = 80) -> str:
    return text if len(text) <= n else text[: n - 3] + "..."
