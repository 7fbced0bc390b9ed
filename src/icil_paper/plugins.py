"""Tokenizers and policies from outside the package: plugins, checked before any work.

A plugin is a Python module that registers one or more components with the decorators of
the library (`@register_tokenizer`, `@register_policy`) when it is imported. Three ways in:

    icil-paper train --plugin my_tokenizers --tokenizer pca     # an importable module
    icil-paper train --plugin ./pca.py --tokenizer pca          # a file
    # an installed package that declares an entry point (pyproject.toml):
    #   [project.entry-points."icil_paper.tokenizers"]
    #   pca = "my_tokenizers.pca"
    from icil_paper.plugins import load_plugins; load_plugins(["./pca.py"])   # from code

Entry points are loaded once per process by `discover`; plugins named with `--plugin` travel
with each cell to its worker. Every stored record names the plugins its config uses
(`record_of`), with package version or file SHA-256. Each plugin is checked as it is loaded
(imports, registers something new, config fields have defaults and are checked, the
component passes its kind's probe); a bad one raises `PluginError`.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
import importlib
import importlib.metadata
import importlib.util
import re
import sys
import warnings
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from icil_paper.registry import REGISTRIES, ComponentRegistry, NameClashError

VALIDATION_PROBE = {"tokenizer": "latent_dim", "policy": "n_layer"}
"""A field of each kind's base config that a config class checking its values refuses at -1."""


class PluginError(ValueError):
    """A plugin that cannot be used; the message names it, the problem and the fix."""


@dataclass(frozen=True)
class Plugin:
    """One loaded plugin and what it registered."""

    spec: str
    """What was named: a module, a file path, or `name = value` of an entry point."""
    source: str
    """`module`, `file` or `entry point`."""
    module: str
    """The name the module is imported under (a file: `icil_plugin_<stem>_<digest>`)."""
    names: Mapping[str, tuple[str, ...]] = field(default_factory=dict)
    """kind (`tokenizer`, `policy`) -> the names it registered."""
    path: str | None = None
    """The module's file."""
    sha256: str | None = None
    """SHA-256 of that file."""
    distribution: str | None = None
    """The installed package that provides it, where there is one."""
    version: str | None = None
    """That package's version."""

    def record(self) -> dict[str, Any]:
        """The plugin as a stored record names it (JSON)."""
        return dataclasses.asdict(self) | {"names": {k: list(v) for k, v in self.names.items()}}


_LOADED: dict[str, Plugin] = {}
"""Loaded plugins by their spec (a file by its resolved path)."""
_DISCOVERED: set[str] = set()
"""The kinds whose entry points this process has loaded."""


def discover() -> None:
    """Load the entry points of every kind's group, once per process (`load_entry_points`)."""
    for kind, reg in REGISTRIES.items():
        if kind not in _DISCOVERED:
            _DISCOVERED.add(kind)  # first: a plugin's own registrations come back here
            load_entry_points(reg)


def loaded() -> list[Plugin]:
    """Every plugin loaded in this process (entry points included), in load order."""
    return list(_LOADED.values())


def named() -> list[str]:
    """The specs of the plugins loaded by name or file: what a grid worker loads."""
    return [(p.path if p.source == "file" else p.spec) for p in _LOADED.values()
            if p.source != "entry point"]


def owner(kind: str, name: str) -> Plugin | None:
    """The plugin that registered component `name` of `kind`, or None (a built-in)."""
    return next((p for p in _LOADED.values() if name in p.names.get(kind, ())), None)


def record_of(config: Any) -> list[dict[str, Any]]:
    """The records of the plugins whose components a (JSON) config names by `type`."""
    if not _LOADED:
        return []
    types = set(_types(config))
    return [p.record() for p in _LOADED.values()
            if any(n in types for names in p.names.values() for n in names)]


def _types(value: Any) -> Iterable[str]:
    if isinstance(value, Mapping):
        if isinstance(value.get("type"), str):
            yield value["type"]
        for v in value.values():
            yield from _types(v)
    elif isinstance(value, (list, tuple)):
        for v in value:
            yield from _types(v)


# --------------------------------------------------------------------------- loading
def load_plugins(specs: Sequence[str]) -> list[Plugin]:
    """Load the entry-point plugins, then each module or file of `specs`; return the latter."""
    discover()
    return [load_plugin(spec) for spec in specs]


def _is_file(spec: str) -> bool:
    return spec.endswith(".py") or "/" in spec or "\\" in spec or Path(spec).is_file()


def load_plugin(spec: str) -> Plugin:
    """Import one module (a dotted name) or file (a path) and check what it registered."""
    if not isinstance(spec, str) or not spec.strip():
        raise PluginError("--plugin needs a module name or a .py file, got an empty value")
    path = Path(spec).resolve() if _is_file(spec) else None
    key = str(path) if path else spec
    if key in _LOADED:
        return _LOADED[key]
    discover()
    if path is None:
        module_name = spec
        try:
            found = importlib.util.find_spec(spec)
        except (ImportError, ValueError):
            found = None
        if found is None:
            raise PluginError(f"plugin {spec}: no module named {spec!r} on the import path; "
                              "install the package that provides it, or pass a .py file")
        load = functools.partial(importlib.import_module, spec)
    else:
        if not path.is_file():
            raise PluginError(f"plugin {spec}: no such file; pass the path of a .py file "
                              "that registers a tokenizer or policy, or an importable module")
        digest = hashlib.sha256(str(path).encode()).hexdigest()[:8]
        module_name = f"icil_plugin_{_identifier(path.stem)}_{digest}"
        load = functools.partial(_exec_file, module_name, path)

    names = _load_checked(f"plugin {spec}", load, "fix the module", module_name)
    _LOADED[key] = _describe(spec, "file" if path else "module", module_name, names)
    return _LOADED[key]


def _exec_file(module_name: str, path: Path) -> None:
    loader_spec = importlib.util.spec_from_file_location(module_name, path)
    module = importlib.util.module_from_spec(loader_spec)
    sys.modules[module_name] = module  # dataclasses look the module up by name
    loader_spec.loader.exec_module(module)


def load_entry_points(reg: ComponentRegistry) -> None:
    """Load and check the entry points of `reg.group` (`discover` calls it once)."""
    for ep in importlib.metadata.entry_points(group=reg.group) if reg.group else ():
        spec = f"{ep.name} = {ep.value}"
        if spec in _LOADED:
            continue
        where = f"entry point {ep.name!r} ({ep.value}) of group {reg.group}"
        dist = getattr(ep, "dist", None)
        if dist is not None:
            where += f" (package {dist.metadata['Name']} {dist.version})"
        names = _load_checked(where, ep.load, "reinstall or fix the package, or uninstall it",
                              kind=reg.kind, name=ep.name)
        _LOADED[spec] = _describe(spec, "entry point", ep.value.partition(":")[0].strip(), names,
                                  dist)


def _load_checked(where: str, load: Callable[[], Any], fix: str, module_name: str | None = None,
                  kind: str | None = None, name: str | None = None) -> dict[str, tuple[str, ...]]:
    """What `load()` (an import) registered, each component checked: something (with
    `kind`, an entry point's, a component of that kind or one already called `name`). On a
    problem a PluginError (`fix` for a failed import), the registries and `sys.modules` left
    as they were."""
    before = _registered()
    try:
        try:
            load()
        except NameClashError as exc:
            holder = owner(exc.kind, exc.name)
            by = f"the plugin {holder.spec}" if holder else "a built-in"
            raise PluginError(f"{where} registers the {exc.kind} {exc.name!r}, a name {by} "
                              "already has; register it under another name") from None
        except Exception as exc:
            if isinstance(exc, TypeError) and "non-default argument" in str(exc):
                raise PluginError(f"{where}: a config class has a field without a default "
                                  f"({_line(exc)}); give every field a default, so that a "
                                  "preset can build it") from exc
            raise PluginError(f"{where}: importing it failed ({_line(exc)}); {fix}") from exc
        names = _new_names(before)
        if kind is None and not any(names.values()):
            raise PluginError(f"{where} registers nothing: decorate its config class with "
                              "@register_tokenizer(name, 'Class') or @register_policy(name, "
                              "'Class') (see icil_paper.plugins)")
        if kind is not None and not names.get(kind) and name not in REGISTRIES[kind].configs:
            raise PluginError(f"{where} registers no {kind} (and none named {name!r}); "
                              f"decorate its config class with @register_{kind}")
        for new_kind, new in names.items():
            for new_name in new:
                _check_component(where, new_kind, new_name, REGISTRIES[new_kind].configs[new_name])
    except PluginError:
        for new_kind, new in _new_names(before).items():  # unregister what it registered
            REGISTRIES[new_kind].forget(new)
        if module_name:
            sys.modules.pop(module_name, None)
        raise
    return names


def _identifier(text: str) -> str:
    out = re.sub(r"\W", "_", text)
    return out if out and not out[0].isdigit() else f"_{out}"


def _line(exc: BaseException) -> str:
    text = " ".join(str(exc).split())
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def _registered() -> dict[str, dict[str, type]]:
    return {kind: dict(reg.configs) for kind, reg in REGISTRIES.items()}


def _new_names(before: Mapping[str, Mapping[str, type]]) -> dict[str, tuple[str, ...]]:
    """What was registered since `before`, the package's own components left out."""
    return {kind: tuple(n for n, cls in reg.configs.items() if n not in before.get(kind, {})
                        and not cls.__module__.startswith("icil_paper."))
            for kind, reg in REGISTRIES.items()}


def _check_component(where: str, kind: str, name: str, cls: type) -> None:
    """Every field of its config class has a default, the defaults pass the class's own
    checks, its `__post_init__` checks values (refuses -1 for the base's `VALIDATION_PROBE`
    field), and the component passes its kind's own check (`ComponentRegistry.probe`)."""
    what = f"{where}: the config class {cls.__name__} of {kind} {name!r}"
    missing = [f.name for f in dataclasses.fields(cls) if f.init
               and f.default is dataclasses.MISSING
               and f.default_factory is dataclasses.MISSING]
    if missing:
        raise PluginError(f"{what} has fields without a default ({', '.join(missing)}); give "
                          "each a default, so that a preset can build it")
    try:
        config = cls()
    except Exception as exc:
        raise PluginError(f"{where}: the default config of {kind} {name!r} fails its own "
                          f"checks ({_line(exc)}); fix its defaults") from None
    probe = VALIDATION_PROBE[kind]
    try:
        dataclasses.replace(config, **{probe: -1})
    except ValueError:
        pass
    except Exception as exc:
        raise PluginError(f"{what} fails on a bad value with {_line(exc)} instead of a "
                          "ValueError; let its __post_init__ call super().__post_init__()"
                          ) from None
    else:
        raise PluginError(f"{what} does not check its values ({probe}=-1 passes); its "
                          "__post_init__ must call super().__post_init__()")
    if REGISTRIES[kind].probe is None:
        return
    with warnings.catch_warnings():  # a broken component's broadcasting warnings say less
        warnings.simplefilter("ignore")
        try:
            problem = REGISTRIES[kind].probe(cls())
        except Exception as exc:
            problem = f"raises {_line(exc)}"
    if problem:
        raise PluginError(f"{where}: the {kind} {name!r}, {problem}")


def _describe(spec: str, source: str, module_name: str, names: Mapping[str, tuple[str, ...]],
              dist: Any = None) -> Plugin:
    module = sys.modules.get(module_name)
    file = getattr(module, "__file__", None)
    sha = hashlib.sha256(Path(file).read_bytes()).hexdigest() if file and Path(
        file).is_file() else None
    name = version = None
    if dist is not None:
        name, version = dist.metadata["Name"], dist.version
    elif source == "module":
        dists = importlib.metadata.packages_distributions().get(module_name.split(".")[0])
        if dists:
            try:
                name, version = dists[0], importlib.metadata.version(dists[0])
            except importlib.metadata.PackageNotFoundError:
                pass
    return Plugin(spec=spec, source=source, module=module_name,
                  names={k: tuple(v) for k, v in names.items() if v}, path=file,
                  sha256=sha, distribution=name, version=version)


def needed_by(records: Sequence[Mapping[str, Any]]) -> str:
    """The plugins of stored records (`Plugin.record`) in words, with versions or digests."""
    def one(p: Mapping[str, Any]) -> str:
        at = (f"{p['distribution']} {p['version']}" if p.get("version")
              else f"sha256 {p['sha256'][:12]}" if p.get("sha256") else "no version")
        return f"{p['spec']} ({at})"

    return ", ".join(one(p) for p in records)
